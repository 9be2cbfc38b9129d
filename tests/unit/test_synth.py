"""Tests of bkabem_core.synth.synthesizer / bkabem_ros.cli.synth: accuracy against BKA-BEM, continuity, determinism, errors, CLI.

The BKA-BEM model comes from the session fixture ``model`` (tests/conftest.py), built once.
"""

from __future__ import annotations

import json
import math
import tracemalloc

import numpy as np
import pytest

from bkabem_core.model.vocabulary import DIRECTIONS
from bkabem_core.solve.harmonic import TWO_PI
from bkabem_core.synth.channels import _combination, make_channels
from bkabem_core.synth.plan import LineSpectrum, choose_method
from bkabem_core.synth.randomness import SlipWalk
from bkabem_core.synth.synthesizer import (
    SpeedProfile,
    SynthError,
    Synthesizer,
    parse_profile,
    waveform_features,
)


def render(synth, profile, seconds):
    return np.concatenate([c.samples for c in synth.render(profile, seconds)], axis=1)


def reference(model, synth, speed_hz):
    """Exact BKA-BEM complex amplitudes (K, C) of the synthesiser's channels, and the DC (C,)."""
    sp = model.spectrum(speed_hz)
    w = TWO_PI * sp.frequency_hz
    locs = {"de": 0, "nde": 2}
    cols, dc = [], []
    for c in synth.channels:
        li, di = locs[c.bearing], DIRECTIONS.index(c.direction)
        x_h = sp.displacement[:, li + 1, di]
        if c.quantity == "acceleration":
            cols.append(-(w ** 2) * x_h)
            dc.append(0.0)
        elif c.quantity == "velocity":
            cols.append(1j * w * x_h * 1e3)
            dc.append(0.0)
        else:
            cols.append(sp.displacement[:, li, di] - x_h)
            dc.append(sp.dc_m[li, di] - sp.dc_m[li + 1, di])
    return np.array(cols).T, np.array(dc)


# ----------------------------------------------------------------------------------------- accuracy
@pytest.mark.parametrize("spectrum", ["exact", "modal"])
def test_constant_speed_fft_reproduces_bka_bem(model, spectrum):
    """FFT of 1 s at constant speed: every order within 0.5 % (amplitude and phase) of the exact BKA-BEM solve.

    BPFO = 157 Hz exactly and 1 s: each order sits on an FFT bin; the wavetable's interpolation images (-86 dB)
    fall between the order bins at this speed (docs/synthesis.md)."""
    bpfo = 157
    f = bpfo / model.bpfo_per_hz
    s = Synthesizer(model, sample_rate_hz=51200, spectrum=spectrum,
                    quantities=("acceleration", "displacement", "velocity"), strikes=False)
    x = render(s, f"constant:{f!r}", 1.0).astype(float)
    assert x.shape == (12, 51200)
    spec = np.fft.rfft(x, axis=1) / x.shape[1]
    got = 2 * spec[:, bpfo * s.orders].T
    ref, dc = reference(model, s, f)
    ls = s.line_spectrum(f)                                 # the public view of the same lines
    np.testing.assert_allclose(ls["amplitude"], ref, rtol=1e-9 if spectrum == "exact" else 5e-3,
                               atol=1e-12 if spectrum == "exact" else 5e-3 * np.abs(ref).max())
    np.testing.assert_allclose(ls["dc"], dc, rtol=1e-9, atol=1e-15)
    amp = np.abs(ref)
    big = amp >= 0.01 * amp.max(axis=0)                     # orders within 40 dB of the channel's largest
    rel = np.abs(got - ref) / amp
    assert rel[big].max() < 5e-3, rel[big].max()
    assert np.abs(np.angle(got / ref))[big].max() < 5e-3
    assert (np.abs(got - ref) / amp.max(axis=0)).max() < 5e-5   # every order, relative to the largest
    np.testing.assert_allclose(spec[:, 0].real, dc, atol=1e-6 * np.abs(ref).max(axis=0).max())


