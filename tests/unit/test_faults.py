"""The fault library (issue 12): defect kinds, their lines, the machine baseline, synthesis of any line set.

Oracles are independent of the code under test: the CWRU 6205 fault multipliers (published), the kinematic
structure of each kind's lines, and a textbook envelope analysis written here (band-pass at the strongest resonance
band, Hilbert envelope, envelope spectrum; Randall & Antoni, MSSP 25, 2011), never bkabem's own features.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from bkabem_core.bearing.deep_groove import Bearing, BearingGeometry, Dent
from bkabem_core.excitation.lines import LineSet, union
from bkabem_core.excitation.quasi_static import quasi_static_excitation
from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.synthesizer import Synthesizer

INCH = 25.4e-3
FS = 51200.0


def cwru_6205(**kw) -> BearingGeometry:
    """CWRU drive-end SKF 6205-2RS: 9 balls, d = 0.3126 in, D = 1.537 in, alpha = 0 (CWRU's bearing page)."""
    return BearingGeometry("6205", 0.3126 * INCH, 1.537 * INCH, 9, diametral_clearance_m=15e-6, **kw)


def test_cwru_multipliers_are_the_oracle():
    fm = Bearing(cwru_6205()).fault_multipliers()
    assert fm.bpfi == pytest.approx(5.4152, abs=2e-4)
    assert fm.bpfo == pytest.approx(3.5848, abs=2e-4)
    assert fm.bsf == pytest.approx(2.3567, abs=2e-4)
    assert fm.ftf == pytest.approx(0.39828, abs=5e-5)          # CWRU: FTF 0.39828 but BPFO / 9 = 0.39831


def _lines(kind: str, geometry=None, **dent):
    g = geometry or cwru_6205()
    d = Dent(length_m=dent.get("length_m", 1.0e-3), depth_m=dent.get("depth_m", 30e-6),
             angle_rad=dent.get("angle_rad", -math.pi / 2 if kind == "outer" else 0.0), race=kind,
             ball_index=dent.get("ball_index", 0))
    b = Bearing(g, defects=[d])
    ex = quasi_static_excitation(b, 400.0, 0.0, 1024, 1e-3, 30)
    return b, ex, ex.line_set()


def _largest(ls: LineSet, n: int):
    a = np.abs(ls.amplitude).max(axis=1)
    return np.argsort(a)[::-1][:n], a


@pytest.mark.parametrize("kind", ["outer", "inner", "ball"])
def test_each_kind_has_its_textbook_lines(kind):
    """Largest lines of each kind at the CWRU multipliers: BPFO comb; BPFI with +- 1x sidebands; 2 x BSF with
    +- FTF sidebands (and the 1x / FTF modulation line of the load zone)."""
    b, ex, ls = _lines(kind)
    fm = b.fault_multipliers()
    nu = ls.multipliers
    idx, amp = _largest(ls, 6)
    if kind == "outer":
        assert np.allclose(nu / fm.bpfo, np.round(nu / fm.bpfo), atol=1e-12)          # only BPFO orders
        assert np.isclose(nu[idx[0]], fm.bpfo) or np.isclose(nu[idx[0]] / fm.bpfo, round(nu[idx[0]] / fm.bpfo))
        return
    if kind == "inner":
        fault, side = fm.bpfi, 1.0
    else:
        fault, side = 2.0 * fm.bsf, fm.ftf
    near = lambda f: np.flatnonzero(np.isclose(nu, f, rtol=0, atol=1e-9))
    main = near(fault)
    assert main.size == 1 and amp[main[0]] >= 0.3 * amp.max()                       # the fault line is big
    lo, hi = near(fault - side), near(fault + side)
    assert lo.size == 1 and hi.size == 1                                               # sidebands at +- spacing
    assert amp[lo[0]] > 0.1 * amp[main[0]] and amp[hi[0]] > 0.1 * amp[main[0]]
    # every line is an integer combination of the kind's phases: m BPFO + n (inner), m BSF + n FTF (ball)
    c = ls.coefficients
    if kind == "inner":
        assert np.all(c[:, 2] == 0) and np.all(c[:, 1] % b.geometry.n_balls == 0)
    else:
        assert np.all(c[:, 0] == 0)
    # the harmonic comb of the fault frequency is there too
    assert near(2 * fault).size == 1 and amp[near(2 * fault)[0]] > 0.1 * amp[main[0]]


def test_outer_race_and_healthy_are_exactly_bpfo_orders():
    """No 2-D grid for them: the line set is the excitation's BPFO orders, bit for bit."""
    for depth in (0.0, 30e-6):
        b, ex, ls = _lines("outer", depth_m=depth)
        assert ex.lines is None
        assert np.array_equal(ls.coefficients[:, 1], ex.orders * 9)
        assert np.array_equal(ls.amplitude, ex.complex_amplitude_m())
    healthy = quasi_static_excitation(Bearing(cwru_6205()), 400.0, 0.0, 1024, 1e-3, 30)
    assert healthy.lines is None and len(healthy.line_set()) == len(healthy.orders)


def test_inner_race_lines_converge_with_the_grid():
    """The 2-torus sampling: twice the samples along both angles moves the largest lines by < 1 %."""
    g = cwru_6205()
    b = Bearing(g, defects=[Dent(1.0e-3, 30e-6, 0.0, race="inner")])
    coarse = quasi_static_excitation(b, 400.0, 0.0, 1024, 1e-3, 30).line_set()           # default: 64 slow
    fine = quasi_static_excitation(b, 400.0, 0.0, 2048, 1e-3, 30, n_slow=128).line_set()
    idx, amp = _largest(fine, 10)
    on = coarse.on(fine.coefficients[idx])
    rel = np.abs(on.amplitude - fine.amplitude[idx]).max(axis=1) / amp[idx]
    assert rel.max() < 0.01, rel


def test_several_defects_superpose_inside_the_bearing():
    """Two outer-race dents in one bearing: one quasi-static solution with both (not the sum of two)."""
    g = cwru_6205()
    d1 = Dent(1.0e-3, 30e-6, -math.pi / 2)
    d2 = Dent(1.0e-3, 30e-6, -math.pi / 2 + 0.7 * 2 * math.pi / 9)
    both = quasi_static_excitation(Bearing(g, defects=[d1, d2]), 400.0, 0.0, 1024, 1e-3, 30)
    one = quasi_static_excitation(Bearing(g, d1), 400.0, 0.0, 1024, 1e-3, 30)
    two = quasi_static_excitation(Bearing(g, d2), 400.0, 0.0, 1024, 1e-3, 30)
    assert both.relative_displacement_m.min() < min(one.relative_displacement_m.min(),
                                                    two.relative_displacement_m.min()) + 1e-12
    # the path with both is the one with either where the other is not under a ball
    assert np.allclose(both.relative_displacement_m, one.relative_displacement_m + two.relative_displacement_m
                       - quasi_static_excitation(Bearing(g), 400.0, 0.0, 1024, 1e-3, 30).relative_displacement_m,
                       atol=2e-9)


def test_union_of_line_sets_keeps_speed_powers_apart():
    rates = np.array([1.0, 0.4, 2.3, 0.0])
    a = LineSet([[1, 0, 0, 0], [0, 9, 0, 0]], [[1.0], [2.0]], ("x",), rates)
    b = LineSet([[1, 0, 0, 0], [0, 9, 0, 0]], [[10.0], [20.0]], ("x",), rates, speed_power=[2, 0])
    u = union([a, b])
    assert len(u) == 3
    assert np.allclose(sorted(np.abs(u.amplitude[:, 0])), [1.0, 10.0, 22.0])


# --------------------------------------------------------------------------- machine, identity
REF = Path(__file__).resolve().parents[1] / "fixtures" / "outer_race_main_a6a1bf7.npz"


def test_identity_with_the_outer_race_results_of_main(model):
    """The embedded case through the new line machinery reproduces main's BKA-BEM (commit a6a1bf7, before the
    fault library): same orders, the same excitation bit for bit, the same response at three speeds to the
    round-off of the reduced model's factorisation (the basis made plane by plane and the line pencils in their
    real form, issue 12: 1e-10 of each channel's largest; the reduced model itself is 1e-6 from the full FE)."""
    ref = np.load(REF)
    m = model                                   # BkaBem(Case.load()), made once (tests/conftest.py)
    assert np.array_equal(m.orders, ref["orders"]) and m.is_order_set
    # the same excitation to the Newton tolerance of its path (1e-15 m, excitation.path): numpy's sums and linear
    # algebra differ from release to release in the last bits, and the iteration stops at another point within it
    for b in ("de", "nde"):
        np.testing.assert_allclose(m.excitations[b].complex_amplitude_m(), ref[f"{b}_amp"], rtol=0, atol=1e-15)
    x = m.response(ref["speeds"])
    scale = np.abs(ref["response"]).max(axis=1, keepdims=True)
    assert np.max(np.abs(x - ref["response"]) / scale) < 1e-9
    # components that are zero by symmetry: to the static equilibrium's tolerance (1e-9 of the load: ~1e-14 m)
    assert np.allclose(m.dc_m, ref["dc"], rtol=1e-13, atol=1e-14)


@pytest.fixture(scope="module")
def models(fault_library):
    return fault_library


def test_baseline_adds_its_lines_without_touching_the_bearing_lines(models):
    """Superposition: the G 2.5 machine's BPFO lines are the bare machine's (linear FE), plus a 1x line."""
    bare = BkaBem(Case.load().with_overrides({"excitation.max_order": 0}))     # the library's lines: no order cap
    m = models["outer"]
    assert m.lines.keys()[0] == (1, 0, 0, 0, 0, 0) and not m.is_order_set
    pure = m.orders > 0
    x, y = m.response([25.0])[0][pure], bare.response([25.0])[0]
    assert np.max(np.abs(x - y)) <= 1e-9 * np.abs(y).max()


def test_unbalance_force_follows_iso_21940(models):
    """G 2.5 at the case's 75 Hz: e = G / Omega_max; the 1x force grows with the square of the speed."""
    m = models["healthy"]
    case = m.case
    e = 2.5e-3 / (2 * math.pi * case.max_speed_hz)
    mass = sum(d["mass_kg"] for d in case.raw["rotor"]["disks"])
    i = m.lines.keys().index((1, 0, 0, 0, 0, 0))
    col = m.input_names.index("unbalance.x")
    force_25 = abs(m._force_a[i, col]) * mass * 25.0 ** 2
    assert force_25 == pytest.approx(mass * e * (2 * math.pi * 25.0) ** 2, rel=1e-12)
    # the response against a dense solve of the full FE written here: disk forces m e Omega^2, rotating
    rot = m.rotor
    for f_hz in (12.0, 24.0):
        w = 2 * math.pi * f_hz
        force = np.zeros(rot.ndof, complex)
        for d in case.raw["rotor"]["disks"]:
            force[rot.dof_index(d["node"], "x")] += d["mass_kg"] * e * w * w
            force[rot.dof_index(d["node"], "y")] += -1j * d["mass_kg"] * e * w * w
        z = rot.K - w * w * rot.M + 1j * w * (rot.C + w * rot.G)
        x = np.linalg.solve(z, force)
        mine = m.response([f_hz])[0][i]                                             # (4 locations, 2 directions)
        ref = np.array([[x[rot.dof_index(node, "y")], x[rot.dof_index(node, "x")]]
                        for node in (m.machine.sites["de"].rotor_node, m.machine.sites["de"].housing_node,
                                     m.machine.sites["nde"].rotor_node, m.machine.sites["nde"].housing_node)])
        assert np.max(np.abs(mine - ref)) < 1e-4 * np.abs(ref).max()


def test_healthy_machine_at_25_hz_looks_healthy(models):
    """1x is the largest line of every housing acceleration; ISO 10816 velocity in zone A/B (class I, < 1.8
    mm/s RMS) computed here from the lines in 10-1000 Hz."""
    m = models["healthy"]
    sp = m.spectrum(25.0)
    i1 = m.lines.keys().index((1, 0, 0, 0, 0, 0))
    for li in (1, 3):
        for di in (0, 1):
            a = np.abs(sp.acceleration[:, li, di])
            assert np.argmax(a) == i1
            band = (sp.frequency_hz >= 10) & (sp.frequency_hz <= 1000)
            v_rms = np.sqrt(0.5 * np.sum(np.abs(sp.velocity[band, li, di]) ** 2)) * 1e3
            assert v_rms < 1.8


# --------------------------------------------------------------------------- envelope analysis
def _envelope_fault(x: np.ndarray, fs: float, candidates: dict, f_r: float):
    """Textbook envelope analysis: the strongest resonance band above 1 kHz (Welch PSD, 1 kHz bands), 4th-order
    Butterworth band-pass, Hilbert envelope, squared, its spectrum; each candidate fault frequency's peak (the
    largest bin within 1 % and its first two harmonics) against the median floor of the envelope spectrum around
    it. Returns (name of the strongest candidate, its peak-to-floor ratio, all ratios)."""
    f, pxx = signal.welch(x, fs, nperseg=4096)
    edges = np.arange(1000.0, 0.4 * fs, 500.0)
    energy = [pxx[(f >= lo) & (f < lo + 1000.0)].sum() for lo in edges]
    lo = edges[int(np.argmax(energy))]
    sos = signal.butter(4, [lo, lo + 1000.0], btype="bandpass", fs=fs, output="sos")
    env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x))) ** 2
    env -= env.mean()
    spec = np.abs(np.fft.rfft(env * np.hanning(env.size)))
    fr = np.fft.rfftfreq(env.size, 1.0 / fs)
    ratios = {}
    tol = 1.5 * (fr[1] - fr[0])
    for name, fc in candidates.items():
        peaks, floors = [], []
        for h in (1, 2):
            sel = np.abs(fr - h * fc) <= max(0.01 * h * fc, tol)
            around = (fr > h * fc - 0.4 * f_r) & (fr < h * fc + 0.4 * f_r) & ~sel
            peaks.append(spec[sel].max())
            floors.append(np.median(spec[around]))
        ratios[name] = float(np.mean(peaks) / np.mean(floors))
    best = max(ratios, key=ratios.get)
    return best, ratios[best], ratios


