"""Tests of bkabem_core.synth.kernel: the C sample loop (_synthloop.c) against its numpy reference (the generic path
bit for bit, the fast path with fused multiply-adds to a stated rounding bound), its chunk invariance, the accuracy of
the cubic B-spline interpolation, the knot table against the direct formula and an FFT, and the running-moment
features.

The kernel is built by ``pip install -e .``; these tests fail (not skip) when it is missing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bkabem_core.synth import kernel as sk
from bkabem_core.synth.synthesizer import waveform_features

FS = 51200.0
PASSES_PER_SAMPLE = 151.0 / FS          # ball passes per sample at a typical speed
M64 = (1 << 64) - 1


def test_kernel_is_built():
    assert sk.AVAILABLE, "bkabem_core/kernels/_synthloop.c is not built: run `pip install -e .`"


def test_phase_bits_and_weights():
    assert sk.PASS_UNITS == 2 ** 62
    assert sk.phase_bits(512) == 53 and sk.phase_bits(64) == 56 and sk.phase_bits(65536) == 46
    for bad in (32, 100, 1 << 17):
        with pytest.raises(ValueError):
            sk.phase_bits(bad)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_spline_weights_are_the_cubic_b_spline(dtype):
    """The weights from 24 fraction bits: the B-spline polynomials to a few units of the dtype's rounding, sum 1,
    the knot values at t = 0, symmetric (w3(t) = w0(1 - t), w2(t) = w1(1 - t)) up to rounding."""
    eps = np.finfo(dtype).eps
    rng = np.random.default_rng(0)
    q = np.concatenate([[0, 1, 2, 1 << 23, (1 << 24) - 1], rng.integers(0, 1 << 24, 100000)])
    w = sk.spline_weights(q, dtype)
    assert w.shape == (q.size, 4) and w.dtype == dtype
    t = q / 2.0 ** 24
    exact = np.stack([(1 - t) ** 3 / 6, (3 * t ** 3 - 6 * t ** 2 + 4) / 6, (-3 * t ** 3 + 3 * t ** 2 + 3 * t + 1) / 6,
                      t ** 3 / 6], axis=1)
    assert np.all(np.abs(w - exact) <= 4 * eps * np.maximum(exact, 1 / 6))      # relative where a weight is small
    assert np.all(np.abs(w[:, 0] - exact[:, 0]) <= 4 * eps * exact[:, 0])
    assert np.all(np.abs(w[:, 3] - exact[:, 3]) <= 4 * eps * exact[:, 3])
    np.testing.assert_allclose(w.astype(np.float64).sum(axis=1), 1.0, rtol=0, atol=4 * eps)
    f = np.dtype(dtype).type                                  # t = 0: 1/6, 2/3, 2/3 - 1/2, 0 rounded as computed
    assert np.array_equal(w[0], np.array([f(1 / 6), f(2 / 3), f(2 / 3) - f(0.5), 0.0], dtype)), w[0]
    mirror = sk.spline_weights((1 << 24) - q[1:], dtype)[:, ::-1]
    np.testing.assert_allclose(w[1:], mirror, rtol=0, atol=4 * eps)
    # the 12-bit table this replaced was off by up to ~1e-4: the test tells them apart
    coarse = sk.spline_weights(q >> 12 << 12, np.float64)
    assert np.abs(coarse - exact).max() > 1e-4


def test_empty_aligned():
    for shape, dt in (((5120, 8), np.float32), ((515, 3), np.float64), (7, np.complex128), ((0, 8), np.float32)):
        a = sk.empty_aligned(shape, dt)
        assert a.shape == (shape if isinstance(shape, tuple) else (shape,)) and a.dtype == dt
        assert a.flags.c_contiguous and a.flags.writeable and (a.size == 0 or a.ctypes.data % 64 == 0)
        a[...] = 1
        assert np.all(a == 1)


def _closed_form(phase0, dphase0, ddphase, j):
    """Phase and increment of sample j (Python ints, modulo 2^64)."""
    return (phase0 + j * dphase0 + ddphase * (j * (j - 1) // 2)) & M64, (dphase0 + j * ddphase) & M64


def test_phases_reference_is_the_recurrence():
    u0, d0, dd = M64 - 5, (1 << 63) + 12345, -(1 << 40) - 7
    ref = sk.phases_reference(u0, d0, dd, 1000)
    u, d = u0 & M64, d0 & M64
    for j in range(1000):
        assert int(ref[j]) == u
        assert _closed_form(u0, d0, dd, j)[0] == u
        u, d = (u + d) & M64, (d + dd) & M64


def _case(rng, dtype, n_table, c, m, blend, warp, big_warp=False):
    fb = sk.phase_bits(n_table)
    ta = sk.pad_coefficients(rng.standard_normal((n_table, c))).astype(dtype)
    tb = sk.pad_coefficients(rng.standard_normal((n_table, c))).astype(dtype) if blend else None
    if not warp:
        w = None
    elif big_warp:
        w = rng.integers(-(1 << 61), 1 << 61, m, dtype=np.int64)
    else:
        w = rng.integers(-(1 << (fb + 2)), 1 << (fb + 2), m, dtype=np.int64)     # a few table steps
    dphase = int(PASSES_PER_SAMPLE * rng.uniform(0.2, 2.0) * sk.PASS_UNITS)
    phase0 = (1 << 64) - int(rng.integers(1, 1 << 50))                             # close to the wrap
    ddphase = -int(rng.integers(0, 1 << 30)) if rng.uniform() < 0.5 else int(rng.integers(0, 1 << 30))
    length = m + rng.uniform(-0.3 * m, 3000.0)
    return (phase0, dphase, ddphase, w, ta, tb, float(rng.uniform(-20.0, 50.0)), 65536.0 / max(length, 1.0))


#: |fast path - reference| <= FAST_TOL * M, M the largest |tap| of the sample's channel in tables a and b: each path's
#: four-term sum is within 4 roundings of ~M (2^-24 each), the blend adds 3 (reference) and 2 (fast) more of up to
#: 2M; 16 units bound their difference with margin (observed: <= ~5 units).
FAST_TOL = 16 * 2.0 ** -24


def _fast_path_bound(args, m):
    """(m, C) bound FAST_TOL * M of the fast path's deviation from the reference for segment arguments ``args``."""
    phase0, dphase0, ddphase, warp, ta, tb = args[:6]
    n = ta.shape[0] - 3
    v = sk.phases_reference(phase0, dphase0, ddphase, m)
    if warp is not None:
        v += warp.view(np.uint64)
    i = ((v >> np.uint64(sk.phase_bits(n))) & np.uint64(n - 1)).astype(np.intp)
    mag = np.zeros((m, ta.shape[1]))
    for t in (ta, tb) if tb is not None else (ta,):
        for k in range(4):
            mag = np.maximum(mag, np.abs(t[i + k]).astype(np.float64))
    return FAST_TOL * mag