def test_modal_spectrum_error_bound(model):
    """The stated bound of spectrum="modal" against BkaBem.response (docs/synthesis.md): every order within 1e-5
    of its channel's largest order, for displacement and acceleration weighting, at speeds from min_speed_hz up.
    No speed grid: random speeds, the 50.607 Hz that the old speed-grid form got worst, and the lowest speeds."""
    chans = make_channels()
    comb, *_ = _combination(chans)
    modal = LineSpectrum(model, comb, "modal")
    speeds = np.concatenate([[0.05, 0.1, 0.5, 50.607], np.random.default_rng(11).uniform(1.0, 75.0, 20)])
    exact = model.response(speeds).reshape(speeds.size, model.orders.size, -1) @ comb.T
    worst = 0.0
    for i, f in enumerate(speeds):
        w = TWO_PI * model.bpfo_per_hz * f * model.orders
        for scale in (np.ones_like(w), w ** 2):             # displacement and acceleration weighting
            a = modal(f) * scale[:, None]
            b = exact[i] * scale[:, None]
            worst = max(worst, float(np.max(np.abs(a - b).max(0) / np.abs(b).max(0))))
    assert worst < 1e-5, worst
    assert modal._check(modal.cells, 33.3) < 1e-6          # float32 residues in the C kernel: ~1e-7
    assert model.order_modal_form(comb).speed_cells() is modal.cells    # made once per model and combination


def test_order_modal_form_matches_the_direct_solver(model):
    """OrderModalForm (all 8 output displacements) against the dense direct solve of the full FE, with gyroscopics:
    the order-wise pencil K + s C + s^2 (M - i G / (k BPFO)) is the same system as Eq. (8) along each order (on the
    reduced model: its modal truncation is the 1e-7 left, tests/unit/test_harmonic.py)."""
    from bkabem_core.solve.harmonic import BkaBem as _B
    direct = _B(model.case, excitation=model.excitations, solver="direct", machine=model.machine)
    form = direct.order_modal_form()
    assert np.abs(direct.rotor.G).max() > 0
    for f in (3.7, 41.0):
        ref = direct.response([f])[0].reshape(model.orders.size, -1)
        got = form(f)
        assert np.abs(got - ref).max() <= 1e-6 * np.abs(ref).max(), np.abs(got - ref).max() / np.abs(ref).max()
    assert np.abs(form.direct).max() <= 1e-9 * np.abs(ref).max()


def test_velocity_is_acceleration_over_i_omega(model):
    # every strike alike: a random strike strength modulates both channels in time, which mixes the bins
    s = Synthesizer(model, sample_rate_hz=25600, quantities=("acceleration", "velocity"), strikes=False)
    f = 151.0 / model.bpfo_per_hz
    x = render(s, f"constant:{f!r}", 1.0).astype(float)
    spec = 2 * np.fft.rfft(x, axis=1)[:, 151 * s.orders].T / x.shape[1]
    names = list(s.channel_names)
    acc, vel = spec[:, names.index("de_vertical_acceleration")], spec[:, names.index("de_vertical_velocity")]
    w = TWO_PI * 151.0 * s.orders
    np.testing.assert_allclose(vel, acc / (1j * w) * 1e3, rtol=2e-3, atol=1e-4 * np.abs(vel).max())
    assert s.units[names.index("de_vertical_velocity")] == "mm/s"


