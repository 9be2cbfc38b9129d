"""The synthesiser's C kernels (the extension module ``bkabem_core.kernels._synth``) and their numpy references.

What they compute, and why they are shaped so, is ``docs/performance.md``. Here: their Python face, argument by
argument, and the numpy references that the tests hold the kernels to and that the synthesiser runs when the
kernels are not built (:data:`AVAILABLE` is False).

:func:`segment` renders ``m`` samples of ``C`` channels from a periodic spline table of one phase (a family of
lines), at an integer phase that advances with a constant second difference (a linear speed ramp), optionally
blending in time towards a second table (the next knot) and accumulating the moments of the chunk features on the
fly (``acc``), so that :func:`features_from_acc` gives ``waveform_features`` without another pass over the samples.
:func:`segment_reference` is the same computation in numpy, operation for operation: the kernel's samples equal it
bit for bit (built with ``-ffp-contract=off``).

Phase: fixed-point uint64, wrapping; one turn is :data:`PASS_UNITS` = 2^62 units, one table step ``2**phase_bits(N)``
units. For sample j = 0..m-1 of a call (modulo 2^64)::

    U_j = phase0 + j dphase0 + ddphase j (j - 1) / 2        (U_{j+1} = U_j + D_j, D_{j+1} = D_j + ddphase)
    V_j = U_j + warp[j]                                       (warp optional)
    i = (V_j >> FB) & (N - 1);   q = (V_j >> (FB - 24)) & (2^24 - 1)

Interpolation: cubic uniform B-spline of a coefficient table ``(N + 3, C)`` with wrap padding (row n holds
coefficient (n - 1) mod N), weights :func:`spline_weights` ``(q)``, computed from the fraction ``t = q 2^-24`` of
the table step (exact in float32) by one fixed sequence of operations in the tables' dtype::

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
  without ``acc``).

Splitting a call at sample j into two calls (phase0 and dphase0 advanced as above, xi0 by j, warp sliced) gives the
same samples, provided ``xi0 + j`` is exact in double: the phase is exact integer arithmetic, the blend weight is
computed from the double ``j + xi0``.

The line-set kernels (``lines_knot_plan``, ``lines_knot``, ``lines_segment_plan``, ``lines_render``) are the
extension's functions themselves; :class:`bkabem_core.synth.render.FusedLines` drives them.
"""

from __future__ import annotations

import importlib
import importlib.util

import numpy as np

from bkabem_core.synth.features import _moment_features
from bkabem_core.synth.noise import noise_reference

#: Phase units of one turn of a family's phase (a ball pass for BPFO orders).
PASS_UNITS = 1 << 62
FRAC_BITS = 24                 # bits of the fraction of a table step the spline weights are computed from
BLEND_LEVELS = 1 << 16         # time-blend weight quantised to 2^-16
MIN_TABLE, MAX_TABLE = 64, 1 << 16
_MASK64 = (1 << 64) - 1


def _load():
    """The extension module, or None if it is not built (or a stale build of another source)."""
    spec = importlib.util.find_spec("bkabem_core.kernels._synth")
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    ext = importlib.import_module("bkabem_core.kernels._synth")
    return ext if hasattr(ext, "lines_render") else None


_EXT = _load()
#: True if the C kernels are built (``pip install -e .``).
AVAILABLE = _EXT is not None
#: The same, for the line-set kernels (one module with the others).
LINES_AVAILABLE = AVAILABLE
if AVAILABLE:
    lines_knot_plan, lines_knot = _EXT.lines_knot_plan, _EXT.lines_knot
    lines_segment_plan, lines_render = _EXT.lines_segment_plan, _EXT.lines_render


def _not_built(what: str):
    return RuntimeError(f"the C kernels (bkabem_core/kernels) are not built, {what} needs them: run `pip install -e .`")


def _set_isa_cap(cap: int) -> int:
    """Cap the run-time dispatch of the C kernels (2: AVX-512 knot FFT, 1: AVX2 + FMA, 0: baseline only) for the
    tests of the other paths; returns the previous cap. Process-wide: not while kernels run in other threads."""
    return int(_EXT.set_isa_cap(int(cap))) if AVAILABLE else 0


def fast_path() -> bool:
    """True if the kernels' AVX2 + FMA paths run now (CPU and :func:`_set_isa_cap`)."""
    return bool(AVAILABLE and _EXT.fast_path())


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
    """(w0, w1, w2, w3) arrays of :func:`spline_weights` (the operation sequence of the kernels' WEIGHT_BLOCK)."""
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


