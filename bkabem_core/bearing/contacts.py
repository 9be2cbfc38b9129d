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

__all__ = ["HertzPair", "LinearPair", "same_ball_set"]

#: ``A_r`` at u = 0 of the padding balls of a smaller ball set (:class:`HertzPair`, two different bearings): any
#: positive radius keeps the contact angle finite; their contact stiffness is zero, so they carry no force.
_PAD_AR0 = 1.0


class HertzPair:
    """Nonlinear ball forces of the DE and NDE bearings, tabulated over one BPFO period.

    ``evaluate(u, j)`` returns the forces on the two rotor nodes (4,) ``[F_x DE, F_y DE, F_x NDE, F_y NDE]`` [N]
    and the tangent stiffness ``K = -dF/du`` (4, 4, block diagonal) [N/m] for relative displacements
    ``u = [e_x DE, e_y DE, e_x NDE, e_y NDE]`` [m] at table step ``j`` (cage angle ``j h omega_cage`` modulo one
    ball pitch). Same equations as :meth:`Bearing.forces_n` (module docstring of :mod:`bearing`: groove-centre
    offsets, loaded contact angle at the held axial displacement, the dent's radial drop), written for both
    bearings at once: one (4 x z) @ (z x 6) product gives all force and stiffness sums.

    **Two different bearings.** When the DE and NDE bearings differ in ball set or kinematics (ball count, attitude
    of ball 1, cage or spin rate), or the table gives each its own cage angle (``cage_angles_rad`` of shape
    (N, 2)), each bearing has its own table of ball angles: the smaller ball set is padded to the larger one with
    balls of zero contact stiffness (they carry no force and add no stiffness), and the sums run per bearing. The
    ball forces of two different bearings do not repeat with one period: a time-domain model takes them row by row
    from its clock (:meth:`set_clock`, :meth:`rows`).

    Parameters
    ----------
    bearings : (Bearing, Bearing)
        DE and NDE bearing.
    cage_angles_rad : ndarray (N,) or (N, 2)
        Cage angles of the table steps [rad]: one for both bearings, or one per bearing (columns DE, NDE).
    films_m : (float, float)
        EHL film thickness of each bearing [m] (0 if the case disables it).
    axial_m : (float, float)
        Held axial displacement ``e_z`` of each bearing [m] (its static value under the axial load).
    """

    def __init__(self, bearings, cage_angles_rad, films_m=(0.0, 0.0), axial_m=(0.0, 0.0)):
        b0, b1 = bearings
        g0 = b0.geometry
        cage_angles_rad = np.asarray(cage_angles_rad, dtype=float)
        self.split = bool(cage_angles_rad.ndim == 2 or not same_ball_set(b0, b1))
        if self.split:
            self._init_split(bearings, cage_angles_rad, films_m, axial_m)
            return
        self.bearings = bearings
        cage_angles_rad = np.atleast_1d(cage_angles_rad)
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

    def _init_split(self, bearings, cage_angles_rad, films_m, axial_m) -> None:
        """Each bearing its own table of ball angles, padded to the larger ball set (class docstring)."""
        self.bearings = bearings
        cage = np.asarray(cage_angles_rad, dtype=float)
        if cage.ndim == 2 and cage.shape[1] != 2:
            raise ValueError(f"cage_angles_rad: (N,) or (N, 2) cage angles (got shape {cage.shape})")
        cage = cage if cage.ndim == 2 else np.stack([np.atleast_1d(cage)] * 2, axis=1)
        self.n_table = cage.shape[0]
        self.z_max = max(b.geometry.n_balls for b in bearings)
        self._beta = [b.ball_angles_rad(cage[:, i]) for i, b in enumerate(bearings)]          # (N, z_b) each
        self.cs, self.rt = self._tables(self._beta)
        self.ar0 = np.full((self.n_table, 2, self.z_max), _PAD_AR0)
        self._moving = []
        for i, b in enumerate(bearings):
            self.ar0[:, i, :b.geometry.n_balls] = self._ar0_of(i, self._beta[i])
            moving = type(b)(b.geometry, defects=b.moving_defects).defect_set
            if moving:
                self._moving.append((i, moving))             # placed by bake_phases or row by row (rows)
        self._clock = None
        self.aa = np.array([b._aa0 + axial_m[i] for i, b in enumerate(bearings)])[:, None]
        self.a0 = np.array([b.groove_centre_distance_m for b in bearings])[:, None]
        self.film = np.asarray(films_m, dtype=float)[:, None]
        self.axial = bool(np.any(self.aa != 0.0))
        self.k = np.array([b.contact_constant_n_m15 for b in bearings])
        self._kc = np.zeros((2, self.z_max))                  # padding balls: zero contact stiffness
        for i, b in enumerate(bearings):
            self._kc[i, :b.geometry.n_balls] = self.k[i]
        self._f_idx = np.array([0, 1, 6, 7])
        kmap = np.full((4, 4), 17)
        kmap[0, 0], kmap[0, 1], kmap[1, 0], kmap[1, 1] = 14, 15, 15, 16
        kmap[2, 2], kmap[2, 3], kmap[3, 2], kmap[3, 3] = 20, 21, 21, 22
        self._k_idx = kmap
        self._y = np.empty((4, 6))

    def _tables(self, betas):
        """(cos, sin) (N, 2 bearings, 2, z_max) and the right-hand factors [cos, sin, cos^2, cos sin, sin^2, 0]
        (N, 2, z_max, 6) of per-bearing ball angles (padding balls: zeros)."""
        n = betas[0].shape[0]
        cs = np.zeros((n, 2, 2, self.z_max))
        for i, beta in enumerate(betas):
            cs[:, i, 0, :beta.shape[1]] = np.cos(beta)
            cs[:, i, 1, :beta.shape[1]] = np.sin(beta)
        c, s = cs[:, :, 0], cs[:, :, 1]
        rt = np.stack([c, s, c * c, c * s, s * s, np.zeros_like(c)], axis=3)
        return cs, rt

    def _ar0_of(self, i: int, beta, shaft=None, spin=None):
        """``A_r`` at u = 0 of bearing ``i`` at ball angles ``beta`` (n, z) [m]: its periodic defects and, with
        ``shaft`` and ``spin`` [rad] (n,), also those with phases of their own placed there."""
        b = self.bearings[i]
        out = np.full(beta.shape, b._ar0)
        periodic = b.periodic_defects
        if periodic:
            out -= type(b)(b.geometry, defects=periodic).dent_depth_m(beta)
        if shaft is not None:
            moving = type(b)(b.geometry, defects=b.moving_defects).defect_set
            if moving:
                out -= moving.drop_m(beta, shaft, spin)
        return out

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
        """Whether the ball forces repeat every BPFO period (healthy bearings and periodic kinds: the outer race, one
        bearing type); other kinds (inner race, ball) move with the shaft and the ball spin, and two different
        bearings have two periods, so their rows come from :meth:`rows`."""
        return not self._moving and not self.split

    def bake_phases(self, shaft_angles_rad, spin_angles_rad) -> "HertzPair":
        """Place the moving defects once for all table rows: row j at shaft angle ``shaft_angles_rad[j]`` and
        ball spin ``spin_angles_rad[j]`` [rad] (a table of points of a torus, not of time; the spin (N,) or one per
        bearing (N, 2)). In place; returns self, whose :meth:`evaluate`, :meth:`forces_only` and
        :meth:`forces_many` then include them."""
        shaft = np.broadcast_to(np.asarray(shaft_angles_rad, dtype=float), (self.n_table,))
        spin = np.asarray(spin_angles_rad, dtype=float)
        spin = np.broadcast_to(spin if spin.ndim == 2 else spin.reshape(-1, 1) if spin.ndim else spin,
                               (self.n_table, 2))
        for i, moving in self._moving:
            if self.split:
                z = self.bearings[i].geometry.n_balls
                self.ar0[:, i, :z] -= moving.drop_m(self._beta[i], shaft, spin[:, i])
            else:
                self.ar0[:, i, :] -= moving.drop_m(self._beta, shaft, spin[:, i])
        self._moving = []
        return self

    def set_clock(self, step_s: float, shaft_rad_s: float, spin_rad_s, cage_rad_s=None) -> None:
        """The time base of :meth:`rows`: table step j of absolute step n is ``n mod N`` (N table rows, one
        BPFO period), shaft angle ``shaft_rad_s n h``, ball spin ``spin_rad_s n h`` [rad/s]; two different
        bearings: ``spin_rad_s`` and ``cage_rad_s`` one per bearing (DE, NDE), each bearing's ball angles from its
        own cage angle ``cage_rad_s n h``."""
        if self.split:
            if cage_rad_s is None:
                raise ValueError("set_clock: two different bearings need each bearing's cage speed (cage_rad_s)")
            self._clock = (float(step_s), float(shaft_rad_s), np.broadcast_to(np.asarray(spin_rad_s, float), 2),
                           np.broadcast_to(np.asarray(cage_rad_s, float), 2))
        else:
            self._clock = (float(step_s), float(shaft_rad_s), float(spin_rad_s))

    def rows(self, n0: int, n1: int):
        """The ball forces' inputs at absolute steps n0..n1-1 of the clock (:meth:`set_clock`): ``A_r`` at u = 0
        (:meth:`ar0_rows`) for one bearing type; for two different bearings a sequence whose item k is the
        tuple (cos/sin, right-hand factors, ``A_r`` at u = 0) of step n0 + k, each bearing at its own cage angle.
        Item k is what :meth:`evaluate` takes as ``ar0``."""
        if not self.split:
            return self.ar0_rows(n0, n1)
        h, w_shaft, w_spin, w_cage = self._clock
        n = np.arange(n0, n1)
        betas = [b.ball_angles_rad(w_cage[i] * h * n) for i, b in enumerate(self.bearings)]
        cs, rt = self._tables(betas)
        ar0 = np.full((n.size, 2, self.z_max), _PAD_AR0)
        for i, b in enumerate(self.bearings):
            ar0[:, i, :b.geometry.n_balls] = self._ar0_of(i, betas[i], w_shaft * h * n, w_spin[i] * h * n)
        return _SplitRows(cs, rt, ar0)

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
        """Forces (4,) [N] and tangent stiffness (4, 4) [N/m] at relative displacements ``u`` (4,) [m] and table
        step ``j`` (class docstring); ``ar0``: ``A_r`` at u = 0 of that step instead of the table's (a row of
        :meth:`rows`)."""
        if self.split:
            return self._evaluate_split(u, j, ar0)
        buf = self._buf
        ar = u.reshape(2, 2).dot(self.cs[j])
        ar += self.ar0[j] if ar0 is None else ar0
        buf[:2], buf[2:] = self._terms(ar)
        y = buf.dot(self.rt[j]).ravel()
        return -y[self._f_idx], y[self._k_idx]

    def _evaluate_split(self, u, j, row):
        if isinstance(row, tuple):
            cs, rt, ar0 = row
        else:
            cs, rt, ar0 = self.cs[j], self.rt[j], self.ar0[j] if row is None else row
        ar = np.einsum("bd,bdi->bi", u.reshape(2, 2), cs) + ar0
        qc, w = self._terms(ar)
        y = self._y
        y[:2] = np.einsum("bi,bik->bk", qc, rt)
        y[2:] = np.einsum("bi,bik->bk", w, rt)
        y = y.ravel()
        return -y[self._f_idx], y[self._k_idx]

    def potential_energy_j(self, u, j):
        """Elastic energy stored in the ball contacts [J] (``sum 2/5 K delta^2.5``)."""
        if self.split:
            ar = np.einsum("bd,bdi->bi", u.reshape(2, 2), self.cs[j]) + self.ar0[j]
            a = np.sqrt(ar * ar + self.aa * self.aa)
            delta = np.maximum(a - self.a0 + self.film, 0.0)
            return float(np.sum(0.4 * self._kc * delta ** 2.5))
        ar = u.reshape(2, 2).dot(self.cs[j]) + self.ar0[j]
        a = np.sqrt(ar * ar + self.aa * self.aa)
        delta = np.maximum(a - self.a0 + self.film, 0.0)
        return float(np.sum(0.4 * self.k[:, None] * delta ** 2.5))

    def forces_only(self, u_t):
        """Ball forces (N, 4) at the N table instants, without the stiffness (cheaper than :meth:`forces_many`)."""
        n = u_t.shape[0]
        if self.split:
            ar = np.einsum("nbd,nbdi->nbi", u_t.reshape(n, 2, 2), self.cs) + self.ar0
            qc, _ = self._terms(ar)
            return -np.einsum("nbi,nbdi->nbd", qc, self.cs).reshape(n, 4)
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
        if self.split:
            ar = np.einsum("nbd,nbdi->nbi", u_t.reshape(n, 2, 2), self.cs) + self.ar0
            c, s = self.cs[:, :, 0, :], self.cs[:, :, 1, :]
        else:
            ar = np.einsum("nbd,ndi->nbi", u_t.reshape(n, 2, 2), self.cs) + self.ar0
            c, s = self.cs[:, None, 0, :], self.cs[:, None, 1, :]
        qc, w = self._terms(ar)
        f = -np.stack([np.sum(qc * c, axis=-1), np.sum(qc * s, axis=-1)], axis=-1).reshape(n, 4)
        kxx, kxy, kyy = np.sum(w * c * c, -1), np.sum(w * c * s, -1), np.sum(w * s * s, -1)
        kt = np.zeros((n, 4, 4))
        for b in range(2):
            kt[:, 2 * b, 2 * b] = kxx[:, b]
            kt[:, 2 * b, 2 * b + 1] = kt[:, 2 * b + 1, 2 * b] = kxy[:, b]
            kt[:, 2 * b + 1, 2 * b + 1] = kyy[:, b]
        return f, kt


class _SplitRows:
    """Rows of :meth:`HertzPair.rows` for two different bearings: item k is (cos/sin (2, 2, z), right-hand factors
    (2, z, 6), ``A_r`` at u = 0 (2, z))."""

    def __init__(self, cs, rt, ar0):
        self.cs, self.rt, self.ar0 = cs, rt, ar0

    def __len__(self) -> int:
        return self.ar0.shape[0]

    def __getitem__(self, k):
        return self.cs[k], self.rt[k], self.ar0[k]


def same_ball_set(b0, b1) -> bool:
    """Whether two bearings can share one table of ball angles: the same ball count, attitude of ball 1 and
    kinematics (cage and spin rates)."""
    g0, g1 = b0.geometry, b1.geometry
    return (g0.n_balls == g1.n_balls and g0.first_ball_angle_rad == g1.first_ball_angle_rad
            and b0.fault_multipliers() == b1.fault_multipliers())


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
