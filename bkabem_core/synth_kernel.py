"""The synthesiser's sample loop in C (``_synthloop.c``), its numpy reference, and chunk features from running moments.

:func:`segment` renders the samples of one segment between two knots exactly as ``Synthesizer._segment`` does in
numpy, bit for bit (same IEEE operations in the same order), in one pass instead of ~25 passes over (m, C)
temporaries; it can also accumulate the moments of the chunk features on the fly (``acc``), so that
:func:`features_from_acc` gives ``waveform_features`` without another pass over the samples. :func:`accumulate`
adds a finished block (e.g. after the noise was added) to such accumulators. :func:`segment_reference` and
:func:`accumulate_reference` are the same computations in numpy: the tests hold the kernel to them, and callers use
them when the kernel is not built (:data:`AVAILABLE` is False).

Arguments of :func:`segment` (for sample k = 0..m-1 of the segment; see ``_synthloop.c`` for the formulas):

* ``xi0``: position of the first sample relative to knot a [samples] (``lo - a.x``);
* ``c1``, ``c2``: passes per sample at knot a and half the pass acceleration (``u = (c2 xi + c1) xi + u_frac``);
* ``u_frac``: fraction of a pass at knot a; ``warp``: optional (m,) float64 slip warp added to ``u`` [passes];
* ``table_a``, ``table_b``: (N, C) wavetables of knots a and b (N a power of 2); ``table_b`` None: no time blend;
* ``blend_scale``: ``2^16 / (b.x - a.x)``, the time-blend weight index per sample;
* ``out``: (m, C) C-contiguous, written; dtype float32 or float64, the tables' dtype;
* ``acc``: optional (C, 6) float64 accumulators per channel [sum d, sum d^2, sum d^3, sum d^4, max d, min d] of
  ``d = out - off`` (see :func:`new_acc`), updated in place; ``off``: (C,) float64, e.g. the static part.
"""

from __future__ import annotations

import ctypes
import importlib.util

import numpy as np

FRAC_BITS = 12                 # synth._FRAC_BITS
BLEND_LEVELS = 1 << 16         # synth._BLEND_LEVELS
PHASE_OFFSET = float(1 << 20)  # synth._PHASE_OFFSET

_from_buffer = ctypes.c_char.from_buffer
_addressof = ctypes.addressof


def _load():
    """{dtype: (segment, accumulate)} of the compiled kernel (bkabem_core/_synthloop.c), or None if not built."""
    spec = importlib.util.find_spec("bkabem_core._synthloop")
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    lib = ctypes.CDLL(spec.origin)
    ptr, i64, dbl = ctypes.c_void_p, ctypes.c_int64, ctypes.c_double
    fns = {}
    for dt, suf in ((np.dtype(np.float32), "f32"), (np.dtype(np.float64), "f64")):
        seg = getattr(lib, f"synth_segment_{suf}")
        seg.argtypes = [i64, i64, i64, dbl, dbl, dbl, dbl, ptr, ptr, ptr, dbl, ptr, ptr, ptr]
        seg.restype = ctypes.c_int
        acc = getattr(lib, f"synth_accumulate_{suf}")
        acc.argtypes = [i64, i64, ptr, ptr, ptr]
        acc.restype = ctypes.c_int
        fns[dt] = (seg, acc)
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
    """Shapes and dtypes of :func:`segment`'s arrays; returns (m, C, N)."""
    if out.ndim != 2:
        raise ValueError(f"out must be (m, C) (got shape {out.shape})")
    if not out.flags.writeable:
        raise ValueError("out must be writeable")
    m, c = out.shape
    dt = out.dtype
    n = table_a.shape[0]
    if table_a.dtype != dt or table_a.shape != (n, c):
        raise ValueError(f"table_a must be (N, {c}) {dt} (got {table_a.shape} {table_a.dtype})")
    if n < 1 or n & (n - 1):
        raise ValueError(f"table size must be a power of 2 (got {n})")
    if table_b is not None and (table_b.dtype != dt or table_b.shape != (n, c)):
        raise ValueError(f"table_b must be ({n}, {c}) {dt} (got {table_b.shape} {table_b.dtype})")
    if warp is not None and (warp.dtype != np.float64 or warp.shape != (m,)):
        raise ValueError(f"warp must be ({m},) float64 (got {warp.shape} {warp.dtype})")
    if acc is not None:
        if acc.dtype != np.float64 or acc.shape != (c, 6):
            raise ValueError(f"acc must be ({c}, 6) float64 (got {acc.shape} {acc.dtype})")
        if off is None or off.dtype != np.float64 or off.shape != (c,):
            raise ValueError(f"off must be ({c},) float64 with acc")
    return m, c, n


