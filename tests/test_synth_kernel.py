"""Tests of bkabem_core.synth_kernel: the C sample loop (_synthloop.c) against its numpy reference and against the
synthesiser, bit for bit; the running-moment features against waveform_features.

The kernel is built by ``pip install -e .``; these tests fail (not skip) when it is missing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bkabem_core import synth_kernel as sk
from bkabem_core.synth import _BLEND_LEVELS, _FRAC_BITS, _PHASE_OFFSET, Synthesizer, waveform_features

FS = 51200.0
PASSES_PER_SAMPLE = 151.0 / FS          # ball passes per sample at a typical speed


def test_kernel_is_built():
    assert sk.AVAILABLE, "bkabem_core/_synthloop.c is not built: run `pip install -e .`"


def test_constants_match_the_synthesiser():
    assert (sk.FRAC_BITS, sk.BLEND_LEVELS, sk.PHASE_OFFSET) == (_FRAC_BITS, _BLEND_LEVELS, _PHASE_OFFSET)


def _case(rng, dtype, n_table, c, m, blend, warp):
    ta = rng.standard_normal((n_table, c)).astype(dtype)
    tb = rng.standard_normal((n_table, c)).astype(dtype) if blend else None
    w = 1e-3 * rng.standard_normal(m) if warp else None
    length = m + rng.uniform(0.0, 3000.0)
    args = (float(rng.uniform(0.0, 50.0)),                             # xi0
            PASSES_PER_SAMPLE * rng.uniform(0.2, 2.0),                 # c1
            float(rng.uniform(-1e-9, 1e-9)),                           # c2
            float(rng.uniform(0.0, 1.0)),                              # u_frac
            w, ta, tb, _BLEND_LEVELS / length)
    return args


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n_table,c", [(2048, 8), (64, 3)])
@pytest.mark.parametrize("blend", [False, True])
@pytest.mark.parametrize("warp", [False, True])
@pytest.mark.parametrize("m", [1, 7, 5120])
def test_segment_equals_reference_bit_for_bit(dtype, n_table, c, blend, warp, m):
    rng = np.random.default_rng([n_table, c, blend, warp, m])
    for _ in range(3):
        args = _case(rng, dtype, n_table, c, m, blend, warp)
        big = np.full((m + 4, c), np.nan, dtype)
        got = big[2:2 + m]                                             # a row slice of a bigger buffer
        ref = np.empty((m, c), dtype)
        sk.segment(*args, got)
        sk.segment_reference(*args, ref)
        assert np.array_equal(got, ref)
        assert np.isnan(big[:2]).all() and np.isnan(big[2 + m:]).all()     # nothing written outside
        # the fused moments equal a separate accumulation of the same samples
        off = rng.standard_normal(c)
        acc, acc_ref = sk.new_acc(c), sk.new_acc(c)
        out2 = np.empty((m, c), dtype)
        sk.segment(*args, out2, acc, off)
        assert np.array_equal(out2, ref)
        sk.accumulate_reference(ref, off, acc_ref)
        np.testing.assert_allclose(acc[:, :4], acc_ref[:, :4], rtol=1e-12, atol=1e-12 * np.abs(acc_ref[:, :4]).max())
        assert np.array_equal(acc[:, 4:], acc_ref[:, 4:])


def test_segment_covers_every_table_row_and_fraction():
    """A fast phase sweeps all rows, the wrap-around slope (last row -> row 0) and the blend weight to its clip."""
    rng = np.random.default_rng(7)
    for dtype in (np.float32, np.float64):
        ta = rng.standard_normal((64, 8)).astype(dtype)
        tb = rng.standard_normal((64, 8)).astype(dtype)
        m = 4000
        args = (-3.0, 0.0371, 1e-7, 0.999, None, ta, tb, _BLEND_LEVELS / 3000.0)   # xi < 0 and > length: clipped
        got, ref = np.empty((m, 8), dtype), np.empty((m, 8), dtype)
        sk.segment(*args, got)
        sk.segment_reference(*args, ref)
        assert np.array_equal(got, ref)


def test_segment_rejects_bad_arrays():
    t = np.zeros((64, 4), np.float32)
    out = np.zeros((10, 4), np.float32)
    with pytest.raises(ValueError):
        sk.segment(0.0, 0.01, 0.0, 0.0, None, t.astype(np.float64), None, 1.0, out)     # dtype mismatch
    with pytest.raises(ValueError):
        sk.segment(0.0, 0.01, 0.0, 0.0, None, np.zeros((63, 4), np.float32), None, 1.0, out)   # not 2^k
    with pytest.raises(ValueError):
        sk.segment(0.0, 0.01, 0.0, 0.0, None, t, None, 1.0, np.zeros((4, 10), np.float32).T)   # not C-contiguous
    with pytest.raises(ValueError):
        sk.segment(0.0, 0.01, 0.0, 0.0, np.zeros(9), t, None, 1.0, out)                  # warp length
    with pytest.raises(ValueError):
        sk.segment(0.0, 0.01, 0.0, 0.0, None, t, None, 1.0, out, acc=sk.new_acc(4))      # acc without off
    with pytest.raises(ValueError):
        sk.segment(0.0, 0.01, 0.0, 0.0, None, t.astype(np.float16), None, 1.0, out.astype(np.float16))


# ----------------------------------------------------------------------------------------- the real synthesiser
def _replay_chunk(s: Synthesizer, n0: int, n: int, fn) -> np.ndarray:
    """The chunk [n0, n0 + n) re-rendered from the synthesiser's knots through ``fn`` (segment or its reference),
    with xi0, c1, c2, warp and blend_scale computed as Synthesizer._segment does."""
    ks = s._knots
    out = np.empty((n, len(s.channels)), dtype=s.dtype)
    pos, i = n0, 0
    while pos < n0 + n:
        i = s._segment_at(i, pos)
        a, b = ks[i], ks[i + 1]
        end = min(n0 + n, max(pos + 1, math.ceil(b.x - 1e-9)))
        length = b.x - a.x
        alpha = (b.f - a.f) / length
        c1 = s.bpfo_per_hz / s.sample_rate_hz * a.f
        c2 = 0.5 * s.bpfo_per_hz / s.sample_rate_hz * alpha
        xi0 = pos - a.x
        warp = None
        if s._slip_walk is not None:
            xi = np.arange(end - pos, dtype=np.float64) + xi0
            u = xi * c2
            u += c1
            u *= xi
            u += a.u_frac
            warp = np.ascontiguousarray(s._slip_walk.warp(a.u_int, u), dtype=np.float64)
        tb = b.table if b.table is not a.table else None
        fn(xi0, c1, c2, a.u_frac, warp, a.table, tb, _BLEND_LEVELS / length, out[pos - n0:end - n0])
        pos = end
    return out


@pytest.fixture(scope="module")
def synth_runs(model):
    """Chunks of a few runs (speed changes inside chunks, float32 and float64, with and without slip), each with a
    snapshot of the knots it was rendered from."""
    runs = []
    for dtype, slip in ((np.float32, 0.0), (np.float64, 0.0), (np.float32, 0.01)):
        s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, dtype=dtype, slip=slip)
        for f in (25.0, 26.3, 26.3, 24.1):
            ch = s.next_chunk(f)
            runs.append((s, ch, list(s._knots)))
    return runs


def test_synthesiser_chunks_bit_for_bit(synth_runs):
    n_blend = 0
    for s, ch, knots in synth_runs:
        saved, s._knots = s._knots, list(knots)
        try:
            n0, n = ch.first_sample_index, ch.n_samples
            ref = _replay_chunk(s, n0, n, sk.segment_reference)
            got = _replay_chunk(s, n0, n, sk.segment)
        finally:
            s._knots = saved
        n_blend += sum(b.table is not a.table for a, b in zip(knots[:-1], knots[1:]))
        assert ch.samples.dtype == s.dtype
        assert np.array_equal(ref, ch.samples.T), "numpy reference differs from Synthesizer._segment"
        assert np.array_equal(got, ch.samples.T), "C kernel differs from Synthesizer._segment"
    assert n_blend > 0                                   # the speed changes exercised the time blend


# ----------------------------------------------------------------------------------------- features
def _features_c(x: np.ndarray, off: np.ndarray) -> dict:
    acc = sk.new_acc(x.shape[1])
    sk.accumulate(x, np.asarray(off, np.float64), acc)
    return sk.features_from_acc(acc, x.shape[0], off)


def _features_f64(x: np.ndarray) -> dict:
    return waveform_features(x.astype(np.float64))


def test_accumulate_equals_reference():
    rng = np.random.default_rng(3)
    for dtype in (np.float32, np.float64):
        for n, c in ((1, 8), (300, 8), (5120, 8), (1000, 5), (77, 1)):
            x = rng.standard_normal((n, c)).astype(dtype)
            off = rng.standard_normal(c)
            acc, ref = sk.new_acc(c), sk.new_acc(c)
            sk.accumulate(x[: n // 2], off, acc)               # two calls add up
            sk.accumulate(x[n // 2:], off, acc)
            sk.accumulate_reference(x, off, ref)
            np.testing.assert_allclose(acc[:, :4], ref[:, :4], rtol=1e-10, atol=1e-10 * np.abs(ref[:, :4]).max())
            assert np.array_equal(acc[:, 4:], ref[:, 4:])


def test_features_match_waveform_features_on_a_chunk(model):
    """A synthesised chunk (acceleration and displacement: the displacement rides on a static offset ~ -4e-5 m with
    ~1e-7 m dynamics): the running moments give waveform_features' values, closer to float64 than float32 is."""
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1)
    s.next_chunk(25.0)
    ch = s.next_chunk(26.3)
    x = np.ascontiguousarray(ch.samples.T)
    off = s._dc.astype(np.float64)
    disp = [i for i, c in enumerate(s.channels) if c.quantity == "displacement"]
    assert np.abs(off[disp]).max() > 1e-5                 # the large static offset is there
    got = _features_c(x, off)
    f32 = waveform_features(x, s._dc)
    f64 = _features_f64(x)
    for key in ("rms", "peak", "peak_to_peak", "kurtosis"):
        np.testing.assert_allclose(got[key], f32[key], rtol=1e-4, err_msg=key)
        err_c = np.abs(got[key] - f64[key])
        err_32 = np.abs(f32[key] - f64[key])
        assert np.all(err_c <= err_32 + 1e-12 * np.abs(f64[key])), key
    np.testing.assert_allclose(got["mean"], f64["mean"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got["crest_factor"], f64["crest_factor"], rtol=1e-6)
    # fused into the rendering: the same accumulators
    acc = sk.new_acc(x.shape[1])
    ks = s._knots
    n0, n = ch.first_sample_index, ch.n_samples
    out = np.empty_like(x)
    pos, i = n0, 0
    while pos < n0 + n:
        i = s._segment_at(i, pos)
        a, b = ks[i], ks[i + 1]
        end = min(n0 + n, max(pos + 1, math.ceil(b.x - 1e-9)))
        length = b.x - a.x
        c1 = s.bpfo_per_hz / s.sample_rate_hz * a.f
        c2 = 0.5 * s.bpfo_per_hz / s.sample_rate_hz * ((b.f - a.f) / length)
        tb = b.table if b.table is not a.table else None
        sk.segment(pos - a.x, c1, c2, a.u_frac, None, a.table, tb, _BLEND_LEVELS / length, out[pos - n0:end - n0],
                   acc, off)
        pos = end
    assert np.array_equal(out, x)
    fused = sk.features_from_acc(acc, n, off)
    for key in got:
        np.testing.assert_allclose(fused[key], got[key], rtol=1e-12, atol=1e-300, err_msg=key)


def test_features_of_a_sine_and_a_constant():
    t = np.arange(51200) / 51200.0
    x = np.stack([np.sin(2 * np.pi * 100 * t) * 3.0 + 1.0, np.full_like(t, 2.5)], axis=1).astype(np.float32)
    f = _features_c(x, np.array([1.0, 0.0]))
    assert f["kurtosis"][0] == pytest.approx(1.5, rel=1e-6)
    assert f["crest_factor"][0] == pytest.approx(math.sqrt(2), rel=1e-6)
    assert f["rms"][0] == pytest.approx(3 / math.sqrt(2), rel=1e-6)
    assert f["mean"][0] == pytest.approx(1.0, abs=1e-6)
    assert f["peak_to_peak"][0] == pytest.approx(6.0, rel=1e-6)
    for key in ("rms", "peak", "peak_to_peak", "crest_factor", "kurtosis"):
        assert f[key][1] == 0.0, key                        # a constant: zeros, not NaN
    assert f["mean"][1] == 2.5
