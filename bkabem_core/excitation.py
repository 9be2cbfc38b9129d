"""The 4-DOF quasi-static bearing model and its spectrum: the "bearing kinematics" of BKA-BEM.

Paper section 3: the rotor and the housing of the faulty bearing, two lateral DOFs each, are connected by the
nonlinear ball-bearing force with the dent (Eqs. 1-4) and a viscous bearing damper; the housing sits on a
spring-damper support; gravity acts on both. The model is integrated at the reference speed with a stiff
(implicit) solver (LSODA, switching to BDF when stiff) from the static equilibrium, the start transient is discarded and a whole number of cage
periods is recorded. The FFT of the rotor-housing relative displacement over exactly those periods gives the
DC part and the amplitude A_k and phase phi_k (cosine convention) of every BPFO order k, for the vertical and
horizontal directions:

    u(t) = DC + sum_k A_k cos(k omega_BPFO t + phi_k),      t = 0 when the cage angle is 0.

Because every ball sees the same load and dent, the response repeats with the ball-pass period, so only BPFO
orders carry energy (checked in the tests). In the angle domain ``omega_BPFO t = z theta_cage``, which is how
the synthesiser places the orders under a varying speed.

Units: SI (m, s, N, kg, rad).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import odeint

from .bearing import TWO_PI, Bearing

DIRECTIONS = ("vertical", "horizontal")


@dataclass(frozen=True)
class FourDofParameters:
    """Parameters of the 4-DOF model (SI).

    Attributes
    ----------
    rotor_mass_kg, housing_mass_kg : float
        Lumped rotor and housing masses [kg].
    support_stiffness_n_m, support_damping_n_s_m : float
        Housing-to-ground support, same in both lateral directions [N/m], [N s/m].
    bearing_damping_n_s_m : float
        Viscous damper between rotor and housing [N s/m] (Table 1: 0.55 N s/mm).
    gravity_m_s2 : float
        Gravitational acceleration along -y [m/s^2].
    reference_speed_hz : float
        Shaft speed of the integration [Hz] (paper: 1 Hz).
    settle_time_s : float
        Minimum start transient discarded [s]; rounded up to whole ball-pass periods.
    record_cage_periods : int
        Whole cage periods recorded for the FFT.
    samples_per_ball_pass : int
        FFT samples per ball-pass (BPFO) period; orders up to half of it are resolved.
    rtol, atol_m : float
        Integrator tolerances (relative; absolute on displacements [m], velocities get atol_m x 1e3 1/s).
    relative_amplitude_threshold : float
        Orders are kept while ``A_k >= threshold * max_k A_k`` in either direction.
    max_order : int
        Keep at most orders 1..max_order (0 = no limit). The paper's choice is 24.
    """

    rotor_mass_kg: float = 82.0
    housing_mass_kg: float = 3.17
    support_stiffness_n_m: float = 1.0e6
    support_damping_n_s_m: float = 1.0e4
    bearing_damping_n_s_m: float = 550.0
    gravity_m_s2: float = 9.80665
    reference_speed_hz: float = 1.0
    settle_time_s: float = 0.3
    record_cage_periods: int = 1
    samples_per_ball_pass: int = 2048
    rtol: float = 1.0e-7
    atol_m: float = 1.0e-12
    relative_amplitude_threshold: float = 1.0e-3
    max_order: int = 0


@dataclass
class Excitation:
    """Spectrum of the rotor-housing relative displacement from the 4-DOF model.

    Attributes
    ----------
    bpfo_per_hz : float
        BPFO multiplier (BPFO per 1 Hz of shaft speed) [-].
    reference_speed_hz : float
        Shaft speed of the 4-DOF integration [Hz].
    orders : ndarray of int (n_orders,)
        Kept BPFO orders k (1 = BPFO).
    amplitude_m : dict direction -> ndarray (n_orders,)
        A_k [m], cosine convention, for ``"vertical"`` and ``"horizontal"``.
    phase_rad : dict direction -> ndarray (n_orders,)
        phi_k [rad], referred to t = 0 at cage angle 0.
    dc_m : dict direction -> float
        Mean relative displacement [m] (static deflection of the bearing incl. clearance).
    peak_to_peak_m : dict direction -> float
        Peak-to-peak of the recorded relative displacement [m].
    clearance_m : float
        Diametral clearance of the bearing [m].
    all_orders, all_amplitude_m, all_phase_rad :
        Every resolved order (before the threshold), for plots and diagnostics.
    time_s, relative_displacement_m : ndarray
        The recorded window (time from the start of recording [s]; shape (2, N): vertical, horizontal [m]).
    off_order_fraction : float
        RMS of the non-BPFO FFT bins relative to the RMS of the BPFO bins (should be ~0) [-].
    static_displacement_m : ndarray (2,)
        Static equilibrium e (horizontal x, vertical y) without the dent [m].
    wall_time_s : float
        Time spent integrating and transforming [s].
    n_steps : int
        Right-hand-side evaluations of the integrator.
    housing_resonance_hz : float
        Housing-on-bearing natural frequency of the 4-DOF model at the static equilibrium (vertical) [Hz];
        orders near and above it carry the 4-DOF model's own ringing rather than bearing kinematics.
    """

    bpfo_per_hz: float
    reference_speed_hz: float
    orders: np.ndarray
    amplitude_m: dict
    phase_rad: dict
    dc_m: dict
    peak_to_peak_m: dict
    clearance_m: float
    all_orders: np.ndarray
    all_amplitude_m: dict
    all_phase_rad: dict
    time_s: np.ndarray
    relative_displacement_m: np.ndarray
    off_order_fraction: float
    static_displacement_m: np.ndarray
    wall_time_s: float
    n_steps: int
    housing_resonance_hz: float = float("nan")

    def to_dict(self) -> dict:
        """JSON-ready summary (field names of the CLI contract)."""
        return {
            "bpfo_per_hz": self.bpfo_per_hz,
            "reference_speed_hz": self.reference_speed_hz,
            "dc_m": {d: float(self.dc_m[d]) for d in DIRECTIONS},
            "orders": [int(k) for k in self.orders],
            "amplitude_m": {d: self.amplitude_m[d].tolist() for d in DIRECTIONS},
            "phase_rad": {d: self.phase_rad[d].tolist() for d in DIRECTIONS},
            "peak_to_peak_m": {d: float(self.peak_to_peak_m[d]) for d in DIRECTIONS},
            "clearance_m": self.clearance_m,
            "off_order_fraction": self.off_order_fraction,
            "static_displacement_m": {"vertical": float(self.static_displacement_m[1]),
                                      "horizontal": float(self.static_displacement_m[0])},
            "n_resolved_orders": int(len(self.all_orders)),
            "housing_resonance_hz": self.housing_resonance_hz,
            "wall_time_s": self.wall_time_s,
            "integrator_steps": self.n_steps,
        }

    def with_selection(self, relative_amplitude_threshold: float, max_order: int = 0) -> "Excitation":
        """The same result with the kept orders chosen again (no re-integration).

        ``max_order=24, relative_amplitude_threshold=0`` is the paper's choice (BPFO and 23 harmonics).
        """
        keep = select_orders(self.all_amplitude_m, relative_amplitude_threshold, max_order)
        out = copy.copy(self)
        out.orders = self.all_orders[keep]
        out.amplitude_m = {d: self.all_amplitude_m[d][keep] for d in DIRECTIONS}
        out.phase_rad = {d: self.all_phase_rad[d][keep] for d in DIRECTIONS}
        return out


def select_orders(all_amplitude_m: dict, relative_amplitude_threshold: float, max_order: int) -> np.ndarray:
    """Boolean mask over orders 1..N: ``A_k >= threshold x max A`` in either direction, and ``k <= max_order``."""
    amp = np.vstack([all_amplitude_m[d] for d in DIRECTIONS])
    keep = np.max(amp, axis=0) >= relative_amplitude_threshold * amp.max()
    if max_order > 0:
        keep &= np.arange(1, amp.shape[1] + 1) <= max_order
    return keep


class FourDofModel:
    """Rotor + housing of one bearing, two lateral DOFs each, nonlinear bearing force with the dent.

    State vector ``y = [x_r, y_r, x_h, y_h, vx_r, vy_r, vx_h, vy_h]`` [m, m/s]; x horizontal, y vertical.

    Parameters
    ----------
    bearing : Bearing
        The faulty bearing (its ``dent`` is used).
    params : FourDofParameters
    """

    def __init__(self, bearing: Bearing, params: FourDofParameters):
        self.bearing = bearing
        self.p = params
        g = bearing.geometry
        self.z = g.n_balls
        self.ftf = bearing.fault_multipliers().ftf
        self.cage_speed_rad_s = TWO_PI * self.ftf * params.reference_speed_hz
        self._u0 = np.exp(1j * bearing._ball_offsets)
        self._half_cd = 0.5 * g.diametral_clearance_m
        self._k = bearing.contact_constant_n_m15
        self._cos_a0 = math.cos(g.contact_angle_rad)
        self._kc = self._k * self._cos_a0
        self._k15 = 1.5 * self._k * self._cos_a0
        self._beta0 = g.first_ball_angle_rad
        self._inv_mr = 1.0 / params.rotor_mass_kg
        self._inv_mh = 1.0 / params.housing_mass_kg
        self._dy = np.zeros(8)
        self._jac_const = self._constant_jacobian()
        self._static = None
        d = bearing.dent
        self._dent = d is not None and bearing.dent_effective_depth_m > 0.0
        if self._dent:
            self._phi_d = d.angle_rad
            self._h = bearing.dent_effective_depth_m
            self._a = bearing.dent_half_angle_rad
            self._a0 = self._a - bearing._dent_edge
            self._one_ball_dent = 2.0 * self._a < TWO_PI / self.z

    # -- bearing force on the rotor, scalar fast path (RHS of the integrator) --
    def _bearing(self, ex, ey, t, stiffness=True):
        """Bearing force on the rotor [N] and, optionally, its tangent stiffness [N/m] (Eqs. 1-4).

        Scalar fast path of :meth:`Bearing.forces_n` (tested equal to it): ball directions as unit complex
        numbers ``u_i = exp(i beta_i)``, so ``delta_i = Re(conj(e) u_i) - c_d/2 - h_dent`` and
        ``F_x + i F_y = -sum Q_i u_i``; the stiffness follows from ``sum dQ_i`` and ``sum dQ_i u_i^2``.
        """
        th = math.fmod(self.cage_speed_rad_s * t, TWO_PI)
        u = self._u0 * complex(math.cos(th), math.sin(th))
        delta = (complex(ex, -ey) * u).real
        delta -= self._half_cd
        if self._dent:
            if self._one_ball_dent:
                # only the ball nearest to the dent can be inside it (dent shorter than the ball pitch)
                pitch = TWO_PI / self.z
                i = int(round((self._phi_d - th - self._beta0) / pitch)) % self.z
                rel = abs(math.remainder(th + self._beta0 + i * pitch - self._phi_d, TWO_PI))
                if rel < self._a:
                    if rel <= self._a0:
                        delta[i] -= self._h
                    else:
                        x = (rel - self._a0) / (self._a - self._a0)
                        delta[i] -= self._h * (1.0 - x * x * (3.0 - 2.0 * x))
            else:
                delta -= self.bearing.dent_depth_m(np.angle(u))
        np.maximum(delta, 0.0, out=delta)
        root = np.sqrt(delta)
        f = -self._kc * np.dot(delta * root, u)
        if not stiffness:
            return f.real, f.imag
        dq = root * self._k15
        s0 = dq.sum()
        s2 = np.dot(dq, u * u)
        return f.real, f.imag, 0.5 * (s0 + s2.real), 0.5 * s2.imag, 0.5 * (s0 - s2.real)

    def rhs(self, t, y):
        """Time derivative of the state (SI)."""
        p = self.p
        fx, fy = self._bearing(y[0] - y[2], y[1] - y[3], t, stiffness=False)
        fx -= p.bearing_damping_n_s_m * (y[4] - y[6])
        fy -= p.bearing_damping_n_s_m * (y[5] - y[7])
        out = self._dy
        out[0:4] = y[4:8]
        out[4] = fx * self._inv_mr
        out[5] = fy * self._inv_mr - p.gravity_m_s2
        out[6] = (-fx - p.support_stiffness_n_m * y[2] - p.support_damping_n_s_m * y[6]) * self._inv_mh
        out[7] = (-fy - p.support_stiffness_n_m * y[3] - p.support_damping_n_s_m * y[7]) * self._inv_mh - p.gravity_m_s2
        return out.copy()

    def jacobian(self, t, y):
        """Analytic Jacobian of :meth:`rhs` (the bearing tangent stiffness enters with ``dF/de = -K``)."""
        _, _, kxx, kxy, kyy = self._bearing(y[0] - y[2], y[1] - y[3], t)
        kb = np.array([[kxx, kxy], [kxy, kyy]])
        j = self._jac_const.copy()
        j[4:6, 0:2] -= kb * self._inv_mr
        j[4:6, 2:4] += kb * self._inv_mr
        j[6:8, 0:2] += kb * self._inv_mh
        j[6:8, 2:4] -= kb * self._inv_mh
        return j

    def _constant_jacobian(self):
        """The part of the Jacobian that does not depend on the bearing force."""
        p = self.p
        cb = p.bearing_damping_n_s_m * np.eye(2)
        j = np.zeros((8, 8))
        j[0:4, 4:8] = np.eye(4)
        j[4:6, 4:6] = -cb * self._inv_mr
        j[4:6, 6:8] = cb * self._inv_mr
        j[6:8, 2:4] = -p.support_stiffness_n_m * np.eye(2) * self._inv_mh
        j[6:8, 4:6] = cb * self._inv_mh
        j[6:8, 6:8] = (-cb - p.support_damping_n_s_m * np.eye(2)) * self._inv_mh
        return j

    def static_state(self):
        """State at the static equilibrium without the dent (housing on its support, bearing loaded).

        Solved once per model (a Newton solve); returns copies (state (8,), bearing e (2,)).
        """
        if self._static is None:
            p = self.p
            e = self.bearing.static_equilibrium_m(0.0, -p.rotor_mass_kg * p.gravity_m_s2)
            yh = -(p.rotor_mass_kg + p.housing_mass_kg) * p.gravity_m_s2 / p.support_stiffness_n_m
            self._static = (np.array([e[0], yh + e[1], 0.0, yh, 0.0, 0.0, 0.0, 0.0]), e)
        return self._static[0].copy(), self._static[1].copy()

    def housing_resonance_hz(self) -> float:
        """Vertical housing-on-bearing natural frequency at the static equilibrium [Hz] (rotor held fixed)."""
        e = self.static_state()[1]
        _, _, (_, _, kyy) = self.bearing.forces_n(e[0], e[1], 0.0, with_stiffness=True, with_dent=False)
        k = float(kyy) + self.p.support_stiffness_n_m
        return math.sqrt(k / self.p.housing_mass_kg) / TWO_PI

    def max_step_s(self) -> float:
        """Largest integrator step that cannot jump over the dent or its edges [s]."""
        bp = 1.0 / (self.z * self.ftf * self.p.reference_speed_hz)
        if not self._dent:
            return bp / 50.0
        edge = (self._a - self._a0) if self._a > self._a0 else self._a / 10.0
        return min(bp / 50.0, 0.5 * edge / self.cage_speed_rad_s)

    def integrate(self, progress=None):
        """Integrate from the static equilibrium; return (record times [s], relative displacement (2, N) [m], steps).

        The recording starts after ``settle_time_s`` rounded up to whole ball-pass periods, so t = 0 of the
        recording is again a cage angle that is a multiple of the ball pitch (phases refer to cage angle 0).
        """
        p = self.p
        f_bp = self.z * self.ftf * p.reference_speed_hz
        t_bp = 1.0 / f_bp
        n_settle = max(1, math.ceil(p.settle_time_s / t_bp - 1e-9))
        t0 = n_settle * t_bp
        n_rec = p.record_cage_periods * self.z
        n = n_rec * p.samples_per_ball_pass
        t_rec = n_rec * t_bp
        t_eval = t0 + t_rec * np.arange(n) / n
        y0, _ = self.static_state()
        atol = np.r_[np.full(4, p.atol_m), np.full(4, p.atol_m * 1e3)]
        # LSODA through odeint: the same integrator as solve_ivp(method="LSODA"), but its Fortran driver steps
        # without a Python round trip per step (about 2x faster here); output by its own interpolation.
        y, info = odeint(self.rhs, y0, np.r_[0.0, t_eval], Dfun=self.jacobian, tfirst=True, rtol=p.rtol,
                         atol=atol, hmax=self.max_step_s(), mxstep=10_000_000, full_output=True)
        if info["message"] != "Integration successful.":
            raise RuntimeError(f"4-DOF integration failed: {info['message']}")
        y = y[1:].T
        n_eval = int(info["nfe"][-1])
        rel = np.vstack([y[1] - y[3], y[0] - y[2]])                   # vertical, horizontal
        return t_eval - t0, rel, n_eval


def compute_excitation(bearing: Bearing, params: FourDofParameters) -> Excitation:
    """Integrate the 4-DOF model and transform it into BPFO orders (DC, A_k, phi_k, vertical and horizontal).

    Parameters
    ----------
    bearing : Bearing
        The faulty bearing with its dent.
    params : FourDofParameters

    Returns
    -------
    Excitation
    """
    t_start = time.perf_counter()
    model = FourDofModel(bearing, params)
    t, rel, n_steps = model.integrate()
    n = rel.shape[1]
    spec = np.fft.rfft(rel, axis=1) / n
    stride = params.record_cage_periods * model.z            # FFT bins per BPFO order
    k_max = (n // 2 - 1) // stride                              # the Nyquist bin is not an order
    all_orders = np.arange(1, k_max + 1)
    bins = all_orders * stride
    amp = 2.0 * np.abs(spec[:, bins])
    pha = np.angle(spec[:, bins])
    mask = np.ones(spec.shape[1], dtype=bool)
    mask[0] = False
    mask[bins] = False
    on = np.sqrt(np.sum(np.abs(spec[:, bins]) ** 2))
    off = np.sqrt(np.sum(np.abs(spec[:, mask]) ** 2))
    keep = select_orders({"vertical": amp[0], "horizontal": amp[1]}, params.relative_amplitude_threshold,
                         params.max_order)
    orders = all_orders[keep]
    ex = Excitation(
        bpfo_per_hz=bearing.fault_multipliers().bpfo,
        reference_speed_hz=params.reference_speed_hz,
        orders=orders,
        amplitude_m={"vertical": amp[0, keep], "horizontal": amp[1, keep]},
        phase_rad={"vertical": pha[0, keep], "horizontal": pha[1, keep]},
        dc_m={"vertical": float(spec[0, 0].real), "horizontal": float(spec[1, 0].real)},
        peak_to_peak_m={"vertical": float(np.ptp(rel[0])), "horizontal": float(np.ptp(rel[1]))},
        clearance_m=bearing.geometry.diametral_clearance_m,
        all_orders=all_orders,
        all_amplitude_m={"vertical": amp[0], "horizontal": amp[1]},
        all_phase_rad={"vertical": pha[0], "horizontal": pha[1]},
        time_s=t,
        relative_displacement_m=rel,
        off_order_fraction=float(off / on) if on > 0 else 0.0,
        static_displacement_m=model.static_state()[1],
        wall_time_s=time.perf_counter() - t_start,
        n_steps=n_steps,
        housing_resonance_hz=model.housing_resonance_hz(),
    )
    return ex
