"""A line set's knots and segments as single C calls (``_synthknot.h``), for :class:`synth_lines.LineSetPath`.

Why: the line-set path's Python cost more per chunk than its C kernels (per knot ~15 numpy temporaries and a ctypes
call with 15 pointers, per segment a Python loop over the families' phases and a ctypes call with 29 arguments, per
chunk the ISO velocity in numpy). Here the constant arrays of a line set are handed to C once (a plan) and a knot,
a segment and a chunk's ISO velocity are one call each of the extension module:

* :meth:`LineKnots.knot`: from the displacement combinations at a knot's speed to the channel amplitudes, the housing
  velocity of the ISO rows and every family's spline tables (the same IEEE operations as the numpy formulas of
  ``LineSetPath._line_amplitudes_numpy`` and the FFT of :func:`synth_kernel.family_tables`: the same numbers);
* :meth:`LineSegments.segment`: the families' fixed-point phases at the segment's first sample
  (``LineSetPath._phase_args``), their slip offsets (:func:`synth_kernel.slip_warp`) and the samples
  (:func:`synth_kernel.lines_segment`) with the noise, the floor and the features;
* :func:`band_rms_lines`: the ISO 10816 velocity RMS of the lines in the band.

Units: speeds [Hz], phases in turns (fixed point: :data:`synth_kernel.PASS_UNITS` per turn), amplitudes in the
channels' units, velocity [mm/s].
"""

from __future__ import annotations

import numpy as np

from bkabem_core.solve.harmonic import TWO_PI
from bkabem_core.synth import kernel as synth_kernel

_EXT = synth_kernel._EXT
#: True if the extension module has the line-set knot and segment calls.
AVAILABLE = bool(synth_kernel.LINES_AVAILABLE and _EXT is not None and hasattr(_EXT, "lines_knot"))
_MASK64 = (1 << 64) - 1


def _i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def _f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


class LineKnots:
    """The knot call of one line set: its families' plan (:meth:`synth_lines.LineFamilies.plan`, with ``out_off``
    set), the lines' frequencies ``nu f + mu`` [Hz] (``nu`` [Hz per shaft Hz], ``mu`` [Hz]), per channel the column
    of the displacement combinations it reads (``cindex``), its power of (i omega) and unit scale, and the 4 rows
    of the housing displacements (DE/NDE x vertical/horizontal) of the ISO velocity, of ``n_columns``
    combinations."""

    def __init__(self, plan: dict, nu, mu, cindex, power, scale, iso_rows, n_columns: int):
        self.n_lines = int(np.asarray(nu).size)
        self.n_channels = int(np.asarray(cindex).size)
        self.floats = int(plan["rows"]) * self.n_channels
        self._plan = _EXT.lines_knot_plan(
            _i64(plan["n_lines"]), _i64(plan["line"]), _i64(plan["slot"]), _f64(plan["factor"]), _i64(plan["N"]),
            _f64(plan["tw"]), _i64(plan["tw_off"]), _i64(plan["carrier"]), _i64(plan["out_off"]), _f64(nu), _f64(mu),
            _i64(cindex), _i64(power), _f64(scale), _i64(iso_rows), int(n_columns), float(TWO_PI))
        self._work = np.empty(2 * int(plan["max_n"]) * self.n_channels)

    def knot(self, x: np.ndarray, f: float, fade: float, taper, spow):
        """(y, v_iso, tables) at shaft speed ``f`` [Hz]: ``x`` (L, U) complex128 displacement combinations [m]
        (multiplied in place by ``spow`` (L,), the lines' speed powers ``f ** p``, if given), ``fade`` the low-speed
        fade, ``taper`` (L,) or None. ``y`` (L, C) complex channel amplitudes (fade and taper applied), ``v_iso``
        (L, 8) housing velocity [mm/s] of the ISO rows, real parts then imaginary parts (weights applied), ``tables``
        the families' float32 tables in one buffer (the plan's layout)."""
        y = np.empty((self.n_lines, self.n_channels), complex)
        v_iso = np.empty((self.n_lines, 8))
        table = np.empty(self.floats, dtype=np.float32)
        _EXT.lines_knot(self._plan, x, float(f), float(fade), taper, spow, y, v_iso, table, self._work)
        return y, v_iso, table