# ----------------------------------------------------------------------------------------- invariance, seeds
def test_chunk_size_invariance_with_slip_and_noise(model):
    kw = dict(sample_rate_hz=25600, slip=0.02, noise_density={"acceleration": 1e-3, "displacement": 1e-9}, seed=3)
    ref = render(Synthesizer(model, chunk_s=0.1, **kw), "ramp:5:30:1", 1.0)
    for chunk in (0.037, 0.25, 1.0):
        x = render(Synthesizer(model, chunk_s=chunk, **kw), "ramp:5:30:1", 1.0)
        np.testing.assert_array_equal(x, ref)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_c_loop_and_numpy_reference_give_the_same_run(model, dtype):
    """Through a whole streamed run with speed changes, slip and noise: the per-family C sample loop and its numpy
    reference (the fallback without a compiler) give the same samples bit for bit; the fused line-set kernels
    (float32; for float64 the loop itself) agree within float32 rounding (a few units of 2^-24 of the channel's
    largest value); features within the float block sums' round-off."""
    from bkabem_core.synth import kernel as synth_kernel

    assert synth_kernel.AVAILABLE and synth_kernel.LINES_AVAILABLE
    kw = dict(sample_rate_hz=25600, chunk_s=0.05, slip=0.01, seed=4, dtype=dtype,
              noise_density={"acceleration": 1e-3, "displacement": 1e-9}, spectrum="exact")
    fused, loop, ref = (Synthesizer(model, kernel=k, **kw) for k in ("auto", "loop", "reference"))
    from bkabem_core.synth.render import FusedLines, LoopLines
    assert isinstance(fused._plan.lines_kernel, FusedLines if dtype == np.float32 else LoopLines)
    for f in (12.0, 12.0, 13.7, 15.1, 14.2, 14.2):
        a, b, c = fused.next_chunk(f), loop.next_chunk(f), ref.next_chunk(f)
        np.testing.assert_array_equal(b.samples, c.samples)
        top = np.abs(c.samples).max(axis=1, keepdims=True)
        tol = 64 * np.finfo(np.float32).eps if dtype == np.float32 else 1e-12
        assert np.all(np.abs(a.samples - c.samples) <= tol * top)
        for name in ("rms", "peak", "peak_to_peak", "kurtosis"):
            np.testing.assert_allclose(a.features[name], c.features[name], rtol=1e-4)
            np.testing.assert_allclose(b.features[name], c.features[name], rtol=1e-9)


def test_seed_determinism(model):
    kw = dict(sample_rate_hz=25600, slip=0.015, noise_density={"acceleration": 1e-3})
    a = render(Synthesizer(model, seed=7, **kw), "constant:20", 0.3)
    b = render(Synthesizer(model, seed=7, **kw), "constant:20", 0.3)
    c = render(Synthesizer(model, seed=8, **kw), "constant:20", 0.3)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    # the same synthesiser twice gives the same run
    s = Synthesizer(model, seed=7, **kw)
    np.testing.assert_array_equal(render(s, "constant:20", 0.3), render(s, "constant:20", 0.3))
    # noise only: the difference of two seeds is noise of the stated RMS (density * sqrt(fs / 2))
    n1 = render(Synthesizer(model, sample_rate_hz=25600, seed=1, noise_density={"acceleration": 1e-3},
                            strikes=False), "constant:20", 0.5)
    n0 = render(Synthesizer(model, sample_rate_hz=25600, strikes=False), "constant:20", 0.5)
    d = (n1 - n0)[0].astype(float)
    assert abs(d.std() / (1e-3 * math.sqrt(12800)) - 1) < 0.03
    np.testing.assert_array_equal((n1 - n0)[2], 0)          # displacement had no noise density


def test_snr_noise_level(model):
    clean = render(Synthesizer(model, sample_rate_hz=25600, dtype=np.float64, strikes=False), "constant:20", 0.5)
    noisy = render(Synthesizer(model, sample_rate_hz=25600, dtype=np.float64, snr_db=20.0, seed=2, strikes=False),
                   "constant:20", 0.5)
    d = (noisy - clean).std(axis=1)
    sig = (clean - clean.mean(axis=1, keepdims=True)).std(axis=1)
    np.testing.assert_allclose(d / sig, 0.1, rtol=0.05)


def test_slip_model_statistics():
    walk = SlipWalk(0.02, seed=5)
    w = walk.values(0, 40000)
    inter = 1 - np.diff(w)                                   # inter-arrival in nominal ball passes
    assert abs(inter.mean() - 1) < 1e-3
    assert abs(inter.std() / 0.02 - 1) < 0.03
    # the warp is C1 and monotonic: v = u + W(u)
    u = np.linspace(0, 200, 200001)
    v = u + walk.warp(0, u)
    dv = np.diff(v) / np.diff(u)
    assert dv.min() > 0.8 and dv.max() < 1.2
    assert np.abs(np.diff(dv)).max() < 1e-3                  # no slope jumps at the integer knots
    # blocks are independent of how they are requested
    w2 = SlipWalk(0.02, seed=5)
    np.testing.assert_array_equal(w2.values(30000, 30010), w[30000:30011])


