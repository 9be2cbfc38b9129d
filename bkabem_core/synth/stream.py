"""The mutable state of a synthesiser's run (its knots, the next sample, the position of the slip walks), and the
samples and metadata of a chunk over its knots.

Speed is piecewise linear in time between *knots* (every chunk border in streaming; every ``knot_s`` of run time and
every profile breakpoint when rendering a profile; subdivided so that the speed moves by at most
``max_speed_step_hz`` between knots). A knot holds its sample position, its speed, the DE bearing's ball passes since t = 0
(integer part and fraction: the ball-pass phase is integrated exactly, a quadratic in time per segment; every other
phase, the NDE's cage and spin among them, is a multiple of it) and the line amplitudes at its speed. Everything else a run needs is the plan's (:mod:`bkabem_core.synth.plan`), fixed.

A chunk (:meth:`Stream.chunk`) is rendered segment by segment by the plan's line kernels
(:mod:`bkabem_core.synth.render`). With the C kernels the sensor noise and the broadband floor are added inside the
sample loop or in one pass after it per segment; without them numpy's noise and the floor after all segments, then
the features. A segment across a model switch (two plans' knots) renders each knot's lines on their own and
blends them.

Units: positions in samples, speeds in Hz, phases in ball passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from bkabem_core.solve.harmonic import TWO_PI
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.balltrack import GAIN_TOLERANCE, keep_knots
from bkabem_core.synth.features import Chunk
from bkabem_core.synth.render import Amplitudes, blend

#: ISO 10816 evaluation band for velocity RMS [Hz]
ISO_BAND_HZ = (10.0, 1000.0)


@dataclass(slots=True)
class Knot:
    x: int              # position [samples] (time * sample rate); knots sit on samples
    f: float            # shaft speed [Hz]
    u_int: int          # ball passes since t = 0: integer part ...
    u_frac: float       # ... and fraction in [0, 1)
    amp: Amplitudes     # line amplitudes and tables at f
    base: Amplitudes | None = None  # ... before a wandering ball defect's gain (None: amp)
    gain: float = 1.0   # that gain


class Stream:
    """The knots of a run around its next sample, that sample's index, and the slip walk (or None).

    Parameters
    ----------
    walk : SlipWalks or None
        The random walks of the bearings' ball-pass phases of the run's seed (their blocks are made as the run
        advances).
    gate : TrackGate or None
        The track wander of a ball defect for the run's seed (:mod:`bkabem_core.synth.balltrack`).
    """

    def __init__(self, walk=None, gate=None):
        self.knots: list[Knot] = []
        self.next_index = 0
        self.walk = walk
        self.gate = gate

    @property
    def speed_hz(self) -> float | None:
        """The last knot's speed [Hz], None before the first (safe to read from another thread)."""
        try:
            return self.knots[-1].f
        except IndexError:
            return None

    @staticmethod
    def knots_between(plan, fa: float, fb: float, max_knots: int) -> int:
        """Segments between knots of speeds fa and fb [Hz]: the speed moves by at most ``max_speed_step_hz`` per
        segment, and with ``band_limit="taper"`` by at most 2 % where a line is near the taper (0.8 .. 0.95 of
        Nyquist; outside that range a change from standstill would ask for a thousand knots); at most
        ``max_knots``."""
        s = plan.settings
        n = math.ceil(abs(fb - fa) / s.max_speed_step_hz - 1e-12)
        if s.band_limit == "taper":
            near_lo, near_hi = plan.taper_speeds_hz
            hi = min(max(fa, fb), near_hi)
            lo = max(min(fa, fb), near_lo)
            if hi > 1.02 * lo:
                n = max(n, math.ceil(math.log(hi / lo) / math.log(1.02)))
        return max(1, min(n, max_knots))

    def append(self, x: int, f: float, plan, max_knots: int) -> None:
        """Add knot(s) up to sample x with speed f [Hz] (speed linear in time from the last knot), at most
        ``max_knots`` (:meth:`knots_between`); subdivision knots sit on samples too, with the speed of the straight
        line at that sample. Where a ball defect wanders (:mod:`bkabem_core.synth.balltrack`), knots are added
        between these where the walk's gain needs them (:meth:`_gate_knots`): they take the amplitudes of their
        segment blended in time (as the samples between its knots are) and the gain of the walk at their ball
        pass, with no spectrum of their own."""
        x = int(x)
        ks = self.knots
        if not ks:
            base = plan.amplitudes(f)
            amp, gain = self._gated(plan, base, 0.0)
            ks.append(Knot(x=x, f=float(f), u_int=0, u_frac=0.0, amp=amp, base=base, gain=gain))
            return
        last = ks[-1]
        span = x - last.x
        n = min(self.knots_between(plan, last.f, f, max_knots), span)
        track = plan.track
        if n == 1 and (track is None or not track.wanders):   # one step (streaming: nearly always)
            self._add(x, f, plan, plan.amplitudes(f))
            return
        for i in range(1, n + 1):
            xi = last.x + (span * i) // n
            fi = last.f + (f - last.f) * (xi - last.x) / span if i < n else f
            base = plan.amplitudes(fi)
            if track is not None and track.wanders:
                self._gate_knots(xi, base, plan, last, span, f, max_knots)
            self._add(xi, fi, plan, base)

    def _gate_knots(self, x: int, base, plan, first, span: int, f_end: float, max_knots: int) -> None:
        """The knots between the last one and the speed knot at sample x (amplitudes ``base``) that the walk's gain
        needs: the gain is linear between the walk's steps, so the candidates are the samples nearest to each step
        (every ``passes_per_step`` ball passes), at most ``max_knots``; of them those are kept where the gain,
        linear between the kept ones, would be off by more than
        :data:`~bkabem_core.synth.balltrack.GAIN_TOLERANCE` (:func:`~bkabem_core.synth.balltrack.keep_knots`: a pit
        off the track needs none). Their speed on the straight line from knot ``first`` over ``span`` samples to
        ``f_end`` [Hz]."""
        prev = self.knots[-1]
        length = x - prev.x
        k = plan.lines.bpfo_per_hz / plan.settings.sample_rate_hz
        step = plan.track.passes_per_step
        u0 = prev.u_int + prev.u_frac
        c1, c2 = k * prev.f, 0.5 * k * (base.f - prev.f) / length        # passes since prev: (c2 xi + c1) xi
        u1 = u0 + (c2 * length + c1) * length
        k0, k1 = math.floor(u0 / step) + 1, math.floor(u1 / step)
        if k1 < k0:
            return
        ks = range(k0, k1 + 1) if k1 - k0 < max_knots else np.linspace(k0, k1, max_knots).round().astype(int)
        xs = [prev.x]
        for j in ks:                                  # the sample where the ball passes reach step j
            d = j * step - u0
            xi = 2.0 * d / (c1 + math.sqrt(c1 * c1 + 4.0 * c2 * d)) if c1 > 0.0 or c2 > 0.0 else length
            xj = prev.x + int(round(xi))
            if xs[-1] < xj < x:
                xs.append(xj)
        xs.append(x)
        if len(xs) <= 2:
            return
        fs = [first.f + (f_end - first.f) * (xj - first.x) / span for xj in xs]
        gains = np.array([self.gate.gain(plan.track, u0 + (c2 * (xj - prev.x) + c1) * (xj - prev.x)) for xj in xs])
        a = prev.base if prev.base is not None and prev.base.lines is base.lines else None
        for j in keep_knots(np.array(xs, dtype=float), gains, GAIN_TOLERANCE):
            mid = plan.amplitudes(fs[j]) if a is None else blend(a, base, (xs[j] - prev.x) / length, fs[j])
            self._add(xs[j], fs[j], plan, mid)

    def _add(self, x: int, f: float, plan, base) -> None:
        prev = self.knots[-1]
        du = plan.lines.bpfo_per_hz / plan.settings.sample_rate_hz * 0.5 * (prev.f + f) * (x - prev.x)
        tot = prev.u_frac + du
        fl = math.floor(tot)
        u_int = prev.u_int + int(fl)
        amp, gain = self._gated(plan, base, u_int + (tot - fl))
        self.knots.append(Knot(x=int(x), f=float(f), u_int=u_int, u_frac=tot - fl, amp=amp, base=base, gain=gain))

    def _gated(self, plan, base, passes: float) -> tuple:
        """(amplitudes, gain) of a knot of amplitudes ``base`` at ``passes`` ball passes since t = 0: a wandering
        ball defect's lines times the gain of the walk there (:mod:`bkabem_core.synth.balltrack`); the last knot's
        own amplitudes where they are the same (a segment of one table: no blend in time)."""
        track = plan.track
        if track is None or not track.wanders or self.gate is None:
            return base, 1.0
        gain = self.gate.gain(track, passes)
        last = self.knots[-1] if self.knots else None
        if last is not None and last.base is base and last.gain == gain:
            return last.amp, gain
        return plan.gated_amplitudes(base, gain), gain

    def chunk(self, plan, n0: int, n: int, features: bool) -> Chunk:
        """The chunk of samples [n0, n0 + n) of ``plan`` over the knots (they cover the range; earlier knots are
        dropped), with its features if asked."""
        self.drop_before(n0)
        acc = None
        if features:
            acc = np.zeros((plan.n_channels, 6))
            acc[:, 4], acc[:, 5] = -np.inf, np.inf
        if plan.output:                     # the acquisition's output stage: the features of what it records
            out = _render_samples(plan, self, n0, n, None)
            for stage in plan.output:
                stage.apply(out, n0)
            if acc is not None:
                plan.accumulate(out, plan.dc_off, acc)
        else:
            out = _render_samples(plan, self, n0, n, acc)
        return _make_chunk(plan, self, n0, n, out, acc)

    def _segment_at(self, start: int, pos: float) -> int:
        ks = self.knots
        i = start
        while i + 2 < len(ks) and ks[i + 1].x <= pos:
            i += 1
        return i

    def drop_before(self, n0: int) -> None:
        """Forget the knots before the segment that holds sample n0."""
        i0 = self._segment_at(0, n0)
        if i0 > 0:
            del self.knots[:i0]

    def segments(self, n0: int, n: int) -> list:
        """(knot a, knot b, first sample, end sample) of the segments covering samples [n0, n0 + n)."""
        ks = self.knots
        if len(ks) == 2 and ks[1].x >= n0 + n:
            return [(ks[0], ks[1], n0, n0 + n)]
        out = []
        pos, i = n0, 0
        while pos < n0 + n:
            i = self._segment_at(i, pos)
            a, b = ks[i], ks[i + 1]
            end = min(n0 + n, max(pos + 1, b.x))
            out.append((a, b, pos, end))
            pos = end
        return out

    def state_at(self, pos: float, bpfo_per_hz: float, sample_rate_hz: float) -> tuple:
        """(speed [Hz], ball passes int, frac, knot a, knot b, blend weight) at sample position ``pos``."""
        ks = self.knots
        if len(ks) > 1:                                     # chunk borders on knots (streaming: always)
            if ks[0].x == pos:
                return ks[0].f, ks[0].u_int, ks[0].u_frac, ks[0], ks[1], 0.0
            if ks[-1].x == pos:
                return ks[-1].f, ks[-1].u_int, ks[-1].u_frac, ks[-2], ks[-1], 1.0
        i = self._segment_at(0, pos)
        a, b = ks[i], ks[i + 1]
        xi = pos - a.x
        f = a.f + (b.f - a.f) * xi / (b.x - a.x)
        du = bpfo_per_hz / sample_rate_hz * 0.5 * (a.f + f) * xi
        tot = a.u_frac + du
        fl = math.floor(tot)
        return f, a.u_int + int(fl), tot - fl, a, b, xi / (b.x - a.x)


