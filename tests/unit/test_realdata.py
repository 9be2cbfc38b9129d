"""The bench's real-data helpers (bench/realdata): textbook diagnostics on measured CWRU excerpts, the twin adapter.

The excerpts (tests/fixtures/cwru/, CWRU Bearing Data Center, https://engineering.case.edu/bearingdatacenter) are
1 s of the drive-end channel of a healthy, an outer-race, an inner-race and a ball record; the full comparisons
take the data folder as an argument (bench/validate_real.py, bench/sim2real.py) and are not part of the suite.
"""

from __future__ import annotations

import itertools
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))

from realdata.diagnostics import (  # noqa: E402
    KIND_LINE,
    amplitude_spectrum,
    decimate,
    diagnose,
    envelope_analysis,
    moments,
    squared_envelope,
    welch_psd,
)
from realdata.kurtogram import fast_kurtogram, pick_band  # noqa: E402
from realdata.records import EFFECTIVE_6205, parse_name  # noqa: E402

FIXTURE = ROOT / "tests" / "fixtures" / "cwru" / "excerpts.npz"


@pytest.fixture(scope="module")
def excerpts():
    with np.load(FIXTURE) as d:
        prov = json.loads(str(d["provenance"]))
        return {k: (d[k].astype(np.float64), prov["records"][k]) for k in prov["records"]}


def diagnosed(excerpts, name):
    x, meta = excerpts[name]
    x12 = decimate(x, meta["sample_rate_hz"])
    return diagnose(x12, 12000.0, meta["speed_hz"], EFFECTIVE_6205), meta


def test_fixture_is_small_float32_and_cited():
    assert FIXTURE.stat().st_size < 400e3
    with np.load(FIXTURE) as d:
        prov = json.loads(str(d["provenance"]))
        assert "bearingdatacenter" in prov["source"]
        assert prov["converter"]["commit"] and prov["converter"]["repository"]
        for k, meta in prov["records"].items():
            assert d[k].dtype == np.float32 and d[k].size == meta["n_samples"]
            assert meta["source_file"] and meta["unit"] == "g"
    assert "bearingdatacenter" in (FIXTURE.parent / "README.md").read_text()


def test_outer_race_excerpt_reads_outer_with_bpfo_standing_out(excerpts):
    d, meta = diagnosed(excerpts, "1797_ORat6_7_DE12")
    ses = d["ses"]["fixed"]
    assert ses["verdict"] == "outer"
    assert ses["levels"]["BPFO"] > 20.0
    assert ses["levels"]["BPFO"] - max(ses["levels"]["BPFI"], ses["levels"]["2BSF"]) > 10.0
    # the line sits at the rig's effective BPFO (3.598x), within the +-0.5 % window
    assert abs(ses["frequencies"]["BPFO"] / (3.598 * meta["speed_hz"]) - 1.0) < 0.005


def test_inner_race_excerpt_reads_inner(excerpts):
    d, _ = diagnosed(excerpts, "1797_IR_7_DE12")
    assert d["ses"]["fixed"]["verdict"] == "inner"
    assert d["ses"]["fixed"]["levels"]["BPFI"] > 20.0


def test_healthy_excerpt_has_no_fault_line_above_the_threshold(excerpts):
    d, meta = diagnosed(excerpts, "1797_Normal")
    assert meta["sample_rate_hz"] == 48000.0
    levels = d["ses"]["fixed"]["levels"]
    assert max(levels[KIND_LINE[k]] for k in ("outer", "inner", "ball")) < 10.0
    assert d["ses"]["fixed"]["verdict"] == "healthy"
    assert 0.05 < d["rms"] < 0.1 and 2.5 < d["kurtosis"] < 3.2      # CWRU's healthy baseline: ~0.07 g, Gaussian


def test_ball_excerpt_is_impulsive_without_a_line_standing_out(excerpts):
    """The known hard case: the 0.014 in ball record is impulsive (kurtosis ~10) while no fault line of the
    2-4 kHz envelope reaches the threshold in a 1-s excerpt."""
    d, _ = diagnosed(excerpts, "1797_B_14_DE12")
    assert d["kurtosis"] > 6.0
    assert max(d["ses"]["fixed"]["levels"][k] for k in ("BPFO", "BPFI", "2BSF")) < 10.0


