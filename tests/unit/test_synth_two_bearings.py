"""The synthesiser on a machine whose two bearings have kinematics of their own: the CWRU rig's types, a 6205 at the
drive end with an outer-race dent and a 6203 at the non-drive end with an inner-race dent (the embedded machine
otherwise, tests/case_files.py).

Each bearing's lines turn with its own cage and spin and slip with its own walk; a machine of one bearing type keeps
the one walk of earlier versions. The diagnostics are textbook ones written here: band-pass (4th-order Butterworth,
2-8 kHz, forwards and backwards), Hilbert envelope, squared, its spectrum (Hann window), peak search against the
median floor around the line; complex demodulation of the envelope for a line's phase; computed order tracking
(the envelope resampled at even shaft angle) under a ramp. The expected fault frequencies are the ones CWRU
publishes for its rig's bearings (independent of the bearing model; within 0.05 % of the catalogue geometry's).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from case_files import textbook_multipliers, two_bearing_text
from scipy import signal

from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.randomness import SlipWalk, SlipWalks
from bkabem_core.synth.synthesizer import Synthesizer

FS = 25600.0
SPEED_HZ = 29.95                         # 1797 rpm, the CWRU rig at 0 hp
#: CWRU's published fault multipliers [Hz per shaft Hz]: drive end 6205, fan end 6203
CWRU = {"de": {"bpfi": 5.4152, "bpfo": 3.5848, "ftf": 0.39828, "bsf": 2.3567},
        "nde": {"bpfi": 4.9469, "bpfo": 3.0530, "ftf": 0.3817, "bsf": 1.9937}}
BAND_HZ = (2000.0, 8000.0)


def _cwru_text(nde_race: str = "inner") -> str:
    """The two-bearing machine with the NDE's dent on ``nde_race`` (1 mm x 20 um; the DE's 2 mm x 50 um outer)."""
    race = f'race = "{nde_race}"' + ("\nball = 1" if nde_race == "ball" else "")
    return two_bearing_text().replace('bearing = "nde"\nrace = "outer"', f'bearing = "nde"\n{race}')


@pytest.fixture(scope="module")
def cwru(cached_model) -> BkaBem:
    case = Case.from_toml(_cwru_text(), "cwru.toml")
    assert [(d.bearing, d.race) for d in case.defects()] == [("de", "outer"), ("nde", "inner")]
    return cached_model(case)


def _synth(model, **kw) -> Synthesizer:
    """Every strike alike: these tests read where each bearing's lines are, not the strikes' random strength."""
    return Synthesizer(model, sample_rate_hz=FS, quantities=("acceleration",), measurement=False, features=False,
                       strikes=False, **kw)


def _render(synth, profile: str, seconds: float) -> np.ndarray:
    return np.concatenate([c.samples for c in synth.render(profile, seconds)], axis=1).astype(float)


def _squared_envelope(x: np.ndarray) -> np.ndarray:
    """Band-pass (Butterworth, 4th order, forwards and backwards), analytic signal, |.|^2, mean removed."""
    sos = signal.butter(4, BAND_HZ, btype="bandpass", fs=FS, output="sos")
    e = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x - x.mean()))) ** 2
    return e - e.mean()


def _over_floor(spec: np.ndarray, axis: np.ndarray, at: float, span: float) -> float:
    """The largest bin within 2.5 bins of ``at`` over the median of the bins within ``span`` of it (the line's own
    bins left out)."""
    step = axis[1] - axis[0]
    near = np.abs(axis - at)
    return float(spec[near <= 2.5 * step].max() / np.median(spec[(near > 4 * step) & (near < span)]))


# --------------------------------------------------------------------------- each bearing's lines at its own rates
def test_each_channel_shows_its_own_bearings_fault_frequency(cwru):
    """Steady 29.95 Hz, 4 s: the DE housing's squared envelope peaks at the 6205's BPFO and holds nothing at the
    6203's; the NDE housing's at the 6203's BPFI, not at the 6205's (where the NDE's inner-race lines would be on
    the DE's cage) nor at the 6203's BPFO. An NDE line written on the DE's cage would move every NDE peak here."""
    s = _synth(cwru)
    x = _render(s, f"constant:{SPEED_HZ}", 4.0)
    f = {b: {k: v * SPEED_HZ for k, v in kin.items()} for b, kin in CWRU.items()}
    res = FS / x.shape[1]
    seen = {}
    for b in ("de", "nde"):
        e = _squared_envelope(x[s.channel_names.index(f"{b}_vertical_acceleration")])
        spec = np.abs(np.fft.rfft(e * np.hanning(e.size)))
        fr = np.fft.rfftfreq(e.size, 1.0 / FS)
        band = (fr > 60.0) & (fr < 200.0)
        seen[b] = float(fr[band][np.argmax(spec[band])])
        ratio = {(o, k): _over_floor(spec, fr, f[o][k], 0.3 * SPEED_HZ) for o in CWRU for k in ("bpfo", "bpfi")}
        if b == "de":
            assert ratio["de", "bpfo"] > 100.0, ratio
            assert ratio["nde", "bpfo"] < 0.1 * ratio["de", "bpfo"], ratio
        else:
            assert ratio["nde", "bpfi"] > 30.0, ratio
            assert ratio["de", "bpfi"] < 0.1 * ratio["nde", "bpfi"], ratio
            assert ratio["nde", "bpfo"] < 0.1 * ratio["nde", "bpfi"], ratio
    # the strongest envelope line of 60-200 Hz: each bearing's fault frequency (to the resolution, 0.25 Hz)
    assert abs(seen["de"] - f["de"]["bpfo"]) <= 1.5 * res, seen
    assert abs(seen["nde"] - f["nde"]["bpfi"]) <= 1.5 * res, seen


def test_a_ramp_keeps_each_bearings_lines_on_its_own_multiplier(cwru):
    """15 -> 30 Hz in 4 s. Computed order tracking (the squared envelope at even shaft angle, from the ramp's own
    angle integral written here): a sharp line at the 6205's BPFO order in the DE channel, at the 6203's BPFI order
    in the NDE channel (resolution 1/90 order); and each chunk's cage angle per bearing is the integral of the speed
    times that bearing's FTF (textbook, contact angle 0)."""
    f0, f1, t_end = 15.0, 30.0, 4.0
    s = _synth(cwru)
    chunks = list(s.render(f"ramp:{f0}:{f1}:{t_end}", t_end))
    x = np.concatenate([c.samples for c in chunks], axis=1).astype(float)

    def revs(t):
        return f0 * t + (f1 - f0) * t * t / (2 * t_end)

    for c in chunks:
        for b in ("de", "nde"):
            want = 2 * math.pi * revs(c.t0_s) * textbook_multipliers(cwru.case.bearing_table(b))["ftf"]
            assert abs(np.angle(np.exp(1j * (c.cage_angles_rad[b] - want)))) < 1e-8, (b, c.t0_s)
        assert c.cage_angle_rad == c.cage_angles_rad["de"]
    r = revs(np.arange(x.shape[1]) / FS)
    per_rev = 64
    grid = np.arange(0.5, r[-1] - 0.5, 1.0 / per_rev)
    for b, (own, kind), others in (("de", ("de", "bpfo"), (("nde", "bpfo"), ("nde", "bpfi"))),
                                   ("nde", ("nde", "bpfi"), (("de", "bpfi"), ("nde", "bpfo")))):
        e = np.interp(grid, r, _squared_envelope(x[s.channel_names.index(f"{b}_vertical_acceleration")]))
        e -= e.mean()
        spec = np.abs(np.fft.rfft(e * np.hanning(e.size)))
        orders = np.fft.rfftfreq(e.size, 1.0 / per_rev)
        band = (orders > 2.0) & (orders < 6.0)
        peak = float(orders[band][np.argmax(spec[band])])
        assert abs(peak - CWRU[own][kind]) <= 1.5 * orders[1], (b, peak)
        line = _over_floor(spec, orders, CWRU[own][kind], 0.3)
        assert line > 25.0, (b, line)
        for o, k in others:
            assert _over_floor(spec, orders, CWRU[o][k], 0.3) < 0.3 * line, (b, o, k)


def test_line_phases_put_each_bearings_lines_at_its_own_cage_angle(cwru):
    """The line spectrum turned by ``line_phases_rad`` of a chunk is that chunk (no slip): every line summed here
    at its frequency from the chunk's first sample reproduces the samples; the NDE's lines need the NDE's cage
    angle (with the DE's in its place they are off by the whole signal)."""
    s = Synthesizer(cwru, sample_rate_hz=FS, chunk_s=0.0371, measurement=False, features=False, strikes=False)
    for _ in range(3):
        chunk = s.next_chunk(SPEED_HZ)
    ls = s.line_spectrum(SPEED_HZ)
    t = np.arange(chunk.n_samples) / FS
    x = chunk.samples.astype(float)
    scale = np.abs(x - ls["dc"][:, None]).max(axis=1)

    def rebuilt(phases):
        z = np.exp(1j * (phases[:, None] + 2 * np.pi * ls["frequency_hz"][:, None] * t[None, :]))
        return ls["dc"][:, None] + np.real(ls["amplitude"].T @ z)

    assert chunk.cage_angles_rad["de"] != pytest.approx(chunk.cage_angles_rad["nde"], abs=0.1)
    assert (np.abs(rebuilt(s.line_phases_rad(chunk)) - x).max(axis=1) < 5e-4 * scale).all()
    chunk.cage_angles_rad = {"de": chunk.cage_angle_rad, "nde": chunk.cage_angle_rad}
    assert (np.abs(rebuilt(s.line_phases_rad(chunk)) - x).max(axis=1) > 0.1 * scale).all()


# --------------------------------------------------------------------------- each bearing's own slip
def _line_phase(e: np.ndarray, f_hz: float, step_s: float = 0.1) -> np.ndarray:
    """The phase [rad] of the envelope's line at ``f_hz``, every ``step_s``: complex demodulation, low-pass
    (Butterworth, 4 Hz, forwards and backwards), angle, unwrapped (ends dropped)."""
    z = e * np.exp(-2j * np.pi * f_hz * np.arange(e.size) / FS)
    sos = signal.butter(4, 4.0, fs=FS, output="sos")
    z = signal.sosfiltfilt(sos, z.real) + 1j * signal.sosfiltfilt(sos, z.imag)
    n = int(round(step_s * FS))
    return np.unwrap(np.angle(z[n // 2::n]))[2:-2]


def test_each_bearings_fault_line_slips_by_its_own_walk(cwru):
    """1 % slip, 8 s: the phases of the DE's BPFO line (DE envelope) and of the NDE's BPFI line (NDE envelope) each
    drift like a random walk of 1 % per own ball pass (the increments over 0.1 s: 2 pi 0.01 sqrt(passes in 0.1 s),
    about 0.8 of it behind the 4 Hz demodulation filter), and not together (their increments uncorrelated: one walk
    shared by both bearings would give a correlation near 1 in magnitude).
    Without slip the phases stay put (within 0.15 rad: the demodulation's leak of the neighbouring envelope lines)."""
    sigma = 0.01
    steps, spread = {}, {}
    for slip in (0.0, sigma):
        s = _synth(cwru, slip=slip, seed=5)
        x = _render(s, f"constant:{SPEED_HZ}", 8.0)
        for b, kind in (("de", "bpfo"), ("nde", "bpfi")):
            e = _squared_envelope(x[s.channel_names.index(f"{b}_vertical_acceleration")])
            phase = _line_phase(e, getattr(s.bearing_multipliers[b].at_speed(SPEED_HZ), kind))
            steps[b, slip], spread[b, slip] = np.diff(phase), float(np.ptp(phase))
    for b in ("de", "nde"):
        passes = CWRU[b]["bpfo"] * SPEED_HZ * 0.1
        expect = 2 * math.pi * sigma * math.sqrt(passes)
        got = float(np.std(steps[b, sigma]))
        assert 0.5 * expect < got < 1.3 * expect, (b, got, expect)
        assert float(np.std(steps[b, 0.0])) < 0.3 * expect and spread[b, 0.0] < 0.15, (b, spread)
        assert spread[b, sigma] > 0.5, (b, spread)
    assert abs(np.corrcoef(steps["de", sigma], steps["nde", sigma])[0, 1]) < 0.4


def test_each_bearing_has_a_walk_of_its_own_and_the_de_keeps_the_runs_walk():
    """The DE's walk is the one walk of a machine of one bearing type (blocks of ``SeedSequence([seed, tag,
    block])``, rebuilt here); the NDE's is seeded by the seed and its name, of the same law and independent."""
    walks = SlipWalks(0.01, seed=3)
    n = SlipWalk.BLOCK
    de, nde = walks.bearing("de").values(0, n - 1), walks.bearing("nde").values(0, n - 1)
    eps = 0.01 * np.random.default_rng(np.random.SeedSequence([3, SlipWalk._TAG, 0])).standard_normal(n)
    np.testing.assert_array_equal(de, np.concatenate([[0.0], np.cumsum(eps[:-1])]))
    np.testing.assert_array_equal(de, SlipWalk(0.01, seed=3).values(0, n - 1))
    dd, dn = np.diff(de), np.diff(nde)
    assert abs(dn.std() / 0.01 - 1) < 0.03
    assert abs(np.corrcoef(dd, dn)[0, 1]) < 0.05
    assert not np.array_equal(nde, SlipWalks(0.01, seed=4).bearing("nde").values(0, n - 1))


def test_the_nde_walk_steps_in_its_own_ball_passes(cwru):
    """The walks step once per ball pass of the DE (the stream's clock); the NDE's families move
    ``sqrt(BPFO_nde / BPFO_de)`` times their own ``(p_cage + p_spin BSF/FTF) / z`` per step, so that the variance
    of an NDE phase per NDE ball pass is that of the DE's per DE pass (sigma^2, kappa = 1 for a ball pass). Each
    family's phase is on its own bearing's columns."""
    fams = _synth(cwru, slip=0.01)._plan.lines.families.families
    z = {b: cwru.case.bearing_geometry(b).n_balls for b in ("de", "nde")}
    tb = {b: textbook_multipliers(cwru.case.bearing_table(b)) for b in ("de", "nde")}
    by_phase = {f.p: f for f in fams}
    de_pass, nde_inner = (0, z["de"], 0, 0, 0, 0), (z["nde"], 0, 0, -z["nde"], 0, 0)
    assert {de_pass, nde_inner} <= set(by_phase)
    assert by_phase[de_pass].bearing_p == "de" and by_phase[de_pass].kappa_p == 1.0
    f = by_phase[nde_inner]                              # BPFI: one turn against the cage per ball pass
    assert f.bearing_p == "nde" and f.kappa_p < 0
    assert f.kappa_p ** 2 * tb["de"]["bpfo"] == pytest.approx(tb["nde"]["bpfo"], rel=1e-12)
    assert f.rate_p == pytest.approx(z["nde"] * (1.0 - tb["nde"]["ftf"]), rel=1e-12)
    scale = math.sqrt(tb["nde"]["bpfo"] / tb["de"]["bpfo"])
    for f in fams:
        for v, own, kappa in ((f.p, f.bearing_p, f.kappa_p), (f.q, f.bearing_q, f.kappa_q)):
            assert not (any(v[1:3]) and any(v[3:5]))     # no phase reads both bearings' columns
            cage, spin = (1, 2) if own != "nde" else (3, 4)
            b = own or "de"
            plain = (v[cage] + v[spin] * tb[b]["bsf"] / tb[b]["ftf"]) / z[b]
            assert kappa == pytest.approx(plain * (scale if own == "nde" else 1.0), rel=1e-9, abs=1e-12)
    kernel = _synth(cwru, slip=0.01)._plan.lines_kernel
    assert kernel.walk_sources == (("de", None), ("nde", None))


def test_one_bearing_type_keeps_one_walk(model, fault_library):
    """A machine of one bearing type (the 6010 at both ends): every line on the DE's columns, the kernels read
    the run's one walk (and the spin walk of a ball defect with it), and the stream makes no other."""
    assert model.phases.shared
    for m, want in ((model, (("de", None),)), (fault_library["ball"], (("de", None), ("de", 0.02)))):
        s = Synthesizer(m, sample_rate_hz=FS, slip=0.01, seed=2)
        assert s._plan.lines_kernel.walk_sources == want
        assert not s.coefficients[:, 3:5].any()
        s.next_chunk(25.0)
        s.next_chunk(25.5)
        assert set(s._stream.walk._walks) == {"de"}
    loop = Synthesizer(model, sample_rate_hz=FS, slip=0.01, seed=2, dtype=np.float64)
    loop.next_chunk(25.0)
    assert set(loop._stream.walk._walks) == {"de"}


def test_a_ball_defect_of_the_nde_is_gated_and_slips_on_the_nde(cwru, cached_model):
    """A ball defect in the 6203 (NDE): its track gates the lines on the NDE's spin and the NDE's cage orders
    (not the DE's 6205 lines), its steps are the NDE's cage revolutions counted in DE ball passes
    (BPFO_de / FTF_nde), and its spin slip reads the NDE's walk; the run renders through both kernel paths."""
    m = cached_model(Case.from_toml(_cwru_text("ball"), "cwru_ball.toml"))
    tb = {b: textbook_multipliers(m.case.bearing_table(b)) for b in ("de", "nde")}
    s = _synth(m, slip=0.0, seed=1)
    track = s._plan.track
    c, z = s.coefficients, m.case.bearing_geometry("nde").n_balls
    assert track.bearing == "nde" and track.spin_column == 4
    np.testing.assert_array_equal(track.gated, (c[:, 4] != 0) | (c[:, 3] % z != 0))
    assert track.gated.any() and not track.gated[c[:, 1:3].any(axis=1)].any()
    assert track.passes_per_step == pytest.approx(tb["de"]["bpfo"] / tb["nde"]["ftf"], rel=1e-12)
    assert s._plan.lines_kernel.walk_sources == (("nde", track.spin_slip),)
    x = _render(s, f"constant:{SPEED_HZ}", 0.5)
    y = _render(_synth(m, slip=0.0, seed=1, kernel="loop"), f"constant:{SPEED_HZ}", 0.5)
    assert np.all(np.isfinite(x)) and np.abs(x).max() > 0
    np.testing.assert_allclose(x, y, rtol=0, atol=64 * np.finfo(np.float32).eps * np.abs(x).max())