def _segment_swap(a, b, lo: int, hi: int, out: np.ndarray, walk, strike_key: int) -> None:
    """A segment across a model switch (two line sets: knot a's and knot b's): each knot's lines rendered on their
    own at the common phases, blended linearly in time as the tables of one model are (the 2^-16 steps of the
    sample loop): phase continuous, the amplitudes move from one model to the other over the segment."""
    other = np.empty_like(out)
    for side, dest in ((a, out), (b, other)):
        side.amp.lines.segment(replace(a, amp=side.amp), replace(b, amp=side.amp), lo, hi, dest, None, None, walk,
                               None, strike_key)
    xi = np.arange(lo - a.x, hi - a.x, dtype=np.float64) * (65536.0 / (b.x - a.x))
    w = (np.clip(np.floor(xi), 0.0, 65536.0) / 65536.0).astype(out.dtype)
    other -= out
    other *= w[:, None]
    out += other


def _floor_faded(x: np.ndarray, a, b, lo: int) -> np.ndarray:
    """The floor under the low-speed fade of the lines (no rolling, no roughness excitation at standstill):
    linear in time from knot a's fade to knot b's, as the lines' amplitudes."""
    fa, fb = a.amp.fade, b.amp.fade
    if fa == 1.0 and fb == 1.0:
        return x
    s = (np.arange(lo, lo + x.shape[0]) - a.x) / max(b.x - a.x, 1)
    return np.ascontiguousarray(x * (fa + (fb - fa) * s)[:, None], dtype=x.dtype)


