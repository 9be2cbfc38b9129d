"""Tests of bkabem_core.synth.kernel: the C sample loop (kernels/synth_segment.c) against its numpy reference (bit
for bit, on every instruction-set path), its chunk invariance, the accuracy of the cubic B-spline interpolation, the
running-moment features, the carrier mix and the slip warp.

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
    assert sk.AVAILABLE, "bkabem_core/kernels is not built: run `pip install -e .`"


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


def _pad(coef: np.ndarray) -> np.ndarray:
    """(N + 3, C) table with wrap padding from (N, C) spline coefficients: row n holds coefficient (n - 1) mod N."""
    coef = np.asarray(coef)
    return np.ascontiguousarray(np.concatenate([coef[-1:], coef, coef[:2]], axis=0))


@pytest.fixture(params=[2, 0], ids=["simd", "baseline"])
def isa(request):
    """The kernels' instruction-set cap: the vector paths (if the CPU has them) and the baseline."""
    old = sk._set_isa_cap(request.param)
    yield request.param
    sk._set_isa_cap(old)


def _case(rng, dtype, n_table, c, m, blend, warp, big_warp=False):
    fb = sk.phase_bits(n_table)
    ta = _pad(rng.standard_normal((n_table, c))).astype(dtype)
    tb = _pad(rng.standard_normal((n_table, c))).astype(dtype) if blend else None
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
def test_segment_equals_reference_bit_for_bit(dtype, n_table, c, blend, warp, m, isa):
    """The C loop bit for bit the reference, on every path the CPU takes; nothing written outside ``out``; the fused
    moments those of a separate accumulation of the same samples."""
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
        off = rng.standard_normal(c)
        acc, acc_sep, acc_ref = sk.new_acc(c), sk.new_acc(c), sk.new_acc(c)
        out2 = np.empty((m, c), dtype)
        sk.segment(*args, out2, acc, off)
        assert np.array_equal(out2, ref)
        sk.accumulate(out2, off, acc_sep)
        assert np.array_equal(acc, acc_sep)
        sk.accumulate_reference(out2, off, acc_ref)
        _assert_moments(acc, acc_ref, dtype)
        assert np.array_equal(acc[:, 4:], acc_ref[:, 4:])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("c", [8, 4, 3])
def test_segment_noise_and_extra_are_the_reference(dtype, c, isa):
    """Noise and an extra block inside the loop: the reference's samples (its normals: the numpy transcription of
    the generator) bit for bit, with the noise blocks' borders inside the call."""
    rng = np.random.default_rng([c, 5])
    m = 700
    args = _case(rng, dtype, 256, c, m, True, True)
    sigma = rng.uniform(0.1, 2.0, c).astype(dtype)
    extra = rng.standard_normal((m, c)).astype(dtype)
    noise = (123456789, 2_000_000_100, sigma, extra)
    got, ref = np.empty((m, c), dtype), np.empty((m, c), dtype)
    sk.segment(*args, got, noise=noise)
    sk.segment_reference(*args, ref, noise=noise)
    assert np.array_equal(got, ref)


def test_segment_covers_every_row_weight_and_blend_clip():
    """A fast, accelerating phase sweeps all rows and weight indices, xi from < 0 to > length (blend clipped)."""
    rng = np.random.default_rng(7)
    for dtype in (np.float32, np.float64):
        for n_table in (64, 65536):
            ta = _pad(rng.standard_normal((n_table, 4))).astype(dtype)
            tb = _pad(rng.standard_normal((n_table, 4))).astype(dtype)
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
    sk.segment(*args, a)
    p0, d0, dd = args[:3]
    sk.segment(p0 - (1 << 64), d0 + (3 << 64), (dd & M64) - (5 << 64), *args[3:], b)
    assert np.array_equal(a, b)
    sk.segment_reference(p0 + (1 << 64), d0 - (1 << 64), dd + (1 << 64), *args[3:], b)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("blend,warp", [(False, False), (True, False), (True, True)])
def test_chunk_invariance(dtype, blend, warp, isa):
    """Two calls split at any j give the samples of one call (xi0 a multiple of 1/8: xi0 + j exact): a sample's
    operations do not depend on its place in a block."""
    rng = np.random.default_rng([3, blend, warp])
    m, c = 1500, 8
    args = list(_case(rng, dtype, 512, c, m, blend, warp, big_warp=True))
    args[6] = 2.375
    whole = np.empty((m, c), dtype)
    sk.segment(*args, whole)
    p0, d0, dd, w = args[:4]
    for j in (0, 1, 2, 3, 5, 255, 256, 257, 258, 700, 1021, m - 1, m):
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
    return _pad(np.fft.irfft(y, n_table)[:, None])


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
    channels go through the float block sums (synth_block.c, moments8_f32_avx2), ~1e-6 of a sum; everything else
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
    """The carrier mix of line families with a carrier (the per-family loop): C bit for bit its numpy reference."""
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
