"""The rolling noise follows the load on the balls: a bearing's broadband floor swings with a load that turns.

The broadband floor (:mod:`bkabem_core.synth.floor`) is the structure's response to the force a rolling contact makes
on its roughness: the contact stiffness times the roughness displacement. A Hertzian point contact stiffens with its
load, ``dQ / d delta = 1.5 K^(2/3) Q^(1/3)``, so the force noise of one contact has a power ~ ``Q^(2/3)``, and the
independent contacts of a bearing make a noise whose power goes as

    P(theta) = < sum_i Q_i(theta)^(2/3) >_cage,

``Q_i`` the ball loads [N] of the bearing's static equilibrium under its static radial load, its axial preload and
the load that turns with the shaft (the coupling's force, ``baseline.coupling_force_n``: the bearing's share
:attr:`~bkabem_core.fe.machine.BearingSite.rotating_load_n`) at shaft angle ``theta``, averaged over the cage's
positions within one ball pitch (the ball passes' own part of the swing is left out: with every ball loaded by the
preload it is small, and a line at the ball pass would be a fault line in a healthy bearing's envelope). Where no
load turns, ``P`` is constant and the floor is the stationary one. Where a load turns, the bearing's force pairs are
multiplied by the amplitude gain

    g(theta) = sqrt(P(theta) / mean_theta P),

whose mean square is 1: the floor's mean power, hence its calibration (docs/rigs.md), stays what it was, and the
power moves over the turn. The acquisition's input floor does not follow the shaft and is not touched.

What it does to a diagnosis: the squared envelope of the housing's band, where the bearing's floor dominates, gets
the shaft orders of ``g^2`` (mostly 1x) without any line in the spectrum to make them. On the CWRU rig the healthy
record's 2-4 kHz power swings 1.8 : 1 over the turn and reads 17 dB at 1x in its squared envelope with its discrete
lines clipped away, so it is the noise that swings (docs/rigs.md); the twin's own drive-end contacts (31.5 N of
weight, 20 N of preload, 30.8 N turning) swing ``P`` by 1.17 : 1.

Realisation: the stationary floor of :class:`~bkabem_core.synth.floor.BroadbandFloor` is kept as it is (the input
floor and every force pair at gain 1), and :class:`RollingSwing` adds ``(g_b(theta) - 1) x floor_b`` per swinging
bearing ``b``, ``floor_b`` that bearing's own force pairs rendered from the same seed (the same normals and grains
as in the stationary floor, the other pairs at gain 0). ``theta`` per sample is the stream's shaft angle (the knots'
phase, the same as the lines' shaft angle), and ``g`` is read from a table of :data:`TURN_POINTS` angles over the
turn by periodic linear interpolation. The floor's fade at low speed applies to both parts alike.

Units: newtons, radians (turns where said), amplitude gains [-].
"""

from __future__ import annotations

import functools
import math

import numpy as np

from bkabem_core.bearing.deep_groove import Bearing
from bkabem_core.model.vocabulary import BEARINGS
from bkabem_core.synth.floor import BroadbandFloor

#: Shaft angles of the gain table over one turn (P is smooth in theta: its harmonics fall fast).
TURN_POINTS = 64
#: Cage positions within one ball pitch the contact power is averaged over.
CAGE_POINTS = 8


def contact_power(site, n: int = TURN_POINTS, cage_points: int = CAGE_POINTS) -> np.ndarray:
    """(n,) ``P(theta)`` [N^(2/3)] of a bearing site (module docstring) at shaft angles ``2 pi k / n``.

    It depends on the bearing's geometry and loads alone (the static equilibrium and ball loads without the
    defects), so the models of one machine (a data set's defects, a scenario's states) share one computation.

    Parameters
    ----------
    site : BearingSite
        The bearing's site of the machine (static radial load, axial load, turning load, bearing).
    n : int
        Shaft angles over one turn.
    cage_points : int
        Cage positions within one ball pitch.
    """
    w = np.asarray(site.radial_load_n, dtype=float)
    return np.array(_contact_power(site.bearing.geometry, float(w[0]), float(w[1]), float(site.axial_load_n),
                                   complex(site.rotating_load_n), int(n), int(cage_points)))


@functools.lru_cache(maxsize=32)
def _contact_power(geometry, load_x_n: float, load_y_n: float, axial_load_n: float, turning_n: complex, n: int,
                   cage_points: int) -> tuple:
    """:func:`contact_power` of a defect-free bearing of ``geometry`` under these loads [N], as a tuple."""
    bearing = Bearing(geometry)
    pitch = 2.0 * math.pi / geometry.n_balls
    cages = np.arange(cage_points) * (pitch / cage_points)
    out = []
    for k in range(n):
        turn = turning_n * complex(math.cos(2.0 * math.pi * k / n), math.sin(2.0 * math.pi * k / n))
        e = bearing.state(load_x_n + turn.real, load_y_n + turn.imag, axial_load_n=axial_load_n).displacement_m
        p = 0.0
        for c in cages:
            q = np.asarray(bearing.ball_loads_n(e[0], e[1], float(c), 0.0, with_dent=False, e_z_m=e[2]))
            p += float(np.sum(np.clip(q, 0.0, None) ** (2.0 / 3.0)))
        out.append(p / cage_points)
    return tuple(out)


