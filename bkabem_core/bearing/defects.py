"""Localised defects of a ball bearing: what a ball centre feels at a dent in the outer race, the inner race or a ball.

A dent (pit, spall) of length l along the rolling direction and depth h lowers the contact under a ball by the
*radial drop of the ball centre*: the ball (or the race, for a pit in the ball) bridges the pit and rests on its
edges, so what it feels depends on the curvatures of the two bodies, not only on h (the "ball-over-edge" profile of
the physics issue). Three kinds (``Dent.race``), each with its own phases (fault_kinds.md):

``"outer"``
    Fixed in space at ``angle_rad`` (from +x towards +y; -90 deg = bottom, in the load zone). A ball at attitude
    angle beta is inside when ``|wrap(beta - angle)| < l / (2 R_o)``. Its drop is the exact path of a ball of
    radius r_b in the concave race of radius R_o resting on the nearer edge (:func:`outer_race_drop_m`). Depends on
    the cage angle only: lines at m BPFO.
``"inner"``
    On the inner race, which turns with the shaft: at ``angle_rad + theta_shaft``. Same test with the inner race
    radius R_i and the exact path of a ball on the edge of a pit in a convex race (:func:`inner_race_drop_m`).
    Depends on the cage and the shaft angle: lines at m BPFO + n (shaft orders), BPFI = z - BPFO and sidebands at
    +- f_r.
``"ball"``
    On ball ``ball_index`` (0-based, ball 1 of :class:`~bkabem_core.bearing.deep_groove.BearingGeometry` is index 0), at spin
    angle ``angle_rad + theta_spin`` about the ball's own axis, 0 facing the outer race, pi facing the inner race.
    The defect meets the outer race when ``|wrap(theta)| < l / (2 r_b)`` and the inner race when
    ``|wrap(theta - pi)| < l / (2 r_b)``: twice per spin turn (the 2 x BSF comb). The drop is the race bridging a
    pit in the ball, to leading order ``s^2 / (2 R_x)`` at an arc distance s inside the nearer edge with R_x the
    rolling-direction effective radius of that contact (the same leading order as the exact race profiles).
    Depends on the cage angle (where the ball is in the load zone) and the spin angle: lines at m BSF + n FTF.

Every kind has the alternative ``edge = "cubic"`` profile of the physics issue (flat bottom, ADAMS cubic STEP edges
over ``edge_fraction`` of the half-angle; depth at most what the ``"ball"`` profile reaches, for the outer race the
ball's sagitta over the pit as before). Several defects in one bearing combine inside the bearing model: drops of the
same contact take the deeper one (a ball is in one pit of a race at a time), the outer and inner contacts are in
series, so their drops add.

Angles in rad, lengths in m. Nothing here imports the bearing model: :class:`DefectSet` gets the radii it needs.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

TWO_PI = 2.0 * math.pi
KINDS = ("outer", "inner", "ball")
EDGE_PROFILES = ("ball", "cubic")
#: The base phases each kind's excitation depends on (besides the ball-set position that every bearing has).
PHASES_OF_KIND = {"outer": (), "inner": ("shaft",), "ball": ("spin",)}


@dataclass(frozen=True)
class Dent:
    """A localised defect (dent, pit, spall) of one bearing (module docstring).

    Attributes
    ----------
    length_m : float
        Length along the rolling direction [m] (the arc on the race, or on the ball's rolling circle).
    depth_m : float
        Depth (the paper's "height") [m]; 0: no defect.
    angle_rad : float
        ``"outer"``: position angle of the centre in the bearing plane [rad], from +x towards +y.
        ``"inner"``: the same at shaft angle 0 (it turns with the shaft).
        ``"ball"``: spin angle of the centre at t = 0 [rad], 0 facing the outer race.
    edge_fraction : float
        ``edge = "cubic"`` only: width of each smoothed edge as a fraction of the half-angle [-], in [0, 1].
    bearing : str
        ``"de"`` or ``"nde"``: which bearing of the machine carries it.
    race : str
        Kind: ``"outer"``, ``"inner"`` or ``"ball"`` (:data:`KINDS`).
    edge : str
        ``"ball"`` (the ball-over-edge path) or ``"cubic"``.
    ball_index : int
        ``"ball"`` only: which ball (0-based, ball 1 at ``first_ball_angle`` when the cage angle is 0).
    """

    length_m: float
    depth_m: float
    angle_rad: float
    edge_fraction: float = 0.1
    bearing: str = "de"
    race: str = "outer"
    edge: str = "ball"
    ball_index: int = 0

    def __post_init__(self):
        if self.edge not in EDGE_PROFILES:
            raise ValueError(f"edge: must be one of {', '.join(EDGE_PROFILES)} (got {self.edge!r})")
        if self.race not in KINDS:
            raise ValueError(f"race: must be one of {', '.join(KINDS)} (got {self.race!r})")

    @property
    def kind(self) -> str:
        return self.race

    def to_dict(self) -> dict:
        return asdict(self)


def step_cubic(x, x0: float, x1: float):
    """ADAMS ``STEP(x, x0, 0, x1, 1)``: 0 below x0, 1 above x1, cubic ``D^2 (3 - 2 D)`` in between."""
    if x1 <= x0:
        return (np.asarray(x) >= x1).astype(float)
    d = np.clip((np.asarray(x) - x0) / (x1 - x0), 0.0, 1.0)
    return d * d * (3.0 - 2.0 * d)


def wrap_to_pi(angle_rad):
    """Wrap angles [rad] to [-pi, pi): the "n 2 pi" of paper Eq. (2)."""
    return np.remainder(np.asarray(angle_rad) + math.pi, TWO_PI) - math.pi


def outer_race_drop_m(psi, race_radius_m: float, ball_radius_m: float, depth_m: float):
    """Drop of a ball centre [m] at angle ``psi`` [rad] inside the nearer sharp edge of a pit in a concave race.

    The ball (radius r_b) rests on the edge point of the race (radius R_o): its centre lies on the circle of radius
    r_b about that point, ``r_c = R_o cos(psi) - sqrt(r_b^2 - R_o^2 sin^2(psi))``, against ``R_o - r_b`` on the
    intact race; the drop is at most the depth.
    """
    ro, rb = race_radius_m, ball_radius_m
    psi = np.asarray(psi, dtype=float)
    s = np.minimum(ro * np.sin(np.clip(psi, 0.0, None)), rb)
    drop = ro * np.cos(psi) - np.sqrt(np.maximum(rb * rb - s * s, 0.0)) - (ro - rb)
    drop = np.where(ro * np.sin(np.clip(psi, 0.0, None)) >= rb, np.inf, drop)
    return np.clip(drop, 0.0, depth_m)


def inner_race_drop_m(psi, race_radius_m: float, ball_radius_m: float, depth_m: float):
    """Drop of a ball centre [m] at angle ``psi`` [rad] inside the nearer sharp edge of a pit in a convex race.

    The ball's centre is on the circle of radius r_b about the edge point of the race (radius R_i):
    ``r_c = R_i cos(psi) + sqrt(r_b^2 - R_i^2 sin^2(psi))`` against ``R_i + r_b`` on the intact race (about
    ``s^2 / (2 R_x)`` at an arc ``s = R_i psi``, ``1/R_x = 1/r_b + 1/R_i``); at most the depth.
    """
    ri, rb = race_radius_m, ball_radius_m
    psi = np.asarray(psi, dtype=float)
    s = np.minimum(ri * np.sin(np.clip(psi, 0.0, None)), rb)
    drop = (ri + rb) - ri * np.cos(psi) - np.sqrt(np.maximum(rb * rb - s * s, 0.0))
    drop = np.where(ri * np.sin(np.clip(psi, 0.0, None)) >= rb, np.inf, drop)
    return np.clip(drop, 0.0, depth_m)


def bridged_drop_m(arc_m, effective_radius_m: float, depth_m: float):
    """Drop [m] at an arc ``arc_m`` [m] inside the nearer edge of a pit bridged by a body of relative radius R_x:
    ``min(h, s^2 / (2 R_x))`` (the leading order of the exact race profiles; used for a pit in a ball)."""
    s = np.clip(np.asarray(arc_m, dtype=float), 0.0, None)
    return np.minimum(s * s / (2.0 * effective_radius_m), depth_m)


class DefectProfile:
    """One defect with the geometry of its bearing: its half-angle, effective depth and drop profile(s).

    Parameters
    ----------
    dent : Dent
    outer_race_radius_m, inner_race_radius_m, ball_radius_m : float
        Race radii in the rolling direction and ball radius [m].
    rx_outer_m, rx_inner_m : float
        Rolling-direction effective radii of the outer and inner contact [m] (Hertz).

    Attributes
    ----------
    half_angle_rad : float
        Half the angle the pit subtends on its surface (race, or ball for ``"ball"``) [rad].
    depth_eff_m : float
        Largest drop (at the centre) [m]; for ``"ball"`` the larger of the two contacts.
    edge_rad : float
        ``"cubic"``: the smoothed edge width [rad]; 0 for ``"ball"``.
    """

    def __init__(self, dent: Dent, outer_race_radius_m: float, inner_race_radius_m: float, ball_radius_m: float,
                 rx_outer_m: float, rx_inner_m: float):
        self.dent = dent
        self.kind = dent.race
        self._ro, self._ri, self._rb = outer_race_radius_m, inner_race_radius_m, ball_radius_m
        self._rx = {"outer": rx_outer_m, "inner": rx_inner_m}
        surface = {"outer": outer_race_radius_m, "inner": inner_race_radius_m, "ball": ball_radius_m}[self.kind]
        self.half_angle_rad = dent.length_m / (2.0 * surface)
        a = self.half_angle_rad
        self.edge_rad = dent.edge_fraction * a if dent.edge == "cubic" else 0.0
        if self.kind == "ball":
            ball_depths = [float(self._ball_profile(np.array(a), c)) for c in ("outer", "inner")]
            self._depth = {c: d for c, d in zip(("outer", "inner"), ball_depths)}
            self.depth_eff_m = max(ball_depths)
        else:
            ball_depth = float(self._ball_profile(np.array(a)))
            if dent.edge == "cubic" and self.kind == "outer":
                half = min(dent.length_m / 2.0, ball_radius_m)
                limit = ball_radius_m - math.sqrt(ball_radius_m ** 2 - half * half)   # ball's sagitta over the pit
                self.depth_eff_m = min(dent.depth_m, limit)
            else:
                self.depth_eff_m = ball_depth
            self._depth = {"outer": self.depth_eff_m, "inner": self.depth_eff_m}

    @property
    def active(self) -> bool:
        """Whether a ball feels it at all (depth > 0)."""
        return self.depth_eff_m > 0.0

    def _ball_profile(self, psi, contact: str = ""):
        """The ``"ball"`` profile [m] at ``psi`` [rad] inside the nearer edge."""
        h = self.dent.depth_m
        if self.kind == "outer":
            return outer_race_drop_m(psi, self._ro, self._rb, h)
        if self.kind == "inner":
            return inner_race_drop_m(psi, self._ri, self._rb, h)
        return bridged_drop_m(self._rb * np.asarray(psi, dtype=float), self._rx[contact], h)

    def drop_m(self, rel_angle_rad, contact: str = ""):
        """Drop [m] at an absolute angular distance ``rel_angle_rad`` [rad] from the pit centre on its surface;
        ``contact`` (``"outer"``/``"inner"``) only for a ball defect."""
        rel = np.asarray(rel_angle_rad, dtype=float)
        if not self.active:
            return np.zeros(rel.shape)
        a = self.half_angle_rad
        if self.dent.edge == "cubic":
            depth = self._depth[contact] if self.kind == "ball" else self.depth_eff_m
            return depth * (1.0 - step_cubic(rel, a - self.edge_rad, a))
        return np.where(rel < a, self._ball_profile(a - rel, contact), 0.0)

    def entry_ramp_rad(self) -> float:
        """Angle on its surface over which the drop goes from 0 to its largest value at each edge [rad]."""
        if self.dent.edge == "cubic":
            return self.edge_rad
        psi = np.linspace(0.0, self.half_angle_rad, 2049)
        contact = "outer" if self.kind == "ball" else ""
        prof = self._ball_profile(psi, contact)
        full = np.nonzero(prof >= prof[-1] * (1.0 - 1e-9))[0]
        return float(psi[full[0]]) if full.size else float(self.half_angle_rad)


class DefectSet:
    """The defects of one bearing, as the drop every ball feels at given phases.

    Parameters
    ----------
    dents : sequence of Dent
        The bearing's defects (depth 0 ones are ignored).
    outer_race_radius_m, inner_race_radius_m, ball_radius_m, rx_outer_m, rx_inner_m : float
        Geometry (:class:`DefectProfile`).
    n_balls : int

    Attributes
    ----------
    profiles : tuple of DefectProfile
        The active defects.
    kinds : tuple of str
        Their kinds, without repetition, in :data:`KINDS` order.
    """

    def __init__(self, dents, outer_race_radius_m: float, inner_race_radius_m: float, ball_radius_m: float,
                 rx_outer_m: float, rx_inner_m: float, n_balls: int):
        radii = (outer_race_radius_m, inner_race_radius_m, ball_radius_m, rx_outer_m, rx_inner_m)
        profiles = [DefectProfile(d, *radii) for d in dents]
        self.profiles = tuple(p for p in profiles if p.active)
        self.n_balls = int(n_balls)
        for p in self.profiles:
            if p.kind == "ball" and not 0 <= p.dent.ball_index < self.n_balls:
                raise ValueError(f"ball_index: must be in 0..{self.n_balls - 1} (got {p.dent.ball_index})")
        self.kinds = tuple(k for k in KINDS if any(p.kind == k for p in self.profiles))

    def __bool__(self) -> bool:
        return bool(self.profiles)

    def of_kind(self, kind: str) -> tuple:
        return tuple(p for p in self.profiles if p.kind == kind)

    @property
    def phases(self) -> tuple:
        """Base phases besides the cage angle that the drops depend on (``"shaft"``, ``"spin"``)."""
        return tuple(ph for k in self.kinds for ph in PHASES_OF_KIND[k])

    def drop_m(self, beta_rad, shaft_angle_rad=0.0, spin_angle_rad=0.0):
        """Drop of every ball [m], shape of ``beta_rad`` (..., z), at ball attitude angles ``beta_rad`` [rad], shaft
        angle and spin angle [rad] (broadcast against ``beta_rad[..., 0]``)."""
        beta = np.asarray(beta_rad, dtype=float)
        total = np.zeros(beta.shape)
        for kind in ("outer", "inner"):
            race = None
            for p in self.of_kind(kind):
                centre = p.dent.angle_rad
                if kind == "inner":
                    centre = centre + np.asarray(shaft_angle_rad, dtype=float)[..., None]
                d = p.drop_m(np.abs(wrap_to_pi(beta - centre)))
                race = d if race is None else np.maximum(race, d)
            if race is not None:
                total = total + race
        balls = self.of_kind("ball")
        if balls:
            spin = np.broadcast_to(np.asarray(spin_angle_rad, dtype=float), beta.shape[:-1])
            per_ball = np.zeros(beta.shape)
            for p in balls:
                theta = spin + p.dent.angle_rad
                d = p.drop_m(np.abs(wrap_to_pi(theta)), "outer") + p.drop_m(np.abs(wrap_to_pi(theta - math.pi)),
                                                                          "inner")
                col = per_ball[..., p.dent.ball_index]
                per_ball[..., p.dent.ball_index] = np.maximum(col, d)
            total = total + per_ball
        return total
