"""Time-domain solution method (TDSM): the full nonlinear rotor-bearing model integrated in time.

This is the reference BKA-BEM is validated against (paper section 5). Same case as the core:

* the FE rotor of :func:`bkabem_core.rotor.rotor_from_case` (Timoshenko shaft, disks, both housings on their
  supports), **without** the two linear ``[bearings.de]``/``[bearings.nde]`` elements;
* instead, between rotor node and housing node of each bearing, the nonlinear Sopanen-Mikkola ball force of
  :class:`bkabem_core.bearing.Bearing` (Hertz contacts with the case's clearance; the dent in the faulty bearing,
  the other one healthy) in parallel with the viscous damper ``[excitation] bearing_damping_n_s_m`` (the paper's
  0.55 N s/mm, the same damper as the 4-DOF model);
* gravity on every mass; constant shaft speed Omega (in ``Omega G``) and cage angle ``theta = 2 pi FTF f t``
  (t = 0 at cage angle 0, the BKA-BEM phase reference);
* integrated from the static equilibrium of this nonlinear model (solved, with the dent ignored at t = 0).

Integrator
----------
The equations are written for the deviation ``x`` from the static equilibrium. With ``f`` the 4 nonlinear
bearing forces (DE x, y; NDE x, y; minus their static values) one constant step ``h`` is the affine map

    z_{n+1} = T z_n + W f_{n+1} + W_p f_n,

precomputed once. Two schemes:

``"exponential"`` (default)
    ``z = [x, v]``; the linear part (FE rotor, housings, supports, dampers, ``Omega G``) is discretised exactly
    (matrix exponential) and the bearing forces are linear in time over a step (first-order hold). No mode of
    the linear part suffers period error or numerical damping at any step, which matters here: the shaft has
    bending modes at 2-5 kHz with damping ratios of 0.001-0.004 that some BPFO harmonics hit.
``"newmark"``
    ``z = [x, v, a]``; HHT-alpha (``hht_alpha = 0``: Newmark average acceleration, exact discrete energy balance
    for a linear model). Second order too, but its period error shifts the lightly damped shaft resonances: it
    needs a 4-8 times smaller step for the same accuracy of the resonant orders (docs/validation.md).

In both, the bearing relative displacements ``u = B^T x`` satisfy ``u = u_pred + H f(u)`` with the precomputed
4 x 4 flexibility ``H``: Newton iterates on these 4 unknowns only (one ball-force evaluation and a 4 x 4 update
per iteration), and the full state is updated once per step. ``|H K_contact|`` is about 1e-3 at these steps, so
the Newton update uses ``(I + H K)^-1 ~ I - H K`` (checked at set-up; the exact 4 x 4 solve otherwise). There is
no model reduction: the FE has 60 DOFs, a step is one 120 x 120 matrix-vector product, and reduction would add
an error without saving time (the cost is Python overhead of the ball-force evaluation, see BENCHMARKS.md).

The step is chosen as ``h = T_bpfo / N`` (N integer, ``h <= max_step_s``), so every BPFO period holds exactly N
steps: the steady-state response is BPFO-periodic and its FFT over whole periods has no leakage. The ball
positions (and the dent depth felt by each ball) are tabulated once for one BPFO period: after one period the
ball set has turned by exactly one ball pitch and the table repeats.

Units: SI (m, s, N, rad). Axes as in :mod:`bkabem_core.rotor`: x horizontal, y vertical (up), z axial.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from .bearing import TWO_PI
from .case import Case
from .rotor import Rotor, rotor_from_case

__all__ = ["Tdsm", "TdsmResult", "PeriodicSolution", "StaticEquilibrium", "HertzPair", "LinearPair", "LOCATIONS", "DIRECTIONS"]

LOCATIONS = ("de_rotor", "de_housing", "nde_rotor", "nde_housing")
DIRECTIONS = ("vertical", "horizontal")
BEARINGS = ("de", "nde")
_DIR_DOF = {"vertical": "y", "horizontal": "x"}


# --------------------------------------------------------------------------- bearing force models
class HertzPair:
    """Nonlinear ball forces of the DE and NDE bearings, tabulated over one BPFO period.

    ``evaluate(u, j)`` returns the forces on the two rotor nodes (4,) ``[F_x DE, F_y DE, F_x NDE, F_y NDE]`` [N]
    and the tangent stiffness ``K = -dF/du`` (4, 4, block diagonal) [N/m] for relative displacements
    ``u = [e_x DE, e_y DE, e_x NDE, e_y NDE]`` [m] at table step ``j`` (cage angle ``j h omega_cage`` modulo one
    ball pitch). Same equations as :meth:`Bearing.forces_n` (Eqs. 1, 3, 4; the dent of ``Bearing.dent_depth_m``),
    written for both bearings at once: one (4 x z) @ (z x 6) product gives all force and stiffness sums.

    Parameters
    ----------
    bearings : (Bearing, Bearing)
        DE and NDE bearing (same ball set and cage speed: one shaft).
    cage_angles_rad : ndarray (N,)
        Cage angles of the table steps [rad].
    films_m : (float, float)
        EHL film thickness of each bearing [m] (0 if the case disables it).
    """

    def __init__(self, bearings, cage_angles_rad, films_m=(0.0, 0.0)):
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
        off = np.empty((len(cage_angles_rad), 2, g0.n_balls))
        for i, b in enumerate(bearings):
            off[:, i, :] = 0.5 * b.geometry.diametral_clearance_m - films_m[i]
            if b.dent is not None:
                off[:, i, :] += b.dent_depth_m(beta)
        self.offset = off
        self.k = np.array([b.contact_constant_n_m15 * math.cos(b.geometry.contact_angle_rad) for b in bearings])
        # Y = [delta^1.5 (2 rows); delta^0.5 (2 rows)] @ rt  -> (4, 6), flattened 24:
        # F = -k Y[b, 0:2];  K = 1.5 k [[Y[2+b, 2], Y[2+b, 3]], [Y[2+b, 3], Y[2+b, 4]]]
        self._f_idx = np.array([0, 1, 6, 7])
        self._f_scale = -np.repeat(self.k, 2)
        kmap = np.full((4, 4), 17)                                           # Y[2, 5] = 0
        kmap[0, 0], kmap[0, 1], kmap[1, 0], kmap[1, 1] = 14, 15, 15, 16
        kmap[2, 2], kmap[2, 3], kmap[3, 2], kmap[3, 3] = 20, 21, 21, 22
        self._k_idx = kmap
        self._k_scale = 1.5 * np.repeat(self.k, 2)[:, None]
        self._buf = np.empty((4, g0.n_balls))
        self.n_table = len(cage_angles_rad)

    def evaluate(self, u, j):
        buf = self._buf
        delta = u.reshape(2, 2).dot(self.cs[j])
        delta -= self.offset[j]
        np.maximum(delta, 0.0, out=delta)
        np.sqrt(delta, out=buf[2:])
        np.multiply(delta, buf[2:], out=buf[:2])
        y = buf.dot(self.rt[j]).ravel()
        return y[self._f_idx] * self._f_scale, y[self._k_idx] * self._k_scale

    def potential_energy_j(self, u, j):
        """Elastic energy stored in the ball contacts [J] (``sum 2/5 K delta^2.5``)."""
        delta = u.reshape(2, 2).dot(self.cs[j]) - self.offset[j]
        delta = np.maximum(delta, 0.0)
        return float(np.sum(0.4 * self.k[:, None] * delta ** 2.5))


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

    def evaluate(self, u, j):
        return -self._kflat * u, self.kt

    def potential_energy_j(self, u, j):
        return float(0.5 * np.sum(self._kflat * u * u))


# --------------------------------------------------------------------------- results
@dataclass
class StaticEquilibrium:
    """Static equilibrium of the nonlinear model under gravity (dent ignored, cage angle 0).

    Attributes
    ----------
    q_m : ndarray (ndof,)
        Static displacement of every DOF [m, rad].
    relative_m : dict bearing -> ndarray (2,)
        Rotor-minus-housing displacement ``(e_x, e_y)`` at each bearing [m].
    force_n : dict bearing -> ndarray (2,)
        Force of the bearing on its rotor node ``(F_x, F_y)`` [N] (F_y > 0 carries the rotor).
    iterations : int
        Newton iterations.
    """

    q_m: np.ndarray
    relative_m: dict
    force_n: dict
    iterations: int

    def to_dict(self) -> dict:
        return {"relative_m": {b: v.tolist() for b, v in self.relative_m.items()},
                "force_n": {b: v.tolist() for b, v in self.force_n.items()}, "iterations": self.iterations}


@dataclass
class TdsmResult:
    """A TDSM run: the recorded response after the discarded start transient.

    Attributes
    ----------
    speed_hz : float
        Shaft speed [Hz].
    step_s : float
        Integration step h [s] (``T_bpfo / steps_per_bpfo``).
    steps_per_bpfo : int
        Integration steps per BPFO period.
    record_every : int
        One sample is stored every ``record_every`` steps.
    settle_s : float
        Discarded start transient [s] (whole BPFO periods).
    time_s : ndarray (N,)
        Sample times from the start of the recording [s]; the recording starts at a whole number of BPFO
        periods, so t = 0 is again "cage angle 0" for the BPFO-periodic response.
    displacement_m : ndarray (N, 4, 2)
        Absolute displacement [m] of the LOCATIONS in DIRECTIONS (static sag included).
    bearing_relative_m : ndarray (N, 2, 2)
        Rotor-minus-housing displacement at (de, nde) in DIRECTIONS [m].
    bearing_force_n : ndarray (N, 2, 2)
        Ball force on the rotor node at (de, nde) in DIRECTIONS [N] (damper not included).
    bpfo_hz : float
        Ball-pass frequency, outer race [Hz].
    static : StaticEquilibrium
    steps : int
        Steps integrated (settling included).
    wall_time_s : float
        Wall time of the integration (set-up excluded, it is in ``setup_time_s``) [s].
    setup_time_s : float
        Wall time of the model set-up (matrices, static equilibrium, tables) [s].
    newton_iterations_mean, newton_iterations_max : float, int
        Newton iterations per step.
    interrupted : bool
        True if the run was stopped (Ctrl-C) before the requested end; the arrays hold what was computed.
    settings : dict
        Everything that defines the run (reproducibility); ``case_hash`` included.
    """

    speed_hz: float
    step_s: float
    steps_per_bpfo: int
    record_every: int
    settle_s: float
    time_s: np.ndarray
    displacement_m: np.ndarray
    bearing_relative_m: np.ndarray
    bearing_force_n: np.ndarray
    bpfo_hz: float
    static: StaticEquilibrium
    steps: int
    wall_time_s: float
    setup_time_s: float
    newton_iterations_mean: float
    newton_iterations_max: int
    interrupted: bool
    settings: dict = field(default_factory=dict)

    @property
    def ms_per_step(self) -> float:
        return 1e3 * self.wall_time_s / max(self.steps, 1)

    @property
    def whole_periods(self) -> int:
        """Whole BPFO periods in the recording."""
        per = self.steps_per_bpfo // self.record_every
        return self.time_s.size // per if per > 0 else 0

    def _periodic_window(self):
        per = self.steps_per_bpfo // self.record_every
        n = self.whole_periods * per
        if n == 0:
            raise ValueError("the recording holds less than one BPFO period")
        return n, self.whole_periods

    def order_spectrum(self, max_order: int | None = None, signal: str = "displacement"):
        """BPFO-order spectrum of the recording (exact: whole periods, no window).

        Parameters
        ----------
        max_order : int, optional
            Highest order returned (default: all the sampling resolves).
        signal : {"displacement", "bearing_relative"}

        Returns
        -------
        orders : ndarray (K,)
        complex_amplitude : ndarray complex (K, L, 2)
            ``X`` with ``x(t) = Re(X e^{i 2 pi k BPFO t})`` (t = 0 at the start of the recording = cage angle 0
            modulo one ball pitch); L = 4 locations or 2 bearings.
        dc : ndarray (L, 2)
            Mean value [m].
        """
        n, periods = self._periodic_window()
        x = self.displacement_m if signal == "displacement" else self.bearing_relative_m
        spec = np.fft.rfft(x[:n], axis=0) / n
        k_max = (spec.shape[0] - 1) // periods
        if max_order is not None:
            k_max = min(k_max, int(max_order))
        orders = np.arange(1, k_max + 1)
        return orders, 2.0 * spec[orders * periods], spec[0].real.copy()

    def off_order_fraction(self, signal: str = "displacement") -> np.ndarray:
        """RMS of the non-BPFO FFT bins over the RMS of the BPFO bins, per location and direction (L, 2).

        Zero for an exactly BPFO-periodic steady state; start transient, sub-harmonics or chaos raise it.
        """
        n, periods = self._periodic_window()
        x = self.displacement_m if signal == "displacement" else self.bearing_relative_m
        spec = np.abs(np.fft.rfft(x[:n] - x[:n].mean(axis=0), axis=0)) ** 2
        on = np.zeros(spec.shape[0], bool)
        on[periods::periods] = True
        on[0] = False
        off = ~on
        off[0] = False
        return np.sqrt(spec[off].sum(axis=0) / np.maximum(spec[on].sum(axis=0), 1e-300))

    def peak_frequencies_hz(self, orders, location: int, direction: int, search_fraction: float = 0.4):
        """Frequencies of the spectral peaks nearest to ``orders x BPFO`` [Hz] (Hann window, interpolated).

        The peak is the largest bin of the Hann-windowed, 8x zero-padded spectrum within
        ``+/- search_fraction x BPFO`` of the expected frequency, refined by a parabola through the log
        magnitudes of its neighbours. This is an independent check that the TDSM energy really sits at the BPFO
        harmonics (no assumption of periodicity).
        """
        x = self.displacement_m[:, location, direction]
        x = x - x.mean()
        n = x.size
        dt = self.step_s * self.record_every
        nfft = 8 * n
        mag = np.abs(np.fft.rfft(x * np.hanning(n), nfft))
        df = 1.0 / (nfft * dt)
        out = []
        for k in np.asarray(orders):
            f0 = k * self.bpfo_hz
            lo = max(1, int((f0 - search_fraction * self.bpfo_hz) / df))
            hi = min(mag.size - 2, int(math.ceil((f0 + search_fraction * self.bpfo_hz) / df)))
            if hi <= lo:
                out.append(float("nan"))
                continue
            i = lo + int(np.argmax(mag[lo:hi + 1]))
            a, b, c = np.log(mag[i - 1:i + 2] + 1e-300)
            den = a - 2 * b + c
            p = 0.5 * (a - c) / den if den != 0 else 0.0
            out.append(float((i + p) * df))
        return np.array(out)


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


class _State:
    """Integrator state carried between :meth:`Tdsm._integrate` calls."""

    def __init__(self, z):
        self.z = z
        self.f_dev = np.zeros(4)
        self.f_old = np.zeros(4)
        self.steps = 0
        self.newton_total = 0
        self.newton_max = 0
        self.interrupted = False
        self.recorded = 0


# --------------------------------------------------------------------------- the model
class Tdsm:
    """The nonlinear rotor-bearing model of a case at one constant shaft speed, ready to integrate.

    Parameters
    ----------
    case : Case
    speed_hz : float
        Shaft speed [Hz] (> 0).
    max_step_s : float, optional
        Largest integration step [s]; the step is ``T_bpfo / ceil(T_bpfo / max_step_s)``. Default: the smaller
        of ``MAX_STEP_S`` (10 us) and a quarter of the time a ball takes to cross one smoothed dent edge (33 us
        at 30 Hz, 13 us at 75 Hz for the embedded case), from the step-size study in docs/validation.md.
    hht_alpha : float
        HHT-alpha parameter in [-1/3, 0] of the ``"newmark"`` scheme; 0 = average acceleration.
    bearing_damping_n_s_m : float, optional
        Viscous damper between rotor and housing at each bearing [N s/m] (default: the case's
        ``[excitation] bearing_damping_n_s_m``).
    bearing_model : {"hertz", "linear"}
        ``"linear"`` replaces the ball forces by the case's linear bearing springs (integrator tests).
    newton_tol_m : float
        A Newton update smaller than this (Euclidean norm over the 4 bearing coordinates) ends the iteration
        [m]. Every update is followed by the linearised force correction ``f += K du``, so the error left is
        second order in the update (about 1e-15 m for a 1 nm update here; tests/test_tdsm.py checks that
        1e-9 and 1e-13 give the same spectrum).
    max_newton : int
        Iteration limit per step (a step that does not converge raises ``RuntimeError``).
    scheme : {"exponential", "newmark"}
        Time discretisation (module docstring).
    """

    #: Largest default step [s] (the ~1 kHz housing modes and orders up to ~10 kHz need no more).
    MAX_STEP_S = 1.0e-5
    #: Default steps per dent edge (the cubic STEP ramp where a ball enters or leaves the dent).
    STEPS_PER_DENT_EDGE = 4

    def __init__(self, case: Case, speed_hz: float, max_step_s: float | None = None, hht_alpha: float = 0.0,
                 bearing_damping_n_s_m: float | None = None, bearing_model: str = "hertz",
                 newton_tol_m: float = 1.0e-9, max_newton: int = 30, scheme: str = "exponential"):
        t_setup = time.perf_counter()
        speed_hz = float(speed_hz)
        if not (math.isfinite(speed_hz) and speed_hz > 0.0):
            raise ValueError(f"speed_hz: must be a finite number > 0 (got {speed_hz})")
        if max_step_s is not None and not (max_step_s > 0.0):
            raise ValueError(f"max_step_s: must be > 0 (got {max_step_s})")
        if not (-1.0 / 3.0 <= hht_alpha <= 0.0):
            raise ValueError(f"hht_alpha: must be in [-1/3, 0] (got {hht_alpha})")
        if scheme not in ("exponential", "newmark"):
            raise ValueError(f"scheme: 'exponential' or 'newmark' (got {scheme!r})")
        if bearing_model not in ("hertz", "linear"):
            raise ValueError(f"bearing_model: 'hertz' or 'linear' (got {bearing_model!r})")
        self.case = case
        self.speed_hz = speed_hz
        self.hht_alpha = float(hht_alpha)
        self.bearing_model = bearing_model
        self.scheme = scheme
        self.newton_tol_m = float(newton_tol_m)
        self.max_newton = int(max_newton)
        exc = case.raw["excitation"]
        self.gravity_m_s2 = float(exc["gravity_m_s2"])
        self.bearing_damping_n_s_m = float(exc["bearing_damping_n_s_m"] if bearing_damping_n_s_m is None
                                           else bearing_damping_n_s_m)
        brg = case.raw["bearings"]

        # ---- FE model: the case's rotor with the linear bearings replaced by the damper only
        raw = copy.deepcopy(case.raw)
        for name in BEARINGS:
            b = raw["bearings"][name]
            b["stiffness_vertical_n_m"] = b["stiffness_horizontal_n_m"] = 0.0
            b["damping_vertical_n_s_m"] = b["damping_horizontal_n_s_m"] = self.bearing_damping_n_s_m
        self.rotor: Rotor = rotor_from_case(raw)
        rot = self.rotor
        n = rot.ndof
        self.ndof = n
        idx = rot.dof_index
        self._rotor_nodes = [brg[b]["rotor_node"] for b in BEARINGS]
        self._housing_nodes = [brg[b]["housing_node"] for b in BEARINGS]
        bmat = np.zeros((n, 4))
        for i, b in enumerate(BEARINGS):
            for j, d in enumerate(("x", "y")):
                bmat[idx(brg[b]["rotor_node"], d), 2 * i + j] = 1.0
                bmat[idx(brg[b]["housing_node"], d), 2 * i + j] = -1.0
        self.B = bmat
        nodes = {"de_rotor": brg["de"]["rotor_node"], "de_housing": brg["de"]["housing_node"],
                 "nde_rotor": brg["nde"]["rotor_node"], "nde_housing": brg["nde"]["housing_node"]}
        self.out_dofs = np.array([[idx(nodes[loc], _DIR_DOF[d]) for d in DIRECTIONS] for loc in LOCATIONS])
        # reference (Table 1) linear bearing stiffness: needed only to make the static problem non-singular
        self._k_ref = np.array([[brg[b]["stiffness_horizontal_n_m"], brg[b]["stiffness_vertical_n_m"]]
                                for b in BEARINGS], dtype=float)

        # ---- bearings and kinematics
        self.bearings = (case.bearing("de"), case.bearing("nde"))
        fm = self.bearings[0].fault_multipliers()
        self.ftf_hz = fm.ftf * speed_hz
        self.bpfo_hz = fm.bpfo * speed_hz
        self.cage_speed_rad_s = TWO_PI * self.ftf_hz
        self.bpfo_period_s = 1.0 / self.bpfo_hz
        if max_step_s is None:
            max_step_s = self.MAX_STEP_S
            faulty = [b for b in self.bearings if b.dent is not None and b.dent_effective_depth_m > 0.0]
            if faulty:
                b = faulty[0]
                edge = b._dent_edge if b._dent_edge > 0.0 else 0.25 * b.dent_half_angle_rad
                max_step_s = min(max_step_s, edge / self.cage_speed_rad_s / self.STEPS_PER_DENT_EDGE)
        self.steps_per_bpfo = max(1, math.ceil(self.bpfo_period_s / max_step_s - 1e-9))
        self.h = self.bpfo_period_s / self.steps_per_bpfo
        if case.raw["bearing"].get("ehl_film", False):
            loads = self._lever_loads()
            films = tuple(b.ehl_film_thickness_m(speed_hz, float(np.hypot(*loads[i])))
                          for i, b in enumerate(self.bearings))
        else:
            films = (0.0, 0.0)
        self.films_m = films
        cage = self.cage_speed_rad_s * self.h * np.arange(self.steps_per_bpfo)
        if bearing_model == "hertz":
            self.forces = HertzPair(self.bearings, cage, films)
        else:
            self.forces = LinearPair(self._k_ref, self.steps_per_bpfo)

        # ---- static equilibrium and the integrator matrices
        self.static = self.static_equilibrium()
        self._u_static = np.concatenate([self.static.relative_m[b] for b in BEARINGS])
        self._f_static = np.concatenate([self.static.force_n[b] for b in BEARINGS])
        if scheme == "newmark":
            self._build_integrator()
        else:
            self._build_exponential()
        self.state_size = self.T.shape[0]
        # the approximate Newton inverse I - H K needs |H K| << 1 (checked with a 10x stiffer contact)
        _, k_st = self.forces.evaluate(self._u_static, 0)
        self.newton_contraction = float(np.linalg.norm(self.H, 2) * np.linalg.norm(k_st, 2))
        self.newton_exact = 10.0 * self.newton_contraction > 0.1
        self.setup_time_s = time.perf_counter() - t_setup

    # ------------------------------------------------------------------ statics
    def _lever_loads(self):
        """Static bearing forces on the rotor nodes from the linear FE (statically determinate) [N], (2, 2)."""
        full = rotor_from_case(self.case.raw)
        loads = full.static_bearing_loads_n(self.gravity_m_s2)
        return np.array([loads[b] for b in BEARINGS], dtype=float)

    def static_equilibrium(self, tol_m: float = 1e-15, max_iter: int = 100) -> StaticEquilibrium:
        """Solve ``K q = F_g + B f(B^T q)`` with the ball forces at cage angle 0, dent ignored.

        The rotor hangs in the bearings only, so the FE stiffness alone is singular; a reference spring
        ``K_r`` (the Table-1 bearing) is added on both sides, ``(K + B K_r B^T) q = F_g + B (f(u) + K_r u)``,
        and the problem is condensed onto the 4 bearing coordinates ``u`` and solved by Newton's method from the
        bearing model's own static solution under the lever-rule loads.
        """
        rot = self.rotor
        kr = self._k_ref.reshape(4)
        ks = rot.K + (self.B * kr) @ self.B.T
        fg = rot.gravity_force(self.gravity_m_s2)
        lu = scipy.linalg.lu_factor(ks)
        flex_b = scipy.linalg.lu_solve(lu, self.B)
        q_g = scipy.linalg.lu_solve(lu, fg)
        hs = self.B.T @ flex_b
        u0 = self.B.T @ q_g
        # starting point: each bearing alone under the statically determinate load
        loads = self._lever_loads()
        if self.bearing_model == "hertz":
            u = np.concatenate([self._bearing_alone(i, -loads[i]) for i in range(2)])
            j0 = 0
            pair = HertzPair(self.bearings, np.zeros(1), self.films_m)
        else:
            u = u0.copy()
            j0 = 0
            pair = self.forces
        for it in range(1, max_iter + 1):
            f, kt = pair.evaluate(u, j0)
            g = f + kr * u
            r = u - u0 - hs @ g
            jac = np.eye(4) + hs @ (kt - np.diag(kr))
            du = np.linalg.solve(jac, -r)
            nrm = np.max(np.abs(du))
            if nrm > 1e-6:
                du *= 1e-6 / nrm                     # never more than 1 um at once (contact sets change)
            u = u + du
            if nrm <= tol_m:
                break
        else:
            raise RuntimeError("TDSM static equilibrium did not converge")
        f, _ = pair.evaluate(u, j0)
        q = q_g + flex_b @ (f + kr * u)
        return StaticEquilibrium(q_m=q, relative_m={b: u[2 * i:2 * i + 2].copy() for i, b in enumerate(BEARINGS)},
                                 force_n={b: f[2 * i:2 * i + 2].copy() for i, b in enumerate(BEARINGS)},
                                 iterations=it)

    def _bearing_alone(self, i, load_n):
        if self.bearing_model != "hertz":
            return -load_n / self._k_ref[i]
        return self.bearings[i].static_equilibrium_m(load_n[0], load_n[1], 0.0, self.films_m[i])

    # ------------------------------------------------------------------ integrator
    def _build_integrator(self):
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
        wq = scipy.linalg.lu_solve(lu, self.B)
        eye, zero = np.eye(n), np.zeros((n, n))
        ta = c0 * (tq - np.hstack([eye, zero, zero])) - np.hstack([zero, c2 * eye, c3 * eye])
        tv = np.hstack([zero, eye, h * (1.0 - gamma) * eye]) + h * gamma * ta
        self.T = np.ascontiguousarray(np.vstack([tq, tv, ta]))
        w_unit = np.vstack([wq, h * gamma * c0 * wq, c0 * wq])                       # per unit of force
        self.W = np.ascontiguousarray((1.0 + al) * w_unit)
        self.Wp = np.ascontiguousarray(-al * w_unit)
        bz = np.zeros((4, 3 * n))
        bz[:, :n] = self.B.T
        self.Bz = bz
        self.H = bz @ self.W                                                          # (4, 4)

    def _build_exponential(self):
        """Exact discretisation of the linear part with a first-order-hold bearing force.

        ``y = [x, v]``, ``y' = A y + B_f f(t)``; with ``f`` linear in time over a step,
        ``y_{n+1} = e^{A h} y_n + (P_0 - P_1) f_n + P_1 f_{n+1}`` where ``P_0 = int_0^h e^{A(h-s)} ds B_f`` and
        ``P_1 = 1/h int_0^h e^{A(h-s)} s ds B_f`` (one augmented matrix exponential, Van Loan). Every mode of the
        linear part keeps its exact frequency and damping at any step; the only discretisation error is the
        linear interpolation of the 4 bearing forces over a step (second order in h).
        """
        rot, n, h = self.rotor, self.ndof, self.h
        cw = rot.C + TWO_PI * self.speed_hz * rot.G
        minv = np.linalg.inv(rot.M)
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -minv @ rot.K
        a[n:, n:] = -minv @ cw
        bf = np.zeros((2 * n, 4))
        bf[n:] = minv @ self.B
        aug = np.zeros((2 * n + 8, 2 * n + 8))
        aug[:2 * n, :2 * n] = a * h
        aug[:2 * n, 2 * n:2 * n + 4] = bf * h
        aug[2 * n:2 * n + 4, 2 * n + 4:] = np.eye(4)
        e = scipy.linalg.expm(aug)
        phi, p0, p1 = e[:2 * n, :2 * n], e[:2 * n, 2 * n:2 * n + 4], e[:2 * n, 2 * n + 4:]
        self.T = np.ascontiguousarray(phi)
        self.W = np.ascontiguousarray(p1)
        self.Wp = np.ascontiguousarray(p0 - p1)
        bz = np.zeros((4, 2 * n))
        bz[:, :n] = self.B.T
        self.Bz = bz
        self.H = bz @ self.W

    # ------------------------------------------------------------------ helpers
    def harmonic_balance(self, n_orders: int = 50, n_time: int = 8192, linearised: bool = False,
                         tol_m: float = 1e-14, max_iter: int = 30) -> PeriodicSolution:
        """The BPFO-periodic steady state of this nonlinear model, solved in the frequency domain.

        Harmonic balance with alternating frequency-time evaluation of the ball forces, condensed onto the 4
        bearing coordinates: with ``U_k`` the harmonics (k = -K..K) of the relative displacements ``u - u_s``,
        the FE (with a reference spring ``K_r`` per bearing, compensated in the force) gives
        ``U_k = G(w_k) [F(u_s + U(t), theta(t)) - F_s + K_r U]_k`` with the 4 x 4 receptance
        ``G(w) = B^T (K + B K_r B^T - w^2 M + i w (C + Omega G))^-1 B``. Newton's method on the 4 (2K+1) complex
        unknowns; the Jacobian ``I + G(w_k) (K_t - K_r)_{k-j}`` couples the orders through the harmonics of the
        tangent stiffness ``K_t(t)`` (ball passage and dent). The forces are evaluated at ``n_time`` instants per
        BPFO period (the dent edges need thousands) and transformed by FFT.

        ``linearised=True`` stops after the first Newton step from the static equilibrium: the linear
        time-periodic (parametric) model, in which the ball forces and stiffnesses at the static displacement
        are the excitation and the time-varying stiffness.

        Same equations as :meth:`run` (HertzPair forces, same FE, damper, gyroscopics); only the periodic part is
        computed, so no start transient. The harmonics above ``n_orders`` are truncated.
        """
        if self.bearing_model != "hertz":
            raise ValueError("harmonic_balance needs the Hertz bearing model")
        t0 = time.perf_counter()
        rot = self.rotor
        kk = int(n_orders)
        ks = np.arange(-kk, kk + 1)
        nk = ks.size
        w = TWO_PI * self.bpfo_hz * ks
        # reference spring: mean tangent at the static state (conditioning only; the solution does not depend
        # on it)
        grid = HertzPair(self.bearings, self.cage_speed_rad_s * self.bpfo_period_s * np.arange(n_time) / n_time,
                         self.films_m)
        kt0 = self._tangents(grid, np.broadcast_to(self._u_static, (n_time, 4)))
        k_ref = np.diag(np.diag(kt0.mean(axis=0)))
        kz = rot.K + self.B @ k_ref @ self.B.T
        cw = rot.C + TWO_PI * self.speed_hz * rot.G
        pos = ks >= 0
        zp = kz[None] - (w[pos] ** 2)[:, None, None] * rot.M[None] + 1j * w[pos][:, None, None] * cw[None]
        hb_pos = np.linalg.solve(zp, np.broadcast_to(self.B.astype(complex), (int(pos.sum()),) + self.B.shape))
        hb = np.concatenate([np.conj(hb_pos[:0:-1]), hb_pos])                       # (nk, ndof, 4), k = -K..K
        g = np.einsum("ai,kaj->kij", self.B, hb)                                     # (nk, 4, 4)
        diff = (ks[:, None] - ks[None, :]) % n_time
        u_harm = np.zeros((nk, 4), dtype=complex)
        f_s = self._f_static
        kr = np.diag(k_ref)
        converged = False
        it = 0
        nrm = float("inf")
        for it in range(1, max_iter + 1):
            u_t = self._synth(u_harm, ks, n_time) + self._u_static
            f_t, kt_t = self._forces_many(grid, u_t)
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
            u_t = self._synth(u_harm, ks, n_time) + self._u_static
            f_t, _ = self._forces_many(grid, u_t)
            phi = np.fft.fft(f_t - f_s, axis=0)[ks % n_time] / n_time + u_harm * kr
        x = np.einsum("kaj,kj->ka", hb[:, self.out_dofs.reshape(-1), :], phi).reshape(nk, 4, 2)
        rel = np.stack([x[:, 0] - x[:, 1], x[:, 2] - x[:, 3]], axis=1)                # (nk, 2, 2)
        i0 = kk
        q_s = self.static.q_m[self.out_dofs]
        rel_s = np.stack([q_s[0] - q_s[1], q_s[2] - q_s[3]])
        return PeriodicSolution(
            speed_hz=self.speed_hz, bpfo_hz=self.bpfo_hz, orders=ks[i0 + 1:], complex_amplitude=2.0 * x[i0 + 1:],
            dc_m=q_s + x[i0].real, bearing_complex_amplitude=2.0 * rel[i0 + 1:], bearing_dc_m=rel_s + rel[i0].real,
            linearised=linearised, iterations=it, residual_m=nrm, converged=converged,
            wall_time_s=time.perf_counter() - t0, n_time=n_time)

    @staticmethod
    def _synth(u_harm, ks, n_time):
        spec = np.zeros((n_time, 4), dtype=complex)
        spec[ks % n_time] = u_harm
        return np.fft.ifft(spec, axis=0).real * n_time

    @staticmethod
    def _forces_many(pair: HertzPair, u_t):
        """Ball forces (N, 4) and block-diagonal tangent stiffnesses (N, 4, 4) at N table instants."""
        n = u_t.shape[0]
        delta = np.einsum("nbd,ndi->nbi", u_t.reshape(n, 2, 2), pair.cs) - pair.offset
        np.maximum(delta, 0.0, out=delta)
        root = np.sqrt(delta)
        q = delta * root * pair.k[None, :, None]
        dq = 1.5 * root * pair.k[None, :, None]
        c, s = pair.cs[:, None, 0, :], pair.cs[:, None, 1, :]
        f = -np.stack([np.sum(q * c, axis=-1), np.sum(q * s, axis=-1)], axis=-1).reshape(n, 4)
        kxx, kxy, kyy = np.sum(dq * c * c, -1), np.sum(dq * c * s, -1), np.sum(dq * s * s, -1)
        kt = np.zeros((n, 4, 4))
        for b in range(2):
            kt[:, 2 * b, 2 * b] = kxx[:, b]
            kt[:, 2 * b, 2 * b + 1] = kt[:, 2 * b + 1, 2 * b] = kxy[:, b]
            kt[:, 2 * b + 1, 2 * b + 1] = kyy[:, b]
        return f, kt

    def _tangents(self, pair, u_t):
        return self._forces_many(pair, np.ascontiguousarray(u_t))[1]

    def settings(self) -> dict:
        return {"case": self.case.name, "case_hash": self.case.case_hash, "speed_hz": self.speed_hz,
                "step_s": self.h, "steps_per_bpfo": self.steps_per_bpfo, "scheme": self.scheme,
                "hht_alpha": self.hht_alpha,
                "bearing_damping_n_s_m": self.bearing_damping_n_s_m, "bearing_model": self.bearing_model,
                "newton_tol_m": self.newton_tol_m, "films_m": list(self.films_m),
                "gravity_m_s2": self.gravity_m_s2}

    # ------------------------------------------------------------------ run
    def run(self, duration_s: float, settle_s: float | None = None, record_every: int = 1,
            progress: bool = True, initial_state=None, record_state: bool = False, settle_tol_db: float = 0.02,
            settle_window_s: float = 0.05, settle_lag_s: float = 0.25, min_settle_s: float = 0.1,
            max_settle_s: float = 4.0) -> TdsmResult:
        """Integrate from the static equilibrium, discard the start transient, record ``duration_s``.

        Parameters
        ----------
        duration_s : float
            Recorded time [s], rounded up to whole BPFO periods.
        settle_s : float, optional
            Discarded start transient [s], rounded up to whole BPFO periods. None (default): settle until the
            BPFO-order spectrum is steady: the run advances in windows of ``settle_window_s`` (whole periods)
            and stops settling when no order of any recorded displacement that is within 20 dB of that
            signal's largest order differs by more than ``settle_tol_db`` from the window ``settle_lag_s``
            earlier (after at least ``min_settle_s``; at most ``max_settle_s``, else ``settled`` is False).
            Needed because the shaft has nearly undamped bending modes (damping ratio ~1e-5) that take seconds
            to settle when a BPFO harmonic sits next to one (docs/validation.md); the lag keeps a slow
            exponential drift from passing as steady.
        record_every : int
            Store one sample every this many steps (must divide the steps per BPFO period).
        progress : bool
            Show a tqdm progress bar.
        initial_state : ndarray (state_size,), optional
            Deviation from the static equilibrium at t = 0: ``[x, v]`` (exponential) or ``[x, v, a]`` (newmark;
            ``a`` must be consistent with x, v). Default zeros: at rest in the static equilibrium.
        record_state : bool
            Also keep the full state of every recorded sample in ``result.state`` (tests).

        Ctrl-C stops the integration cleanly: the result holds what was computed (``interrupted=True``).
        """
        if not duration_s > 0:
            raise ValueError(f"duration_s: must be > 0 (got {duration_s})")
        if settle_s is not None and settle_s < 0:
            raise ValueError(f"settle_s: must be >= 0 (got {settle_s})")
        record_every = int(record_every)
        if record_every < 1 or self.steps_per_bpfo % record_every != 0:
            raise ValueError(f"record_every: must divide the {self.steps_per_bpfo} steps per BPFO period "
                             f"(got {record_every})")
        nbp = self.steps_per_bpfo
        periods = lambda t: math.ceil(t / self.bpfo_period_s - 1e-9)
        n_rec = max(1, periods(duration_s)) * nbp
        n_samples = n_rec // record_every
        st = _State(np.zeros(self.state_size) if initial_state is None else np.array(initial_state, dtype=float))
        f0, _ = self.forces.evaluate(self._u_static + self.Bz.dot(st.z), 0)
        st.f_dev = f0 - self._f_static
        st.f_old = st.f_dev.copy()
        bar = None
        if progress:
            from tqdm import tqdm
            first = periods(settle_s) * nbp if settle_s is not None else periods(min_settle_s) * nbp
            bar = tqdm(total=first + n_rec, desc=f"TDSM {self.speed_hz:g} Hz", unit="step", unit_scale=True,
                       mininterval=0.5, leave=False)
        t0 = time.perf_counter()
        settle_log = []
        settled = True
        n_settle = 0
        rec_x = np.empty((n_samples, 12))
        states = np.empty((n_samples, self.state_size)) if record_state else None
        try:
            # ---- settle
            if settle_s is not None:
                self._integrate(st, periods(settle_s) * nbp, bar=bar)
            else:
                win = max(2, periods(settle_window_s))
                lag = max(1, math.ceil(settle_lag_s / (win * self.bpfo_period_s) - 1e-9))
                buf = np.empty((win * nbp, 12))
                history = []
                settled = False
                while True:
                    self._integrate(st, win * nbp, rec=buf, bar=bar)
                    if st.interrupted:
                        break
                    amp = np.abs(np.fft.rfft(buf[:, :8], axis=0)[win::win][:50])          # (orders, 8)
                    history.append(amp)
                    t_now = st.steps * self.h
                    if len(history) > lag:
                        prev = history[-1 - lag]
                        rel = amp >= 0.1 * amp.max(axis=0)
                        change = float(np.max(np.abs(20 * np.log10(amp[rel] / prev[rel]))))
                        settle_log.append((t_now, change))
                        if t_now >= min_settle_s - 1e-12 and change <= settle_tol_db:
                            settled = True
                            break
                    if t_now >= max_settle_s - 1e-12:
                        break
                    if bar is not None:
                        bar.total += win * nbp
                        bar.refresh()
            n_settle = st.steps
            # ---- record
            if not st.interrupted:
                self._integrate(st, n_rec, rec=rec_x, rec_every=record_every, states=states, bar=bar)
        finally:
            wall = time.perf_counter() - t0
            if bar is not None:
                bar.close()
        n_done = st.recorded if st.steps > n_settle or n_settle == 0 else 0
        if st.steps == n_settle and st.interrupted:
            n_done = 0
        out_idx = self.out_dofs.reshape(-1)
        q_s = self.static.q_m[out_idx]
        disp = rec_x[:n_done, :8] + q_s
        frc = rec_x[:n_done, 8:] + self._f_static
        u_rec = np.empty((n_done, 2, 2))
        for i in range(2):
            # rotor minus housing, directions (vertical, horizontal)
            u_rec[:, i, :] = disp[:, 4 * i:4 * i + 2] - disp[:, 4 * i + 2:4 * i + 4]
        res = TdsmResult(
            speed_hz=self.speed_hz, step_s=self.h, steps_per_bpfo=nbp, record_every=record_every,
            settle_s=n_settle * self.h,
            time_s=np.arange(n_done) * record_every * self.h,
            displacement_m=disp.reshape(n_done, 4, 2),
            bearing_relative_m=u_rec,
            bearing_force_n=frc.reshape(n_done, 2, 2)[:, :, ::-1],     # (x, y) -> (vertical, horizontal)
            bpfo_hz=self.bpfo_hz, static=self.static, steps=st.steps, wall_time_s=wall,
            setup_time_s=self.setup_time_s,
            newton_iterations_mean=st.newton_total / max(st.steps, 1), newton_iterations_max=st.newton_max,
            interrupted=st.interrupted,
            settings={**self.settings(), "settle_s": n_settle * self.h, "settle": "fixed" if settle_s is not None
                      else "adaptive", "settle_tol_db": settle_tol_db, "duration_s": n_rec * self.h,
                      "record_every": record_every},
        )
        res.settled = settled
        res.settle_log = settle_log
        if states is not None:
            res.state = states[:n_done]
        return res

    def _integrate(self, st, n_steps, rec=None, rec_every=1, states=None, bar=None, chunk=4096):
        """Advance ``st`` by ``n_steps`` steps; sample ``k`` of ``rec`` (and ``states``) is the state before the
        ``k rec_every``-th step of this call (so sample 0 is the state at the start of the call).

        Sets ``st.interrupted`` on Ctrl-C (the steps done so far are kept) and ``st.recorded``.
        """
        T, W, Wp, Bz, H = self.T, self.W, self.Wp, self.Bz, self.H
        use_wp = self.scheme == "exponential" or self.hht_alpha != 0.0
        out_idx = self.out_dofs.reshape(-1)
        u_s, f_s = self._u_static, self._f_static
        evaluate = self.forces.evaluate
        tol2, max_newton = self.newton_tol_m ** 2, self.max_newton
        exact = self.newton_exact
        eye4 = np.eye(4)
        solve = np.linalg.solve
        nbp = self.steps_per_bpfo
        z, f_dev, f_old = st.z, st.f_dev, st.f_old
        newton_total, newton_max = st.newton_total, st.newton_max
        n0 = st.steps
        n_ = n0
        recorded = 0
        st.recorded = 0
        try:
            k0 = 0
            while k0 < n_steps:
                k1 = min(n_steps, k0 + chunk)
                for k in range(k0, k1):
                    if rec is not None and k % rec_every == 0:
                        i = k // rec_every
                        rec[i, :8] = z[out_idx]
                        rec[i, 8:] = f_dev
                        if states is not None:
                            states[i] = z
                        recorded = i + 1
                    n_ = n0 + k
                    j = (n_ + 1) % nbp                 # table step of t_{n+1}
                    zp = T.dot(z)
                    if use_wp:
                        zp += Wp.dot(f_dev)
                    up = Bz.dot(zp)
                    up += u_s                           # relative displacement without the force f_{n+1}
                    u = up + H.dot(f_dev + f_dev - f_old)   # start: force extrapolated from the last two steps
                    # Newton on u = up + H f(u): J = I + H K with |H K| ~ 1e-3 at these steps, so
                    # J^-1 ~ I - H K (error (H K)^2) unless `exact`; the converged u is the same.
                    for it in range(1, max_newton + 1):
                        f, kt = evaluate(u, j)
                        f -= f_s
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
