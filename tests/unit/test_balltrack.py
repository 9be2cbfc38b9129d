"""A ball defect as it is (bkabem_core.synth.balltrack): the spin axis's walk on the sphere, the pit's share of the
contact track, the gate of the ball-defect lines at the knots, the spin slip; seeded, chunk-invariant, and what an
envelope analysis then sees.

The diagnostics are textbook ones written here: sample autocorrelation, Kolmogorov-Smirnov against the uniform law,
Monte Carlo areas, the squared-envelope spectrum (band-pass by FFT mask, analytic signal, |.|^2, Hann-windowed
spectrum), a Lorentzian's half-power width.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from bkabem_core.model.case import Case, CaseError
from bkabem_core.synth.balltrack import AxisWalk, BallTrack, keep_knots, rho_of_sigma, sigma_for_correlation
from bkabem_core.synth.synthesizer import Synthesizer

FS, SPEED = 25600.0, 25.0


@pytest.fixture(scope="module")
def ball_models(fault_library, classic_ball, cached_model):
    """(default: wandering, spin slip; classic: the pit on the track; fast: a short correlation, 60 revolutions)."""
    fast = Case.load("motor_6010_ball").with_overrides({"defects.0.wander_revolutions": 60.0})
    return {"default": fault_library["ball"], "classic": classic_ball,
            "fast": cached_model(fast, like=fault_library["ball"])}


def _render(model, seconds, chunk_s=0.5, seed=1, slip=0.01, **kw):
    s = Synthesizer(model, FS, chunk_s, quantities=("acceleration",), slip=slip, seed=seed, features=False, **kw)
    return np.concatenate([c.samples for c in s.render(f"constant:{SPEED}", seconds)], axis=1), s


def _ses(x: np.ndarray, fs: float, band=(2000.0, 11000.0)):
    """Squared-envelope spectrum (power) of ``x`` in ``band`` [Hz]: FFT mask, analytic signal, |.|^2, Hann."""
    n = x.size
    spec = np.fft.fft(x - x.mean())
    f = np.fft.fftfreq(n, 1.0 / fs)
    spec[(np.abs(f) < band[0]) | (np.abs(f) > band[1])] = 0.0
    env = np.abs(np.fft.ifft(np.where(f > 0, 2.0 * spec, 0.0))) ** 2
    e = np.abs(np.fft.rfft((env - env.mean()) * np.hanning(n))) ** 2
    return np.fft.rfftfreq(n, 1.0 / fs), e


# --------------------------------------------------------------------------- the walk
def test_step_correlation_is_dawsons_formula():
    """rho(sigma) = E[cos |v|] of a 2-D Gaussian tangent step, against a Monte Carlo mean; and the inverse."""
    rng = np.random.default_rng(5)
    for sigma in (0.05, 0.3, 1.0):
        r = sigma * np.hypot(rng.standard_normal(400_000), rng.standard_normal(400_000))
        assert rho_of_sigma(sigma) == pytest.approx(np.cos(r).mean(), abs=4e-3)
    for tau in (1.0, 7.0, 150.0):
        assert rho_of_sigma(sigma_for_correlation(tau)) == pytest.approx(math.exp(-1.0 / tau), rel=1e-10)


def test_axis_walk_is_uniform_on_the_sphere_and_decorrelates_in_tau_steps():
    tau = 40.0
    n = AxisWalk(tau, seed=11).axes(0, 120_000)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    # uniform on the sphere: each coordinate uniform on [-1, 1] (Archimedes), tested on samples 4 tau apart
    for c in range(3):
        assert stats.kstest(n[::160, c], "uniform", args=(-1.0, 2.0)).pvalue > 1e-3
    # E[n_k . n_{k+l}] = exp(-l / tau): the sample autocorrelation, within 4 of its batch standard errors
    for lag in (1, 10, 40, 80):
        dots = np.einsum("ij,ij->i", n[:-lag], n[lag:])
        batches = dots[: dots.size // 50 * 50].reshape(50, -1).mean(axis=1)
        err = batches.std(ddof=1) / math.sqrt(batches.size)
        assert abs(dots.mean() - math.exp(-lag / tau)) < 4 * err + 1e-3, (lag, dots.mean(), err)


def test_axis_walk_is_seeded_and_replays():
    a, b = AxisWalk(100.0, 3), AxisWalk(100.0, 3)
    assert np.array_equal(a.axes(0, 3000), b.axes(0, 3000))
    assert np.array_equal(a.axes(2500, 2600), b.axes(2500, 2600))      # forward, then back: replayed
    assert np.array_equal(a.axes(10, 20), b.axes(10, 20))
    assert not np.allclose(AxisWalk(100.0, 4).axes(0, 10), a.axes(0, 10))
    with pytest.raises(ValueError, match="correlation_steps"):
        AxisWalk(0.4, 1)


# --------------------------------------------------------------------------- the pit in the track
def test_gain_is_the_share_of_the_pit_inside_the_track(ball_models):
    """Monte Carlo: points uniform in the round pit, the share within |y| <= a of the track, relative to a pit on
    the centre line; and the mean time on the track of a uniform axis, sin((a + r) / R)."""
    tr = BallTrack.of_model(ball_models["default"], ball_models["default"].lines.coefficients)
    r, a, big_r = tr.pit_radius_m, tr.half_width_m, tr.ball_radius_m
    assert 0.0 < a < big_r and r == pytest.approx(0.75e-3)
    rng = np.random.default_rng(2)
    rho, phi = r * np.sqrt(rng.random(400_000)), 2 * np.pi * rng.random(400_000)
    y = rho * np.sin(phi)
    centred = np.mean(np.abs(y) <= a)
    for s in (0.0, 0.3 * a, a, a + 0.5 * r, a + r, a + 1.2 * r):
        want = np.mean(np.abs(y + s) <= a) / centred
        assert tr.gain(math.sin(s / big_r)) == pytest.approx(want, abs=4e-3), s
    assert tr.gain(0.0) == 1.0 and tr.gain(1.0) == 0.0
    # a long walk's share of steps with the pit (partly) on the track
    n = AxisWalk(20.0, 8).axes(0, 200_000)[::5, 2]
    on = np.mean(tr.gain(n) > 0.0)
    assert on == pytest.approx(tr.in_track_fraction, abs=0.02)


def test_gated_lines_are_the_ball_defects_and_race_defects_have_no_track(fault_library):
    """The ball defect's lines (on the spin phase, or cage orders a perfect ball set has none of) are gated, the
    ball set's BPFO orders and the shaft's and supply's lines are not; a healthy machine and the race defects have
    no track at all (their samples: bench/hash_samples.py)."""
    m = fault_library["ball"]
    tr = BallTrack.of_model(m, m.lines.coefficients)
    c, z = m.lines.coefficients, m.n_balls
    assert np.array_equal(tr.gated, (c[:, 2] != 0) | (c[:, 1] % z != 0))
    assert not tr.gated[(c[:, 2] == 0) & (c[:, 1] % z == 0)].any() and tr.gated.sum() > 1000
    for kind in ("healthy", "outer", "inner"):
        assert BallTrack.of_model(fault_library[kind], fault_library[kind].lines.coefficients) is None
        assert Synthesizer(fault_library[kind], FS)._plan.track is None


def test_knots_carry_the_gain_of_the_walk_at_their_ball_pass(ball_models):
    """Every knot's ball-defect lines are its amplitudes times the gain of the walk at the knot's ball passes, the
    other lines untouched; the gain linear between the knots follows the walk's (within the knots' tolerance
    at the candidates, half a cage revolution apart); the knots between two spectra blend them linearly in
    time."""
    m = ball_models["fast"]
    s = Synthesizer(m, FS, 0.1, quantities=("acceleration",), seed=4, features=False)
    plan = s._plan
    tr = plan.track
    walk = AxisWalk(tr.correlation_steps, 4)
    gains, knots = [], []
    for _ in range(30):
        s.next_chunk(SPEED)
        knots += [k for k in s._stream.knots if not knots or k.x > knots[-1].x]
        for k in s._stream.knots:
            u = k.u_int + k.u_frac
            g = _walk_gain(tr, walk, u)
            base = k.base
            assert np.allclose(k.amp.y[tr.gated], g * base.y[tr.gated], rtol=1e-13, atol=0.0)
            assert np.array_equal(k.amp.y[~tr.gated], base.y[~tr.gated])
            assert np.allclose(k.amp.v_iso[tr.gated], g * base.v_iso[tr.gated], rtol=1e-13, atol=0.0)
            t = np.asarray(base.tables, dtype=np.float64)              # the ball's lines are whole families
            for sl, on in plan._gate_slices:
                want = g * t[sl] if on else t[sl]
                assert np.allclose(k.amp.tables[sl], want, rtol=1e-6, atol=1e-7 * np.abs(t).max())
            gains.append(g)
        for a, b, c in zip(s._stream.knots, s._stream.knots[1:], s._stream.knots[2:]):
            if b.base is not plan.amplitudes(b.f) and a.base is not b.base:      # b: a knot between spectra
                w = (b.x - a.x) / (c.x - a.x)
                assert np.allclose(b.base.y, a.base.y + w * (c.base.y - a.base.y), rtol=1e-12)
    assert len(set(gains)) > 5
    u = np.array([k.u_int + k.u_frac for k in knots])
    g = np.array([_walk_gain(tr, walk, v) for v in u])
    fine = np.arange(u[0], u[-1], tr.passes_per_step / 8)
    err = np.abs(np.interp(fine, u, g) - np.array([_walk_gain(tr, walk, v) for v in fine]))
    assert err.max() < 0.012, err.max()                     # the tolerance, and the steps' rounding to samples


def test_keep_knots_keeps_the_kinks_only():
    x = np.arange(9.0)
    assert keep_knots(x, np.zeros(9), 0.01) == []                           # the pit off the track: none
    assert keep_knots(x, 0.1 * x, 0.01) == []                               # a straight line: none
    g = np.array([0, 0, 0, 0.5, 1, 1, 1, 1, 1.0])
    assert keep_knots(x, g, 0.01) == [2, 4]                                 # the kinks
    assert keep_knots(x, g + np.array([0, 0.005, 0, 0, 0, 0, 0.009, 0, 0]), 0.01) == [2, 4]


def _walk_gain(track, walk, passes: float) -> float:
    """The gain at ``passes``: the pit's at the two steps around it, linear in between (the definition)."""
    steps = passes / track.passes_per_step
    k = int(math.floor(steps))
    g0, g1 = track.gain(walk.axes(k, k + 1)[:, 2])
    return float(g0 + (g1 - g0) * (steps - k))


