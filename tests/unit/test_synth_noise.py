"""The sensor noise's normal numbers (``kernels/synth_noise.c``: xoshiro256++ per block of 256 samples, a 1024-layer
ziggurat) checked the way a statistician would, with textbook estimators written here: moments against their
standard errors, Kolmogorov-Smirnov and chi-square against the normal law, tail probabilities, auto- and cross-
correlation (whiteness), and a flat periodogram. Thresholds are ~5 standard errors; the streams are seeded, so the
tests are deterministic. Also: the AVX2 code, the scalar code and the numpy transcription give the same bits,
any split of the samples gives the same numbers, and the key decides the stream. The normals are taken where the
synthesiser takes them: from the sample loop (a zero table, sigma 1: the samples are the normals)."""

import math

import numpy as np
import pytest
from scipy import stats

from bkabem_core.synth import kernel as sk
from bkabem_core.synth import noise as synth_noise
from bkabem_core.synth.randomness import noise_key

if not sk.AVAILABLE:     # the set-up builds them (make install): fail, never skip, when they are missing
    pytest.fail("the C kernel is not built: run `make install`", pytrace=False)

KEY = noise_key(11)


def noise_fill(key: int, n0: int, n: int, c: int, avx2: bool = True) -> np.ndarray:
    """(n, c) float32 normals of the stream ``key`` at absolute samples n0 .. n0 + n - 1, as the sample loop adds
    them: a zero table and sigma 1 (0 + 1 z is z exactly); ``avx2=False`` takes the scalar code (cap 0)."""
    out = np.empty((n, c), np.float32)
    table = np.zeros((67, c), np.float32)
    old = sk._set_isa_cap(2 if avx2 else 0)
    try:
        sk.segment(0, 1 << 40, 0, None, table, None, 0.0, 0.0, out, noise=(key, n0, np.ones(c, np.float32), None))
    finally:
        sk._set_isa_cap(old)
    return out


@pytest.fixture(scope="module")
def z():
    """(500 000, 8) normals of one key from absolute sample 12 345 (4 million numbers)."""
    return noise_fill(KEY, 12_345, 500_000, 8).astype(np.float64)


def test_moments(z):
    x = z.ravel()
    n = x.size
    m = x.mean()
    d = x - m
    var = np.mean(d ** 2)
    skew = np.mean(d ** 3) / var ** 1.5
    kurt = np.mean(d ** 4) / var ** 2
    assert abs(m) < 5 / math.sqrt(n)
    assert abs(var - 1) < 5 * math.sqrt(2 / n)
    assert abs(skew) < 5 * math.sqrt(6 / n)
    assert abs(kurt - 3) < 5 * math.sqrt(24 / n)
    for c in range(8):                                       # every channel on its own
        assert abs(z[:, c].mean()) < 5 / math.sqrt(z.shape[0])
        assert abs(z[:, c].var() - 1) < 5 * math.sqrt(2 / z.shape[0])


def test_law_ks_chi2_and_tails(z):
    x = z.ravel()
    n = x.size
    assert stats.kstest(x[:1_000_000], "norm").pvalue > 1e-3
    edges = stats.norm.ppf(np.linspace(0, 1, 201))             # 200 cells of equal probability
    counts = np.histogram(x, bins=edges)[0]
    chi2 = np.sum((counts - n / 200) ** 2 / (n / 200))
    assert stats.chi2.sf(chi2, 199) > 1e-4
    # tails: beyond 2 and 3, and beyond the ziggurat's base edge R (drawn by the slow path's tail method)
    for a in (2.0, 3.0, synth_noise.R):
        p = 2 * stats.norm.sf(a)
        got = np.mean(np.abs(x) > a)
        assert abs(got / p - 1) < 5 / math.sqrt(p * n), (a, got, p)
    assert np.all(np.isfinite(x)) and np.abs(x).max() < 7.0