def _run(model, speed, seconds=2.0, seed=3):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.25, quantities=("acceleration",), slip=0.01, seed=seed,
                    noise_density={"acceleration": 2e-4}, band_limit="taper", features=False)
    x = np.concatenate([s.next_chunk(speed).channel("de_vertical_acceleration") for _ in range(int(seconds / 0.25))])
    return x.astype(float)


def _diagnose(ratios: dict, stands_out: float = 4.0):
    """The textbook reading of an envelope spectrum: a ball defect shows 2 x BSF modulated by the cage (FTF and
    its harmonics stand out, the 14th of which is BPFO); an inner race BPFI; an outer race BPFO without FTF."""
    out = {k for k, v in ratios.items() if v > stands_out}
    if {"ftf", "2bsf"} <= out:
        return "ball"
    if "bpfi" in out and ratios["bpfi"] >= ratios["bpfo"]:
        return "inner"
    if "bpfo" in out:
        return "outer"
    return None


@pytest.mark.parametrize("kind", ["outer", "inner", "ball", "healthy"])
def test_envelope_analysis_names_the_fault(models, classic_ball, kind):
    """At three speeds the envelope spectrum (1 % slip, sensor noise) names the right fault, and none for the
    healthy machine: no candidate stands 4x above its floor. The ball's pit is kept on the track (a wandering pit
    strikes only now and then: tests/unit/test_balltrack.py)."""
    m = classic_ball if kind == "ball" else models[kind]
    fm = m.fault_multipliers
    for speed in (15.0, 25.0, 35.0):
        cand = {"bpfo": fm.bpfo * speed, "bpfi": fm.bpfi * speed, "2bsf": 2 * fm.bsf * speed,
                "ftf": fm.ftf * speed}
        _, _, ratios = _envelope_fault(_run(m, speed), FS, cand, speed)
        assert _diagnose(ratios) == (None if kind == "healthy" else kind), (speed, ratios)