def test_moments_of_textbook_signals():
    rng = np.random.default_rng(1)
    g = moments(rng.standard_normal(200_000))
    assert abs(g["kurtosis"] - 3.0) < 0.05 and abs(g["rms"] - 1.0) < 0.01
    t = np.arange(120_000) / 12000.0
    s = moments(2.0 * np.sin(2 * np.pi * 50.0 * t))
    assert abs(s["kurtosis"] - 1.5) < 1e-3 and abs(s["crest"] - np.sqrt(2)) < 1e-3 and abs(s["rms"] - np.sqrt(2)) < 1e-3


def test_ses_finds_a_synthetic_impact_train_and_its_level():
    """Decaying 3 kHz bursts at 107.7 Hz (an outer-race signature at 29.93 Hz) in white noise: the SES line at
    BPFO stands out, the verdict is outer; a component B cos of the squared envelope reads B."""
    fs, fr = 12000.0, 29.93
    bpfo = EFFECTIVE_6205["bpfo"] * fr
    t = np.arange(int(10 * fs)) / fs
    phase = (t * bpfo) % 1.0 / bpfo
    noise = 0.2 * np.random.default_rng(2).standard_normal(t.size)
    x = np.exp(-phase / 1.5e-3) * np.sin(2 * np.pi * 3000.0 * t) + noise
    r = envelope_analysis(x, fs, (2000.0, 4000.0), fr, EFFECTIVE_6205)
    assert r["verdict"] == "outer" and r["levels"]["BPFO"] > 30.0 and r["levels"]["BPFI"] < 10.0
    am = np.sin(2 * np.pi * 3000.0 * t) * np.sqrt(1.0 + 0.5 * np.cos(2 * np.pi * 100.0 * t))
    e = squared_envelope(am, fs, 2000.0, 4000.0)
    assert abs(np.mean(e) - 1.0) < 0.01                       # squared envelope of sin: 1 + 0.5 cos
    e = e[: e.size - e.size % 120]                          # whole periods of 100 Hz: the line on a bin
    f, spec = amplitude_spectrum(e, fs)
    assert abs(spec[np.argmin(np.abs(f - 100.0))] - 0.5) < 0.005


def test_kurtogram_puts_a_tone_in_the_band_of_largest_energy_and_picks_the_impulsive_band():
    fs = 12000.0
    t = np.arange(48_000) / fs
    for f0 in (700.0, 2100.0, 3300.0, 4700.0):
        nodes = fast_kurtogram(np.sin(2 * np.pi * f0 * t), fs, 4)
        for level in sorted({n.level for n in nodes if n.level > 0}):
            best = max((n for n in nodes if n.level == level), key=lambda n: n.power)
            assert best.f_lo - 1.0 <= f0 <= best.f_hi + 1.0, (f0, level, best)
    rng = np.random.default_rng(3)
    x = rng.standard_normal(t.size)
    period = int(fs / 100.0)
    ring = np.exp(-np.arange(120) / 20.0) * np.sin(2 * np.pi * 3500.0 * np.arange(120) / fs)
    for i in range(0, t.size - 120, period):
        x[i:i + 120] += 8.0 * ring
    band = pick_band(fast_kurtogram(x, fs, 3), fs)
    assert band.f_lo <= 3500.0 <= band.f_hi and band.kurtosis > 1.0


def test_cwru_file_names():
    assert parse_name("1797_IR_7_DE12") == {"rpm_nominal": 1797, "load_hp": 0, "kind": "inner", "size_mils": 7,
                                            "position_oclock": None, "fault_bearing": "de", "sample_rate_hz": 12000.0}
    o = parse_name("1772_OR@6_14_DE12")
    assert o["kind"] == "outer" and o["position_oclock"] == 6 and o["load_hp"] == 1
    assert parse_name("1730_ORat12_21_FE12")["fault_bearing"] == "fe"
    assert parse_name("1797_Normal")["sample_rate_hz"] == 48000.0 and parse_name("1797_Normal")["kind"] == "healthy"
    for bad in ("README", "1797_IR_DE12", "1800_IR_7_DE12", "1797_ORat5_7_DE12", "1797_XX_7_DE12"):
        assert parse_name(bad) is None, bad


