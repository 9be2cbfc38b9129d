"""From knots to samples: the line kernels a plan chooses once.

A knot's amplitudes become one spline table (pair) per family of the line set (:mod:`bkabem_core.synth.lines`);
a segment between two knots renders every family at its own fixed-point phase, blending the two knots' tables
linearly in time. Two implementations of the same arithmetic, chosen once per plan:

:class:`FusedLines`
    The C line-set kernels, float32: a knot is one call (channel amplitudes, ISO velocities and every family's
    table by an FFT that keeps the channels in vector lanes), a segment is one call (every family's phase, the slip
    offsets, the samples, the static part, sensor noise, broadband floor and chunk features in one pass).
:class:`LoopLines`
    The tables by numpy's FFT and, per family, the sample loop (:func:`bkabem_core.synth.kernel.segment`, or its
    numpy reference), a carrier mixed in afterwards: float64 samples, and the fallback without the C kernels.

Phase: a family's phase ``rate`` turns per shaft turn plus ``fixed`` turns per second goes to the loops as a
fixed-point integer (one turn = :data:`~bkabem_core.synth.kernel.PASS_UNITS`), with its first and second
difference: exact functions of (knot, sample), so a chunk border anywhere gives the same samples.

Units: speeds in Hz, phases in turns, amplitudes in the channels' units, velocity in mm/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkabem_core.solve.harmonic import TWO_PI
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.lines import carrier_sums
from bkabem_core.synth.strikes import strike_gains_reference

PASS = float(synth_kernel.PASS_UNITS)
_MASK64 = (1 << 64) - 1


@dataclass(slots=True)
class Amplitudes:
    """What a knot needs at its speed (shared by the knots of one speed)."""
    f: float                    # shaft speed [Hz]
    x: np.ndarray | None        # (L, U) complex displacement combinations [m], sensors applied (None: a knot
                                #  derived from others, a wandering ball defect's: balltrack)
    fade: float                 # low-speed fade of every line
    taper: np.ndarray | None    # (L,) Nyquist taper (None: 1)
    y: np.ndarray               # (L, C) complex channel amplitudes (weights applied)
    v_iso: np.ndarray           # (L, 8) housing velocity [mm/s] of DE/NDE x vertical/horizontal, Re | Im
    tables: object              # the families' spline tables, laid out as ``lines`` wants them
    lines: object               # the FusedLines or LoopLines that made them (and renders their segments)
    _rms: np.ndarray | None = None

    @property
    def weights(self) -> np.ndarray:
        """(L,) line weights (fade x taper)."""
        return self.fade * (np.ones(self.y.shape[0]) if self.taper is None else self.taper)

    @property
    def rms(self) -> np.ndarray:
        """(C,) RMS of the dynamic part (channel units)."""
        if self._rms is None:
            self._rms = np.sqrt(0.5 * np.sum(np.abs(self.y) ** 2, axis=0))
        return self._rms


def blend(a: Amplitudes, b: Amplitudes, s: float, f: float) -> Amplitudes:
    """The amplitudes a fraction ``s`` in [0, 1] of the time from a knot of amplitudes ``a`` to one of ``b`` (the
    same line kernel), at speed ``f`` [Hz]: linear in time, as the samples between the two knots are (tables,
    channel amplitudes, ISO velocities, the weights); the knot of a wandering ball defect between two spectra
    (:mod:`bkabem_core.synth.balltrack`)."""
    if a is b:
        return a

    def lerp(u, v):
        out = np.subtract(v, u)
        out *= s
        out += u
        return out

    if isinstance(a.tables, np.ndarray):
        tables = np.subtract(b.tables, a.tables)
        tables *= np.float32(s)
        tables += a.tables
    else:
        tables = [tuple(ta + ta.dtype.type(s) * (tb - ta) for ta, tb in zip(fa, fb))
                  for fa, fb in zip(a.tables, b.tables)]
    taper = None
    if a.taper is not None or b.taper is not None:
        ones = np.ones(a.y.shape[0])
        taper = lerp(ones if a.taper is None else a.taper, ones if b.taper is None else b.taper)
    return Amplitudes(f=float(f), x=None, fade=a.fade + s * (b.fade - a.fade), taper=taper, y=lerp(a.y, b.y),
                      v_iso=lerp(a.v_iso, b.v_iso), tables=tables, lines=a.lines)


def _i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def _f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def phase_args(rate: float, fixed: float, a, b, j: int, sample_rate_hz: float, bpfo_per_hz: float) -> tuple:
    """(phase0, dphase0, ddphase) of the sample loop for a phase of ``rate`` turns per shaft turn plus ``fixed``
    turns per second, at sample j after knot a (speed linear from a to b): exact integers per (knot, sample)."""
    fs = sample_rate_hz
    length = b.x - a.x
    t0 = (rate / bpfo_per_hz) * (a.u_int + a.u_frac) + fixed * (a.x / fs)
    t0 -= math.floor(t0)
    c1 = (rate * a.f + fixed) / fs
    c2 = 0.5 * rate * (b.f - a.f) / (fs * length)
    d0 = round((c1 + c2) * PASS)
    dd = round(2.0 * c2 * PASS)
    return round(t0 * PASS) + j * d0 + dd * (j * (j - 1) // 2), d0 + j * dd, dd


class FusedLines:
    """The C line-set kernels of one line set, channels and slip setting (module docstring).

    Parameters
    ----------
    selection : LineSelection
    channels : ChannelMap
    dc : ndarray (C,)
        Static part per channel.
    sample_rate_hz : float
    slip : bool
        Whether the stream has random slip (the families' slip offsets are computed in the segment call).
    spin_slip : float
        The balls' spin slip (:mod:`bkabem_core.synth.balltrack`): the families of the spin phase of the bearing
        whose spin is in column ``spin_column`` read the walk of that bearing's cage and spin slip together (0: none).
    spin_column : int
        The column of the defective ball's spin phase in the machine's phases (2: the DE's, 4: the NDE's).
    strikes : StrikeSpread or None
        A race pit's random strike strength (:mod:`bkabem_core.synth.strikes`): its families are multiplied by the
        strikes' gain in the segment call (None, or a spread of 0: none).
    """

    renders_floor = True

    def __init__(self, selection, channels, dc, sample_rate_hz: float, slip: bool, spin_slip: float = 0.0,
                 spin_column: int = 2, strikes=None):
        fams = selection.families
        c = len(channels)
        layout = fams.layout(c)
        self.sample_rate_hz = float(sample_rate_hz)
        self.bpfo_per_hz = selection.bpfo_per_hz
        self.dc = np.ascontiguousarray(dc, dtype=np.float32)
        self.n_lines, self.n_channels = len(selection), c
        self._floats = layout["floats"]
        self._knot_plan = synth_kernel.lines_knot_plan(
            _i64(layout["n_lines"]), _i64(layout["line"]), _i64(layout["slot"]), _f64(layout["factor"]),
            _i64(layout["N"]), _f64(layout["tw"]), _i64(layout["tw_off"]), _i64(layout["carrier"]),
            _i64(layout["offset"]), _f64(selection.nu), _f64(selection.mu), _i64(channels.cindex),
            _i64(channels.power), _f64(channels.scale), _i64(channels.iso_rows), channels.combination.shape[0],
            float(TWO_PI))
        self._work = np.empty(2 * layout["max_n"] * c)
        # per phase (each family's, then its carrier's) the constants of phase_args (rate / BPFO, fixed, rate,
        # rate / 2), the slip-offset row of each family's phase and carrier (-1: none) over the distinct slip
        # factors and walks, the carrier sums. A walk is a bearing's cage slip, or its cage's and its balls' spin
        # slip together (the families of the defective ball's spin phase): ``walk_sources`` (bearing, spin slip or
        # None) in the order of their index, only those some row reads
        rows: list = []
        self.spin_slip = float(spin_slip)

        def row(kappa: float, source) -> int:
            if kappa == 0.0 or (source[1] is None and not slip):
                return -1
            if (kappa, source) not in rows:
                rows.append((kappa, source))
            return rows.index((kappa, source))

        def source_of(v, bearing: str) -> tuple:
            return bearing, (self.spin_slip if self.spin_slip > 0 and v[spin_column] != 0 else None)

        ff = fams.families
        bpfo = self.bpfo_per_hz
        consts = np.zeros((2 * len(ff), 4))
        for i, f in enumerate(ff):
            consts[2 * i] = (f.rate_p / bpfo, f.fixed_p, f.rate_p, 0.5 * f.rate_p)
            if f.carrier:
                consts[2 * i + 1] = (f.rate_q / bpfo, f.fixed_q, f.rate_q, 0.5 * f.rate_q)
        self.wp = np.array([row(f.kappa_p, source_of(f.p, f.bearing_p)) for f in ff], dtype=np.int64)
        self.wq = np.array([row(f.kappa_q, source_of(f.q, f.bearing_q)) if f.carrier else -1 for f in ff],
                           dtype=np.int64)
        self.kappas = tuple(r[0] for r in rows)
        #: the walks the segments read, (bearing, spin slip or None) each, DE first and the cage's alone first
        self.walk_sources = tuple(sorted({r[1] for r in rows}, key=lambda w: (w[0] != "de", w[1] is not None)))
        self.walks = tuple(self.walk_sources.index(r[1]) for r in rows)
        self.csrc = carrier_sums(ff)
        self._layout, self._consts = layout, consts
        on = strikes is not None and strikes.on
        self.strike = np.asarray(strikes.families if on else np.zeros(len(ff), bool), dtype=np.int64)
        self.strike_params = np.array([strikes.sigma, strikes.offset_turns] if on else [0.0, 0.0])
        self._segment_plan = self.segment_plan(layout, consts, self.kappas, self.wp, self.wq, self.csrc, self.walks,
                                               self.strike, self.strike_params)
        self._warp: dict = {}

    @staticmethod
    def segment_plan(layout: dict, consts: np.ndarray, kappas, wp, wq, csrc, walks=None, strike=None,
                     strike_params=(0.0, 0.0)):
        """The segment kernel's plan (checked in C): the families' ``layout``, per phase (each family's, then its
        carrier's) ``consts`` (rate / BPFO, fixed, rate, rate / 2), the distinct slip rows' factors ``kappas`` and
        walks ``walks`` (indices into :attr:`walk_sources`; None: the first walk for every one), each family's slip
        rows ``wp``, ``wq`` (-1: none), carrier sums ``csrc`` (F, 2), the struck families ``strike`` (F,) (None:
        none) and the strikes' (log-standard deviation, offset [turns]) ``strike_params``."""
        walks = np.zeros(len(kappas), dtype=np.int64) if walks is None else walks
        strike = np.zeros(len(layout["lg"]), dtype=np.int64) if strike is None else strike
        return synth_kernel.lines_segment_plan(
            _i64(layout["lg"]), _i64(layout["carrier"]), _i64(layout["offset"]), _i64(wp), _i64(wq),
            _f64(consts).reshape(-1), _f64(np.asarray(kappas, dtype=float)), _i64(csrc).reshape(-1), _i64(walks),
            _i64(strike), _f64(strike_params))

    def family_tables(self) -> list:
        """Per family the slice of its table(s) in a knot's buffer (floats)."""
        lay = self._layout
        rows = (lay["N"] + 3) * (1 + lay["carrier"])
        return [slice(int(o), int(o + r * self.n_channels)) for o, r in zip(lay["offset"], rows)]

    def knot(self, x: np.ndarray, f: float, fade: float, taper, spow) -> tuple:
        """(y, v_iso, tables) at shaft speed ``f`` [Hz]: ``x`` (L, U) complex128 combinations [m] (multiplied in
        place by ``spow`` (L,), the lines' speed powers, if given), ``fade`` the low-speed fade, ``taper`` (L,) or
        None: ``y`` (L, C) channel amplitudes, ``v_iso`` (L, 8) housing velocity [mm/s], the families' float32
        tables in one buffer."""
        y = np.empty((self.n_lines, self.n_channels), complex)
        v_iso = np.empty((self.n_lines, 8))
        table = np.empty(self._floats, dtype=np.float32)
        synth_kernel.lines_knot(self._knot_plan, x, float(f), float(fade), taper, spow, y, v_iso, table,
                                self._work)
        return y, v_iso, table

    def segment(self, a, b, lo: int, hi: int, out: np.ndarray, acc, off, walk, noise, strike_key: int = 0) -> bool:
        """Samples [lo, hi) of the segment between knots a and b (of these lines) into ``out`` (hi - lo, C)
        float32, with the static part, and ``noise`` (None or ``(key, n0, sigma, extra)``: ``extra`` None, an
        (m, C) block, or the broadband floor's :meth:`~bkabem_core.synth.floor.BroadbandFloor.source`) and the
        features (``acc`` about ``off``) in the same pass, the struck families times the gain of the strikes of
        stream ``strike_key`` (:func:`~bkabem_core.synth.strikes.strike_key`): returns True (they are done)."""
        m, j = hi - lo, lo - a.x
        length = b.x - a.x
        w = jw0 = None
        c1u = c2u = 0.0
        warp = None
        if self.kappas:
            bpfo, fs = self.bpfo_per_hz, self.sample_rate_hz
            c1u = bpfo / fs * a.f
            c2u = 0.5 * bpfo / fs * (b.f - a.f) / length
            w, jw0 = walk.window(a.u_int, j, m, c1u, c2u, a.u_frac, self.walk_sources)
            warp = self._warp.get(m)
            if warp is None:
                warp = self._warp[m] = np.empty(len(self.kappas) * m, dtype=np.int64)
                if len(self._warp) > 8:
                    del self._warp[next(iter(self._warp))]
        key, n0, sigma, extra = noise if noise is not None else (0, 0, None, None)
        tb = None if b.amp is a.amp else b.amp.tables
        synth_kernel.lines_render(self._segment_plan, m, j, a.f, b.f, a.x, length, a.u_int + a.u_frac,
                                  self.sample_rate_hz, a.amp.tables, tb, w, jw0, c1u, c2u, a.u_frac, warp, out, acc,
                                  off, self.dc, int(key) & _MASK64, int(n0), sigma, extra, int(strike_key) & _MASK64)
        return True


class LoopLines:
    """The line kernels in numpy and the per-family sample loop (module docstring).

    Parameters
    ----------
    selection : LineSelection
    channels : ChannelMap
    dc : ndarray (C,)
    sample_rate_hz : float
    dtype : numpy dtype of the samples
    segment_fn : callable
        :func:`~bkabem_core.synth.kernel.segment` or its numpy reference.
    spin_slip, spin_column, strikes : float, int, StrikeSpread or None
        As :class:`FusedLines`.
    """

    renders_floor = False

    def __init__(self, selection, channels, dc, sample_rate_hz: float, dtype, segment_fn, spin_slip: float = 0.0,
                 spin_column: int = 2, strikes=None):
        self.families = selection.families
        self.strikes = strikes if strikes is not None and strikes.on else None
        self.spin_slip = float(spin_slip)
        self.spin_column = int(spin_column)
        self.nu, self.mu = selection.nu, selection.mu
        self.bpfo_per_hz = selection.bpfo_per_hz
        self.sample_rate_hz = float(sample_rate_hz)
        self.dtype = dtype
        self.dc = np.ascontiguousarray(dc, dtype=np.float64)
        self._segment_fn = segment_fn
        self._cindex, self._iso_rows = channels.cindex, channels.iso_rows
        self._power_index = channels.power.astype(np.int64)
        self._chan_scale = channels.scale.astype(float)
        # (cos, sin) of a carrier's phase: one line each, a 64-point spline table (pre-emphasised: exact line)
        n = 64
        g = np.exp(2j * np.pi * ((np.arange(n + 3) - 1) % n) / n) / np.sinc(1.0 / n) ** 4
        self._carrier_table = np.ascontiguousarray(np.stack([g.real, g.imag], axis=1), dtype=dtype)
        self._scratch: dict = {}

    def knot(self, x: np.ndarray, f: float, fade: float, taper) -> tuple:
        """(y, v_iso, tables) at shaft speed ``f`` [Hz] from the combinations ``x`` (L, U) [m] (speed powers and
        sensors applied): as :meth:`FusedLines.knot`, the tables a list of per-family tuples."""
        w = TWO_PI * (self.nu * f + self.mu)                                 # (L,) [rad/s]
        iw = 1j * w
        powers = np.stack([np.ones_like(iw), iw, iw * iw])                  # (i w)^p, p = 0, 1, 2 (no complex pow)
        fac = powers[self._power_index].T * (self._chan_scale * fade)[None, :]
        if taper is not None:
            fac = fac * taper[:, None]
        y = x[:, self._cindex] * fac
        weights = fade * (np.ones(x.shape[0]) if taper is None else taper)
        v = x[:, self._iso_rows] * (1j * w * 1e3 * weights)[:, None]
        v_iso = np.empty((v.shape[0], 8))
        v_iso[:, :4], v_iso[:, 4:] = v.real, v.imag
        return y, v_iso, self.families.tables(y, self.dtype)

    def segment(self, a, b, lo: int, hi: int, out: np.ndarray, acc, off, walk, noise, strike_key: int = 0) -> bool:
        """Samples [lo, hi) of the segment a-b into ``out`` with the static part: every family's table(s) through
        the sample loop at the family's own phase; a carrier's cosine and sine through the same loop from a
        two-column table, mixed in (:func:`~bkabem_core.synth.kernel.carrier_mix`); the struck families summed
        apart and added times the strikes' gain (:func:`~bkabem_core.synth.strikes.strike_gains_reference`).
        Returns False: the noise and the features are the caller's."""
        m = hi - lo
        length = b.x - a.x
        fs, bpfo = self.sample_rate_hz, self.bpfo_per_hz
        j = lo - a.x
        warps: dict = {}
        c1u = bpfo / fs * a.f
        c2u = 0.5 * bpfo / fs * (b.f - a.f) / length

        def warp_of(kappa: float, p, bearing: str):
            """Fixed-point slip offsets of a phase ``p`` of ``bearing`` that moves kappa turns per step of its
            bearing's walk (None: no slip): that bearing's cage walk, with its spin walk for a phase of the
            defective ball's spin."""
            spin = self.spin_slip if self.spin_slip > 0 and p[self.spin_column] != 0 else None
            if walk is None or kappa == 0.0 or (spin is None and walk.sigma == 0.0):
                return None
            if (kappa, spin, bearing) not in warps:
                warps[kappa, spin, bearing] = walk.warp_fixed(a.u_int, j, m, c1u, c2u, a.u_frac, (kappa,), spin,
                                                              bearing)[0]
            return warps[kappa, spin, bearing]

        out[...] = self.dc
        scratch = self._scratch.get(m)
        if scratch is None:
            c = out.shape[1]
            scratch = self._scratch[m] = (np.empty((m, c), self.dtype), np.empty((m, c), self.dtype),
                                          np.empty((m, 2), self.dtype))
            if len(self._scratch) > 8:
                del self._scratch[next(iter(self._scratch))]
        same = b.amp is a.amp
        blend = 65536.0 / length
        struck = None if self.strikes is None or m == 0 else np.zeros_like(out)
        gain = None
        for fi, fam in enumerate(self.families.families):
            phase0, dphase0, dd = phase_args(fam.rate_p, fam.fixed_p, a, b, j, fs, bpfo)
            warp = warp_of(fam.kappa_p, fam.p, fam.bearing_p)
            dest = out
            if struck is not None and self.strikes.families[fi]:
                dest = struck
                if gain is None:
                    gain = self._strike_gain(fam, a, b, j, m, walk, warp, (phase0, dphase0, dd), strike_key)
            ta, tb = a.amp.tables[fi], (None if same else b.amp.tables[fi])
            for ti in range(len(ta)):
                self._segment_fn(phase0, dphase0, dd, warp, ta[ti], None if tb is None else tb[ti], float(j), blend,
                                 scratch[ti], None, None)
            if not fam.carrier:
                dest += scratch[0]
                continue
            q0, dq0, ddq = phase_args(fam.rate_q, fam.fixed_q, a, b, j, fs, bpfo)
            self._segment_fn(q0, dq0, ddq, warp_of(fam.kappa_q, fam.q, fam.bearing_q), self._carrier_table, None,
                             float(j), blend, scratch[2], None, None)
            synth_kernel.carrier_mix(scratch[2], scratch[0], scratch[1], dest)
        if gain is not None:
            out += struck * gain[:, None].astype(out.dtype)
        return False

    def _strike_gain(self, fam, a, b, j: int, m: int, walk, warp, phase: tuple, strike_key: int) -> np.ndarray:
        """The strikes' gain of the m samples from sample j of segment a-b (float64) on family ``fam``'s phase
        (``phase``: the sample loop's (phase0, dphase0, ddphase); ``warp``: its slip offsets or None)."""
        fs, bpfo = self.sample_rate_hz, self.bpfo_per_hz
        length = b.x - a.x
        c1 = (fam.rate_p * a.f + fam.fixed_p) / fs
        c2 = 0.5 * fam.rate_p * (b.f - a.f) / (fs * length)
        first = (fam.rate_p / bpfo) * (a.u_int + a.u_frac) + fam.fixed_p * (a.x / fs) + (c1 + c2 * j) * j
        u = synth_kernel.phases_reference(*phase, m)
        if warp is not None:
            u = u + warp.view(np.uint64)
            c1u = bpfo / fs * a.f
            c2u = 0.5 * bpfo / fs * (b.f - a.f) / length
            w, jw0 = walk.bearing(fam.bearing_p).window(a.u_int, j, m, c1u, c2u, a.u_frac)
            first += fam.kappa_p * synth_kernel.slip_value_reference(float(j), c1u, c2u, a.u_frac, w, jw0)
        s = self.strikes
        return strike_gains_reference(u, first, s.offset_turns, strike_key, s.sigma)
