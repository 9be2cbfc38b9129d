"""The reduced model diagonalised line by line: the poles and residues of every line's receptance.

Along line j the frequency is tied to the shaft speed, ``omega = nu_j Omega``, so the dynamic stiffness of the
reduced model (:class:`bkabem_core.fe.modal.ModalBasis`) is a fixed quadratic pencil in ``s = i omega``::

    Z_j(s) = K + s C + s^2 (M - i sigma_j G),        sigma_j = 1 / nu_j

(the gyroscopic term ``i omega Omega G = -i s^2 sigma G`` joins the mass). Its state matrix, diagonalised once per
line, gives the receptance from the basis's input patterns to its outputs at any frequency as a pole sum
(:class:`LineModes`). That eigen-decomposition is the whole cost of preparing a model with hundreds of lines
(inner-race and ball defects: 350-670 lines), so it is made cheap in two exact steps:

**A real form.** The FE has no coupling between its two bending planes (x, beta) and (y, alpha) except through
the gyroscopic matrix, which couples only them (bearing elements have no cross stiffness; tested on the assembled
matrices). With the basis built plane by plane (``ModalBasis.planes``) and the y-plane coordinates multiplied by
``i`` (``D = diag(1, i)``), ``D^H Z D = K + s C + s^2 (M + sigma G~)`` with ``G~ = Re(D^H (-i G) D)`` real and
symmetric: the pencil is real, its 2m-state matrix is real (a real ``dgeev``, ~3x cheaper than the complex one),
and the receptance is ``O D Z~^-1 D^H P``. The poles are the same; only inputs and outputs are rotated.

**Anchors and refinement.** The pencil depends on ``sigma`` only, and for most lines of a defect's spectrum the
``sigma`` of neighbouring lines are close (``nu`` from 20 to 300, ``sigma`` within a few 1e-4 of each other). Lines
are grouped by ``sigma``; one line of each group (its *anchor*) is decomposed exactly, ``S_a V_a = V_a Lambda_a``.
With ``B(sigma) = diag(I, M + sigma G~)`` linear in ``sigma``, every other line of the group, ``delta = sigma -
sigma_a``, is in the anchor's coordinates (``v = V_a x``) the pencil::

    Lambda_a x = lambda (I + delta Q) x,      Q = V_a^-1 B(sigma_a)^-1 diag(0, G~) V_a      (made once per anchor)

whose eigenpairs are found by the fixed-point (Jacobi) iteration from ``x = e_r``::

    lambda_r = lambda_a,r / (1 + delta (Q x_r)_r),      x_qr = -delta lambda_r (Q x_r)_q / (lambda_r - lambda_a,q)

(one product ``Q X`` per sweep, half the columns: the others are their conjugates), to a change below ``tol`` in
every entry (converged, not truncated: the result is the exact eigen-decomposition to that tolerance). A line whose
iteration does not converge in ``max_sweeps``, loses a pole, or merges two, is decomposed exactly instead (and
becomes an anchor). Measured against the complex exact decomposition over every line of the fault library
(tests/unit/test_faults.py): receptances within 1e-7 of the exact ones at every speed up to the case's maximum.

Units: SI (m, s, N, rad).
"""

from __future__ import annotations

import math
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

TWO_PI = 2.0 * math.pi

#: Methods of :class:`LineModes`: ``"auto"`` (real form with anchors when the basis is plane-separated, else
#: complex), ``"real"`` (real form, every line exact), ``"complex"`` (the complex state matrix of every line).
METHODS = ("auto", "real", "complex")


