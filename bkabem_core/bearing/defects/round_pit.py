"""A round pit: a round hole of diameter D and depth h in a race or a ball (an EDM pit), as a ball's contact feels it.

A ``"slot"`` (:data:`~bkabem_core.bearing.defects.profiles.SHAPES`) runs across the whole ball track, so a ball drops
into it as far as its curvature along the rolling direction lets it (the ball-over-edge profiles of
:mod:`~bkabem_core.bearing.defects.profiles`). A round pit is narrower than that: under load a ball touches its race
over the Hertz ellipse, whose semi-axis across the rolling direction ``a`` is several times the one along it ``b``
(the ball sits in a groove of nearly its own radius). A pit narrower than ``2 a`` is bridged: the ball keeps resting
on the pit's sides and sinks only by the extra approach the reduced contact needs to carry the same load. This
module computes that approach loss, for every kind (the shape of a pit is the same whether it is cut in the outer
race, the inner race or a ball; the kind gives the surface, the contact and the phases).

Geometry (one contact, the pit at arc ``s`` from the contact point along the rolling direction). In the contact's
frame (x along the rolling direction, y across it) the undeformed gap of ball and race is::

    g(x, y) = x^2 / (2 R_x) + (r_b - sqrt(r_b^2 - y^2)) - (r_g - sqrt(r_g^2 - y^2))   [+ h inside the pit]

with ``R_x`` the rolling-direction effective radius of the contact (Hertz, :class:`~bkabem_core.bearing.deep_groove.
HertzContact`), r_b the ball radius and ``r_g = f d`` the groove radius (``1/R_y = 1/r_b - 1/r_g``): second order
along x, the exact circles across it, where a wide pit's sides are far from the groove bottom. A pit in a ball gives
the same gap (only the relative geometry of the two surfaces enters).

Effective drop. With the ball load Q at which the pit is evaluated (``Dent.bridging_load_n``, the bearing's largest
static ball load: :meth:`~bkabem_core.bearing.deep_groove.Bearing.with_bridging_load`) the approach of the intact
contact is ``delta_0(Q)``; with the pit at arc s it is ``delta_pit(Q, s)``, from the elastic half-space contact of the
two bodies (:mod:`bkabem_core.bearing.halfspace`; Johnson 1985, Polonsky & Keer 1999). The drop a ball feels is
``h_eff(s) = delta_pit(Q, s) - delta_0(Q)``: in the bearing model's ball law ``Q = K (delta - h_eff)^1.5`` the ball
then carries exactly Q at the approach the half-space solution needs, and the pit's influence is zero once its rim
is a contact half-length ``b`` away from the contact point (the ellipse overlaps it from ``s = D/2 + b``: the entry
and exit of the drop profile). Its limits:

* a pit much wider than the ellipse (or a light load): the ball is rigid against it and drops by the geometric
  depth: the gap's smallest value on the pit's rim (the ball resting on the rim), at most the depth h (a shallow
  pit: the ball on its bottom) -- :meth:`PitContact.rigid_drop_m`, the drop at zero load;
* a pit much narrower than the ellipse: a small drop, growing with D (the share of the contact's load it takes away:
  :meth:`PitContact.hertz_load_fraction`).

The ball's drop into a round hole limited by its curvature is the transverse counterpart of the defect models of
Sawalhi & Randall (MSSP 22, 2008: the ball's path into a defect limited by the ball's curvature) and Petersen et al.
(MSSP 50-51, 2015); the Hertz ellipse follows Harris & Kotzalas (*Rolling Bearing Analysis*, 5th ed., 2006, ch. 6)
with the Brewe-Hamrock approximations the bearing model uses.

Limits: the bridging is evaluated at one load per pit and the drop profile is then held as the ball's load varies
(the narrow pit's drop grows with the load, roughly as the contact's approach); the pit's rim is a half-space edge
(the material a real sharp rim misses softens it a little more); no plastic rolling-in of the rim, no debris, no
lubricant; the pit's walls are vertical and its bottom flat.

Units: SI (m, N, Pa).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from bkabem_core.bearing.defects.profiles import ContactGeometry
from bkabem_core.bearing.halfspace import ContactDomainError, HalfSpaceGrid, combined_modulus_pa

__all__ = ["PitContact", "PitProfile", "pit_contact", "check_table", "WIDEST_PER_BALL_DIAMETER"]

#: Widest round pit, per ball diameter: its rim must stay near the bottom of the groove, where the ball's contact
#: is radial (a pit of half the ball's diameter reaches about 30 deg up the groove's side).
WIDEST_PER_BALL_DIAMETER = 0.5
#: Cells per contact semi-axis (or per pit radius, if smaller) of the half-space grid.
_CELLS_PER_SEMI_AXIS = 10
#: Pit positions solved along the rolling direction (centre to the end of the profile).
_POSITIONS = 20
#: Below this ratio of the intact contact's approach to the pit's rigid drop the contact is taken as rigid.
_RIGID_BELOW = 1e-3
_MAX_CELLS = 1 << 18


@dataclass(frozen=True)
class PitProfile:
    """The drop a ball feels from a round pit at one contact, over the arc from the pit's centre.

    Attributes
    ----------
    support_m : float
        Arc from the pit centre beyond which the pit is not felt [m] (its radius plus the contact half-length).
    arc_m, drop_table_m : ndarray
        The drop [m] tabulated over the arc [0, support] [m] (monotone between the solved positions).
    """

    support_m: float
    arc_m: np.ndarray
    drop_table_m: np.ndarray

    @property
    def max_drop_m(self) -> float:
        """The drop at the pit's centre [m]."""
        return float(self.drop_table_m[0])

    def drop_m(self, arc_m):
        """Drop [m] at absolute arcs ``arc_m`` [m] from the pit's centre along the rolling direction."""
        s = np.abs(np.asarray(arc_m, dtype=float))
        return np.where(s < self.support_m, np.interp(s, self.arc_m, self.drop_table_m), 0.0)


