"""The ball-contact forces between rotor and housing of both bearings, as the time-domain models use them.

:class:`HertzPair` evaluates the nonlinear ball forces and tangent stiffnesses of the DE and NDE bearings at once
(the equations of :meth:`bkabem_core.bearing.deep_groove.Bearing.forces_n`, written for tables of cage angles and batches of
displacements); :class:`LinearPair` is its linear counterpart for tests. Used by the TDSM
(:mod:`bkabem_core.reference.tdsm`), the harmonic balance (:mod:`bkabem_core.reference.periodic`) and the improved method
(:mod:`bkabem_core.solve.improved`).

Units: SI (m, N, rad).
"""

from __future__ import annotations

import numpy as np

__all__ = ["HertzPair", "LinearPair"]


class HertzPair:
    """Nonlinear ball forces of the DE and NDE bearings, tabulated over one BPFO period.

    ``evaluate(u, j)`` returns the forces on the two rotor nodes (4,) ``[F_x DE, F_y DE, F_x NDE, F_y NDE]`` [N]
    and the tangent stiffness ``K = -dF/du`` (4, 4, block diagonal) [N/m] for relative displacements
    ``u = [e_x DE, e_y DE, e_x NDE, e_y NDE]`` [m] at table step ``j`` (cage angle ``j h omega_cage`` modulo one
    ball pitch). Same equations as :meth:`Bearing.forces_n` (module docstring of :mod:`bearing`: groove-centre
    offsets, loaded contact angle at the held axial displacement, the dent's radial drop), written for both
    bearings at once: one (4 x z) @ (z x 6) product gives all force and stiffness sums.

    Parameters
    ----------
    bearings : (Bearing, Bearing)
        DE and NDE bearing (same ball set and cage speed: one shaft).
    cage_angles_rad : ndarray (N,)
        Cage angles of the table steps [rad].
    films_m : (float, float)
        EHL film thickness of each bearing [m] (0 if the case disables it).
    axial_m : (float, float)
        Held axial displacement ``e_z`` of each bearing [m] (its static value under the axial load).
    """

    def __init__(self, bearings, cage_angles_rad, films_m=(0.0, 0.0), axial_m=(0.0, 0.0)):
        b0, b1 = bearings
        g0, g1 = b0.geometry, b1.geometry
        if (g0.n_balls != g1.n_balls or g0.first_ball_angle_rad != g1.first_ball_angle_rad
                or b0.fault_multipliers() != b1.fault_multipliers()):
            raise ValueError("HertzPair: both bearings must have the same ball set (one cage speed and table)")
        self.bearings = bearings
        cage_angles_rad = np.atleast_1d(np.asarray(cage_angles_rad, dtype=float))
        beta = bearings[0].ball_angles_rad(cage_angles_rad)                 # (N, z)
        c, s = np.cos(beta), np.sin(beta)
        self.cs = np.ascontiguousarray(np.stack([c, s], axis=1))            # (N, 2, z)
        # right-hand factors of the sums: [cos, sin, cos^2, cos sin, sin^2, 0]
        self.rt = np.ascontiguousarray(np.stack([c, s, c * c, c * s, s * s, np.zeros_like(c)], axis=2))
        ar0 = np.empty((len(cage_angles_rad), 2, g0.n_balls))
        self._moving = []                     # (bearing index, DefectSet) of defects that are not BPFO-periodic
        for i, b in enumerate(bearings):
            ar0[:, i, :] = b._ar0
            periodic = b.periodic_defects
            if b.dent is not None and len(periodic) == len(b.defects):
                ar0[:, i, :] -= b.dent_depth_m(beta)
            elif b.defect_set:
                if periodic:
                    ar0[:, i, :] -= type(b)(b.geometry, defects=periodic).dent_depth_m(beta)
                moving = type(b)(b.geometry, defects=b.moving_defects).defect_set
                if moving:
                    self._moving.append((i, moving))
        self.ar0 = ar0                                                       # A_r at u = 0 [m]
        self._beta = beta
        self._clock = None
        self.aa = np.array([b._aa0 + axial_m[i] for i, b in enumerate(bearings)])[:, None]   # (2, 1) A_a [m]
        self.a0 = np.array([b.groove_centre_distance_m for b in bearings])[:, None]
        self.film = np.asarray(films_m, dtype=float)[:, None]
        self.axial = bool(np.any(self.aa != 0.0))
        self.k = np.array([b.contact_constant_n_m15 for b in bearings])
        self._kc = self.k[:, None]
        # Y = [Q cos(phi) (2 rows); w (2 rows)] @ rt -> (4, 6), flattened 24:
        # F = -Y[b, 0:2];  K = [[Y[2+b, 2], Y[2+b, 3]], [Y[2+b, 3], Y[2+b, 4]]]
        self._f_idx = np.array([0, 1, 6, 7])
        kmap = np.full((4, 4), 17)                                           # Y[2, 5] = 0
        kmap[0, 0], kmap[0, 1], kmap[1, 0], kmap[1, 1] = 14, 15, 15, 16
        kmap[2, 2], kmap[2, 3], kmap[3, 2], kmap[3, 3] = 20, 21, 21, 22
        self._k_idx = kmap
        self._buf = np.empty((4, g0.n_balls))
        self._cs_t = None
        self.n_table = len(cage_angles_rad)

    def _terms(self, ar):
        """Per ball: Q cos(phi) and the tangent weight w (module docstring of :mod:`bearing`), broadcasting."""
        if not self.axial:
            delta = ar - self.a0 + self.film
            np.maximum(delta, 0.0, out=delta)
            root = np.sqrt(delta)
            return self._kc * delta * root, (1.5 * self._kc) * root
        a = np.sqrt(ar * ar + self.aa * self.aa)
        delta = a - self.a0 + self.film
        np.maximum(delta, 0.0, out=delta)
        root = np.sqrt(delta)
        c = ar / a
        q = self._kc * delta * root
        return q * c, (1.5 * self._kc) * root * c * c + q * (1.0 - c * c) / a

    @property
    def periodic(self) -> bool:
        """Whether the ball forces repeat every BPFO period (healthy bearings and periodic kinds: the outer race);
        other kinds (inner race, ball) move with the shaft and the ball spin, so their drops come from
        :meth:`ar0_rows`."""
        return not self._moving

    def bake_phases(self, shaft_angles_rad, spin_angles_rad) -> "HertzPair":
        """Place the moving defects once for all table rows: row j at shaft angle ``shaft_angles_rad[j]`` and
        ball spin ``spin_angles_rad[j]`` [rad] (a table of points of a torus, not of time). In place; returns
        self, whose :meth:`evaluate`, :meth:`forces_only` and :meth:`forces_many` then include them."""
        shaft = np.broadcast_to(np.asarray(shaft_angles_rad, dtype=float), (self.n_table,))
        spin = np.broadcast_to(np.asarray(spin_angles_rad, dtype=float), (self.n_table,))
        for i, moving in self._moving:
            self.ar0[:, i, :] -= moving.drop_m(self._beta, shaft, spin)
        self._moving = []
        return self

    def set_clock(self, step_s: float, shaft_rad_s: float, spin_rad_s: float) -> None:
        """The time base of :meth:`ar0_rows`: table step j of absolute step n is ``n mod N`` (N table rows, one
        BPFO period), shaft angle ``shaft_rad_s n h``, ball spin ``spin_rad_s n h``."""
        self._clock = (float(step_s), float(shaft_rad_s), float(spin_rad_s))

    def ar0_rows(self, n0: int, n1: int) -> np.ndarray:
        """``A_r`` at u = 0 (n1 - n0, 2, z) [m] at absolute steps n0..n1-1, every defect included.

        After r BPFO periods the ball set has turned by r ball pitches, so ball i sits in table column
        ``(i + r) mod z``: a ball defect follows its ball through the columns; an inner-race defect is placed by
        the column's position and the shaft angle."""
        n = np.arange(n0, n1)
        n_tab, z = self._beta.shape
        j = n % n_tab
        rows = self.ar0[j].copy()
        if not self._moving:
            return rows
        h, w_shaft, w_spin = self._clock
        cols = (np.arange(z)[None, :] + (n // n_tab)[:, None]) % z                 # column of ball i at step n
        beta = np.take_along_axis(self._beta[j], cols, axis=1)                    # (n, z) per ball
        for i, moving in self._moving:
            d = moving.drop_m(beta, w_shaft * h * n, w_spin * h * n)
            d_col = np.empty_like(d)
            np.put_along_axis(d_col, cols, d, axis=1)
            rows[:, i, :] -= d_col
        return rows

    def evaluate(self, u, j, ar0=None):
        buf = self._buf
        ar = u.reshape(2, 2).dot(self.cs[j])
        ar += self.ar0[j] if ar0 is None else ar0
        buf[:2], buf[2:] = self._terms(ar)
        y = buf.dot(self.rt[j]).ravel()
        return -y[self._f_idx], y[self._k_idx]

    def potential_energy_j(self, u, j):
        """Elastic energy stored in the ball contacts [J] (``sum 2/5 K delta^2.5``)."""
        ar = u.reshape(2, 2).dot(self.cs[j]) + self.ar0[j]
        a = np.sqrt(ar * ar + self.aa * self.aa)
        delta = np.maximum(a - self.a0 + self.film, 0.0)
        return float(np.sum(0.4 * self.k[:, None] * delta ** 2.5))

    def forces_only(self, u_t):
        """Ball forces (N, 4) at the N table instants, without the stiffness (cheaper than :meth:`forces_many`)."""
        n = u_t.shape[0]
        if self._cs_t is None:
            self._cs_t = np.ascontiguousarray(np.swapaxes(self.cs, 1, 2))             # (N, z, 2)
        ar = np.matmul(u_t.reshape(n, 2, 2), self.cs)
        ar += self.ar0
        if self.axial:
            a = np.sqrt(ar * ar + self.aa * self.aa)
            delta = a - self.a0 + self.film
            np.maximum(delta, 0.0, out=delta)
            qc = (self._kc * delta * np.sqrt(delta)) * (ar / a)
        else:
            delta = ar - self.a0 + self.film
            np.maximum(delta, 0.0, out=delta)
            qc = self._kc * delta * np.sqrt(delta)
        return -np.matmul(qc, self._cs_t).reshape(n, 4)

    def forces_many(self, u_t):
        """Ball forces (N, 4) and block-diagonal tangent stiffnesses (N, 4, 4) at the N table instants."""
        n = u_t.shape[0]
        ar = np.einsum("nbd,ndi->nbi", u_t.reshape(n, 2, 2), self.cs) + self.ar0
        qc, w = self._terms(ar)
        c, s = self.cs[:, None, 0, :], self.cs[:, None, 1, :]
        f = -np.stack([np.sum(qc * c, axis=-1), np.sum(qc * s, axis=-1)], axis=-1).reshape(n, 4)
        kxx, kxy, kyy = np.sum(w * c * c, -1), np.sum(w * c * s, -1), np.sum(w * s * s, -1)
        kt = np.zeros((n, 4, 4))
        for b in range(2):
            kt[:, 2 * b, 2 * b] = kxx[:, b]
            kt[:, 2 * b, 2 * b + 1] = kt[:, 2 * b + 1, 2 * b] = kxy[:, b]
            kt[:, 2 * b + 1, 2 * b + 1] = kyy[:, b]
        return f, kt


class LinearPair:
    """Linear bearing springs ``F = -K u`` (diagonal per bearing), the force-model interface of :class:`HertzPair`.

    Used to test the integrator against the linear FE (energy balance, harmonic response).

    Parameters
    ----------
    stiffness_n_m : array (2, 2)
        ``[[k_xx DE, k_yy DE], [k_xx NDE, k_yy NDE]]`` [N/m].
    """

    def __init__(self, stiffness_n_m, n_table=1):
        k = np.asarray(stiffness_n_m, dtype=float).reshape(4)
        self.kt = np.diag(k)
        self._kflat = k
        self.n_table = n_table

    def evaluate(self, u, j, ar0=None):
        return -self._kflat * u, self.kt

    periodic = True

    def potential_energy_j(self, u, j):
        return float(0.5 * np.sum(self._kflat * u * u))

    def forces_many(self, u_t):
        n = u_t.shape[0]
        return -u_t * self._kflat, np.broadcast_to(self.kt, (n, 4, 4)).copy()
