"""The sensor noise's normals in numpy: a transcription of the C generator (``kernels/synth_noise.c``) for the tests and the
fallback without the kernel.

Stream: per block of 256 absolute samples four xoshiro256++ generators seeded from the noise key and the block
number; each step gives eight 32-bit words, one per channel (``C`` channels take ``ceil(C / 8)`` steps a sample).
Normals: the 1024-layer ziggurat (Marsaglia & Tsang 2000, in Doornik's 2005 form) whose common case is a table
look-up, a multiply and a compare; the words outside their layer's rectangle (~1.5 %) are finished with uniforms
of a second stream seeded by (key, sample, channel), so a value depends on the key, the absolute sample and the
channel only. The C code is the fast one (the sample loops add its normals); this one loops in Python over the rare
cases and over the steps (slow, for tests).
"""

from __future__ import annotations

import math

import numpy as np

from bkabem_core.synth.splitmix import GOLDEN, MASK64, mix64

_U64 = np.uint64
_SALT = 0xD1B54A32D192ED03

#: 1024 layers of the ziggurat: the base strip's edge R closes them (Marsaglia & Tsang 2000).
BITS = 10
LAYERS = 1 << BITS
R = 4.038849846109505


def _tables():
    """(x_i, f(x_i)) for i = 0 .. LAYERS in double and the fast test's float32 tables (x_i, x_{i+1} / x_i), as
    ``zn_init``: the same recurrence and libm calls (math.exp / math.log are the C library's)."""
    x, f = [0.0] * (LAYERS + 1), [0.0] * (LAYERS + 1)
    fr = math.exp(-0.5 * R * R)
    v = R * fr + math.sqrt(2.0 * math.atan(1.0)) * math.erfc(R / math.sqrt(2.0))
    x[0], x[1], f[0], f[1] = v / fr, R, fr, fr
    for i in range(2, LAYERS):
        x[i] = math.sqrt(-2.0 * math.log(v / x[i - 1] + fr))
        fr = f[i] = math.exp(-0.5 * x[i] * x[i])
    x[LAYERS], f[LAYERS] = 0.0, 1.0
    xf = np.array(x[:LAYERS], dtype=np.float32)
    rf = np.array([x[i + 1] / x[i] for i in range(LAYERS)], dtype=np.float32)
    return x, f, xf, rf


_X, _F, _XF, _RF = _tables()


def words(key: int, block: int, steps: int) -> np.ndarray:
    """(steps, 4) uint64 words of the four xoshiro256++ lanes of noise block ``block``."""
    x = mix64((key & MASK64) ^ mix64((block + GOLDEN) & MASK64))
    st = np.zeros((4, 4), dtype=np.uint64)
    for lane in range(4):
        for i in range(4):
            x = (x + GOLDEN) & MASK64
            st[i, lane] = mix64(x)
    s0, s1, s2, s3 = (st[i].copy() for i in range(4))
    out = np.empty((steps, 4), dtype=np.uint64)

    def rotl(v, k):
        return (v << _U64(k)) | (v >> _U64(64 - k))

    with np.errstate(over="ignore"):
        for k in range(steps):
            out[k] = rotl(s0 + s3, 23) + s0
            t = s1 << _U64(17)
            s2 ^= s0
            s3 ^= s1
            s1 ^= s2
            s0 ^= s3
            s2 ^= t
            s3 = rotl(s3, 45)
    return out


def _fast(w: np.ndarray):
    """(z float32, ok bool) of the fast test of 32-bit words ``w`` (uint32)."""
    i = (w & np.uint32(LAYERS - 1)).astype(np.intp)
    j = w.view(np.int32) >> BITS
    u = (2 * j + 1).astype(np.float32) * np.float32(2.0 ** -22)
    return u * _XF[i], np.abs(u) < _RF[i]


def _slow(key: int, n: int, c: int, w: int) -> np.float32:
    """The normal of sample n, channel c whose word w failed the fast test (``zn_slow``)."""
    h = mix64((key & MASK64) ^ ((n * 64 + c) * _SALT & MASK64))

    def nxt():
        nonlocal h
        h = (h + GOLDEN) & MASK64
        return mix64(h)

    def uniform():
        return ((nxt() >> 11) + 0.5) * 2.0 ** -53

    first = True
    while True:
        z, ok = _fast(np.array([w], dtype=np.uint32))
        if ok[0] and not first:
            return z[0]
        first = False
        i = w & (LAYERS - 1)
        j = w - (1 << 32) if w >> 31 else w
        u = (2 * (j >> BITS) + 1) * 2.0 ** -22
        if i == 0:
            while True:
                a = -math.log(uniform()) / R
                b = -math.log(uniform())
                if not b + b < a * a:
                    break
            return np.float32(-(R + a) if u < 0.0 else R + a)
        x = u * _X[i]
        if _F[i + 1] + uniform() * (_F[i] - _F[i + 1]) < math.exp(-0.5 * x * x):
            return np.float32(x)
        w = nxt() >> 32


def noise_reference(key: int, n0: int, n: int, n_channels: int) -> np.ndarray:
    """(n, C) float32 normals of the noise stream ``key`` at absolute samples ``n0 ..`` (what
    the sample loops add in C), in numpy."""
    c = int(n_channels)
    steps = (c + 7) // 8
    out = np.empty((int(n), c), dtype=np.float32)
    j = 0
    while j < n:
        b, first = divmod(n0 + j, 256)
        cnt = min(256 - first, n - j)
        w = words(key, b, (first + cnt) * steps)[first * steps:]          # (cnt * steps, 4) uint64
        w32 = w.view(np.uint32).reshape(cnt, steps * 8)[:, :c]            # word k = half k % 2 of lane k / 2
        z, ok = _fast(np.ascontiguousarray(w32))
        for r, ch in zip(*np.nonzero(~ok)):
            z[r, ch] = _slow(key, n0 + j + int(r), int(ch), int(w32[r, ch]))
        out[j:j + cnt] = z
        j += cnt
    return out