def test_slip_perturbs_ball_passes(model):
    f = 25.0
    clean = render(Synthesizer(model, sample_rate_hz=25600), f"constant:{f}", 2.0)[2].astype(float)
    slip = render(Synthesizer(model, sample_rate_hz=25600, slip=0.02, seed=1), f"constant:{f}", 2.0)[2].astype(float)
    assert not np.allclose(clean, slip)
    # the order-1 line spreads: its peak drops while the total power stays
    def order1_peak(x):
        spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(x.size)))
        freq = np.fft.rfftfreq(x.size, 1 / 25600)
        b = model.bpfo_per_hz * f
        return spec[np.argmin(abs(freq - b))], np.sqrt(np.sum(spec ** 2))
    p0, e0 = order1_peak(clean)
    p1, e1 = order1_peak(slip)
    assert p1 < 0.8 * p0
    assert abs(e1 / e0 - 1) < 0.1


# ----------------------------------------------------------------------------------------- continuity, speed
def test_continuity_at_chunk_borders_with_speed_changes(model):
    s = Synthesizer(model, sample_rate_hz=25600, chunk_s=0.02)
    rng = np.random.default_rng(0)
    sp, parts, idx = 20.0, [], []
    for _ in range(50):
        sp = max(5.0, sp + rng.normal(0, 0.5))
        ch = s.next_chunk(sp)
        idx.append(ch.first_sample_index)
        parts.append(ch.samples)
    assert idx == list(range(0, 50 * 512, 512))
    x = np.concatenate(parts, axis=1).astype(float)
    d2 = np.abs(x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2])      # second difference centred on sample j + 1
    border = np.arange(512, x.shape[1] - 1, 512) - 1
    interior = np.delete(d2, border, axis=1)
    for c in range(x.shape[0]):
        assert d2[c, border].max() <= interior[c].max(), s.channel_names[c]          # a border is no outlier
        assert np.median(d2[c, border]) <= 2 * np.median(interior[c]), s.channel_names[c]
    d1 = np.abs(np.diff(x, axis=1))
    assert (d1[:, border] <= d1.max(axis=1, keepdims=True)).all()


def test_streaming_equals_rendering_the_same_profile(model):
    # steps <= max_speed_step_hz add one knot (one segment per chunk), larger ones are subdivided
    speeds = [20.0, 21.0, 23.0, 22.5, 22.5, 22.8, 22.6, 0.0, 3.0, 25.0]
    s = Synthesizer(model, sample_rate_hz=25600, chunk_s=0.02)
    chunks = [s.next_chunk(v) for v in speeds]
    x1 = np.concatenate([c.samples for c in chunks], axis=1)
    assert [c.shaft_speed_hz for c in chunks] == pytest.approx([20.0] + speeds[:-1])
    prof = SpeedProfile.from_points([0.0] + [0.02 * (i + 1) for i in range(len(speeds))], [20.0] + speeds)
    x2 = render(Synthesizer(model, sample_rate_hz=25600, chunk_s=0.05, knot_s=0.02), prof, 0.02 * len(speeds))
    np.testing.assert_array_equal(x1, x2)