class LineModes:
    """The reduced model diagonalised line by line: poles, input participations and output shapes.

    The receptance from the basis's input patterns to its outputs along line j at frequency omega is

        H_j(omega) = sum_r p_{j,r} a_{j,r}^T / (i omega - lambda_{j,r})

    with ``a = V^-1 [0; M_j^-1 P]`` (participation of each input pattern) and ``p = O V[:m]`` (output shapes) for
    the eigenvectors ``V`` of the line's state matrix (module docstring: real form, anchors). The lines are
    independent groups; they run on two threads (LAPACK releases the GIL), BLAS limited to one thread each.

    Parameters
    ----------
    basis : ModalBasis
    multipliers : ndarray (K,)
        ``nu_j`` [-] (line frequency per shaft frequency), > 0.
    method : {"auto", "real", "complex"}
        :data:`METHODS`.
    group_width : float
        Largest ``|sigma - sigma_anchor|`` of a group relative to ``sigma_anchor`` [-].
    group_width_abs : float
        ... and absolute [-] (the refinement's contraction grows with ``delta |lambda|`` at the 3-4 kHz pairs).
    tol : float
        Convergence of the refinement: largest change of an eigenvector entry in the anchor's coordinates
        (normalised to 1 on its own anchor mode) in the last sweep.
    max_sweeps : int
        Sweeps before a line is decomposed exactly instead.

    Attributes
    ----------
    poles : ndarray complex (K, 2m) [rad/s]
    participation : ndarray complex (K, 2m, P) [1/(N s)]
    shapes : ndarray complex (K, 2m, U) [m s/m]
    static : ndarray (U, P)
        Static receptance [m/N] (exact: the basis holds the static residual vectors).
    stats : dict
        ``method``, ``exact`` (lines decomposed exactly, anchors included), ``refined``, ``sweeps_mean``,
        ``sweeps_max``, ``fallbacks`` (refinements that failed and were decomposed exactly).
    """

    def __init__(self, basis, multipliers: np.ndarray, method: str = "auto", group_width: float = 0.05,
                 group_width_abs: float = 2.0e-3, tol: float = 1e-10, max_sweeps: int = 20):
        nu = np.asarray(multipliers, dtype=float).reshape(-1)
        if np.any(~np.isfinite(nu)) or np.any(nu <= 0.0):
            raise ValueError("multipliers: must be finite and > 0")
        if method not in METHODS:
            raise ValueError(f"method: one of {', '.join(METHODS)} (got {method!r})")
        self.basis = basis
        self.multipliers = nu
        n = basis.size
        n_k, n_p, n_u = nu.size, basis.inputs.shape[1], basis.outputs.shape[0]
        self.poles = np.empty((n_k, 2 * n), complex)
        self.participation = np.empty((n_k, 2 * n, n_p), complex)
        self.shapes = np.empty((n_k, 2 * n, n_u), complex)
        real = method != "complex" and getattr(basis, "planes", None) is not None
        form = _RealForm(basis) if real else _ComplexForm(basis)
        sigma = 1.0 / nu
        if real and method == "auto":
            groups = _groups(sigma, group_width, group_width_abs)
        else:
            groups = [(i, []) for i in range(n_k)]

        stop = threading.Event()

        def run(group):
            anchor, members = group
            sweeps, fallbacks = [], 0
            if stop.is_set():
                return sweeps, fallbacks
            a = form.exact(sigma[anchor], keep=bool(members))
            self._store(anchor, a)
            for side in (1, -1):                        # outwards on either side of the anchor, warm-started
                here, warm = a, {}
                for i in (j for j in members if (sigma[j] > sigma[anchor]) == (side > 0)):
                    if stop.is_set():
                        return sweeps, fallbacks
                    got = form.refine(here, sigma[i], tol, max_sweeps, warm)
                    if got is None:                      # too far for this anchor: the line is the next one
                        fallbacks += 1
                        here, warm = form.exact(sigma[i], keep=True), {}
                        self._store(i, here)
                        continue
                    sweeps.append(got["sweeps"])
                    self._store(i, got)
            return sweeps, fallbacks

        # one BLAS thread per worker: two workers each running a 2-thread OpenBLAS on these small matrices
        # oversubscribe a 2-core machine (measured 10-25 s instead of 2.2 s for the 50 lines of the default case)
        # an interrupt (SIGINT, SIGTERM) stops the workers at their next line instead of waiting for all lines
        pool = ThreadPoolExecutor(max_workers=2)
        try:
            with threadpool_limits(limits=1, user_api="blas"):
                done = list(pool.map(run, sorted(groups, key=lambda g: -len(g[1]))))
        except BaseException:
            stop.set()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        self.static = basis.outputs @ np.linalg.solve(basis.K, basis.inputs)
        self.w_per_hz = TWO_PI * nu
        self._shapes_t = None
        sw = [k for s, _ in done for k in s]
        self.stats = {"method": ("real+anchors" if method == "auto" else "real") if real else "complex",
                      "lines": int(n_k), "exact": int(n_k - len(sw)), "refined": len(sw),
                      "fallbacks": int(sum(f for _, f in done)), "sweeps_mean": float(np.mean(sw)) if sw else 0.0,
                      "sweeps_max": int(max(sw)) if sw else 0}

    def _store(self, i: int, d: dict) -> None:
        self.poles[i] = d["poles"]
        self.participation[i] = d["participation"]
        self.shapes[i] = d["shapes"]

    def subset(self, lines: np.ndarray) -> "LineModes":
        """The same decomposition restricted to the lines at indices ``lines`` (no new eigen-decomposition)."""
        lines = np.asarray(lines, dtype=int)
        other = object.__new__(LineModes)
        other.__dict__.update(self.__dict__)
        for name in ("multipliers", "poles", "participation", "shapes", "w_per_hz"):
            setattr(other, name, getattr(self, name)[lines])
        other._shapes_t = None
        return other

    def extended(self, multipliers: np.ndarray) -> "LineModes":
        """Line modes of ``multipliers``: those already decomposed here are reused, only the new ones are made."""
        nu = np.asarray(multipliers, dtype=float)
        pos = {float(v): i for i, v in enumerate(self.multipliers)}
        new = np.array(sorted({float(v) for v in nu if float(v) not in pos}))
        more = LineModes(self.basis, new) if new.size else None
        other = object.__new__(LineModes)
        other.__dict__.update(self.__dict__)
        src = [(self, pos[float(v)]) if float(v) in pos else (more, int(np.searchsorted(new, float(v))))
               for v in nu]
        for name in ("poles", "participation", "shapes"):
            setattr(other, name, np.stack([getattr(m, name)[i] for m, i in src]) if src else
                    getattr(self, name)[:0])
        other.multipliers = nu
        other.w_per_hz = TWO_PI * nu
        other._shapes_t = None
        return other

    def receptance(self, speed_hz: float, lines: np.ndarray | None = None) -> np.ndarray:
        """``H_j(omega_j)`` (K, U, P) [m/N] at shaft speed ``speed_hz`` [Hz] (lines: a subset of indices)."""
        sl = slice(None) if lines is None else lines
        iw = 1j * self.w_per_hz[sl] * float(speed_hz)
        g = 1.0 / (iw[:, None] - self.poles[sl])                                       # (K, 2m)
        if self._shapes_t is None:
            self._shapes_t = np.ascontiguousarray(np.swapaxes(self.shapes, 1, 2))    # (K, U, 2m)
        return np.matmul(self._shapes_t[sl], g[:, :, None] * self.participation[sl])

    def receptance_at(self, omega_rad_s: np.ndarray, line: int) -> np.ndarray:
        """``H_j(omega)`` (W, U, P) [m/N] of one line at frequencies ``omega_rad_s`` (W,) [rad/s], in the
        mode-acceleration form of the compiled kernel (the static part exact)."""
        iw = 1j * np.asarray(omega_rad_s, dtype=float)
        lam = self.poles[line]
        g = iw[:, None] / ((iw[:, None] - lam[None]) * lam[None])                      # (W, 2m)
        modal = self.shapes[line][:, :, None] * self.participation[line][:, None, :]    # (2m, U, P)
        return self.static[None] + (g @ modal.reshape(lam.size, -1)).reshape(iw.size, *modal.shape[1:])


