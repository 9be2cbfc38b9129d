"""The reduced modal form of BKA-BEM: the response at any speed in microseconds, exactly for the reduced model.

``ModalBasis``
    Ritz reduction of the FE model: its undamped modes (bearings and supports included) up to a cut-off above the
    highest frequency the model serves, plus one static residual vector per input force pattern (the static
    response minus its modal part), M-orthonormalised. The static response is then exact, and the modes above
    the cut-off respond quasi-statically; the error against the full FE is tested (tests/unit/test_harmonic.py).
``LineModes`` (:mod:`bkabem_core.fe.linemodes`)
    The reduced model diagonalised along every line (the poles and residues the forms below use).
``OrderModalForm``
    Along line j (frequency ``omega = nu_j Omega``) the gyroscopic term joins the mass, so the dynamic stiffness is
    a fixed quadratic pencil per line; diagonalised once, the response is a pole-residue sum at every speed.
``SpeedCells``
    That sum in cells of shaft speed: a Chebyshev interpolant of the far poles, the near poles exact, with a
    rigorous bound (the synthesiser's fast path).

Units: SI (m, s, N, rad).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg

from bkabem_core.fe.linemodes import LineModes  # noqa: F401  (re-exported: the line modes of a basis)
from bkabem_core.fe.solvers import load_kernel

TWO_PI = 2.0 * math.pi


def plane_mask(rotor) -> np.ndarray | None:
    """(ndof,) bool: True for the DOFs of the vertical bending plane (y, alpha), False for (x, beta); None if the
    model is not separable into the two planes (some stiffness, mass or damping couples them, or the gyroscopic
    matrix acts within a plane) or does not name its DOFs (``node_labels``, ``dof_index``)."""
    labels, index = getattr(rotor, "node_labels", None), getattr(rotor, "dof_index", None)
    if labels is None or index is None:
        return None
    y = np.zeros(rotor.K.shape[0], dtype=int)
    for node in labels:
        for direction, plane in (("x", 1), ("beta", 1), ("y", 2), ("alpha", 2)):
            try:
                y[index(node, direction)] = plane
            except KeyError:
                continue
    if np.any(y == 0):
        return None
    ym = y == 2
    for a in (rotor.K, rotor.M, rotor.C):
        if np.abs(a[np.ix_(ym, ~ym)]).max(initial=0.0) > 1e-14 * np.abs(a).max(initial=1e-300):
            return None
    g = rotor.G
    if (np.abs(g[np.ix_(ym, ym)]).max(initial=0.0) > 0.0 or np.abs(g[np.ix_(~ym, ~ym)]).max(initial=0.0) > 0.0):
        return None
    return ym


def _ritz_vectors(k, m, p, w_cut):
    """M-orthonormal ``[modes below w_cut, static residual vectors of the patterns p]`` and the modes' w^2."""
    w2, phi = scipy.linalg.eigh(k, m, subset_by_value=(-np.inf, w_cut * w_cut))
    if w2.size and w2.min() <= 0.0:
        raise ValueError("ModalBasis: the model has a rigid-body mode (K singular); ground it first")
    static = scipy.linalg.solve(k, p, assume_a="sym")
    resid = static - phi @ ((phi.T @ p) / w2[:, None])
    v = np.hstack([phi, resid])
    mr = v.T @ m @ v
    lower = np.linalg.cholesky(0.5 * (mr + mr.T))
    return scipy.linalg.solve_triangular(lower, v.T, lower=True).T, w2       # V L^-T: V^T M V = I


