"""The coupling's running-speed force in the time-domain reference (:class:`bkabem_core.reference.tdsm.Tdsm`).

``[baseline] coupling_force_n`` and ``coupling_phase_deg`` (:mod:`bkabem_core.excitation.baseline`) put a radial
force that turns with the shaft on the coupling node, ``(F_x, F_y) = (Re, Im)(R exp(i Omega t))`` with
``R = coupling_force_n exp(i coupling_phase_deg)``. In the TDSM it is an external force on the FE rotor like
gravity, but turning: the rotor carries it to the bearings through its own dynamics and the nonlinear ball
forces meet it there, so the load zone of each bearing swings once per turn without any model of the share each
bearing takes (BKA-BEM takes the shares from the rotor's statics, :meth:`bkabem_core.fe.machine.Machine.
_turning_loads`, and solves each bearing on the torus of its ball-set position and the shaft angle,
:mod:`bkabem_core.excitation.turning`). The other baseline keys stay out of the TDSM (the bearings' reference).

Discretised as the bearing forces are (first-order hold over a step): the state increment of step ``n`` is
``W_p F(t_n) + W F(t_{n+1})``, which for a rotating force is ``Re(q_n) V_0 + Im(q_n) V_1`` with
``q_n = R exp(i Omega h n)`` (:meth:`RotatingForce.step_vectors`). The record is then no longer periodic in the
ball pass (the shaft turns at its own rate): give :meth:`~bkabem_core.reference.tdsm.Tdsm.run` a fixed
``settle_s`` (its adaptive rule compares BPFO orders) and fit the record at the lines' own frequencies
(:func:`bkabem_core.reference.validation.validate_lines`).

Units: SI (N, m, s, rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["RotatingForce"]


@dataclass(frozen=True)
class RotatingForce:
    """A radial force turning with the shaft at one node of the FE rotor.

    Attributes
    ----------
    amplitude_n : complex
        ``R`` [N]: the force is ``(Re, Im)(R exp(i Omega t))`` on (x, y).
    pattern : ndarray (ndof, 2)
        Unit x and y force at the node.
    omega_rad_s : float
        Shaft speed ``Omega`` [rad/s].
    """

    amplitude_n: complex
    pattern: np.ndarray
    omega_rad_s: float

    @classmethod
    def of_case(cls, case, rotor, speed_hz: float) -> "RotatingForce | None":
        """The coupling force of a case's ``[baseline]`` on ``rotor`` at ``speed_hz`` [Hz], or None if it is 0."""
        b = case.raw["baseline"]
        force = float(b.get("coupling_force_n", 0.0))
        if force <= 0.0:
            return None
        pattern = np.zeros((rotor.ndof, 2))
        node = int(b["misalignment_node"])
        pattern[rotor.dof_index(node, "x"), 0] = pattern[rotor.dof_index(node, "y"), 1] = 1.0
        amplitude = force * complex(np.exp(1j * math.radians(float(b.get("coupling_phase_deg", 0.0)))))
        return cls(amplitude, pattern, 2.0 * math.pi * float(speed_hz))

    def at_step(self, n: int, h: float) -> complex:
        """``q_n = R exp(i Omega h n)`` [N]: the force at ``t = n h`` is ``(Re, Im)(q_n)``."""
        return self.amplitude_n * complex(np.exp(1j * self.omega_rad_s * h * n))

    def step_vectors(self, w: np.ndarray, w_p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
        """``(V_0, V_1)`` of the state increment ``Re(q_n) V_0 + Im(q_n) V_1`` from the step's input columns of the
        pattern, ``w`` (weight of ``F(t_{n+1})``) and ``w_p`` (of ``F(t_n)``), each (state, 2)."""
        c, s = math.cos(self.omega_rad_s * h), math.sin(self.omega_rad_s * h)
        v0 = w_p[:, 0] + c * w[:, 0] + s * w[:, 1]              # Re(q e^{i Omega h}) = c Re q - s Im q, ...
        v1 = w_p[:, 1] - s * w[:, 0] + c * w[:, 1]
        return np.ascontiguousarray(v0), np.ascontiguousarray(v1)

    def steady_state(self, rotor) -> tuple[np.ndarray, np.ndarray]:
        """Displacement and velocity (ndof,) at t = 0 of the linear rotor's steady response to the force,
        ``x = Re(X)``, ``v = Re(i Omega X)`` with ``[K - Omega^2 M + i Omega (C + Omega G)] X = P (R, -i R)``: a
        start that leaves only the nonlinear bearings' share of the transient."""
        w = self.omega_rad_s
        x = np.linalg.solve(rotor.K - w * w * rotor.M + 1j * w * (rotor.C + w * rotor.G),
                            self.pattern @ np.array([self.amplitude_n, -1j * self.amplitude_n]))
        return x.real, (1j * w * x).real
