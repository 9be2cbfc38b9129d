"""The synthesiser's sample loop in C (``_synthloop.c``), its numpy reference, and chunk features from running moments.

:func:`segment` renders ``m`` samples of ``C`` channels from a periodic table of one ball pass, at an integer phase
that advances with a constant second difference (a linear speed ramp), optionally blending in time towards a second
table (the next knot) and accumulating the moments of the chunk features on the fly (``acc``), so that
:func:`features_from_acc` gives ``waveform_features`` without another pass over the samples. :func:`accumulate` adds
a finished block (e.g. after the noise was added) to such accumulators. :func:`segment_reference` and
:func:`accumulate_reference` are the same computations in numpy: the tests hold the kernel's samples to them bit for
bit (the moments to ~1e-6: float32 blocks of 8 channels are summed in float, see ``_synthloop.c``), and callers use
them when the kernel is not built (:data:`AVAILABLE` is False). Exception: float32 with 8 channels on a CPU with AVX2
and FMA (:data:`FAST_PATH`) takes a fast path with fused multiply-adds, whose samples differ from the reference by
float rounding (a few 2^-24 of the taps' magnitude; still chunk invariant); ``segment(..., exact=True)`` takes the
generic path, bit for bit the reference, everywhere.

:func:`knot_table` builds the padded spline table of a knot from the modal sum's amplitudes in C (quarter-wave
symmetry, sums in double; :func:`quarter_basis` holds its cosines and sines), :func:`knot_table_reference` is the
direct formula in numpy.

Phase: fixed-point uint64, wrapping; one ball pass is :data:`PASS_UNITS` = 2^62 units, one table step
``2**phase_bits(N)`` units. For sample j = 0..m-1 of a call (modulo 2^64)::

    U_j = phase0 + j dphase0 + ddphase j (j - 1) / 2        (U_{j+1} = U_j + D_j, D_{j+1} = D_j + ddphase)
    V_j = U_j + warp[j]                                       (warp optional)
    i = (V_j >> FB) & (N - 1);   q = (V_j >> (FB - 24)) & (2^24 - 1)

Interpolation: cubic uniform B-spline of a coefficient table ``(N + 3, C)`` with wrap padding (row n holds
coefficient (n - 1) mod N; see :func:`pad_coefficients`), weights :func:`spline_weights` ``(q)``, computed from the
fraction ``t = q 2^-24`` of the table step (exact in float32) by one fixed sequence of operations in the tables'
dtype (the C kernel's, see :func:`spline_weights`)::

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
  ``d = out - off`` (see :func:`new_acc`), updated in place; ``off``: (C,) float64, e.g. the static part (ignored
  without ``acc``);
* ``exact``: True takes the generic path (bit for bit :func:`segment_reference`) also where the fast path applies.

Splitting a call at sample j into two calls (phase0 and dphase0 advanced as above, xi0 by j, warp sliced) gives the
same samples, provided ``xi0 + j`` is exact in double (e.g. xi0 a multiple of a power of 2 well below 2^52): the
phase is exact integer arithmetic, the blend weight is computed from the double ``j + xi0``.
"""

from __future__ import annotations

import ctypes
import importlib
import importlib.util
import math

import numpy as np

from bkabem_core.synth.features import _moment_features
from bkabem_core.synth.noise import noise_reference  # noqa: F401  (the numpy transcription of the noise, used below)

#: Phase units of one ball pass.
PASS_UNITS = 1 << 62
FRAC_BITS = 24                 # bits of the fraction of a table step the spline weights are computed from
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


def spline_weights(frac, dtype) -> np.ndarray:
    """(n, 4) cubic B-spline weights [w0, w1, w2, w3] at the fractions ``t = frac * 2^-24`` of a table step
    (``frac``: integers in [0, 2^24)), in ``dtype`` (float32 or float64), bit for bit those of the C kernel::

        s = 1 - t;  t2 = t t, s2 = s s;  t3 = t2 t, s3 = s2 s
        w0 = s3 (1/6);  w1 = 2/3 - (t2 (2 - t)) 0.5;  w2 = 2/3 - (s2 (2 - s)) 0.5;  w3 = t3 (1/6)

    every operation rounded in ``dtype`` (1/6 and 2/3 rounded to it): the uniform cubic B-spline
    (1-t)^3/6, (3t^3 - 6t^2 + 4)/6, (-3t^3 + 3t^2 + 3t + 1)/6, t^3/6 to a few units of the dtype's rounding."""
    return np.stack(_weights_from_fraction(np.asarray(frac), np.dtype(dtype)), axis=1)


def _weights_from_fraction(frac: np.ndarray, dt: np.dtype):
    """(w0, w1, w2, w3) arrays of :func:`spline_weights` (the operation sequence of ``_synthloop.c``, WEIGHT_BLOCK)."""
    f = dt.type
    t = frac.astype(dt)                       # exact: frac < 2^24
    t *= f(2.0 ** -FRAC_BITS)
    s = f(1.0) - t
    t2, s2 = t * t, s * s
    t3, s3 = t2 * t, s2 * s
    e, g = f(2.0) - t, f(2.0) - s
    e *= t2
    g *= s2
    e *= f(0.5)
    g *= f(0.5)
    sixth, two_thirds = f(1.0 / 6.0), f(2.0 / 3.0)
    s3 *= sixth
    t3 *= sixth
    return s3, two_thirds - e, two_thirds - g, t3