class ModalBasis:
    """Ritz reduction of an FE model for the frequency band it must serve.

    Basis ``V = [Phi, R]``: the undamped modes ``Phi`` of ``(K, M)`` below ``cutoff_hz`` (bearings and supports
    included) and, for each input force pattern ``p``, the residual static vector ``K^-1 p - Phi Omega^-2 Phi^T p``;
    all M-orthonormalised. The reduced matrices are ``V^T A V``. When the FE separates into its two bending planes
    (:func:`plane_mask`: bearings without cross stiffness, the gyroscopic matrix coupling only the planes) the
    basis is made plane by plane (each pattern's residual vector split into its planes): the same subspace, and
    every vector in one plane (``planes``), which gives the line pencils a real form (:mod:`linemodes`).

    Parameters
    ----------
    rotor : Rotor
        Any object with ``M, K, C, G`` (ndof x ndof).
    inputs : ndarray (ndof, P)
        Force patterns the model is driven by [N per unit].
    outputs : ndarray of int (U,), or ndarray (U, ndof)
        DOF indices of the displacements wanted, or rows of a selection matrix (e.g. relative displacements).
    cutoff_hz : float
        Highest natural frequency kept [Hz] (default in :class:`BkaBem`: 1.25 x the case's highest frequency,
        tested to 0.01 dB).

    Attributes
    ----------
    V : ndarray (ndof, m)
    M, K, C, G : ndarray (m, m)
        Reduced matrices (``M`` ~ identity).
    inputs : ndarray (m, P)
    outputs : ndarray (U, m)
        Rows of ``V`` at the output DOFs.
    n_modes : int
        Modes kept (the rest are residual vectors).
    planes : ndarray of bool (m,) or None
        True for the basis vectors of the vertical plane (y, alpha), False for (x, beta); None if the FE does not
        separate into the planes.
    """

    def __init__(self, rotor, inputs: np.ndarray, outputs: np.ndarray, cutoff_hz: float):
        k, m = rotor.K, rotor.M
        w_cut = TWO_PI * float(cutoff_hz)
        p = np.asarray(inputs, dtype=float)
        planes = plane_mask(rotor)
        if planes is None:
            v, w2 = _ritz_vectors(k, m, p, w_cut)
            self.planes = None
        else:
            # plane by plane: the same subspace, and a basis whose vectors each lie in one bending plane
            parts, freq, flags = [], [], []
            for y in (False, True):
                idx = np.flatnonzero(planes == y)
                pp = p[idx]
                pp = pp[:, np.abs(pp).max(axis=0) > 0.0] if pp.size else pp
                vi, w2i = _ritz_vectors(k[np.ix_(idx, idx)], m[np.ix_(idx, idx)], pp, w_cut)
                full = np.zeros((k.shape[0], vi.shape[1]))
                full[idx] = vi
                parts.append(full)
                freq.append(w2i)
                flags.append(np.full(vi.shape[1], y))
            v = np.hstack(parts)
            w2 = np.sort(np.concatenate(freq))
            self.planes = np.concatenate(flags)
        self.V = v
        self.n_modes = int(w2.size)
        self.cutoff_hz = float(cutoff_hz)
        self.M, self.K, self.C, self.G = (v.T @ a @ v for a in (rotor.M, rotor.K, rotor.C, rotor.G))
        self.inputs = v.T @ p
        outputs = np.asarray(outputs)
        self.outputs = v[outputs.astype(int)] if outputs.ndim == 1 else outputs @ v
        self.natural_frequencies_hz = np.sqrt(w2) / TWO_PI

    @property
    def size(self) -> int:
        return self.V.shape[1]

    def with_ports(self, inputs: np.ndarray, outputs: np.ndarray) -> "ModalBasis":
        """The same reduced model with other input patterns and outputs (no new modes computed).

        The static residual vectors span the static responses to the original patterns only: ``inputs`` must lie
        in their span (e.g. the same force pairs in another order or sign) for the static response to stay exact.
        """
        other = object.__new__(ModalBasis)
        other.__dict__.update(self.__dict__)
        other.inputs = self.V.T @ np.asarray(inputs, dtype=float)
        outputs = np.asarray(outputs)
        other.outputs = self.V[outputs.astype(int)] if outputs.ndim == 1 else outputs @ self.V
        return other

    def solve_unit(self, omega: np.ndarray, big_omega: np.ndarray) -> np.ndarray:
        """Receptance (B, U, P) [m/N]: outputs per unit force on each input pattern at omega, big_omega (B,) [rad/s]."""
        z = (self.K[None] - (omega ** 2)[:, None, None] * self.M[None]
             + 1j * omega[:, None, None] * (self.C[None] + big_omega[:, None, None] * self.G[None]))
        q = np.linalg.solve(z, np.broadcast_to(self.inputs.astype(complex), (omega.size,) + self.inputs.shape))
        return self.outputs @ q

    def solve(self, omega: np.ndarray, big_omega: np.ndarray, force: np.ndarray) -> np.ndarray:
        """Reduced dense solve: omega, big_omega (B,) [rad/s], force (B, P) on the input patterns -> outputs (B, U)."""
        z = (self.K[None] - (omega ** 2)[:, None, None] * self.M[None]
             + 1j * omega[:, None, None] * (self.C[None] + big_omega[:, None, None] * self.G[None]))
        q = np.linalg.solve(z, (force @ self.inputs.T)[..., None])[..., 0]
        return q @ self.outputs.T