def _floor_part(floor, a, b, lo: int, hi: int):
    """The floor of samples [lo, hi) of the segment a-b for the fused kernel: its source (rendered inside the pass)
    where the segment is one line set at full level, else the samples, faded."""
    if a.amp.fade == 1.0 and b.amp.fade == 1.0 and a.amp.lines is b.amp.lines and a.amp.lines.renders_floor:
        return floor.source(lo, hi - lo)
    return _floor_faded(floor.render(lo, hi - lo), a, b, lo)


def _render_samples(plan, stream, n0: int, n: int, acc) -> np.ndarray:
    """The (n, C) samples of [n0, n0 + n) of ``plan`` over the stream's knots (they cover the range), with sensor
    noise and the broadband floor; their features accumulated into ``acc`` (None: none). With the C kernels the
    noise and the floor are added inside the sample loop or one pass after it per segment; without them, numpy's
    noise and the floor after all segments, then the features."""
    segments = stream.segments(n0, n)
    out = np.empty((n, plan.n_channels), dtype=plan.settings.dtype)
    noise, off, walk = plan.noise, plan.dc_off, stream.walk
    floor_on = plan.floor is not None
    lazy = floor_on and plan.lines_kernel.renders_floor     # the fused kernel renders the floor per block itself
    floor = plan.floor_block(n0, n) if floor_on and not lazy else None
    fused = synth_kernel.AVAILABLE and (noise.on or floor_on)
    late = not fused and (noise.on or floor is not None)  # numpy: added, moments taken, at the end
    swing = plan.rolling                                  # the floor's swing with a turning load: added last
    seg_acc = None if late or swing is not None else acc
    for a, b, lo, hi in segments:
        dest = out[lo - n0:hi - n0]
        args = None
        if fused:
            args = noise.segment(a, b, lo) if noise.on else (noise.key, lo, None)
            if lazy:
                args = args + (_floor_part(plan.floor, a, b, lo, hi),)
            else:
                args = args + (None if floor is None else _floor_faded(floor[lo - n0:hi - n0], a, b, lo),)
        if a.amp.lines is not b.amp.lines:
            _segment_swap(a, b, lo, hi, dest, walk, plan.strike_key)   # a model switch between line sets
        elif a.amp.lines.segment(a, b, lo, hi, dest, seg_acc, off, walk, args, plan.strike_key):
            continue                                            # noise and features in the same pass
        if args is not None:                                    # the families' sum first, then one pass
            synth_kernel.noise_add(dest, args[0], lo, args[2], off, seg_acc, args[3])
        elif seg_acc is not None:
            plan.accumulate(dest, off, seg_acc)
    if late:
        if noise.on:
            noise.add(out, n0, segments)
        if floor is not None:
            out += floor
    if swing is not None:
        fs = plan.settings.sample_rate_hz
        for a, b, lo, hi in segments:
            out[lo - n0:hi - n0] += _floor_faded(swing.block(a, b, lo, hi, fs), a, b, lo)
    if acc is not None and seg_acc is None:
        plan.accumulate(out, off, acc)
    return out