def test_any_line_set_synthesis_is_the_line_spectrum(models):
    """A steady run of the inner-race machine (carrier families, unbalance, sidebands): its FFT at each of the
    ten largest lines is the synthesiser's own line amplitude, and a chunk border anywhere gives the same
    samples (to float32 rounding: the families' phases are recomputed in double at every knot)."""
    m = models["inner"]
    # every strike alike (the line spectrum's lines as they are; random strike strengths: tests/unit/test_strikes.py)
    # and no floor under them (the library's faulty bearing rolls 15 dB rougher: its floor would move a flattop bin
    # by ~2 %; the floor: tests/unit/test_floor.py)
    s = Synthesizer(m, sample_rate_hz=FS, chunk_s=0.5, quantities=("acceleration",), features=False, strikes=False,
                    broadband_floor=False)
    speed = 24.0
    x = np.concatenate([s.next_chunk(speed).channel("de_vertical_acceleration") for _ in range(8)]).astype(float)
    ls = s.line_spectrum(speed)
    ci = s.channel_names.index("de_vertical_acceleration")
    a = np.abs(ls["amplitude"][:, ci])
    win = signal.windows.flattop(x.size)                       # amplitude-true to ~0.01 dB between bins
    spec = 2 * np.abs(np.fft.rfft(x * win)) / win.sum()
    for j in np.argsort(a)[::-1][:10]:
        b = int(round(ls["frequency_hz"][j] * x.size / FS))
        assert spec[b - 2:b + 3].max() == pytest.approx(a[j], rel=0.01)
    s2 = Synthesizer(m, sample_rate_hz=FS, chunk_s=0.5, quantities=("acceleration",), features=False,
                     strikes=False, broadband_floor=False)
    y = np.concatenate([s2.next_chunk(speed, n).channel("de_vertical_acceleration")
                        for n in (7000, 25600 - 7000, 25600 * 7)])
    assert np.max(np.abs(x - y)) <= 1e-6 * np.abs(x).max()


