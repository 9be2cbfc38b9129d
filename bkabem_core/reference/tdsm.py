"""Time-domain solution method (TDSM): the full nonlinear rotor-bearing model integrated in time.

This is the reference BKA-BEM is validated against (paper section 5). It is the same machine as the core
(:class:`bkabem_core.fe.machine.Machine`):

* the FE rotor (Timoshenko shaft refined for the case's highest frequency, disks, both housings on their
  supports, the rotor's structural damping) with, between rotor node and housing node of each bearing, the
  nonlinear Sopanen ball force of :class:`bkabem_core.bearing.deep_groove.Bearing` (Hertz contacts, the position's
  own bearing and clearance, the axial displacement held at its static value under the axial load; the defects of
  each bearing) in parallel with the position's viscous bearing damper ``[bearings.*] damping_n_s_m`` (the same
  damper as in the FE and the 4-DOF model);
* gravity on every mass, the radial loads applied at the bearings (:func:`bkabem_core.fe.machine.static_force_n`)
  and the coupling's running-speed force, turning with the shaft at its node (``[baseline]
  coupling_force_n``, :mod:`bkabem_core.reference.coupling`; the other baseline keys stay out);
* constant shaft speed Omega (in ``Omega G``) and each bearing's cage angle
  ``theta = 2 pi FTF f t`` with its own FTF (t = 0 at cage angle 0, the BKA-BEM phase reference);
* integrated from the static equilibrium of this nonlinear model (solved, with the dent ignored at t = 0).

The linear part is written with the FE's linear bearing springs ``K_b`` inside (the machine's linearisation) and
the ball forces as ``g(u) = f(u) + K_b u`` outside: the same equations, and a linear part without rigid-body
modes.

Integrator
----------
The equations are written for the deviation ``x`` from the static equilibrium. With ``f`` the 4 nonlinear
bearing forces (DE x, y; NDE x, y; minus their static values) one constant step ``h`` is the affine map

    z_{n+1} = T z_n + W f_{n+1} + W_p f_n,

precomputed once. Two schemes:

``"exponential"`` (default)
    The linear part (FE rotor, housings, supports, dampers, ``Omega G``) is discretised exactly and the bearing
    forces are linear in time over a step (first-order hold). The state is kept in the eigenvector coordinates
    of the linear part (``z = V^-1 [x, v]``, all 2 ndof modes, no truncation), where ``T`` is diagonal: a step
    costs O(ndof), and no mode suffers period error or numerical damping at any step.
``"newmark"``
    ``z = [x, v, a]``; HHT-alpha (``hht_alpha = 0``: Newmark average acceleration, exact discrete energy balance
    for a linear model), dense matrices. Second order too, but its period error shifts the lightly damped
    resonances: it needs a 4-8 times smaller step for the same accuracy (docs/validation.md); meant for coarse
    meshes (``mesh=None``) and the energy-balance tests.

In both, the bearing relative displacements ``u = B^T x`` satisfy ``u = u_pred + H f(u)`` with the precomputed
4 x 4 flexibility ``H``: Newton iterates on these 4 unknowns only (one ball-force evaluation and a 4 x 4 update
per iteration), and the full state is updated once per step. ``|H (K_t - K_b)|`` is small at these steps, so
the Newton update uses ``(I + H (K_t - K_b))^-1 ~ I - H (K_t - K_b)`` (checked at set-up; the exact 4 x 4 solve
otherwise).
The step matrices and the Newton iteration are :class:`bkabem_core.reference.integrator.Integrator`.

The step is chosen as ``h = T_bpfo / N`` (N integer, ``h <= max_step_s``), so every BPFO period holds exactly N
steps: the steady-state response is BPFO-periodic and its FFT over whole periods has no leakage. The ball
positions (and the dent depth felt by each ball) are tabulated once for one BPFO period: after one period the
ball set has turned by exactly one ball pitch and the table repeats. Two different bearings (another ball set or
other cage and spin rates at the NDE) have two ball-pass periods: T_bpfo is the DE bearing's, and each bearing's
ball angles are computed at every step from its own cage angle (:meth:`HertzPair.rows`); the response is then
quasi-periodic (its lines are fitted, :func:`bkabem_core.reference.validation.validate_lines`).

Units: SI (m, s, N, rad). Axes as in :mod:`bkabem_core.fe.rotor`: x horizontal, y vertical (up), z axial.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from bkabem_core.bearing.contacts import HertzPair, LinearPair, same_ball_set
from bkabem_core.bearing.deep_groove import TWO_PI
from bkabem_core.bearing.defects.registry import kind as defect_kind
from bkabem_core.fe.machine import Machine, static_force_n
from bkabem_core.fe.rotor import Rotor, rotor_from_case
from bkabem_core.model.case import Case
from bkabem_core.model.vocabulary import BEARINGS, DIRECTIONS, LOCATIONS
from bkabem_core.reference.coupling import RotatingForce
from bkabem_core.reference.integrator import Integrator

__all__ = ["Tdsm", "TdsmResult", "StaticEquilibrium", "HertzPair", "LinearPair", "LOCATIONS", "DIRECTIONS",
           "BEARINGS"]

_DIR_DOF = {"vertical": "y", "horizontal": "x"}


@dataclass
class StaticEquilibrium:
    """Static equilibrium of the nonlinear model under its static loads (gravity, the radial loads applied at the
    bearings; dent ignored, cage angle 0).

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
        of ``MAX_STEP_S`` and a quarter of the time a ball takes to enter the dent (its entry ramp), from the
        step-size study in docs/validation.md.
    hht_alpha : float
        HHT-alpha parameter in [-1/3, 0] of the ``"newmark"`` scheme; 0 = average acceleration.
    bearing_damping_n_s_m : float, optional
        Viscous damper between rotor and housing at both bearings [N s/m] (default: each position's
        ``[bearings.*] damping_n_s_m``).
    bearing_model : {"hertz", "linear"}
        ``"linear"`` replaces the ball forces by the FE's linear bearing springs (integrator tests: the model is
        then exactly the linear FE).
    newton_tol_m : float
        A Newton update smaller than this (Euclidean norm over the 4 bearing coordinates) ends the iteration
        [m]. Every update is followed by the linearised force correction ``f += K du``, so the error left is
        second order in the update.
    max_newton : int
        Iteration limit per step (a step that does not converge raises ``RuntimeError``).
    scheme : {"exponential", "newmark"}
        Time discretisation (module docstring).
    machine : Machine, "auto" mesh or None
        The machine (default: ``Machine(case)``, mesh refined for the case); ``mesh=None`` builds it on the
        case's own elements (coarse; tests of the integrator).
    """

    #: Largest default step [s].
    MAX_STEP_S = 1.0e-5
    #: Default steps per dent entry ramp (where a ball sinks into the dent).
    STEPS_PER_DENT_EDGE = 4

    def __init__(self, case: Case, speed_hz: float, max_step_s: float | None = None, hht_alpha: float = 0.0,
                 bearing_damping_n_s_m: float | None = None, bearing_model: str = "hertz",
                 newton_tol_m: float = 1.0e-9, max_newton: int = 30, scheme: str = "exponential",
                 machine: Machine | None = None, mesh="auto"):
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
        self.gravity_m_s2 = case.gravity_m_s2
        #: the viscous damper across each bearing [N s/m]: {"de": ..., "nde": ...}
        self.bearing_damping_n_s_m = {b: float(case.bearing_damping_n_s_m(b) if bearing_damping_n_s_m is None
                                               else bearing_damping_n_s_m) for b in BEARINGS}
        self.machine = machine if machine is not None else Machine(case, mesh=mesh)
        sites = self.machine.sites

        # ---- FE model: the machine's rotor, its linear bearing springs K_b and the bearing dampers
        cb = self.bearing_damping_n_s_m
        self._k_ref = np.array([sites[b].stiffness_n_m for b in BEARINGS], dtype=float)     # (2, 2): xx, yy
        elements = {b: (self._k_ref[i, 0], self._k_ref[i, 1], cb[b], cb[b]) for i, b in enumerate(BEARINGS)}
        self.rotor: Rotor = rotor_from_case(case.raw, bearings=elements, mesh=self.machine.mesh)
        rot = self.rotor
        n = rot.ndof
        self.ndof = n
        idx = rot.dof_index
        bmat = np.zeros((n, 4))
        for i, b in enumerate(BEARINGS):
            for j, d in enumerate(("x", "y")):
                bmat[idx(sites[b].rotor_node, d), 2 * i + j] = 1.0
                bmat[idx(sites[b].housing_node, d), 2 * i + j] = -1.0
        self.B = bmat
        self.coupling = RotatingForce.of_case(case, rot, speed_hz)     # None: no coupling force
        nodes = {"de_rotor": sites["de"].rotor_node, "de_housing": sites["de"].housing_node,
                 "nde_rotor": sites["nde"].rotor_node, "nde_housing": sites["nde"].housing_node}
        self.out_dofs = np.array([[idx(nodes[loc], _DIR_DOF[d]) for d in DIRECTIONS] for loc in LOCATIONS])
        self._kb = np.diag(self._k_ref.reshape(4))

        # ---- bearings and kinematics (each bearing its own; the step follows the DE bearing's ball pass)
        self.bearings = (sites["de"].bearing, sites["nde"].bearing)
        self.axial_m = tuple(float(sites[b].state.displacement_m[2]) for b in BEARINGS)
        fms = [b.fault_multipliers() for b in self.bearings]
        fm = fms[0]
        self.one_ball_set = same_ball_set(*self.bearings)      # one table of ball angles, BPFO-periodic
        self.ftf_hz = fm.ftf * speed_hz
        self.bpfo_hz = fm.bpfo * speed_hz
        self.cage_speed_rad_s = TWO_PI * self.ftf_hz
        #: each bearing's cage speed [rad/s] (DE, NDE)
        self.cage_speeds_rad_s = tuple(TWO_PI * f.ftf * speed_hz for f in fms)
        self.bpfo_period_s = 1.0 / self.bpfo_hz
        if max_step_s is None:
            max_step_s = self.MAX_STEP_S
            moving = [b for b in self.bearings if b.defect_set.moving]
            for b in moving:                 # moving kinds (inner race, ball): their own relative speeds
                max_step_s = min(max_step_s, b.shortest_defect_event_s(speed_hz) / self.STEPS_PER_DENT_EDGE)
            for b, w_cage in zip(self.bearings, self.cage_speeds_rad_s):
                if b.dent is not None and b.dent_effective_depth_m > 0.0 and defect_kind(b.dent.race).periodic:
                    ramp = b.dent_entry_ramp_rad
                    edge = ramp if ramp > 0.0 else 0.25 * b.dent_half_angle_rad
                    max_step_s = min(max_step_s, edge / w_cage / self.STEPS_PER_DENT_EDGE)
                    if self.one_ball_set:
                        break                   # the first dented bearing's, as for one bearing type
        self.steps_per_bpfo = max(1, math.ceil(self.bpfo_period_s / max_step_s - 1e-9))
        self.h = self.bpfo_period_s / self.steps_per_bpfo
        films = tuple(b.ehl_film_thickness_m(speed_hz, float(np.hypot(*sites[name].radial_load_n)))
                      if case.ehl_film(name) else 0.0 for b, name in zip(self.bearings, BEARINGS))
        self.films_m = films
        steps = np.arange(self.steps_per_bpfo)
        cage = self.cage_speed_rad_s * self.h * steps if self.one_ball_set else \
            np.stack([w * self.h * steps for w in self.cage_speeds_rad_s], axis=1)
        if bearing_model == "hertz":
            self.forces = HertzPair(self.bearings, cage, films, self.axial_m)
            if self.one_ball_set:
                self.forces.set_clock(self.h, TWO_PI * speed_hz, TWO_PI * fm.bsf * speed_hz)
            else:
                self.forces.set_clock(self.h, TWO_PI * speed_hz, [TWO_PI * f.bsf * speed_hz for f in fms],
                                      self.cage_speeds_rad_s)
        else:
            self.forces = LinearPair(self._k_ref, self.steps_per_bpfo)

        # ---- static equilibrium and the integrator matrices
        self.static = self.static_equilibrium()
        self._u_static = np.concatenate([self.static.relative_m[b] for b in BEARINGS])
        self._f_static = np.concatenate([self.static.force_n[b] for b in BEARINGS])
        self.integrator: Integrator | None = None       # made on the first run (the_integrator())
        self.setup_time_s = time.perf_counter() - t_setup

    def the_integrator(self) -> Integrator:
        """The step matrices (``T``, ``W``, ``W_p``, ``B_z``, ``H``) and the Newton iteration of this model, made on
        first use (:class:`bkabem_core.reference.integrator.Integrator`)."""
        if self.integrator is None:
            t0 = time.perf_counter()
            self.integrator = Integrator(self.rotor, self.B, self.out_dofs, self.h, self.speed_hz, self.forces,
                                         self._u_static, self._f_static, self._kb, self.steps_per_bpfo,
                                         scheme=self.scheme, hht_alpha=self.hht_alpha,
                                         newton_tol_m=self.newton_tol_m, max_newton=self.max_newton,
                                         coupling=self.coupling)
            self.setup_time_s += time.perf_counter() - t0
        return self.integrator

    # ------------------------------------------------------------------ statics
    def static_equilibrium(self, tol_m: float = 1e-15, max_iter: int = 100) -> StaticEquilibrium:
        """Solve ``K q = F_g + B g(B^T q)`` with the ball forces at cage angle 0, dent ignored.

        ``K`` holds the linear bearing springs ``K_b`` and ``g(u) = f(u) + K_b u`` (module docstring); the problem
        is condensed onto the 4 bearing coordinates ``u`` and solved by Newton's method from the bearing model's
        own static solution under the lever-rule loads.
        """
        rot = self.rotor
        kb = self._k_ref.reshape(4)
        fg = static_force_n(self.machine.case, rot)
        lu = scipy.linalg.lu_factor(rot.K)
        flex_b = scipy.linalg.lu_solve(lu, self.B)
        q_g = scipy.linalg.lu_solve(lu, fg)
        hs = self.B.T @ flex_b
        u0 = self.B.T @ q_g
        sites = self.machine.sites
        if self.bearing_model == "hertz":
            u = np.concatenate([sites[b].state.displacement_m[:2] for b in BEARINGS])
            pair = HertzPair(self.bearings, np.zeros(1), self.films_m, self.axial_m)
        else:
            u = u0.copy()
            pair = self.forces
        for it in range(1, max_iter + 1):
            f, kt = pair.evaluate(u, 0)
            g = f + kb * u
            r = u - u0 - hs @ g
            jac = np.eye(4) + hs @ (kt - np.diag(kb))
            du = np.linalg.solve(jac, -r)
            nrm = np.max(np.abs(du))
            if nrm > 1e-6:
                du *= 1e-6 / nrm                     # never more than 1 um at once (contact sets change)
            u = u + du
            if nrm <= tol_m:
                break
        else:
            raise RuntimeError("TDSM static equilibrium did not converge")
        f, _ = pair.evaluate(u, 0)
        q = q_g + flex_b @ (f + kb * u)
        return StaticEquilibrium(q_m=q, relative_m={b: u[2 * i:2 * i + 2].copy() for i, b in enumerate(BEARINGS)},
                                 force_n={b: f[2 * i:2 * i + 2].copy() for i, b in enumerate(BEARINGS)},
                                 iterations=it)

    def settings(self) -> dict:
        return {"case": self.case.name, "case_hash": self.case.case_hash, "speed_hz": self.speed_hz,
                "step_s": self.h, "steps_per_bpfo": self.steps_per_bpfo, "scheme": self.scheme,
                "hht_alpha": self.hht_alpha,
                "bearing_damping_n_s_m": self.bearing_damping_n_s_m, "bearing_model": self.bearing_model,
                "newton_tol_m": self.newton_tol_m, "films_m": list(self.films_m),
                "gravity_m_s2": self.gravity_m_s2, "ndof": self.ndof, "fe_elements": self.machine.mesh.n_elements,
                "axial_m": list(self.axial_m)}


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
            ``a`` must be consistent with x, v). Default zeros: at rest in the static equilibrium (exponential, with
            a coupling force: plus the linear rotor's steady response to it, :meth:`RotatingForce.steady_state`).
        record_state : bool
            Also keep the full state of every recorded sample in ``result.state`` (tests).

        Ctrl-C stops the integration cleanly: the result holds what was computed (``interrupted=True``).
        """
        if not duration_s > 0:
            raise ValueError(f"duration_s: must be > 0 (got {duration_s})")
        integ = self.the_integrator()
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
        st = integ.start(initial_state)
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
        states = np.empty((n_samples, integ.state_size), dtype=complex if integ.diagonal else float) \
            if record_state else None
        try:
            # ---- settle
            if settle_s is not None:
                integ.advance(st, periods(settle_s) * nbp, bar=bar)
            else:
                win = max(2, periods(settle_window_s))
                lag = max(1, math.ceil(settle_lag_s / (win * self.bpfo_period_s) - 1e-9))
                buf = np.empty((win * nbp, 12))
                history = []
                settled = False
                while True:
                    integ.advance(st, win * nbp, rec=buf, bar=bar)
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
                integ.advance(st, n_rec, rec=rec_x, rec_every=record_every, states=states, bar=bar)
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
            res.state = integ.to_physical(states[:n_done]) if integ.diagonal else states[:n_done]
        return res
