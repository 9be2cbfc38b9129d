"""The machine baseline: what every real motor has besides its bearings, as force lines on the FE rotor.

Each effect is one key of the case's ``[baseline]`` section (0 = off) and enters the harmonic solve as a force
pattern on the FE model with its own line (:mod:`bkabem_core.excitation.lines`), beside the bearings' base excitations:

``unbalance_grade_mm_s`` (default G 2.5), ``unbalance_phase_deg``
    Residual unbalance by balance grade, ISO 21940-11: ``G = e_per Omega_max`` [mm/s], the permissible specific
    unbalance at the maximum service speed (G 2.5: electric motors, machine tools). The mass centre of every disk
    of the rotor sits ``e = G / Omega_max`` off the axis (``Omega_max`` from ``operating.max_speed_hz``) at the
    angle ``unbalance_phase_deg`` (a static unbalance), so the force is ``m_i e Omega^2`` rotating with the shaft:
    the 1x line, growing with the square of the speed. For the embedded 82 kg rotor, G 2.5 at 75 Hz: e = 5.3 um,
    34 N at 50 Hz.
``misalignment_force_n``, ``misalignment_node``
    A misaligned flexible coupling loads the shaft end mostly at twice the running speed (Piotrowski, *Shaft
    Alignment Handbook*, 3rd ed., ch. 2; ISO 18436-2 training material): modelled as a 2x force of the given
    amplitude rotating with the shaft at the coupling node. A model, not a coupling law: set the amplitude from
    the coupling's radial stiffness times the offset.
``electrical_force_n``, ``line_frequency_hz``
    An induction motor's unbalanced magnetic pull pulsates at twice the supply frequency (100 Hz at 50 Hz),
    independent of the speed (Finley, Hodowanec & Holter, "An analytical approach to solving motor vibration
    problems", IEEE Trans. Ind. Appl. 36, 2000): a vertical force of that amplitude on the rotor core (the disks
    named ``core*``, else every disk), shared by mass.

Units: SI (N, m, kg, rad); line amplitudes per the ``speed_power`` convention of :class:`~bkabem_core.excitation.lines.LineSet`
(the unbalance force per Hz^2 of shaft speed).
"""

from __future__ import annotations

import math

import numpy as np

from bkabem_core.excitation.lines import N_PHASES, LineSet

TWO_PI = 2.0 * math.pi
#: Force patterns of the baseline, in the order BkaBem appends them to its input patterns.
PATTERNS = ("unbalance.x", "unbalance.y", "misalignment.x", "misalignment.y", "electrical.y")


def unbalance_eccentricity_m(case) -> float:
    """Mass-centre offset of the disks from ISO 21940-11: ``e = G / Omega_max`` [m]."""
    grade = float(case.raw["baseline"]["unbalance_grade_mm_s"]) * 1e-3
    return grade / (TWO_PI * case.max_speed_hz)


def baseline_forces(case, rotor, rates_per_hz) -> tuple[LineSet, dict]:
    """The baseline as force lines and their patterns.

    Parameters
    ----------
    case : Case
    rotor : Rotor
        The FE model (``dof_index``, ``ndof``).
    rates_per_hz : ndarray (6,)
        Base-phase rates of the machine (:class:`~bkabem_core.excitation.lines.MachinePhases`): the baseline's
        lines follow the shaft and the supply only.

    Returns
    -------
    lines : LineSet
        Inputs = the names of the active patterns; amplitudes [N] (unbalance [N per Hz^2], ``speed_power`` 2).
    patterns : dict name -> ndarray (ndof,)
        Force pattern on the FE DOFs per unit input.
    """
    b = case.raw["baseline"]
    disks = case.raw["rotor"]["disks"]
    idx = rotor.dof_index
    patterns: dict = {}
    rows: list = []                   # (coefficients, {pattern: amplitude}, speed power)
    e = unbalance_eccentricity_m(case)
    if e > 0.0 and disks:
        for axis in ("x", "y"):
            v = np.zeros(rotor.ndof)
            for d in disks:
                v[idx(int(d["node"]), axis)] += float(d["mass_kg"])
            patterns[f"unbalance.{axis}"] = v
        a = e * TWO_PI ** 2 * np.exp(1j * math.radians(b["unbalance_phase_deg"]))
        rows.append(((1, 0, 0, 0, 0, 0), {"unbalance.x": a, "unbalance.y": -1j * a}, 2))
    f_mis = float(b["misalignment_force_n"])
    if f_mis > 0.0:
        for axis in ("x", "y"):
            v = np.zeros(rotor.ndof)
            v[idx(int(b["misalignment_node"]), axis)] = 1.0
            patterns[f"misalignment.{axis}"] = v
        rows.append(((2, 0, 0, 0, 0, 0), {"misalignment.x": f_mis, "misalignment.y": -1j * f_mis}, 0))
    f_el = float(b["electrical_force_n"])
    if f_el > 0.0 and disks:
        core = [d for d in disks if str(d["name"]).startswith("core")] or list(disks)
        total = sum(float(d["mass_kg"]) for d in core)
        v = np.zeros(rotor.ndof)
        for d in core:
            v[idx(int(d["node"]), "y")] += float(d["mass_kg"]) / total
        patterns["electrical.y"] = v
        rows.append(((0, 0, 0, 0, 0, 2), {"electrical.y": f_el}, 0))
    names = tuple(n for n in PATTERNS if n in patterns)
    coef = np.array([r[0] for r in rows], dtype=np.int64).reshape(-1, N_PHASES)
    amp = np.zeros((len(rows), len(names)), complex)
    for i, (_, vals, _) in enumerate(rows):
        for n, v in vals.items():
            amp[i, names.index(n)] = v
    power = np.array([r[2] for r in rows], dtype=np.int64)
    lines = LineSet(coef, amp, names, rates_per_hz, float(b["line_frequency_hz"]), power)
    return lines, patterns