def test_slip_moves_cage_lines_only(models):
    """Random slip perturbs the cage and spin phases: the inner-race machine's 1x unbalance line keeps its
    amplitude to < 1 % while the BPFI lines smear."""
    m = models["inner"]
    speed = 24.0

    def spectrum(slip):
        s = Synthesizer(m, sample_rate_hz=FS, chunk_s=0.5, quantities=("acceleration",), features=False,
                        slip=slip, seed=1)
        x = np.concatenate([s.next_chunk(speed).channel("de_vertical_acceleration") for _ in range(4)])
        return 2 * np.abs(np.fft.rfft(x.astype(float))) / x.size

    clean, slipped = spectrum(0.0), spectrum(0.02)
    b1 = int(round(speed * 2.0))
    assert slipped[b1] == pytest.approx(clean[b1], rel=0.01)
    bi = int(round(m.fault_multipliers.bpfi * 3 * speed * 2.0))
    assert slipped[bi - 1:bi + 2].max() < 0.7 * clean[bi - 1:bi + 2].max()


# --------------------------------------------------------------------------- TDSM per kind


def test_set_model_swaps_between_any_line_sets(models):
    """healthy -> outer race -> inner race, each swap at a chunk border: phase continuous (no jump beyond the
    signal's own sample-to-sample change), and each steady part is its own model's line spectrum."""
    fs = FS
    s = Synthesizer(models["healthy"], sample_rate_hz=fs, chunk_s=0.25, quantities=("acceleration",),
                    features=True, broadband_floor=False)       # the lines alone (the floor: tests/unit/test_floor.py)
    parts = [s.next_chunk(25.0) for _ in range(2)]
    s.set_model(models["outer"])
    parts += [s.next_chunk(25.0) for _ in range(3)]
    s.set_model(models["inner"])
    parts += [s.next_chunk(25.0) for _ in range(3)]
    x = np.concatenate([c.channel("de_vertical_acceleration") for c in parts]).astype(float)
    assert np.all(np.isfinite(x))
    step = np.abs(np.diff(x))
    n = parts[0].n_samples
    for border in (2 * n, 5 * n):                                  # the swaps: no step beyond the usual ones
        assert step[border - 1] <= 1.5 * step[border - 200:border + 200].max() + 1e-12
    assert [c.first_sample_index for c in parts] == [i * n for i in range(8)]
    tail = x[-2 * n:]                                              # the last 0.5 s: the inner-race machine alone
    ls = s.line_spectrum(25.0)
    a = np.abs(ls["amplitude"][:, 0])
    j = int(np.argmax(a))
    win = signal.windows.flattop(tail.size)
    spec = 2 * np.abs(np.fft.rfft(tail * win)) / win.sum()
    b = int(round(ls["frequency_hz"][j] * tail.size / fs))
    assert spec[b - 2:b + 3].max() == pytest.approx(a[j], rel=0.02)