@dataclass(frozen=True)
class PitContact:
    """A round pit at one ball-race contact (module docstring), SI.

    Attributes
    ----------
    diameter_m, depth_m : float
        The pit's diameter D and depth h [m].
    rx_m, ry_m : float
        Rolling-direction and transverse effective radii of the contact [m].
    ball_radius_m : float
        r_b [m].
    effective_modulus_pa : float
        ``E' = E / (1 - nu^2)`` [Pa].
    load_n : float
        Ball load at which the bridging is evaluated [N]; 0: a rigid ball.
    """

    diameter_m: float
    depth_m: float
    rx_m: float
    ry_m: float
    ball_radius_m: float
    effective_modulus_pa: float
    load_n: float

    @property
    def radius_m(self) -> float:
        return 0.5 * self.diameter_m

    @property
    def groove_radius_m(self) -> float:
        """The groove's radius across the rolling direction, ``1 / (1/r_b - 1/R_y)`` [m]."""
        return 1.0 / (1.0 / self.ball_radius_m - 1.0 / self.ry_m)

    def gap_m(self, x_m, y_m):
        """Undeformed gap of the intact ball and race [m] at (x along, y across the rolling direction) [m] from the
        point where they touch."""
        rb, rg = self.ball_radius_m, self.groove_radius_m
        y2 = np.asarray(y_m, dtype=float) ** 2
        across = (rb - np.sqrt(rb * rb - y2)) - (rg - np.sqrt(rg * rg - y2))
        return np.asarray(x_m, dtype=float) ** 2 / (2.0 * self.rx_m) + across

    def contact_ellipse_m(self) -> tuple[float, float]:
        """Hertz semi-axes ``(a, b)`` [m] of the intact contact at the load: a across the rolling direction, b along
        it (Brewe-Hamrock, as :class:`~bkabem_core.bearing.deep_groove.HertzContact`)."""
        rx, ry = self.rx_m, self.ry_m
        r = 1.0 / (1.0 / rx + 1.0 / ry)
        k = 1.0339 * (ry / rx) ** 0.6360
        e_bar = 1.0003 + 0.5968 * rx / ry
        c = 6.0 * e_bar * r * max(self.load_n, 0.0) / (math.pi * self.effective_modulus_pa)
        return (c * k * k) ** (1.0 / 3.0), (c / k) ** (1.0 / 3.0)

    def hertz_approach_m(self) -> float:
        """Approach of the intact contact at the load (Brewe-Hamrock) [m]."""
        rx, ry = self.rx_m, self.ry_m
        r = 1.0 / (1.0 / rx + 1.0 / ry)
        k = 1.0339 * (ry / rx) ** 0.6360
        e_bar = 1.0003 + 0.5968 * rx / ry
        f_bar = 1.5277 + 0.6023 * math.log(ry / rx)
        kc = math.pi * k * self.effective_modulus_pa * math.sqrt(r * e_bar / (4.5 * f_bar ** 3))
        return (max(self.load_n, 0.0) / kc) ** (2.0 / 3.0)

    def hertz_load_fraction(self) -> float:
        """Share of the intact contact's load [-] that the Hertz pressure puts over the pit's footprint when the pit
        is centred on the contact (the part of the contact the pit takes away before the contact adjusts).

        With ``x = b r cos t``, ``y = a r sin t`` the elliptic pressure's integral out to ``r`` is ``1 - (1 - r^2)^1.5``
        of the load; the pit reaches ``r_pit(t) = rho / sqrt(b^2 cos^2 t + a^2 sin^2 t)``."""
        a, b = self.contact_ellipse_m()
        if a == 0.0:
            return 1.0
        t = np.linspace(0.0, 2.0 * math.pi, 8193)[:-1]
        r = np.minimum(self.radius_m / np.sqrt((b * np.cos(t)) ** 2 + (a * np.sin(t)) ** 2), 1.0)
        return float(np.mean(1.0 - (1.0 - r * r) ** 1.5))

    def rigid_drop_m(self, arc_m):
        """Drop [m] of a rigid ball whose contact point is at arcs ``arc_m`` [m] from the pit's centre: the smallest
        gap on the pit's rim (where it rests), at most the depth; 0 outside the pit."""
        s = np.abs(np.atleast_1d(np.asarray(arc_m, dtype=float)))
        rho = self.radius_m
        t = np.linspace(0.0, math.pi, 4097)                               # the rim, one side (the gap is even in y)
        rim = self.gap_m(rho * np.cos(t)[None, :] - s[:, None], rho * np.sin(t)[None, :])
        out = np.where(s < rho, np.minimum(rim.min(axis=1), self.depth_m), 0.0)
        return out if np.ndim(arc_m) else float(out[0])

    def profile(self) -> PitProfile:
        """The drop profile over the arc from the pit's centre (cached per pit and contact)."""
        return _profile(self)