def segment(xi0: float, c1: float, c2: float, u_frac: float, warp, table_a: np.ndarray, table_b, blend_scale: float,
            out: np.ndarray, acc=None, off=None) -> None:
    """Samples of one segment into ``out`` (m, C) with the C kernel (see the module docstring).

    Raises RuntimeError if the kernel is not built, ValueError on wrong shapes, dtypes or non-contiguous arrays."""
    seg = _kernel(out.dtype)[0]
    m, c, n = _check_segment(warp, table_a, table_b, out, acc, off)
    if m == 0:
        return
    rc = seg(m, c, n, xi0, c1, c2, u_frac,
             None if warp is None else _ptr(warp, "warp"), _ptr(table_a, "table_a"),
             None if table_b is None else _ptr(table_b, "table_b"), blend_scale, _ptr(out, "out"),
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


def features_from_acc(acc: np.ndarray, n: int, off) -> dict:
    """The dict of ``synth.waveform_features`` (mean, rms, peak, peak_to_peak, crest_factor, kurtosis) from the
    accumulators of ``n`` samples per channel taken about ``off`` (C,)."""
    from .synth import _moment_features      # here, not at the top: synth may import this module

    s = acc[:, :4] / float(n)
    return _moment_features(s[:, 0], s[:, 1], s[:, 2], s[:, 3], acc[:, 4].copy(), acc[:, 5].copy(),
                            np.asarray(off, dtype=np.float64))


# ----------------------------------------------------------------------------------------- numpy references
def segment_reference(xi0: float, c1: float, c2: float, u_frac: float, warp, table_a: np.ndarray, table_b,
                      blend_scale: float, out: np.ndarray, acc=None, off=None) -> None:
    """:func:`segment` in numpy: the arithmetic of ``Synthesizer._segment``, operation for operation."""
    m, c, n = _check_segment(warp, table_a, table_b, out, acc, off)
    if m == 0:
        return
    dt = out.dtype
    q1 = 1 << FRAC_BITS
    xi = np.arange(m, dtype=np.float64)
    xi += xi0                                                     # samples since knot a
    u = xi * c2
    u += c1
    u *= xi
    u += u_frac                                                   # passes since knot a (+ its integer part)
    if warp is not None:
        u += warp
    u += PHASE_OFFSET
    u *= float(n << FRAC_BITS)
    u += 0.5
    p = u.astype(np.int64)                                        # truncation = floor (positive)
    i = (p >> FRAC_BITS) & (n - 1)
    q = p & (q1 - 1)
    frows = np.repeat((np.arange(q1, dtype=np.float64) / q1)[:, None], c, axis=1).astype(dt)
    F = np.take(frows, q, axis=0)
    A = np.take(table_a, i, axis=0)
    B = np.take(_slope(table_a), i, axis=0)
    B *= F
    if table_b is None:
        np.add(A, B, out=out)
    else:
        A += B
        C = np.take(table_b, i, axis=0)
        D = np.take(_slope(table_b), i, axis=0)
        D *= F
        C += D
        C -= A                                                    # interp(table_b) - interp(table_a)
        qs = (xi * blend_scale).astype(np.int64)
        srows = np.repeat((np.arange(BLEND_LEVELS + 1, dtype=np.float64) / BLEND_LEVELS)[:, None], c,
                          axis=1).astype(dt)
        C *= np.take(srows, qs, axis=0, mode="clip")
        np.add(A, C, out=out)
    if acc is not None:
        accumulate_reference(out, off, acc)


def _slope(table: np.ndarray) -> np.ndarray:
    """table[i + 1] - table[i] (wrapping), as the knots' precomputed slope tables."""
    s = np.empty_like(table)
    np.subtract(table[1:], table[:-1], out=s[:-1])
    np.subtract(table[0], table[-1], out=s[-1])
    return s


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