def test_misalignment_and_electrical_lines(cached_model):
    """2x misalignment at the coupling node and the 2 x line frequency magnetic pull on the core: their lines,
    the electrical one at 100 Hz whatever the speed (solved per speed: no fixed pencil), both against a dense
    solve of the full FE with the forces written here."""
    case = Case.load("motor_6010_healthy").with_overrides({"baseline.misalignment_force_n": 40.0,
                                                           "baseline.electrical_force_n": 25.0})
    m = cached_model(case)
    keys = m.lines.keys()
    i2, ie = keys.index((2, 0, 0, 0, 0, 0)), keys.index((0, 0, 0, 0, 0, 2))
    rot = m.rotor
    core = [d for d in case.raw["rotor"]["disks"] if d["name"].startswith("core")]
    mass = sum(d["mass_kg"] for d in core)
    nodes = [m.machine.sites[b].rotor_node for b in ("de", "nde")] + [m.machine.sites[b].housing_node
                                                                      for b in ("de", "nde")]
    order = [nodes[0], nodes[2], nodes[1], nodes[3]]                  # de rotor, de housing, nde rotor, nde housing
    for f_hz in (17.0, 31.0):
        sp = m.spectrum(f_hz)
        assert sp.frequency_hz[i2] == pytest.approx(2 * f_hz) and sp.frequency_hz[ie] == pytest.approx(100.0)
        for i, w, force in ((i2, 2 * math.pi * 2 * f_hz, None), (ie, 2 * math.pi * 100.0, None)):
            fvec = np.zeros(rot.ndof, complex)
            if i == i2:
                fvec[rot.dof_index(1, "x")] = 40.0
                fvec[rot.dof_index(1, "y")] = -40j
            else:
                for d in core:
                    fvec[rot.dof_index(d["node"], "y")] += 25.0 * d["mass_kg"] / mass
            big = 2 * math.pi * f_hz
            x = np.linalg.solve(rot.K - w * w * rot.M + 1j * w * (rot.C + big * rot.G), fvec)
            ref = np.array([[x[rot.dof_index(n, "y")], x[rot.dof_index(n, "x")]] for n in order])
            assert np.max(np.abs(sp.displacement[i] - ref)) < 1e-4 * np.abs(ref).max()
    s = Synthesizer(m, sample_rate_hz=12800.0, chunk_s=0.5, quantities=("acceleration",), features=False)
    ls = [s.line_spectrum(f) for f in (17.0, 31.0)]
    assert all(np.isclose(x["frequency_hz"][ie], 100.0) for x in ls)
    x = np.concatenate([s.next_chunk(31.0).channel("de_vertical_acceleration") for _ in range(4)]).astype(float)
    win = signal.windows.flattop(x.size)
    spec = 2 * np.abs(np.fft.rfft(x * win)) / win.sum()
    b = int(round(100.0 * x.size / 12800.0))
    assert spec[b - 2:b + 3].max() == pytest.approx(abs(ls[1]["amplitude"][ie, 0]), rel=0.02)


