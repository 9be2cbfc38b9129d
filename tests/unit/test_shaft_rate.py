"""Shaft-rate content of the machine baseline: the coupling's running-speed force (a 1x line on the FE and a load
that turns with the shaft in each bearing), the looseness comb and the electrical harmonics.

Every reference is written here from its textbook: the lever rule of a shaft on two supports, the quasi-static
equilibrium of the bearing under the load of each instant (a Newton iteration on the bearing's ball forces) and
its 2-D Fourier series, a dense solve of the FE with the forces written here, the squared envelope (band-pass,
Hilbert, |.|^2, FFT) and the Fourier series of a sawtooth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from case_files import embedded_text
from scipy import signal

from bkabem_core.bearing.deep_groove import Bearing
from bkabem_core.excitation.baseline import baseline_forces
from bkabem_core.excitation.quasi_static import quasi_static_excitation
from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case, CaseError
from bkabem_core.synth.synthesizer import Synthesizer

COUPLING_N = 30.0
FS = 25600.0


def _node_x(case: Case, node: int) -> float:
    return float(case.raw["rotor"]["node_positions_m"][node - 1])


def _lever_rule(case: Case, force: complex) -> dict:
    """Shares of a force at the coupling node carried by the two supports of a rigid shaft (moments about each
    support): ``R_de = F (x_nde - x_c) / (x_nde - x_de)``, ``R_nde = F (x_c - x_de) / (x_nde - x_de)``."""
    x_c = _node_x(case, case.raw["baseline"]["misalignment_node"])
    x_de = _node_x(case, case.raw["bearings"]["de"]["rotor_node"])
    x_nde = _node_x(case, case.raw["bearings"]["nde"]["rotor_node"])
    span = x_nde - x_de
    return {"de": force * (x_nde - x_c) / span, "nde": force * (x_c - x_de) / span}


@pytest.fixture(scope="module")
def coupled(cached_model):
    """motor_6010_outer with a 30 N coupling force and no unbalance (its 1x line alone): BkaBem."""
    case = Case.load("motor_6010_outer").with_overrides({"baseline.coupling_force_n": COUPLING_N,
                                                         "baseline.unbalance_grade_mm_s": 0.0})
    return cached_model(case)


# --------------------------------------------------------------------------- the coupling force: statics, 1x line
def test_each_bearing_carries_its_lever_rule_share_of_the_coupling_force():
    """Two bearings make the shaft statically determinate: the turning load of each is its lever-rule share of
    the coupling force (phase included), and the shares sum to the force (an overhung coupling: the near bearing
    carries more than the force, the far one is pulled the other way)."""
    case = Case.load("motor_6010_outer").with_overrides({"baseline.coupling_force_n": COUPLING_N,
                                                         "baseline.coupling_phase_deg": 40.0})
    force = COUPLING_N * np.exp(1j * math.radians(40.0))
    shares = _lever_rule(case, force)
    sites = Machine(case).sites
    for name in ("de", "nde"):
        assert sites[name].rotating_load_n == pytest.approx(shares[name], rel=1e-9, abs=1e-9)
    assert sum(s.rotating_load_n for s in sites.values()) == pytest.approx(force, rel=1e-9)
    assert abs(sites["de"].rotating_load_n) > COUPLING_N and sites["nde"].rotating_load_n.real < 0.0
    assert all(s.rotating_load_n == 0j for s in Machine(Case.load("motor_6010_outer")).sites.values())


def test_coupling_force_is_a_1x_line_with_its_statics_at_the_bearings(coupled, cached_model):
    """The 1x line of the coupling force on the healthy machine: at 25 Hz the dense FE solve of the force written
    here (rotating at the coupling node, (Re, Im)(F exp(i theta))); at 1 Hz (quasi-static) the force each bearing
    element transmits, k_b (rotor - housing) + i omega c_b (...), is its lever-rule share and the two sum to the
    force. With an outer-race dent the 1x line also holds the dent's own shaft order (the turning load sweeps the
    load over it once per turn): present, and small beside the force's."""
    m = cached_model(Case.load("motor_6010_healthy").with_overrides({"baseline.coupling_force_n": COUPLING_N,
                                                                     "baseline.unbalance_grade_mm_s": 0.0}))
    i1 = m.lines.keys().index((1, 0, 0, 0, 0, 0))
    rot = m.rotor
    node = m.case.raw["baseline"]["misalignment_node"]
    fvec = np.zeros(rot.ndof, complex)
    fvec[rot.dof_index(node, "x")] = COUPLING_N
    fvec[rot.dof_index(node, "y")] = -1j * COUPLING_N
    sites = m.machine.sites
    order = [sites["de"].rotor_node, sites["de"].housing_node, sites["nde"].rotor_node, sites["nde"].housing_node]
    f_hz = 25.0
    w = 2 * math.pi * f_hz
    x = np.linalg.solve(rot.K - w * w * rot.M + 1j * w * (rot.C + w * rot.G), fvec)
    ref = np.array([[x[rot.dof_index(n, "y")], x[rot.dof_index(n, "x")]] for n in order])
    sp = m.spectrum(f_hz)
    assert sp.frequency_hz[i1] == pytest.approx(f_hz)
    assert np.max(np.abs(sp.displacement[i1] - ref)) < 1e-4 * np.abs(ref).max()
    dented = np.abs(coupled.spectrum(f_hz).displacement[coupled.lines.keys().index((1, 0, 0, 0, 0, 0))] - ref).max()
    assert 1e-4 * np.abs(ref).max() < dented < 1e-2 * np.abs(ref).max(), dented / np.abs(ref).max()
    sp = m.spectrum(1.0)
    w = 2 * math.pi
    shares = _lever_rule(m.case, COUPLING_N)
    total = np.zeros(2, complex)
    for b, (rotor, housing) in (("de", (0, 1)), ("nde", (2, 3))):
        rel = sp.displacement[i1, rotor] - sp.displacement[i1, housing]              # (vertical, horizontal)
        k, c = sites[b].stiffness_n_m[::-1], sites[b].damping_n_s_m[::-1]           # (x, y) -> (vertical, horiz.)
        carried = (k + 1j * w * c) * rel
        assert np.abs(carried) == pytest.approx([abs(shares[b])] * 2, rel=0.01)
        total += carried
    assert np.abs(total) == pytest.approx([COUPLING_N] * 2, rel=0.01)