def _uses_fast_path(dtype, c) -> bool:
    return sk.fast_path() and np.dtype(dtype) == np.float32 and c == 8


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n_table,c", [(512, 8), (64, 3)])
@pytest.mark.parametrize("blend", [False, True])
@pytest.mark.parametrize("warp", [None, "small", "big"])
@pytest.mark.parametrize("m", [1, 7, 5120])
def test_segment_equals_reference_bit_for_bit(dtype, n_table, c, blend, warp, m):
    """The generic path (exact=True) bit for bit the reference; the default path too, except the fast path (float32,
    8 channels, AVX2 + FMA), which is within the rounding bound FAST_TOL and differs somewhere (it does fuse)."""
    rng = np.random.default_rng([n_table, c, blend, m, 0 if warp is None else len(warp)])
    fast = _uses_fast_path(dtype, c)
    differs = 0
    for _ in range(3):
        args = _case(rng, dtype, n_table, c, m, blend, warp is not None, warp == "big")
        big = np.full((m + 4, c), np.nan, dtype)
        exact = big[2:2 + m]                                           # a row slice of a bigger buffer
        ref = np.empty((m, c), dtype)
        sk.segment(*args, exact, exact=True)
        sk.segment_reference(*args, ref)
        assert np.isfinite(ref).all()
        assert np.array_equal(exact, ref)
        assert np.isnan(big[:2]).all() and np.isnan(big[2 + m:]).all()     # nothing written outside
        big[...] = np.nan
        got = big[2:2 + m]
        sk.segment(*args, got)
        assert np.isnan(big[:2]).all() and np.isnan(big[2 + m:]).all()
        if fast:
            assert np.all(np.abs(got.astype(np.float64) - ref) <= _fast_path_bound(args, m))
            differs += int(np.count_nonzero(got != ref))
        else:
            assert np.array_equal(got, ref)
        # the fused moments equal a separate accumulation of the same samples
        off = rng.standard_normal(c)
        for ex in (False, True):
            acc, acc_sep, acc_ref = sk.new_acc(c), sk.new_acc(c), sk.new_acc(c)
            out2 = np.empty((m, c), dtype)
            sk.segment(*args, out2, acc, off, exact=ex)
            assert np.array_equal(out2, ref if ex else got)
            sk.accumulate(out2, off, acc_sep)
            assert np.array_equal(acc, acc_sep)
            sk.accumulate_reference(out2, off, acc_ref)
            _assert_moments(acc, acc_ref, dtype)
            assert np.array_equal(acc[:, 4:], acc_ref[:, 4:])
    if fast and m == 5120:
        assert differs > 0                      # the fused path is the one that ran


