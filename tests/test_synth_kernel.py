"""Tests of bkabem_core.synth_kernel: the C sample loop (_synthloop.c) against its numpy reference bit for bit, its
chunk invariance, the accuracy of the cubic B-spline interpolation, and the running-moment features.

The kernel is built by ``pip install -e .``; these tests fail (not skip) when it is missing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bkabem_core import synth_kernel as sk
from bkabem_core.synth import waveform_features

FS = 51200.0
PASSES_PER_SAMPLE = 151.0 / FS          # ball passes per sample at a typical speed
M64 = (1 << 64) - 1


def test_kernel_is_built():
    assert sk.AVAILABLE, "bkabem_core/_synthloop.c is not built: run `pip install -e .`"


def test_phase_bits_and_weights():
    assert sk.PASS_UNITS == 2 ** 62
    assert sk.phase_bits(512) == 53 and sk.phase_bits(64) == 56 and sk.phase_bits(65536) == 46
    for bad in (32, 100, 1 << 17):
        with pytest.raises(ValueError):
            sk.phase_bits(bad)
    w = sk.spline_weights(np.float64)
    assert w.shape == (4096, 4) and sk.spline_weights(np.float64) is w
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(w[0], [1 / 6, 4 / 6, 1 / 6, 0.0], atol=1e-16)
    assert np.array_equal(sk.spline_weights(np.float32), w.astype(np.float32))


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


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n_table,c", [(512, 8), (64, 3)])
@pytest.mark.parametrize("blend", [False, True])
@pytest.mark.parametrize("warp", [None, "small", "big"])
@pytest.mark.parametrize("m", [1, 7, 5120])
def test_segment_equals_reference_bit_for_bit(dtype, n_table, c, blend, warp, m):
    rng = np.random.default_rng([n_table, c, blend, m, 0 if warp is None else len(warp)])
    for _ in range(3):
        args = _case(rng, dtype, n_table, c, m, blend, warp is not None, warp == "big")
        big = np.full((m + 4, c), np.nan, dtype)
        got = big[2:2 + m]                                             # a row slice of a bigger buffer
        ref = np.empty((m, c), dtype)
        sk.segment(*args, got)
        sk.segment_reference(*args, ref)
        assert np.isfinite(ref).all()
        assert np.array_equal(got, ref)
        assert np.isnan(big[:2]).all() and np.isnan(big[2 + m:]).all()     # nothing written outside
        # the fused moments equal a separate accumulation of the same samples
        off = rng.standard_normal(c)
        acc, acc_sep, acc_ref = sk.new_acc(c), sk.new_acc(c), sk.new_acc(c)
        out2 = np.empty((m, c), dtype)
        sk.segment(*args, out2, acc, off)
        assert np.array_equal(out2, ref)
        sk.accumulate(ref, off, acc_sep)
        assert np.array_equal(acc, acc_sep)
        sk.accumulate_reference(ref, off, acc_ref)
        _assert_moments(acc, acc_ref, dtype)
        assert np.array_equal(acc[:, 4:], acc_ref[:, 4:])


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
            assert len(np.unique((v >> np.uint64(fb - 12)) & np.uint64(4095))) > 4000


def test_phase_arguments_modulo_2_64():
    """Negative and >= 2^63 Python ints mean the same as their residues modulo 2^64."""
    rng = np.random.default_rng(11)
    args = _case(rng, np.float32, 512, 8, 999, True, True)
    a, b = np.empty((999, 8), np.float32), np.empty((999, 8), np.float32)
    sk.segment(*args, a)
    p0, d0, dd = args[:3]
    sk.segment(p0 - (1 << 64), d0 + (3 << 64), (dd & M64) - (5 << 64), *args[3:], b)
    assert np.array_equal(a, b)
    sk.segment_reference(p0 + (1 << 64), d0 - (1 << 64), dd + (1 << 64), *args[3:], b)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("blend,warp", [(False, False), (True, False), (True, True)])
def test_chunk_invariance(dtype, blend, warp):
    """Two calls split at any j give the samples of one call (xi0 a multiple of 1/8: xi0 + j exact)."""
    rng = np.random.default_rng([3, blend, warp])
    m, c = 1500, 8
    args = list(_case(rng, dtype, 512, c, m, blend, warp, big_warp=True))
    args[6] = 2.375
    whole = np.empty((m, c), dtype)
    sk.segment(*args, whole)
    p0, d0, dd, w = args[:4]
    for j in (0, 1, 3, 255, 256, 257, 700, m - 1, m):
        u, d = _closed_form(p0, d0, dd, j)
        parts = np.empty((m, c), dtype)
        sk.segment(p0, d0, dd, None if w is None else w[:j], *args[4:6], args[6], args[7], parts[:j])
        sk.segment(u, d, dd, None if w is None else w[j:], *args[4:6], args[6] + j, args[7], parts[j:])
        assert np.array_equal(parts, whole), j


def _spline_table(n_table, harmonics, droop=True):
    """(N + 3, 1) padded B-spline coefficients of sum_k a_k cos(2 pi k x / N + phi_k) (x in table steps): the
    Fourier coefficients divided by sinc(k / N)^4, the B-spline's droop."""
    y = np.zeros(n_table // 2 + 1, complex)
    for k, a, phi in harmonics:
        y[k] = 0.5 * n_table * a * np.exp(1j * phi) / (np.sinc(k / n_table) ** 4 if droop else 1.0)
    return sk.pad_coefficients(np.fft.irfft(y, n_table)[:, None])


@pytest.mark.parametrize("n_table", [512, 256])
def test_interpolation_reproduces_a_band_limited_signal(n_table):
    """Samples equal the analytic signal at the sample's phase (quantised to 1/4096 of a table step, as the weights)
    to ~1e-5 relative: the images of harmonic k are at most (k / (N - k))^4 of it."""
    harmonics = [(1, 1.0, 0.3), (3, 0.5, -1.1), (7, 0.25, 2.0), (12, 0.2, 0.7)]
    table = _spline_table(n_table, harmonics)
    fb = sk.phase_bits(n_table)
    m = 20000
    d0 = int(0.0123457 * sk.PASS_UNITS) + 77777
    phase0 = 12345678901234567
    out = np.empty((m, 1))
    sk.segment(phase0, d0, 0, None, table, None, 0.0, 0.0, out)
    v = sk.phases_reference(phase0, d0, 0, m)
    x = ((v >> np.uint64(fb - 12)) & np.uint64((n_table << 12) - 1)).astype(np.float64) / 4096.0   # table steps
    exact = sum(a * np.cos(2 * np.pi * k * x / n_table + phi) for k, a, phi in harmonics)
    scale = sum(a for _, a, _ in harmonics)
    assert np.abs(out[:, 0] - exact).max() < 1e-5 * scale
    # and the whole thing is not trivially satisfied: without the droop correction it is visibly off
    raw = _spline_table(n_table, harmonics, droop=False)
    out_raw = np.empty((m, 1))
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