def empty_aligned(shape, dtype=np.float32, align: int = 64) -> np.ndarray:
    """Uninitialised C-contiguous array whose first element is at a multiple of ``align`` bytes (a view of a slightly
    larger buffer; ~2.5 us against ~0.4 us for np.empty). Why: numpy aligns to 16 bytes, so an 8-channel float32 row
    (32 bytes) of a table or an output block can straddle a cache line every other row; the fast path's vector loads
    and stores then cost up to ~10 % more (measured 0-10 %, bench/bench_loop.py). Worth it for buffers
    used many times, e.g. the knot tables (:func:`knot_table`'s ``table_out``); row slices of an aligned 8 x float32
    block stay 32-byte aligned."""
    dt = np.dtype(dtype)
    shape = (int(shape),) if isinstance(shape, (int, np.integer)) else tuple(shape)
    count = math.prod(shape)
    raw = np.empty(count + align // dt.itemsize + 1, dtype=dt)
    gap = -_addressof(_from_buffer(raw)) % align              # (raw.ctypes.data costs ~2 us)
    if gap % dt.itemsize == 0:                                  # numpy allocates at multiples of 16 bytes
        return raw[gap // dt.itemsize:gap // dt.itemsize + count].reshape(shape)
    raw = np.empty(count * dt.itemsize + align, dtype=np.uint8)
    gap = -_addressof(_from_buffer(raw)) % align
    return raw[gap:gap + count * dt.itemsize].view(dt).reshape(shape)


def pad_coefficients(coef: np.ndarray) -> np.ndarray:
    """(N + 3, C) table with wrap padding from (N, C) spline coefficients: row n holds coefficient (n - 1) mod N."""
    coef = np.asarray(coef)
    return np.ascontiguousarray(np.concatenate([coef[-1:], coef, coef[:2]], axis=0))


def _load():
    """(extension module, {name: ctypes function}) of the compiled kernel (bkabem_core/kernels/_synthloop.c), or None if it
    is not built. segment, knot_table, band_rms and features are the module's Python functions (cheap calls, see
    _synthloop.c), the others ctypes functions of the same library."""
    spec = importlib.util.find_spec("bkabem_core.kernels._synthloop")
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    ext = importlib.import_module("bkabem_core.kernels._synthloop")
    if not hasattr(ext, "segment"):                     # a stale build of an older source
        return None
    lib = ctypes.CDLL(spec.origin)
    ptr, i64 = ctypes.c_void_p, ctypes.c_int64
    fns = {}
    for dt, suf in ((np.dtype(np.float32), "f32"), (np.dtype(np.float64), "f64")):
        acc = getattr(lib, f"synth_accumulate_{suf}")
        acc.argtypes = [i64, i64, ptr, ptr, ptr]
        acc.restype = ctypes.c_int
        fns[dt] = acc
        mix = getattr(lib, f"synth_carrier_mix_{suf}", None)
        if mix is not None:
            mix.argtypes = [i64, i64, ptr, ptr, ptr, ptr]
            mix.restype = ctypes.c_int
            fns[("carrier_mix", dt)] = mix
        nrm = getattr(lib, f"synth_normals_{suf}")
        nrm.argtypes = [ctypes.c_uint64, i64, ptr]
        nrm.restype = ctypes.c_int
        fns[("normals", dt)] = nrm
    sw = getattr(lib, "synth_slip_warp", None)
    if sw is not None:
        dbl = ctypes.c_double
        sw.argtypes = [i64, dbl, dbl, dbl, dbl, ptr, i64, i64, ptr, i64, ptr]
        sw.restype = ctypes.c_int
        fns["slip_warp"] = sw
    ft = lib.synth_family_tables
    ft.argtypes = [i64, i64, i64] + [ptr] * 12
    ft.restype = ctypes.c_int
    fns["family_tables"] = ft
    ls = lib.synth_lines_segment_f32
    ls.argtypes = [i64, i64, i64] + [ptr] * 11 + [ctypes.c_double, ctypes.c_double, ptr, ptr, ptr,
                                                  ctypes.c_uint64, i64, ptr, ptr, ptr, ptr, i64, ptr, i64, i64, ptr]
    fr = lib.synth_floor_render
    fr.argtypes = [i64, i64, i64, i64, i64, ptr, ptr, i64, ptr, ptr, ptr]
    fr.restype = ctypes.c_int
    fns["floor_render"] = fr
    fs_ = getattr(lib, "synth_floor_spectrum", None)
    if fs_ is not None:
        fs_.argtypes = [ctypes.c_uint64, i64, i64, ptr, ctypes.c_double, ptr, ctypes.c_int]
        fs_.restype = ctypes.c_int
        fns["floor_spectrum"] = fs_
        fq = lib.synth_floor_quantise
        fq.argtypes = [i64, i64, ptr, ptr, ptr]
        fq.restype = ctypes.c_int
        fns["floor_quantise"] = fq
    ls.restype = ctypes.c_int
    fns["lines_segment"] = ls
    nf = lib.synth_noise_fill
    nf.argtypes = [ctypes.c_uint64, i64, i64, i64, ctypes.c_int, ptr]
    nf.restype = ctypes.c_int
    fns["noise_fill"] = nf
    for dt, suf in ((np.dtype(np.float32), "f32"), (np.dtype(np.float64), "f64")):
        na = getattr(lib, f"synth_noise_add_{suf}")
        na.argtypes = [i64, i64, ptr, ctypes.c_uint64, i64, ptr, ptr, ptr, ptr]
        na.restype = ctypes.c_int
        fns[("noise_add", dt)] = na
    lib.synth_fast_path.argtypes = []
    lib.synth_fast_path.restype = ctypes.c_int
    fns["fast_path"] = bool(lib.synth_fast_path())
    fns["lib"] = lib
    return ext, fns


_LOADED = _load()
_EXT, _FNS = _LOADED if _LOADED is not None else (None, None)
_EXT_LIB = _FNS["lib"] if _FNS is not None else None
#: True if the C kernel is built (``pip install -e .`` or ``python setup.py build_ext --inplace``).
AVAILABLE = _FNS is not None
#: True if :func:`segment` takes the fast path (fused multiply-adds) for float32 with 8 channels on this CPU.
FAST_PATH = bool(AVAILABLE and _FNS["fast_path"])
_segment_c = _EXT.segment if AVAILABLE else None


def _set_isa_cap(cap: int) -> int:
    """Cap the run-time dispatch of the C kernels (2: AVX-512 knot table, 1: AVX2 + FMA, 0: baseline only) for the
    tests of the other paths; returns the previous cap. Process-wide: not while kernels run in other threads."""
    if not AVAILABLE:
        return 0
    fn = _EXT_LIB.synth_set_isa_cap
    fn.argtypes, fn.restype = [ctypes.c_int], ctypes.c_int
    return fn(int(cap))


def _set_reference_paths(on: bool) -> bool:
    """Route the line-set kernel's AVX2 rows and the 4-channel noise through their previous code (one family a pass,
    one sample a register; the 8-lane noise buffer), the tests' reference for the newer code (the same bits);
    returns the previous setting. Process-wide: not while kernels run in other threads."""
    if not AVAILABLE:
        return False
    fn = _EXT_LIB.synth_set_reference_paths
    fn.argtypes, fn.restype = [ctypes.c_int], ctypes.c_int
    return bool(fn(int(bool(on))))


def fast_path() -> bool:
    """True if :func:`segment` takes the fast path for float32 with 8 channels now (CPU and :func:`_set_isa_cap`)."""
    return bool(AVAILABLE and _EXT_LIB.synth_fast_path())


_knot_table_c = _EXT.knot_table if AVAILABLE else None
_band_rms_c = getattr(_EXT, "band_rms", None) if AVAILABLE else None
_features_c = getattr(_EXT, "features", None) if AVAILABLE else None


def _ptr(a: np.ndarray, name: str) -> int:
    """Address of the first element of a C-contiguous array (ValueError if it is not C-contiguous)."""
    if not a.flags.c_contiguous:
        raise ValueError(f"{name} must be C-contiguous")
    if a.flags.writeable and a.size:
        return _addressof(_from_buffer(a))      # ~4x cheaper than a.ctypes.data
    return a.ctypes.data


def _accumulate_fn(dtype):
    if _FNS is None:
        raise RuntimeError("the C sample loop (bkabem_core/kernels/_synthloop.c) is not built: run `pip install -e .`")
    fn = _FNS.get(dtype)
    if fn is None:
        raise ValueError(f"dtype must be float32 or float64 (got {dtype})")
    return fn


def _check_segment(warp, table_a, table_b, out, acc, off):
    """Shapes and dtypes of :func:`segment_reference`'s arrays; returns (m, C, N, FB)."""
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
            blend_scale: float, out: np.ndarray, acc=None, off=None, exact: bool = False, noise=None) -> None:
    """Samples of one call into ``out`` (m, C) with the C kernel (see the module docstring).

    The arguments are checked in C (``_synthloop.c``, py_segment: C-contiguity, writeability, dtypes and shapes):
    ~1 us per call instead of ~6 us of Python checks and ctypes conversions. ``noise``: None, or ``(key, n0,
    sigma[, extra])``: sensor noise ``sigma[c] z`` added to every sample before its features are taken, ``z`` the
    normals of :func:`noise_fill` at the absolute sample indices ``n0 ..`` (``sigma`` (C,) of out's dtype, or None:
    no noise), and ``extra`` (m, C) of out's dtype added too (the broadband floor; None: none). Raises
    RuntimeError if the kernel is not built, ValueError on wrong shapes, dtypes or non-contiguous arrays."""
    if _segment_c is None:
        raise RuntimeError("the C sample loop (bkabem_core/kernels/_synthloop.c) is not built: run `pip install -e .`")
    if noise is None:
        _segment_c(phase0, dphase0, ddphase, warp, table_a, table_b, xi0, blend_scale, out, acc, off, exact)
    else:
        key, n0, sigma, *extra = noise
        _segment_c(phase0, dphase0, ddphase, warp, table_a, table_b, xi0, blend_scale, out, acc, off, exact,
                   int(key) & _MASK64, int(n0), sigma, extra[0] if extra else None)


def accumulate(x: np.ndarray, off: np.ndarray, acc: np.ndarray) -> None:
    """Add the moments of the block ``x`` (n, C) to ``acc`` (C, 6) with the C kernel (see :func:`new_acc`)."""
    fn = _accumulate_fn(x.dtype)
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
        raise RuntimeError("the C kernel (bkabem_core/kernels/_synthloop.c) is not built: run `pip install -e .`")
    dt = np.dtype(dtype)
    out = np.empty(int(n), dtype=dt)
    if _FNS[("normals", dt)](int(key) & _MASK64, out.size, _ptr(out, "out")):
        raise ValueError(f"synth_normals rejected n={n}")
    return out


def slip_warp(m: int, j0: int, c1: float, c2: float, u_frac: float, w: np.ndarray, jw0: int, kappas) -> np.ndarray:
    """(K, m) int64 phase offsets of random slip for one segment, one row per factor of ``kappas`` (K <= 8; see
    ``synth_slip_warp`` in _synthloop.c): in C when built, else :func:`slip_warp_reference`; the two agree bit for
    bit."""
    fn = _FNS.get("slip_warp") if _FNS is not None else None
    kap = np.ascontiguousarray(np.atleast_1d(np.asarray(kappas, dtype=np.float64)))
    if fn is None:
        return slip_warp_reference(m, j0, c1, c2, u_frac, w, jw0, kap)
    w = np.ascontiguousarray(w, dtype=np.float64)
    out = np.empty((kap.size, int(m)), dtype=np.int64)
    if fn(int(m), float(j0), float(c1), float(c2), float(u_frac), w.ctypes.data, w.size, int(jw0), kap.ctypes.data,
          kap.size, out.ctypes.data):
        raise ValueError("synth_slip_warp: a sample falls outside the walk's values (or K not in 1..8)")
    return out


def slip_warp_reference(m: int, j0: int, c1: float, c2: float, u_frac: float, w: np.ndarray, jw0: int,
                        kappas) -> np.ndarray:
    """:func:`slip_warp` in numpy (the operations of the C function in its order): the walk's Hermite cubic in
    Horner form per pass interval, ``rint(y 2^52) 2^10`` with ``y = kappa W - rint(kappa W)``."""
    kap = np.atleast_1d(np.asarray(kappas, dtype=np.float64))
    xi = np.arange(j0, j0 + m, dtype=np.float64)
    u = (c2 * xi + c1) * xi + u_frac
    fl = np.floor(u)
    k = fl.astype(np.int64) - jw0
    t = u - fl
    w0, w1 = w[k], w[k + 1]
    m0, m1 = 0.5 * (w[k + 1] - w[k - 1]), 0.5 * (w[k + 2] - w[k])
    d = w1 - w0
    a2 = ((3.0 * d) - (2.0 * m0)) - m1
    a3 = ((-2.0 * d) + m0) + m1
    ww = ((a3 * t + a2) * t + m0) * t + w0
    out = np.empty((kap.size, int(m)), dtype=np.int64)
    for q, kappa in enumerate(kap):
        wp = kappa * ww
        out[q] = np.rint((wp - np.rint(wp)) * 2.0 ** 52).astype(np.int64) << 10
    return out


# ----------------------------------------------------------------------------------------- sensor noise
def noise_fill(key: int, n0: int, n: int, n_channels: int, avx2: bool = True) -> np.ndarray:
    """(n, C) float32 standard normals of the noise stream ``key`` at absolute samples ``n0 .. n0 + n - 1``: what
    :func:`segment` adds with ``noise=(key, n0, sigma)`` (``_synthnoise.h``: xoshiro256++ lanes seeded per block of
    256 samples, a 1024-layer ziggurat; numpy: :func:`synth_noise.noise_reference`). ``avx2=False`` takes the scalar
    code (the same bits). Raises RuntimeError if the kernel is not built."""
    if _FNS is None:
        raise RuntimeError("the C kernel (bkabem_core/kernels/_synthloop.c) is not built: run `pip install -e .`")
    out = np.empty((int(n), int(n_channels)), dtype=np.float32)
    if _FNS["noise_fill"](int(key) & _MASK64, int(n0), int(n), int(n_channels), int(bool(avx2)), out.ctypes.data):
        raise ValueError(f"synth_noise_fill rejected n0={n0}, n={n}, C={n_channels}")
    return out


def noise_add(x: np.ndarray, key: int, n0: int, sigma, off=None, acc=None, extra=None) -> None:
    """``x += sigma z (+ extra)`` (z: :func:`noise_fill` at absolute samples ``n0 ..``; sigma None: no noise;
    ``extra`` (n, C) of x's dtype, e.g. the broadband floor) for a finished block ``x`` (n, C), and with ``acc`` its
    features accumulated (:func:`accumulate`), in one C pass."""
    fn = _FNS.get(("noise_add", x.dtype)) if _FNS is not None else None
    if fn is None:
        raise RuntimeError("the C kernel (bkabem_core/kernels/_synthloop.c) is not built: run `pip install -e .`")
    n, c = x.shape
    sig = None if sigma is None else np.ascontiguousarray(sigma, dtype=x.dtype)
    if sig is not None and sig.shape != (c,):
        raise ValueError(f"sigma must be ({c},)")
    if extra is not None and (extra.shape != x.shape or extra.dtype != x.dtype or not extra.flags.c_contiguous):
        raise ValueError(f"extra must be {x.shape} C-contiguous {x.dtype}")
    if fn(n, c, _ptr(x, "x"), int(key) & _MASK64, int(n0), 0 if sig is None else sig.ctypes.data,
          0 if extra is None else extra.ctypes.data,
          0 if off is None else _ptr(off, "off"), 0 if acc is None else _ptr(acc, "acc")):
        raise ValueError(f"synth_noise_add rejected n={n}, C={c}")


#: True if the line-set kernels (family tables by FFT, one call per segment over all families) are built.
LINES_AVAILABLE = bool(AVAILABLE and hasattr(_EXT, "lines_knot"))
if LINES_AVAILABLE:
    lines_knot_plan, lines_knot = _EXT.lines_knot_plan, _EXT.lines_knot
    lines_segment_plan, lines_render = _EXT.lines_segment_plan, _EXT.lines_render


def band_rms_lines(va: np.ndarray, vb: np.ndarray, nu: np.ndarray, mu: np.ndarray, f: float, band_hz,
                   s: float) -> tuple:
    """RMS [mm/s] of the blend ``va + s (vb - va)`` of two knots' housing velocities (L, 8) (4 rows, Re | Im) over
    the lines whose frequency ``nu f + mu`` [Hz] is in ``band_hz`` (inclusive): ``sqrt(0.5 sum_k |v_k|^2)`` per
    row, a tuple of 4 floats. In C when built, else :func:`band_rms_lines_reference`."""
    if not LINES_AVAILABLE:
        return band_rms_lines_reference(va, vb, nu, mu, f, band_hz, s)
    return _EXT.band_rms_lines(va, vb, nu, mu, float(f), float(band_hz[0]), float(band_hz[1]), float(s))


def band_rms_lines_reference(va, vb, nu, mu, f: float, band_hz, s: float) -> tuple:
    """:func:`band_rms_lines` in numpy."""
    freq = nu * float(f) + mu
    band = (freq >= band_hz[0]) & (freq <= band_hz[1])
    v = va[band]
    v = v + float(s) * (vb[band] - v)
    p = np.einsum("ij,ij->j", v, v)
    return tuple(np.sqrt(0.5 * (p[:4] + p[4:])).tolist())


def family_tables(y: np.ndarray, plan: dict, table: np.ndarray, work: np.ndarray) -> None:
    """The spline tables of every family of a line set into ``table`` (float32, the families' (N + 3, C) tables at
    ``plan["out_off"]``) from the lines' channel amplitudes ``y`` (L, C) complex128, by the C FFT of
    ``_synthlines.h`` (``plan``: :meth:`synth_lines.LineFamilies.plan`; ``work``: >= 2 N C doubles)."""
    L, C = y.shape
    y = np.ascontiguousarray(y, dtype=np.complex128)
    pl = plan
    fixed = pl.get("_table_addresses")
    if fixed is None:                               # the plan's arrays do not change: their addresses once
        fixed = pl["_table_addresses"] = tuple(pl[k].ctypes.data for k in ("n_lines", "line", "slot", "factor",
                                                                            "N", "tw", "tw_off", "carrier"))
    if _FNS["family_tables"](pl["F"], C, L, _ptr(y, "y"), *fixed, _ptr(table, "table"), pl["out_off"].ctypes.data,
                             _ptr(work, "work")):
        raise ValueError("synth_family_tables rejected its arguments")


def lines_segment(m: int, phases: np.ndarray, plan: dict, ta: np.ndarray, tb, warp, wp: np.ndarray,
                  wq: np.ndarray, dc: np.ndarray, xi0: float, blend_scale: float, out: np.ndarray, acc=None,
                  off=None, noise=None, csrc=None) -> None:
    """Samples of one segment of a line set, every family in one C pass (``_synthlines.h``), float32: ``phases``
    (F, 6) uint64 (family phase0, dphase0, ddphase, then the carrier's), tables ``ta``/``tb`` (knot a, b; tb None:
    no blend) laid out by ``plan``, ``warp`` (K, m) int64 slip offsets (or None) with the row of each family's
    phase ``wp`` and carrier ``wq`` (-1: none), ``dc`` (C,) float32 static part, ``out`` (m, C) written; ``acc``/
    ``off`` the features, ``noise`` (key, n0, sigma float32[, extra]) as :func:`segment`; ``extra`` an (m, C)
    float32 block added with the noise, or the broadband floor itself as :meth:`synth_floor.BroadbandFloor.source`
    ``(frames, window, grains, half, scale)``, rendered per block inside the pass (the same samples as
    :func:`floor_render`, without the chunk-sized buffer); ``csrc`` (F, 2) int64 the carrier sums
    (:func:`synth_lines._carrier_sums`; None: every carrier from its own phase)."""
    C = out.shape[1]
    key, n0, sigma, *extra = noise if noise is not None else (0, 0, None)
    extra = extra[0] if extra else None
    floor = (0, 0, 0, 0, 1, 2, 0)
    if isinstance(extra, tuple):
        frames, window, grains, half, scale = extra
        floor = (_ptr(frames, "frames"), _ptr(window, "window"), len(grains), _ptr(grains, "grains"), int(half),
                 frames.shape[1], _ptr(scale, "scale"))
        extra = None
    fixed = plan.get("_addresses")
    if fixed is None:                               # the plan's arrays do not change: their addresses once
        fixed = plan["_addresses"] = tuple(plan[k].ctypes.data for k in ("lg", "carrier", "off_t"))
    src = 0 if csrc is None else _ptr(csrc, "csrc")
    if _FNS["lines_segment"](int(m), C, plan["F"], _ptr(phases, "phases"), *fixed[:2], src, fixed[2], _ptr(ta, "ta"),
                             0 if tb is None else _ptr(tb, "tb"), 0 if warp is None else _ptr(warp, "warp"),
                             _ptr(wp, "wp"), _ptr(wq, "wq"), _ptr(dc, "dc"), float(xi0), float(blend_scale),
                             _ptr(out, "out"), 0 if acc is None else _ptr(acc, "acc"),
                             0 if off is None else _ptr(off, "off"), int(key) & _MASK64, int(n0),
                             0 if sigma is None else _ptr(sigma, "sigma"), 0 if extra is None else _ptr(extra, "extra"),
                             *floor):
        raise ValueError("synth_lines_segment rejected its arguments")


def floor_render(n0: int, m: int, half: int, frames: np.ndarray, window: np.ndarray, grains: np.ndarray,
                 out: np.ndarray, scale: np.ndarray) -> None:
    """The broadband floor at absolute samples ``n0 .. n0 + m - 1`` into ``out`` (m, C) float32: grains (G, 3)
    int64 (grain index g, frame, offset) over frames (F, L, C) int16 times ``scale`` (C,) float32 per channel, sine
    window (2 half,) (``synth_floor.py``), in C when built, else in numpy (the same operations)."""
    if frames.dtype != np.int16 or scale.dtype != np.float32 or scale.shape != (frames.shape[2],):
        raise ValueError("floor_render: frames must be int16 (F, L, C) and scale float32 (C,)")
    fn = _FNS.get("floor_render") if _FNS is not None else None
    n_l, c = frames.shape[1], frames.shape[2]
    if fn is not None:
        if fn(int(m), c, int(n0), int(half), n_l, frames.ctypes.data, window.ctypes.data, len(grains),
              grains.ctypes.data, _ptr(out, "out"), scale.ctypes.data):
            raise ValueError("synth_floor_render rejected its arguments")
        return
    out[...] = 0.0
    for g, fr, off in grains:
        lo, hi = max(g * half, n0), min(g * half + 2 * half, n0 + m)
        if hi > lo:
            t = np.arange(lo - g * half, hi - g * half)
            out[lo - n0:hi - n0] += window[t][:, None] * frames[fr][(t + off) % n_l].astype(np.float32)
    out *= scale


def floor_spectrum(key: int, by_input: np.ndarray, s: float, out: np.ndarray, avx2: bool = True) -> None:
    """One frame's spectrum of the broadband floor into ``out`` (F, C) complex64: ``out[k] = sum_j by_input[j, k]
    a_j(k)`` with the amplitudes ``a_j(k) = s (z[k, j] + i z[k, 4 + j])`` of the four force pairs, z the (F, 8)
    standard normals of the stream ``key`` (:func:`noise_fill` at samples 0 .. F - 1: the sensor noise's ziggurat),
    ``by_input`` (4, F, C) complex64 C-contiguous. In C when built (normals and product in one pass,
    ``_synthfloor.h``), else numpy (:func:`synth_noise.noise_reference` and complex64 products: the same normals,
    the products to float32 rounding). ``avx2=False``: the scalar generator (the same bits)."""
    f, c = by_input.shape[1], by_input.shape[2]
    if (by_input.dtype != np.complex64 or by_input.shape[0] != 4 or not by_input.flags.c_contiguous
            or out.dtype != np.complex64 or out.shape != (f, c) or not out.flags.c_contiguous):
        raise ValueError("floor_spectrum: by_input must be (4, F, C) and out (F, C), complex64 C-contiguous")
    fn = _FNS.get("floor_spectrum") if _FNS is not None else None
    if fn is not None:
        if fn(int(key) & _MASK64, f, c, by_input.ctypes.data, float(s), out.ctypes.data, int(bool(avx2))):
            raise ValueError("synth_floor_spectrum rejected its arguments")
        return
    z = noise_reference(int(key) & _MASK64, 0, f, 8) * np.float32(s)
    a = np.empty((f, 4), np.complex64)
    a.real, a.imag = z[:, :4], z[:, 4:]
    np.multiply(by_input[0], a[:, 0:1], out=out)
    for j in range(1, 4):
        out += by_input[j] * a[:, j:j + 1]


def floor_quantise(x: np.ndarray) -> tuple:
    """(int16 q, float32 scale (C,)) of the float32 frames ``x`` (..., C) C-contiguous: ``scale = max |x| / 32767``
    per channel over all frames (1 for an all-zero channel), ``q = clip(rint(x inv), -32767, 32767)`` in float32
    with ``inv = 32767 / max`` (a product: |x inv - x / scale| < 0.002 of a step): in C when built (two passes),
    else numpy (the same operations, bit for bit)."""
    if x.dtype != np.float32 or not x.flags.c_contiguous:
        raise ValueError("floor_quantise: x must be float32 C-contiguous")
    c = x.shape[-1]
    q = np.empty(x.shape, dtype=np.int16)
    scale = np.empty(c, dtype=np.float32)
    fn = _FNS.get("floor_quantise") if _FNS is not None else None
    if fn is not None and c <= 64:
        if fn(x.size // c, c, x.ctypes.data, q.ctypes.data, scale.ctypes.data):
            raise ValueError("synth_floor_quantise rejected its arguments")
        return q, scale
    flat = x.reshape(-1, c)
    top = np.abs(flat).max(axis=0)
    t64 = top.astype(np.float64)
    scale[...] = np.where(top > 0, t64 / 32767.0, 1.0)
    inv = np.where(top > 0, 32767.0 / np.where(top > 0, t64, 1.0), 1.0).astype(np.float32)
    q.reshape(-1, c)[...] = np.clip(np.rint(flat * inv), -32767, 32767)
    return q, scale


def carrier_mix(cs: np.ndarray, re: np.ndarray, im: np.ndarray, out: np.ndarray) -> None:
    """``out += cs[:, :1] re - cs[:, 1:] im`` for (m, C) blocks and the carrier's (cos, sin) ``cs`` (m, 2), all of
    out's dtype and C-contiguous: in C when the kernel is built (bit for bit :func:`carrier_mix_reference`)."""
    fn = _FNS.get(("carrier_mix", out.dtype)) if _FNS is not None else None
    if fn is None:
        carrier_mix_reference(cs, re, im, out)
        return
    m, c = out.shape
    for a, name in ((cs, "cs"), (re, "re"), (im, "im")):
        if a.dtype != out.dtype or a.shape[0] != m:
            raise ValueError(f"{name} must be ({m}, ...) {out.dtype}")
    if re.shape != out.shape or im.shape != out.shape or cs.shape != (m, 2):
        raise ValueError("carrier_mix: shapes (m, 2), (m, C), (m, C), (m, C)")
    if fn(m, c, _ptr(cs, "cs"), _ptr(re, "re"), _ptr(im, "im"), _ptr(out, "out")):
        raise ValueError(f"synth_carrier_mix rejected m={m}, C={c}")


def carrier_mix_reference(cs: np.ndarray, re: np.ndarray, im: np.ndarray, out: np.ndarray) -> None:
    """:func:`carrier_mix` in numpy (the same operations in the same order and precision)."""
    x = cs[:, :1] * re
    y = cs[:, 1:] * im
    out += x - y


FEATURE_NAMES = ("mean", "rms", "peak", "peak_to_peak", "crest_factor", "kurtosis")


def features_from_acc(acc: np.ndarray, n: int, off) -> dict:
    """The dict of ``synth.waveform_features`` (mean, rms, peak, peak_to_peak, crest_factor, kurtosis) from the
    accumulators of ``n`` samples per channel taken about ``off`` (C,), float64 (C,) arrays (views of one block).
    In C when the kernel is built (``synth_features``), else :func:`features_from_acc_reference`."""
    if _features_c is None:
        return features_from_acc_reference(acc, n, off)
    out = np.empty((6, acc.shape[0]))
    _features_c(acc, int(n), np.ascontiguousarray(off, dtype=np.float64), out)     # checks the arrays
    return dict(zip(FEATURE_NAMES, out))


def features_from_acc_reference(acc: np.ndarray, n: int, off) -> dict:
    """:func:`features_from_acc` in numpy (``synth_features._moment_features``)."""
    s = acc[:, :4] / float(n)
    return _moment_features(s[:, 0], s[:, 1], s[:, 2], s[:, 3], acc[:, 4].copy(), acc[:, 5].copy(),
                            np.asarray(off, dtype=np.float64))


# ----------------------------------------------------------------------------------------- knot table
_KNOT_JB = 6                   # values of j per block of the C kernel (KNOT_JB): the basis has a multiple of it rows


class QuarterBasis:
    """Cosines and sines of a knot table's orders over a quarter wave, made once per (orders, N) (see
    :func:`quarter_basis`); read-only.

    Attributes: ``orders`` (K,) int64; ``n_table`` N; ``n_even`` the number of even orders; ``perm`` (K,) int64 the
    orders' indices, even orders first (each parity in the given order); ``basis`` (R, K, 2) float64
    ``[cos, sin](orders[perm] 2 pi j / N)`` for j = 0..R-1, R = N/4 + 1 rounded up to a multiple of 6 (the C
    kernel's blocks of j; rows beyond N/4 are padding), with
    the angle reduced exactly to a quarter turn first, so that cos and sin are exactly 0 and +-1 at multiples of
    pi / 2 (the quarter-wave identities of ``_synthloop.c`` need it at j = N/4)."""

    __slots__ = ("orders", "n_table", "n_even", "perm", "basis", "_full")

    def __init__(self, orders, n_table: int):
        orders = np.asarray(orders)
        n = int(n_table)
        phase_bits(n)                                   # N a power of 2 in 64..65536
        if orders.ndim != 1 or not np.issubdtype(orders.dtype, np.integer) and not np.all(orders == np.round(orders)):
            raise ValueError(f"orders must be a 1-d array of integers (got {orders!r})")
        orders = orders.astype(np.int64)
        if orders.size and (orders.min() < 1 or 2 * orders.max() >= n):
            raise ValueError(f"orders must be in 1 .. N/2 - 1 = {n // 2 - 1} (got {orders.min()} .. {orders.max()})")
        even = orders % 2 == 0
        perm = np.concatenate([np.flatnonzero(even), np.flatnonzero(~even)]).astype(np.int64)
        rows = -(-(n // 4 + 1) // _KNOT_JB) * _KNOT_JB
        j = np.arange(rows, dtype=np.int64)
        cos, sin = _cos_sin_exact((j[:, None] * orders[perm][None, :]) % n, n)
        basis = np.ascontiguousarray(np.stack([cos, sin], axis=2))
        for a in (orders, perm, basis):
            a.flags.writeable = False
        self.orders, self.n_table, self.n_even, self.perm, self.basis = orders, n, int(even.sum()), perm, basis
        self._full = None

    def full(self):
        """(cos, sin) (N + 3, K) of orders 2 pi n / N at n = (r - 1) mod N, r = 0..N+2 (the table rows), for
        :func:`knot_table_reference` (made when first asked, kept)."""
        if self._full is None:
            n = self.n_table
            r = (np.arange(n + 3, dtype=np.int64) - 1) % n
            self._full = _cos_sin_exact((r[:, None] * self.orders[None, :]) % n, n)
        return self._full


def _cos_sin_exact(m: np.ndarray, n: int):
    """cos and sin of 2 pi m / n for integers 0 <= m < n (n divisible by 4), reduced exactly to the first quadrant."""
    quarter = n // 4
    q, r = np.divmod(m, quarter)
    a = (2 * np.pi / n) * r
    c0, s0 = np.cos(a), np.sin(a)
    cos = np.choose(q, [c0, -s0, -c0, s0])
    sin = np.choose(q, [s0, c0, -s0, -c0])
    return cos, sin


def quarter_basis(orders, n_table: int) -> QuarterBasis:
    """The :class:`QuarterBasis` of positive integer ``orders`` (each < N/2) and table size ``n_table`` (a power of 2
    in 64..65536) for :func:`knot_table`: make it once per model and table size."""
    return QuarterBasis(orders, n_table)


def knot_table(x: np.ndarray, cindex: np.ndarray, factor: np.ndarray, scale: np.ndarray, taper, dc: np.ndarray,
               basis: QuarterBasis, table_out: np.ndarray, y_out: np.ndarray):
    """The padded spline table of a knot and its channel amplitudes, in C (``_synthloop.c``, synth_knot_table)::

        y[k, c] = x[k, cindex[c]] * ((factor[k, c] * scale[c]) * taper[k])          (taper None: no factor)
        table_out[r, c] = dc[c] + sum_k Re(y[k, c] exp(i orders[k] 2 pi n / N)),   n = (r - 1) mod N, r = 0..N+2

    Parameters
    ----------
    x : (K, U) complex128, C-contiguous
        Amplitudes of the K orders (e.g. the modal sum's displacement combinations [m]).
    cindex : (C,) int64
        Column of x of each channel (checked against U).
    factor : (K, C) complex128
        Channel factor per order and channel (e.g. ``(i k)^p scale / sinc(k/N)^4``, the B-spline pre-emphasis).
    scale : (C,) float64
        Per-channel factor of this knot (e.g. ``(2 pi BPFO f)^p * fade``).
    taper : (K,) float64 or None
        Per-order factor (the Nyquist taper), None for 1.
    dc : (C,) float64
        Static part per channel [channel units].
    basis : QuarterBasis
        Of the orders and table size (:func:`quarter_basis`, made once).
    table_out : (N + 3, C) float32 or float64, C-contiguous, written
        Row r holds coefficient (r - 1) mod N (the wrap padding of :func:`pad_coefficients`).
    y_out : (K, C) complex128, C-contiguous, written
        y as above (must not overlap the inputs).

    Returns ``(table_out, y_out)``. The sums are taken in double over a quarter wave (quarter-wave symmetry of
    integer orders); the table agrees with :func:`knot_table_reference` (the direct formula in float64) to ~1e-15
    of its largest value before the rounding to ``table_out``'s dtype. Raises RuntimeError if the kernel is not
    built, ValueError on wrong shapes, dtypes or non-contiguous arrays."""
    if _knot_table_c is None:
        raise RuntimeError("the C kernel (bkabem_core/kernels/_synthloop.c) is not built: run `pip install -e .`")
    _knot_table_c(x, cindex, factor, scale, taper, dc, basis.n_even, basis.perm, basis.basis, table_out, y_out)
    return table_out, y_out


def knot_table_reference(x: np.ndarray, cindex: np.ndarray, factor: np.ndarray, scale: np.ndarray, taper,
                         dc: np.ndarray, basis: QuarterBasis, table_out: np.ndarray, y_out: np.ndarray):
    """:func:`knot_table` in numpy by the direct formula (all N + 3 rows, float64, the basis's :meth:`full`
    cosines and sines), the fallback without the kernel and the tests' reference."""
    fac = factor * np.asarray(scale, dtype=np.float64)[None, :]
    if taper is not None:
        fac = fac * np.asarray(taper, dtype=np.float64)[:, None]
    y = x[:, np.asarray(cindex)] * fac
    cos, sin = basis.full()
    table_out[...] = np.asarray(dc, dtype=np.float64)[None, :] + (cos @ y.real - sin @ y.imag)
    y_out[...] = y
    return table_out, y_out


def band_rms(va: np.ndarray, vb: np.ndarray, lo: int, hi: int, s: float) -> tuple:
    """RMS of four complex channels over rows ``lo:hi`` of the blend ``va + s (vb - va)``.

    ``va``, ``vb``: (K, 8) float64, C-contiguous, real parts in columns 0-3 and imaginary parts in 4-7 (e.g. order
    amplitudes [mm/s] of two knots); ``s`` the blend weight in [0, 1]. Returns ``sqrt(0.5 sum_k |v_k,c|^2)`` for
    c = 0..3 (a tuple of floats). In C when the kernel is built, else :func:`band_rms_reference`."""
    if _band_rms_c is None:
        return band_rms_reference(va, vb, lo, hi, s)
    return _band_rms_c(va, vb, lo, hi, float(s))


def band_rms_reference(va: np.ndarray, vb: np.ndarray, lo: int, hi: int, s: float) -> tuple:
    """:func:`band_rms` in numpy."""
    v = va[lo:hi]
    v = v + s * (vb[lo:hi] - v)
    p = np.einsum("ij,ij->j", v, v)
    return tuple(np.sqrt(0.5 * (p[:4] + p[4:])).tolist())


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
                      blend_scale: float, out: np.ndarray, acc=None, off=None, noise=None) -> None:
    """:func:`segment` in numpy, operation for operation (the same IEEE operations in the same order and precision);
    the noise's normals from the C generator (:func:`noise_fill`, tested against :func:`noise_reference`; the
    latter without the kernel, slow)."""
    m, c, n, fb = _check_segment(warp, table_a, table_b, out, acc, off)
    if m == 0:
        return
    dt = out.dtype
    v = phases_reference(phase0, dphase0, ddphase, m)
    if warp is not None:
        v += warp.view(np.uint64)
    i = ((v >> np.uint64(fb)) & np.uint64(n - 1)).astype(np.intp)
    q = ((v >> np.uint64(fb - FRAC_BITS)) & np.uint64((1 << FRAC_BITS) - 1)).astype(np.int32)
    w = [wk[:, None] for wk in _weights_from_fraction(q, dt)]      # 4 x (m, 1)

    def interp(table):
        val = w[0] * table[i]
        for k in (1, 2, 3):
            val += w[k] * table[i + k]
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
    if noise is not None:
        key, n0, sigma, *extra = noise
        if sigma is not None:
            z = (noise_fill(key, n0, m, c) if AVAILABLE else noise_reference(key, n0, m, c)).astype(dt)
            z *= np.asarray(sigma, dtype=dt)[None, :]
            out += z
        if extra and extra[0] is not None:
            out += extra[0]
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
