"""BKA-BEM harmonic solve: each bearing's excitation applied as a base excitation to the full FE model.

For each BPFO order k, each excited bearing b and each lateral direction d (vertical y, horizontal x) the
excitation (:mod:`bkabem_core.excitation.quasi_static`) gives the relative displacement ``u_k(t) = A_k cos(omega_k t + phi_k)``
that the bearing's kinematics (ball passage, dent) impose between rotor and housing. Paper Eq. (5): the bearing
element transmits it to the rotor node (+) and the housing node (-); in complex form, with ``u = Re(U e^{i omega
t})``, ``U = A e^{i phi}``:

    F_k = k_b U_k                        (``[excitation] force = "spring"``, default)
    F_k = (k_b + i omega_k c_b) U_k      (``"paper"``: Eq. 5 as printed)

The default keeps the damper where the time-domain model has it: across the bearing, acting on the actual
relative velocity; the printed Eq. 5 also drives the damper with the base motion, a force that grows with
omega without bound (docs/method.md). Eq. (8) in its equivalent complex form (real part = the paper's
``a sin + b cos``):

    [K - omega_k^2 M + i omega_k (C + Omega G)] X_k = sum_b F_{k,b},      omega_k = k 2 pi BPFO(Omega),

so that the response at any DOF is ``x(t) = Re(X_k e^{i omega_k t})``: amplitude |X_k| (Eq. 9) and phase
angle(X_k) in the same cosine convention as the excitation. Velocity and acceleration are ``i omega X`` and
``-omega^2 X``. The DC part (k = 0) is the static response ``K X_0 = sum_b k_b DC_b``. The model is the
:class:`bkabem_core.fe.machine.Machine` of the case: one bearing model at every bearing's own operating point,
the FE mesh converged up to the case's highest frequency, the rotor's structural damping.

Solvers
-------
``"modal"`` (default): the reduced model (:class:`bkabem_core.fe.modal.ModalBasis`: modes to 1.25 x the case's
highest frequency plus static residual vectors, tested against the full FE to < 0.01 dB) in its exact
pole-residue form per order (:class:`bkabem_core.fe.modal.OrderModalForm`), made at set-up (~1 s): a new speed
costs a pole sum (~50 us in C).
``"block"``: the full FE, exact: housings condensed into the shaft, block-tridiagonal LU in C
(:class:`bkabem_core.fe.solvers.ShaftSolver`; needs banded damping). ``"direct"``: the full FE by dense LU, any
model. Both are the references the modal form is tested against.

Units: SI (m, s, N, rad). Locations: DE/NDE rotor and housing nodes; directions ``vertical`` (y), ``horizontal``
(x).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from bkabem_core.bearing.deep_groove import FaultFrequencies
from bkabem_core.excitation.baseline import baseline_forces
from bkabem_core.excitation.line_names import line_labels
from bkabem_core.excitation.lines import BASE_PHASES, BEARING_COLUMNS, LineSet, MachinePhases, union
from bkabem_core.excitation.quasi_static import Excitation
from bkabem_core.fe.budget import check_line_modes, singular_stiffness
from bkabem_core.fe.machine import Machine
from bkabem_core.fe.modal import LineModes, ModalBasis, OrderModalForm, SpeedCells  # noqa: F401  (SpeedCells: for synth)
from bkabem_core.fe.rotor import Rotor
from bkabem_core.fe.solvers import ShaftSolver, solve_direct
from bkabem_core.model.case import Case
from bkabem_core.model.vocabulary import BEARINGS, DIRECTIONS, LOCATIONS

_DIR_DOF = {"vertical": "y", "horizontal": "x"}
TWO_PI = 2.0 * math.pi
SOLVERS = ("modal", "block", "direct")
#: Highest natural frequency the modal basis keeps, relative to the case's highest frequency (docs/method.md).
MODAL_CUTOFF_FACTOR = 1.25


@dataclass
class Spectrum:
    """BKA-BEM response at one shaft speed.

    Attributes
    ----------
    speed_hz : float
        Shaft speed [Hz].
    orders : ndarray of int (K,)
        BPFO order of each line (0: a line that is not a BPFO order, e.g. ``BPFI - 1 f_r``).
    frequency_hz : ndarray (K,)
        Frequency of each line [Hz] (``orders x BPFO`` for a BPFO order).
    displacement : ndarray complex (K, 4, 2)
        Complex displacement amplitude X [m] per order, location (LOCATIONS) and direction (DIRECTIONS):
        ``x(t) = Re(X e^{i 2 pi f t})`` with t = 0 at cage angle 0.
    dc_m : ndarray (4, 2)
        Static (k = 0) displacement [m] from the DC of the excitation.
    fault_frequencies_hz : FaultFrequencies
        FTF, BPFO, BPFI, BSF [Hz] at this speed of the DE bearing (the field of earlier versions, where both
        positions had one bearing); every bearing's: ``bearing_fault_frequencies_hz``.
    coefficients : ndarray of int (K, 6), optional
        Each line's coefficients on the machine's base phases (:data:`~bkabem_core.excitation.lines.BASE_PHASES`).
    bearing_fault_frequencies_hz : dict, optional
        ``{"de": FaultFrequencies, "nde": FaultFrequencies}`` [Hz] at this speed: each bearing's own.
    line_bearings : list of str, optional
        Per line the bearing whose cage or spin it follows (``"de"``, ``"nde"``, ``"de+nde"`` when both bearings
        share their kinematics, ``""`` for a shaft or supply line; :meth:`MachinePhases.line_bearings`).
    labels : tuple of str (K,), optional
        What each line is (:mod:`bkabem_core.excitation.line_names`: ``"BPFO"``, ``"BPFI - 1 f_r"``, ``"1x"``;
        with two different bearings the bearing's name follows: ``"BPFO (NDE)"``).
    band_hz : float
        Highest frequency the model serves [Hz] (the case's band, :attr:`Case.max_frequency_hz`): lines above it
        at this speed are beyond the converged FE model and every sample rate of the case; the overall RMS
        (:meth:`rms`) leaves them out.
    """

    speed_hz: float
    orders: np.ndarray
    frequency_hz: np.ndarray
    displacement: np.ndarray
    dc_m: np.ndarray
    fault_frequencies_hz: FaultFrequencies
    coefficients: np.ndarray | None = None
    bearing_fault_frequencies_hz: dict | None = None
    line_bearings: list | None = None
    labels: tuple | None = None
    band_hz: float = math.inf

    @property
    def in_band(self) -> np.ndarray:
        """(K,) bool: lines at or below :attr:`band_hz`."""
        return np.asarray(self.frequency_hz) <= self.band_hz

    def rms(self, quantity: str = "acceleration") -> np.ndarray:
        """Overall RMS of the lines in the band [m, m/s or m/s^2], (4, 2) (the static part excluded)."""
        x = {"acceleration": self.acceleration, "velocity": self.velocity, "displacement": self.displacement}[quantity]
        return np.sqrt(0.5 * np.sum(np.abs(x[self.in_band]) ** 2, axis=0))

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
        """JSON-ready (``bkabem spectrum --json``): per line its name (``lines``), coefficients and BPFO order (0: not
        one); per location and direction the line frequencies, amplitudes, phases and the static part."""
        out = {"speed_hz": self.speed_hz, "orders": [int(k) for k in self.orders],
               "fault_frequencies_hz": self.fault_frequencies_hz.to_dict(),
               "band_hz": self.band_hz if math.isfinite(self.band_hz) else None}
        if self.labels is not None:
            out["lines"] = list(self.labels)
        if self.bearing_fault_frequencies_hz is not None:
            out["bearing_fault_frequencies_hz"] = {b: ff.to_dict() for b, ff in
                                                   self.bearing_fault_frequencies_hz.items()}
        if self.coefficients is not None:
            c = np.asarray(self.coefficients)
            if c.shape[1] == len(BASE_PHASES):     # each line on its own bearing's phases (shaft, cage, spin, line)
                own = [BEARING_COLUMNS["nde" if b == "nde" else "de"] for b in (self.line_bearings or ["de"] * len(c))]
                out["line_coefficients"] = [[int(r[0]), int(r[cg]), int(r[sp]), int(r[-1])]
                                            for r, (cg, sp) in zip(c, own)]
                out["base_phases"] = list(BASE_PHASES)
                out["line_coefficients_machine"] = c.tolist()
            else:
                out["line_coefficients"] = c.tolist()
        if self.line_bearings is not None:
            out["line_bearings"] = list(self.line_bearings)
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
        Shaft speeds [Hz].
    orders : ndarray (K,)
        BPFO order of each line (0: not a BPFO order).
    displacement : ndarray complex (S, K, 4, 2) [m]
    bpfo_per_hz : float
        BPFO per shaft Hz [-].
    multipliers : ndarray (K,), optional
        Speed-proportional part of each line's frequency [Hz per shaft Hz]; without it every line must be a BPFO
        order (``orders x bpfo_per_hz``).
    fixed_hz : ndarray (K,), optional
        Part of each line's frequency that does not follow the speed [Hz] (0 without it).
    coefficients : ndarray of int (K, 4), optional
        Each line's coefficients on the base phases.
    labels : tuple of str (K,), optional
        What each line is (``"BPFO"``, ``"BPFI - 1 f_r"``, ``"1x"``).
    band_hz : float
        Highest frequency the model serves [Hz] (:attr:`Spectrum.band_hz`): :meth:`rms` leaves the lines above it
        out at each speed.
    """

    speeds_hz: np.ndarray
    orders: np.ndarray
    displacement: np.ndarray
    bpfo_per_hz: float
    multipliers: np.ndarray | None = None
    fixed_hz: np.ndarray | None = None
    coefficients: np.ndarray | None = None
    labels: tuple | None = None
    band_hz: float = math.inf

    def __post_init__(self):
        if self.multipliers is None and np.any(np.asarray(self.orders) <= 0):
            raise ValueError("multipliers: required when a line is not a BPFO order (orders 0)")

    @classmethod
    def concatenate(cls, parts) -> "Sweep":
        """One sweep of the sweeps ``parts`` of the same model over consecutive speeds (their lines are equal)."""
        parts = list(parts)
        first = parts[0]
        return cls(speeds_hz=np.concatenate([p.speeds_hz for p in parts]), orders=first.orders,
                   displacement=np.concatenate([p.displacement for p in parts]), bpfo_per_hz=first.bpfo_per_hz,
                   multipliers=first.multipliers, fixed_hz=first.fixed_hz, coefficients=first.coefficients,
                   labels=first.labels, band_hz=first.band_hz)

    @property
    def frequency_hz(self) -> np.ndarray:
        """(S, K) frequency of every line at every speed [Hz]."""
        if self.multipliers is None:
            return np.multiply.outer(self.speeds_hz, self.orders * self.bpfo_per_hz)
        fixed = 0.0 if self.fixed_hz is None else self.fixed_hz
        return np.multiply.outer(self.speeds_hz, self.multipliers) + fixed

    @property
    def acceleration(self) -> np.ndarray:
        w = TWO_PI * self.frequency_hz
        return -(w[..., None, None] ** 2) * self.displacement

    @property
    def in_band(self) -> np.ndarray:
        """(S, K) bool: lines at or below :attr:`band_hz` at each speed."""
        return self.frequency_hz <= self.band_hz

    def rms(self, quantity: str = "acceleration") -> np.ndarray:
        """Overall RMS of the lines in the band at each speed [m or m/s^2], shape (S, 4, 2) (DC excluded)."""
        x = self.acceleration if quantity == "acceleration" else self.displacement
        return np.sqrt(0.5 * np.sum(np.abs(x) ** 2 * self.in_band[..., None, None], axis=1))


class BkaBem:
    """The BKA-BEM model of one case: bearing excitations + FE machine, solved order by order at any speed.

    Parameters
    ----------
    case : Case
    excitation : Excitation or dict name -> Excitation, optional
        Precomputed excitation(s); a single one is the excitation of the bearing it names (``Excitation.bearing``,
        default the faulty one). Default: computed from the case (:meth:`Machine.excitations`).
    solver : {"modal", "block", "direct"}
        See the module docstring.
    machine : Machine, optional
        A machine of this case made already.
    like : BkaBem, optional
        A model of a case with the same FE (another defect or excitation, e.g. a defect that grows): its FE, modal
        basis and line modes are reused, so only the excitation is new (milliseconds instead of ~1 s).

    Attributes
    ----------
    machine : Machine
    rotor : Rotor
    excitations : dict name -> Excitation
        The applied excitation of each excited bearing, on the common ``orders``.
    bearing_multipliers : dict name -> FaultFrequencies
        FTF, BPFO, BPFI, BSF per shaft Hz of the bearing at each position (its own kinematics).
    phases : MachinePhases
        The machine's base phases (a cage and a spin phase per bearing, shared when their rates are equal).
    lines : LineSet
        Every line on the machine's base phases, sorted by frequency.
    orders : ndarray of int
        Per line its BPFO order of the DE bearing (``orders x bpfo_per_hz`` is its multiplier) when the line is one;
        0 for any other line (an inner-race or ball line, a shaft or supply line, a line of a different NDE
        bearing).
    bpfo_per_hz : float
        The DE bearing's BPFO per shaft Hz: the unit of ``orders``.
    speed_locked_index : ndarray of int
        The lines whose frequency is proportional to the shaft speed (``lines.speed_locked``): their response is
        the line modes' pole-residue sum.
    fixed_frequency_index : ndarray of int
        The other lines (the supply's: a fixed part in Hz), each solved at its own frequency
        (:meth:`fixed_frequency_lines`).
    preparation_time_s : dict
        Wall time of each preparation stage [s].
    """

    def __init__(self, case: Case, excitation: Excitation | dict | None = None, solver: str = "modal",
                 machine: Machine | None = None, like: "BkaBem | None" = None, baseline: bool = True):
        if solver not in SOLVERS:
            raise ValueError(f"solver: must be one of {', '.join(SOLVERS)} (got {solver!r})")
        self.case = case
        self.solver = solver
        self.preparation_time_s = {}
        t0 = time.perf_counter()
        reuse = like is not None and machine is None and Machine.fe_key(like.case) == Machine.fe_key(case)
        if reuse:
            machine = Machine(case, mesh=like.machine.mesh, rotor=like.rotor)
        self.machine = machine if machine is not None else Machine(case)
        self.rotor: Rotor = self.machine.rotor
        t1 = time.perf_counter()
        if excitation is None:
            raw = self.machine.excitations()
        elif isinstance(excitation, Excitation):
            raw = {excitation.bearing or case.faulty_bearing: excitation}
        else:
            raw = dict(excitation)
        t2 = time.perf_counter()
        self.preparation_time_s["fe_assembly"] = t1 - t0
        self.preparation_time_s["excitation"] = t2 - t1 if excitation is None else 0.0
        self.bearing_multipliers = {b: case.fault_multipliers(b) for b in BEARINGS}
        self.phases = MachinePhases.of(self.bearing_multipliers)
        self.bpfo_per_hz = self.bearing_multipliers["de"].bpfo           # the unit of `orders`
        self.n_balls = int(case.bearing_geometry("de").n_balls)
        rates = self.phases.rates_per_hz
        self.force_model = case.raw["excitation"]["force"]

        # input patterns: a force pair across each bearing (+ rotor node, - housing node), vertical and horizontal,
        # then the machine baseline's force patterns (unbalance at the disks, misalignment, magnetic pull)
        idx = self.rotor.dof_index
        sites = self.machine.sites
        self._patterns = [(b, d) for b in BEARINGS for d in DIRECTIONS]
        names = [f"{b}.{d}" for b, d in self._patterns]
        base_lines, base_patterns = (baseline_forces(case, self.rotor, rates) if baseline
                                     else (LineSet.empty((), rates), {}))
        self.include_baseline = bool(baseline)
        p = np.zeros((self.rotor.ndof, len(names) + len(base_patterns)))
        for j, (b, d) in enumerate(self._patterns):
            p[idx(sites[b].rotor_node, _DIR_DOF[d]), j] += 1.0
            p[idx(sites[b].housing_node, _DIR_DOF[d]), j] -= 1.0
        for j, name in enumerate(base_lines.inputs):
            p[:, len(names) + j] = base_patterns[name]
        self.input_names = tuple(names) + tuple(base_lines.inputs)
        self._p = p
        nodes = {"de_rotor": sites["de"].rotor_node, "de_housing": sites["de"].housing_node,
                 "nde_rotor": sites["nde"].rotor_node, "nde_housing": sites["nde"].housing_node}
        self._out_dofs = np.array([[idx(nodes[loc], _DIR_DOF[d]) for d in DIRECTIONS] for loc in LOCATIONS])

        # the lines: every bearing's excitation lines and the baseline's, on one set (sorted by frequency)
        self.bearing_lines = {b: self.phases.place(e.line_set(), b) for b, e in raw.items()}
        disp = [ls.with_inputs(names[:4], [names.index(f"{b}.{d}") for d in DIRECTIONS])
                for b, ls in self.bearing_lines.items()]
        everything = union([u.with_inputs(self.input_names, range(4)) for u in disp]
                           + [base_lines.with_inputs(self.input_names, range(4, len(self.input_names)))])
        self.lines = everything
        n_k = len(everything)
        z = self.n_balls
        c = everything.coefficients
        pure = (c[:, [0, 2, 3, 4, 5]] == 0).all(axis=1) & (c[:, 1] % z == 0)        # the DE bearing's BPFO orders
        self.orders = np.where(pure, c[:, 1] // z, 0).astype(int)
        self.excitations = {b: (e.on_orders(self.orders[pure]) if e.lines is None else e) for b, e in raw.items()}
        # force per line on the patterns: F = a + i omega b  (K, P) [N], [N s]; bearing columns k_b U (+ c_b U)
        amp = everything.amplitude
        self._force_a = np.zeros((n_k, len(self.input_names)), complex)
        self._force_b = np.zeros_like(self._force_a)
        self._force_a[:, 4:] = amp[:, 4:]
        f0 = np.zeros(len(self.input_names))
        for j, (b, d) in enumerate(self._patterns):
            if b not in raw:
                continue
            kb = sites[b].stiffness_n_m[1 if d == "vertical" else 0]
            cb = sites[b].damping_n_s_m[1 if d == "vertical" else 0]
            self._force_a[:, j] = kb * amp[:, j]
            if self.force_model == "paper":
                self._force_b[:, j] = cb * amp[:, j]
            f0[j] = kb * self.bearing_lines[b].dc[DIRECTIONS.index(d)]
        self._speed_power = everything.speed_power.astype(float)
        self._locked = everything.speed_locked
        self.speed_locked_index = np.flatnonzero(self._locked)
        self.fixed_frequency_index = np.flatnonzero(~self._locked)
        # DC (static) response at the outputs
        self._dc = np.linalg.solve(self.rotor.K, p @ f0)[self._out_dofs]
        t3 = time.perf_counter()
        self._block = None
        self._basis = None
        self._line_modes = None
        self._modal_forms: dict = {}                       # order_modal_form() per output combination
        if solver == "block":
            try:
                self._block = ShaftSolver(self.rotor)
            except ValueError:
                self.solver = "direct"
        elif solver == "modal":
            if reuse and like._basis is not None and like.input_names == self.input_names:
                self._basis = like._basis
                if like._line_modes is not None:            # the speed-locked lines only, as line_modes makes them
                    locked = self.multipliers[self.speed_locked_index]
                    pos = {float(v): i for i, v in enumerate(like._line_modes.multipliers)}
                    rows = [pos.get(float(v)) for v in locked]
                    if all(r is not None for r in rows):
                        self._line_modes = like._line_modes.subset(rows)
                    else:
                        self._line_modes = like._line_modes.extended(locked)
            else:
                self._basis = self._make_basis()
            self.order_modal_form()
        self.preparation_time_s["solver_setup"] = time.perf_counter() - t3
        self.preparation_time_s["total"] = sum(v for kk, v in self.preparation_time_s.items() if kk != "total")

    @property
    def fault_multipliers(self):
        """FTF, BPFO, BPFI, BSF per shaft Hz of the machine's bearings when both positions have the same ones (one
        bearing type); ValueError for two different bearings (:attr:`bearing_multipliers` has each)."""
        de, nde = self.bearing_multipliers["de"], self.bearing_multipliers["nde"]
        if de != nde:
            raise ValueError("the DE and NDE bearings have different kinematics: bearing_multipliers[position] "
                             "gives each bearing's fault multipliers")
        return de

    def shared_phase_lines(self) -> LineSet:
        """:attr:`lines` on one bearing's base phases (shaft, cage, spin, line): the form of a machine whose two
        bearings turn their cages and balls at the same rates (:meth:`MachinePhases.on_one_bearing`). ValueError
        for two bearings of different kinematics."""
        return self.phases.on_one_bearing(self.lines)

    def fault_frequencies_hz(self, speed_hz: float) -> dict:
        """``{"de": FaultFrequencies, "nde": FaultFrequencies}`` [Hz] at a shaft speed [Hz]."""
        return {b: fm.at_speed(speed_hz) for b, fm in self.bearing_multipliers.items()}

    def spectrum_fields(self, speed_hz: float) -> dict:
        """The kinematic fields of a :class:`Spectrum` at ``speed_hz`` [Hz]: the DE bearing's fault frequencies,
        every bearing's, and each line's coefficients and bearing."""
        ff = self.fault_frequencies_hz(speed_hz)
        return {"fault_frequencies_hz": ff["de"], "bearing_fault_frequencies_hz": ff,
                "coefficients": self.lines.coefficients.copy(),
                "line_bearings": self.phases.line_bearings(self.lines.coefficients)}

    @property
    def is_order_set(self) -> bool:
        """Whether every line is a BPFO order of the DE bearing (an outer-race or healthy bearing set without
        baseline, one bearing type or the NDE not excited): the form of the earlier versions, which the improved
        method's orders form and the TDSM's order-by-order validation take."""
        return bool(np.all(self.orders > 0)) and self.one_ball_pass

    @property
    def one_ball_pass(self) -> bool:
        """Whether both bearings have the same fault multipliers (one ball-pass period: one bearing type, or two of
        the same kinematics and ball count), so that the machine's steady state repeats with the DE's BPFO."""
        return self.bearing_multipliers["de"] == self.bearing_multipliers["nde"]

    @property
    def fixed_hz(self) -> np.ndarray:
        """(K,) fixed part of each line's frequency [Hz] (the electrical line; 0 for speed-locked lines)."""
        return self.lines.fixed_hz

    def frequency_hz(self, speed_hz: float) -> np.ndarray:
        """Line frequencies [Hz] at a shaft speed [Hz]."""
        return self.lines.frequency_hz(speed_hz)

    @property
    def band_hz(self) -> float:
        """Highest frequency the model serves [Hz]: the case's band (:attr:`Case.max_frequency_hz`, half its
        highest sample rate), up to which the FE mesh is converged and the modal basis complete."""
        return float(self.case.max_frequency_hz)

    @cached_property
    def line_labels(self) -> tuple:
        """What each line is (``"BPFO"``, ``"BPFI - 1 f_r"``, ``"2 BSF + FTF"``, ``"1x"``), (K,): named once per
        model (the lines are the model's), not at every spectrum."""
        c = self.lines.coefficients
        out = []
        for j, b in enumerate(self.phases.line_bearings(c)):
            own = b.split("+")[0] or "de"                      # a shaft or supply line: no cage, any bearing's columns
            cage, spin = self.phases.columns(own)
            four = np.array([c[j, 0], c[j, cage], c[j, spin], c[j, -1]])
            z = int(self.case.bearing_geometry(own).n_balls)
            label = line_labels(four[None, :], z)[0]
            out.append(label if self.phases.shared or b in ("", "de+nde") else f"{label} ({own.upper()})")
        return tuple(out)

    # ------------------------------------------------------------------ solve
    @property
    def multipliers(self) -> np.ndarray:
        """Speed-locked part of every line's frequency per shaft frequency ``nu_j`` [-] (``k BPFO_per_Hz`` for
        BPFO order k, exactly that product for an order set)."""
        if self.is_order_set:
            return self.orders * self.bpfo_per_hz
        return self.lines.multipliers

    @property
    def basis(self) -> ModalBasis:
        """The reduced modal basis (made on first use with another solver)."""
        if self._basis is None:
            self._basis = self._make_basis()
        return self._basis

    def _make_basis(self) -> ModalBasis:
        try:
            return ModalBasis(self.rotor, self._p, self._out_dofs.reshape(-1),
                              MODAL_CUTOFF_FACTOR * self.case.max_frequency_hz)
        except ValueError as exc:
            if "rigid-body" not in str(exc):
                raise
            raise singular_stiffness(self.case, "a rigid-body mode") from None

    @property
    def line_modes(self) -> LineModes:
        """The reduced model diagonalised along every speed-locked line (made on first use; ~1 s for 50)."""
        if self._line_modes is None:
            check_line_modes(self.case, self.speed_locked_index.size, self.basis.size)
            self._line_modes = LineModes(self.basis, self.multipliers[self.speed_locked_index])
        return self._line_modes

    def response(self, speeds_hz) -> np.ndarray:
        """Complex displacement amplitudes (S, K, 4, 2) [m] at shaft speeds [Hz] (S speeds, K lines)."""
        speeds_hz = np.atleast_1d(np.asarray(speeds_hz, dtype=float))
        if np.any(~np.isfinite(speeds_hz)) or np.any(speeds_hz < 0):
            raise ValueError("speed_hz: must be finite and >= 0")
        n_s, n_k = speeds_hz.size, len(self.lines)
        if self.solver != "modal":
            return self.response_full(speeds_hz)
        form = self.order_modal_form()
        out = np.empty((n_s, n_k, len(LOCATIONS) * len(DIRECTIONS)), complex)
        for i, f in enumerate(speeds_hz):
            if self.speed_locked_index.size:
                out[i, self.speed_locked_index] = form(f)
            if self.fixed_frequency_index.size:
                out[i, self.fixed_frequency_index] = self.fixed_frequency_lines(f)
        self._apply_speed_power(out, speeds_hz)
        return out.reshape(n_s, n_k, len(LOCATIONS), len(DIRECTIONS))

    def _apply_speed_power(self, out: np.ndarray, speeds_hz: np.ndarray) -> None:
        """Amplitudes that grow with speed (unbalance: f^2) scaled in place, (S, K, ...)."""
        if np.any(self._speed_power != 0.0):
            fac = np.power.outer(np.asarray(speeds_hz, dtype=float), self._speed_power)
            out *= fac.reshape(fac.shape + (1,) * (out.ndim - 2))

    def fixed_frequency_lines(self, speed_hz: float) -> np.ndarray:
        """The lines whose frequency does not follow the speed (the electrical line), (K_fixed, 8) [m]: one dense
        solve of the reduced model each (the gyroscopic term changes with speed, so they have no fixed pencil)."""
        idx = self.fixed_frequency_index
        w = TWO_PI * (self.lines.multipliers[idx] * speed_hz + self.lines.fixed_hz[idx])
        big = np.full(idx.size, TWO_PI * speed_hz)
        f = self._force_a[idx] + 1j * w[:, None] * self._force_b[idx]
        return self.basis.solve(w, big, f)

    def response_full(self, speeds_hz) -> np.ndarray:
        """The same on the full FE model (block-tridiagonal or dense LU: the exact reference)."""
        speeds_hz = np.atleast_1d(np.asarray(speeds_hz, dtype=float))
        n_s, n_k = speeds_hz.size, len(self.lines)
        omega = TWO_PI * (np.multiply.outer(speeds_hz, self.multipliers) + self.lines.fixed_hz[None])   # (S, K)
        big_omega = np.broadcast_to((TWO_PI * speeds_hz)[:, None], omega.shape)
        f_in = self._force_a[None] + 1j * omega[..., None] * self._force_b[None]              # (S, K, P)
        f = f_in.reshape(-1, f_in.shape[-1]) @ self._p.T                                       # (S K, ndof)
        w, big_w = omega.reshape(-1), big_omega.reshape(-1)
        if self._block is None and self.solver == "block":
            self._block = ShaftSolver(self.rotor)
        x = self._block.solve(w, big_w, f) if self._block is not None else solve_direct(self.rotor, w, big_w, f)
        out = x[:, self._out_dofs.reshape(-1)].reshape(n_s, n_k, -1)
        self._apply_speed_power(out, speeds_hz)
        return out.reshape(n_s, n_k, len(LOCATIONS), len(DIRECTIONS))

    def spectrum(self, speed_hz: float) -> Spectrum:
        """BKA-BEM spectrum at one shaft speed [Hz]."""
        speed_hz = float(speed_hz)
        x = self.response([speed_hz])[0]
        return Spectrum(speed_hz=speed_hz, orders=self.orders.copy(), frequency_hz=self.frequency_hz(speed_hz),
                        displacement=x, dc_m=self._dc.copy(), **self.spectrum_fields(speed_hz),
                        labels=self.line_labels, band_hz=self.band_hz)

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
                     bpfo_per_hz=self.bpfo_per_hz, multipliers=self.multipliers.copy(),
                     fixed_hz=self.lines.fixed_hz.copy(), coefficients=self.lines.coefficients.copy(),
                     labels=self.line_labels, band_hz=self.band_hz)

    @property
    def dc_m(self) -> np.ndarray:
        """Static response (4, 2) [m] to the DC of the excitations."""
        return self._dc.copy()

    @property
    def excitation(self) -> Excitation:
        """The faulty bearing's excitation (or the first excited bearing's)."""
        fb = self.case.faulty_bearing
        return self.excitations[fb] if fb in self.excitations else next(iter(self.excitations.values()))

    def order_modal_form(self, combination: np.ndarray | None = None) -> OrderModalForm:
        """The exact pole-residue form of the reduced model (:class:`OrderModalForm`), for fast evaluation at many
        speeds (one eigen-decomposition per order up front; kept per combination, so it is made once)."""
        key = _combination_key(combination)
        form = self._modal_forms.get(key)
        if form is None:
            li = self.speed_locked_index
            form = self._modal_forms[key] = OrderModalForm(self.line_modes, self._force_a[li], self._force_b[li],
                                                           combination, orders=self.orders[li])
        return form

    def has_line_modes(self) -> bool:
        """Whether the line modes are made already (then a modal form for any output combination is cheap)."""
        return self._line_modes is not None

    def has_order_modal_form(self, combination: np.ndarray | None = None) -> bool:
        """Whether :meth:`order_modal_form` for this combination is made already (then it costs nothing)."""
        return _combination_key(combination) in self._modal_forms

    def solver_info(self) -> dict:
        """Which solver runs and on what model size."""
        info = {"solver": self.solver, "ndof": self.rotor.ndof, "fe_elements": self.machine.mesh.n_elements,
                "shaft_nodes": len(self.rotor.shaft_node_labels), "orders": int(self.orders.size),
                "lines": len(self.lines), "inputs": list(self.input_names),
                "excited_bearings": sorted(self.excitations), "force": self.force_model}
        if self._basis is not None:
            info.update({"modal_basis_size": self._basis.size, "modal_cutoff_hz": self._basis.cutoff_hz})
        return info


def _combination_key(combination) -> tuple | None:
    if combination is None:
        return None
    comb = np.ascontiguousarray(combination, dtype=float)
    return comb.shape, comb.tobytes()