# --------------------------------------------------------------------------- seeded, chunk-invariant
def test_samples_are_seeded_and_do_not_depend_on_the_chunks(ball_models):
    m = ball_models["fast"]
    kw = dict(noise_density={"acceleration": 1e-3})
    ref, _ = _render(m, 2.0, chunk_s=0.1, seed=9, **kw)
    for chunk_s in (0.037, 0.25, 1.0):
        x, _ = _render(m, 2.0, chunk_s=chunk_s, seed=9, **kw)
        assert np.array_equal(x, ref), chunk_s
    again, _ = _render(m, 2.0, chunk_s=0.1, seed=9, **kw)
    assert np.array_equal(again, ref)
    other, _ = _render(m, 2.0, chunk_s=0.1, seed=10, **kw)
    assert not np.allclose(other, ref)
    loop, _ = _render(m, 2.0, chunk_s=0.25, seed=9, kernel="loop", **kw)     # the per-family path: the same walks
    scale = np.abs(ref).max()
    assert np.max(np.abs(loop - ref)) <= 64 * np.finfo(np.float32).eps * scale


# --------------------------------------------------------------------------- what an envelope analysis sees
def test_envelope_2xbsf_is_weaker_and_smeared_than_with_the_pit_on_the_track(ball_models):
    """Squared-envelope spectra (2-11 kHz band) of 4-s runs, averaged over six seeds, each normalised to its mean
    over 5-1000 Hz: with the pit on the track 2 x BSF stands ~38 dB over the floor and ~90 % of the power within
    5 Hz of it is in the central +-0.3 Hz (a line, 1 % cage slip); with the default wander and spin slip it stands
    ~15-20 dB and spreads into a hump (measured: 16.5 dB, 26 %)."""
    out = {}
    for name in ("classic", "default"):
        m = ball_models[name]
        total = 0.0
        for seed in range(6):
            x, _ = _render(m, 4.0, seed=seed)
            f, e = _ses(x[0].astype(float), FS)
            total = total + e / e[(f > 5.0) & (f < 1000.0)].mean()
        v = 2.0 * m.fault_multipliers.bsf * SPEED
        floor = np.median(total[(f > 5.0) & (f < 1000.0)])
        near, core = np.abs(f - v) < 5.0, np.abs(f - v) < 0.3
        out[name] = (10 * np.log10(total[near].max() / floor), total[core].sum() / total[near].sum())
    assert out["classic"][0] > 30.0 and out["classic"][1] > 0.7, out
    assert out["default"][0] < out["classic"][0] - 10.0, out
    assert out["default"][1] < 0.5, out


