"""BKA-BEM harmonic solve: the 4-DOF excitation applied as a base excitation to the full FE model.

For each BPFO order k and each lateral direction d (vertical y, horizontal x) the 4-DOF model gives the
relative displacement ``u_k(t) = A_k cos(omega_k t + phi_k)`` between the faulty bearing's inner and outer race.
Paper Eq. (5): the bearing element transmits ``F = k_b u + c_b u'`` to the rotor node (+) and the housing
node (-); in complex form, with ``u = Re(U e^{i omega t})``, ``U = A e^{i phi}``:

    F_k = (k_b + i omega_k c_b) U_k     (rotor node),    -F_k (housing node),

and Eq. (8) in its equivalent complex form (real part = the paper's a sin + b cos):

    [K - omega_k^2 M + i omega_k (C + Omega G)] X_k = F_k,      omega_k = k 2 pi BPFO(Omega),

so that the response at any DOF is ``x(t) = Re(X_k e^{i omega_k t})``: amplitude |X_k| (Eq. 9) and phase
angle(X_k) in the same cosine convention as the excitation. Velocity and acceleration are ``i omega X`` and
``-omega^2 X``. The DC part (k = 0) is the static response ``K X_0 = k_b DC``.

Solvers
-------
``"block"`` (default): exact. The housing DOFs (point masses that touch the shaft at one node and the ground)
are condensed into the shaft node they hang on, which leaves the block-tridiagonal shaft matrix (4 x 4
blocks). A block LU sweep with partial pivoting inside the blocks, in a small C kernel, solves all orders and
speeds of a batch in one call: cost linear in shaft nodes and orders. Used whenever the model has this
single-shaft topology (checked at set-up); see :class:`ShaftSolver` for why C and what else was measured.

``"direct"``: the full complex system is solved for every order and speed with numpy's batched LU. Exact, any
topology; the reference the block solver is tested against.

Units: SI (m, s, N, rad). Locations: DE/NDE rotor and housing nodes; directions ``vertical`` (y), ``horizontal``
(x).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .bearing import FaultFrequencies
from .case import Case
from .excitation import DIRECTIONS, Excitation, compute_excitation
from .rotor import Rotor, rotor_from_case

LOCATIONS = ("de_rotor", "de_housing", "nde_rotor", "nde_housing")
_DIR_DOF = {"vertical": "y", "horizontal": "x"}
TWO_PI = 2.0 * math.pi


@dataclass
class Spectrum:
    """BKA-BEM response at one shaft speed.

    Attributes
    ----------
    speed_hz : float
        Shaft speed [Hz].
    orders : ndarray of int (K,)
        BPFO orders.
    frequency_hz : ndarray (K,)
        ``orders x BPFO`` [Hz].
    displacement : ndarray complex (K, 4, 2)
        Complex displacement amplitude X [m] per order, location (LOCATIONS) and direction (DIRECTIONS):
        ``x(t) = Re(X e^{i 2 pi f t})`` with t = 0 at cage angle 0.
    dc_m : ndarray (4, 2)
        Static (k = 0) displacement [m] from the DC of the excitation.
    fault_frequencies_hz : FaultFrequencies
        FTF, BPFO, BPFI, BSF [Hz] at this speed.
    """

    speed_hz: float
    orders: np.ndarray
    frequency_hz: np.ndarray
    displacement: np.ndarray
    dc_m: np.ndarray
    fault_frequencies_hz: FaultFrequencies

    @property
    def omega_rad_s(self) -> np.ndarray:
        return TWO_PI * self.frequency_hz

    @property
    def velocity(self) -> np.ndarray:
        """Complex velocity amplitude [m/s], (K, 4, 2)."""
        return 1j * self.omega_rad_s[:, None, None] * self.displacement

    @property
    def acceleration(self) -> np.ndarray:
        """Complex acceleration amplitude [m/s^2], (K, 4, 2)."""
        return -(self.omega_rad_s[:, None, None] ** 2) * self.displacement

    def to_dict(self) -> dict:
        """JSON-ready, field names of the CLI contract (architecture.md)."""
        out = {"speed_hz": self.speed_hz, "orders": [int(k) for k in self.orders],
               "fault_frequencies_hz": self.fault_frequencies_hz.to_dict()}
        disp, acc, vel = self.displacement, self.acceleration, self.velocity
        for li, loc in enumerate(LOCATIONS):
            out[loc] = {}
            for di, d in enumerate(DIRECTIONS):
                out[loc][d] = {
                    "frequency_hz": self.frequency_hz.tolist(),
                    "displacement_m": np.abs(disp[:, li, di]).tolist(),
                    "velocity_m_s": np.abs(vel[:, li, di]).tolist(),
                    "acceleration_m_s2": np.abs(acc[:, li, di]).tolist(),
                    "phase_rad": np.angle(disp[:, li, di]).tolist(),
                    "dc_m": float(self.dc_m[li, di]),
                }
        return out


@dataclass
class Sweep:
    """BKA-BEM responses over many speeds (arrays stacked along the first axis).

    Attributes
    ----------
    speeds_hz : ndarray (S,)
    orders : ndarray (K,)
    displacement : ndarray complex (S, K, 4, 2) [m]
    bpfo_per_hz : float
    """

    speeds_hz: np.ndarray
    orders: np.ndarray
    displacement: np.ndarray
    bpfo_per_hz: float

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.multiply.outer(self.speeds_hz, self.orders * self.bpfo_per_hz)

    @property
    def acceleration(self) -> np.ndarray:
        w = TWO_PI * self.frequency_hz
        return -(w[..., None, None] ** 2) * self.displacement

    def rms(self, quantity: str = "acceleration") -> np.ndarray:
        """Overall RMS over the kept orders [m or m/s^2], shape (S, 4, 2) (DC excluded)."""
        x = self.acceleration if quantity == "acceleration" else self.displacement
        return np.sqrt(0.5 * np.sum(np.abs(x) ** 2, axis=1))


class BkaBem:
    """The BKA-BEM model of one case: excitation + FE rotor, solved order by order at any speed.

    Parameters
    ----------
    case : Case
    excitation : Excitation, optional
        Precomputed 4-DOF result (computed from the case if omitted).
    solver : {"block", "direct"}
        See the module docstring; ``"block"`` falls back to ``"direct"`` for models that are not a single
        shaft with housings.

    Attributes
    ----------
    rotor : Rotor
    excitation : Excitation
    preparation_time_s : dict
        Wall time of each preparation stage [s].
    """

    def __init__(self, case: Case, excitation: Excitation | None = None, solver: str = "block"):
        if solver not in ("block", "direct"):
            raise ValueError(f"solver: must be 'block' or 'direct' (got {solver!r})")
        self.case = case
        self.solver = solver
        self.preparation_time_s = {}
        t0 = time.perf_counter()
        self.excitation = excitation if excitation is not None else compute_excitation(
            case.bearing(), case.four_dof_parameters())
        t1 = time.perf_counter()
        self.rotor: Rotor = rotor_from_case(case.raw)
        t2 = time.perf_counter()
        self.preparation_time_s["excitation"] = t1 - t0 if excitation is None else 0.0
        self.preparation_time_s["fe_assembly"] = t2 - t1
        self.fault_multipliers = case.bearing().fault_multipliers()
        self.bpfo_per_hz = self.fault_multipliers.bpfo
        self.orders = np.asarray(self.excitation.orders, dtype=int)

        # input DOFs: faulty bearing rotor (x, y), housing (x, y); output DOFs: 4 locations x 2 directions
        brg = case.raw["bearings"]
        fb = case.faulty_bearing
        r_node, h_node = brg[fb]["rotor_node"], brg[fb]["housing_node"]
        idx = self.rotor.dof_index
        self._in_dofs = np.array([idx(r_node, "y"), idx(r_node, "x"), idx(h_node, "y"), idx(h_node, "x")])
        nodes = {"de_rotor": brg["de"]["rotor_node"], "de_housing": brg["de"]["housing_node"],
                 "nde_rotor": brg["nde"]["rotor_node"], "nde_housing": brg["nde"]["housing_node"]}
        self._out_dofs = np.array([[idx(nodes[loc], _DIR_DOF[d]) for d in DIRECTIONS] for loc in LOCATIONS])
        # bearing element of the faulty bearing, per direction (vertical, horizontal)
        self._kb = np.array([brg[fb]["stiffness_vertical_n_m"], brg[fb]["stiffness_horizontal_n_m"]], float)
        self._cb = np.array([brg[fb]["damping_vertical_n_s_m"], brg[fb]["damping_horizontal_n_s_m"]], float)
        # complex excitation amplitudes U (K, 2) and DC (2,)
        ex = self.excitation
        self._u = np.stack([ex.amplitude_m[d] * np.exp(1j * ex.phase_rad[d]) for d in DIRECTIONS], axis=1)
        self._u_dc = np.array([ex.dc_m[d] for d in DIRECTIONS])

        k = self.rotor.K
        # DC (static) response at the outputs
        f0 = np.zeros(self.rotor.ndof)
        f0[self._in_dofs[:2]] += self._kb * self._u_dc
        f0[self._in_dofs[2:]] -= self._kb * self._u_dc
        self._dc = np.linalg.solve(k, f0)[self._out_dofs]
        t3 = time.perf_counter()
        self._block = None
        self._modal_forms: dict = {}                       # order_modal_form() per output combination
        if solver == "block":
            try:
                self._block = ShaftSolver(self.rotor)
            except ValueError:
                self.solver = "direct"
        t4 = time.perf_counter()
        self.preparation_time_s["solver_setup"] = t4 - t3
        self.preparation_time_s["total"] = sum(v for kk, v in self.preparation_time_s.items() if kk != "total")

    # ------------------------------------------------------------------ solve
    def _forces(self, omega: np.ndarray) -> np.ndarray:
        """Complex force amplitudes at the 4 input DOFs, (..., K, 4) for omega (..., K) [rad/s]."""
        dyn = (self._kb + 1j * omega[..., None] * self._cb) * self._u          # (..., K, 2)
        return np.concatenate([dyn, -dyn], axis=-1)

    def response(self, speeds_hz) -> np.ndarray:
        """Complex displacement amplitudes (S, K, 4, 2) [m] at shaft speeds [Hz] (S speeds, K orders)."""
        speeds_hz = np.atleast_1d(np.asarray(speeds_hz, dtype=float))
        if np.any(~np.isfinite(speeds_hz)) or np.any(speeds_hz < 0):
            raise ValueError("speed_hz: must be finite and >= 0")
        n_s, n_k = speeds_hz.size, self.orders.size
        omega = TWO_PI * np.multiply.outer(speeds_hz, self.orders * self.bpfo_per_hz)   # (S, K)
        big_omega = np.broadcast_to((TWO_PI * speeds_hz)[:, None], omega.shape)
        f_in = self._forces(omega).reshape(-1, 4)                                         # (S K, 4)
        f = np.zeros((n_s * n_k, self.rotor.ndof), dtype=complex)
        f[:, self._in_dofs] = f_in
        w, big_w = omega.reshape(-1), big_omega.reshape(-1)
        if self._block is not None:
            x = self._block.solve(w, big_w, f)
        else:
            rot = self.rotor
            z = (rot.K[None] - (w ** 2)[:, None, None] * rot.M[None]
                 + 1j * w[:, None, None] * (rot.C[None] + big_w[:, None, None] * rot.G[None]))
            x = np.linalg.solve(z, f[..., None])[..., 0]
        out = x[:, self._out_dofs.reshape(-1)]
        return out.reshape(n_s, n_k, len(LOCATIONS), len(DIRECTIONS))

    def spectrum(self, speed_hz: float) -> Spectrum:
        """BKA-BEM spectrum at one shaft speed [Hz]."""
        speed_hz = float(speed_hz)
        x = self.response([speed_hz])[0]
        return Spectrum(speed_hz=speed_hz, orders=self.orders.copy(),
                        frequency_hz=self.orders * self.bpfo_per_hz * speed_hz, displacement=x,
                        dc_m=self._dc.copy(), fault_frequencies_hz=self.fault_multipliers.at_speed(speed_hz))

    def sweep(self, speeds_hz, batch: int = 16, progress: bool = False) -> Sweep:
        """Responses over many speeds [Hz], computed in batches (memory bounded)."""
        speeds_hz = np.asarray(speeds_hz, dtype=float).ravel()
        parts = []
        starts = range(0, speeds_hz.size, batch)
        if progress:
            from tqdm import tqdm
            starts = tqdm(starts, desc="sweep", unit="batch")
        for s in starts:
            parts.append(self.response(speeds_hz[s:s + batch]))
        disp = np.concatenate(parts) if parts else np.zeros((0, self.orders.size, 4, 2), complex)
        return Sweep(speeds_hz=speeds_hz, orders=self.orders.copy(), displacement=disp,
                     bpfo_per_hz=self.bpfo_per_hz)

    @property
    def dc_m(self) -> np.ndarray:
        """Static response (4, 2) [m] to the DC of the excitation."""
        return self._dc.copy()

    def order_modal_form(self, combination: np.ndarray | None = None) -> "OrderModalForm":
        """The exact pole-residue form of this model (:class:`OrderModalForm`), for fast evaluation at many
        speeds (one eigen-decomposition per order up front; kept per combination, so it is made once)."""
        key = _combination_key(combination)
        form = self._modal_forms.get(key)
        if form is None:
            form = self._modal_forms[key] = OrderModalForm(self, combination)
        return form

    def has_order_modal_form(self, combination: np.ndarray | None = None) -> bool:
        """Whether :meth:`order_modal_form` for this combination is made already (then it costs nothing)."""
        return _combination_key(combination) in self._modal_forms

    def solver_info(self) -> dict:
        """Which solver runs and on what model size."""
        return {"solver": self.solver, "ndof": self.rotor.ndof,
                "shaft_nodes": len(self.rotor.shaft_node_labels), "orders": int(self.orders.size)}


def _combination_key(combination) -> tuple | None:
    if combination is None:
        return None
    comb = np.ascontiguousarray(combination, dtype=float)
    return comb.shape, comb.tobytes()


class OrderModalForm:
    """Exact pole-residue form of the BKA-BEM response, order by order: any speed in microseconds.

    Along order k the spin speed is tied to the order frequency, ``Omega = omega / (k BPFO_per_Hz)``, so the
    dynamic stiffness of Eq. (8) is a fixed quadratic pencil in ``s = i omega`` for each order:

        Z_k(s) = K + s C + s^2 M_k,      M_k = M - i G / (k BPFO_per_Hz)

    (the gyroscopic term ``i omega Omega G = -i s^2 G / (k b)`` joins the mass). With the state matrix of that
    pencil diagonalised once per order, ``S_k = V diag(lambda) V^-1``, and the bearing force linear in omega
    (``F_k = (k_b + i omega c_b) U_k``, fixed ``U_k``), the response at any output combination u is

        X_{k,u}(omega) = D_{k,u} + sum_r E_{k,r,u} / (i omega - lambda_{k,r})

    exactly, for every shaft speed: the lightly damped resonances are poles here, not samples on a speed grid,
    and there is no interpolation in speed at all. ``D`` is zero analytically (displacement has no
    feed-through from force) and kept to round-off. One eigen-decomposition per order (2 ndof states; ~1.5 s for
    50 orders of the embedded case); then an evaluation is one complex division per pole and order and one
    multiply-add per pole, order and output.

    Parameters
    ----------
    model : BkaBem
    combination : ndarray (U, 8), optional
        Output combinations of the 8 output displacements (LOCATIONS x DIRECTIONS, row-major); default the
        identity (the 8 displacements themselves).

    Attributes
    ----------
    poles : ndarray complex (K, 2 ndof)
        lambda_{k,r} [rad/s].
    residues : ndarray complex (K, 2 ndof, U)
        E_{k,r,u} [m rad/s].
    direct : ndarray complex (K, U)
        D_{k,u} [m].
    static : ndarray complex (K, U)
        The static response X_k(0) [m], solved directly (K X0 = F(0)).

    Evaluation: the compiled kernel (``_modalsum.c``) sums the mode-acceleration form
    ``X = X0 + i w sum_r (E_r / lambda_r) / (i w - lambda_r)`` with float32 residues (half the memory; round-off
    below 1e-6 of a channel's largest order, see the kernel); :meth:`evaluate_numpy` the form above in double.
    """

    def __init__(self, model: "BkaBem", combination: np.ndarray | None = None):
        rot = model.rotor
        n = rot.ndof
        comb = np.eye(len(LOCATIONS) * len(DIRECTIONS)) if combination is None else np.asarray(combination, float)
        self.orders = np.asarray(model.orders, dtype=int)
        self.bpfo_per_hz = float(model.bpfo_per_hz)
        self.combination = comb
        out = np.asarray(model._out_dofs).reshape(-1)
        in_dofs = np.asarray(model._in_dofs)                 # rotor y, x, housing y, x of the faulty bearing
        k_u = model._kb * model._u                            # (K, 2): stiffness force per unit (k_b U_k)
        c_u = model._cb * model._u                            # (K, 2): damping force per unit omega (c_b U_k)
        n_k = self.orders.size
        self.poles = np.empty((n_k, 2 * n), complex)
        self.residues = np.empty((n_k, 2 * n, comb.shape[0]), complex)
        self.direct = np.empty((n_k, comb.shape[0]), complex)
        s = np.zeros((2 * n, 2 * n), complex)
        s[:n, n:] = np.eye(n)
        for i, k in enumerate(self.orders):
            m_inv = np.linalg.inv(rot.M - (1j / (k * self.bpfo_per_hz)) * rot.G)
            s[n:, :n] = -m_inv @ rot.K
            s[n:, n:] = -m_inv @ rot.C
            lam, vec = np.linalg.eig(s)
            w_in = np.linalg.solve(vec, np.vstack([np.zeros((n, 4)), m_inv[:, in_dofs]]))   # (2n, 4)
            wc = w_in[:, :2] - w_in[:, 2:]                    # +F at the rotor node, -F at the housing node
            a, b = wc @ k_u[i], wc @ c_u[i]                   # (2n,): F = a + i omega b per pole
            p = (comb @ vec[out, :]).T                        # (2n, U)
            # (a + i w b) / (i w - lam) = b + (a + lam b) / (i w - lam)
            self.poles[i] = lam
            self.residues[i] = p * (a + lam * b)[:, None]
            self.direct[i] = b @ p

        self._w_per_hz = TWO_PI * self.bpfo_per_hz * self.orders.astype(float)
        # static response per order (exact): K X0 = k_b U_k at the rotor node, -k_b U_k at the housing node
        f0 = np.zeros((rot.ndof, n_k), complex)
        f0[in_dofs[:2], :] = k_u.T
        f0[in_dofs[2:], :] = -k_u.T
        self.static = (comb @ np.linalg.solve(rot.K, f0)[out]).T                      # (K, U) [m]
        self._c = None
        self._speed_cells = None
        if _MODAL_KERNEL is not None and comb.shape[0] <= 8 and 2 * n <= 1024:     # the kernel's limits (MAXR)
            # the C kernel's form: X = X0 + i w sum_r E'_r / (i w - lambda_r), E' = E / lambda in float32,
            # 8 outputs (zero-padded), real and imaginary parts split (see _modalsum.c)
            n_u = comb.shape[0]
            e = np.zeros((n_k, 2 * n, 8), complex)
            e[..., :n_u] = self.residues / self.poles[:, :, None]
            x0 = np.zeros((n_k, 8), complex)
            x0[:, :n_u] = self.static
            self._c = [np.ascontiguousarray(self.poles.real), np.ascontiguousarray(self.poles.imag),
                       np.ascontiguousarray(e.real, dtype=np.float32), np.ascontiguousarray(e.imag, dtype=np.float32),
                       np.ascontiguousarray(x0.real), np.ascontiguousarray(x0.imag)]
            self._c_ptrs = [arr.ctypes.data for arr in self._c]

    def __call__(self, speed_hz: float) -> np.ndarray:
        """Complex displacement combinations (K, U) [m] at shaft speed ``speed_hz`` [Hz]."""
        w = self._w_per_hz * float(speed_hz)
        if self._c is not None:
            out = np.empty((2, self.orders.size, 8))          # per call: the form may be shared across threads
            _MODAL_KERNEL(self.orders.size, self.poles.shape[1], w.ctypes.data, *self._c_ptrs, out[0].ctypes.data,
                          out[1].ctypes.data)
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
        g = 1.0 / (iw[:, None] - self.poles)                                          # (K, 2n)
        return self.direct + np.matmul(g[:, None, :], self.residues)[:, 0, :]


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
        """Cell ``i`` (made if missing): its arrays, the kernel's header of their addresses, the near-pole mask,
        the header's address."""
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
            kk = fm.orders.astype(float)
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
        header = np.array([n_k, self.degree + 1, n_u] + [a.ctypes.data for a in arrays], dtype=np.int64)
        return arrays, header, near, header.ctypes.data

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
        self._kernel(c[3], f, 2.0 * f / self.cell_hz - (2 * i + 1), x.ctypes.data)      # t in [-1, 1]
        return x

    def evaluate_numpy(self, speed_hz: float) -> np.ndarray:
        """The same evaluation in numpy (the kernel's reference and fallback)."""
        f = float(speed_hz)
        i = int(f // self.cell_hz)
        arrays, _, near, _ = self.cell(i)
        t = 2.0 * f / self.cell_hz - (2 * i + 1)
        tc = np.polynomial.chebyshev.chebvander(np.array([t]), self.degree)[0]     # (D+1,)
        n_u = self.form.direct.shape[1]
        x = np.einsum("d,kdu->ku", tc, arrays[1] + 1j * arrays[2])[:, :n_u]
        fm = self.form
        iw = 1j * fm._w_per_hz * f
        g = np.where(near, 1.0 / (iw[:, None] - fm.poles), 0.0)
        return x + np.einsum("kr,kru->ku", g, fm.residues)


def _load_library(name: str):
    """A compiled kernel of this package (ctypes.CDLL), or None if it was not built."""
    import ctypes
    import importlib.util

    spec = importlib.util.find_spec(f"bkabem_core.{name}")
    if spec is None or not spec.origin or not spec.origin.endswith((".so", ".pyd", ".dylib")):
        return None
    return ctypes.CDLL(spec.origin)


def _load_kernel():
    """The compiled block-tridiagonal kernel (bkabem_core/_blocktri.c), or None if it was not built."""
    import ctypes

    lib = _load_library("_blocktri")
    if lib is None:
        return None
    fn = lib.bt_solve_coef
    ptr, cint = ctypes.c_void_p, ctypes.c_int
    fn.argtypes = [cint, cint, ptr, ptr, ptr, cint, ptr, ptr, ptr, ptr, ptr, ptr, ptr, ptr, ptr,
                   ptr, ptr, ptr, ptr, ptr, ptr, ctypes.c_double]
    fn.restype = cint
    return fn


_KERNEL = _load_kernel()


def _load_modal_kernel():
    """The compiled pole-residue sum (bkabem_core/_modalsum.c), or None if it was not built."""
    import ctypes

    lib = _load_library("_modalsum")
    if lib is None:
        return None
    fn = lib.modal_sum8
    fn.argtypes = [ctypes.c_int, ctypes.c_int] + [ctypes.c_void_p] * 9
    fn.restype = ctypes.c_int
    return fn


_MODAL_KERNEL = _load_modal_kernel()


def _load_cell_kernel():
    """The compiled speed-cell sum (bkabem_core/_modalsum.c, cell_sum8), or None if it was not built."""
    import ctypes

    lib = _load_library("_modalsum")
    if lib is None or not hasattr(lib, "cell_sum8"):
        return None
    fn = lib.cell_sum8
    fn.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_void_p]
    fn.restype = ctypes.c_int
    return fn


_CELL_KERNEL = _load_cell_kernel()


class ShaftSolver:
    """Exact batched solver of ``[K - w^2 M + i w (C + W G)] x = f`` for a single-shaft model.

    The housing DOFs (point masses that touch the shaft at one node and otherwise only the ground) are
    condensed exactly into the shaft node they hang on. What remains is the shaft matrix, block-tridiagonal
    with 4 x 4 blocks; a block LU (Thomas) sweep with partial pivoting inside each block solves every system
    of the batch (orders x speeds) in one call of a small C kernel (``_blocktri.c``). Members whose smallest
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
        _KERNEL(nb, b, cd.ctypes.data, cu.ctypes.data, cl.ctypes.data, no, self._o_node_c.ctypes.data,
                coo.ctypes.data, cso.ctypes.data, cos_.ctypes.data, w.ctypes.data, big_w.ctypes.data,
                f_s.ctypes.data, f_o.ctypes.data, x_o.ctypes.data, *(a.ctypes.data for a in work),
                bad.ctypes.data, self.PIVOT_RATIO_MIN)
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