def test_like_reuses_the_machine_for_a_growing_defect(models, cached_model):
    """A deeper inner-race dent (a scenario's growth step) built ``like=`` the existing model: the FE, basis and
    the decompositions of the lines both share are reused (new lines, if any, decomposed), and the spectrum is the one
    of a model built from scratch."""
    base = models["inner"]
    case = base.case.with_overrides({"defects.0.depth_m": 80e-6})
    import time
    t0 = time.perf_counter()
    grown = BkaBem(case, like=base)
    t_like = time.perf_counter() - t0
    fresh = cached_model(case)                  # BkaBem(case), made once
    assert grown._basis is base._basis
    assert grown.lines.keys() == fresh.lines.keys()
    x, y = grown.response([23.0])[0], fresh.response([23.0])[0]
    assert np.max(np.abs(x - y)) <= 1e-10 * np.abs(y).max()
    shared = len(set(np.round(grown.multipliers, 12)) & set(np.round(base.multipliers, 12)))
    assert shared > 0.5 * len(grown.lines)
    assert t_like < fresh.preparation_time_s["total"]


def test_line_modes_extended_reuses_and_adds(model):
    from bkabem_core.fe.modal import LineModes

    basis = model.basis
    lm = LineModes(basis, np.array([1.0, 2.5, 7.0]))
    ext = lm.extended(np.array([7.0, 0.43, 1.0]))
    ref = LineModes(basis, np.array([7.0, 0.43, 1.0]))
    assert np.array_equal(ext.poles[0], lm.poles[2]) and np.array_equal(ext.poles[2], lm.poles[0])
    for f in (5.0, 40.0):
        assert np.allclose(ext.receptance(f), ref.receptance(f), rtol=1e-9, atol=1e-18)


def test_prepare_makes_the_speed_cells_of_any_line_set(models):
    s = Synthesizer(models["healthy"], sample_rate_hz=FS)
    s.prepare()
    assert s.spectrum_method == "modal"
    assert len(s._plan.spectrum.cells) == len(range(int(models["healthy"].case.max_speed_hz // 0.5) + 1))
    a = s.line_spectrum(25.0)["amplitude"]
    exact = Synthesizer(models["healthy"], sample_rate_hz=FS, spectrum="exact").line_spectrum(25.0)["amplitude"]
    assert np.max(np.abs(a - exact)) <= 1e-5 * np.abs(exact).max()
