"""A race pit's strikes of random strength (bkabem_core.synth.strikes): the draw, the law of its spread, the kernels,
what a pipeline sees of it, and the case key.

Oracles written here: the lognormal's moments; the share of its load a ball loses over the pit from the bearing's
own ball loads with and without the pit (rings held), not from the formula under test; the energy of each ball pass
of a rendered waveform, and its RMS, against the same run with every strike alike.
"""

from __future__ import annotations

import numpy as np
import pytest

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case, CaseError
from bkabem_core.synth.lines import LineSelection
from bkabem_core.synth.profile import SynthError
from bkabem_core.synth.strikes import StrikeSpread, load_loss, strike_gain, strike_key
from bkabem_core.synth.synthesizer import Synthesizer

FS = 25600.0
SPEED_HZ = 25.0


def _rig_pit(kind: str, mils: int, **extra) -> Case:
    """The CWRU rig case with one of its EDM pits in the drive-end bearing (its depth 0.011 in)."""
    base = Case.load("cwru_rig")
    table = {"bearing": "de", "race": kind, "length_m": mils * 2.54e-5, "depth_m": 2.794e-4,
             "angle_deg": -90.0 if kind == "outer" else 0.0, "shape": "round_pit", "edge": "ball",
             "edge_fraction": 0.1, **extra}
    return Case.from_dict({**base.raw, "defects": [table]})


@pytest.fixture(scope="module")
def outer(fault_library):
    return fault_library["outer"]


def _waveform(model, strikes: bool, seconds: float = 20.0, **kw) -> np.ndarray:
    s = Synthesizer(model, FS, 1.0, quantities=("acceleration",), slip=0.0, seed=4, noise_density=None,
                    broadband_floor=False, measurement=False, features=False, strikes=strikes, **kw)
    return np.concatenate([s.next_chunk(SPEED_HZ).channel("de_vertical_acceleration")
                           for _ in range(int(seconds))]).astype(float)


# --------------------------------------------------------------------------- the draw
@pytest.mark.parametrize("spread", [0.25, 0.5, 1.0])
def test_a_strikes_energy_is_lognormal_of_mean_one_and_the_stated_spread(spread):
    sigma = np.sqrt(np.log1p(spread ** 2))
    e = strike_gain(strike_key(11), np.arange(-1000, 199000), sigma) ** 2
    assert e.mean() == pytest.approx(1.0, abs=4 * spread / np.sqrt(e.size))
    assert e.std() / e.mean() == pytest.approx(spread, rel=0.05)
    assert abs(np.corrcoef(np.log(e[:-1]), np.log(e[1:]))[0, 1]) < 0.01          # strike to strike: independent
    assert np.array_equal(strike_gain(strike_key(11), [5, 7], sigma), strike_gain(strike_key(11), [5, 7], sigma))
    assert not np.allclose(strike_gain(strike_key(12), [5, 7], sigma), strike_gain(strike_key(11), [5, 7], sigma))
    assert np.array_equal(strike_gain(strike_key(11), [5, 7], 0.0), [1.0, 1.0])


# --------------------------------------------------------------------------- the law
@pytest.fixture(scope="module")
def rig_state():
    """The rig's drive-end static state (its pits do not move it: the static solve leaves defects out)."""
    site = Machine(Case.load("cwru_rig")).sites["de"]
    return site.state, site.bearing.peak_ball_load_n(site.state)


def _pit_bearing(kind: str, mils: int, rig_state):
    """The rig's drive-end bearing with one of its pits, bridged at its largest static ball load (as the machine
    makes it)."""
    return _rig_pit(kind, mils).bearing("de").with_bridging_load(rig_state[1])


@pytest.mark.parametrize("mils", [7, 21])
def test_the_load_a_ball_loses_over_a_rig_pit_is_the_bearings_own(mils, rig_state):
    """lambda against the bearing's own ball loads: the ball sitting over the pit's centre, rings held at the static
    state, with and without the pit (the pit at 6 o'clock, the load zone's centre: the most loaded ball)."""
    b = _pit_bearing("outer", mils, rig_state)
    state = rig_state[0]
    e = state.displacement_m
    cage = b.defects[0].angle_rad - b.ball_angles_rad(0.0)[0]
    q_pit = b.ball_loads_n(e[0], e[1], cage, with_dent=True, e_z_m=e[2])[0]
    q = b.ball_loads_n(e[0], e[1], cage, with_dent=False, e_z_m=e[2])[0]
    lam = load_loss(b, state, b.defect_set.profiles[0])
    assert lam == pytest.approx(1.0 - q_pit / q, abs=0.02), (lam, 1.0 - q_pit / q)