def _groups(sigma: np.ndarray, width: float, width_abs: float) -> list:
    """Lines grouped around anchors: (anchor index, [member indices]) with ``|sigma - sigma_anchor| <=
    min(width sigma_anchor, width_abs)``; members sorted by distance from the anchor (warm starts)."""
    order = np.argsort(sigma)
    s = sigma[order]
    groups = []
    i = 0
    while i < s.size:
        reach = lambda a: min(width * a, width_abs)
        # the anchor as far up as it still covers the first line of the group
        hi = i
        while hi + 1 < s.size and s[hi + 1] - reach(s[hi + 1]) <= s[i]:
            hi += 1
        a = hi
        end = a
        while end + 1 < s.size and s[end + 1] <= s[a] + reach(s[a]):
            end += 1
        members = [int(order[j]) for j in range(i, end + 1) if j != a]
        members.sort(key=lambda j: abs(sigma[j] - s[a]))
        groups.append((int(order[a]), members))
        i = end + 1
    return groups


class _ComplexForm:
    """Every line's complex state matrix decomposed exactly (the form for any basis; the reference)."""

    def __init__(self, basis):
        self.b = basis
        self.n = basis.size

    def exact(self, sigma: float, keep: bool = False) -> dict:
        b, n = self.b, self.n
        s = np.zeros((2 * n, 2 * n), complex)
        s[:n, n:] = np.eye(n)
        m_inv = np.linalg.inv(b.M - (1j * sigma) * b.G)
        s[n:, :n] = -m_inv @ b.K
        s[n:, n:] = -m_inv @ b.C
        lam, vec = np.linalg.eig(s)
        part = np.linalg.solve(vec, np.concatenate([np.zeros((n, b.inputs.shape[1]), complex),
                                                     m_inv @ b.inputs]))
        return {"poles": lam, "participation": part, "shapes": (b.outputs @ vec[:n, :]).T}

    def refine(self, anchor, sigma, tol, max_sweeps, warm):          # pragma: no cover - never grouped
        return None