def test_twin_adapter_rate_length_and_unit():
    """The fault-library twin of an outer-race record: DE and FE in g at the asked rate and length, its BPFO in
    the envelope where the twin's bearing puts it."""
    from realdata.twin import Condition, synthesize

    for fs, seconds in ((12000.0, 1.0), (48000.0, 0.25)):
        sig = synthesize(Condition("outer", 7, 0, 6), "motor_6010", 1, 29.93, fs, seconds)
        for ch in ("DE", "FE"):
            x = sig[ch]
            assert x.dtype == np.float64 and x.shape == (int(round(fs * seconds)),) and np.all(np.isfinite(x))
            assert 0.3 < np.std(x) < 3.0                         # g (the library's outer race: 0.7-1.8 g), not m/s^2
    sig = synthesize(Condition("outer", 7, 0, 6), "motor_6010", 1, 29.93, 12000.0, 2.0)
    r = envelope_analysis(sig["DE"], 12000.0, (2000.0, 4000.0), 29.93, sig["mult"])
    assert r["verdict"] == "outer"
    assert abs(r["frequencies"]["BPFO"] / (sig["mult"]["bpfo"] * 29.93) - 1.0) < 0.005
    assert abs(sig["mult"]["bpfo"] - 6.0598) < 1e-3                # the 6010's BPFO multiplier
    other = synthesize(Condition("outer", 7, 0, 6), "motor_6010", 2, 29.93, 12000.0, 2.0)
    assert not np.allclose(other["DE"], sig["DE"])                  # another seed, another record


def test_case_toml_writes_every_embedded_case_back():
    from realdata.twin import case_toml

    from bkabem_core.model.case import Case, embedded_cases

    for name in embedded_cases():
        c = Case.load(name)
        assert Case.from_toml(case_toml(c.raw)).raw == c.raw, name


def test_sim2real_grid_specs_cover_the_runs_exactly():
    from sim2real import factorise

    pts = [({"fault": "outer", "speed_hz": s, "slip": sl, "angle_deg": a}, 2)
           for s in (29.95, 29.53) for sl in (0.01, 0.02) for a in (-90.0, 0.0)]
    pts += [({"fault": "healthy", "speed_hz": s, "slip": 0.01}, 4) for s in (29.95, 29.53)]
    pts += [({"fault": "inner", "speed_hz": 29.95, "slip": 0.01}, 1), ({"fault": "inner", "speed_hz": 29.53,
                                                                         "slip": 0.02}, 1)]
    specs = factorise(pts)
    runs = []
    for fixed, grid, reps in specs:
        for combo in itertools.product(*grid.values()):
            runs += [json.dumps(dict(fixed, **dict(zip(grid, combo))), sort_keys=True)] * reps
    assert sorted(runs) == sorted(json.dumps(p, sort_keys=True) for p, r in pts for _ in range(r))
    assert len(specs) == 4                                           # outer, healthy, and the inner pair split


def test_sim2real_ablation_finds_the_family_the_twin_teaches_the_other_way():
    """Four classes, two families of two features each: ``right`` separates the classes alike in the twin and the
    measurement; ``flipped`` separates them too, more sharply, but the measurement carries it for another class (as
    the rig's race records carry an envelope line at FTF that the twin gives only its ball faults). Leaving
    ``flipped`` out raises the measured score; leaving ``right`` out lowers it; the twin's own held-out score stays
    high either way, so only the measurement can tell."""
    from sim2real import ablation, ablation_lines

    rng = np.random.default_rng(3)
    k, n = 4, 40
    y = np.repeat(np.arange(k), n)

    corner = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])

    def table(flip):                                    # the classes at the corners of a square, noise sd 1
        x = np.hstack([4.0 * corner[y], 8.0 * corner[(y + flip) % k]])
        return x + rng.normal(0.0, 1.0, x.shape)

    tw = {"X": table(0), "y": y, "groups": [(int(c), i % 10) for i, c in enumerate(y)]}
    me = {"X": table(1), "y": y}
    sets = {"both": (0, 1, 2, 3)}
    fams = {"right": (0, 1), "flipped": (2, 3)}
    ab = ablation(tw, me, 0.01, sets, fams)["both"]
    assert ab["flipped"]["measured"] > ab["none"]["measured"] + 0.2, ab
    assert ab["right"]["measured"] < ab["none"]["measured"] + 0.05, ab
    assert min(r["twin_cv"] for r in ab.values()) > 0.75, ab
    text = "\n".join(ablation_lines({"both": {**ab}}, len(y)))
    assert "rises without flipped (+" in text and "falls without right (-" in text, text

