"""A pit in the inner race: it turns with the shaft (lines at m BPFI +- n f_r).

The pit is at ``angle_rad + theta_shaft`` (``angle_rad`` at shaft angle 0). A ball is inside when
``|wrap(beta - angle - theta_shaft)| < l / (2 R_i)``; its drop is the exact path of a ball on the edge of a pit in a
convex race of radius R_i (:func:`~bkabem_core.bearing.defects.profiles.inner_race_drop_m`). It depends on the
ball-set position and the shaft angle: its torus is ``a = psi = z (theta_shaft - theta_cage)`` (a ball's position
relative to the inner race, one ball pitch per turn: BPFI) and ``b = theta_shaft`` (where the pit is in the load
zone), so ``theta_cage = theta_shaft - psi / z``; its lines are m BPFO + n shaft orders, BPFI = z - BPFO and its
sidebands at +- f_r.
"""

from __future__ import annotations

import numpy as np

from bkabem_core.bearing.defects.profiles import ContactGeometry, inner_race_drop_m
from bkabem_core.bearing.defects.protocol import RaceDefect, TorusGrid, torus_axes


class InnerRace(RaceDefect):
    """A pit in the inner race (module docstring)."""

    name = "inner"
    order = 1
    place = "inner race"
    adjective = "inner-race"
    fault_frequency = "bpfi"
    phases = ("shaft",)
    contacts = ("inner",)

    def surface_rate_per_hz(self, fault_multipliers) -> float:
        return 1.0 - fault_multipliers.ftf

    def torus(self, n_balls: int, n_fast: int, n_slow: int) -> TorusGrid:
        z = int(n_balls)
        i, j, a, b = torus_axes(n_fast, n_slow)
        step = max(n_fast // n_slow, 1)
        return TorusGrid(np.array([[z, -z, 0, 0], [1, 0, 0, 0]]), b - a / z, b, np.zeros_like(a),
                         (z * j * step - i) % n_fast)             # z theta_cage on the base's grid (exact)

    def surface_radius_m(self, geometry: ContactGeometry) -> float:
        return geometry.inner_race_radius_m

    def edge_drop_m(self, psi, dent, geometry: ContactGeometry, contact: str):
        return inner_race_drop_m(psi, geometry.inner_race_radius_m, geometry.ball_radius_m, dent.depth_m)

    def centre_rad(self, angle_rad: float, shaft_angle_rad):
        return angle_rad + np.asarray(shaft_angle_rad, dtype=float)[..., None]

    def table_race_radius_m(self, bearing: dict) -> float:
        return (bearing["pitch_diameter_m"] - bearing["ball_diameter_m"] - bearing["diametral_clearance_m"] / 2.0) / 2.0
