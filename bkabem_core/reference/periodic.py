"""The periodic steady state of the time-domain model, found in the frequency domain (harmonic balance).

The same nonlinear model as :class:`bkabem_core.reference.tdsm.Tdsm` (same FE, bearings, damper, gyroscopics), solved for
its BPFO-periodic steady state directly: no start transient, no integration step. It is the frequency-domain
cross-check of the TDSM and the accuracy target of the improved BKA-BEM (docs/validation.md).

Units: SI (m, s, N, rad).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from bkabem_core.bearing.contacts import HertzPair
from bkabem_core.fe.modal import ModalBasis
from bkabem_core.reference.tdsm import Tdsm

TWO_PI = 2.0 * math.pi


@dataclass
class PeriodicSolution:
    """BPFO-periodic steady state of the nonlinear model found in the frequency domain (harmonic balance).

    Attributes
    ----------
    speed_hz, bpfo_hz : float
    orders : ndarray (K,)
        BPFO orders 1..K.
    complex_amplitude : ndarray complex (K, 4, 2)
        ``X`` at LOCATIONS x DIRECTIONS with ``x(t) = Re(X e^{i 2 pi k BPFO t})``, t = 0 at cage angle 0 (the
        convention of :meth:`TdsmResult.order_spectrum` and of BKA-BEM).
    dc_m : ndarray (4, 2)
        Mean absolute displacement [m] (static sag included).
    bearing_complex_amplitude : ndarray complex (K, 2, 2)
        Rotor-minus-housing displacement at (de, nde) x DIRECTIONS [m].
    bearing_dc_m : ndarray (2, 2)
        Mean rotor-minus-housing displacement [m].
    linearised : bool
        True: one Newton step from the static equilibrium (the linear time-periodic model); False: converged
        nonlinear harmonic balance.
    iterations : int
    residual_m : float
        Last Newton update (max norm over the harmonics of the 4 bearing coordinates) [m].
    converged : bool
    wall_time_s : float
    n_time : int
        Time samples per BPFO period of the alternating frequency-time force evaluation.
    """

    speed_hz: float
    bpfo_hz: float
    orders: np.ndarray
    complex_amplitude: np.ndarray
    dc_m: np.ndarray
    bearing_complex_amplitude: np.ndarray
    bearing_dc_m: np.ndarray
    linearised: bool
    iterations: int
    residual_m: float
    converged: bool
    wall_time_s: float
    n_time: int



def harmonic_balance(model: Tdsm, n_orders: int = 50, n_time: int = 8192, linearised: bool = False,
                     tol_m: float = 1e-14, max_iter: int = 30, basis: ModalBasis | None = None,
                     cutoff_hz: float | None = None, initial: np.ndarray | None = None) -> PeriodicSolution:
    """The BPFO-periodic steady state of this nonlinear model, solved in the frequency domain.

    Harmonic balance with alternating frequency-time evaluation of the ball forces, condensed onto the 4
    bearing coordinates: with ``U_k`` the harmonics (k = -K..K) of the relative displacements ``u - u_s``,
    the FE (with its linear bearing springs ``K_r`` inside ``K``, compensated in the force) gives
    ``U_k = G(w_k) [F(u_s + U(t), theta(t)) - F_s + K_r U]_k`` with the 4 x 4 receptance
    ``G(w) = B^T (K - w^2 M + i w (C + Omega G))^-1 B`` of the reduced model (:class:`ModalBasis`). Newton's
    method on the 4 (2K+1) complex unknowns; the Jacobian ``I + G(w_k) (K_t - K_r)_{k-j}`` couples the orders through the harmonics of the
    tangent stiffness ``K_t(t)`` (ball passage and dent). The forces are evaluated at ``n_time`` instants per
    BPFO period (the dent edges need thousands) and transformed by FFT.

    ``linearised=True`` stops after the first Newton step from the static equilibrium: the linear
    time-periodic (parametric) model, in which the ball forces and stiffnesses at the static displacement
    are the excitation and the time-varying stiffness.

    Same equations as :meth:`Tdsm.run` (HertzPair forces, same FE, damper, gyroscopics); only the periodic part is
    computed, so no start transient. The harmonics above ``n_orders`` are truncated.
    """
    if model.bearing_model != "hertz":
        raise ValueError("harmonic_balance needs the Hertz bearing model")
    if not model.one_ball_set:
        raise ValueError("harmonic_balance: the DE and NDE bearings have two ball-pass periods (different ball sets "
                         "or kinematics); their steady state is not BPFO-periodic (validate_lines fits its lines)")
    t0 = time.perf_counter()
    m = model
    rot = m.rotor
    kk = int(n_orders)
    ks = np.arange(-kk, kk + 1)
    nk = ks.size
    w = TWO_PI * m.bpfo_hz * ks
    grid = HertzPair(m.bearings, m.cage_speed_rad_s * m.bpfo_period_s * np.arange(n_time) / n_time, m.films_m,
                     m.axial_m)
    k_ref = m._kb                                       # the FE's linear bearing springs (inside rot.K)
    kr = np.diag(k_ref)
    # receptances of the reduced model (ModalBasis: tested against the full FE to < 0.01 dB): bearing relative
    # displacements (4) and the 8 outputs per unit force pair across each bearing
    if basis is None:
        if cutoff_hz is None:
            cutoff_hz = 1.25 * m.case.max_frequency_hz
        sel = np.zeros((12, rot.ndof))
        sel[:4] = m.B.T
        sel[np.arange(4, 12), m.out_dofs.reshape(-1)] = 1.0
        basis = ModalBasis(rot, m.B, sel, cutoff_hz)
    pos = ks >= 0
    wp = w[pos]
    resp = basis.solve_unit(wp, np.full(wp.size, TWO_PI * m.speed_hz))      # (K+1, 12, 4)
    resp = np.concatenate([np.conj(resp[:0:-1]), resp])                     # k = -K..K
    g = resp[:, :4, :]                                                      # (nk, 4, 4)
    hb_out = resp[:, 4:, :]                                                 # (nk, 8, 4)
    diff = (ks[:, None] - ks[None, :]) % n_time
    u_harm = np.zeros((nk, 4), dtype=complex) if initial is None else np.array(initial, dtype=complex)
    f_s = m._f_static
    converged = False
    it = 0
    nrm = float("inf")
    for it in range(1, max_iter + 1):
        u_t = _synth(u_harm, ks, n_time) + m._u_static
        f_t, kt_t = grid.forces_many(u_t)
        phi = np.fft.fft(f_t - f_s, axis=0)[ks % n_time] / n_time + u_harm * kr   # (nk, 4)
        res = u_harm - np.einsum("kij,kj->ki", g, phi)
        dk = np.fft.fft(kt_t, axis=0) / n_time                                     # (N, 4, 4)
        dk[0] -= k_ref
        jac = np.einsum("aij,abjl->aibl", g, dk[diff]).reshape(4 * nk, 4 * nk)
        jac[np.diag_indices(4 * nk)] += 1.0
        if it == 1:
            phi0, dk0 = phi - u_harm * kr, dk                                      # at the static state
        du = np.linalg.solve(jac, res.reshape(-1)).reshape(nk, 4)
        du = 0.5 * (du + np.conj(du[::-1]))                                        # keep u(t) real
        u_harm -= du
        nrm = float(np.max(np.abs(du)))
        if linearised or nrm <= tol_m:
            converged = nrm <= tol_m or linearised
            break
    if linearised:
        # the linear time-periodic model's force: F(u_s) - F_s - (K_t(u_s) - K_r) * U (a convolution)
        phi = phi0 - np.einsum("abjl,bl->aj", dk0[diff], u_harm)
    else:
        u_t = _synth(u_harm, ks, n_time) + m._u_static
        f_t, _ = grid.forces_many(u_t)
        phi = np.fft.fft(f_t - f_s, axis=0)[ks % n_time] / n_time + u_harm * kr
    x = np.einsum("kaj,kj->ka", hb_out, phi).reshape(nk, 4, 2)
    rel = np.stack([x[:, 0] - x[:, 1], x[:, 2] - x[:, 3]], axis=1)                # (nk, 2, 2)
    i0 = kk
    q_s = m.static.q_m[m.out_dofs]
    rel_s = np.stack([q_s[0] - q_s[1], q_s[2] - q_s[3]])
    return PeriodicSolution(
        speed_hz=m.speed_hz, bpfo_hz=m.bpfo_hz, orders=ks[i0 + 1:], complex_amplitude=2.0 * x[i0 + 1:],
        dc_m=q_s + x[i0].real, bearing_complex_amplitude=2.0 * rel[i0 + 1:], bearing_dc_m=rel_s + rel[i0].real,
        linearised=linearised, iterations=it, residual_m=nrm, converged=converged,
        wall_time_s=time.perf_counter() - t0, n_time=n_time)


def _synth(u_harm, ks, n_time):
    spec = np.zeros((n_time, 4), dtype=complex)
    spec[ks % n_time] = u_harm
    return np.fft.ifft(spec, axis=0).real * n_time