@pytest.mark.parametrize("seeds", [1, 2, 3])
def test_sim2real_race_pits_span_the_strike_spread_with_the_same_runs(seeds):
    """A rig twin's race conditions spread their replicates over PIT_SPREADS (each spread as often as the replicates
    allow, over the slips together), the other kinds carry no spread, and the number of runs is what it was."""
    from sim2real import PIT_SPREADS, conditions, runs_of

    groups = runs_of(conditions((0,)), "cwru_rig", seeds, 1.0)
    per_cond = {}
    for pts in groups.values():
        for p, reps, c in pts:
            assert ("strike_spread" in p) == (c.kind in ("inner", "outer")), (c, p)
            per_cond.setdefault(c, Counter())[p.get("strike_spread")] += reps
    for c, counts in per_cond.items():
        if c.kind in ("inner", "outer"):
            assert sum(counts.values()) == 2 * seeds                  # two slips, ``seeds`` each
            assert set(counts) == set(PIT_SPREADS) and max(counts.values()) - min(counts.values()) <= 1, counts
        else:
            assert set(counts) == {None}


def test_the_low_band_reader_finds_shaft_orders_and_tells_them_from_fixed_lines():
    """bench/rig_low_band.py on two synthetic 'records' at two speeds: a BPFI-like order and a 360 Hz supply line
    over white noise; the order comes back as one order in both, the supply line as a fixed frequency, and a line
    under the threshold is not reported."""
    from rig_low_band import FS, table, tones

    rng = np.random.default_rng(3)
    rows = []
    for fr in (29.93, 29.54):
        t = np.arange(int(10 * FS)) / FS
        x = (0.05 * np.sin(2 * np.pi * 5.40 * fr * t) + 0.05 * np.sin(2 * np.pi * 360.0 * t)
             + 1e-4 * np.sin(2 * np.pi * 17.0 * fr * t) + 0.01 * rng.standard_normal(t.size))
        f, p = welch_psd(x, FS, resolution_hz=0.5)
        lines = tones(f, p, fr, 25.0)
        orders = sorted(o for o, _d in lines)
        assert len(orders) == 2 and abs(orders[0] - 5.40) < 0.02 and abs(orders[1] - 360.0 / fr) < 0.02
        rows.append((f"{fr}", fr, 0.5, lines))
    text = table(rows, 25.0)
    assert "| 5.40x | 2 |" in text                 # an order in both records
    assert "| 360 | 2 | 6.00 |" in text             # the supply line, fixed in Hz across the two speeds
    assert "17.00x" not in text


def _impact_train(rng, cv, fs=12000.0, seconds=5.0, f_fault=107.6, fr=29.93, modulation=0.0, window=None):
    """Impacts at ``f_fault`` [Hz] ringing a 3 kHz, 3 % damped resonance, each with an energy of random spread
    ``cv`` (lognormal, i.i.d.) times ``window(theta)`` of the shaft angle at it (default: a periodic shaft-rate
    modulation of depth ``modulation``), over weak white noise; also returns the number of impacts."""
    if window is None:
        def window(th):
            return 1.0 + modulation * np.cos(th)
    n = int(seconds * f_fault)
    times = np.arange(n) / f_fault
    s2 = np.log1p(cv ** 2)                          # energy lognormal with that spread; the amplitude its root
    energy = rng.lognormal(-s2 / 2.0, np.sqrt(s2), n) * window(2 * np.pi * fr * times)
    x = np.zeros(int(seconds * fs))
    np.add.at(x, np.round(times * fs).astype(int), np.sqrt(energy))
    th = np.arange(int(0.01 * fs)) / fs
    wn, z = 2 * np.pi * 3000.0, 0.03
    ring = np.exp(-z * wn * th) * np.sin(wn * np.sqrt(1 - z * z) * th)
    return np.convolve(x, ring)[:x.size] + 1e-4 * rng.standard_normal(x.size), n