def test_bpfo_follows_a_ramp(model):
    """Short-time FFT of the shaft displacement (order 1 dominates): the peak tracks BPFO(t) of the ramp."""
    fs = 25600
    s = Synthesizer(model, sample_rate_hz=fs, chunk_s=0.1)
    x = render(s, "ramp:10:40:2", 2.0)[s.channel_names.index("de_vertical_displacement")].astype(float)
    win = 2048
    for start in range(0, x.size - win, 2048):
        seg = x[start:start + win]
        spec = np.abs(np.fft.rfft((seg - seg.mean()) * np.hanning(win), 16 * win))
        freq = np.fft.rfftfreq(16 * win, 1 / fs)
        t_mid = (start + win / 2) / fs
        bpfo = model.bpfo_per_hz * (10 + 15 * t_mid)
        band = (freq > 0.7 * bpfo) & (freq < 1.3 * bpfo)
        peak = freq[band][np.argmax(spec[band])]
        assert abs(peak / bpfo - 1) < 0.01, (t_mid, peak, bpfo)
    # phase bookkeeping: the cage angle at each chunk start is the integral of the speed
    for c in Synthesizer(model, sample_rate_hz=fs).render("ramp:10:40:2", 2.0):
        t = c.t0_s
        revs = 10 * t + 7.5 * t * t if t < 2 else 10 * 2 + 7.5 * 4 + 40 * (t - 2)
        expect = (TWO_PI * revs * model.fault_multipliers.ftf) % TWO_PI
        assert abs(np.angle(np.exp(1j * (c.cage_angle_rad - expect)))) < 1e-9
        assert c.shaft_speed_hz == pytest.approx(10 + 15 * t)


def test_zero_and_low_speed_static_part_only(model):
    s = Synthesizer(model, sample_rate_hz=25600)
    chunks = list(s.render("constant:0", 0.3))
    x = np.concatenate([c.samples for c in chunks], axis=1)
    assert np.isfinite(x).all()
    names = list(s.channel_names)
    _, dc = reference(model, s, 0.0)
    for i, n in enumerate(names):
        np.testing.assert_allclose(x[i], dc[i], rtol=1e-6, atol=0)
    f = chunks[-1].features
    for k in ("rms", "peak", "crest_factor", "kurtosis"):
        assert np.isfinite(f[k]).all()
        np.testing.assert_allclose(f[k], 0.0, atol=1e-9)
    # below the threshold too, and a ramp through zero stays finite
    y = render(Synthesizer(model, sample_rate_hz=25600, min_speed_hz=0.05), "constant:0.04", 0.1)
    np.testing.assert_allclose(y, np.broadcast_to(dc[:, None], y.shape), rtol=1e-6)
    z = render(Synthesizer(model, sample_rate_hz=25600), "ramp:0:5:0.5", 1.0)
    assert np.isfinite(z).all()


