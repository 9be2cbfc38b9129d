"""A deep-groove ball bearing under a static load: its equilibrium, the ball-load distribution there, and the
lateral stiffness and damping linearised at it.

The equilibrium solves ``F_bearing(e) + W = 0`` with the ball forces of :class:`bkabem_core.bearing.deep_groove.Bearing`
(Sopanen-Mikkola, module docstring there) and their analytic tangent; :class:`BearingState` and
:class:`BearingLinearisation` are what every linear consumer (quasi-static excitation, FE bearing elements, TDSM
start) takes from it. Everything is SI: m, N, rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["BearingState", "BearingLinearisation", "BearingStatics"]

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class BearingState:
    """The bearing at a static equilibrium (dent ignored): what every linear consumer needs.

    Attributes
    ----------
    displacement_m : ndarray (3,)
        ``(e_x, e_y, e_z)`` of the inner race relative to the outer race [m].
    radial_load_n : ndarray (2,)
        External load on the shaft ``(W_x, W_y)`` that the bearing carries [N] (gravity: ``W_y < 0``).
    axial_load_n : float
        Axial load the bearing carries [N] (>= 0).
    ball_loads_n : ndarray (n_balls,)
        Ball loads Q_i at cage angle 0 [N].
    contact_angles_rad : ndarray (n_balls,)
        Loaded contact angles phi_i at cage angle 0 [rad] (NaN for unloaded balls).
    """

    displacement_m: np.ndarray
    radial_load_n: np.ndarray
    axial_load_n: float
    ball_loads_n: np.ndarray
    contact_angles_rad: np.ndarray

    @property
    def loaded_balls(self) -> int:
        return int(np.sum(self.ball_loads_n > 0.0))

    @property
    def mean_contact_angle_deg(self) -> float:
        """Load-weighted mean loaded contact angle [deg]."""
        q = self.ball_loads_n
        if q.sum() == 0.0:
            return 0.0
        return float(np.degrees(np.sum(q * np.abs(np.nan_to_num(self.contact_angles_rad))) / q.sum()))

    def to_dict(self) -> dict:
        return {"displacement_m": self.displacement_m.tolist(), "radial_load_n": self.radial_load_n.tolist(),
                "axial_load_n": self.axial_load_n, "max_ball_load_n": float(self.ball_loads_n.max()),
                "loaded_balls": self.loaded_balls, "mean_contact_angle_deg": self.mean_contact_angle_deg}


@dataclass(frozen=True)
class BearingLinearisation:
    """Lateral bearing stiffness and damping linearised at a static equilibrium (axial displacement held).

    Attributes
    ----------
    state : BearingState
        The equilibrium it is linearised at.
    stiffness_n_m : ndarray (2, 2)
        ``K = -dF/de`` [N/m], rows/columns (x, y): the tangent at cage angle 0, or its mean over one ball pitch
        (``averaged``).
    damping_n_s_m : ndarray (2, 2)
        Lateral damping [N s/m].
    stiffness_variation : float
        Ball-passage variation of the tangent over one pitch, ``(max - min) / mean`` of the vertical term [-].
    averaged : bool
        Whether ``stiffness_n_m`` is the pitch mean.
    stiffness_horizontal_n_m, stiffness_vertical_n_m : float
        Diagonal terms K_xx, K_yy [N/m].
    damping_horizontal_n_s_m, damping_vertical_n_s_m : float
        Diagonal terms C_xx, C_yy [N s/m].
    """

    state: BearingState
    stiffness_n_m: np.ndarray
    damping_n_s_m: np.ndarray
    stiffness_variation: float = 0.0
    averaged: bool = False
    stiffness_horizontal_n_m: float = field(init=False)
    stiffness_vertical_n_m: float = field(init=False)
    damping_horizontal_n_s_m: float = field(init=False)
    damping_vertical_n_s_m: float = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "stiffness_horizontal_n_m", float(self.stiffness_n_m[0, 0]))
        object.__setattr__(self, "stiffness_vertical_n_m", float(self.stiffness_n_m[1, 1]))
        object.__setattr__(self, "damping_horizontal_n_s_m", float(self.damping_n_s_m[0, 0]))
        object.__setattr__(self, "damping_vertical_n_s_m", float(self.damping_n_s_m[1, 1]))

    @property
    def displacement_m(self) -> np.ndarray:
        return self.state.displacement_m

    @property
    def max_ball_load_n(self) -> float:
        return float(self.state.ball_loads_n.max())

    def to_dict(self) -> dict:
        return {"state": self.state.to_dict(), "stiffness_n_m": self.stiffness_n_m.tolist(),
                "damping_n_s_m": self.damping_n_s_m.tolist(), "stiffness_variation": self.stiffness_variation,
                "averaged": self.averaged}


class BearingStatics:
    """The statics of :class:`bkabem_core.bearing.deep_groove.Bearing` (a base class of it): equilibrium under a
    radial load and a thrust, its ball loads and contact angles, its linearisation.

    Uses the bearing's ball forces (``forces_n``, ``forces_3d_n``, ``ball_loads_n``, ``contact_angles_rad``),
    its ``geometry``, contact constant ``_k`` and groove-centre offsets ``_a0``, ``_ar0``, ``_aa0``.
    """

    #: Damping-to-stiffness ratio of Kraemer's rule [s] (paper Table 1 follows it: c = 2.5e-5 s x k).
    KRAEMER_DAMPING_RATIO_S = 2.5e-5

    def static_equilibrium_m(self, load_x_n: float, load_y_n: float, cage_angle_rad: float = 0.0,
                             film_m: float = 0.0, with_dent: bool = False, tol_n: float = 1e-9,
                             axial_load_n: float = 0.0):
        """Displacement e [m] at which the bearing carries an external load on the shaft.

        Solves ``F_bearing(e) + W = 0`` by damped Newton with the analytic tangent stiffness, where
        ``W = (load_x, load_y)`` [N] is the external load on the shaft (gravity: ``(0, -m g)``) and, if
        ``axial_load_n > 0``, a thrust of that size on the shaft along -z.

        Returns
        -------
        ndarray (2,) ``(e_x, e_y)`` without an axial load, else (3,) ``(e_x, e_y, e_z)``.

        Raises
        ------
        ValueError
            If the load is zero or Newton does not converge.
        """
        axial = float(axial_load_n)
        if axial < 0.0:
            raise ValueError(f"axial_load_n: must be >= 0 (got {axial})")
        w = np.array([load_x_n, load_y_n], dtype=float)
        wn = float(np.hypot(*w))
        if wn == 0.0 and axial == 0.0:
            raise ValueError("static equilibrium needs a non-zero load")
        g = self.geometry
        if axial == 0.0:
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
                if np.linalg.cond(kmat) > 1e12:
                    # A direction without stiffness: no ball in contact yet (push along the load), or one ball alone
                    # under a light load (stiff along its own line only): Newton along the load's direction.
                    u = w / wn
                    k_u = float(u @ kmat @ u)
                    s = float(u @ r) / k_u if k_u > 0.0 else 1e-7
                    e = e + u * float(np.clip(s, -1e-5, 1e-5))      # damped as below
                    continue
                step = np.linalg.solve(kmat, r)      # F(e + s) ~ F(e) - K s = -W
                n = np.hypot(*step)                  # damped: never more than 10 um at once (contact sets change)
                if n > 1e-5:
                    step *= 1e-5 / n
                e = e + step
            raise ValueError("bearing static equilibrium did not converge")
        # with thrust: the axial offset that takes up the play first (all balls touching), then Newton in 3-D
        load = np.array([w[0], w[1], -axial])
        ln = float(np.linalg.norm(load))
        aa_touch = math.sqrt(max(self._a0**2 - self._ar0**2, 0.0)) - self._aa0
        q_guess = axial / (g.n_balls * 0.4)
        e = np.array([0.0, 0.0, -(aa_touch + (q_guess / self._k) ** (2.0 / 3.0))])
        for _ in range(200):
            f, k = self.forces_3d_n(e, cage_angle_rad, film_m, with_dent)
            r = f + load
            if np.linalg.norm(r) <= tol_n * max(ln, 1.0):
                return e
            if np.linalg.cond(k) > 1e12:
                e = e + load / ln * 1e-7
                continue
            step = np.linalg.solve(k, r)
            n = np.linalg.norm(step)
            if n > 2e-6:
                step *= 2e-6 / n
            e = e + step
        raise ValueError("bearing static equilibrium under the axial load did not converge")

    def state(self, load_x_n: float, load_y_n: float, axial_load_n: float = 0.0, film_m: float = 0.0) -> BearingState:
        """The static equilibrium under a radial load ``(load_x, load_y)`` on the shaft and a thrust [N]."""
        e = self.static_equilibrium_m(load_x_n, load_y_n, film_m=film_m, axial_load_n=axial_load_n)
        e3 = np.r_[e, 0.0] if e.size == 2 else e
        q = self.ball_loads_n(e3[0], e3[1], 0.0, film_m, with_dent=False, e_z_m=e3[2])
        phi = np.where(q > 0.0, self.contact_angles_rad(e3[0], e3[1], 0.0, e3[2], with_dent=False), np.nan)
        return BearingState(displacement_m=e3, radial_load_n=np.array([load_x_n, load_y_n], float),
                            axial_load_n=float(axial_load_n), ball_loads_n=q, contact_angles_rad=phi)

    def linearise(self, load_x_n: float, load_y_n: float, cage_angle_rad: float = 0.0, film_m: float = 0.0,
                  damping_ratio_s: float | None = None, axial_load_n: float = 0.0, damping_n_s_m: float | None = None,
                  average_over_pitch: bool = False, n_angles: int = 64) -> BearingLinearisation:
        """Lateral stiffness and damping at the static equilibrium under a load (dent ignored, ``e_z`` held).

        ``K = -dF/de`` from the analytic tangent at ``cage_angle_rad`` (the paper's and LUT's procedure), or with
        ``average_over_pitch`` its mean over one ball pitch of cage angle at the same displacement. Damping: a
        viscous ``damping_n_s_m`` in both directions if given, else ``C = damping_ratio_s K`` (Kraemer's rule,
        default 2.5e-5 s, which paper Table 1 follows).
        """
        st = self.state(load_x_n, load_y_n, axial_load_n, film_m)
        e = st.displacement_m
        if average_over_pitch:
            theta = cage_angle_rad + np.arange(n_angles) * (TWO_PI / self.geometry.n_balls / n_angles)
        else:
            theta = np.array([cage_angle_rad])
        _, _, (kxx, kxy, kyy) = self.forces_n(e[0], e[1], theta, film_m, with_stiffness=True, with_dent=False,
                                              e_z_m=e[2])
        k = np.array([[np.mean(kxx), np.mean(kxy)], [np.mean(kxy), np.mean(kyy)]], dtype=float)
        if average_over_pitch:
            var = float((kyy.max() - kyy.min()) / max(np.mean(kyy), 1e-300))
        else:
            th = cage_angle_rad + np.arange(n_angles) * (TWO_PI / self.geometry.n_balls / n_angles)
            _, _, (_, _, kyy_p) = self.forces_n(e[0], e[1], th, film_m, with_stiffness=True, with_dent=False,
                                                e_z_m=e[2])
            var = float((kyy_p.max() - kyy_p.min()) / max(np.mean(kyy_p), 1e-300))
        if damping_n_s_m is not None:
            c = float(damping_n_s_m) * np.eye(2)
        else:
            ratio = self.KRAEMER_DAMPING_RATIO_S if damping_ratio_s is None else damping_ratio_s
            c = ratio * k
        return BearingLinearisation(state=st, stiffness_n_m=k, damping_n_s_m=c, stiffness_variation=var,
                                    averaged=average_over_pitch)