def _textbook_line_over_floor_db(x, fs, f0):
    """The fault line of the 2-4 kHz squared-envelope spectrum over the spectrum's median within 50 Hz of it
    (outside +-2 Hz of the line's harmonics and of the shaft's orders: the local floor, where the impact's own
    envelope spectrum is about as high as at the line), written here from the textbook: a FIR band-pass, the
    analytic signal's squared magnitude, its DFT magnitude."""
    from scipy.signal import firwin, hilbert

    y = np.convolve(x, firwin(401, [2000.0, 4000.0], pass_zero=False, fs=fs), mode="same")
    e = np.abs(hilbert(y)) ** 2
    spec = np.abs(np.fft.rfft(e - e.mean()))
    f = np.fft.rfftfreq(e.size, 1.0 / fs)
    keep = np.abs(f - f0) < 50.0
    for h in range(1, 5):
        keep &= np.abs(f - h * f0) > 2.0
    for k in range(1, 17):
        keep &= np.abs(f - k * 29.93) > 2.0
    line = spec[np.abs(f - f0) <= 0.5].max()
    return 20.0 * np.log10(line / np.median(spec[keep]))


@pytest.mark.parametrize("cv", [0.1, 0.5])
def test_the_impacts_random_spread_is_read_through_a_periodic_modulation_and_bounds_the_envelope_line(cv):
    """bench/impact_spread.py on impact trains of known random spread: the spread is read back within 20 % under
    a deep shaft-rate modulation too (its lines in the passes' sequence are not randomness; it scales the random
    part by sqrt(1 + depth^2 / 2)), and the squared-envelope line of an unmodulated train stands at the ceiling that
    spread gives, within 2 dB."""
    from impact_spread import ceiling_db, pass_energies, random_spread

    fs, f0 = 12000.0, 107.6
    rng = np.random.default_rng(11)
    for depth in (0.0, 0.8):
        x, n = _impact_train(rng, cv, modulation=depth)
        energies, f = pass_energies(x, fs, f0 * 1.002)            # found from 0.2 % off, as on a record
        assert abs(f - f0) < 1e-3 * f0 and n - 10 <= energies.size <= n   # the filter's ends cut ~7 passes
        want = cv * np.sqrt(1.0 + depth ** 2 / 2.0)               # the modulation scales the random part too
        assert abs(random_spread(energies) / want - 1.0) < 0.2, (depth, random_spread(energies), want)
    x, n = _impact_train(rng, cv)
    line = _textbook_line_over_floor_db(x, fs, f0)
    assert abs(line - ceiling_db(n, cv)) <= 2.0, (line, ceiling_db(n, cv))


def _windowed_train(rng, window, fr=29.93):
    """10 s of ``_impact_train`` (spread 0.3 in the log of the energy) at the 6205's measured BPFO under
    ``window(theta)``, and the shaft speed [Hz]."""
    x, _ = _impact_train(rng, np.sqrt(np.expm1(0.09)), seconds=10.0, f_fault=EFFECTIVE_6205["bpfo"] * fr, fr=fr,
                         window=window)
    return x, fr