def test_spin_slip_makes_2xbsf_a_lorentzian_and_leaves_the_cage_lines(fault_library, classic_ball, cached_model):
    """Spin slip alone (no wander, no cage slip): the envelope's 2 x BSF (harmonic 2 of the spin) is the Lorentzian
    of a phase random walk, of half-power width (2 pi 2 kappa sigma)^2 BPFO / (2 pi) (kappa = BSF / (FTF z) spin
    turns per ball pass; 3.46 Hz here; a least-squares Lorentzian fit to 24 averaged 2-s spectra measured 3.34 Hz);
    the cage line FTF stays a line."""
    from scipy.optimize import curve_fit

    sigma = 0.05
    case = classic_ball.case.with_overrides({"defects.0.spin_slip": sigma})
    m = cached_model(case, like=fault_library["ball"])
    fm = m.fault_multipliers
    kappa = fm.bsf / (fm.ftf * m.n_balls)
    want = (2 * np.pi * 2 * kappa * sigma) ** 2 * fm.bpfo * SPEED / (2 * np.pi)
    total = 0.0
    for seed in range(4):
        x, _ = _render(m, 12.0, chunk_s=1.0, seed=seed, slip=0.0)
        y = x[0].astype(float)
        seg = int(2 * FS)
        for i in range(6):
            f, e = _ses(y[i * seg:(i + 1) * seg], FS)
            total = total + e
    v = 2 * fm.bsf * SPEED
    near = np.abs(f - v) < 8.0

    def lorentzian(f_, a, f0, fwhm, c):
        return a / (1.0 + ((f_ - f0) / (0.5 * fwhm)) ** 2) + c

    p, _ = curve_fit(lorentzian, f[near], total[near], p0=[total[near].max(), v, 2.0, np.median(total[near])])
    assert want == pytest.approx(3.46, rel=0.01)
    assert p[2] == pytest.approx(want, rel=0.25), (p[2], want)
    assert p[1] == pytest.approx(v, abs=0.2)
    ftf = np.abs(f - fm.ftf * SPEED) < 2.0
    q = total[ftf]
    assert np.sum(q > 0.5 * q.max()) * (f[1] - f[0]) <= 1.0       # a line: the Hann main lobe of 0.5 Hz bins


