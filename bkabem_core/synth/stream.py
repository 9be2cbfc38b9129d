"""The mutable state of a synthesiser's run: its knots, the next sample, the position of the slip walk.

Speed is piecewise linear in time between *knots* (every chunk border in streaming; every ``knot_s`` of run time and
every profile breakpoint when rendering a profile; subdivided so that the speed moves by at most
``max_speed_step_hz`` between knots). A knot holds its sample position, its speed, the ball passes since t = 0
(integer part and fraction: the ball-pass phase is integrated exactly, a quadratic in time per segment) and the
line amplitudes at its speed. Everything else a run needs is the plan's (:mod:`bkabem_core.synth.plan`), fixed.

Units: positions in samples, speeds in Hz, phases in ball passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bkabem_core.synth.render import Amplitudes


@dataclass(slots=True)
class Knot:
    x: int              # position [samples] (time * sample rate); knots sit on samples
    f: float            # shaft speed [Hz]
    u_int: int          # ball passes since t = 0: integer part ...
    u_frac: float       # ... and fraction in [0, 1)
    amp: Amplitudes     # line amplitudes and tables at f


class Stream:
    """The knots of a run around its next sample, that sample's index, and the slip walk (or None).

    Parameters
    ----------
    walk : SlipWalk or None
        The random walk of the ball-pass phase of the run's seed (its blocks are made as the run advances).
    """

    def __init__(self, walk=None):
        self.knots: list[Knot] = []
        self.next_index = 0
        self.walk = walk

    @property
    def speed_hz(self) -> float | None:
        """The last knot's speed [Hz], None before the first (safe to read from another thread)."""
        try:
            return self.knots[-1].f
        except IndexError:
            return None

    def append(self, x: int, f: float, plan, max_knots: int) -> None:
        """Add knot(s) up to sample x with speed f [Hz] (speed linear in time from the last knot), at most
        ``max_knots`` (:meth:`Plan.knots_between <bkabem_core.synth.plan.Plan.knots_between>` places them);
        subdivision knots sit on samples too, with the speed of the straight line at that sample."""
        x = int(x)
        ks = self.knots
        if not ks:
            ks.append(Knot(x=x, f=float(f), u_int=0, u_frac=0.0, amp=plan.amplitudes(f)))
            return
        last = ks[-1]
        span = x - last.x
        n = min(plan.knots_between(last.f, f, max_knots), span)
        if n == 1:                                      # one step (streaming: nearly always)
            self._add(x, f, plan)
            return
        for i in range(1, n + 1):
            xi = last.x + (span * i) // n
            fi = last.f + (f - last.f) * (xi - last.x) / span if i < n else f
            self._add(xi, fi, plan)

    def _add(self, x: int, f: float, plan) -> None:
        prev = self.knots[-1]
        du = plan.lines.bpfo_per_hz / plan.settings.sample_rate_hz * 0.5 * (prev.f + f) * (x - prev.x)
        tot = prev.u_frac + du
        fl = math.floor(tot)
        self.knots.append(Knot(x=int(x), f=float(f), u_int=prev.u_int + int(fl), u_frac=tot - fl,
                               amp=plan.amplitudes(f)))

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