def test_the_spread_grows_with_the_pit_and_is_whole_for_a_pit_the_ball_falls_into(fault_library, rig_state):
    lams = []
    for mils in (7, 14, 21, 28):
        b = _pit_bearing("inner", mils, rig_state)
        lams.append(load_loss(b, rig_state[0], b.defect_set.profiles[0]))
    assert all(a < b for a, b in zip(lams, lams[1:])), lams
    assert 0.0 < lams[0] < 0.15 and 0.6 < lams[-1] < 1.0, lams               # bridged a little .. mostly free
    s = StrikeSpread.of_model(fault_library["outer"], LineSelection(fault_library["outer"]))
    assert s.load_loss == 1.0 and s.spread == 1.0                               # 50 um deep, 2 mm long: free
    for kind in ("ball", "healthy"):
        assert StrikeSpread.of_model(fault_library[kind], LineSelection(fault_library[kind])) is None


# --------------------------------------------------------------------------- the kernels
@pytest.mark.parametrize("kind", ["outer", "inner"])
def test_the_c_kernel_and_the_numpy_reference_give_the_same_strikes_across_chunk_borders(fault_library, kind):
    """With 1 % slip (the strikes move with the slipping phase) and a carrier family (inner race): the C line kernel
    and the numpy reference agree, and a chunk border anywhere gives the same samples (to float32 rounding, as the
    lines without strikes)."""
    m = fault_library[kind]
    runs = {}
    for kernel in ("auto", "reference"):
        for chunk in (0.1, 0.0371):
            s = Synthesizer(m, FS, chunk, quantities=("acceleration",), slip=0.01, seed=5, noise_density=None,
                            broadband_floor=False, measurement=False, features=False, kernel=kernel)
            x = np.concatenate([s.next_chunk(24.0).samples for _ in range(int(np.ceil(1.2 / chunk)))], axis=1)
            runs[kernel, chunk] = x[:, :int(1.1 * FS)].astype(float)
    rms = np.sqrt(np.mean(runs["auto", 0.1] ** 2))
    plain = Synthesizer(m, FS, 0.1, quantities=("acceleration",), slip=0.01, seed=5, noise_density=None,
                        broadband_floor=False, measurement=False, features=False, strikes=False)
    y = np.concatenate([plain.next_chunk(24.0).samples for _ in range(12)], axis=1)[:, :int(1.1 * FS)]
    assert np.max(np.abs(runs["auto", 0.1] - y)) > 0.1 * rms                   # the strikes are there
    for other in (("auto", 0.0371), ("reference", 0.1), ("reference", 0.0371)):
        assert np.max(np.abs(runs["auto", 0.1] - runs[other])) < 2e-5 * rms, other


def test_a_spread_of_zero_is_every_strike_alike_bit_for_bit(outer, cached_model):
    zero = cached_model(outer.case.with_overrides({"defects.0.strike_spread": 0.0}), like=outer)
    assert np.array_equal(_waveform(zero, True, 2.0), _waveform(outer, False, 2.0))


# --------------------------------------------------------------------------- what a pipeline sees
@pytest.mark.parametrize("spread", [0.4, 1.0])
def test_each_pass_is_struck_anew_and_the_rms_stays(outer, spread, cached_model):
    """20 s at 25 Hz (3000 ball passes): the energy of each ball pass over the same pass with every strike alike
    varies by about the stated spread (a little less: a strike's ringing runs on into the blend towards the next),
    around 1, and the RMS is the quasi-static model's (to the sampling error of 3000 random strikes)."""
    model = cached_model(outer.case.with_overrides({"defects.0.strike_spread": spread}), like=outer)
    x, x0 = _waveform(model, True), _waveform(model, False)
    per = FS / (SPEED_HZ * model.bpfo_per_hz)
    n = int(x.size / per) - 1
    edges = (np.arange(n + 1) * per).astype(int)
    e = np.add.reduceat(x[:edges[-1]] ** 2, edges[:-1])
    e0 = np.add.reduceat(x0[:edges[-1]] ** 2, edges[:-1])
    r = e / e0
    assert 0.75 * spread < r.std() < 1.1 * spread, r.std()
    assert r.mean() == pytest.approx(1.0, abs=3 * spread / np.sqrt(n))
    assert np.sqrt(np.mean(x ** 2) / np.mean(x0 ** 2)) == pytest.approx(1.0, abs=3 * spread / np.sqrt(n))