# --------------------------------------------------------------------------- the case keys
def test_case_keys_are_checked():
    ball = Case.load("motor_6010_ball")
    assert ball.defects()[0].own == (("wander_revolutions", 900.0), ("spin_slip", 0.02), ("roughness_db", 15.0))
    assert ball.ground_truth()["defects"][0]["wander_revolutions"] == 900.0
    for key, value, match in (("wander_revolutions", 3.0, "one cage revolution"),
                              ("wander_revolutions", -1.0, "must be >= 0"),
                              ("spin_slip", 0.2, r"\[0, 0.1\]"), ("spin_slip", "x", "must be a number")):
        with pytest.raises(CaseError, match=match) as exc:
            ball.with_overrides({f"defects.0.{key}": value})
        assert exc.value.key == f"defects[0].{key}"
    outer = Case.load("motor_6010_outer")
    raw = outer.raw | {"defects": [dict(outer.raw["defects"][0], spin_slip=0.01)]}
    with pytest.raises(CaseError, match="only for race = 'ball'"):
        Case.from_dict(raw)


def test_a_data_set_varies_the_keys():
    """The keys are run parameters of a data set (their defaults in every ball run's case, labelled through the
    ground truth's defect entries)."""
    from bkabem_core.dataset.spec import DatasetSpec

    spec = DatasetSpec.from_toml("""
[dataset]
name = "wander"
schema_version = 1
seed = 1
[run]
fault = "ball"
duration_s = 0.1
[grid]
wander_revolutions = [0.0, 300.0]
spin_slip = [0.0, 0.03]
""")
    runs = spec.runs
    assert len(runs) == 4 and len({r.case_hash for r in runs}) == 4
    tables = [r.case_raw["defects"][0] for r in runs]
    assert {(t["wander_revolutions"], t["spin_slip"]) for t in tables} == {(0.0, 0.0), (0.0, 0.03), (300.0, 0.0),
                                                                          (300.0, 0.03)}