@pytest.mark.parametrize("blend", [False, True])
def test_fast_path_rounding_is_small(blend):
    """Fast path against the reference over a long run: within FAST_TOL of the taps' magnitude (a wrong tap or a
    coarser weight would be ~1e-4 of it), and by a few units of 2^-24 in practice."""
    if not _uses_fast_path(np.float32, 8):
        pytest.skip("no AVX2 + FMA: the fast path is not taken")
    rng = np.random.default_rng(21)
    m = 40000
    args = _case(rng, np.float32, 512, 8, m, blend, True)
    got, ref = np.empty((m, 8), np.float32), np.empty((m, 8), np.float32)
    sk.segment(*args, got)
    sk.segment_reference(*args, ref)
    ratio = np.abs(got.astype(np.float64) - ref) / (_fast_path_bound(args, m) / FAST_TOL)
    assert ratio.max() <= 16 * 2.0 ** -24
    assert ratio.max() <= 8 * 2.0 ** -24, ratio.max() * 2 ** 24      # observed ~3 (no blend) and ~5 units
    assert np.count_nonzero(got != ref) > m                          # fused: not the reference's rounding


def test_segment_covers_every_row_weight_and_blend_clip():
    """A fast, accelerating phase sweeps all rows and weight indices, xi from < 0 to > length (blend clipped)."""
    rng = np.random.default_rng(7)
    for dtype in (np.float32, np.float64):
        for n_table in (64, 65536):
            ta = sk.pad_coefficients(rng.standard_normal((n_table, 4))).astype(dtype)
            tb = sk.pad_coefficients(rng.standard_normal((n_table, 4))).astype(dtype)
            m = 20000
            args = (3, int(0.0371 * sk.PASS_UNITS) + 12345, 987654321, None, ta, tb, -3.0, 65536.0 / 15000.0)
            got, ref = np.empty((m, 4), dtype), np.empty((m, 4), dtype)
            sk.segment(*args, got)
            sk.segment_reference(*args, ref)
            assert np.array_equal(got, ref)
            v = sk.phases_reference(*args[:3], m)
            fb = sk.phase_bits(n_table)
            q = (v >> np.uint64(fb - 24)) & np.uint64((1 << 24) - 1)
            assert len(np.unique(q)) > 0.99 * m
            assert len(np.unique(q >> np.uint64(12))) > 4000 and len(np.unique(q & np.uint64(4095))) > 4000


def test_phase_arguments_modulo_2_64():
    """Negative and >= 2^63 Python ints mean the same as their residues modulo 2^64."""
    rng = np.random.default_rng(11)
    args = _case(rng, np.float32, 512, 8, 999, True, True)
    a, b = np.empty((999, 8), np.float32), np.empty((999, 8), np.float32)
    sk.segment(*args, a, exact=True)
    p0, d0, dd = args[:3]
    sk.segment(p0 - (1 << 64), d0 + (3 << 64), (dd & M64) - (5 << 64), *args[3:], b, exact=True)
    assert np.array_equal(a, b)
    sk.segment_reference(p0 + (1 << 64), d0 - (1 << 64), dd + (1 << 64), *args[3:], b)
    assert np.array_equal(a, b)
    sk.segment(*args, a)                                              # the fast path (if taken) likewise
    sk.segment(p0 - (1 << 64), d0 + (3 << 64), (dd & M64) - (5 << 64), *args[3:], b)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("blend,warp", [(False, False), (True, False), (True, True)])