class LineSegments:
    """The segment call of one line set and slip setting: per family (``families`` of
    :class:`synth_lines.LineFamilies`) its table size and offsets (``plan``), the constants of its phase and carrier
    ``(rate / BPFO, fixed, rate, rate / 2)`` (``phases``: per family the phase's, then the carrier's or None), the
    distinct slip factors ``kappas``, each family's slip rows ``wp``, ``wq`` (-1: none) and ``csrc`` (F, 2) the
    two families whose carriers add up to its own (-1, -1: its own phase; None: every carrier from its own)."""

    def __init__(self, plan: dict, phases: list, kappas, wp, wq, sample_rate_hz: float, csrc=None):
        consts = np.zeros((len(phases), 4))
        for i, ph in enumerate(phases):
            if ph is not None:
                consts[i] = ph
        self.n_kappas = len(kappas)
        self.sample_rate_hz = float(sample_rate_hz)
        self._plan = _EXT.lines_segment_plan(_i64(plan["lg"]), _i64(plan["carrier"]), _i64(plan["off_t"]), _i64(wp),
                                             _i64(wq), consts.reshape(-1), _f64(np.asarray(kappas, dtype=float)),
                                             _i64(np.full((len(wp), 2), -1) if csrc is None else csrc).reshape(-1))
        self._warp: dict = {}

    def segment(self, m: int, j: int, a, b, walk, bpfo_per_hz: float, ta, tb, out, acc, off, dc, noise) -> None:
        """Samples ``j .. j + m - 1`` after knot ``a`` of the segment a-b (:class:`synth_lines._Knot`) into ``out``
        (m, C) float32: tables ``ta`` of a, ``tb`` of b (None: a's alone), the slip walk ``walk``
        (:class:`synth_random._SlipWalk`, or None without slip factors) at ``bpfo_per_hz`` ball passes per shaft
        turn, ``acc``/``off`` the features, ``dc`` (C,)
        float32 static part, ``noise`` None or ``(key, n0, sigma[, extra])`` as :func:`synth_kernel.lines_segment`."""
        length = b.x - a.x
        w = jw0 = None
        c1u = c2u = 0.0
        warp = None
        if self.n_kappas:
            bpfo, fs = bpfo_per_hz, self.sample_rate_hz
            c1u = bpfo / fs * a.f                           # as LineSetPath._segment_lines
            c2u = 0.5 * bpfo / fs * (b.f - a.f) / length
            w, jw0 = walk.window(a.u_int, j, m, c1u, c2u, a.u_frac)
            warp = self._warp.get(m)
            if warp is None:
                warp = self._warp[m] = np.empty(self.n_kappas * m, dtype=np.int64)
                if len(self._warp) > 8:
                    del self._warp[next(iter(self._warp))]
        key, n0, sigma, *extra = noise if noise is not None else (0, 0, None)
        _EXT.lines_render(self._plan, m, j, a.f, b.f, a.x, length, a.u_int + a.u_frac, self.sample_rate_hz, ta, tb,
                          w, jw0, c1u, c2u, a.u_frac, warp, out, acc, off, dc, int(key) & _MASK64, int(n0), sigma,
                          extra[0] if extra else None)


def band_rms_lines(va: np.ndarray, vb: np.ndarray, nu: np.ndarray, mu: np.ndarray, f: float, band_hz,
                   s: float) -> tuple:
    """RMS [mm/s] of the blend ``va + s (vb - va)`` of two knots' housing velocities (L, 8) (4 rows, Re | Im) over
    the lines whose frequency ``nu f + mu`` [Hz] is in ``band_hz`` (inclusive): ``sqrt(0.5 sum_k |v_k|^2)`` per
    row, a tuple of 4 floats."""
    return _EXT.band_rms_lines(va, vb, nu, mu, float(f), float(band_hz[0]), float(band_hz[1]), float(s))