def _series(lam_a: np.ndarray, q: np.ndarray, h: np.ndarray, order: int):
    """Perturbation series of the eigenpairs ``h`` of ``Lambda_a x = lambda (I + delta Q) x`` about delta = 0.

    With ``x_r = 1`` on its own anchor mode, ``lambda = sum_k delta^k l_k``, ``x = sum_k delta^k x_k``; order k::

        l_k   = -sum_{i<k} l_i (Q x_{k-1-i})_r
        x_k,q = (sum_{1<=i<=k} l_i x_{k-i,q} + sum_{i<k} l_i (Q x_{k-1-i})_q) / (lambda_a,q - lambda_a,r),  q != r

    One product ``Q x_k`` per order. Returns ``l`` (order + 1, H) and ``x`` (order + 1, 2m, H)."""
    n2, nh = lam_a.size, h.size
    cols = np.arange(nh)
    lam_k = np.zeros((order + 1, nh), complex)
    x_k = np.zeros((order + 1, n2, nh), complex)
    qx = np.zeros((order + 1, n2, nh), complex)
    lam_k[0] = lam_a[h]
    x_k[0, h, cols] = 1.0
    qx[0] = q[:, h]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_gap = 1.0 / (lam_a[:, None] - lam_a[h][None, :])
    inv_gap[h, cols] = 0.0
    inv_gap[~np.isfinite(inv_gap)] = 0.0          # exactly repeated anchor poles: no series for that pair
    tmp = np.empty((n2, nh), complex)
    part = np.empty((n2, nh), complex)
    for k in range(1, order + 1):
        lam_k[k] = -sum(lam_k[i] * qx[k - 1 - i, h, cols] for i in range(k))
        num = x_k[k]                                # the two sums accumulated in place, each in its own order
        np.multiply(lam_k[1][None, :], x_k[k - 1], out=num)
        for i in range(2, k + 1):
            num += np.multiply(lam_k[i][None, :], x_k[k - i], out=tmp)
        np.multiply(lam_k[0][None, :], qx[k - 1], out=part)
        for i in range(1, k):
            part += np.multiply(lam_k[i][None, :], qx[k - 1 - i], out=tmp)
        num += part
        num *= inv_gap
        if k < order:
            qx[k] = q @ x_k[k]
    return lam_k, x_k


