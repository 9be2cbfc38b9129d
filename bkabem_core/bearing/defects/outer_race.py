"""A pit in the outer race: fixed in space, met by every ball in turn (lines at m BPFO).

The pit is at ``angle_rad`` in the bearing plane (from +x towards +y; -90 deg = bottom, in the load zone), or at a
clock position (``clock``: 12 at the top, 3 at +x, 6 at the bottom, the load zone of a horizontal shaft under its
weight; ``angle_deg = 90 - 30 clock``), as CWRU places its outer-race pits (3, 6 and 12 o'clock, the sensor at 12). A ball at
attitude angle beta is inside when ``|wrap(beta - angle)| < l / (2 R_o)``. Its drop is the exact path of a ball of
radius r_b in the concave race of radius R_o resting on the nearer edge
(:func:`~bkabem_core.bearing.defects.profiles.outer_race_drop_m`); the ``"cubic"`` profile's depth is at most the
ball's sagitta over the pit, ``r_b - sqrt(r_b^2 - (l/2)^2)`` (116 um for a 2 mm pit under 8.73 mm balls). It depends
on the ball-set position only: its drops repeat with the ball pass, BPFO orders.
"""

from __future__ import annotations

import math

from bkabem_core.bearing.defects.profiles import ContactGeometry, outer_race_drop_m
from bkabem_core.bearing.defects.protocol import RaceDefect


class OuterRace(RaceDefect):
    """A pit in the outer race (module docstring)."""

    name = "outer"
    order = 0
    place = "outer race"
    adjective = "outer-race"
    fault_frequency = "bpfo"
    contacts = ("outer",)

    def surface_rate_per_hz(self, fault_multipliers) -> float:
        return fault_multipliers.ftf

    def surface_radius_m(self, geometry: ContactGeometry) -> float:
        return geometry.outer_race_radius_m

    def edge_drop_m(self, psi, dent, geometry: ContactGeometry, contact: str):
        return outer_race_drop_m(psi, geometry.outer_race_radius_m, geometry.ball_radius_m, dent.depth_m)

    def cubic_depth_m(self, dent, geometry: ContactGeometry, edge_depth_m: float) -> float:
        rb = geometry.ball_radius_m
        half = min(dent.length_m / 2.0, rb)
        limit = rb - math.sqrt(rb ** 2 - half * half)                  # the ball's sagitta over the pit
        return min(dent.depth_m, limit)

    def centre_rad(self, angle_rad: float, shaft_angle_rad):
        return angle_rad

    def clock_angle_deg(self, hours: int) -> float | None:
        return math.remainder(90.0 - 30.0 * hours, 360.0)       # 12 -> 90 (top), 3 -> 0 (+x), 6 -> -90 (bottom)

    def table_race_radius_m(self, bearing: dict) -> float:
        return (bearing["pitch_diameter_m"] + bearing["ball_diameter_m"] + bearing["diametral_clearance_m"] / 2.0) / 2.0
