"""Deep-groove ball bearing: geometry, kinematics, Hertz contact, clearance, axial load, dent and ball forces.

The force model is the Sopanen-Mikkola deep-groove ball bearing model (paper Eqs. 1, 3, 4) with its axial
degree of freedom: every ball's contact line follows from the positions of the two groove-curvature centres, so
an axial load takes up the radial play and sets a loaded contact angle per ball (Sopanen & Mikkola 2003, Part 1;
Harris & Kotzalas, *Rolling Bearing Analysis*, ch. 7). Everything is SI: m, N, rad, s.

Plane of the bearing: x horizontal, y vertical (up), z axial. Ball attitude angles beta are measured from +x
towards +y, so -pi/2 is the bottom of the bearing. ``e = (e_x, e_y, e_z)`` is the displacement of the
inner-race centre (rotor) relative to the outer-race centre (housing); the bearing force ``(F_x, F_y, F_z)`` is
the force the bearing exerts on the shaft (Eq. 4, negative sums).

Per ball i (nominal contact angle alpha_0, groove-centre distance ``A_0 = (f_i + f_o - 1) d``)::

    A_r = A_0 cos(alpha_0) - c_d / 2 + e_x cos(beta_i) + e_y sin(beta_i) - h_defect(beta_i)    (radial)
    A_a = A_0 sin(alpha_0) + e_z                                                              (axial)
    A   = sqrt(A_r^2 + A_a^2),   phi_i = atan2(A_a, A_r)      (loaded contact angle)
    delta_i = A - A_0 + h_film,   Q_i = K_tot max(delta_i, 0)^1.5

and the force on the shaft is ``-sum Q_i (cos(phi_i) cos(beta_i), cos(phi_i) sin(beta_i), sin(phi_i))``. A dent
lowers the race under the ball by ``h_defect`` (the radial drop of the ball centre, :class:`Dent`).

The lateral models of BKA-BEM (4-DOF, quasi-static excitation, FE linearisation, TDSM) hold the axial
displacement at its static value ``e_z0`` under the case's axial load (docs/method.md: the 82 kg rotor's axial
inertia blocks axial motion above its ~100 Hz axial resonance, and the paper's linearisation takes partial
derivatives at held coordinates); with ``e_z = 0`` and no axial load the model is the radial one.

All force routines are vectorised over time samples: ``e_x``, ``e_y`` and ``cage_angle_rad`` broadcast
against each other, and a trailing axis of length ``n_balls`` is added internally.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass

import numpy as np

from bkabem_core.bearing.defects.base import DefectProfile, DefectSet, Dent
from bkabem_core.bearing.defects.profiles import ContactGeometry, wrap_to_pi  # noqa: F401  (wrap_to_pi: for users)
from bkabem_core.bearing.defects.registry import kind
from bkabem_core.bearing.statics import BearingState, BearingStatics

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class BearingGeometry:
    """Geometry and material of a deep-groove ball bearing (SI units).

    Attributes
    ----------
    designation : str
        Catalogue designation, e.g. ``"6010"``.
    ball_diameter_m, pitch_diameter_m : float
        Ball diameter d and pitch diameter d_m [m].
    n_balls : int
        Number of balls z [-].
    diametral_clearance_m : float
        Diametral clearance c_d [m] (radial play = c_d / 2).
    inner_conformity, outer_conformity : float
        Groove radius divided by the ball diameter, f_i and f_o [-] (> 0.5).
    contact_angle_rad : float
        Nominal contact angle alpha_0 [rad]; 0 for a radially loaded deep-groove bearing.
    youngs_modulus_pa, poisson_ratio : float
        Elastic constants of balls and races [Pa], [-].
    bore_diameter_m, outer_diameter_m : float
        Envelope dimensions [m] (informational).
    static_load_rating_n : float
        C_0 [N] (informational).
    pressure_viscosity_m2_n, dynamic_viscosity_pa_s : float
        Lubricant pressure-viscosity coefficient [m^2/N] and viscosity at ambient pressure [Pa s] (EHL film).
    first_ball_angle_rad : float
        Attitude angle of ball 1 when the cage angle is zero [rad].
    """

    designation: str
    ball_diameter_m: float
    pitch_diameter_m: float
    n_balls: int
    diametral_clearance_m: float = 0.0
    inner_conformity: float = 0.52
    outer_conformity: float = 0.52
    contact_angle_rad: float = 0.0
    youngs_modulus_pa: float = 206.0e9
    poisson_ratio: float = 0.3
    bore_diameter_m: float = float("nan")
    outer_diameter_m: float = float("nan")
    static_load_rating_n: float = float("nan")
    pressure_viscosity_m2_n: float = 2.3e-8
    dynamic_viscosity_pa_s: float = 0.04
    first_ball_angle_rad: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class FaultFrequencies:
    """Bearing defect frequencies [Hz] (or multipliers of the shaft frequency when ``per_shaft_hz``).

    Attributes
    ----------
    ftf : float
        Fundamental train (cage) frequency.
    bpfo : float
        Ball-pass frequency, outer race.
    bpfi : float
        Ball-pass frequency, inner race.
    bsf : float
        Ball spin frequency (one revolution of a ball about its own axis; a ball defect strikes at 2 x BSF).
    """

    ftf: float
    bpfo: float
    bpfi: float
    bsf: float

    def at_speed(self, shaft_speed_hz: float) -> "FaultFrequencies":
        """Multipliers scaled to a shaft speed [Hz]."""
        s = float(shaft_speed_hz)
        return FaultFrequencies(self.ftf * s, self.bpfo * s, self.bpfi * s, self.bsf * s)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class HertzContact:
    """Hertz point-contact constants of one bearing (Brewe-Hamrock approximations), SI.

    Attributes
    ----------
    k_inner_n_m15, k_outer_n_m15 : float
        Contact constants of the inner and outer race contacts [N/m^1.5].
    k_total_n_m15 : float
        Both contacts in series, ``K_tot = (K_i^(-2/3) + K_o^(-2/3))^(-3/2)`` [N/m^1.5] (Eq. 3).
    rx_inner_m, rx_outer_m, ry_inner_m, ry_outer_m : float
        Effective radii of curvature in the rolling and transverse directions [m].
    ellipticity_inner, ellipticity_outer : float
        Ellipticity parameters k_e [-].
    effective_modulus_pa : float
        E' = E / (1 - nu^2) for equal materials [Pa].
    """

    k_inner_n_m15: float
    k_outer_n_m15: float
    k_total_n_m15: float
    rx_inner_m: float
    rx_outer_m: float
    ry_inner_m: float
    ry_outer_m: float
    ellipticity_inner: float
    ellipticity_outer: float
    effective_modulus_pa: float

    def to_dict(self) -> dict:
        return asdict(self)


class Bearing(BearingStatics):
    """A deep-groove ball bearing, healthy or with defects (:mod:`bkabem_core.bearing.defects`).

    Its statics (equilibrium under a load, ball loads, linearisation) are :class:`BearingStatics`
    (:mod:`bkabem_core.bearing.statics`).

    Parameters
    ----------
    geometry : BearingGeometry
    dent : Dent or None
        One defect this bearing carries (``None`` for a healthy bearing); the form of the physics issue.
    defects : sequence of Dent, optional
        Every defect it carries (outer race, inner race, ball; several at once). Give ``dent`` or ``defects``.

    Attributes
    ----------
    defects : tuple of Dent
        As given (depth-0 ones included).
    defect_set : DefectSet
        The active ones with this bearing's geometry: the drop every ball feels at given phases.
    dent : Dent or None
        The first defect (the single-defect interface: :meth:`dent_depth_m`, :attr:`dent_half_angle_rad`, ...).
    """

    def __init__(self, geometry: BearingGeometry, dent: Dent | None = None, defects=None):
        if dent is not None and defects:
            raise ValueError("Bearing: give dent or defects, not both")
        self.geometry = geometry
        self.defects = tuple(defects) if defects else ((dent,) if dent is not None else ())
        self.dent = self.defects[0] if self.defects else None
        g = geometry
        d, dm, cd, a0 = g.ball_diameter_m, g.pitch_diameter_m, g.diametral_clearance_m, g.contact_angle_rad
        # Race radii in the rolling direction (Sopanen/LUT; clearance and contact angle included) [m]
        self.outer_race_radius_m = (dm + (d + cd / 2.0) * math.cos(a0)) / (2.0 * math.cos(a0))
        self.inner_race_radius_m = (dm - (d + cd / 2.0) * math.cos(a0)) / (2.0 * math.cos(a0))
        #: distance between the two groove-curvature centres when the ball just touches both races [m]
        self.groove_centre_distance_m = (g.inner_conformity + g.outer_conformity - 1.0) * d
        self._a0 = self.groove_centre_distance_m
        self._ar0 = self._a0 * math.cos(a0) - 0.5 * cd          # A_r at e = 0
        self._aa0 = self._a0 * math.sin(a0)                      # A_a at e = 0
        self.contact = self._hertz_contact()
        self._k = self.contact.k_total_n_m15
        self._ball_offsets = TWO_PI * np.arange(g.n_balls) / g.n_balls + g.first_ball_angle_rad
        self._rb = 0.5 * d
        c = self.contact
        self.contact_geometry = ContactGeometry(self.outer_race_radius_m, self.inner_race_radius_m, self._rb,
                                                c.rx_outer_m, c.rx_inner_m, g.n_balls, c.ry_outer_m, c.ry_inner_m,
                                                c.effective_modulus_pa)
        self.defect_set = DefectSet(self.defects, self.contact_geometry)
        self._profile = DefectProfile(self.dent, self.contact_geometry) if self.dent is not None else None
        if self._profile is not None:
            self._dent_half_angle = self._profile.half_angle_rad
            self._dent_edge = self._profile.edge_rad
            self._dent_depth_eff = self._profile.depth_eff_m
        else:
            self._dent_half_angle = self._dent_edge = self._dent_depth_eff = 0.0

    @property
    def has_defect(self) -> bool:
        """Whether any ball feels a defect (some defect with depth > 0)."""
        return bool(self.defect_set)

    @property
    def periodic_defects(self) -> tuple:
        """Its defects whose kinds repeat with the ball pass (BPFO orders: a pit in the outer race), depth-0 ones
        included."""
        return tuple(d for d in self.defects if kind(d.race).periodic)

    @property
    def moving_defects(self) -> tuple:
        """Its other defects (phases of their own: inner race, ball), depth-0 ones included."""
        return tuple(d for d in self.defects if not kind(d.race).periodic)

    # ------------------------------------------------------------------ kinematics
    def fault_multipliers(self) -> FaultFrequencies:
        """Defect frequencies per 1 Hz of shaft speed (stationary outer race, rolling without slip).

        ``FTF = (1 - g)/2``, ``BPFO = z (1 - g)/2``, ``BPFI = z (1 + g)/2``, ``BSF = d_m/(2 d) (1 - g^2)`` with
        ``g = d cos(alpha) / d_m`` at the nominal contact angle alpha (docs/method.md: the loaded contact angle
        under an axial load would move them by about 1 %; every model of bkabem uses these same ratios).
        """
        g = self.geometry
        r = g.ball_diameter_m * math.cos(g.contact_angle_rad) / g.pitch_diameter_m
        z = g.n_balls
        return FaultFrequencies(
            ftf=0.5 * (1.0 - r),
            bpfo=0.5 * z * (1.0 - r),
            bpfi=0.5 * z * (1.0 + r),
            bsf=g.pitch_diameter_m / (2.0 * g.ball_diameter_m) * (1.0 - r * r),
        )

    def fault_frequencies_hz(self, shaft_speed_hz: float) -> FaultFrequencies:
        """Defect frequencies [Hz] at a shaft speed [Hz]."""
        return self.fault_multipliers().at_speed(shaft_speed_hz)

    def ball_angles_rad(self, cage_angle_rad):
        """Attitude angles beta_i [rad] of all balls, shape ``cage_angle.shape + (n_balls,)``.

        ``beta_i = first_ball_angle + 2 pi (i-1)/z + cage_angle``. The cage angle is wrapped to [0, 2 pi)
        first, so long runs keep full precision.
        """
        c = np.remainder(np.asarray(cage_angle_rad, dtype=float), TWO_PI)
        return c[..., None] + self._ball_offsets

    # ------------------------------------------------------------------ Hertz
    def _hertz_contact(self) -> HertzContact:
        g = self.geometry
        d = g.ball_diameter_m
        e_eff = g.youngs_modulus_pa / (1.0 - g.poisson_ratio**2)

        def one(race_radius_signed: float, conformity: float):
            rx = 1.0 / (2.0 / d + 1.0 / race_radius_signed)
            ry = 1.0 / (2.0 / d - 1.0 / (conformity * d))
            r = 1.0 / (1.0 / rx + 1.0 / ry)
            ke = 1.0339 * (ry / rx) ** 0.6360
            e_bar = 1.0003 + 0.5968 * rx / ry
            f_bar = 1.5277 + 0.6023 * math.log(ry / rx)
            kc = math.pi * ke * e_eff * math.sqrt(r * e_bar / (4.5 * f_bar**3))
            return kc, rx, ry, ke

        k_in, rx_in, ry_in, ke_in = one(+self.inner_race_radius_m, g.inner_conformity)
        k_out, rx_out, ry_out, ke_out = one(-self.outer_race_radius_m, g.outer_conformity)
        k_tot = (k_in ** (-2.0 / 3.0) + k_out ** (-2.0 / 3.0)) ** (-1.5)
        return HertzContact(k_in, k_out, k_tot, rx_in, rx_out, ry_in, ry_out, ke_in, ke_out, e_eff)

    @property
    def contact_constant_n_m15(self) -> float:
        """Total Hertz contact constant K_tot [N/m^1.5] (inner and outer contact in series)."""
        return self._k

    # ------------------------------------------------------------------ dent
    @property
    def dent_half_angle_rad(self) -> float:
        """Half of the angle the dent subtends at the outer-race contact radius [rad]."""
        return self._dent_half_angle

    @property
    def dent_geometric_depth_limit_m(self) -> float:
        """Deepest a ball can sink into a dent of this length: its sagitta over the pit [m].

        ``r_b - sqrt(r_b^2 - (l/2)^2)`` on a flat race (the ``"cubic"`` profile's limit for the outer race; the
        ``"ball"`` profile follows the ball over the edges in the curved race and needs no separate limit). 116 um
        for the paper's 2 mm dent and 8.73 mm balls.
        """
        if self.dent is None:
            return 0.0
        rb = self._rb
        half = min(self.dent.length_m / 2.0, rb)
        return rb - math.sqrt(rb * rb - half * half)

    @property
    def dent_effective_depth_m(self) -> float:
        """Largest radial drop of a ball centre in the (first) dent (at its centre) [m]."""
        return self._dent_depth_eff

    @property
    def dent_entry_ramp_rad(self) -> float:
        """Angle over which a ball sinks from the race to the full depth at each edge [rad] (0: sharp/no dent).

        ``"ball"``: from the ball-over-edge geometry (the angle at which the drop reaches the depth, or the
        half-angle when the pit is too short for that); ``"cubic"``: ``edge_fraction`` x the half-angle. On the
        defect's own surface (the ball for a ball defect).
        """
        return 0.0 if self._profile is None else self._profile.entry_ramp_rad()

    def shortest_defect_event_s(self, shaft_speed_hz: float) -> float:
        """Shortest time a ball takes over an entry ramp of any of its defects at a shaft speed [s] (inf: none).

        The rate of each kind's relative motion (its ``surface_rate_per_hz``: outer race the cage, inner race shaft
        minus cage, ball the spin); the time-domain model's step must resolve it."""
        fm = self.fault_multipliers()
        out = math.inf
        for p in self.defect_set.profiles:
            ramp = p.entry_ramp_rad()
            edge = ramp if ramp > 0.0 else 0.25 * p.half_angle_rad
            out = min(out, edge / (TWO_PI * p.kind.surface_rate_per_hz(fm) * abs(shaft_speed_hz)))
        return out

    def dent_depth_m(self, ball_angle_rad, shaft_angle_rad=0.0, spin_angle_rad=0.0):
        """Radial drop of the ball centre [m] at ball attitude angles [rad] (paper Eqs. 1-2; :class:`Dent`).

        Zero outside the defects; the wrap of ``beta - phi_d`` to [-pi, pi) handles the ``n 2 pi`` of Eq. (2)
        exactly. For race defects the drop at these angles; with ball defects too, ``ball_angle_rad`` must be the
        angles of all balls (trailing axis of length z). Shaft and spin angle [rad] place inner-race and ball
        defects (:meth:`DefectSet.drop_m`).
        """
        beta = np.asarray(ball_angle_rad, dtype=float)
        if not self.defect_set:
            return np.zeros(beta.shape)
        if self.defect_set.per_ball:
            return self.defect_set.drop_m(beta, shaft_angle_rad, spin_angle_rad)
        return self.defect_set.drop_m(beta[..., None], shaft_angle_rad, spin_angle_rad)[..., 0]

    def peak_ball_load_n(self, state: BearingState, n_angles: int = 64) -> float:
        """Largest ball load [N] at the displacement of a static ``state`` over one ball pitch of cage angle (defects
        ignored)."""
        e = state.displacement_m
        theta = np.arange(n_angles) * (TWO_PI / self.geometry.n_balls / n_angles)
        return float(np.max(self.ball_loads_n(e[0], e[1], theta, with_dent=False, e_z_m=e[2])))

    def with_bridging_load(self, load_n: float) -> "Bearing":
        """This bearing with its round pits bridged at the ball load ``load_n`` [N] (``Dent.bridging_load_n``: the
        contact ellipse at that load decides how far a ball sinks into a pit narrower than it,
        :mod:`bkabem_core.bearing.defects.round_pit`); other defects as they are. The models of a machine evaluate
        every round pit at its bearing's largest static ball load (:meth:`peak_ball_load_n`)."""
        if not any(d.shape == "round_pit" for d in self.defects):
            return self
        load = float(load_n)
        return Bearing(self.geometry, defects=[dataclasses.replace(d, bridging_load_n=load)
                                               if d.shape == "round_pit" else d for d in self.defects])

    def dent_drop_m(self, rel_angle_rad):
        """Radial drop [m] at an absolute angular distance ``rel_angle_rad`` [rad] from the (first) dent centre."""
        rel = np.asarray(rel_angle_rad, dtype=float)
        if self._profile is None or self._dent_depth_eff == 0.0:
            return np.zeros(rel.shape)
        return self._profile.drop_m(rel)

    # ------------------------------------------------------------------ EHL
    def ehl_film_thickness_m(self, shaft_speed_hz: float, radial_load_n: float) -> float:
        """Total (inner + outer) Hamrock-Dowson central film thickness [m].

        Uses the Stribeck maximum ball load ``Q = 5 F_r / z`` and the mean entrainment speed
        ``u = (d_m^2 - d^2) / (4 d_m) |omega|``. The film acts as a negative clearance.
        """
        g = self.geometry
        if shaft_speed_hz == 0.0 or radial_load_n <= 0.0:
            return 0.0
        c = self.contact
        omega = TWO_PI * abs(shaft_speed_hz)
        u = (g.pitch_diameter_m**2 - g.ball_diameter_m**2) / (4.0 * g.pitch_diameter_m) * omega
        q = 5.0 * radial_load_n / g.n_balls
        big_g = g.pressure_viscosity_m2_n * c.effective_modulus_pa
        h = 0.0
        for rx, ke in ((c.rx_inner_m, c.ellipticity_inner), (c.rx_outer_m, c.ellipticity_outer)):
            big_u = g.dynamic_viscosity_pa_s * u / (c.effective_modulus_pa * rx)
            big_w = q / (c.effective_modulus_pa * rx * rx)
            h += 2.69 * rx * big_u**0.67 * big_g**0.53 * big_w**-0.067 * (1.0 - 0.61 * math.exp(-0.73 * ke))
        return h

    # ------------------------------------------------------------------ forces
    def _geometry(self, e_x_m, e_y_m, cage_angle_rad, e_z_m, with_dent, shaft_angle_rad=0.0, spin_angle_rad=0.0):
        """Per ball: direction cosines, radial and axial groove-centre offsets A_r, A_a [m]."""
        beta = self.ball_angles_rad(cage_angle_rad)
        cb, sb = np.cos(beta), np.sin(beta)
        ex = np.asarray(e_x_m, dtype=float)[..., None]
        ey = np.asarray(e_y_m, dtype=float)[..., None]
        ar = self._ar0 + ex * cb + ey * sb
        if with_dent and self.defect_set:
            ar = ar - self.defect_set.drop_m(beta, shaft_angle_rad, spin_angle_rad)
        aa = self._aa0 + np.asarray(e_z_m, dtype=float)[..., None] + np.zeros_like(ar)
        return cb, sb, ar, aa

    def ball_deformations_m(self, e_x_m, e_y_m, cage_angle_rad, film_m: float = 0.0, with_dent: bool = True,
                            e_z_m=0.0, shaft_angle_rad=0.0, spin_angle_rad=0.0):
        """Total elastic deformation of every ball [m] (Eq. 1), negative = no contact.

        ``delta_i = sqrt(A_r^2 + A_a^2) - A_0 + h_film`` (module docstring); with no axial offset this is
        ``e_x cos beta_i + e_y sin beta_i - c_d/2 + h_film - h_dent(beta_i)``. Shape:
        ``broadcast(e_x, e_y, cage_angle, e_z).shape + (n_balls,)``.
        """
        _, _, ar, aa = self._geometry(e_x_m, e_y_m, cage_angle_rad, e_z_m, with_dent, shaft_angle_rad,
                                      spin_angle_rad)
        return np.hypot(ar, aa) - self._a0 + film_m

    def forces_n(self, e_x_m, e_y_m, cage_angle_rad, film_m: float = 0.0, with_stiffness: bool = False,
                 with_dent: bool = True, e_z_m=0.0, shaft_angle_rad=0.0, spin_angle_rad=0.0):
        """Lateral bearing force on the shaft [N] (Eqs. 3-4), optionally with its stiffness ``K = -dF/de`` [N/m].

        Parameters
        ----------
        e_x_m, e_y_m : array_like
            Inner-race centre relative to the outer-race centre [m].
        cage_angle_rad : array_like
            Cage angle [rad] (ball i at ``first_ball_angle + 2 pi (i-1)/z + cage_angle``).
        film_m : float
            EHL film thickness added to every ball's deformation [m].
        with_stiffness : bool
            Also return ``(k_xx, k_xy, k_yy)`` [N/m], the lateral tangent at held ``e_z`` (symmetric).
        with_dent : bool
            False: the bearing as if it had no dent (static equilibrium, linearisation).
        e_z_m : array_like
            Axial displacement of the inner race [m], held (e.g. the static value under the axial load).
        shaft_angle_rad, spin_angle_rad : array_like
            Shaft angle and spin angle of the balls about their own axes [rad] (broadcast with the cage angle):
            where inner-race and ball defects are (:meth:`DefectSet.drop_m`).

        Returns
        -------
        f_x, f_y : ndarray
            Force components on the shaft [N].
        (k_xx, k_xy, k_yy) : tuple of ndarray, only with ``with_stiffness``.
        """
        cb, sb, ar, aa = self._geometry(e_x_m, e_y_m, cage_angle_rad, e_z_m, with_dent, shaft_angle_rad,
                                        spin_angle_rad)
        a = np.hypot(ar, aa)
        delta = np.maximum(a - self._a0 + film_m, 0.0)
        root = np.sqrt(delta)
        q = self._k * delta * root                      # ball loads [N]
        with np.errstate(invalid="ignore", divide="ignore"):
            c_phi = np.where(a > 0.0, ar / a, 1.0)      # cos of the loaded contact angle
        qr = q * c_phi
        fx = -np.sum(qr * cb, axis=-1)
        fy = -np.sum(qr * sb, axis=-1)
        if not with_stiffness:
            return fx, fy
        # d(Q cos phi t)/de_lat = [Q' cos^2 phi + (Q / A) sin^2 phi] t t^T    (t = (cos beta, sin beta))
        with np.errstate(invalid="ignore", divide="ignore"):
            w = 1.5 * self._k * root * c_phi * c_phi + np.where(a > 0.0, q * (1.0 - c_phi * c_phi) / a, 0.0)
        kxx = np.sum(w * cb * cb, axis=-1)
        kxy = np.sum(w * cb * sb, axis=-1)
        kyy = np.sum(w * sb * sb, axis=-1)
        return fx, fy, (kxx, kxy, kyy)

    def forces_3d_n(self, e_m, cage_angle_rad: float = 0.0, film_m: float = 0.0, with_dent: bool = False):
        """Force ``(F_x, F_y, F_z)`` on the shaft [N] and its 3 x 3 stiffness ``-dF/de`` [N/m] at one state.

        ``K = sum_i [Q_i' n_i n_i^T + (Q_i / A_i)(P_i - n_i n_i^T)]`` with the contact normal
        ``n_i = (cos phi cos beta, cos phi sin beta, sin phi)`` and ``P_i`` the projector on the plane of ball i.
        """
        e = np.asarray(e_m, dtype=float)
        cb, sb, ar, aa = self._geometry(e[0], e[1], cage_angle_rad, e[2], with_dent)
        a = np.hypot(ar, aa)
        delta = np.maximum(a - self._a0 + film_m, 0.0)
        q = self._k * delta ** 1.5
        dq = 1.5 * self._k * np.sqrt(delta)
        n = np.stack([ar / a * cb, ar / a * sb, aa / a], axis=-1)              # (z, 3)
        t = np.stack([cb, sb, np.zeros_like(cb)], axis=-1)
        ez = np.array([0.0, 0.0, 1.0])
        proj = t[:, :, None] * t[:, None, :] + ez[None, :, None] * ez[None, None, :]
        nn = n[:, :, None] * n[:, None, :]
        k = np.sum(dq[:, None, None] * nn + (q / a)[:, None, None] * (proj - nn), axis=0)
        return -np.sum(q[:, None] * n, axis=0), k

    def ball_loads_n(self, e_x_m, e_y_m, cage_angle_rad, film_m: float = 0.0, with_dent: bool = True, e_z_m=0.0):
        """Load on every ball [N], ``K_tot max(delta, 0)^1.5`` (Eq. 3)."""
        delta = self.ball_deformations_m(e_x_m, e_y_m, cage_angle_rad, film_m, with_dent, e_z_m)
        return self._k * np.maximum(delta, 0.0) ** 1.5

    def contact_angles_rad(self, e_x_m, e_y_m, cage_angle_rad, e_z_m=0.0, with_dent: bool = True):
        """Loaded contact angle ``phi_i = atan2(A_a, A_r)`` of every ball [rad]."""
        _, _, ar, aa = self._geometry(e_x_m, e_y_m, cage_angle_rad, e_z_m, with_dent)
        return np.arctan2(aa, ar)
