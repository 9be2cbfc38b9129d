"""The synthesiser's sample loop in C (``_synthloop.c``), its numpy reference, and chunk features from running moments.

:func:`segment` renders ``m`` samples of ``C`` channels from a periodic table of one ball pass, at an integer phase
that advances with a constant second difference (a linear speed ramp), optionally blending in time towards a second
table (the next knot) and accumulating the moments of the chunk features on the fly (``acc``), so that
:func:`features_from_acc` gives ``waveform_features`` without another pass over the samples. :func:`accumulate` adds
a finished block (e.g. after the noise was added) to such accumulators. :func:`segment_reference` and
:func:`accumulate_reference` are the same computations in numpy: the tests hold the kernel's samples to them bit for
bit (the moments to ~1e-6: float32 blocks of 8 channels are summed in float, see ``_synthloop.c``), and callers use
them when the kernel is not built (:data:`AVAILABLE` is False).

Phase: fixed-point uint64, wrapping; one ball pass is :data:`PASS_UNITS` = 2^62 units, one table step
``2**phase_bits(N)`` units. For sample j = 0..m-1 of a call (modulo 2^64)::

    U_j = phase0 + j dphase0 + ddphase j (j - 1) / 2        (U_{j+1} = U_j + D_j, D_{j+1} = D_j + ddphase)
    V_j = U_j + warp[j]                                       (warp optional)
    i = (V_j >> FB) & (N - 1);   q = (V_j >> (FB - 12)) & 4095

Interpolation: cubic uniform B-spline of a coefficient table ``(N + 3, C)`` with wrap padding (row n holds
coefficient (n - 1) mod N; see :func:`pad_coefficients`), weights :func:`spline_weights` ``[q]``::

    va = ((w0 A[i] + w1 A[i+1]) + w2 A[i+2]) + w3 A[i+3]       in the tables' dtype, every operation rounded

Time blend (``table_b`` given): ``vb`` likewise; ``xi = j + xi0``; ``s = clip(int(xi * blend_scale), 0, 2^16) / 2^16``;
``out = va + (vb - va) * s``.

Arguments of :func:`segment`:

* ``phase0``, ``dphase0``, ``ddphase``: Python ints (any sign and size; taken modulo 2^64): phase of sample 0,
  phase increment from sample 0 to 1, and its change per sample (negative: deceleration);
* ``warp``: optional (m,) int64 phase offsets (the slip warp, in phase units, wrapping);
* ``table_a``, ``table_b``: (N + 3, C) padded coefficient tables of knots a and b (N a power of 2, 64..65536,
  float32 or float64); ``table_b`` None: no time blend;
* ``xi0``: position of sample 0 relative to knot a [samples]; ``blend_scale``: ``2^16 / (b.x - a.x)``;
* ``out``: (m, C) C-contiguous, written; dtype the tables' dtype;
* ``acc``: optional (C, 6) float64 accumulators per channel [sum d, sum d^2, sum d^3, sum d^4, max d, min d] of
  ``d = out - off`` (see :func:`new_acc`), updated in place; ``off``: (C,) float64, e.g. the static part.

Splitting a call at sample j into two calls (phase0 and dphase0 advanced as above, xi0 by j, warp sliced) gives the
same samples, provided ``xi0 + j`` is exact in double (e.g. xi0 a multiple of a power of 2 well below 2^52): the
phase is exact integer arithmetic, the blend weight is computed from the double ``j + xi0``.
"""

from __future__ import annotations

import ctypes
import importlib.util

import numpy as np

#: Phase units of one ball pass.
PASS_UNITS = 1 << 62
WEIGHT_BITS = 12               # spline weight index: bits of the fraction of a table step
BLEND_LEVELS = 1 << 16         # time-blend weight quantised to 2^-16
MIN_TABLE, MAX_TABLE = 64, 1 << 16
_MASK64 = (1 << 64) - 1

_from_buffer = ctypes.c_char.from_buffer
_addressof = ctypes.addressof


def phase_bits(n_table: int) -> int:
    """FB: phase units of one table step are 2^FB (62 - log2 N), for N a power of 2 in 64..65536."""
    n = int(n_table)
    if n < MIN_TABLE or n > MAX_TABLE or n & (n - 1):
        raise ValueError(f"table size must be a power of 2 in {MIN_TABLE}..{MAX_TABLE} (got {n})")
    return 62 - (n.bit_length() - 1)


_WEIGHTS: dict = {}        # dtype -> (table, address)