# --------------------------------------------------------------------------- the turning load in the bearing
def _frozen_load_path(bearing, load_n: float, turning_n: complex, axial_n: float, e_static, n_fast: int,
                      n_shaft: int):
    """The bearing's static equilibrium under the load of each instant, W + (Re, Im)(R exp(i theta_shaft)), at
    n_fast ball-set positions over one ball pitch x n_shaft shaft angles: Newton on F(e) + W = 0 with the tangent
    K = -dF/de of the bearing model, the axial displacement held at its static value (as the quasi-static model and
    the TDSM hold it). Returns e (n_fast, n_shaft, 2: x, y) [m]."""
    z = bearing.geometry.n_balls
    a = 2 * np.pi * np.arange(n_fast) / n_fast
    b = 2 * np.pi * np.arange(n_shaft) / n_shaft
    cage, shaft = np.meshgrid(a / z, b, indexing="ij")
    return _frozen_path_on(bearing, load_n, turning_n, axial_n, e_static, cage, shaft), a, b


def test_turning_load_gives_sidebands_at_bpfo_plus_minus_1x(coupled):
    """The outer-race bearing under its share of the coupling force: its lines at k BPFO +- f_r are the 2-D
    Fourier coefficients of the frozen-load equilibrium computed here (vertical and horizontal, amplitude and
    phase), they scale with the turning load, they are absent without it, and the machine's spectrum has them at
    k BPFO f_r +- f_r."""
    site = coupled.machine.sites["de"]
    bearing, z = site.bearing, site.bearing.geometry.n_balls
    load = float(np.hypot(*site.radial_load_n))
    turning = site.rotating_load_n * np.exp(0.7j)                  # any phase of the coupling
    n_fast = 512

    def excitation(r):
        return quasi_static_excitation(bearing, load, site.axial_load_n, n_fast, 1e-3, 0, 1.0,
                                       rotating_load_n=r).line_set()

    lines = excitation(turning)
    path, a, b = _frozen_load_path(bearing, load, turning, site.axial_load_n, site.state.displacement_m, n_fast, 16)
    for k in (1, 2, 3):
        carrier = lines.amplitude[lines.keys().index((0, k * z, 0, 0))]
        for s in (-1, 1):
            ref = 2 * np.mean(path * np.exp(-1j * (k * a[:, None, None] + s * b[None, :, None])), axis=(0, 1))
            ref = ref[::-1]                                        # (vertical, horizontal)
            got = lines.amplitude[lines.keys().index((s, k * z, 0, 0))]
            assert np.max(np.abs(got - ref)) < 2e-3 * np.abs(ref).max(), (k, s)
            assert 0.01 * abs(carrier[0]) < abs(got[0]) < 0.2 * abs(carrier[0])
    half = excitation(0.5 * turning)
    i = half.keys().index((1, z, 0, 0))
    assert abs(half.amplitude[i, 0]) == pytest.approx(0.5 * abs(lines.amplitude[lines.keys().index((1, z, 0, 0)), 0]),
                                                      rel=0.03)
    still = excitation(0j)
    assert all(c[0] == 0 for c in still.keys())
    keys = coupled.lines.keys()
    sp = coupled.spectrum(25.0)
    bpfo = coupled.fault_multipliers.bpfo * 25.0
    for s in (-1, 1):
        i = keys.index((s, z, 0, 0, 0, 0))
        assert sp.frequency_hz[i] == pytest.approx(bpfo + s * 25.0)
        assert np.abs(sp.acceleration[i, 1, 0]) > 0.01 * np.abs(sp.acceleration[keys.index((0, z, 0, 0, 0, 0)), 1, 0])


