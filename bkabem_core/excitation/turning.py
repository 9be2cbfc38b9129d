"""The lines of one bearing under a load that turns with the shaft (the coupling force's share of each bearing).

A radial load on the shaft that turns with it, ``(Re, Im)(R exp(i theta_shaft))`` [N] on top of the static load
(:meth:`bkabem_core.fe.machine.Machine._turning_loads`), makes the bearing's state depend on the shaft angle as
well as on the ball-set position: the quasi-static equilibrium
(:func:`~bkabem_core.excitation.path.quasi_static_path_m`) is solved on the 2-torus of those two angles and its
2-D Fourier series gives the lines (:func:`~bkabem_core.excitation.lines.lines_from_grid`). The load zone swings
once per turn, so every line of the bearing gains sidebands at the shaft frequency (an outer-race defect:
BPFO +- k f_r), and a healthy bearing's ball passage relative to the turning load appears at BPFI (McFadden &
Smith, "Model for the vibration produced by a single point defect in a rolling element bearing", J. Sound Vib.
96, 1984; Randall & Antoni, "Rolling element bearing diagnostics - a tutorial", MSSP 25, 2011, section 2).

Units: SI (m, N, rad).
"""

from __future__ import annotations

import math

import numpy as np

from bkabem_core.bearing.deep_groove import TWO_PI, Bearing
from bkabem_core.bearing.defects.registry import kind as defect_kind
from bkabem_core.excitation.lines import LineSet, lines_from_grid, union
from bkabem_core.excitation.path import quasi_static_path_m
from bkabem_core.model.vocabulary import DIRECTIONS

__all__ = ["turning_lines", "TURNING_BASE_SAMPLES", "NEGLIGIBLE_M"]


def turning_lines(bearing: Bearing, load, turning_load_n: complex, axial_load_n: float, n_fast: int, n_slow: int,
                   film_m: float, rates) -> LineSet:
    """Lines of the bearing's races and their defects (every kind but the ball's) under a load that turns with the
    shaft, each part on a 2-torus whose slow angle is the shaft angle ``b = theta_shaft`` (where the turning load
    points) and whose fast angle is the ball-set position along which that part is narrow:

    * the races without defects, relative to the outer race ``a = z theta_cage``, on a coarse grid of it (their
      path is smooth along the ball passage);
    * what the outer-race defects add to them, on the same torus, solved where a ball meets one;
    * what the inner-race defects add to the bearing with its outer-race defects, relative to the shaft
      ``a = z (theta_shaft - theta_cage)`` (they turn with it), solved where a ball meets one: the path with every
      defect less the path without the inner-race ones, both under the same loads, so that a ball in an outer-race
      pit while another meets an inner-race one is in this difference.

    This is how the moving kinds add to the rest of a bearing under a static load too
    (:func:`~bkabem_core.excitation.quasi_static.quasi_static_excitation`); no single 2-torus resolves an inner-race
    and an outer-race defect together, each being narrow along its own ball-set position. Every grid point is
    solved (batched Newton). The pure shaft orders of the races without defects are dropped: their 1x is the
    bearing's deflection under the turning force, which the FE carries as a line of its own. The defects' own
    shaft orders (a pit's effect on the path changes as the turning load sweeps past it) are kept. Lines below
    ``NEGLIGIBLE_M`` (round-off of a nearly uniform bearing) are dropped."""
    g = bearing.geometry
    z = g.n_balls
    slow = n_slow if n_slow > 0 else max(64, 1 << math.ceil(math.log2(8 * z)))
    if n_fast % slow:
        raise ValueError(f"samples: {n_fast} per ball pass must be a multiple of the {slow} slow samples")
    healthy = Bearing(g)
    outer = Bearing(g, defects=[d for d in bearing.defects if defect_kind(d.race).periodic])
    inner = [d for d in bearing.defects if d.race == "inner"]
    i, j = np.meshgrid(np.arange(n_fast), np.arange(slow), indexing="ij")
    phase_map = np.array([[0, z, 0, 0], [1, 0, 0, 0]])
    cage, shaft = TWO_PI * i / (n_fast * z), TWO_PI * j / slow
    step = n_fast // min(n_fast, TURNING_BASE_SAMPLES)
    base, _, _ = quasi_static_path_m(healthy, load, axial_load_n, cage[::step], film_m,
                                     shaft_angles_rad=shaft[::step], turning_load_n=turning_load_n)
    base_lines = lines_from_grid(base[..., ::-1], phase_map, rates, DIRECTIONS)      # (vertical, horizontal)
    parts = [base_lines.subset(~(base_lines.coefficients[:, 1:] == 0).all(axis=1))]
    if outer.defects:
        parts.append(_difference(outer, healthy, outer, load, turning_load_n, axial_load_n, cage, shaft, phase_map,
                                 film_m, rates))
    if inner:
        grid = defect_kind("inner").torus(z, n_fast, slow)
        full = Bearing(g, defects=[d for d in bearing.defects if defect_kind(d.race).periodic or d.race == "inner"])
        parts.append(_difference(full, outer, Bearing(g, defects=inner), load, turning_load_n, axial_load_n,
                                 grid.cage, grid.shaft, grid.phase_map, film_m, rates))
    out = union(parts)
    return out.subset(np.abs(out.amplitude).max(axis=1) >= NEGLIGIBLE_M)


def _difference(with_d: Bearing, without: Bearing, meets: Bearing, load, turning_load_n: complex,
                axial_load_n: float, cage, shaft, phase_map, film_m: float, rates) -> LineSet:
    """Lines of ``path(with_d) - path(without)`` under the same loads on the grid ``cage``, ``shaft`` [rad] of a
    2-torus (``phase_map``): zero but where a ball meets a defect of ``meets``, solved there."""
    touched = np.any(meets.defect_set.drop_m(meets.ball_angles_rad(cage), shaft, np.zeros_like(shaft)) > 0.0,
                     axis=-1)
    diff = np.zeros(cage.shape + (2,))
    if touched.any():
        a, _, _ = quasi_static_path_m(with_d, load, axial_load_n, cage[touched], film_m,
                                      shaft_angles_rad=shaft[touched], turning_load_n=turning_load_n)
        b, _, _ = quasi_static_path_m(without, load, axial_load_n, cage[touched], film_m,
                                      shaft_angles_rad=shaft[touched], turning_load_n=turning_load_n)
        diff[touched] = a - b
    return lines_from_grid(diff[..., ::-1], phase_map, rates, DIRECTIONS)


#: Samples per ball pass of a healthy bearing's path under a turning load (it is smooth along the ball passage).
TURNING_BASE_SAMPLES = 128
#: Lines of a quasi-static path below this are round-off, not physics (1e-15 m: 1e-6 m/s^2 at 5 kHz).
NEGLIGIBLE_M = 1.0e-15