# ----------------------------------------------------------------------------------------- the sample loop
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
            blend_scale: float, out: np.ndarray, acc=None, off=None, noise=None) -> None:
    """Samples of one call into ``out`` (m, C) with the C kernel (module docstring); the arrays are checked in C.
    ``noise``: None, or ``(key, n0, sigma, extra)``: sensor noise ``sigma[c] z`` added to every sample before its
    features are taken, ``z`` the normals of the stream ``key`` at the absolute sample indices ``n0 ..`` (``sigma``
    (C,) of out's dtype, or None: no noise), and ``extra`` (m, C) of out's dtype added too (None: none). Raises
    RuntimeError if the kernel is not built, ValueError on wrong shapes, dtypes or non-contiguous arrays."""
    if not AVAILABLE:
        raise _not_built("segment")
    if noise is None:
        _EXT.segment(phase0, dphase0, ddphase, warp, table_a, table_b, xi0, blend_scale, out, acc, off)
    else:
        key, n0, sigma, extra = noise
        _EXT.segment(phase0, dphase0, ddphase, warp, table_a, table_b, xi0, blend_scale, out, acc, off,
                     int(key) & _MASK64, int(n0), sigma, extra)


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
    the noise's normals by :func:`~bkabem_core.synth.noise.noise_reference` (the C generator's transcription)."""
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
        key, n0, sigma, extra = noise
        if sigma is not None:
            z = noise_reference(int(key) & _MASK64, n0, m, c).astype(dt)
            z *= np.asarray(sigma, dtype=dt)[None, :]
            out += z
        if extra is not None:
            out += extra
    if acc is not None:
        accumulate_reference(out, off, acc)


# ----------------------------------------------------------------------------------------- noise, features
def new_acc(n_channels: int) -> np.ndarray:
    """Empty feature accumulators (C, 6): sums 0, max -inf, min +inf."""
    acc = np.zeros((n_channels, 6))
    acc[:, 4] = -np.inf
    acc[:, 5] = np.inf
    return acc


def accumulate(x: np.ndarray, off: np.ndarray, acc: np.ndarray) -> None:
    """Add the moments of the block ``x`` (n, C) about ``off`` (C,) to ``acc`` (C, 6) with the C kernel."""
    if not AVAILABLE:
        raise _not_built("accumulate")
    _EXT.accumulate(x, off, acc)


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


def noise_add(x: np.ndarray, key: int, n0: int, sigma, off=None, acc=None, extra=None) -> None:
    """``x += sigma z (+ extra)`` (z: the normals of the stream ``key`` at absolute samples ``n0 ..``; sigma None: no
    noise; ``extra`` (n, C) of x's dtype, e.g. the broadband floor) for a finished block ``x`` (n, C), and with
    ``acc`` its features accumulated (:func:`accumulate`), in one C pass."""
    if not AVAILABLE:
        raise _not_built("noise_add")
    sig = None if sigma is None else np.ascontiguousarray(sigma, dtype=x.dtype)
    _EXT.noise_add(x, int(key) & _MASK64, int(n0), sig, extra, off, acc)


FEATURE_NAMES = ("mean", "rms", "peak", "peak_to_peak", "crest_factor", "kurtosis")


def features_into_reference(acc: np.ndarray, n: int, off, out: np.ndarray) -> None:
    """:data:`features_into` in numpy (``features._moment_features``)."""
    s = acc[:, :4] / float(n)
    f = _moment_features(s[:, 0], s[:, 1], s[:, 2], s[:, 3], acc[:, 4].copy(), acc[:, 5].copy(),
                         np.asarray(off, dtype=np.float64))
    for i, name in enumerate(FEATURE_NAMES):
        out[i] = f[name]


#: ``features_into(acc, n, off, out)``: the chunk features (rows :data:`FEATURE_NAMES` of ``out`` (6, C) float64) from
#: the accumulators ``acc`` (C, 6) of ``n`` samples per channel taken about ``off`` (C,): the C function when built
#: (the arrays checked there), else :func:`features_into_reference`.
features_into = _EXT.features if AVAILABLE else features_into_reference


def features_from_acc(acc: np.ndarray, n: int, off) -> dict:
    """The dict of ``waveform_features`` (mean, rms, peak, peak_to_peak, crest_factor, kurtosis) from the
    accumulators of ``n`` samples per channel taken about ``off`` (C,) (:data:`features_into`)."""
    out = np.empty((6, acc.shape[0]))
    features_into(acc, int(n), np.ascontiguousarray(off, dtype=np.float64), out)
    return dict(zip(FEATURE_NAMES, out))


# ----------------------------------------------------------------------------------------- slip, carriers
def slip_warp(m: int, j0: int, c1: float, c2: float, u_frac: float, w: np.ndarray, jw0: int, kappas) -> np.ndarray:
    """(K, m) int64 phase offsets of random slip for one segment, one row per factor of ``kappas`` (K <= 8): the
    walk's Hermite cubic at the samples' ball passes ``u = (c2 xi + c1) xi + u_frac``, ``xi = j0 ..``, as
    ``rint(y 2^52) 2^10`` with ``y = kappa W - rint(kappa W)``. In C when built, else :func:`slip_warp_reference`;
    the two agree bit for bit."""
    kap = np.ascontiguousarray(np.atleast_1d(np.asarray(kappas, dtype=np.float64)))
    if not AVAILABLE:
        return slip_warp_reference(m, j0, c1, c2, u_frac, w, jw0, kap)
    out = np.empty((kap.size, int(m)), dtype=np.int64)
    _EXT.slip_warp(float(j0), float(c1), float(c2), float(u_frac), np.ascontiguousarray(w, dtype=np.float64),
                   int(jw0), kap, out)
    return out


def _walk_hermite(xi: np.ndarray, c1: float, c2: float, u_frac: float, w: np.ndarray, jw0: int) -> np.ndarray:
    """The walk W [passes] at ``xi`` samples after the knot (float64 array): the pass ``u = (c2 xi + c1) xi +
    u_frac``, then the Hermite cubic of ``w`` (the walk at passes ``jw0, jw0 + 1, ...``) over its interval in Horner
    form, in the operations and order of ``kernels/synth_slip.c``; ValueError if ``w`` does not cover every ``u``."""
    u = (c2 * xi + c1) * xi + u_frac
    fl = np.floor(u)
    k = fl.astype(np.int64) - int(jw0)
    if k.size and (k.min() < 1 or k.max() + 2 >= len(w)):
        raise ValueError(f"the walk's values do not cover passes {float(u.min())!r} .. {float(u.max())!r}")
    t = u - fl
    w0, w1 = w[k], w[k + 1]
    m0, m1 = 0.5 * (w[k + 1] - w[k - 1]), 0.5 * (w[k + 2] - w[k])
    d = w1 - w0
    a2 = ((3.0 * d) - (2.0 * m0)) - m1
    a3 = ((-2.0 * d) + m0) + m1
    return ((a3 * t + a2) * t + m0) * t + w0


def slip_warp_reference(m: int, j0: int, c1: float, c2: float, u_frac: float, w: np.ndarray, jw0: int,
                        kappas) -> np.ndarray:
    """:func:`slip_warp` in numpy (the operations of the C function in its order): the walk's Hermite cubic in
    Horner form per pass interval, ``rint(y 2^52) 2^10`` with ``y = kappa W - rint(kappa W)``."""
    kap = np.atleast_1d(np.asarray(kappas, dtype=np.float64))
    ww = _walk_hermite(np.arange(j0, j0 + m, dtype=np.float64), c1, c2, u_frac, np.asarray(w, dtype=np.float64), jw0)
    out = np.empty((kap.size, int(m)), dtype=np.int64)
    for q, kappa in enumerate(kap):
        wp = kappa * ww
        out[q] = np.rint((wp - np.rint(wp)) * 2.0 ** 52).astype(np.int64) << 10
    return out


def slip_value_reference(xi: float, c1: float, c2: float, u_frac: float, w: np.ndarray, jw0: int) -> float:
    """The walk W itself [passes] at ``xi`` samples after the knot: the Hermite cubic of :func:`slip_warp_reference`
    at one sample (``kernels/synth_slip.c``, ``synth_slip_value``; the line kernel places a race pit's strikes with
    it, :mod:`bkabem_core.synth.strikes`)."""
    return float(_walk_hermite(np.array([float(xi)]), c1, c2, u_frac, np.asarray(w, dtype=np.float64), jw0)[0])


def carrier_mix(cs: np.ndarray, re: np.ndarray, im: np.ndarray, out: np.ndarray) -> None:
    """``out += cs[:, :1] re - cs[:, 1:] im`` for (m, C) blocks and the carrier's (cos, sin) ``cs`` (m, 2), all of
    out's dtype and C-contiguous: in C when the kernel is built (bit for bit :func:`carrier_mix_reference`)."""
    if not AVAILABLE:
        carrier_mix_reference(cs, re, im, out)
        return
    _EXT.carrier_mix(cs, re, im, out)


def carrier_mix_reference(cs: np.ndarray, re: np.ndarray, im: np.ndarray, out: np.ndarray) -> None:
    """:func:`carrier_mix` in numpy (the same operations in the same order and precision)."""
    x = cs[:, :1] * re
    y = cs[:, 1:] * im
    out += x - y


def band_rms_lines_reference(va, vb, nu, mu, f: float, lo_hz: float, hi_hz: float, s: float) -> tuple:
    """:data:`band_rms_lines` in numpy."""
    freq = nu * float(f) + mu
    band = (freq >= lo_hz) & (freq <= hi_hz)
    v = va[band]
    v = v + float(s) * (vb[band] - v)
    p = np.einsum("ij,ij->j", v, v)
    return tuple(np.sqrt(0.5 * (p[:4] + p[4:])).tolist())


#: ``band_rms_lines(va, vb, nu, mu, f, lo_hz, hi_hz, s)``: the RMS [mm/s] of the blend ``va + s (vb - va)`` of two
#: knots' housing velocities (L, 8) (4 rows, Re | Im) over the lines whose frequency ``nu f + mu`` [Hz] is in
#: [lo_hz, hi_hz]: ``sqrt(0.5 sum_k |v_k|^2)`` per row, a tuple of 4 floats. The C function when built, else
#: :func:`band_rms_lines_reference`.
band_rms_lines = _EXT.band_rms_lines if AVAILABLE else band_rms_lines_reference


# ----------------------------------------------------------------------------------------- broadband floor
def floor_render(n0: int, m: int, half: int, frames: np.ndarray, window: np.ndarray, grains: np.ndarray,
                 out: np.ndarray, scale: np.ndarray) -> None:
    """The broadband floor at absolute samples ``n0 .. n0 + m - 1`` into ``out`` (m, C) float32: grains (G, 3)
    int64 (grain index g, frame, offset) over frames (F, L, C) int16 times ``scale`` (C,) float32 per channel, sine
    window (2 half,) (``floor.py``), in C when built, else in numpy (the same operations)."""
    if frames.dtype != np.int16 or scale.dtype != np.float32 or scale.shape != (frames.shape[2],):
        raise ValueError("floor_render: frames must be int16 (F, L, C) and scale float32 (C,)")
    if AVAILABLE:
        _EXT.floor_render(int(n0), int(half), frames, window, grains, out[:m], scale)
        return
    n_l = frames.shape[1]
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
    standard normals of the stream ``key`` at samples 0 .. F - 1 (the sensor noise's generator), ``by_input``
    (4, F, C) complex64 C-contiguous. In C when built (normals and product in one pass), else numpy
    (:func:`~bkabem_core.synth.noise.noise_reference` and complex64 products: the same normals, the products to
    float32 rounding). ``avx2=False``: the scalar generator (the same bits)."""
    f, c = by_input.shape[1], by_input.shape[2]
    if (by_input.dtype != np.complex64 or by_input.shape[0] != 4 or not by_input.flags.c_contiguous
            or out.dtype != np.complex64 or out.shape != (f, c) or not out.flags.c_contiguous):
        raise ValueError("floor_spectrum: by_input must be (4, F, C) and out (F, C), complex64 C-contiguous")
    if AVAILABLE:
        _EXT.floor_spectrum(int(key) & _MASK64, by_input, float(s), out, bool(avx2))
        return
    z = noise_reference(int(key) & _MASK64, 0, f, 8) * np.float32(s)
    a = np.empty((f, 4), np.complex64)
    a.real, a.imag = z[:, :4], z[:, 4:]
    np.multiply(by_input[0], a[:, 0:1], out=out)
    for j in range(1, 4):
        out += by_input[j] * a[:, j:j + 1]


def floor_quantise(x: np.ndarray) -> tuple:
    """(int16 q, float32 scale (C,)) of the float32 frames ``x`` (F, L, C) C-contiguous: ``scale = max |x| / 32767``
    per channel over all frames (1 for an all-zero channel), ``q = clip(rint(x inv), -32767, 32767)`` in float32
    with ``inv = 32767 / max`` (a product: |x inv - x / scale| < 0.002 of a step): in C when built (two passes),
    else numpy (the same operations, bit for bit)."""
    if x.dtype != np.float32 or not x.flags.c_contiguous or x.ndim != 3:
        raise ValueError("floor_quantise: x must be (F, L, C) float32 C-contiguous")
    c = x.shape[-1]
    q = np.empty(x.shape, dtype=np.int16)
    scale = np.empty(c, dtype=np.float32)
    if AVAILABLE and c <= 64:
        _EXT.floor_quantise(x, q, scale)
        return q, scale
    flat = x.reshape(-1, c)
    top = np.abs(flat).max(axis=0)
    t64 = top.astype(np.float64)
    scale[...] = np.where(top > 0, t64 / 32767.0, 1.0)
    inv = np.where(top > 0, 32767.0 / np.where(top > 0, t64, 1.0), 1.0).astype(np.float32)
    q.reshape(-1, c)[...] = np.clip(np.rint(flat * inv), -32767, 32767)
    return q, scale