def swing_gains(model, n: int = TURN_POINTS) -> dict:
    """``{bearing: (n,) amplitude gain g(theta)}`` of the bearings of ``model`` a load turns in (module docstring);
    empty where none does."""
    out = {}
    for name in BEARINGS:
        site = model.machine.sites[name]
        if complex(site.rotating_load_n) == 0:
            continue
        p = contact_power(site, n)
        out[name] = np.sqrt(p / np.mean(p))
    return out


class RollingSwing:
    """The swinging part of a floor: ``sum_b (g_b(theta) - 1) floor_b`` (module docstring).

    Parameters
    ----------
    floor : BroadbandFloor
        The stationary floor of the synthesiser's channels (its transfer, gains and seed are reused).
    gains : dict
        :func:`swing_gains` of the model (not empty).
    bpfo_per_hz : float
        The stream's phase unit: ball passes of the reference bearing per shaft turn.
    """

    def __init__(self, floor: BroadbandFloor, gains: dict, bpfo_per_hz: float):
        self.gains = {b: np.asarray(g, dtype=float) for b, g in gains.items()}
        if any(g.size != TURN_POINTS for g in self.gains.values()):
            raise ValueError(f"RollingSwing: gain tables of {TURN_POINTS} shaft angles expected")
        #: bearing -> float32 (TURN_POINTS + 1,) ``g - 1``, closed over the turn (the interpolation's table)
        self._tables = {b: (np.append(g, g[0]) - 1.0).astype(np.float32) for b, g in self.gains.items()}
        self.bpfo_per_hz = float(bpfo_per_hz)
        #: bearing -> its force pairs' part of the floor (the same seed)
        self.parts = {b: floor.pairs_only([1.0 if name == b else 0.0 for name in BEARINGS for _ in range(2)])
                      for b in self.gains}

    @classmethod
    def of_plan(cls, model, floor: BroadbandFloor | None, bpfo_per_hz: float) -> "RollingSwing | None":
        """The swing of a synthesiser's floor, or None (no floor force, or no load turns)."""
        if floor is None or floor.density <= 0.0:
            return None
        gains = swing_gains(model)
        return cls(floor, gains, bpfo_per_hz) if gains else None

    def to_dict(self) -> dict:
        """The ground truth's ``floor_swing``: per swinging bearing, its floor's power over the turn, largest over
        smallest [-], and the shaft angle [deg] of the largest (the stream's shaft angle)."""
        out = {}
        for b, g in self.gains.items():
            p = g * g
            out[b] = {"power_swing": float(p.max() / p.min()),
                      "strongest_at_shaft_angle_deg": float(360.0 * int(np.argmax(p)) / p.size)}
        return {"law": "power ~ sum of ball loads^(2/3) (Hertzian contact stiffness)", "bearings": out}

    @property
    def seed(self) -> int:
        return next(iter(self.parts.values())).seed

    def reseeded(self, seed: int) -> "RollingSwing":
        """The same swing over the floor of another seed."""
        out = RollingSwing.__new__(RollingSwing)
        out.gains, out.bpfo_per_hz, out._tables = self.gains, self.bpfo_per_hz, self._tables
        out.parts = {b: p.reseeded(seed) for b, p in self.parts.items()}
        return out

    def shaft_turns(self, a, b, lo: int, hi: int, sample_rate_hz: float) -> np.ndarray:
        """(hi - lo,) shaft angle [turns, in [0, 1)] of samples [lo, hi) of the segment between knots a and b (the
        speed linear in time between them: the phase the stream's :meth:`state_at` gives)."""
        xi = np.arange(lo - a.x, hi - a.x, dtype=np.float64)
        span = max(b.x - a.x, 1)
        du = self.bpfo_per_hz / sample_rate_hz * (a.f * xi + 0.5 * (b.f - a.f) * xi * xi / span)
        u0 = math.fmod(float(a.u_int), self.bpfo_per_hz) + a.u_frac
        return np.mod((u0 + du) / self.bpfo_per_hz, 1.0)

    def _cells(self, turns: np.ndarray) -> tuple:
        """(cell index, float32 fraction in it) of shaft angles ``turns`` in the gain tables."""
        pos = turns * TURN_POINTS
        k = np.minimum(pos.astype(np.int64), TURN_POINTS - 1)  # turns in [0, 1); 1.0 itself from a rounding
        return k, (pos - k).astype(np.float32)

    @staticmethod
    def _interpolate(table: np.ndarray, k: np.ndarray, frac: np.ndarray) -> np.ndarray:
        out = table[k]
        out += (table[k + 1] - out) * frac
        return out

    def block(self, a, b, lo: int, hi: int, sample_rate_hz: float) -> np.ndarray:
        """(hi - lo, C) float32: the swinging part of the floor over samples [lo, hi) of the segment a-b."""
        cells = self._cells(self.shaft_turns(a, b, lo, hi, sample_rate_hz))
        out = None
        for name, part in self.parts.items():
            x = part.render(lo, hi - lo)                        # a view of the part's buffer, reused next call
            x *= self._interpolate(self._tables[name], *cells)[:, None]
            if out is None:
                out = x.copy()
            else:
                out += x
        return out