def test_taper_mode_drops_orders_near_nyquist_without_aliasing(model):
    bpfo, fs = 157, 12800                                   # orders 41..50 are above Nyquist
    f = bpfo / model.bpfo_per_hz
    with pytest.raises(SynthError, match="sample_rate_hz"):
        Synthesizer(model, sample_rate_hz=fs, band_limit="error").render(f"constant:{f!r}", 1.0)
    s = Synthesizer(model, sample_rate_hz=fs, band_limit="taper", spectrum="exact", strikes=False)
    x = render(s, f"constant:{f!r}", 1.0).astype(float)
    spec = np.fft.rfft(x, axis=1) / x.shape[1]
    ref, _ = reference(model, s, f)
    r = s.orders * bpfo / (fs / 2)
    full = r <= 0.85
    got = 2 * spec[:, bpfo * s.orders[s.orders * bpfo < fs / 2]].T
    np.testing.assert_allclose(got[full[:got.shape[0]]], ref[full], rtol=5e-3, atol=1e-5 * np.abs(ref).max())
    assert np.all(np.abs(got[r[:got.shape[0]] >= 0.95]) < 1e-6 * np.abs(ref).max(axis=0))   # float32 floor
    on_order = np.zeros(spec.shape[1], bool)
    on_order[bpfo * np.arange(0, fs // 2 // bpfo + 1)] = True
    off = np.abs(spec[:, ~on_order]) ** 2
    assert off.sum() < 1e-6 * (np.abs(spec) ** 2).sum()      # nothing aliased (images of the table: ~1e-8)


# ----------------------------------------------------------------------------------------- features, ground truth
def test_features_and_iso_velocity(model):
    f = 25.0
    s = Synthesizer(model, sample_rate_hz=25600, chunk_s=1.0, strikes=False)    # the lines' RMS, not a draw
    ch = next(iter(s.render(f"constant:{f}", 1.0)))
    ref, dc = reference(model, s, f)
    rms = np.sqrt(0.5 * np.sum(np.abs(ref) ** 2, axis=0))
    np.testing.assert_allclose(ch.features["rms"], rms, rtol=0.02)
    assert np.all(np.abs(ch.features["mean"] - dc) <= 1e-3 * np.abs(dc) + 1e-2 * rms)   # 151.5 passes
    x = ch.samples.astype(float)
    i = 0
    assert ch.features["peak"][i] == pytest.approx(np.abs(x[i] - x[i].mean()).max(), rel=1e-4)
    assert ch.features["peak_to_peak"][i] == pytest.approx(np.ptp(x[i]), rel=1e-4)
    assert ch.features["crest_factor"][i] == pytest.approx(ch.features["peak"][i] / ch.features["rms"][i])
    k = ((x[i] - x[i].mean()) ** 4).mean() / x[i].var() ** 2
    assert ch.features["kurtosis"][i] == pytest.approx(k, rel=1e-3)
    assert ch.features["kurtosis"][i] > 3                   # impulsive, not a sine (1.5)
    # ISO 10816: housing velocity RMS in 10-1000 Hz from the order amplitudes
    sp = model.spectrum(f)
    band = (sp.frequency_hz >= 10) & (sp.frequency_hz <= 1000)
    for b, li in (("de", 1), ("nde", 3)):
        for di, d in enumerate(DIRECTIONS):
            v = np.sqrt(0.5 * np.sum(np.abs(sp.velocity[band, li, di]) ** 2)) * 1e3
            assert ch.features["iso10816_velocity_rms_mm_s"][b][d] == pytest.approx(v, rel=1e-6)
    # features of a large-DC signal keep their precision in float32 (offset removed first)
    t = np.arange(4096)
    y = (np.stack([1e-3 + 1e-7 * np.sin(0.01 * t)] * 2, axis=1)).astype(np.float32)
    ft = waveform_features(y, np.array([1e-3, 0.0]))
    assert ft["rms"][0] == pytest.approx(1e-7 / math.sqrt(2), rel=1e-2)
    assert ft["kurtosis"][0] == pytest.approx(1.5, rel=2e-2)


def test_chunk_metadata_and_ground_truth(model, case):
    s = Synthesizer(model, sample_rate_hz=25600, chunk_s=0.05, seed=42, slip=0.01)
    chunks = list(s.render("ramp:10:20:0.2", 0.2))
    assert [c.first_sample_index for c in chunks] == [0, 1280, 2560, 3840]
    c = chunks[2]
    assert c.t0_s == pytest.approx(0.1)
    assert c.sample_rate_hz == 25600
    assert c.samples.shape == (8, 1280) and c.samples.dtype == np.float32
    assert c.channel_names[0] == "de_vertical_acceleration" and c.units[0] == "m/s^2"
    assert c.rows("nde", "displacement") == [6, 7]
    assert c.shaft_speed_hz == pytest.approx(15.0)
    gt = c.ground_truth
    assert gt["case_hash"] == case.case_hash and gt["seed"] == 42 and gt["slip_std_fraction"] == 0.01
    assert gt["bearing_designation"] == "6010"
    assert gt["defect"]["bearing"] == "de" and gt["defect"]["depth_m"] == pytest.approx(50e-6)
    fm = model.fault_multipliers
    for k in ("ftf", "bpfo", "bpfi", "bsf"):
        assert gt["fault_frequencies_hz"][k] == pytest.approx(getattr(fm, k) * 15.0)
    d = c.to_dict()
    json.dumps(d)
    assert d["features"]["rms"]["de_vertical_acceleration"] == pytest.approx(float(c.features["rms"][0]))


def test_memory_bounded_by_chunk(model):
    def peak(seconds):
        s = Synthesizer(model, sample_rate_hz=25600, chunk_s=0.1, slip=0.01, noise_density={"acceleration": 1e-3})
        gen = s.render("steps:20,22,21,23:0.5", seconds)
        next(gen)
        tracemalloc.start()
        for _ in gen:
            pass
        p = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return p, len(s._stream.knots)
    p1, k1 = peak(2.0)
    p2, k2 = peak(20.0)
    assert p2 < 1.3 * p1 + 2e6, (p1, p2)
    assert k2 <= k1 + 2


def test_set_model_keeps_phase_continuous(model, case):
    from bkabem_core.solve.harmonic import BkaBem

    s = Synthesizer(model, sample_rate_hz=25600, chunk_s=0.05)
    a = s.next_chunk(20.0)
    deeper = BkaBem(case.with_overrides({"dent.depth_m": 30e-6}), excitation=None)
    s.model = deeper                                        # same as s.set_model(deeper)
    assert s.model is deeper
    b = s.next_chunk(20.0)
    c = s.next_chunk(20.0)
    x = np.concatenate([a.samples, b.samples, c.samples], axis=1).astype(float)
    assert b.first_sample_index == 1280 and np.isfinite(x).all()
    d2 = np.abs(np.diff(x, 2, axis=1))
    assert d2[:, 1278].max() <= np.percentile(d2, 99.9)     # the border sample is not special
    assert c.ground_truth["defect"]["depth_m"] == pytest.approx(30e-6)


def test_spectrum_auto_choice(model):
    from bkabem_core.solve.harmonic import BkaBem as _B
    fresh = _B(model.case, excitation=model.excitation)     # no modal form made yet
    s = Synthesizer(fresh, sample_rate_hz=25600)
    list(s.render("constant:25", 0.1))
    assert s.spectrum_method == "exact"                     # one knot: the modal set-up does not pay off
    comb = s._plan.channels.combination
    assert choose_method(fresh, comb, SpeedProfile.ramp(0, 50, 10), 10.0, s.knot_s, s.max_speed_step_hz) == "exact"
    hour = SpeedProfile.from_points([0, 3600], [24.0, 26.0])
    assert choose_method(fresh, comb, hour, 3600.0, s.knot_s, s.max_speed_step_hz) == "modal"   # 36 000 knots
    s2 = Synthesizer(fresh, sample_rate_hz=25600)
    s2.next_chunk(25.0)
    assert s2.spectrum_method == "modal"                    # streaming: modal (made once for the model) ...
    s3 = Synthesizer(fresh, sample_rate_hz=25600)
    list(s3.render("constant:25", 0.1))
    assert s3.spectrum_method == "modal"                    # ... and then free for every later run


# ----------------------------------------------------------------------------------------- profiles, errors
def test_profiles(tmp_path):
    p = parse_profile("ramp:0:50:10")
    assert p.speed_hz(5.0) == pytest.approx(25.0) and p.speed_hz(20.0) == pytest.approx(50.0)
    assert parse_profile("constant:25").speed_hz(3.0) == 25.0
    st = parse_profile("steps:10,20:1")
    assert st.speed_hz(0.5) == 10 and st.speed_hz(1.5) == 20
    f = tmp_path / "rpm.csv"
    f.write_text("# comment\ntime_s,speed_rpm\n0,600\n2,1200\n")
    q = parse_profile(str(f))
    assert q.speed_hz(1.0) == pytest.approx(15.0)
    g = tmp_path / "plain.csv"
    g.write_text("1,10\n3,30\n")
    r = parse_profile(str(g))
    assert r.speed_hz(0.0) == 10 and r.speed_hz(2.0) == pytest.approx(20.0)


@pytest.mark.parametrize("spec, arg", [
    ("bogus:3", "profile"), ("constant:nan", "profile.speed_hz"), ("constant:-1", "profile.speed_hz"),
    ("ramp:0:10:-1", "profile.duration_s"), ("ramp:0:10", "profile"), ("constant:abc", "profile.speed_hz"),
    ("", "profile"), ("steps::1", "profile"),
])
def test_bad_profiles(spec, arg):
    with pytest.raises(SynthError) as ei:
        parse_profile(spec)
    assert ei.value.argument == arg
    assert str(ei.value).startswith(arg + ":")


def test_bad_csv_profiles(tmp_path):
    cases = {"0,10\n0,20\n": "strictly increasing", "time_s,speed_furlongs\n0,1\n": "speed unit",
             "0,nan\n": "finite", "0,-5\n": ">= 0", "time_ms,speed_hz\n0,1\n": "seconds"}
    for i, (text, msg) in enumerate(cases.items()):
        f = tmp_path / f"p{i}.csv"
        f.write_text(text)
        with pytest.raises(SynthError, match=msg):
            parse_profile(str(f))


def test_bad_arguments(model):
    cases = [
        (dict(sample_rate_hz=-1), "sample_rate_hz"), (dict(sample_rate_hz=float("nan")), "sample_rate_hz"),
        (dict(chunk_s=0), "chunk_s"), (dict(chunk_s=1e-9), "chunk_s"), (dict(slip=0.5), "slip"),
        (dict(slip=-0.1), "slip"), (dict(seed=-3), "seed"), (dict(quantities=("jerk",)), "quantities"),
        (dict(band_limit="maybe"), "band_limit"), (dict(max_order=0), "max_order"),
        (dict(noise_density={"acceleration": -1}), "noise_density.acceleration"),
        (dict(noise_density={"acceleration": 1e-3}, snr_db=20), "noise"), (dict(table_size=1000), "table_size"),
    ]
    for kw, arg in cases:
        with pytest.raises(SynthError) as ei:
            Synthesizer(model, **kw)
        assert ei.value.argument == arg, kw
    s = Synthesizer(model, sample_rate_hz=25600, band_limit="error")
    for secs in (-1.0, 0.0, float("nan"), 1e-9):
        with pytest.raises(SynthError, match="^seconds:"):
            s.render("constant:10", secs)
    with pytest.raises(SynthError, match="^sample_rate_hz: .*twice the highest kept line"):
        s.render("ramp:0:50:10", 10.0)                      # order 50 reaches 15.1 kHz > 12.8 kHz
    # a lower max_order fits the same rate
    list(Synthesizer(model, sample_rate_hz=25600, max_order=40).render("constant:50", 0.05))
    for bad in (float("nan"), -2.0, "fast"):
        with pytest.raises(SynthError, match="^speed_hz:"):
            s.next_chunk(bad)
    with pytest.raises(SynthError, match="^speed_hz: .*twice"):
        s.next_chunk(60.0)
    assert s.next_sample_index == 0                         # rejected updates leave the stream untouched
    s.next_chunk(10.0)
    assert s.next_sample_index == 2560


# ----------------------------------------------------------------------------------------- CLI


def test_synthesisers_of_one_model_share_the_exact_response_and_give_the_same_samples(model):
    """Issue 15: the synthesisers of one model (the machines of a fleet process that run one case) share the
    exact-response cache, so a speed step that several of them follow is solved once per process; sharing changes
    no sample: a run served from a cache that other synthesisers filled (and used) equals, bit for bit, the same
    run with a cache of its own."""
    from bkabem_core.synth.plan import ExactSpectrum

    kw = dict(sample_rate_hz=25600, chunk_s=0.1, seed=5, spectrum="exact", band_limit="taper", features=False)
    ExactSpectrum._shared.pop(id(model), None)
    alone = render(Synthesizer(model, **kw), "ramp:5:30:1", 1.0)
    ExactSpectrum._shared.pop(id(model), None)              # a fresh shared cache from here on
    a, b = Synthesizer(model, **kw), Synthesizer(model, **kw)
    assert a._plan.spectrum.exact._cache is b._plan.spectrum.exact._cache
    calls = []
    orig = model.response

    def counting(speeds):
        calls.append(float(np.atleast_1d(speeds)[0]))
        return orig(speeds)

    model.response = counting
    try:
        for f in (0.0, 25.0, 25.0, 40.0):
            ca, cb = a.next_chunk(f), b.next_chunk(f)
            np.testing.assert_array_equal(ca.samples, cb.samples)
        assert calls and len(calls) == len(set(calls))       # each knot speed solved once for both machines
        np.testing.assert_array_equal(render(Synthesizer(model, **kw), "ramp:5:30:1", 1.0), alone)
        n = len(calls)
        np.testing.assert_array_equal(render(Synthesizer(model, **kw), "ramp:5:30:1", 1.0), alone)
        assert len(calls) == n                               # the second run came from the cache alone
    finally:
        del model.response
