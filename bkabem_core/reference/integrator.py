"""The TDSM's time integrator: one constant step of the linear part as an affine map, closed at every step by
Newton's method on the 4 bearing coordinates (the scheme is described in :mod:`bkabem_core.reference.tdsm`).

The linear part (FE rotor, housings, supports, dampers, ``Omega G``) gives, for one step ``h``,

    z_{n+1} = T z_n + W f_{n+1} + W_p f_n,

with ``f`` the 4 bearing-force deviations (DE x, y; NDE x, y); the bearing relative displacements ``u = B_z z``
then satisfy ``u = u_pred + H f(u)`` with the 4 x 4 flexibility ``H = B_z W``. A coupling force turning with the
shaft (:class:`bkabem_core.reference.coupling.RotatingForce`) is one more input of the same step, discretised as the
bearing forces are: it adds ``Re(q_n) V_0 + Im(q_n) V_1`` to ``z_{n+1}``. :class:`Integrator` makes these
matrices once per model (``"exponential"``: modal coordinates, ``T`` diagonal; ``"newmark"``: HHT-alpha on
``[x, v, a]``) and advances a state through any number of steps.

Units: SI (m, s, N, rad).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from bkabem_core.bearing.deep_groove import TWO_PI

__all__ = ["Integrator", "IntegratorState"]


class IntegratorState:
    """The state carried between :meth:`Integrator.advance` calls: modal or ``[x, v, a]`` state, force history,
    step and Newton counts."""

    def __init__(self, z):
        self.z = z
        self.f_dev = np.zeros(4)
        self.f_old = np.zeros(4)
        self.steps = 0
        self.newton_total = 0
        self.newton_max = 0
        self.interrupted = False
        self.recorded = 0


class Integrator:
    """The step matrices of one model at one step, and the Newton iteration on its bearing forces.

    Parameters
    ----------
    rotor : Rotor
        The FE model with the linear bearing springs ``K_b`` and the bearing dampers inside (``M``, ``C``, ``G``,
        ``K``).
    B : ndarray (ndof, 4)
        Rotor-minus-housing selection of the bearing coordinates: ``u = B^T x`` [-].
    out_dofs : ndarray (4, 2) of int
        The recorded DOFs: LOCATIONS x DIRECTIONS.
    h : float
        Step [s].
    speed_hz : float
        Shaft speed [Hz] (gyroscopic term ``Omega G``).
    forces : HertzPair or LinearPair
        The ball forces and tangent stiffnesses ``evaluate(u, j[, rows])`` [N, N/m].
    u_static, f_static : ndarray (4,)
        Bearing relative displacements [m] and ball forces [N] at the static equilibrium.
    kb : ndarray (4, 4)
        The linear bearing springs inside the FE model [N/m] (``g(u) = f(u) + K_b u``).
    steps_per_bpfo : int
        Steps per BPFO period (the period of the force table).
    scheme : {"exponential", "newmark"}
    hht_alpha : float
        HHT-alpha of the ``"newmark"`` scheme.
    newton_tol_m : float
        Newton update that ends the iteration [m].
    max_newton : int
        Iteration limit per step.
    coupling : RotatingForce, optional
        The coupling's running-speed force on the rotor (None: none).
    """

    def __init__(self, rotor, B, out_dofs, h, speed_hz, forces, u_static, f_static, kb, steps_per_bpfo,
                 scheme="exponential", hht_alpha=0.0, newton_tol_m=1.0e-9, max_newton=30, coupling=None):
        self.rotor, self.ndof, self.B, self.out_dofs = rotor, rotor.ndof, B, out_dofs
        self.coupling = coupling
        self.h, self.speed_hz, self.steps_per_bpfo = h, speed_hz, steps_per_bpfo
        self.forces, self._u_static, self._f_static, self._kb = forces, u_static, f_static, kb
        self.scheme, self.hht_alpha = scheme, hht_alpha
        self.newton_tol_m, self.max_newton = newton_tol_m, max_newton
        if self.scheme == "newmark":
            self._build_newmark()
        else:
            self._build_exponential()
        self.state_size = self.T.shape[0]
        # the approximate Newton inverse I - H (K_t - K_b) needs |H (K_t - K_b)| << 1
        _, k_st = self.forces.evaluate(self._u_static, 0)
        self.newton_contraction = float(np.linalg.norm(self.H, 2) * max(np.linalg.norm(k_st - self._kb, 2),
                                                                        0.1 * np.linalg.norm(self._kb, 2)))
        self.newton_exact = 10.0 * self.newton_contraction > 0.1

    def start(self, initial_state=None) -> IntegratorState:
        """The state at t = 0: ``initial_state`` (deviation from the static equilibrium, ``[x, v]`` or
        ``[x, v, a]``; default at rest, exponential with a coupling force: the linear rotor's steady response to it)
        with the bearing forces it carries."""
        if initial_state is None and self.coupling is not None and self.diagonal:
            z0 = self.to_modal(np.concatenate(self.coupling.steady_state(self.rotor)))   # the linear 1x response
        elif initial_state is None:
            z0 = np.zeros(self.state_size, dtype=complex if self.diagonal else float)
        else:
            z0 = self.to_modal(initial_state) if self.diagonal else np.array(initial_state, dtype=float)
        st = IntegratorState(z0)
        du0 = self.Bz.dot(st.z).real
        if self.forces.periodic:
            f0, _ = self.forces.evaluate(self._u_static + du0, 0)
        else:
            f0, _ = self.forces.evaluate(self._u_static + du0, 0, self.forces.rows(0, 1)[0])
        st.f_dev = f0 - self._f_static + self._kb.dot(du0)
        st.f_old = st.f_dev.copy()
        return st

    def _build_newmark(self):
        rot, n, h, al = self.rotor, self.ndof, self.h, self.hht_alpha
        beta = (1.0 - al) ** 2 / 4.0
        gamma = 0.5 - al
        self.newmark_beta, self.newmark_gamma = beta, gamma
        c0, c2, c3 = 1.0 / (beta * h * h), 1.0 / (beta * h), 1.0 / (2.0 * beta) - 1.0
        m, k = rot.M, rot.K
        cw = rot.C + TWO_PI * self.speed_hz * rot.G
        s = c0 * m + (1.0 + al) * gamma * h * c0 * cw + (1.0 + al) * k
        rq = al * k + c0 * m + (1.0 + al) * gamma * h * c0 * cw
        rv = al * cw + c2 * m - (1.0 + al) * (1.0 - gamma * h * c2) * cw
        ra = c3 * m - (1.0 + al) * h * (1.0 - gamma - gamma * c3) * cw
        lu = scipy.linalg.lu_factor(s)
        tq = scipy.linalg.lu_solve(lu, np.hstack([rq, rv, ra]))
        wq = scipy.linalg.lu_solve(lu, self._inputs())
        eye, zero = np.eye(n), np.zeros((n, n))
        ta = c0 * (tq - np.hstack([eye, zero, zero])) - np.hstack([zero, c2 * eye, c3 * eye])
        tv = np.hstack([zero, eye, h * (1.0 - gamma) * eye]) + h * gamma * ta
        self.T = np.ascontiguousarray(np.vstack([tq, tv, ta]))
        w_unit = np.vstack([wq, h * gamma * c0 * wq, c0 * wq])                       # per unit of force
        self._split_inputs((1.0 + al) * w_unit, -al * w_unit)
        bz = np.zeros((4, 3 * n))
        bz[:, :n] = self.B.T
        self.Bz = bz
        self.H = bz @ self.W                                                          # (4, 4)
        self.O = np.zeros((8, 3 * n))
        self.O[np.arange(8), self.out_dofs.reshape(-1)] = 1.0
        self.diagonal = False
        self.to_physical = None

    def _build_exponential(self):
        """Exact discretisation of the linear part with a first-order-hold bearing force, in modal coordinates.

        ``y = [x, v]``, ``y' = A y + B_f f(t)``, ``A = V diag(lambda) V^-1``; with ``f`` linear in time over a step,
        mode r advances as ``w_{n+1} = e^{lambda h} w_n + (p_0 - p_1) g_n + p_1 g_{n+1}`` (``g = V^-1 B_f f``,
        ``p_0 = (e^{lambda h} - 1) / lambda``, ``p_1 = (e^{lambda h} - 1 - lambda h) / (lambda^2 h)``): every mode
        keeps its exact frequency and damping at any step; the only discretisation error is the linear
        interpolation of the 4 bearing forces over a step (second order in h).
        """
        rot, n, h = self.rotor, self.ndof, self.h
        cw = rot.C + TWO_PI * self.speed_hz * rot.G
        minv = np.linalg.inv(rot.M)
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -minv @ rot.K
        a[n:, n:] = -minv @ cw
        bf = np.zeros((2 * n, self._inputs().shape[1]))
        bf[n:] = minv @ self._inputs()
        lam, vec = scipy.linalg.eig(a)
        lu = scipy.linalg.lu_factor(vec)
        gam = scipy.linalg.lu_solve(lu, bf.astype(complex))                             # V^-1 B_f (2n, 4+)
        z = lam * h
        small = np.abs(z) < 1e-4
        em1 = np.expm1(z)
        with np.errstate(divide="ignore", invalid="ignore"):
            p0 = np.where(small, h * (1 + z / 2 + z * z / 6), em1 / lam)
            p1 = np.where(small, h * (0.5 + z / 6 + z * z / 24), (em1 - z) / (lam * lam * h))
        self.T = np.exp(z)                                                              # diagonal (2n,)
        self._split_inputs(p1[:, None] * gam, (p0 - p1)[:, None] * gam)
        self.Bz = np.ascontiguousarray(self.B.T @ vec[:n])                             # (4, 2n): u = Re(Bz w)
        self.H = (self.Bz @ self.W).real
        self.O = np.ascontiguousarray(vec[self.out_dofs.reshape(-1)])                  # (8, 2n)
        self.diagonal = True
        self.eigenvalues = lam
        self._vec, self._vec_lu = vec, lu
        self.to_physical = lambda w: (w @ vec.T).real                                  # (N, 2n) -> [x, v]

    def _inputs(self) -> np.ndarray:
        """The inputs of a step: the 4 bearing force pairs, then the coupling force's x and y (if any)."""
        return self.B if self.coupling is None else np.hstack([self.B, self.coupling.pattern])

    def _split_inputs(self, w: np.ndarray, w_p: np.ndarray) -> None:
        """``W``, ``W_p`` of the bearing forces and the coupling force's step vectors from those of every input."""
        self.W, self.Wp = np.ascontiguousarray(w[:, :4]), np.ascontiguousarray(w_p[:, :4])
        self._drive = None if self.coupling is None else self.coupling.step_vectors(w[:, 4:], w_p[:, 4:], self.h)

    def to_modal(self, y):
        """A physical state ``[x, v]`` (2 ndof,) as the exponential scheme's modal state."""
        return scipy.linalg.lu_solve(self._vec_lu, np.asarray(y, dtype=complex))

    def advance(self, st, n_steps, rec=None, rec_every=1, states=None, bar=None, chunk=4096):
        """Advance ``st`` by ``n_steps`` steps; sample ``k`` of ``rec`` (and ``states``) is the state before the
        ``k rec_every``-th step of this call (so sample 0 is the state at the start of the call).

        Sets ``st.interrupted`` on Ctrl-C (the steps done so far are kept) and ``st.recorded``.
        """
        T, W, Wp, Bz, H, O = self.T, self.W, self.Wp, self.Bz, self.H, self.O
        use_wp = self.scheme == "exponential" or self.hht_alpha != 0.0
        advance = np.multiply if self.diagonal else np.dot      # T is diagonal in modal coordinates
        u_s, f_s, kb = self._u_static, self._f_static, self._kb
        evaluate = self.forces.evaluate
        tol2, max_newton = self.newton_tol_m ** 2, self.max_newton
        exact = self.newton_exact
        eye4 = np.eye(4)
        solve = np.linalg.solve
        nbp = self.steps_per_bpfo
        drive, coupling, h = self._drive, self.coupling, self.h
        z, f_dev, f_old = st.z, st.f_dev, st.f_old
        newton_total, newton_max = st.newton_total, st.newton_max
        n0 = st.steps
        n_ = n0
        recorded = 0
        st.recorded = 0
        periodic = self.forces.periodic
        try:
            k0 = 0
            while k0 < n_steps:
                k1 = min(n_steps, k0 + chunk)
                rows = None if periodic else self.forces.rows(n0 + k0 + 1, n0 + k1 + 1)
                for k in range(k0, k1):
                    if rec is not None and k % rec_every == 0:
                        i = k // rec_every
                        rec[i, :8] = O.dot(z).real
                        rec[i, 8:] = f_dev - kb.dot(Bz.dot(z).real)     # ball-force deviation (K_b u removed)
                        if states is not None:
                            states[i] = z
                        recorded = i + 1
                    n_ = n0 + k
                    j = (n_ + 1) % nbp                 # table step of t_{n+1}
                    zp = advance(T, z)
                    if use_wp:
                        zp += Wp.dot(f_dev)
                    if drive is not None:               # the coupling force over the step (first-order hold)
                        q = coupling.at_step(n_, h)
                        zp += q.real * drive[0] + q.imag * drive[1]
                    up = Bz.dot(zp).real
                    up += u_s                           # relative displacement without the force f_{n+1}
                    u = up + H.dot(f_dev + f_dev - f_old)   # start: force extrapolated from the last two steps
                    # Newton on u = up + H f(u) with f = ball force + K_b u (deviations): J = I + H (K_t - K_b),
                    # small at these steps, so J^-1 ~ I - H (K_t - K_b) unless `exact`; the converged u is the same.
                    ar_now = None if rows is None else rows[k - k0]
                    for it in range(1, max_newton + 1):
                        f, kt = evaluate(u, j) if ar_now is None else evaluate(u, j, ar_now)
                        f -= f_s
                        du_s = u - u_s
                        f += kb.dot(du_s)
                        kt = kt - kb
                        r = u - up - H.dot(f)
                        if exact or it > 3:
                            du = solve(eye4 + H.dot(kt), r)
                        else:
                            du = r - H.dot(kt.dot(r))
                        u -= du
                        f += kt.dot(du)                 # linearised force at the corrected u (O(du^2))
                        if du.dot(du) <= tol2:
                            break
                    else:
                        raise RuntimeError(f"TDSM Newton did not converge at step {n_ + 1} "
                                           f"(t = {(n_ + 1) * self.h:.6g} s)")
                    newton_total += it
                    if it > newton_max:
                        newton_max = it
                    z = zp + W.dot(f)
                    f_old = f_dev
                    f_dev = f
                    n_ += 1
                if bar is not None:
                    bar.update(k1 - k0)
                k0 = k1
        except KeyboardInterrupt:
            st.interrupted = True
        st.z, st.f_dev, st.f_old = z, f_dev, f_old
        st.newton_total, st.newton_max = newton_total, newton_max
        st.steps = n_
        st.recorded = recorded