def pit_contact(dent, geometry: ContactGeometry, contact: str) -> PitContact:
    """The round pit of ``dent`` (its ``length_m`` is the diameter) at ``contact`` (``"outer"``/``"inner"``) of a
    bearing of this geometry, at the dent's ``bridging_load_n``."""
    return PitContact(float(dent.length_m), float(dent.depth_m), geometry.rx_m(contact), geometry.ry_m(contact),
                      geometry.ball_radius_m, geometry.effective_modulus_pa, float(dent.bridging_load_n))


def check_table(table: dict, bearing: dict) -> tuple[str, str] | None:
    """``(key, reason)`` if a ``[[defects]]`` table of shape ``"round_pit"`` does not fit the case's bearing table
    (None: it fits): narrower than the ball track, and the ball-over-edge profile (its entry and exit are the
    contact's)."""
    widest = WIDEST_PER_BALL_DIAMETER * bearing["ball_diameter_m"]
    if table["length_m"] >= widest:
        return "length_m", (f"a round pit's diameter must be less than half the ball diameter ({widest * 1e3:.2f} mm): "
                            f"a wider one is wider than the ball track at the bottom of the groove, outside this "
                            f"model (got {table['length_m'] * 1e3:g} mm)")
    if table["edge"] != "ball":
        return "edge", (f"must be 'ball' for a round pit: its entry and exit follow from its contact (got "
                        f"{table['edge']!r}; 'cubic' is for a slot)")
    return None


# --------------------------------------------------------------------------- the half-space solution
@functools.lru_cache(maxsize=256)
def _profile(pit: PitContact) -> PitProfile:
    rho = pit.radius_m
    if pit.depth_m <= 0.0 or rho <= 0.0:
        return PitProfile(0.0, np.array([0.0, 1e-300]), np.zeros(2))
    rigid_centre = float(pit.rigid_drop_m(0.0))
    if pit.load_n <= 0.0 or pit.hertz_approach_m() < _RIGID_BELOW * rigid_centre:
        s = rho * np.linspace(0.0, 1.0, 257)
        return _tabulate(rho, s, pit.rigid_drop_m(s))
    a, b = pit.contact_ellipse_m()
    dx = min(b, rho) / _CELLS_PER_SEMI_AXIS
    dy = min(a, rho) / _CELLS_PER_SEMI_AXIS
    last = math.ceil((rho + b) / dx) + 1                      # the pit's rim a contact half-length and a cell away
    steps = np.unique(np.round(np.linspace(0.0, last, _POSITIONS)).astype(int))
    half_x, half_y = _reach_m(pit, steps * dx, pit.hertz_approach_m())
    grow = 1.25
    for _ in range(6):
        try:
            return _solve_profile(pit, dx, dy, grow * half_x + 2 * dx, grow * half_y + 2 * dy, steps)
        except ContactDomainError:
            grow *= 1.5
    raise RuntimeError(f"round pit of {pit.diameter_m * 1e3:g} mm: its contact does not fit a grid of "
                       f"{_MAX_CELLS} cells")