class OrderModalForm:
    """Exact pole-residue form of the reduced model's response, line by line: any speed in microseconds.

    Along line j the frequency is tied to the shaft speed, ``omega = nu_j Omega`` (``nu_j`` per Hz of shaft speed,
    e.g. ``k BPFO_per_Hz`` for BPFO order k), so the dynamic stiffness of Eq. (8) is a fixed quadratic pencil in
    ``s = i omega``:

        Z_j(s) = K + s C + s^2 M_j,      M_j = M - i G / nu_j

    (the gyroscopic term ``i omega Omega G = -i s^2 G / nu_j`` joins the mass). With the state matrix of that pencil
    diagonalised once per line, ``S_j = V diag(lambda) V^-1``, and the force linear in omega
    (``F_j = a_j + i omega b_j``: the base excitation ``k_b U_j`` through the bearing spring, plus ``c_b U_j`` for
    the paper's Eq. 5), the response at any output combination u is

        X_{j,u}(omega) = D_{j,u} + sum_r E_{j,r,u} / (i omega - lambda_{j,r})

    exactly, for every shaft speed: resonances are poles, not samples on a speed grid. ``D`` is zero analytically
    for ``b = 0`` and kept to round-off. One eigen-decomposition per line of the reduced model (2 m states); then
    an evaluation is one complex division per pole and line and one multiply-add per pole, line and output.

    Parameters
    ----------
    modes : LineModes
        The lines' eigen-decompositions (shared by every force and output combination).
    force_a, force_b : ndarray complex (K, P)
        Force on the basis's input patterns per line: ``F = a + i omega b`` [N], [N s].
    combination : ndarray (U, n_outputs), optional
        Output combinations of the basis's outputs (default the identity).
    orders : ndarray of int (K,), optional
        Labels of the lines (BPFO orders), kept as ``orders``.

    Attributes
    ----------
    poles : ndarray complex (K, 2m)
        lambda_{j,r} [rad/s].
    residues : ndarray complex (K, 2m, U)
        E_{j,r,u} [m rad/s].
    direct : ndarray complex (K, U)
        D_{j,u} [m].
    static : ndarray complex (K, U)
        The static response X_j(0) [m] (exact: the basis holds the static residual vectors).

    Evaluation: the compiled kernel (``_modalsum.c``) sums the mode-acceleration form
    ``X = X0 + i w sum_r (E_r / lambda_r) / (i w - lambda_r)``; :meth:`evaluate_numpy` the form above, both in
    double.
    """

    def __init__(self, modes: LineModes, force_a: np.ndarray, force_b: np.ndarray,
                 combination: np.ndarray | None = None, orders: np.ndarray | None = None):
        nu = modes.multipliers
        n2 = modes.poles.shape[1]
        n_out = modes.shapes.shape[2]
        comb = np.eye(n_out) if combination is None else np.asarray(combination, float)
        self.combination = comb
        self.multipliers = nu
        self.orders = np.arange(1, nu.size + 1) if orders is None else np.asarray(orders, dtype=int)
        n_k = nu.size
        fa = np.asarray(force_a, complex)                            # (K, P) on the input patterns
        fb = np.asarray(force_b, complex)
        a = np.einsum("krp,kp->kr", modes.participation, fa)        # (K, 2m): F = a + i omega b per pole
        b = np.einsum("krp,kp->kr", modes.participation, fb)
        p = modes.shapes @ comb.T                                     # (K, 2m, U)
        lam = modes.poles
        # (a + i w b) / (i w - lam) = b + (a + lam b) / (i w - lam)
        self.poles = lam
        self.residues = p * (a + lam * b)[:, :, None]
        self.direct = np.einsum("kr,kru->ku", b, p)
        self._w_per_hz = TWO_PI * nu
        self.static = fa @ (comb @ modes.static).T                   # (K, U) [m]
        self._c = None
        self._speed_cells = None
        if _MODAL_KERNEL is not None and comb.shape[0] <= 8 and n2 <= 1024:     # the kernel's limits (MAXR)
            # the C kernel's form: X = X0 + i w sum_r E'_r / (i w - lambda_r), E' = E / lambda,
            # 8 outputs (zero-padded), real and imaginary parts split (see _modalsum.c)
            n_u = comb.shape[0]
            e = np.zeros((n_k, n2, 8), complex)
            e[..., :n_u] = self.residues / self.poles[:, :, None]
            x0 = np.zeros((n_k, 8), complex)
            x0[:, :n_u] = self.static
            self._c = [np.ascontiguousarray(self.poles.real), np.ascontiguousarray(self.poles.imag),
                       np.ascontiguousarray(e.real), np.ascontiguousarray(e.imag),
                       np.ascontiguousarray(x0.real), np.ascontiguousarray(x0.imag)]

    @property
    def n_lines(self) -> int:
        return int(self.multipliers.size)

    def __call__(self, speed_hz: float) -> np.ndarray:
        """Complex displacement combinations (K, U) [m] at shaft speed ``speed_hz`` [Hz]."""
        w = self._w_per_hz * float(speed_hz)
        if self._c is not None:
            out = np.empty((2, self.n_lines, 8))                     # per call: the form may be shared across threads
            _MODAL_KERNEL(w, *self._c, out[0], out[1])
            x = np.empty(self.direct.shape, complex)
            n_u = x.shape[1]
            x.real = out[0, :, :n_u]
            x.imag = out[1, :, :n_u]
            return x
        return self.evaluate_numpy(speed_hz)

    def speed_cells(self) -> "SpeedCells":
        """This form in cells of shaft speed (:class:`SpeedCells`, made once and kept: synthesisers share it)."""
        if self._speed_cells is None:
            self._speed_cells = SpeedCells(self)
        return self._speed_cells

    def evaluate_numpy(self, speed_hz: float) -> np.ndarray:
        """The same sum in numpy (the reference of the C kernel, and its fallback when it is not built)."""
        iw = 1j * self._w_per_hz * float(speed_hz)
        g = 1.0 / (iw[:, None] - self.poles)                                          # (K, 2m)
        return self.direct + np.matmul(g[:, None, :], self.residues)[:, 0, :]