def test_random_strikes_lower_the_envelope_line_to_their_ceiling(outer):
    """A textbook squared-envelope spectrum (2-4 kHz band, Hilbert envelope): with every strike alike the BPFO line
    stands far over the floor; with random strikes (spread 1) it stands near ``10 log10(N / c^2)`` over it (N
    strikes), the bound of random impact strengths."""
    from scipy import signal

    def line_db(x):
        sos = signal.butter(6, [2000.0, 4000.0], btype="bandpass", fs=FS, output="sos")
        env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x))) ** 2
        spec = np.abs(np.fft.rfft(env - env.mean())) ** 2
        f = np.fft.rfftfreq(env.size, 1.0 / FS)
        bpfo = SPEED_HZ * outer.bpfo_per_hz
        line = spec[np.abs(f - bpfo) < 0.3].max()
        floor = np.median(spec[(f > 20.0) & (f < 500.0) & (np.abs(np.remainder(f / bpfo + 0.5, 1.0) - 0.5) > 0.05)])
        return 10 * np.log10(line / floor), x.size / FS * bpfo

    plain, n = line_db(_waveform(outer, False, 10.0))
    struck, _ = line_db(_waveform(outer, True, 10.0))
    ceiling = 10 * np.log10(n / 1.0 ** 2) + 1.6
    assert plain > ceiling + 20.0, (plain, ceiling)
    assert ceiling - 8.0 < struck < ceiling + 3.0, (struck, ceiling)


def test_a_pit_of_depth_zero_has_no_strikes(outer, cached_model):
    """A fleet's healthy machine is the defect case at depth 0: its bearing drops the pit, and so do the strikes."""
    flat = cached_model(outer.case.with_overrides({"defects.0.depth_m": 0.0}), like=outer)
    assert StrikeSpread.of_model(flat, LineSelection(flat)) is None
    s = Synthesizer(flat, FS, 0.1)
    assert np.all(np.isfinite(s.next_chunk(SPEED_HZ).samples)) and "strikes" not in s.ground_truth()


def test_the_ground_truth_says_how_the_strikes_were_drawn(outer):
    gt = Synthesizer(outer, FS).ground_truth()
    assert gt["strikes"]["kind"] == "outer" and gt["strikes"]["load_loss"] == 1.0
    assert gt["strikes"]["energy_spread"] == 1.0 and gt["strikes"]["struck_families"] >= 1
    assert "strikes" not in Synthesizer(outer, FS, strikes=False).ground_truth()
    assert gt["defects"][0]["strike_spread"] == 1.0


# --------------------------------------------------------------------------- the case key
def test_the_case_key_is_checked(cached_model):
    outer = Case.load("motor_6010_outer")
    assert outer.defects()[0].own == (("strike_spread", 1.0), ("roughness_db", 15.0))     # the library's: rougher
    assert outer.with_overrides({"defects.0.strike_spread": 0.5}).defects()[0].own == (("strike_spread", 0.5),
                                                                                       ("roughness_db", 15.0))
    for value, match in ((-0.1, "must be >= 0"), (6.0, "from 0"), ("x", "must be a number"), (True, "must be")):
        with pytest.raises(CaseError, match=match) as exc:
            outer.with_overrides({"defects.0.strike_spread": value})
        assert exc.value.key == "defects[0].strike_spread"
    ball = Case.load("motor_6010_ball")
    raw = ball.raw | {"defects": [dict(ball.raw["defects"][0], strike_spread=0.5)]}
    with pytest.raises(CaseError, match="only for race = 'outer' or 'inner'"):
        Case.from_dict(raw)
    with pytest.raises(SynthError, match="strikes"):
        Synthesizer(cached_model(outer), FS, strikes="yes")


def test_a_data_set_varies_the_spread():
    from bkabem_core.dataset.spec import DatasetSpec

    spec = DatasetSpec.from_toml("""
[dataset]
name = "strikes"
schema_version = 1
seed = 1
[run]
fault = "outer"
duration_s = 0.1
[grid]
strike_spread = [0.0, 1.5]
""")
    tables = [r.case_raw["defects"][0] for r in spec.runs]
    assert sorted(t["strike_spread"] for t in tables) == [0.0, 1.5]