def _reach_m(pit: PitContact, arcs_m: np.ndarray, margin_m: float) -> tuple[float, float]:
    """Half-widths (x, y) [m] of the region a rigid ball could touch at any of the arcs: where the gap is within
    ``margin_m`` of its rigid drop there, outside the pit (the elastic contact stays inside it for a margin of the
    intact contact's approach: Hertz's ellipse is 1/sqrt(2) of the rigid overlap at its approach)."""
    reach = float(pit.rigid_drop_m(0.0)) + margin_m
    x = np.linspace(-1.0, 1.0, 401) * math.sqrt(2.0 * pit.rx_m * reach)
    y = np.linspace(0.0, 1.0, 401) * min(math.sqrt(2.0 * pit.ry_m * reach), 0.95 * pit.ball_radius_m)
    gap = pit.gap_m(x[:, None], y[None, :])
    touch = np.zeros(gap.shape, dtype=bool)
    for s, drop in zip(arcs_m, pit.rigid_drop_m(arcs_m)):
        touch |= (gap <= drop + margin_m) & ((x[:, None] + s) ** 2 + y[None, :] ** 2 >= pit.radius_m ** 2)
    return float(np.abs(x[touch.any(axis=1)]).max()), float(y[touch.any(axis=0)].max())


def _solve_profile(pit: PitContact, dx: float, dy: float, half_x: float, half_y: float, steps: np.ndarray):
    """The half-space profile on a grid of these half-widths [m], the ball's contact at ``steps`` cells from the
    pit's centre."""
    # here, not at import: most runs never solve a pit, and every process starts faster without it
    from scipy import fft

    rho = pit.radius_m
    half_y = min(half_y, 0.95 * pit.ball_radius_m)
    nx, ny = 2 * math.ceil(half_x / dx), 2 * math.ceil(half_y / dy)
    if nx * ny > _MAX_CELLS:                                  # a contact far smaller than the pit: coarser cells
        raise RuntimeError(f"round pit of {pit.diameter_m * 1e3:g} mm at {pit.load_n:g} N: its contact needs "
                           f"{nx * ny} cells (more than {_MAX_CELLS})")
    nx, ny = fft.next_fast_len(nx) // 2 * 2, fft.next_fast_len(ny) // 2 * 2    # even, and twice fast for the FFT
    grid = HalfSpaceGrid(nx, ny, dx, dy, combined_modulus_pa(pit.effective_modulus_pa))
    # cell centres relative to the contact point; the ball sits at whole cells from the pit's centre, so the pit
    # covers the same cells of a grid fixed to it at every position (no staircase jitter along the profile)
    x = (np.arange(nx) - nx / 2 + 0.5) * dx
    y = (np.arange(ny) - ny / 2 + 0.5) * dy
    gap = pit.gap_m(x[:, None], y[None, :])
    intact = grid.solve(gap, pit.load_n)
    drops, guess = [], intact.pressure_pa
    for k in steps:
        inside = (x[:, None] + k * dx) ** 2 + y[None, :] ** 2 < rho * rho
        sol = grid.solve(gap + pit.depth_m * inside, pit.load_n, guess)
        guess = sol.pressure_pa
        drops.append(sol.approach_m - intact.approach_m)
    # the pit only takes support away: a negative difference is the solver's round-off
    drops = np.maximum(np.array(drops), 0.0)
    return _tabulate(float(steps[-1] * dx), steps * dx, drops)


def _tabulate(support_m: float, arc_m: np.ndarray, drop_m: np.ndarray) -> PitProfile:
    """A monotone table (PCHIP through the drops at the arcs, the last one at the support) of 513 points over
    [0, support]."""
    # here, not at import (scipy.interpolate pulls in scipy.optimize)
    from scipy.interpolate import PchipInterpolator

    s = np.asarray(arc_m, dtype=float)
    h = np.asarray(drop_m, dtype=float)
    if s[-1] < support_m:
        s, h = np.r_[s, support_m], np.r_[h, 0.0]
    fine = np.linspace(0.0, support_m, 513)
    table = PchipInterpolator(s, h)(fine)                     # shape-preserving: no overshoot, no negative drop
    return PitProfile(float(support_m), fine, table)