@pytest.mark.parametrize("exact", [False, True])
def test_chunk_invariance(dtype, blend, warp, exact):
    """Two calls split at any j give the samples of one call (xi0 a multiple of 1/8: xi0 + j exact), on the fast
    path (float32, 8 channels) as on the generic one: a sample's operations do not depend on its place in a block."""
    rng = np.random.default_rng([3, blend, warp])
    m, c = 1500, 8
    args = list(_case(rng, dtype, 512, c, m, blend, warp, big_warp=True))
    args[6] = 2.375
    whole = np.empty((m, c), dtype)
    sk.segment(*args, whole, exact=exact)
    p0, d0, dd, w = args[:4]
    for j in (0, 1, 2, 3, 5, 255, 256, 257, 258, 700, 1021, m - 1, m):
        u, d = _closed_form(p0, d0, dd, j)
        parts = np.empty((m, c), dtype)
        sk.segment(p0, d0, dd, None if w is None else w[:j], *args[4:6], args[6], args[7], parts[:j], exact=exact)
        sk.segment(u, d, dd, None if w is None else w[j:], *args[4:6], args[6] + j, args[7], parts[j:], exact=exact)
        assert np.array_equal(parts, whole), j


def _spline_table(n_table, harmonics, droop=True):
    """(N + 3, 1) padded B-spline coefficients of sum_k a_k cos(2 pi k x / N + phi_k) (x in table steps): the
    Fourier coefficients divided by sinc(k / N)^4, the B-spline's droop."""
    y = np.zeros(n_table // 2 + 1, complex)
    for k, a, phi in harmonics:
        y[k] = 0.5 * n_table * a * np.exp(1j * phi) / (np.sinc(k / n_table) ** 4 if droop else 1.0)
    return sk.pad_coefficients(np.fft.irfft(y, n_table)[:, None])


@pytest.mark.parametrize("n_table", [512, 256])
@pytest.mark.parametrize("dtype,c", [(np.float64, 1), (np.float32, 8)])
def test_interpolation_reproduces_a_band_limited_signal(n_table, dtype, c):
    """Samples equal the analytic signal at the sample's full 64-bit phase to the spline's images (those of harmonic
    k, at N -+ k, ..., are ~2 (k / (N - k))^4 of it; float32 adds its rounding). The 12-bit weight table this
    replaced truncated the phase to 1/4096 of a table step, ~5e-5 here: the test tells the two apart."""
    harmonics = [(1, 1.0, 0.3), (5, 0.5, -1.1), (11, 0.3, 2.0), (24, 0.5, 0.7)]
    table = np.repeat(_spline_table(n_table, harmonics), c, axis=1).astype(dtype)
    fb = sk.phase_bits(n_table)
    m = 20000
    d0 = int(0.0123457 * sk.PASS_UNITS) + 77777
    phase0 = 12345678901234567
    out = np.empty((m, c), dtype)
    sk.segment(phase0, d0, 0, None, table, None, 0.0, 0.0, out)
    v = sk.phases_reference(phase0, d0, 0, m)
    x = (v & np.uint64(sk.PASS_UNITS - 1)).astype(np.float64) / 2.0 ** fb               # table steps, unquantised
    exact = sum(a * np.cos(2 * np.pi * k * x / n_table + phi) for k, a, phi in harmonics)
    scale = sum(a for _, a, _ in harmonics)
    tol = sum(2 * a * (k / (n_table - k)) ** 4 for k, a, _ in harmonics) + 1e-6 * scale
    assert np.abs(out - exact[:, None]).max() < tol
    if n_table == 512:
        x12 = (v >> np.uint64(fb - 12) & np.uint64((n_table << 12) - 1)).astype(np.float64) / 4096.0
        coarse = sum(a * np.cos(2 * np.pi * k * x12 / n_table + phi) for k, a, phi in harmonics)
        assert np.abs(coarse - exact).max() > 3 * tol
    # and the whole thing is not trivially satisfied: without the droop correction it is visibly off
    raw = np.repeat(_spline_table(n_table, harmonics, droop=False), c, axis=1).astype(dtype)
    out_raw = np.empty((m, c), dtype)
    sk.segment(phase0, d0, 0, None, raw, None, 0.0, 0.0, out_raw)
    assert np.abs(out_raw[:, 0] - exact).max() > 1e-4 * scale


def test_segment_rejects_bad_arrays():
    t = np.zeros((67, 4), np.float32)
    out = np.zeros((10, 4), np.float32)
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t.astype(np.float64), None, 0.0, 1.0, out)                # dtype mismatch
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, np.zeros((64, 4), np.float32), None, 0.0, 1.0, out)      # N = 61: not 2^k
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, np.zeros((35, 4), np.float32), None, 0.0, 1.0, out)      # N = 32 < 64
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t, np.zeros((131, 4), np.float32), 0.0, 1.0, out)        # table_b shape
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t, None, 0.0, 1.0, np.zeros((4, 10), np.float32).T)      # not C-contiguous
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, np.zeros(9, np.int64), t, None, 0.0, 1.0, out)                 # warp length
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, np.zeros(10), t, None, 0.0, 1.0, out)                          # warp dtype
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t, None, 0.0, 1.0, out, acc=sk.new_acc(4))              # acc without off
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t.astype(np.float16), None, 0.0, 1.0, out.astype(np.float16))
    ro = out.copy()
    ro.flags.writeable = False
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t, None, 0.0, 1.0, ro)                                   # read-only out
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t, None, 0.0, 1.0, out, np.zeros((4, 5)), np.zeros(4))   # acc shape
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, t[:, :3], None, 0.0, 1.0, out)                           # table columns
    with pytest.raises(ValueError):
        sk.segment(0, 1, 0, None, [[0.0] * 4] * 67, None, 0.0, 1.0, out)                   # not an array of floats
    t_ro = t.copy()
    t_ro.flags.writeable = False
    sk.segment(0, 1, 0, None, t_ro, t_ro, 0.0, 1.0, out)                                   # read-only tables are fine


