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
    shaft, on a 2-torus whose slow angle is the shaft angle ``b = theta_shaft`` (where the turning load points)
    and whose fast angle is the ball-set position: relative to the outer race ``a = z theta_cage`` (healthy races,
    outer-race defects), or relative to the shaft ``a = z (theta_shaft - theta_cage)`` when an inner-race defect
    turns with the shaft (its lines need it fast; an outer-race defect in the same bearing would not be resolved
    then, and is refused). Every grid point is solved (batched Newton); the pure shaft orders are dropped (the FE
    carries the turning force as a line of its own), and lines below ``NEGLIGIBLE_M`` (round-off of a nearly
    uniform bearing) too."""
    z = bearing.geometry.n_balls
    slow = n_slow if n_slow > 0 else max(64, 1 << math.ceil(math.log2(8 * z)))
    if n_fast % slow:
        raise ValueError(f"samples: {n_fast} per ball pass must be a multiple of the {slow} slow samples")
    kinds = {d.race for d in bearing.defects if d.race != "ball"}
    race = Bearing(bearing.geometry, defects=[d for d in bearing.defects if d.race in kinds])
    if "inner" in kinds:
        if len(kinds) > 1:
            raise ValueError("a load that turns with the shaft and both an inner-race and another race defect in one "
                             "bearing: not resolved on one 2-torus")
        grid = defect_kind("inner").torus(z, n_fast, slow)
        phase_map, cage, shaft = grid.phase_map, grid.cage, grid.shaft
    else:
        i, j = np.meshgrid(np.arange(n_fast), np.arange(slow), indexing="ij")
        phase_map = np.array([[0, z, 0, 0], [1, 0, 0, 0]])
        cage, shaft = TWO_PI * i / (n_fast * z), TWO_PI * j / slow
    # the races without defects: smooth along the ball-set position, solved on a coarse grid of it
    coarse = min(n_fast, TURNING_BASE_SAMPLES)
    step = n_fast // coarse
    healthy = Bearing(bearing.geometry)
    base, _, _ = quasi_static_path_m(healthy, load, axial_load_n, cage[::step], film_m,
                                     shaft_angles_rad=shaft[::step], turning_load_n=turning_load_n)
    parts = [lines_from_grid(base[..., ::-1], phase_map, rates, DIRECTIONS)]      # (vertical, horizontal)
    if race.defects:
        # what the defects add: nonzero only where a ball meets one, solved there on the fine grid
        beta = race.ball_angles_rad(cage)
        touched = np.any(race.defect_set.drop_m(beta, shaft, np.zeros_like(shaft)) > 0.0, axis=-1)
        diff = np.zeros(cage.shape + (2,))
        if touched.any():
            with_d, _, _ = quasi_static_path_m(race, load, axial_load_n, cage[touched], film_m,
                                               shaft_angles_rad=shaft[touched], turning_load_n=turning_load_n)
            without, _, _ = quasi_static_path_m(healthy, load, axial_load_n, cage[touched], film_m,
                                                shaft_angles_rad=shaft[touched], turning_load_n=turning_load_n)
            diff[touched] = with_d - without
        parts.append(lines_from_grid(diff[..., ::-1], phase_map, rates, DIRECTIONS))
    out = union(parts)
    keep = ~(out.coefficients[:, 1:] == 0).all(axis=1) & (np.abs(out.amplitude).max(axis=1) >= NEGLIGIBLE_M)
    return out.subset(keep)


#: Samples per ball pass of a healthy bearing's path under a turning load (it is smooth along the ball passage).
TURNING_BASE_SAMPLES = 128
#: Lines of a quasi-static path below this are round-off, not physics (1e-15 m: 1e-6 m/s^2 at 5 kHz).
NEGLIGIBLE_M = 1.0e-15
