"""The geometry every defect kind shares: the bearing as a defect sees it, drop profiles, edge profiles, angle helpers.

A dent (pit, spall) of length l along the rolling direction and depth h lowers the contact under a ball by the
*radial drop of the ball centre*: the ball (or the race, for a pit in the ball) bridges the pit and rests on its
edges, so what it feels depends on the curvatures of the two bodies, not only on h (the "ball-over-edge" profile).
The exact paths over a sharp edge of a concave race (:func:`outer_race_drop_m`) and of a convex one
(:func:`inner_race_drop_m`), and their leading order for any bridging body (:func:`bridged_drop_m`), are here; each
kind (:mod:`bkabem_core.bearing.defects.protocol`) picks the one of its surface. The alternative ``"cubic"`` edge
(:data:`EDGE_PROFILES`) is a flat bottom with ADAMS cubic STEP edges (:func:`step_cubic`). These profiles are those of
a ``"slot"`` (:data:`SHAPES`): a defect across the whole ball track; a ``"round_pit"``, which the contact can bridge
sideways, is :mod:`bkabem_core.bearing.defects.round_pit`.

Angles in rad, lengths in m. Nothing here knows the kinds or the bearing model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * math.pi
#: Edge profiles of a defect: ``"ball"`` (the ball-over-edge path) or ``"cubic"`` (flat bottom, STEP edges).
EDGE_PROFILES = ("ball", "cubic")
#: Shapes of a defect's footprint: ``"slot"`` (across the whole ball track, of a length along the rolling direction)
#: or ``"round_pit"`` (a round hole of that diameter, which the contact ellipse bridges when it is narrower).
SHAPES = ("slot", "round_pit")


@dataclass(frozen=True)
class ContactGeometry:
    """What a defect kind knows of its bearing (SI).

    Attributes
    ----------
    outer_race_radius_m, inner_race_radius_m : float
        Race radii in the rolling direction [m] (clearance and contact angle included).
    ball_radius_m : float
        Ball radius [m].
    rx_outer_m, rx_inner_m : float
        Rolling-direction effective radii of the outer and inner Hertz contact [m].
    n_balls : int
        Number of balls.
    ry_outer_m, ry_inner_m : float
        Transverse effective radii of the outer and inner Hertz contact [m] (``1/R_y = 1/r_b - 1/(f d)``, the ball
        in its groove of radius ``f d``).
    effective_modulus_pa : float
        ``E' = E / (1 - nu^2)`` of balls and races [Pa].
    """

    outer_race_radius_m: float
    inner_race_radius_m: float
    ball_radius_m: float
    rx_outer_m: float
    rx_inner_m: float
    n_balls: int
    ry_outer_m: float = math.inf
    ry_inner_m: float = math.inf
    effective_modulus_pa: float = math.nan

    def rx_m(self, contact: str) -> float:
        """Rolling-direction effective radius of the ``"outer"`` or ``"inner"`` contact [m]."""
        return self.rx_outer_m if contact == "outer" else self.rx_inner_m

    def ry_m(self, contact: str) -> float:
        """Transverse effective radius of the ``"outer"`` or ``"inner"`` contact [m]."""
        return self.ry_outer_m if contact == "outer" else self.ry_inner_m


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