def _squared_envelope_1x_db(x: np.ndarray, fs: float, f_r: float) -> float:
    """Textbook squared envelope: the strongest 1 kHz band above 1 kHz (Welch PSD), 4th-order Butterworth
    band-pass, Hilbert envelope, |.|^2, mean removed, Hann window, FFT. The 1x peak (largest bin within 2 % of
    f_r) over the median of the envelope spectrum from 0.5 f_r to 1.5 f_r [dB]."""
    f, pxx = signal.welch(x, fs, nperseg=4096)
    edges = np.arange(1000.0, 0.4 * fs, 500.0)
    lo = edges[int(np.argmax([pxx[(f >= e) & (f < e + 1000.0)].sum() for e in edges]))]
    sos = signal.butter(4, [lo, lo + 1000.0], btype="bandpass", fs=fs, output="sos")
    env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x))) ** 2
    env -= env.mean()
    spec = np.abs(np.fft.rfft(env * np.hanning(env.size)))
    fr = np.fft.rfftfreq(env.size, 1.0 / fs)
    peak = np.abs(fr - f_r) <= 0.02 * f_r
    floor = (fr > 0.5 * f_r) & (fr < 1.5 * f_r) & ~peak
    return float(20 * np.log10(spec[peak].max() / np.median(spec[floor])))


def _waveform(model, speed: float, strikes: bool = True) -> np.ndarray:
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.25, quantities=("acceleration",), slip=0.01, seed=3,
                    noise_density={"acceleration": 2e-4}, band_limit="taper", features=False, strikes=strikes)
    return np.concatenate([s.next_chunk(speed).channel("de_vertical_acceleration") for _ in range(16)]).astype(float)