def test_shaft_orders_tell_a_sharp_once_per_turn_window_from_a_smooth_one():
    """bench/shaft_orders.py: impacts under a smooth window (1 + 0.8 cos theta) keep 1x and lose the orders from
    3x on; under a sharp one (10x for a tenth of the turn) the orders 3x-6x and the fault line's sidebands stand
    >= 10 dB higher. The "FTF" reading of such a train is its |BPFO - 4 f_r| line: the same line of the spectrum."""
    from shaft_orders import levels

    rng = np.random.default_rng(5)
    x, fr = _windowed_train(rng, lambda th: 1.0 + 0.8 * np.cos(th))
    smooth = levels(x, 12000.0, fr, EFFECTIVE_6205, "outer")
    x, fr = _windowed_train(rng, lambda th: np.where(np.cos(th) > 0.951, 10.0, 1.0))
    sharp = levels(x, 12000.0, fr, EFFECTIVE_6205, "outer")
    assert smooth["orders"][0] > 20.0 and max(smooth["orders"][2:]) < 15.0, smooth["orders"]
    assert min(np.subtract(sharp["orders"][2:], smooth["orders"][2:])) >= 10.0, (sharp["orders"], smooth["orders"])
    assert min(np.subtract(sharp["sidebands"][2:], smooth["sidebands"][2:])) >= 10.0
    assert sharp["ftf_hz"] == sharp["f4_hz"] and sharp["ftf"] > 20.0


def test_shaft_orders_of_a_record_without_a_race_pit_read_a_rolling_noise_that_follows_the_shaft():
    """bench/shaft_orders.py on a healthy or ball-fault record reads the shaft orders alone: a broadband noise whose
    power follows the shaft angle (1 + 0.5 cos theta, the depth of a load zone swung by a turning load) stands at 1x
    >= 15 dB over the SES floor, a stationary one under 10 dB at every order; the band's power over the turn reads
    the modulation's 3 : 1."""
    from shaft_orders import levels

    rng = np.random.default_rng(8)
    fs, fr = 12000.0, 29.93
    t = np.arange(int(10 * fs)) / fs
    noise = rng.standard_normal(t.size)
    follows = levels(noise * np.sqrt(1.0 + 0.5 * np.cos(2 * np.pi * fr * t)), fs, fr, EFFECTIVE_6205, "healthy")
    steady = levels(noise, fs, fr, EFFECTIVE_6205, "ball")
    assert set(follows) == set(steady) == {"orders", "turn", "x1_clipped"}
    assert follows["orders"][0] >= 15.0 and max(steady["orders"]) < 10.0, (follows, steady)
    # the band's power over the turn: 1.5 : 0.5 = 3 for the modulated noise (less its bins' scatter), ~1 steady
    assert 2.4 < follows["turn"] < 3.3 and steady["turn"] < 1.25, (follows["turn"], steady["turn"])

def test_the_clipped_1x_keeps_a_swinging_noise_and_drops_the_beat_of_lines_one_shaft_order_apart():
    """bench/shaft_orders.py's 1x with the lines clipped away: a noise whose power follows the shaft (1 + 0.3 cos)
    keeps its 1x; a stationary noise under two tones one shaft order apart in the band (each ~30 dB over the noise in
    its bin) has a strong 1x from their beat, and none once they are clipped."""
    from shaft_orders import levels

    rng = np.random.default_rng(11)
    fs, fr = 12000.0, 29.93
    t = np.arange(int(10 * fs)) / fs
    noise = rng.standard_normal(t.size)
    swing = levels(noise * np.sqrt(1.0 + 0.3 * np.cos(2 * np.pi * fr * t)), fs, fr, EFFECTIVE_6205, "healthy")
    tones = 0.2 * (np.cos(2 * np.pi * 100 * fr * t) + np.cos(2 * np.pi * 101 * fr * t))
    beat = levels(noise + tones, fs, fr, EFFECTIVE_6205, "healthy")
    assert swing["orders"][0] >= 12.0 and swing["x1_clipped"] >= swing["orders"][0] - 3.0, swing
    assert beat["orders"][0] >= 15.0 and beat["x1_clipped"] < 8.0, beat