def spline_weights(dtype) -> np.ndarray:
    """(4096, 4) cubic B-spline weights [w0, w1, w2, w3] at t = q / 4096, computed in double and cast to ``dtype``
    (cached, read-only; the C kernel receives this very table)."""
    return _weights(np.dtype(dtype))[0]


def _weights(dt: np.dtype):
    """(spline_weights(dt), its address), cached (the address lookup of a read-only array costs ~3 us)."""
    hit = _WEIGHTS.get(dt)
    if hit is None:
        t = np.arange(1 << WEIGHT_BITS, dtype=np.float64) / (1 << WEIGHT_BITS)
        t2, t3 = t * t, t * t * t
        w = np.stack([(1.0 - t) ** 3 / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
                      (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0], axis=1).astype(dt)
        w.flags.writeable = False
        hit = _WEIGHTS[dt] = (w, w.ctypes.data)
    return hit


def pad_coefficients(coef: np.ndarray) -> np.ndarray:
    """(N + 3, C) table with wrap padding from (N, C) spline coefficients: row n holds coefficient (n - 1) mod N."""
    coef = np.asarray(coef)
    return np.ascontiguousarray(np.concatenate([coef[-1:], coef, coef[:2]], axis=0))


def _load():
    """{dtype: (segment, accumulate)} of the compiled kernel (bkabem_core/_synthloop.c), or None if not built."""
    spec = importlib.util.find_spec("bkabem_core._synthloop")
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    lib = ctypes.CDLL(spec.origin)
    ptr, i64, u64, dbl = ctypes.c_void_p, ctypes.c_int64, ctypes.c_uint64, ctypes.c_double
    fns = {}
    for dt, suf in ((np.dtype(np.float32), "f32"), (np.dtype(np.float64), "f64")):
        seg = getattr(lib, f"synth_segment_{suf}")
        seg.argtypes = [i64, i64, i64, ctypes.c_int, u64, u64, u64, ptr, ptr, ptr, dbl, dbl, ptr, ptr, ptr, ptr]
        seg.restype = ctypes.c_int
        acc = getattr(lib, f"synth_accumulate_{suf}")
        acc.argtypes = [i64, i64, ptr, ptr, ptr]
        acc.restype = ctypes.c_int
        fns[dt] = (seg, acc)
    for dt, suf in ((np.dtype(np.float32), "f32"), (np.dtype(np.float64), "f64")):
        nrm = getattr(lib, f"synth_normals_{suf}")
        nrm.argtypes = [ctypes.c_uint64, i64, ptr]
        nrm.restype = ctypes.c_int
        fns[("normals", dt)] = nrm
    feats = lib.synth_features
    feats.argtypes = [i64, i64, ptr, ptr, ptr]
    feats.restype = ctypes.c_int
    fns["features"] = feats
    return fns


_FNS = _load()
#: True if the C kernel is built (``pip install -e .`` or ``python setup.py build_ext --inplace``).
AVAILABLE = _FNS is not None


def _ptr(a: np.ndarray, name: str) -> int:
    """Address of the first element of a C-contiguous array (ValueError if it is not C-contiguous)."""
    if not a.flags.c_contiguous:
        raise ValueError(f"{name} must be C-contiguous")
    if a.flags.writeable and a.size:
        return _addressof(_from_buffer(a))      # ~4x cheaper than a.ctypes.data
    return a.ctypes.data


def _kernel(dtype):
    if _FNS is None:
        raise RuntimeError("the C sample loop (bkabem_core/_synthloop.c) is not built: run `pip install -e .`")
    fns = _FNS.get(dtype)
    if fns is None:
        raise ValueError(f"dtype must be float32 or float64 (got {dtype})")
    return fns


def _check_segment(warp, table_a, table_b, out, acc, off):
    """Shapes and dtypes of :func:`segment`'s arrays; returns (m, C, N, FB)."""
    if out.ndim != 2:
        raise ValueError(f"out must be (m, C) (got shape {out.shape})")
    if not out.flags.writeable:
        raise ValueError("out must be writeable")
    m, c = out.shape
    dt = out.dtype
    if dt != np.float32 and dt != np.float64:
        raise ValueError(f"dtype must be float32 or float64 (got {dt})")
    if table_a.ndim != 2 or table_a.dtype != dt or table_a.shape[1] != c:
        raise ValueError(f"table_a must be (N + 3, {c}) {dt} (got {table_a.shape} {table_a.dtype})")
    n = table_a.shape[0] - 3
    fb = phase_bits(n)
    if table_b is not None and (table_b.dtype != dt or table_b.shape != table_a.shape):
        raise ValueError(f"table_b must be {table_a.shape} {dt} (got {table_b.shape} {table_b.dtype})")
    if warp is not None and (warp.dtype != np.int64 or warp.shape != (m,)):
        raise ValueError(f"warp must be ({m},) int64 (got {warp.shape} {warp.dtype})")
    if acc is not None:
        if acc.dtype != np.float64 or acc.shape != (c, 6):
            raise ValueError(f"acc must be ({c}, 6) float64 (got {acc.shape} {acc.dtype})")
        if off is None or off.dtype != np.float64 or off.shape != (c,):
            raise ValueError(f"off must be ({c},) float64 with acc")
    return m, c, n, fb


def segment(phase0: int, dphase0: int, ddphase: int, warp, table_a: np.ndarray, table_b, xi0: float,
            blend_scale: float, out: np.ndarray, acc=None, off=None) -> None:
    """Samples of one call into ``out`` (m, C) with the C kernel (see the module docstring).

    Raises RuntimeError if the kernel is not built, ValueError on wrong shapes, dtypes or non-contiguous arrays."""
    seg = _kernel(out.dtype)[0]
    m, c, n, fb = _check_segment(warp, table_a, table_b, out, acc, off)
    if m == 0:
        return
    rc = seg(m, c, n, fb, int(phase0) & _MASK64, int(dphase0) & _MASK64, int(ddphase) & _MASK64,
             None if warp is None else _ptr(warp, "warp"), _ptr(table_a, "table_a"),
             None if table_b is None else _ptr(table_b, "table_b"), xi0, blend_scale,
             _weights(out.dtype)[1], _ptr(out, "out"),
             None if acc is None else _ptr(acc, "acc"), None if acc is None else _ptr(off, "off"))
    if rc:
        raise ValueError(f"synth_segment rejected m={m}, C={c}, N={n}")


def accumulate(x: np.ndarray, off: np.ndarray, acc: np.ndarray) -> None:
    """Add the moments of the block ``x`` (n, C) to ``acc`` (C, 6) with the C kernel (see :func:`new_acc`)."""
    fn = _kernel(x.dtype)[1]
    if x.ndim != 2:
        raise ValueError(f"x must be (n, C) (got shape {x.shape})")
    n, c = x.shape
    if acc.dtype != np.float64 or acc.shape != (c, 6):
        raise ValueError(f"acc must be ({c}, 6) float64 (got {acc.shape} {acc.dtype})")
    if off.dtype != np.float64 or off.shape != (c,):
        raise ValueError(f"off must be ({c},) float64 (got {off.shape} {off.dtype})")
    if n == 0:
        return
    if fn(n, c, _ptr(x, "x"), _ptr(off, "off"), _ptr(acc, "acc")):
        raise ValueError(f"synth_accumulate rejected n={n}, C={c}")


def new_acc(n_channels: int) -> np.ndarray:
    """Empty feature accumulators (C, 6): sums 0, max -inf, min +inf."""
    acc = np.zeros((n_channels, 6))
    acc[:, 4] = -np.inf
    acc[:, 5] = np.inf
    return acc


def normals(key: int, n: int, dtype=np.float32) -> np.ndarray:
    """``n`` standard normal numbers of the stream ``key`` (0 <= key < 2^64), float32 or float64, from the C
    generator (xoshiro256+ and Doornik's ziggurat, ``_synthloop.c``): the same key always gives the same numbers.
    Raises RuntimeError if the kernel is not built."""
    if _FNS is None:
        raise RuntimeError("the C kernel (bkabem_core/_synthloop.c) is not built: run `pip install -e .`")
    dt = np.dtype(dtype)
    out = np.empty(int(n), dtype=dt)
    if _FNS[("normals", dt)](int(key) & _MASK64, out.size, _ptr(out, "out")):
        raise ValueError(f"synth_normals rejected n={n}")
    return out


FEATURE_NAMES = ("mean", "rms", "peak", "peak_to_peak", "crest_factor", "kurtosis")


def features_from_acc(acc: np.ndarray, n: int, off) -> dict:
    """The dict of ``synth.waveform_features`` (mean, rms, peak, peak_to_peak, crest_factor, kurtosis) from the
    accumulators of ``n`` samples per channel taken about ``off`` (C,), float64 (C,) arrays (views of one block).
    In C when the kernel is built (``synth_features``), else :func:`features_from_acc_reference`."""
    if _FNS is None:
        return features_from_acc_reference(acc, n, off)
    c = acc.shape[0]
    off = np.ascontiguousarray(off, dtype=np.float64)
    if acc.dtype != np.float64 or acc.shape != (c, 6) or not acc.flags.c_contiguous or off.shape != (c,):
        raise ValueError(f"acc must be (C, 6) float64 and off (C,) (got {acc.shape} {acc.dtype}, {off.shape})")
    out = np.empty((6, c))
    if _FNS["features"](c, int(n), _ptr(acc, "acc"), _ptr(off, "off"), _ptr(out, "out")):
        raise ValueError(f"synth_features rejected C={c}, n={n}")
    return dict(zip(FEATURE_NAMES, out))


def features_from_acc_reference(acc: np.ndarray, n: int, off) -> dict:
    """:func:`features_from_acc` in numpy (``synth._moment_features``)."""
    from .synth import _moment_features      # here, not at the top: synth imports this module

    s = acc[:, :4] / float(n)
    return _moment_features(s[:, 0], s[:, 1], s[:, 2], s[:, 3], acc[:, 4].copy(), acc[:, 5].copy(),
                            np.asarray(off, dtype=np.float64))


# ----------------------------------------------------------------------------------------- numpy references
def phases_reference(phase0: int, dphase0: int, ddphase: int, m: int) -> np.ndarray:
    """U_j, j = 0..m-1 (uint64, modulo 2^64) by the closed form phase0 + j dphase0 + ddphase j (j - 1) / 2."""
    j = np.arange(m, dtype=np.uint64)
    one, two = np.uint64(1), np.uint64(2)
    even = (j & one) == 0
    # j (j - 1) / 2 exactly (mod 2^64): halve the even factor first, so that no product overflows before the halving
    tri = np.where(even, (j >> one) * (j - one), j * ((j - one) // two))
    u = np.full(m, int(phase0) & _MASK64, dtype=np.uint64)       # (j - 1 wraps at j = 0: the product is 0 anyway)
    u += j * np.uint64(int(dphase0) & _MASK64)
    u += tri * np.uint64(int(ddphase) & _MASK64)
    return u


def segment_reference(phase0: int, dphase0: int, ddphase: int, warp, table_a: np.ndarray, table_b, xi0: float,
                      blend_scale: float, out: np.ndarray, acc=None, off=None) -> None:
    """:func:`segment` in numpy, operation for operation (the same IEEE operations in the same order and precision)."""
    m, c, n, fb = _check_segment(warp, table_a, table_b, out, acc, off)
    if m == 0:
        return
    dt = out.dtype
    v = phases_reference(phase0, dphase0, ddphase, m)
    if warp is not None:
        v += warp.view(np.uint64)
    i = ((v >> np.uint64(fb)) & np.uint64(n - 1)).astype(np.intp)
    q = ((v >> np.uint64(fb - WEIGHT_BITS)) & np.uint64((1 << WEIGHT_BITS) - 1)).astype(np.intp)
    w = spline_weights(dt)[q]                                     # (m, 4)

    def interp(table):
        val = w[:, 0:1] * table[i]
        for k in (1, 2, 3):
            val += w[:, k:k + 1] * table[i + k]
        return val

    va = interp(table_a)
    if table_b is None:
        out[...] = va
    else:
        vb = interp(table_b)
        xi = np.arange(m, dtype=np.float64)
        xi += xi0
        sv = xi * blend_scale
        sv = np.where(sv > 0.0, np.minimum(sv, float(BLEND_LEVELS)), 0.0)   # numpy clip after astype, NaN -> 0
        s = (sv.astype(np.int64) / float(BLEND_LEVELS)).astype(dt)
        vb -= va
        vb *= s[:, None]
        np.add(va, vb, out=out)
    if acc is not None:
        accumulate_reference(out, off, acc)


def accumulate_reference(x: np.ndarray, off: np.ndarray, acc: np.ndarray) -> None:
    """:func:`accumulate` in numpy (sums in another order: equal to rounding, extremes exactly)."""
    if x.shape[0] == 0:
        return
    d = x.astype(np.float64) - off
    d2 = d * d
    acc[:, 0] += d.sum(axis=0)
    acc[:, 1] += d2.sum(axis=0)
    acc[:, 2] += (d2 * d).sum(axis=0)
    acc[:, 3] += (d2 * d2).sum(axis=0)
    np.maximum(acc[:, 4], d.max(axis=0), out=acc[:, 4])
    np.minimum(acc[:, 5], d.min(axis=0), out=acc[:, 5])