def test_coupling_force_puts_1x_into_the_squared_envelope(coupled, fault_library):
    """The outer-race machine at 25 Hz (1 % slip, sensor noise, 4 s): without the coupling force its squared
    envelope has no 1x line (the load zone does not move); with 30 N it has one far above the floor (CWRU's
    outer-race records: ~31 dB). Every strike alike: the library's dent unloads its balls fully, and its strikes'
    random strength raises the envelope's floor under 1x as much as under the fault line (tests/unit/test_strikes.py)."""
    without = _squared_envelope_1x_db(_waveform(fault_library["outer"], 25.0, strikes=False), FS, 25.0)
    with_force = _squared_envelope_1x_db(_waveform(coupled, 25.0, strikes=False), FS, 25.0)
    assert without < 6.0, without
    assert with_force > 20.0, with_force


def test_zero_coupling_force_is_the_case_without_the_key(fault_library, cached_model):
    """Backward compatibility: the new keys at 0 (and no electrical harmonics) give the same lines and the same
    spectrum, bit for bit, as a case without them."""
    plain = fault_library["outer"]
    case = plain.case.with_overrides({"baseline.coupling_force_n": 0.0, "baseline.coupling_phase_deg": 0.0,
                                      "baseline.looseness_force_n": 0.0, "baseline.electrical_harmonics": [],
                                      "baseline.electrical_harmonic_forces_n": []})
    zero = cached_model(case)
    assert zero.lines.keys() == plain.lines.keys()
    speeds = [9.0, 25.0, 41.0]
    assert np.array_equal(zero.response(speeds), plain.response(speeds))
    assert all(s.rotating_load_n == 0j for s in zero.machine.sites.values())


# --------------------------------------------------------------------------- looseness and electrical harmonics
@pytest.fixture(scope="module")
def loose(cached_model):
    case = Case.load("motor_6010_healthy").with_overrides({
        "baseline.looseness_force_n": 12.0, "baseline.looseness_orders": 6, "baseline.unbalance_grade_mm_s": 0.0,
        "baseline.electrical_force_n": 5.0, "baseline.electrical_harmonics": [4.0, 6.0],
        "baseline.electrical_harmonic_forces_n": [2.0, 1.0]})
    return cached_model(case)


def test_looseness_is_a_sawtooth_comb_of_shaft_orders(loose):
    """Orders 1..N at F/k with the phase of a sine, nothing at N + 1; the force they make is the truncated
    Fourier series of a sawtooth, F sum_k sin(k theta) / k; with many orders it tends to the sawtooth itself,
    F (pi - theta) / 2 on (0, 2 pi): one jump per turn."""
    lines, patterns = baseline_forces(loose.case, loose.rotor, loose.phases.rates_per_hz)
    y = lines.inputs.index("coupling.y")
    keys = lines.keys()
    for k in range(1, 7):
        a = lines.amplitude[keys.index((k, 0, 0, 0, 0, 0)), y]
        assert a == pytest.approx(-1j * 12.0 / k, rel=1e-12)
    assert (7, 0, 0, 0, 0, 0) not in keys
    node = loose.case.raw["baseline"]["misalignment_node"]
    assert patterns["coupling.y"][loose.rotor.dof_index(node, "y")] == 1.0
    theta = np.linspace(0.1, 2 * np.pi - 0.1, 50)
    shaft = np.array([k[0] for k in keys if k[5] == 0])
    amp = np.array([lines.amplitude[i, y] for i, k in enumerate(keys) if k[5] == 0])
    force = (amp[:, None] * np.exp(1j * shaft[:, None] * theta[None, :])).real.sum(axis=0)
    series = 12.0 * sum(np.sin(k * theta) / k for k in range(1, 7))
    assert np.max(np.abs(force - series)) < 1e-12 * 12.0
    many = Case.load("motor_6010_healthy").with_overrides({"baseline.looseness_force_n": 12.0,
                                                          "baseline.looseness_orders": 200})
    lines, _ = baseline_forces(many, loose.rotor, loose.phases.rates_per_hz)
    y = lines.inputs.index("coupling.y")
    force = sum((lines.amplitude[i, y] * np.exp(1j * k[0] * theta)).real for i, k in enumerate(lines.keys())
                if k[5] == 0 and lines.speed_power[i] == 0)
    inner = (theta > 0.5) & (theta < 2 * np.pi - 0.5)
    assert np.max(np.abs(force[inner] - 12.0 * (np.pi - theta[inner]) / 2)) < 0.02 * 12.0 * np.pi / 2