# ----------------------------------------------------------------------------------------- features
def _features_c(x: np.ndarray, off: np.ndarray) -> dict:
    acc = sk.new_acc(x.shape[1])
    sk.accumulate(x, np.asarray(off, np.float64), acc)
    return sk.features_from_acc(acc, x.shape[0], off)


def _assert_moments(acc, ref, dtype) -> None:
    """Sums within tol of the reference, relative to the moment's size over the channels: float32 samples of 8
    channels go through the float block sums (_synthloop.c, moments8_f32_avx2), ~1e-6 of a sum; everything else
    is summed in double. Extremes exactly."""
    tol = 2e-5 if np.dtype(dtype) == np.float32 else 1e-10
    scale = np.abs(ref[:, :4]).max(axis=0) + np.abs(ref[:, 1:2])       # |sum d^p| is at most ~ sum d^2 (p <= 4)
    assert np.all(np.abs(acc[:, :4] - ref[:, :4]) <= tol * scale), np.abs(acc[:, :4] - ref[:, :4]) / scale
    assert np.array_equal(acc[:, 4:], ref[:, 4:])


def test_accumulate_equals_reference():
    rng = np.random.default_rng(3)
    for dtype in (np.float32, np.float64):
        for n, c in ((1, 8), (300, 8), (5120, 8), (1000, 5), (77, 1), (600, 3)):
            x = rng.standard_normal((n, c)).astype(dtype)
            off = rng.standard_normal(c)
            acc, ref = sk.new_acc(c), sk.new_acc(c)
            sk.accumulate(x[: n // 2], off, acc)               # two calls add up
            sk.accumulate(x[n // 2:], off, acc)
            sk.accumulate_reference(x, off, ref)
            _assert_moments(acc, ref, x.dtype)
            assert np.array_equal(acc[:, 4:], ref[:, 4:])


def test_features_from_acc_match_waveform_features():
    """Fused into the rendering or accumulated separately: the features of waveform_features."""
    rng = np.random.default_rng(5)
    m, c = 5120, 8
    args = _case(rng, np.float64, 512, c, m, True, False)
    off = rng.standard_normal(c)
    acc = sk.new_acc(c)
    x = np.empty((m, c))
    sk.segment(*args, x, acc, off)
    fused = sk.features_from_acc(acc, m, off)
    sep = _features_c(x, off)
    ref = waveform_features(x)
    for key in ref:
        np.testing.assert_allclose(fused[key], sep[key], rtol=1e-12, atol=1e-300, err_msg=key)
        np.testing.assert_allclose(fused[key], np.asarray(ref[key], np.float64).reshape(-1), rtol=1e-9, atol=1e-12,
                                   err_msg=key)


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


def test_normals_are_standard_normal_and_keyed():
    """The C noise generator (xoshiro256+ and Doornik's ziggurat): moments, a Kolmogorov-Smirnov test, the tail
    beyond the ziggurat's base layer (R = 3.4426), no lag-1 correlation; the same key gives the same numbers, another
    key others; float32 is float64 rounded. Thresholds are ~5 standard errors (the test is deterministic)."""
    from scipy import stats

    x = sk.normals(7, 2_000_000, np.float64)
    n = x.size
    assert abs(x.mean()) < 5 / np.sqrt(n)
    assert abs(x.var() - 1) < 5 * np.sqrt(2 / n)
    assert abs(stats.kurtosis(x, fisher=False) - 3) < 5 * np.sqrt(24 / n)
    assert stats.kstest(x[:200_000], "norm").pvalue > 1e-3
    p_tail = 2 * stats.norm.sf(3.442619855899)
    assert abs((np.abs(x) > 3.442619855899).mean() / p_tail - 1) < 5 / np.sqrt(p_tail * n)
    assert abs(np.corrcoef(x[:-1], x[1:])[0, 1]) < 5 / np.sqrt(n)
    np.testing.assert_array_equal(sk.normals(7, 1000, np.float64), x[:1000])
    assert not np.allclose(sk.normals(8, 1000, np.float64), x[:1000])
    np.testing.assert_array_equal(sk.normals(7, 1000, np.float32), x[:1000].astype(np.float32))
    assert sk.normals(2**64 - 1, 3).shape == (3,)


# ----------------------------------------------------------------------------------------- knot table
def _knot_inputs(rng, orders, c, u=6, taper=True):
    k = len(orders)
    x = rng.standard_normal((k, u)) + 1j * rng.standard_normal((k, u))
    cindex = rng.integers(0, u, c).astype(np.int64)
    factor = (rng.standard_normal((k, c)) + 1j * rng.standard_normal((k, c))) * np.linspace(1.0, 3.0, k)[:, None]
    scale = rng.uniform(0.5, 2.0, c)
    tap = rng.uniform(0.0, 1.0, k) if taper else None
    dc = rng.standard_normal(c) * 3.0
    return x, cindex, factor, scale, tap, dc


def _knot_fft(x, cindex, factor, scale, taper, dc, orders, n):
    """The padded table by an inverse FFT of the line spectrum (independent of both implementations)."""
    y = x[:, cindex] * factor * scale[None, :] * (1.0 if taper is None else taper[:, None])
    spec = np.zeros((n, y.shape[1]), complex)
    np.add.at(spec, np.asarray(orders), y)
    t = dc[None, :] + n * np.fft.ifft(spec, axis=0).real
    return sk.pad_coefficients(t), y


ORDER_SETS = {"1..50": np.arange(1, 51), "fibonacci": np.array([1, 2, 3, 5, 8, 13]), "even": np.array([2, 4, 10, 30]),
              "odd": np.array([7, 1, 3, 31]), "one": np.array([5]), "mixed": np.array([13, 2, 8, 1, 5, 3, 20, 21])}


@pytest.mark.parametrize("cap", [2, 1, 0])
@pytest.mark.parametrize("orders_name", list(ORDER_SETS))
@pytest.mark.parametrize("c", [8, 3, 1, 5])
@pytest.mark.parametrize("n_table", [64, 512])
def test_knot_table_equals_the_direct_formula(cap, orders_name, c, n_table):
    """C kernel (AVX-512, AVX2 + FMA and baseline dispatch) = direct formula in float64 = inverse FFT; the float32
    table is the float64 one rounded (to 2^-24 of its largest value), y the numpy product to rounding."""
    orders = ORDER_SETS[orders_name]
    orders = orders[2 * orders < n_table]                                    # N = 64: orders 1..31
    rng = np.random.default_rng([c, n_table, len(orders), cap])
    qb = sk.quarter_basis(orders, n_table)
    old = sk._set_isa_cap(cap)
    try:
        for taper in (True, False):
            args = _knot_inputs(rng, orders, c, taper=taper)
            ref, y_ref = np.empty((n_table + 3, c)), np.empty((len(orders), c), complex)
            sk.knot_table_reference(*args, qb, ref, y_ref)
            fft, y_fft = _knot_fft(*args, orders, n_table)
            scale = np.abs(ref).max()
            assert np.abs(ref - fft).max() <= 1e-13 * scale
            np.testing.assert_allclose(y_ref, y_fft, rtol=1e-14)
            for dtype, tol in ((np.float64, 1e-14), (np.float32, 2.0 ** -24)):
                tab = np.full((n_table + 3, c), np.nan, dtype)
                y = np.full((len(orders), c), np.nan, complex)
                got = sk.knot_table(*args, qb, tab, y)
                assert got[0] is tab and got[1] is y
                assert np.all(np.abs(tab - ref) <= tol * scale), np.abs(tab - ref).max() / scale
                assert np.array_equal(tab[0], tab[n_table]) and np.array_equal(tab[n_table + 1:], tab[1:3])
                np.testing.assert_allclose(y, y_ref, rtol=4e-16 * 4, atol=0)
    finally:
        sk._set_isa_cap(old)


def test_knot_table_big_and_synth_formula():
    """N = 4096 with 200 orders, against the direct formula, and the numpy code of Synthesizer._amplitudes it
    replaces (a float32 GEMM with the (N + 3) x (2K + 1) basis: equal to its float32 round-off)."""
    rng = np.random.default_rng(9)
    n, orders = 4096, np.arange(1, 201)
    qb = sk.quarter_basis(orders, n)
    x, cindex, factor, scale, taper, dc = _knot_inputs(rng, orders, 8, u=16)
    ref, y_ref = np.empty((n + 3, 8)), np.empty((200, 8), complex)
    sk.knot_table_reference(x, cindex, factor, scale, taper, dc, qb, ref, y_ref)
    tab, y = np.empty((n + 3, 8), np.float32), np.empty((200, 8), complex)
    sk.knot_table(x, cindex, factor, scale, taper, dc, qb, tab, y)
    top = np.abs(ref).max()
    assert np.abs(tab - ref).max() <= 2.0 ** -24 * top
    kk = orders.astype(float)
    th = 2 * np.pi * (np.arange(n + 3) - 1) / n
    basis = np.concatenate([np.cos(np.outer(th, kk)), -np.sin(np.outer(th, kk)), np.ones((n + 3, 1))], axis=1)
    coef = np.concatenate([y_ref.real, y_ref.imag, dc[None, :]]).astype(np.float32)
    old = basis.astype(np.float32) @ coef
    assert np.abs(tab - old).max() <= 1e-5 * top


def test_quarter_basis_and_knot_table_arguments():
    qb = sk.quarter_basis([3, 2, 8, 1], 64)
    assert qb.n_table == 64 and qb.n_even == 2 and list(qb.orders[qb.perm]) == [2, 8, 3, 1]
    assert qb.basis.shape == (18, 4, 2) and not qb.basis.flags.writeable       # 17 rows rounded up to 6
    # j = N/4: order 2 at pi, order 3 at 3 pi / 2, exactly
    assert qb.basis[16, 0, 0] == -1.0 and qb.basis[16, 0, 1] == 0.0
    assert qb.basis[16, 2, 0] == 0.0 and qb.basis[16, 2, 1] == -1.0
    for bad in ([0, 1], [32], [1.5]):
        with pytest.raises(ValueError):
            sk.quarter_basis(bad, 64)
    with pytest.raises(ValueError):
        sk.quarter_basis([1], 48)
    rng = np.random.default_rng(1)
    args = list(_knot_inputs(rng, qb.orders, 3, u=4))
    tab, y = np.empty((67, 3), np.float32), np.empty((4, 3), complex)
    sk.knot_table(*args, qb, tab, y)
    bad_index = list(args)
    bad_index[1] = np.array([0, 4, 1], dtype=np.int64)                       # column 4 of a (4, 4) x
    with pytest.raises(ValueError):
        sk.knot_table(*bad_index, qb, tab, y)
    with pytest.raises(ValueError):
        sk.knot_table(*args, sk.quarter_basis([3, 2, 8, 1], 128), tab, y)     # basis of another N
    with pytest.raises(ValueError):
        sk.knot_table(*args, qb, tab[:, :2], y)                               # not C-contiguous / wrong shape
    with pytest.raises(ValueError):
        sk.knot_table(*args, qb, tab.astype(np.float16), y)
    with pytest.raises(ValueError):
        sk.knot_table(*args, qb, tab, y.astype(np.complex64))
    bad_x = list(args)
    bad_x[0] = args[0].T                                                       # non-contiguous x
    with pytest.raises(ValueError):
        sk.knot_table(*bad_x, qb, tab, y)


def test_band_rms_matches_numpy_and_checks_its_arguments():
    """band_rms (the chunk's ISO velocity from the order amplitudes of two knots) against its numpy reference and an
    independent complex formula, over partial bands and blend weights; bad arguments are rejected."""
    rng = np.random.default_rng(8)
    va, vb = rng.standard_normal((2, 37, 8))
    for lo, hi, s in ((0, 37, 0.0), (3, 11, 0.5), (5, 5, 0.3), (0, 1, 1.0), (20, 37, 0.77)):
        got = sk.band_rms(va, vb, lo, hi, s)
        ref = sk.band_rms_reference(va, vb, lo, hi, s)
        za, zb = va[:, :4] + 1j * va[:, 4:], vb[:, :4] + 1j * vb[:, 4:]
        z = (1 - s) * za[lo:hi] + s * zb[lo:hi]
        direct = np.sqrt(0.5 * np.sum(np.abs(z) ** 2, axis=0))
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(got, direct, rtol=1e-12, atol=1e-15)
    with pytest.raises(ValueError, match="lo <= hi"):
        sk.band_rms(va, vb, 3, 40, 0.5)
    with pytest.raises(ValueError, match="va"):
        sk.band_rms(np.asfortranarray(va), vb, 0, 3, 0.5)
    with pytest.raises(ValueError, match="alike"):
        sk.band_rms(va, vb[:, :4].copy(), 0, 3, 0.5)


def test_features_from_acc_rejects_bad_arrays():
    acc = sk.new_acc(8)
    with pytest.raises(ValueError, match="off"):
        sk.features_from_acc(acc, 10, np.zeros(7))
    with pytest.raises(ValueError, match="acc"):
        sk.features_from_acc(acc[:, :5].copy(), 10, np.zeros(8))
    with pytest.raises(ValueError, match="n >= 1"):
        sk.features_from_acc(acc, 0, np.zeros(8))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_carrier_mix_c_equals_numpy(dtype):
    """The carrier mix of line families with a carrier (synth_lines): C bit for bit its numpy reference."""
    rng = np.random.default_rng(7)
    m, c = 1031, 8
    cs = rng.standard_normal((m, 2)).astype(dtype)
    re, im = (rng.standard_normal((m, c)).astype(dtype) for _ in range(2))
    out = rng.standard_normal((m, c)).astype(dtype)
    ref = out.copy()
    sk.carrier_mix(cs, re, im, out)
    sk.carrier_mix_reference(cs, re, im, ref)
    assert np.array_equal(out, ref)
    with pytest.raises(ValueError):
        sk.carrier_mix(cs[:10], re, im, out)


@pytest.mark.parametrize("kappa", [1.0, -1.0, 0.2612])
def test_slip_warp_c_equals_numpy(kappa):
    """The slip warp of a segment (Hermite walk + fixed point) in C, bit for bit its numpy reference."""
    rng = np.random.default_rng(3)
    w = np.cumsum(0.01 * rng.standard_normal(200))
    c1, c2 = 6.06 * 25 / 51200, 0.5 * 6.06 / 51200 * 0.4 / 5120
    for j0, m in ((0, 5120), (777, 2000)):
        ref = sk.slip_warp_reference(m, j0, c1, c2, 0.41, w, -1, kappa)
        assert np.array_equal(sk.slip_warp(m, j0, c1, c2, 0.41, w, -1, kappa), ref)
    if sk.AVAILABLE:
        with pytest.raises(ValueError, match="outside"):
            sk.slip_warp(5120, 0, 1.0, 0.0, 0.0, w, -1, 1.0)
