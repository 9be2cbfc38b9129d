"""Deep-groove ball bearing: geometry, kinematics, Hertz contact, clearance, dent and ball forces.

The force model is the Sopanen-Mikkola deep-groove ball bearing model restricted to the radial plane (the
4-DOF/lateral form used by BKA-BEM): paper Eqs. (1), (3) and (4). Everything is SI: m, N, rad, s.

Plane of the bearing: x horizontal, y vertical (up). Ball attitude angles beta are measured from +x towards +y,
so -pi/2 is the bottom of the bearing. ``e = (e_x, e_y)`` is the displacement of the inner-race centre (rotor)
relative to the outer-race centre (housing); the bearing force ``(F_x, F_y)`` is the force the bearing exerts
on the shaft (Eq. 4, negative sums).

All force routines are vectorised over time samples: ``e_x``, ``e_y`` and ``cage_angle_rad`` broadcast
against each other, and a trailing axis of length ``n_balls`` is added internally.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

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
class Dent:
    """Localized outer-race defect (dent), paper Eqs. (1)-(2).

    Inside the dent a ball's total deformation is reduced by the dent depth; the edges are smoothed with the
    ADAMS cubic ``STEP`` over ``edge_fraction`` of the dent half-angle, so that the force stays C1 in time.

    Attributes
    ----------
    length_m : float
        Dent length along the rolling direction [m].
    depth_m : float
        Dent depth (the paper's "height") [m].
    angle_rad : float
        Position angle of the dent centre in the bearing plane [rad], from +x towards +y.
    edge_fraction : float
        Width of each smoothed edge as a fraction of the dent half-angle [-], in [0, 1]. 0 = sharp edges.
    bearing : str
        ``"de"`` or ``"nde"``: which bearing of the machine carries the dent.
    race : str
        Only ``"outer"`` is modelled.
    """

    length_m: float
    depth_m: float
    angle_rad: float
    edge_fraction: float = 0.1
    bearing: str = "de"
    race: str = "outer"

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


@dataclass(frozen=True)
class BearingLinearisation:
    """Bearing stiffness and damping linearised at a static equilibrium.

    Attributes
    ----------
    displacement_m : ndarray (2,)
        Equilibrium displacement of the inner race relative to the outer race (e_x, e_y) [m].
    stiffness_n_m : ndarray (2, 2)
        ``K = -dF/de`` [N/m], rows/columns (x, y).
    damping_n_s_m : ndarray (2, 2)
        ``C = damping_ratio_s * K`` [N s/m].
    stiffness_horizontal_n_m, stiffness_vertical_n_m : float
        Diagonal terms K_xx, K_yy [N/m].
    damping_horizontal_n_s_m, damping_vertical_n_s_m : float
        Diagonal terms C_xx, C_yy [N s/m].
    max_ball_load_n : float
        Largest ball load at the equilibrium [N].
    """

    displacement_m: np.ndarray
    stiffness_n_m: np.ndarray
    damping_n_s_m: np.ndarray
    max_ball_load_n: float
    stiffness_horizontal_n_m: float = field(init=False)
    stiffness_vertical_n_m: float = field(init=False)
    damping_horizontal_n_s_m: float = field(init=False)
    damping_vertical_n_s_m: float = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "stiffness_horizontal_n_m", float(self.stiffness_n_m[0, 0]))
        object.__setattr__(self, "stiffness_vertical_n_m", float(self.stiffness_n_m[1, 1]))
        object.__setattr__(self, "damping_horizontal_n_s_m", float(self.damping_n_s_m[0, 0]))
        object.__setattr__(self, "damping_vertical_n_s_m", float(self.damping_n_s_m[1, 1]))

    def to_dict(self) -> dict:
        return {
            "displacement_m": self.displacement_m.tolist(),
            "stiffness_n_m": self.stiffness_n_m.tolist(),
            "damping_n_s_m": self.damping_n_s_m.tolist(),
            "max_ball_load_n": self.max_ball_load_n,
        }


class Bearing:
    """A deep-groove ball bearing with an optional outer-race dent.

    Parameters
    ----------
    geometry : BearingGeometry
    dent : Dent or None
        The dent this bearing carries (``None`` for a healthy bearing).
    """

    #: Damping-to-stiffness ratio of the linearised bearing [s] (Kraemer; paper Table 1 implies 2.5e-5 s).
    DEFAULT_DAMPING_RATIO_S = 2.5e-5

    def __init__(self, geometry: BearingGeometry, dent: Dent | None = None):
        self.geometry = geometry
        self.dent = dent
        g = geometry
        d, dm, cd, a0 = g.ball_diameter_m, g.pitch_diameter_m, g.diametral_clearance_m, g.contact_angle_rad
        # Race radii in the rolling direction (Sopanen/LUT; clearance and contact angle included) [m]
        self.outer_race_radius_m = (dm + (d + cd / 2.0) * math.cos(a0)) / (2.0 * math.cos(a0))
        self.inner_race_radius_m = (dm - (d + cd / 2.0) * math.cos(a0)) / (2.0 * math.cos(a0))
        self.contact = self._hertz_contact()
        self._k = self.contact.k_total_n_m15
        self._ball_offsets = TWO_PI * np.arange(g.n_balls) / g.n_balls + g.first_ball_angle_rad
        self._cos_a0 = math.cos(a0)
        if dent is not None:
            self._dent_half_angle = dent.length_m / (2.0 * self.outer_race_radius_m)
            self._dent_edge = dent.edge_fraction * self._dent_half_angle
            self._dent_depth_eff = min(dent.depth_m, self.dent_geometric_depth_limit_m)
        else:
            self._dent_half_angle = self._dent_edge = self._dent_depth_eff = 0.0

    # ------------------------------------------------------------------ kinematics
    def fault_multipliers(self) -> FaultFrequencies:
        """Defect frequencies per 1 Hz of shaft speed (stationary outer race, rolling without slip).

        ``FTF = (1 - g)/2``, ``BPFO = z (1 - g)/2``, ``BPFI = z (1 + g)/2``, ``BSF = d_m/(2 d) (1 - g^2)`` with
        ``g = d cos(alpha) / d_m``.
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
        """Deepest a ball can sink into a dent of this length: ``r_b - sqrt(r_b^2 - (l/2)^2)`` [m].

        A dent shorter than the ball's chord cannot be felt to its full depth; the effective depth is the smaller
        of the two. For the paper's 2 mm dent and 8.73 mm balls this is 116 um > 50 um (full depth felt).
        """
        if self.dent is None:
            return 0.0
        rb = self.geometry.ball_diameter_m / 2.0
        half = min(self.dent.length_m / 2.0, rb)
        return rb - math.sqrt(rb * rb - half * half)

    @property
    def dent_effective_depth_m(self) -> float:
        """Depth by which a ball's deformation is reduced at the dent centre [m]."""
        return self._dent_depth_eff

    def dent_depth_m(self, ball_angle_rad):
        """Reduction of the ball deformation [m] at ball attitude angles [rad] (Eqs. 1-2).

        ``h S(wrap(beta - phi_d))``, S = 1 inside the dent and 0 outside with cubic edges; the wrap to
        [-pi, pi) handles the ``n 2 pi`` of Eq. (2) exactly.
        """
        if self.dent is None or self._dent_depth_eff == 0.0:
            return np.zeros(np.shape(ball_angle_rad))
        rel = np.abs(wrap_to_pi(np.asarray(ball_angle_rad) - self.dent.angle_rad))
        a = self._dent_half_angle
        return self._dent_depth_eff * (1.0 - step_cubic(rel, a - self._dent_edge, a))

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
    def ball_deformations_m(self, e_x_m, e_y_m, cage_angle_rad, film_m: float = 0.0, with_dent: bool = True):
        """Total elastic deformation of every ball [m] (Eq. 1), negative = no contact.

        ``delta_i = e_x cos beta_i + e_y sin beta_i - c_d/2 + h_film - h_dent(beta_i)`` (contact angle 0 in the
        lateral model). Shape: ``broadcast(e_x, e_y, cage_angle).shape + (n_balls,)``.
        """
        beta = self.ball_angles_rad(cage_angle_rad)
        ex = np.asarray(e_x_m, dtype=float)[..., None]
        ey = np.asarray(e_y_m, dtype=float)[..., None]
        delta = ex * np.cos(beta) + ey * np.sin(beta) - 0.5 * self.geometry.diametral_clearance_m + film_m
        if with_dent and self.dent is not None:
            delta = delta - self.dent_depth_m(beta)
        return delta

    def forces_n(self, e_x_m, e_y_m, cage_angle_rad, film_m: float = 0.0, with_stiffness: bool = False,
                 with_dent: bool = True):
        """Bearing force on the shaft [N] (Eqs. 3-4), optionally with its stiffness ``K = -dF/de`` [N/m].

        Parameters
        ----------
        e_x_m, e_y_m : array_like
            Inner-race centre relative to the outer-race centre [m].
        cage_angle_rad : array_like
            Cage angle [rad] (ball i at ``first_ball_angle + 2 pi (i-1)/z + cage_angle``).
        film_m : float
            EHL film thickness added to every ball's deformation [m].
        with_stiffness : bool
            Also return ``(k_xx, k_xy, k_yy)`` [N/m] (the tangent stiffness is symmetric).
        with_dent : bool
            False: the bearing as if it had no dent (static equilibrium, linearisation).

        Returns
        -------
        f_x, f_y : ndarray
            Force components on the shaft [N].
        (k_xx, k_xy, k_yy) : tuple of ndarray, only with ``with_stiffness``.
        """
        beta = self.ball_angles_rad(cage_angle_rad)
        cb, sb = np.cos(beta), np.sin(beta)
        ex = np.asarray(e_x_m, dtype=float)[..., None]
        ey = np.asarray(e_y_m, dtype=float)[..., None]
        delta = ex * cb + ey * sb - 0.5 * self.geometry.diametral_clearance_m + film_m
        if with_dent and self.dent is not None:
            delta = delta - self.dent_depth_m(beta)
        dpos = np.maximum(delta, 0.0)
        root = np.sqrt(dpos)
        q = self._k * dpos * root                       # ball loads [N]
        fx = -np.sum(q * cb, axis=-1) * self._cos_a0
        fy = -np.sum(q * sb, axis=-1) * self._cos_a0
        if not with_stiffness:
            return fx, fy
        dq = 1.5 * self._k * root                       # dQ/d delta [N/m]
        kxx = np.sum(dq * cb * cb, axis=-1) * self._cos_a0
        kxy = np.sum(dq * cb * sb, axis=-1) * self._cos_a0
        kyy = np.sum(dq * sb * sb, axis=-1) * self._cos_a0
        return fx, fy, (kxx, kxy, kyy)

    def ball_loads_n(self, e_x_m, e_y_m, cage_angle_rad, film_m: float = 0.0, with_dent: bool = True):
        """Load on every ball [N], ``K_tot max(delta, 0)^1.5`` (Eq. 3)."""
        delta = self.ball_deformations_m(e_x_m, e_y_m, cage_angle_rad, film_m, with_dent)
        return self._k * np.maximum(delta, 0.0) ** 1.5

    # ------------------------------------------------------------------ statics
    def static_equilibrium_m(self, load_x_n: float, load_y_n: float, cage_angle_rad: float = 0.0,
                             film_m: float = 0.0, with_dent: bool = False, tol_n: float = 1e-9):
        """Displacement e [m] at which the bearing carries an external load on the shaft.

        Solves ``F_bearing(e) + W = 0`` by Newton's method with the analytic tangent stiffness, where
        ``W = (load_x, load_y)`` [N] is the external load on the shaft (gravity: ``(0, -m g)``).

        Raises
        ------
        ValueError
            If the load is zero or Newton does not converge.
        """
        w = np.array([load_x_n, load_y_n], dtype=float)
        wn = float(np.hypot(*w))
        if wn == 0.0:
            raise ValueError("static equilibrium needs a non-zero load")
        g = self.geometry
        q_guess = 5.0 * wn / g.n_balls
        mag = 0.5 * g.diametral_clearance_m - film_m + (q_guess / self._k) ** (2.0 / 3.0)
        e = w / wn * max(mag, 1e-9)           # the shaft moves along the load
        for _ in range(100):
            fx, fy, (kxx, kxy, kyy) = self.forces_n(e[0], e[1], cage_angle_rad, film_m, with_stiffness=True,
                                                    with_dent=with_dent)
            r = np.array([fx + w[0], fy + w[1]])
            if np.hypot(*r) <= tol_n * max(wn, 1.0):
                return e
            kmat = np.array([[kxx, kxy], [kxy, kyy]], dtype=float)
            if np.linalg.cond(kmat) > 1e12:  # a direction has no ball in contact: push along the load
                e = e + w / wn * 1e-7
                continue
            step = np.linalg.solve(kmat, r)      # F(e + s) ~ F(e) - K s = -W
            # damped step: never more than 10 um at once (contact sets change)
            n = np.hypot(*step)
            if n > 1e-5:
                step *= 1e-5 / n
            e = e + step
        raise ValueError("bearing static equilibrium did not converge")

    def linearise(self, load_x_n: float, load_y_n: float, cage_angle_rad: float = 0.0, film_m: float = 0.0,
                  damping_ratio_s: float | None = None) -> BearingLinearisation:
        """Stiffness and damping linearised at the static equilibrium under a load (dent ignored).

        ``K = -dF/de`` from the analytic tangent; damping ``C = damping_ratio_s K`` with the default 2.5e-5 s.
        """
        ratio = self.DEFAULT_DAMPING_RATIO_S if damping_ratio_s is None else damping_ratio_s
        e = self.static_equilibrium_m(load_x_n, load_y_n, cage_angle_rad, film_m)
        _, _, (kxx, kxy, kyy) = self.forces_n(e[0], e[1], cage_angle_rad, film_m, with_stiffness=True,
                                              with_dent=False)
        qmax = float(np.max(self.ball_loads_n(e[0], e[1], cage_angle_rad, film_m, with_dent=False)))
        k = np.array([[kxx, kxy], [kxy, kyy]], dtype=float)
        return BearingLinearisation(displacement_m=e, stiffness_n_m=k, damping_n_s_m=ratio * k, max_ball_load_n=qmax)