def test_looseness_and_electrical_lines_through_the_fe(loose):
    """The 3rd looseness order at 3 f_r and the 6 x line-frequency magnetic line at 300 Hz (whatever the speed):
    the dense FE solve of the forces written here."""
    m = loose
    keys = m.lines.keys()
    rot = m.rotor
    sites = m.machine.sites
    order = [sites["de"].rotor_node, sites["de"].housing_node, sites["nde"].rotor_node, sites["nde"].housing_node]
    node = m.case.raw["baseline"]["misalignment_node"]
    core = [d for d in m.case.raw["rotor"]["disks"] if d["name"].startswith("core")]
    mass = sum(d["mass_kg"] for d in core)
    f_hz = 23.0
    sp = m.spectrum(f_hz)
    for key, w_hz in (((3, 0, 0, 0, 0, 0), 3 * f_hz), ((0, 0, 0, 0, 0, 6), 300.0), ((0, 0, 0, 0, 0, 4), 200.0)):
        i = keys.index(key)
        assert sp.frequency_hz[i] == pytest.approx(w_hz)
        fvec = np.zeros(rot.ndof, complex)
        if key[0]:
            fvec[rot.dof_index(node, "y")] = -1j * 12.0 / 3
        else:
            for d in core:
                fvec[rot.dof_index(d["node"], "y")] += (1.0 if key[5] == 6 else 2.0) * d["mass_kg"] / mass
        w, big = 2 * math.pi * w_hz, 2 * math.pi * f_hz
        x = np.linalg.solve(rot.K - w * w * rot.M + 1j * w * (rot.C + big * rot.G), fvec)
        ref = np.array([[x[rot.dof_index(n, "y")], x[rot.dof_index(n, "x")]] for n in order])
        assert np.max(np.abs(sp.displacement[i] - ref)) < 1e-4 * np.abs(ref).max(), key


# --------------------------------------------------------------------------- bad values
def _with_baseline(extra: str, method: str | None = None) -> str:
    text = embedded_text("motor_6010_outer")
    text = text.replace("[baseline]", "[baseline]\n" + extra, 1)
    if method is not None:
        text = text.replace('method = "quasi_static"', f'method = "{method}"', 1)
    return text


