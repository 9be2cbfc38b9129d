"""BKA-BEM with the bearings' time-varying stiffness: one harmonic-balance Newton step from the quasi-static path.

The plain method (:class:`bkabem_core.harmonic.BkaBem`) drives the LTI FE with the quasi-static relative
displacement of each bearing through its mean stiffness ``K_b``. What it leaves out is that the bearing stiffness
itself varies with the cage angle: the dent unloads a ball once per ball pass, and the ball set's own stiffness
varies as it turns. Those variations couple the orders and make the plain method 1-3 dB off at high speed
(docs/validation.md). The exact periodic steady state is the harmonic balance of the nonlinear model
(:func:`bkabem_core.periodic.harmonic_balance`, ~0.1-0.5 s per speed); this module gets its accuracy at the cost
of a plain spectrum, because almost everything it needs does not depend on the speed:

* speed-independent, made once: the quasi-static path ``u_qs(theta)`` of every bearing (the excitation itself),
  truncated to the model's orders, ``U_0``; the ball forces and tangent stiffnesses along it, whose spectra give the
  residual force ``Phi_0 = F[f(u_0) - f_s + K_b U_0]`` and the stiffness modulation ``dK = F[K_t(u_0)] - K_b``;
* per speed: the FE receptances at the bearings ``G_k`` from the line modes (a pole sum), one Newton step of the
  harmonic balance from ``U_0``::

      (I + G_k dK_{k-j}) dU_j = -(U_0 - G_k Phi_0)_k        (Hill's system, 4 (2K + 1) unknowns)

  solved by GMRES (the Toeplitz operator of ``dK`` is made once; a block-diagonal preconditioner; a few
  iterations), then the ball forces at ``U_1 = U_0 + dU`` once more in the time domain and the response
  ``X_k = H_k Phi(U_1)_k``.

Starting from the quasi-static path is what makes one step enough: that path is exact at low frequency, and the
dynamic deviation from it is small. The result agrees with the full harmonic balance (and so with the TDSM) to
about 0.1 dB (tests/test_hill.py, docs/validation.md).

Units: SI (m, s, N, rad).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .excitation import quasi_static_path_m
from .harmonic import BkaBem, Spectrum
from .machine import BEARINGS
from .modal import LineModes
from .tdsm import HertzPair

TWO_PI = 2.0 * math.pi
# HertzPair order [de x, de y, nde x, nde y] -> BkaBem's input patterns [(de, v), (de, h), (nde, v), (nde, h)]
_PATTERN_OF = np.array([1, 0, 3, 2])
# bearing relative displacements (HertzPair order) from BkaBem's 8 outputs (LOCATIONS x DIRECTIONS)
_REL = np.zeros((4, 8))
for _i, (_r, _h) in enumerate(((1, 3), (0, 2), (5, 7), (4, 6))):
    _REL[_i, _r], _REL[_i, _h] = 1.0, -1.0


class HillCorrection:
    """The improved BKA-BEM of a model: its spectra with the bearings' time-varying stiffness (module docstring).

    Parameters
    ----------
    model : BkaBem
        The plain model (its machine, orders and line modes are used).
    n_time : int
        Instants per ball pass of the ball-force evaluation at the solution (512 resolve the dent ramps: 43
        instants per ramp; 1024 change the result by < 0.001 dB).
    n_precompute : int
        Instants per ball pass of the quasi-static path and its spectra (made once).
    tol : float
        Relative residual of the GMRES solve (1e-4 changes the result by < 0.002 dB against 1e-8).

    Attributes
    ----------
    preparation_time_s : float
    last_iterations : int
        GMRES iterations of the last :meth:`spectrum`.
    """

    def __init__(self, model: BkaBem, n_time: int = 512, n_precompute: int = 4096, tol: float = 1e-4):
        t0 = time.perf_counter()
        if not model.is_order_set:
            raise ValueError("HillCorrection: the model's lines must all be BPFO orders (an outer-race or healthy "
                             "bearing set, BkaBem(..., baseline=False)); other defect kinds are not covered yet")
        self.model = model
        self.tol = float(tol)
        machine = model.machine
        sites = [machine.sites[b] for b in BEARINGS]
        kk = int(model.orders.max())
        self.n_harmonics = kk
        self._ks = np.arange(-kk, kk + 1)
        orders = np.arange(1, kk + 1)
        if np.array_equal(model.orders, orders):
            self.modes = model.line_modes
            self._rows = np.arange(kk)
        else:                                   # the coupling needs every harmonic up to the highest order
            self.modes = LineModes(model.basis, orders * model.bpfo_per_hz)
            self._rows = model.orders - 1
        z = sites[0].bearing.geometry.n_balls
        bearings = tuple(s.bearing for s in sites)
        axial = tuple(float(s.state.displacement_m[2]) for s in sites)
        self._u_s = np.concatenate([s.state.displacement_m[:2] for s in sites])         # [de x, y, nde x, y]
        self._f_s = np.concatenate([-s.radial_load_n for s in sites])                   # ball force = the load
        self._kb = np.concatenate([s.stiffness_n_m for s in sites])                      # (x, y) per bearing
        # the quasi-static paths of both bearings over one ball pitch (the excitation), truncated to K harmonics
        n0 = int(n_precompute)
        theta = TWO_PI / z * np.arange(n0) / n0
        path = np.hstack([quasi_static_path_m(s.bearing, s.radial_load_n, s.axial_load_n, theta)[0]
                          for s in sites])                                                # (n0, 4)
        ks = self._ks
        self._u0 = (np.fft.fft(path - self._u_s, axis=0) / n0)[ks % n0]                # (2K+1, 4)
        u_tr = self._synth(self._u0, n0) + self._u_s
        f_t, kt_t = HertzPair(bearings, theta, axial_m=axial).forces_many(u_tr)
        self._phi0 = (np.fft.fft(f_t - self._f_s, axis=0) / n0)[ks % n0] + self._u0 * self._kb
        dk = np.fft.fft(kt_t, axis=0) / n0
        dk[0] -= np.diag(self._kb)
        # the Toeplitz operator of the stiffness modulation on harmonics -K..K, one per bearing (dK is block
        # diagonal: a bearing's stiffness couples only its own coordinates): T_b[(k, i), (j, l)] = dK_{k-j}[b i, b l]
        diff = (ks[:, None] - ks[None, :]) % n0
        self._t = [np.ascontiguousarray(dk[diff][:, :, 2 * b:2 * b + 2, 2 * b:2 * b + 2].transpose(0, 2, 1, 3)
                                        .reshape(2 * ks.size, 2 * ks.size)) for b in range(2)]
        self.n_time = int(n_time)
        self._pair = HertzPair(bearings, TWO_PI / z * np.arange(self.n_time) / self.n_time, axial_m=axial)
        self.last_iterations = 0
        self.preparation_time_s = time.perf_counter() - t0

    @staticmethod
    def _to_grid(spec, ks, n):
        full = np.zeros((n,) + spec.shape[1:], complex)
        full[ks % n] = spec
        return full

    def _synth(self, spec, n):
        return (np.fft.ifft(self._to_grid(spec, self._ks, n), axis=0) * n).real

    def receptances(self, speed_hz: float):
        """``(H, G)``: outputs (2K+1, 8, 4) and bearing relative displacements (2K+1, 4, 4) per unit force pair,
        harmonics -K..K, inputs in HertzPair order [m/N]."""
        h_pos = self.modes.receptance(speed_hz)[:, :, _PATTERN_OF]                        # (K, 8, 4)
        h0 = self.modes.static[:, _PATTERN_OF].astype(complex)
        h = np.concatenate([np.conj(h_pos[::-1]), h0[None], h_pos])
        return h, np.einsum("ij,kjl->kil", _REL, h)

    def spectrum(self, speed_hz: float) -> Spectrum:
        """The improved BKA-BEM spectrum at one shaft speed [Hz] (same fields as :meth:`BkaBem.spectrum`)."""
        f = float(speed_hz)
        if not (math.isfinite(f) and f > 0.0):
            raise ValueError(f"speed_hz: must be finite and > 0 (got {speed_hz})")
        h, g = self.receptances(f)
        u0, phi0 = self._u0, self._phi0
        r = u0 - np.einsum("kij,kj->ki", g, phi0)
        # Hill's system (I + G T) dU = -r by GMRES: T is the Toeplitz operator of dK (made once), G per harmonic
        (t_de, t_nde), n_k = self._t, self._ks.size
        tv = np.empty((n_k, 4), complex)

        def apply(v):                                   # (I + G T) v
            x = v.reshape(n_k, 4)
            tv[:, :2] = (t_de @ x[:, :2].ravel()).reshape(n_k, 2)
            tv[:, 2:] = (t_nde @ x[:, 2:].ravel()).reshape(n_k, 2)
            return v + (g @ tv[:, :, None]).ravel()

        du, self.last_iterations = _gmres(apply, -r.ravel(), self.tol, 60)
        du = du.reshape(n_k, 4)
        u1 = u0 + du
        n = self.n_time
        f1 = self._pair.forces_only(self._synth(u1, n) + self._u_s)
        phi1 = (np.fft.fft(f1 - self._f_s, axis=0) / n)[self._ks % n] + u1 * self._kb
        x = np.einsum("kij,kj->ki", h, phi1)                                               # (2K+1, 8)
        kk = self.n_harmonics
        disp = 2.0 * x[kk + 1:][self._rows].reshape(-1, 4, 2)
        dc = (h[kk] @ (phi1[kk] + self._kb * self._u_s)).real.reshape(4, 2)
        m = self.model
        return Spectrum(speed_hz=f, orders=m.orders.copy(), frequency_hz=m.orders * m.bpfo_per_hz * f,
                        displacement=disp, dc_m=dc, fault_frequencies_hz=m.fault_multipliers.at_speed(f))


def _gmres(apply, b, tol: float, max_iter: int):
    """Unrestarted GMRES with Givens rotations for ``A x = b`` (A given by ``apply``): (x, iterations).

    Raises ``RuntimeError`` if the relative residual is not below ``tol`` after ``max_iter`` iterations.
    """
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros_like(b), 0
    q = np.empty((max_iter + 1, b.size), complex)
    qc = np.empty((max_iter + 1, b.size), complex)               # the conjugates, kept (no copy per product)
    hess = np.zeros((max_iter + 1, max_iter), complex)
    cs = np.zeros(max_iter, complex)
    sn = np.zeros(max_iter, complex)
    e = np.zeros(max_iter + 1, complex)
    e[0] = beta
    q[0] = b / beta
    np.conjugate(q[0], out=qc[0])
    for j in range(max_iter):
        w = apply(q[j])
        h = qc[:j + 1] @ w                             # classical Gram-Schmidt, twice (as stable as modified)
        w = w - h @ q[:j + 1]
        h2 = qc[:j + 1] @ w
        w = w - h2 @ q[:j + 1]
        hess[:j + 1, j] = h + h2
        nrm = float(np.linalg.norm(w))
        hess[j + 1, j] = nrm
        for i in range(j):                            # the previous rotations on the new column
            a, c = hess[i, j], hess[i + 1, j]
            hess[i, j] = np.conj(cs[i]) * a + np.conj(sn[i]) * c
            hess[i + 1, j] = -sn[i] * a + cs[i] * c
        a, c = hess[j, j], hess[j + 1, j]
        r = np.hypot(abs(a), abs(c))
        cs[j], sn[j] = (a / r, c / r) if r > 0 else (1.0, 0.0)
        hess[j, j], hess[j + 1, j] = r, 0.0
        e[j + 1] = -sn[j] * e[j]
        e[j] = np.conj(cs[j]) * e[j]
        if abs(e[j + 1]) <= tol * beta or r == 0.0:
            y = np.linalg.solve(np.triu(hess[:j + 1, :j + 1]), e[:j + 1])
            return y @ q[:j + 1], j + 1
        q[j + 1] = w / nrm
        np.conjugate(q[j + 1], out=qc[j + 1])
    raise RuntimeError(f"GMRES did not converge in {max_iter} iterations (residual {abs(e[max_iter]) / beta:.1e})")