def test_whiteness(z):
    """No correlation between lags 1..16 of a channel, nor between channels (the 8 lanes of one step)."""
    n = z.shape[0]
    d = z - z.mean(axis=0)
    var = np.mean(d * d, axis=0)
    for c in range(8):
        for lag in range(1, 17):
            r = np.mean(d[lag:, c] * d[:-lag, c]) / var[c]
            assert abs(r) < 5 / math.sqrt(n), (c, lag, r)
    cc = np.corrcoef(d.T)
    assert np.all(np.abs(cc[~np.eye(8, dtype=bool)]) < 5 / math.sqrt(n))
    # flat periodogram: Welch averages of 1024-point segments, in 32 bands each within 5 standard errors of the
    # mean level (a Welch average of K segments has relative standard error 1 / sqrt(K x bins per band))
    seg = d[: n // 1024 * 1024, 0].reshape(-1, 1024)
    p = np.mean(np.abs(np.fft.rfft(seg, axis=1)[:, 1:513]) ** 2, axis=0)
    bands = p.reshape(32, 16).mean(axis=1)
    rel = 1 / math.sqrt(seg.shape[0] * 16)
    assert np.all(np.abs(bands / p.mean() - 1) < 5 * rel), bands / p.mean()


@pytest.mark.parametrize("c", [8, 3, 11, 1])
def test_avx2_scalar_and_numpy_give_the_same_bits(c):
    """The AVX2 code (C <= 8), the scalar code and the numpy transcription, across block borders and with the
    slow path (~0.4 % of the numbers: the wedges and the tail beyond R) taken hundreds of times."""
    n0, n = 1000, 20_000 if c == 8 else 3_000
    fast = noise_fill(KEY, n0, n, c, avx2=True)
    scalar = noise_fill(KEY, n0, n, c, avx2=False)
    ref = synth_noise.noise_reference(KEY, n0, n, c)
    np.testing.assert_array_equal(fast, scalar)
    np.testing.assert_array_equal(fast, ref)
    if c == 8:                                          # the slow path was exercised: words outside the fast test
        w = np.concatenate([synth_noise.words(KEY, b, 256) for b in range(n0 // 256, (n0 + n) // 256)])
        _, ok = synth_noise._fast(w.view(np.uint32))
        assert 0.002 < np.mean(~ok) < 0.007
        assert np.sum(~ok & ((w.view(np.uint32) & (synth_noise.LAYERS - 1)) == 0)) > 0    # base strip


def test_any_split_gives_the_same_numbers_and_the_key_decides():
    whole = noise_fill(KEY, 777, 5000, 8)
    rng = np.random.default_rng(3)
    cuts = np.sort(rng.choice(np.arange(1, 5000), 12, replace=False))
    parts = [noise_fill(KEY, 777 + a, b - a, 8) for a, b in zip(np.r_[0, cuts], np.r_[cuts, 5000])]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    np.testing.assert_array_equal(noise_fill(noise_key(11), 777, 5000, 8), whole)
    other = noise_fill(noise_key(12), 777, 5000, 8)
    assert abs(np.corrcoef(other.ravel(), whole.ravel())[0, 1]) < 5 / math.sqrt(whole.size)
    # the first channels of a wider stream are not the narrow one's (C > 8 takes two steps a sample)
    np.testing.assert_array_equal(noise_fill(KEY, 777, 100, 3), whole[:100, :3])


def test_noise_add_is_x_plus_sigma_z():
    """The fused AVX2 add (8 float32 channels) = x + sigma z (+ extra) with the same normals."""
    rng = np.random.default_rng(5)
    x = rng.standard_normal((3000, 8)).astype(np.float32)
    extra = rng.standard_normal((3000, 8)).astype(np.float32)
    sigma = rng.uniform(0.1, 2.0, 8).astype(np.float32)
    zz = noise_fill(KEY, 300, 3000, 8)
    y = x.copy()
    sk.noise_add(y, KEY, 300, sigma, extra=extra)
    np.testing.assert_array_equal(y, (x + sigma * zz) + extra)
