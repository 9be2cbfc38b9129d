"""Exact frequency-domain solvers of the FE model: ``[K - w^2 M + i w (C + W G)] x = f`` for many w at once.

``ShaftSolver`` (block-tridiagonal, a small C kernel) and :func:`solve_direct` (dense LU) are the exact
references of the reduced modal form that BKA-BEM evaluates (:mod:`bkabem_core.fe.modal`). Units: SI.
"""

from __future__ import annotations

import numpy as np

from bkabem_core.fe.rotor import Rotor

__all__ = ["ShaftSolver", "solve_direct", "load_kernel"]


def load_kernel(name: str):
    """A compiled kernel module of this package (``bkabem_core.kernels.<name>``), or None if it was not built."""
    import importlib
    import importlib.util

    spec = importlib.util.find_spec(f"bkabem_core.kernels.{name}")
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    return importlib.import_module(f"bkabem_core.kernels.{name}")


def _load_kernel():
    """The compiled block-tridiagonal solve (bkabem_core/kernels/blocktri.c), or None if it was not built."""
    module = load_kernel("_blocktri")
    return getattr(module, "solve", None)


_KERNEL = _load_kernel()


def solve_direct(rotor: Rotor, w: np.ndarray, big_w: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Dense batched LU: w, big_w (B,) [rad/s], f (B, ndof) [N] -> x (B, ndof) [m] (exact, any topology)."""
    z = (rotor.K[None] - (w ** 2)[:, None, None] * rotor.M[None]
         + 1j * w[:, None, None] * (rotor.C[None] + big_w[:, None, None] * rotor.G[None]))
    return np.linalg.solve(z, f[..., None])[..., 0]


class ShaftSolver:
    """Exact batched solver of ``[K - w^2 M + i w (C + W G)] x = f`` for a single-shaft model.

    The housing DOFs (point masses that touch the shaft at one node and otherwise only the ground) are
    condensed exactly into the shaft node they hang on. What remains is the shaft matrix, block-tridiagonal
    with 4 x 4 blocks; a block LU (Thomas) sweep with partial pivoting inside each block solves every system
    of the batch (orders x speeds) in one call of a small C kernel (``kernels/blocktri.c``). Members whose smallest
    pivot is tiny, and every member if the kernel is not built, are solved by LAPACK's dense LU instead.

    Parameters
    ----------
    rotor : Rotor

    Raises
    ------
    ValueError
        If the model does not have this topology (the direct solver is used then).
    """

    #: Smallest pivot (relative to its block's largest entry) accepted from the block sweep.
    PIVOT_RATIO_MIN = 1e-10

    def __init__(self, rotor: Rotor):
        shaft = list(rotor.shaft_node_labels)
        if any(len(rotor.node_dofs(n)) != 4 for n in shaft):
            raise ValueError("shaft nodes must have 4 DOFs")
        s_idx = np.concatenate([rotor.node_dofs(n) for n in shaft])
        o_idx = np.setdiff1d(np.arange(rotor.ndof), s_idx)
        self.s_idx, self.o_idx = s_idx, o_idx
        nb = self.n_nodes = len(shaft)
        mats = {"K": rotor.K, "M": rotor.M, "C": rotor.C, "G": rotor.G}
        self._full = mats
        coef = {}
        for name, a in mats.items():
            ss = a[np.ix_(s_idx, s_idx)].reshape(nb, 4, nb, 4).transpose(0, 2, 1, 3)    # (nb, nb, 4, 4)
            far = np.abs(np.subtract.outer(np.arange(nb), np.arange(nb))) > 1
            if np.any(ss[far] != 0.0):
                raise ValueError("shaft matrix is not block-tridiagonal")
            k = np.arange(nb)
            coef[name] = [ss[k, k].ravel(), ss[k[:-1], k[1:]].ravel(), ss[k[1:], k[:-1]].ravel()]
            oo = a[np.ix_(o_idx, o_idx)]
            if np.any(oo - np.diag(np.diag(oo)) != 0.0):
                raise ValueError("non-shaft DOFs must be uncoupled among themselves")
            coef[name].append(np.diag(oo).copy())
        so = {k: a[np.ix_(s_idx, o_idx)] for k, a in mats.items()}
        os_ = {k: a[np.ix_(o_idx, s_idx)] for k, a in mats.items()}
        touch = np.zeros((s_idx.size, o_idx.size), dtype=bool)
        for k in mats:
            touch |= (so[k] != 0.0) | (os_[k].T != 0.0)
        nodes = []
        for o in range(o_idx.size):
            rows = np.nonzero(touch[:, o])[0]
            if rows.size and rows.max() // 4 != rows.min() // 4:
                raise ValueError("a housing DOF couples to more than one shaft node")
            nodes.append(int(rows.min() // 4) if rows.size else 0)
        self.o_node = np.array(nodes, dtype=int)
        rows = 4 * self.o_node[:, None] + np.arange(4)[None, :]                   # (no, 4)
        oi = np.arange(o_idx.size)[:, None]
        for k in mats:
            coef[k] += [so[k][rows, oi].ravel(), os_[k][oi, rows].ravel()]
        # per part (diagonal, upper, lower blocks, housing-housing, shaft-housing, housing-shaft):
        # C-contiguous [K, M, C, G] stacks, the layout the kernel reads
        self._c_arrays = [np.ascontiguousarray(np.stack([coef[k][part] for k in ("K", "M", "C", "G")]))
                          for part in range(6)]
        self._o_node_c = self.o_node.astype(np.intc)
        self.last_fallbacks = 0

    def solve(self, w: np.ndarray, big_w: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Solve for a batch: w, big_w (B,) [rad/s], f (B, ndof) complex [N] -> x (B, ndof) [m]."""
        if _KERNEL is None:
            self.last_fallbacks = w.size
            return self._direct(w, big_w, f)
        b, nb, no = w.size, self.n_nodes, self.o_idx.size
        w = np.ascontiguousarray(w, dtype=float)
        big_w = np.ascontiguousarray(big_w, dtype=float)
        f_s = np.ascontiguousarray(f[:, self.s_idx], dtype=complex)         # (B, nb*4), overwritten with x
        f_o = np.ascontiguousarray(f[:, self.o_idx], dtype=complex)
        x_o = np.empty((b, no), dtype=complex)
        work = [np.empty((nb, 4, 4), complex), np.empty((max(nb - 1, 1), 4, 4), complex),   # one system:
                np.empty((max(nb - 1, 1), 4, 4), complex), np.empty((max(nb - 1, 1), 4, 4), complex),  # D U L X g
                np.empty((nb, 4), complex)]
        bad = np.zeros(b, dtype=np.intc)
        cd, cu, cl, coo, cso, cos_ = self._c_arrays
        _KERNEL(cd, cu, cl, self._o_node_c, coo, cso, cos_, w, big_w, f_s, f_o, x_o, *work, bad, self.PIVOT_RATIO_MIN)
        out = np.empty((b, f.shape[1]), dtype=complex)
        out[:, self.s_idx] = f_s
        out[:, self.o_idx] = x_o
        flagged = bad.astype(bool)
        if np.any(flagged) or not np.all(np.isfinite(out)):
            flagged |= ~np.all(np.isfinite(out), axis=1)
            out[flagged] = self._direct(w[flagged], big_w[flagged], f[flagged])
        self.last_fallbacks = int(flagged.sum())
        return out

    def _direct(self, w, big_w, f):
        m = self._full
        z = (m["K"][None] - (w ** 2)[:, None, None] * m["M"][None]
             + 1j * w[:, None, None] * (m["C"][None] + big_w[:, None, None] * m["G"][None]))
        return np.linalg.solve(z, f[..., None])[..., 0]
