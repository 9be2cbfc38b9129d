"""The quasi-static path of one bearing: its static equilibrium at each position of the ball set (no inertia).

The relative displacement of the inner race in the outer race at which the ball forces balance the load on the
shaft, solved for many angles at once; the quasi-static excitation (:mod:`bkabem_core.excitation.quasi_static`),
the load that turns with the shaft (:mod:`bkabem_core.excitation.turning`) and the improved method's moving
defects (:mod:`bkabem_core.solve.improved`) are Fourier series of it.

Units: SI (m, N, rad).
"""

from __future__ import annotations

import numpy as np

from bkabem_core.bearing.deep_groove import Bearing

__all__ = ["quasi_static_path_m"]


def quasi_static_path_m(bearing: Bearing, radial_load_n, axial_load_n: float, cage_angles_rad,
                        film_m: float = 0.0, tol_m: float = 1e-15, max_iter: int = 100, shaft_angles_rad=0.0,
                        spin_angles_rad=0.0, turning_load_n: complex = 0j):
    """Static equilibrium ``e(theta)`` [m] (N, 2: e_x, e_y) of the bearing with its defects at each cage angle.

    Solves ``F(e, theta; e_z0) + W = 0`` for all angles at once (batched damped Newton with the analytic 2 x 2
    tangent), the axial displacement held at ``e_z0``, its static value under the axial load. ``shaft_angles_rad``
    and ``spin_angles_rad`` (broadcast with the cage angles) place inner-race and ball defects and turn the load
    ``turning_load_n`` [N] that turns with the shaft: the load is ``W + (Re, Im)(R exp(i theta_shaft))``.

    Returns
    -------
    path : ndarray (N, 2)
    state : BearingState
        The healthy static equilibrium (start of the iteration).
    iterations : int
    """
    w = np.asarray(radial_load_n, dtype=float)
    state = bearing.state(w[0], w[1], axial_load_n, film_m)
    e0 = state.displacement_m
    theta = np.asarray(cage_angles_rad, dtype=float)
    shape = np.broadcast_shapes(theta.shape, np.shape(shaft_angles_rad), np.shape(spin_angles_rad))
    theta = np.broadcast_to(theta, shape)
    if turning_load_n != 0:
        turn = complex(turning_load_n) * np.exp(1j * np.broadcast_to(np.asarray(shaft_angles_rad, float), shape))
        w = (w[0] + turn.real, w[1] + turn.imag)
    ex = np.full(shape, e0[0])
    ey = np.full(shape, e0[1])
    wn = np.maximum(np.hypot(w[0], w[1]), 1e-300)
    ux, uy = w[0] / wn, w[1] / wn                        # the load's direction (per angle with a turning load)
    for it in range(1, max_iter + 1):
        fx, fy, (kxx, kxy, kyy) = bearing.forces_n(ex, ey, theta, film_m, with_stiffness=True, e_z_m=e0[2],
                                                   shaft_angle_rad=shaft_angles_rad, spin_angle_rad=spin_angles_rad)
        rx, ry = fx + w[0], fy + w[1]
        det = kxx * kyy - kxy * kxy
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = (kyy * rx - kxy * ry) / det             # K s = r  (F(e + s) ~ F(e) - K s = -W)
            sy = (kxx * ry - kxy * rx) / det
        single = ~(np.abs(det) > 1e-12 * (kxx + kyy) ** 2)
        if np.any(single):
            # one ball alone under a light load is stiff along its own line only (or none touches yet): Newton
            # along the load's direction there, as the bearing's own static solution does
            k_u = ux * (kxx * ux + kxy * uy) + uy * (kxy * ux + kyy * uy)
            with np.errstate(divide="ignore", invalid="ignore"):
                s_u = np.where(k_u > 0.0, (ux * rx + uy * ry) / k_u, 1e-7)
            sx = np.where(single, ux * s_u, sx)
            sy = np.where(single, uy * s_u, sy)
        n = np.hypot(sx, sy)
        scale = np.minimum(1.0, 2e-6 / np.maximum(n, 1e-300))   # never more than 2 um at once (contacts change)
        ex += sx * scale
        ey += sy * scale
        if np.max(n) <= tol_m:
            break
    else:
        raise RuntimeError(f"quasi-static bearing equilibrium did not converge (last step {np.max(n):.2e} m)")
    return np.stack([ex, ey], axis=-1), state, it