@pytest.mark.parametrize("extra, method, key, words", [
    ("coupling_force_n = -3.0", None, "baseline.coupling_force_n", ">= 0"),
    ("coupling_force_n = nan", None, "baseline.coupling_force_n", "finite"),
    ("coupling_force_n = inf", None, "baseline.coupling_force_n", "finite"),
    ("coupling_phase_deg = 720.0", None, "baseline.coupling_phase_deg", "[-360, 360]"),
    ("coupling_forces_n = 3.0", None, "baseline.coupling_forces_n", "unknown key"),
    ("looseness_force_n = -1.0\nlooseness_orders = 3", None, "baseline.looseness_force_n", ">= 0"),
    ("looseness_force_n = 5.0", None, "baseline.looseness_orders", "missing"),
    ("looseness_force_n = 5.0\nlooseness_orders = 0", None, "baseline.looseness_orders", "[1, 200]"),
    ("electrical_harmonics = [3.0]\nelectrical_harmonic_forces_n = [1.0]", None, "baseline.electrical_harmonics",
     "even"),
    ("electrical_harmonics = [4.0, 4.0]\nelectrical_harmonic_forces_n = [1.0, 1.0]", None,
     "baseline.electrical_harmonics", "once"),
    ("electrical_harmonics = [4.0]\nelectrical_harmonic_forces_n = [1.0, 2.0]", None,
     "baseline.electrical_harmonic_forces_n", "one force per"),
    ("electrical_harmonics = [4.0]\nelectrical_harmonic_forces_n = [nan]", None,
     "baseline.electrical_harmonic_forces_n", "finite"),
    ("coupling_force_n = 10.0", "four_dof", "baseline.coupling_force_n", "quasi_static"),
])
def test_bad_baseline_values_are_one_line_naming_the_key(extra, method, key, words):
    with pytest.raises(CaseError) as err:
        Case.from_toml(_with_baseline(extra, method), "test.toml")
    text = str(err.value)
    assert "\n" not in text and key in text and words in text, text


_INNER_PIT = ('\n[[defects]]\nbearing = "de"\nrace = "inner"\nlength_m = 1.0e-3\ndepth_m = 20.0e-6\n'
              'angle_deg = 0.0\nedge = "ball"\nedge_fraction = 0.1\n')


def _frozen_path_on(bearing, load_n: float, turning_n: complex, axial_n: float, e_static, cage, shaft):
    """The frozen-load equilibrium (``_frozen_load_path``) at any cage and shaft angles [rad] (same shapes):
    e (..., 2: x, y) [m]."""
    turn = turning_n * np.exp(1j * shaft)
    wx, wy = turn.real, -load_n + turn.imag
    ex, ey = np.full(cage.shape, e_static[0]), np.full(cage.shape, e_static[1])
    for _ in range(200):
        fx, fy, (kxx, kxy, kyy) = bearing.forces_n(ex, ey, cage, with_stiffness=True, e_z_m=e_static[2],
                                                   shaft_angle_rad=shaft)
        rx, ry = fx + wx, fy + wy
        det = kxx * kyy - kxy * kxy
        sx, sy = (kyy * rx - kxy * ry) / det, (kxx * ry - kxy * rx) / det
        step = np.minimum(1.0, 2e-6 / np.maximum(np.hypot(sx, sy), 1e-300))
        ex, ey = ex + sx * step, ey + sy * step
        if np.max(np.hypot(sx, sy)) < 1e-16:
            break
    return np.stack([ex, ey], axis=-1)