def test_a_noise_that_follows_the_contacts_swings_with_the_turning_load_only(tmp_path):
    """bench/shaft_orders.py's estimate of a rolling noise that follows the contacts' stiffness (power ~ sum Q^(2/3))
    over the turn: constant without a load that turns with the shaft, swinging with the rig's coupling force, and
    a noise that swings by that much reads a 1x line that grows with the swing."""
    from shaft_orders import contact_swing, swinging_noise

    text = (ROOT / "bkabem_core" / "embedded" / "cases" / "cwru_rig.toml").read_text()
    assert "coupling_force_n = 23.0" in text
    still = tmp_path / "still.toml"
    still.write_text(text.replace("coupling_force_n = 23.0", "coupling_force_n = 0.0"))
    assert contact_swing(str(still))["swing"] == pytest.approx(1.0, abs=1e-9)
    rig = contact_swing("cwru_rig")
    assert rig["turning_n"] > 20.0 and 1.05 < rig["swing"] < 2.0, rig
    weak, strong = swinging_noise(1.05, 5.0, 29.93), swinging_noise(1.5, 5.0, 29.93)
    assert strong["x1"] > weak["x1"] + 6.0 and strong["turn"] > weak["turn"], (weak, strong)

def test_the_ball_fold_reads_an_uneven_ball_set_and_nothing_where_the_balls_are_alike():
    """bench/shaft_orders.py's fold of pass energies over the balls: 9 balls whose energies differ by about 20 %
    under a pass-to-pass spread of 40 % read their spread within 25 %; alike balls read under 0.04."""
    from shaft_orders import ball_spread

    rng = np.random.default_rng(3)
    balls = 1.0 + 0.2 * rng.standard_normal(9)
    turns = 120
    noise = rng.lognormal(-0.5 * np.log1p(0.16), np.sqrt(np.log1p(0.16)), (turns, 9))
    uneven = (noise * balls).ravel()
    want = balls.std(ddof=1) / balls.mean()
    assert abs(ball_spread(uneven, 9) / want - 1.0) < 0.25, (ball_spread(uneven, 9), want)
    assert ball_spread(noise.ravel(), 9) < 0.04


@pytest.mark.parametrize("script", ["rig_low_band", "impact_spread", "shaft_orders", "rig_floor"])
def test_a_record_script_on_a_folder_without_records_says_so_in_one_line_and_exits_2(script, tmp_path, capsys):
    """bench/rig_low_band.py, bench/impact_spread.py, bench/shaft_orders.py and bench/rig_floor.py on a missing
    folder and on an empty one: exit 2, one line naming the argument, nothing written to the docs."""
    import importlib

    main = importlib.import_module(script).main
    for folder in (tmp_path / "missing", tmp_path):
        capsys.readouterr()
        assert main([str(folder), "--no-docs"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"{script}: data_dir: "), err


def test_the_input_floor_reader_recovers_a_white_floor_under_lines_and_a_resonant_floor():
    """bench/rig_floor.py's estimator on a synthetic record: white noise of density B through a known gain, a
    resonant floor that it subtracts, and tones that the median over lines ignores: B within the Welch estimate's
    spread (1024 averages of a 1 Hz PSD, well under 5 %)."""
    from rig_floor import input_floor_of
    from scipy import signal

    rng = np.random.default_rng(3)
    fs, n, b = 12000.0, 12000 * 60, 2e-3
    x = rng.standard_normal(n) * b * np.sqrt(fs / 2)                    # white, one-sided density b
    t = np.arange(n) / fs
    for f0 in (360.0, 1437.0, 4800.0):
        x += 0.05 * np.sin(2 * np.pi * f0 * t)                           # tones far over the floor
    sos = signal.butter(4, [2500.0, 3500.0], "bandpass", fs=fs, output="sos")
    x += signal.sosfilt(sos, rng.standard_normal(n)) * 0.5            # a resonant floor in 2.5-3.5 kHz
    f, p = signal.welch(x, fs, nperseg=int(fs))
    floor = np.zeros_like(f)
    gain2 = np.ones_like(f)
    got = np.sqrt(input_floor_of(f, p, floor, gain2))
    assert abs(got / b - 1.0) < 0.05, got
    # a gain the chain puts on it is divided out
    assert abs(np.sqrt(input_floor_of(f, 4.0 * p, floor, 4.0 * gain2)) / b - 1.0) < 0.05
