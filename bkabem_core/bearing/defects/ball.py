"""A pit in a ball: it spins with its ball and meets the races twice per spin turn (lines at m BSF + n FTF).

The pit is on ball ``ball_index`` (0-based; ball 1 of :class:`~bkabem_core.bearing.deep_groove.BearingGeometry` is
index 0), at spin angle ``angle_rad + theta_spin`` about the ball's own axis, 0 facing the outer race, pi facing the
inner race. It meets the outer race when ``|wrap(theta)| < l / (2 r_b)`` and the inner race when
``|wrap(theta - pi)| < l / (2 r_b)``: twice per spin turn (the 2 x BSF comb). The drop is the race bridging a pit in
the ball, to leading order ``s^2 / (2 R_x)`` at an arc distance s inside the nearer edge with R_x the rolling-
direction effective radius of that contact (:func:`~bkabem_core.bearing.defects.profiles.bridged_drop_m`). It depends
on the spin angle and on the cage angle (where its ball is in the load zone): its torus is ``a = theta_spin``,
``b = theta_cage``. The case key ``ball`` (1..z) says which ball.

Two more keys describe how the ball moves, not the pit, and are read by the synthesiser
(:mod:`bkabem_core.synth.balltrack`), not by this model (which places the pit on the track): ``wander_revolutions``,
the correlation of the ball's spin axis in ball revolutions (0: the pit stays on the track), and ``spin_slip``, the
relative standard deviation of the ball's spin advance per ball pass. Both optional, with the defaults documented
there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from bkabem_core.bearing.defects.profiles import ContactGeometry, bridged_drop_m, wrap_to_pi
from bkabem_core.bearing.defects.protocol import (
    ROUGHNESS,
    DefectKey,
    DefectKind,
    TorusGrid,
    roughness_field,
    roughness_problem,
    torus_axes,
)

#: Defaults of ``wander_revolutions`` [ball revolutions] and ``spin_slip`` [-]: their argument is in
#: :mod:`bkabem_core.synth.balltrack`.
DEFAULT_WANDER_REVOLUTIONS = 900.0
DEFAULT_SPIN_SLIP = 0.02


class Ball(DefectKind):
    """A pit in a ball (module docstring)."""

    name = "ball"
    order = 2
    place = "ball"
    adjective = "ball"
    fault_frequency = "bsf"
    strikes = 2
    phases = ("spin",)
    contacts = ("outer", "inner")
    per_ball = True
    own_keys = (DefectKey("ball", "int", 1, 1, "ball number 1..n_balls of a ball defect"),
                DefectKey("wander_revolutions", "float", 0.0, DEFAULT_WANDER_REVOLUTIONS,
                          "correlation of the ball's spin axis, in ball revolutions: how long the pit stays in or out "
                          "of the contact track (0: it stays on it); bkabem_core.synth.balltrack", "revolutions",
                          required=False),
                DefectKey("spin_slip", "float", 0.0, DEFAULT_SPIN_SLIP,
                          "random slip of the ball's spin: std of its advance per ball pass / the nominal "
                          "(0: none); bkabem_core.synth.balltrack", required=False),
                ROUGHNESS)

    def surface_rate_per_hz(self, fault_multipliers) -> float:
        return fault_multipliers.bsf

    def torus(self, n_balls: int, n_fast: int, n_slow: int) -> TorusGrid:
        z = int(n_balls)
        i, j, a, b = torus_axes(n_fast, n_slow)
        step = max(n_fast // n_slow, 1)
        return TorusGrid(np.array([[0, 0, 1, 0], [0, 1, 0, 0]]), b, np.zeros_like(a), a, (z * j * step) % n_fast)

    def surface_radius_m(self, geometry: ContactGeometry) -> float:
        return geometry.ball_radius_m

    def edge_drop_m(self, psi, dent, geometry: ContactGeometry, contact: str):
        arc = geometry.ball_radius_m * np.asarray(psi, dtype=float)
        return bridged_drop_m(arc, geometry.rx_m(contact), dent.depth_m)

    def drop_m(self, profiles, beta_rad, shaft_angle_rad, spin_angle_rad):
        spin = np.broadcast_to(np.asarray(spin_angle_rad, dtype=float), beta_rad.shape[:-1])
        per_ball = np.zeros(beta_rad.shape)
        for p in profiles:
            theta = spin + p.dent.angle_rad
            d = p.drop_m(np.abs(wrap_to_pi(theta)), "outer") + p.drop_m(np.abs(wrap_to_pi(theta - math.pi)), "inner")
            col = per_ball[..., p.dent.ball_index]
            per_ball[..., p.dent.ball_index] = np.maximum(col, d)
        return per_ball

    def check_dent(self, dent, geometry: ContactGeometry) -> None:
        if not 0 <= dent.ball_index < geometry.n_balls:
            raise ValueError(f"ball_index: must be in 0..{geometry.n_balls - 1} (got {dent.ball_index})")

    def check_own_key(self, key: str, value, bearing: dict) -> str | None:
        if key == "roughness_db":
            return roughness_problem(value)
        if key == "wander_revolutions":
            d, pd = bearing["ball_diameter_m"], bearing["pitch_diameter_m"]
            per_cage = pd / d * (1.0 + d / pd * math.cos(math.radians(bearing["contact_angle_deg"])))   # BSF / FTF
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    value == 0.0 or per_cage <= value <= 1.0e9 * per_cage):
                return (f"must be 0 (the pit stays on the track) or from one cage revolution ({per_cage:.3g} ball "
                        f"revolutions) to 1e9 of them (got {value!r})")
            return None
        if key == "spin_slip":
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 0.1:
                return f"must be in [0, 0.1] (a fraction of the spin's advance per ball pass; got {value!r})"
            return None
        z = bearing["n_balls"]
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= z:
            return f"must be a ball number 1..{z} (got {value!r})"
        return None

    def check_size(self, table: dict, bearing: dict) -> tuple[str, str] | None:
        quarter = bearing["ball_diameter_m"] * math.pi / 4
        if table["length_m"] >= quarter:
            return "length_m", (f"must be shorter than a quarter of the ball's circumference ({quarter * 1e3:.2f} "
                                f"mm): a longer pit meets both races at once, outside this model "
                                f"(got {table['length_m'] * 1e3:g} mm)")
        return None

    def dent_fields(self, table: dict) -> dict:
        """The ball number, and the ball's motion (``own``: carried to the ground truth, not used here)."""
        return {"ball_index": int(table["ball"]) - 1,
                "own": (("wander_revolutions", float(table.get("wander_revolutions", DEFAULT_WANDER_REVOLUTIONS))),
                        ("spin_slip", float(table.get("spin_slip", DEFAULT_SPIN_SLIP))), roughness_field(table))}

    def table_fields(self, dent) -> dict:
        return {"ball": dent.ball_index + 1, **dict(dent.own)}

    def part_name(self, fields: Mapping) -> str:
        ball = int(fields.get("ball") or 0)
        return f"ball {ball}" if ball else ""