def test_an_inner_race_pit_under_a_turning_load_keeps_its_own_shaft_orders():
    """An inner-race pit under a turning load, against the frozen-load equilibrium computed here on the inner race's
    torus (psi = z (theta_shaft - theta_cage) fast, theta_shaft slow) and its 2-D Fourier series: the pit's lines
    at BPFI +- k f_r are the coefficients of the path with the pit, and its pure shaft orders (the pit's effect on
    the path as it turns through the load zone) are the coefficients of the path with the pit less the path without
    it; the sound bearing's own shaft orders are left to the FE's coupling line. (Before, every pure shaft order was
    dropped: the time-domain reference then had a 2x line the set lacked, 50-75 dB off at the DE rotor.)"""
    case = Case.from_toml(_with_baseline("coupling_force_n = 30.0") + _INNER_PIT, "test.toml")
    site = Machine(case).sites["de"]
    geometry = site.bearing.geometry
    bearing = Bearing(geometry, defects=[d for d in site.bearing.defects if d.race == "inner"])
    sound = Bearing(geometry)
    z = geometry.n_balls
    load = float(np.hypot(*site.radial_load_n))
    turning = site.rotating_load_n * np.exp(0.4j)
    n_fast, n_shaft = 512, 64
    lines = quasi_static_excitation(bearing, load, site.axial_load_n, n_fast, 1e-3, 0, 1.0,
                                    rotating_load_n=turning).line_set()
    psi, b = np.meshgrid(2 * np.pi * np.arange(n_fast) / n_fast, 2 * np.pi * np.arange(n_shaft) / n_shaft,
                         indexing="ij")
    cage = b - psi / z
    e0 = site.state.displacement_m
    with_pit = _frozen_path_on(bearing, load, turning, site.axial_load_n, e0, cage, b)
    without = _frozen_path_on(sound, load, turning, site.axial_load_n, e0, cage, b)

    def coefficient(path, k, m):                   # the line k psi + m theta_shaft, (vertical, horizontal)
        return (2 * np.mean(path * np.exp(-1j * (k * psi + m * b))[..., None], axis=(0, 1)))[::-1]

    keys = lines.keys()
    largest = np.abs(lines.amplitude).max()
    for k, m in ((1, 0), (1, -1), (1, 1), (2, 0), (0, 1), (0, 2), (0, 3)):
        ref = coefficient(with_pit - without, k, m) if k == 0 else coefficient(with_pit, k, m)
        got = lines.amplitude[keys.index((k * z + m, -k * z, 0, 0))]
        assert np.max(np.abs(got - ref)) < 2e-3 * largest, (k, m, got, ref)
        if k == 0:
            assert np.abs(ref).max() > 1e-3 * largest, (m, ref)                        # there, and not small
    assert (1, 0, 0, 0) in keys and (2, 0, 0, 0) in keys


def test_an_inner_and_an_outer_race_pit_in_one_bearing_under_a_turning_load():
    """Both pits in the DE bearing with a coupling force: a valid case (it was refused: no one 2-torus resolves
    both), whose lines are what each pit makes alone on the sound bearing (the inner pit's added on its own torus to
    the bearing with the outer one) but for their interaction, a ball in each pit at once: small beside the set's
    largest line (it moves the weak BPFO + f_r sideband by ~9 %; the time-domain reference holds the interaction:
    tests/integration/test_faults_tdsm.py)."""
    case = Case.from_toml(_with_baseline("coupling_force_n = 30.0") + _INNER_PIT, "test.toml")
    site = Machine(case).sites["de"]
    geometry, z = site.bearing.geometry, site.bearing.geometry.n_balls
    load = float(np.hypot(*site.radial_load_n))

    def lines_of(defects):
        return quasi_static_excitation(Bearing(geometry, defects=defects), load, site.axial_load_n, 512, 1e-3, 0, 1.0,
                                       rotating_load_n=site.rotating_load_n).line_set()

    both = lines_of(list(site.bearing.defects))
    assert {d.race for d in site.bearing.defects} == {"outer", "inner"}
    alone = [lines_of([d]) for d in site.bearing.defects] + [lines_of([])]

    def amplitude(lines, key):
        return lines.amplitude[lines.keys().index(key)] if key in lines.keys() else np.zeros(2)

    # BPFO and its 1x sidebands, BPFI and its, the inner pit's shaft orders (a line of one family can be a line of
    # the other too: BPFO + f_r = -BPFI + (z + 1) f_r)
    largest = np.abs(both.amplitude).max()
    for key in ((0, z, 0, 0), (1, z, 0, 0), (-1, z, 0, 0), (0, 2 * z, 0, 0), (z, -z, 0, 0), (z + 1, -z, 0, 0),
                (z - 1, -z, 0, 0), (1, 0, 0, 0), (2, 0, 0, 0)):
        ref = amplitude(alone[0], key) + amplitude(alone[1], key) - amplitude(alone[2], key)
        got = amplitude(both, key)
        assert np.abs(ref).max() > 1e-3 * largest, key
        assert np.max(np.abs(got - ref)) < 0.03 * largest, (key, got, ref)