def _iso_velocity(plan, f: float, a, b, s: float) -> dict:
    """ISO 10816 velocity RMS [mm/s] in 10-1000 Hz per housing and direction at shaft speed ``f`` [Hz], from the
    line amplitudes of knots a and b blended by ``s`` (linear in time, as the samples); noise and slip smearing
    excluded."""
    if a.amp.lines is not b.amp.lines:                      # just switched models: the new one
        a = b
    r = synth_kernel.band_rms_lines(a.amp.v_iso, b.amp.v_iso, plan.lines.nu, plan.lines.mu, float(f), ISO_BAND_HZ[0],
                                    ISO_BAND_HZ[1], float(s))
    return {"de": {"vertical": r[0], "horizontal": r[1], "overall": max(r[0], r[1])},
            "nde": {"vertical": r[2], "horizontal": r[3], "overall": max(r[2], r[3])}}


def _make_chunk(plan, stream, n0: int, n: int, out: np.ndarray, acc) -> Chunk:
    """The :class:`Chunk` of samples ``out`` of [n0, n0 + n): speed, angles, features, ground truth."""
    fs = plan.settings.sample_rate_hz
    bpfo = plan.lines.bpfo_per_hz
    f0, ui, uf, *_ = stream.state_at(n0, bpfo, fs)
    f_end, *_ = stream.state_at(n0 + n, bpfo, fs)
    passes = ui + uf
    cages = plan.lines.cage_angles_rad(passes)
    shaft = (TWO_PI * (passes / bpfo)) % TWO_PI
    feats = {}
    if acc is not None:
        values = np.empty((6, plan.n_channels))
        synth_kernel.features_into(acc, n, plan.dc_off, values)
        feats = dict(zip(synth_kernel.FEATURE_NAMES, values))
        f, _, _, a, b, s = stream.state_at(n0 + 0.5 * n, bpfo, fs)
        feats["iso10816_velocity_rms_mm_s"] = _iso_velocity(plan, f, a, b, s)
    gt = dict(plan.ground_truth)
    gt["shaft_speed_hz"] = f0
    per = {b: {"ftf": fm.ftf * f0, "bpfo": fm.bpfo * f0, "bpfi": fm.bpfi * f0, "bsf": fm.bsf * f0}
           for b, fm in plan.lines.multipliers.items()}
    gt["fault_frequencies_hz"] = per["de"]                       # the field of one bearing type: the DE's
    gt["bearing_fault_frequencies_hz"] = per
    return Chunk(samples=out.T, first_sample_index=int(n0), t0_s=n0 / fs, sample_rate_hz=fs,
                 channel_names=plan.channels.names, units=plan.channels.units, shaft_speed_hz=float(f0),
                 shaft_speed_end_hz=float(f_end), cage_angle_rad=float(cages["de"]), shaft_angle_rad=float(shaft),
                 features=feats, ground_truth=gt, cage_angles_rad={b: float(v) for b, v in cages.items()})