class _RealForm:
    """The real, plane-rotated form of the line pencils (module docstring)."""

    series_order = 10

    def __init__(self, basis):
        y = np.asarray(basis.planes, dtype=bool)
        d = np.where(y, 1j, 1.0)
        gt = np.conj(d)[:, None] * (-1j * basis.G) * d[None, :]
        if np.abs(gt.imag).max() > 1e-12 * max(np.abs(gt).max(), 1e-300):
            raise ValueError("LineModes: the basis's gyroscopic matrix couples a plane with itself")
        self.n = basis.size
        self.M, self.K, self.C = basis.M, basis.K, basis.C
        self.Gt = 0.5 * (gt.real + gt.real.T)
        self.P = np.conj(d)[:, None] * basis.inputs                 # D^H P: y-plane patterns x (-i)
        self.O = basis.outputs * d[None, :]                          # O D
        self.n_p = basis.inputs.shape[1]

    def _state(self, sigma: float):
        """Real state matrix (2m, 2m), ``[0; M~^-1 P~]`` (2m, P) and ``M~^-1 G~`` (m, m) at ``sigma``."""
        n, n_p = self.n, self.n_p
        lu = scipy.linalg.lu_factor(self.M + sigma * self.Gt, check_finite=False)
        rhs = np.hstack([self.K, self.C, self.P.real, self.P.imag, self.Gt])
        sol = scipy.linalg.lu_solve(lu, rhs, check_finite=False)
        s = np.zeros((2 * n, 2 * n))
        s[:n, n:] = np.eye(n)
        s[n:, :n] = -sol[:, :n]
        s[n:, n:] = -sol[:, n:2 * n]
        y = np.zeros((2 * n, n_p), complex)
        y[n:] = sol[:, 2 * n:2 * n + n_p] + 1j * sol[:, 2 * n + n_p:2 * n + 2 * n_p]
        return s, y, sol[:, 2 * n + 2 * n_p:]

    def _finish(self, lam, vec, y) -> dict:
        lu = scipy.linalg.lu_factor(vec, check_finite=False)
        piv = np.abs(np.diag(lu[0]))
        if not np.all(np.isfinite(piv)) or piv.min() <= 1e-13 * piv.max():
            return None
        return {"poles": lam, "participation": scipy.linalg.lu_solve(lu, y, check_finite=False),
                "shapes": (self.O @ vec[:self.n]).T, "lu": lu}

    def exact(self, sigma: float, keep: bool = False) -> dict:
        s, y, mg = self._state(sigma)
        lam, vec = np.linalg.eig(s)
        out = self._finish(lam, vec, y)
        if out is None:
            raise FloatingPointError(f"LineModes: defective eigenvectors at sigma = {sigma:.6g}")
        if keep:                                         # an anchor: what its group's refinements need
            n = self.n
            g = np.zeros((2 * n, 2 * n), complex)
            g[n:] = mg @ vec[n:]
            out["Q"] = scipy.linalg.lu_solve(out["lu"], g, check_finite=False)
            out["vec"] = vec
            out["sigma"] = float(sigma)
            out["half"] = np.flatnonzero(lam.imag >= 0.0)       # its perturbation series: on first refine
        out.pop("lu")
        return out

    def refine(self, a: dict, sigma: float, tol: float, max_sweeps: int, warm: dict):
        """The eigen-decomposition at ``sigma`` from the anchor ``a`` (module docstring), or None if the iteration
        does not converge or loses a pole."""
        delta = sigma - a["sigma"]
        if delta == 0.0:
            return {"poles": a["poles"], "participation": a["participation"], "shapes": a["shapes"], "sweeps": 0}
        lam_a, q, h = a["poles"], a["Q"], a["half"]
        cols = np.arange(h.size)
        # the start: the anchor's perturbation series at delta, where its last term is small; elsewhere (a pair
        # of poles nearly coincident, where the series' radius is small) the last refined neighbour or e_r
        if "lam_k" not in a:                             # an anchor made for a group's last line needs none
            a["lam_k"], a["x_k"] = _series(lam_a, q, h, self.series_order)
        lam_k, x_k = a["lam_k"], a["x_k"]
        lam = lam_k[-1].copy()
        x = x_k[-1].copy()
        for k in range(lam_k.shape[0] - 2, -1, -1):
            lam = lam * delta + lam_k[k]
            x = x * delta + x_k[k]
        last = np.abs(x_k[-1]).max(axis=0) * abs(delta) ** (lam_k.shape[0] - 1)
        bad = ~(last <= 1e-9) | ~np.isfinite(lam)
        if np.any(bad):
            prev = warm.get("x")
            if prev is not None:
                x[:, bad] = prev[:, bad]
                lam[bad] = warm["lam"][bad]
            else:
                x[:, bad] = 0.0
                x[h[bad], cols[bad]] = 1.0
                lam[bad] = lam_a[h[bad]]
        active = cols
        sweeps = 0
        for sweeps in range(1, max_sweeps + 1):
            qx = q @ x[:, active]
            lam_new = lam_a[h[active]] / (1.0 + delta * qx[h[active], np.arange(active.size)])
            xn = (-delta * lam_new)[None, :] * qx / (lam_new[None, :] - lam_a[:, None])
            xn[h[active], np.arange(active.size)] = 1.0
            change = np.abs(xn - x[:, active]).max(axis=0)
            if not np.all(np.isfinite(change)):
                return None
            x[:, active] = xn
            lam[active] = lam_new
            active = active[change > tol]
            if active.size == 0:
                break
        else:
            return None
        warm["x"], warm["lam"] = x, lam
        real = lam_a[h].imag == 0.0
        if np.any(np.abs(lam[real].imag) > 1e-9 * np.abs(lam[real])):
            return None                                  # a real pole left the axis: a collision inside the group
        lam = np.where(real, lam.real, lam)
        lam_full = np.concatenate([lam, np.conj(lam[~real])])
        dist = np.abs(lam_full[:, None] - lam_full[None, :])
        np.fill_diagonal(dist, np.inf)
        if np.any(dist.min(axis=1) <= 1e-9 * np.abs(lam_full)):
            return None                                  # two columns on one pole
        out = self._finish_pairs(lam, a["vec"] @ x, real, sigma)
        if out is not None:
            out["sweeps"] = sweeps
        return out

    def _finish_pairs(self, lam: np.ndarray, vh: np.ndarray, real: np.ndarray, sigma: float):
        """Participations and shapes from the eigenvectors of the poles with Im >= 0 (the others are their
        conjugates), by one real LU: ``v = a + i b``, ``v~ = a - i b``, ``y = sum (c_a a + c_b b)`` gives the
        coefficients ``(c_a -+ i c_b) / 2`` of ``v`` and ``v~``."""
        n, n_p = self.n, self.n_p
        cplx = ~real
        r = np.hstack([vh[:, cplx].real, vh[:, cplx].imag, vh[:, real].real])
        lu = scipy.linalg.lu_factor(r, check_finite=False)
        piv = np.abs(np.diag(lu[0]))
        if not np.all(np.isfinite(piv)) or piv.min() <= 1e-13 * piv.max():
            return None
        mlu = scipy.linalg.lu_factor(self.M + sigma * self.Gt, check_finite=False)
        my = scipy.linalg.lu_solve(mlu, np.hstack([self.P.real, self.P.imag]), check_finite=False)
        y = np.zeros((2 * n, 2 * n_p))
        y[n:] = my
        c = scipy.linalg.lu_solve(lu, y, check_finite=False)
        c = c[:, :n_p] + 1j * c[:, n_p:]
        nc = int(cplx.sum())
        ca, cb, cr = c[:nc], c[nc:2 * nc], c[2 * nc:]
        part = np.concatenate([0.5 * (ca - 1j * cb), cr, 0.5 * (ca + 1j * cb)])
        poles = np.concatenate([lam[cplx], lam[real], np.conj(lam[cplx])])
        xs = vh[:n]
        shapes = np.concatenate([(self.O @ xs[:, cplx]).T, (self.O @ xs[:, real].real).T,
                                 (self.O @ np.conj(xs[:, cplx])).T])
        return {"poles": poles, "participation": part, "shapes": shapes}