_MODALSUM = load_kernel("_modalsum")
#: the compiled pole-residue sums (bkabem_core/kernels/modalsum.c), or None if they were not built
_MODAL_KERNEL = getattr(_MODALSUM, "modal_sum", None)
_CELL_KERNEL = getattr(_MODALSUM, "cell_sum", None)
_CELL_PLAN = getattr(_MODALSUM, "cell_plan", None)


class SpeedCells:
    """The order-wise modal form in cells of shaft speed: a Chebyshev interpolant for the far poles, the near
    poles exactly, with a rigorous bound on the interpolation error.

    Within cell ``i`` (shaft speed ``[i, i + 1] * cell_hz``, ``t = 2 (f - f_mid) / cell_hz`` in [-1, 1]) every
    order's frequency ``omega = w_k f`` is linear in ``t``, so one set of Chebyshev values ``T_d(t)`` serves all
    orders::

        X_{k,u}(f) = sum_{d<=D} c_{k,d,u} T_d(t) + sum_{r near} E_{k,r,u} / (i omega - lambda_{k,r})

    ``c`` interpolates the direct term plus the far poles at the D + 1 Chebyshev points of the cell. For one pole,
    ``E / (i omega - lambda)`` with ``omega = omega_mid + h t`` has its singularity at ``z = (-i lambda -
    omega_mid) / h``, and the interpolation error of ``1 / (t - z)`` at these points is
    ``l(t) / (l(z) (t - z))`` with ``l = T_{D+1} / 2^D`` (Hermite's formula), so on the cell::

        |error_{k,r,u}| <= |E_{k,r,u}| / (h |T_{D+1}(z)| dist(z, [-1, 1]))

    Poles are taken as near, largest bound first, until the far poles' bounds sum to at most ``tol`` times the
    output's reference in every order and output: ``min_p max_k' |X_{k',u}| k'^p / k^p`` over p = 0, 1, 2 (the
    largest order of the output as displacement, velocity or acceleration, seen from order k) and over the cell's
    points. Near the lightly damped resonances the poles are therefore exact, as in the full sum; a typical cell
    of the embedded case keeps ~11 of its 6000 poles (0.5 Hz cells, D = 9; cell 0, down to standstill, ~440), and
    a speed costs ~7 us in C.

    Cells are made when first needed (~4 ms each, kept up to ``max_cells``) or ahead with :meth:`build`.
    Thread-safe for readers (a cell is made completely before it is stored).

    Parameters
    ----------
    form : OrderModalForm
    cell_hz : float
        Cell width in shaft speed [Hz] (default 0.5).
    degree : int
        Chebyshev degree D (default 9).
    tol : float
        Bound of the interpolation error relative to the output's reference (default 2e-6).
    max_cells : int
        Cells kept at most (default 512, ~33 MB on the embedded case: 256 Hz of shaft speed); beyond, the oldest
        made is dropped (and made again when needed).
    """

    DEFAULT_CELL_HZ = 0.5

    def __init__(self, form: "OrderModalForm", cell_hz: float = DEFAULT_CELL_HZ, degree: int = 9,
                 tol: float = 2e-6, max_cells: int = 512):
        self.form = form
        self.max_cells = int(max_cells)
        self.cell_hz = float(cell_hz)
        self.degree = int(degree)
        self.tol = float(tol)
        n = self.degree + 1
        j = np.arange(n)
        self._nodes = np.cos((2 * j + 1) * np.pi / (2 * n))                       # Chebyshev points, first kind
        cm = (2.0 / n) * np.cos(np.outer(np.arange(n), (2 * j + 1) * np.pi / (2 * n)))
        cm[0] *= 0.5
        self._to_coef = cm                                                          # values at nodes -> c_d
        self._cells: dict[int, tuple] = {}
        self._shape = form.direct.shape
        self._kernel = _CELL_KERNEL if _CELL_KERNEL is not None and self._shape[1] <= 8 else None

    def __getstate__(self) -> dict:
        """Pickled or copied without its cells (their kernel handles, capsules of this process's arrays) and kernel:
        both are made again where it is unpickled."""
        state = dict(self.__dict__)
        state["_cells"] = {}
        state["_kernel"] = None
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._kernel = _CELL_KERNEL if _CELL_KERNEL is not None and self._shape[1] <= 8 else None

    def __len__(self) -> int:
        return len(self._cells)

    @property
    def nbytes(self) -> int:
        """Memory held by the cells made so far [bytes]."""
        return sum(a.nbytes for c in self._cells.values() for a in c[0][1:])

    @staticmethod
    def cell_range(cell_hz: float, f_lo_hz: float, f_hi_hz: float) -> range:
        """Indices of the cells of width ``cell_hz`` covering shaft speeds ``[f_lo_hz, f_hi_hz]`` [Hz]."""
        return range(max(0, int(f_lo_hz // cell_hz)), int(f_hi_hz // cell_hz) + 1)

    def missing(self, f_lo_hz: float, f_hi_hz: float) -> int:
        """How many cells covering ``[f_lo_hz, f_hi_hz]`` [Hz] are not made yet."""
        return sum(i not in self._cells for i in self.cell_range(self.cell_hz, f_lo_hz, f_hi_hz))

    def build(self, f_lo_hz: float, f_hi_hz: float, progress=None) -> None:
        """Make every cell covering shaft speeds ``[f_lo_hz, f_hi_hz]`` [Hz] now."""
        for i in self.cell_range(self.cell_hz, f_lo_hz, f_hi_hz):
            self.cell(i)
            if progress is not None:
                progress(1)

    def cell(self, i: int) -> tuple:
        """Cell ``i`` (made if missing): its arrays, the kernel's handle of them (None without the kernel), the
        near-pole mask."""
        c = self._cells.get(i)
        if c is None:
            c = self._make(i)
            if len(self._cells) >= self.max_cells:                   # bounded memory: drop the oldest cell
                self._cells.pop(next(iter(self._cells)), None)
            self._cells[i] = c
        return c

    def _make(self, i: int) -> tuple:
        fm = self.form
        lam, e, direct = fm.poles, fm.residues, fm.direct            # (K, R), (K, R, U), (K, U)
        n_k, n_r, n_u = e.shape
        h_hz = 0.5 * self.cell_hz
        f_mid = (i + 0.5) * self.cell_hz
        f_nodes = f_mid + h_hz * self._nodes
        iw = 1j * fm._w_per_hz[:, None] * f_nodes[None, :]                        # (K, n)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = 1.0 / (iw[:, :, None] - lam[:, None, :])                            # (K, n, R)
            full = direct[:, None, :] + np.matmul(g, e)                              # (K, n, U)
            # the error budget per order and output (see the class docstring)
            kk = fm.multipliers / fm.multipliers.min()         # line frequency ratios (k for BPFO orders)
            mag = np.abs(full)
            budget = np.full((n_k, n_u), np.inf)
            for p in (0, 1, 2):
                ref = (mag * kk[:, None, None] ** p).max(axis=0).min(axis=0)         # (U,)
                budget = np.minimum(budget, ref[None, :] / kk[:, None] ** p)
            budget *= self.tol
            # per pole: |E| / (h |T_{D+1}(z)| dist(z, [-1, 1]))
            h = fm._w_per_hz * h_hz                                                   # (K,) [rad/s]
            z = (-1j * lam - (fm._w_per_hz * f_mid)[:, None]) / h[:, None]
            t_top = np.polynomial.chebyshev.chebval(z, np.eye(self.degree + 2)[-1])
            dist = np.abs(z - np.clip(z.real, -1.0, 1.0))
            scale = 1.0 / (h[:, None] * np.abs(t_top) * dist)                          # inf on the segment
            rel = np.abs(e) * scale[:, :, None] / budget[:, None, :]
            rel = np.nan_to_num(rel, nan=0.0, posinf=np.inf).max(axis=2)             # (K, R); 0 residue: 0
        order = np.argsort(rel, axis=1, kind="stable")                              # smallest bound first
        far_sorted = np.cumsum(np.take_along_axis(rel, order, axis=1), axis=1) <= 1.0
        near = np.ones((n_k, n_r), bool)
        np.put_along_axis(near, order, ~far_sorted, axis=1)
        far_values = direct[:, None, :] + np.matmul(np.where(near[:, None, :], 0.0, g), e)   # (K, n, U)
        coef = np.einsum("dj,kju->kdu", self._to_coef, far_values)                  # (K, D+1, U)
        if not np.all(np.isfinite(coef)):
            raise FloatingPointError(f"speed cell {i}: non-finite interpolant (a pole on a Chebyshev point?)")
        c8 = np.zeros((n_k, self.degree + 1, 8), complex)
        c8[..., :n_u] = coef
        kr = np.nonzero(near)
        start = np.zeros(n_k + 1, np.int32)
        start[1:] = np.cumsum(near.sum(axis=1))
        e8 = np.zeros((kr[0].size, 8), complex)
        e8[:, :n_u] = e[kr]
        arrays = [fm._w_per_hz, np.ascontiguousarray(c8.real), np.ascontiguousarray(c8.imag), start,
                  np.ascontiguousarray(lam[kr].real), np.ascontiguousarray(lam[kr].imag),
                  np.ascontiguousarray(e8.real), np.ascontiguousarray(e8.imag)]
        handle = _CELL_PLAN(n_u, *arrays) if _CELL_PLAN is not None and n_u <= 8 else None
        return arrays, handle, near

    def __call__(self, speed_hz: float) -> np.ndarray:
        """Complex displacement combinations (K, U) [m] at shaft speed ``speed_hz`` [Hz] (>= 0)."""
        f = float(speed_hz)
        i = int(f // self.cell_hz)
        c = self._cells.get(i)
        if c is None:
            c = self.cell(i)
        if self._kernel is None:
            return self.evaluate_numpy(f)
        x = np.empty(self._shape, complex)
        self._kernel(c[1], f, 2.0 * f / self.cell_hz - (2 * i + 1), x)      # t in [-1, 1]
        return x

    def evaluate_numpy(self, speed_hz: float) -> np.ndarray:
        """The same evaluation in numpy (the kernel's reference and fallback)."""
        f = float(speed_hz)
        i = int(f // self.cell_hz)
        arrays, _, near = self.cell(i)
        t = 2.0 * f / self.cell_hz - (2 * i + 1)
        tc = np.polynomial.chebyshev.chebvander(np.array([t]), self.degree)[0]     # (D+1,)
        n_u = self.form.direct.shape[1]
        x = np.einsum("d,kdu->ku", tc, arrays[1] + 1j * arrays[2])[:, :n_u]
        fm = self.form
        iw = 1j * fm._w_per_hz * f
        g = np.where(near, 1.0 / (iw[:, None] - fm.poles), 0.0)
        return x + np.einsum("kr,kru->ku", g, fm.residues)


