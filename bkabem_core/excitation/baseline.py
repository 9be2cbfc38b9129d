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
``coupling_force_n``, ``coupling_phase_deg`` (optional, 0 = off)
    The running-speed force of the coupling to the driven machine: the radial force a flexible coupling exerts
    when its hub runs out (the coupling's radial stiffness times the eccentricity that turns with the shaft; a
    parallel offset alone gives a force that stands still), rotating with the shaft at ``misalignment_node``;
    speed-independent. Besides its 1x line through the FE, it is a load that turns with the shaft in each bearing
    (:meth:`bkabem_core.fe.machine.Machine._turning_loads`: each bearing's share from the statics of the
    two-bearing rotor): with the light static loads of small machines it swings the load zone once per turn and
    modulates every ball's contact, so the bearing's lines gain sidebands at the shaft frequency and a healthy
    bearing gains its ball passage relative to the turning load, at BPFI (McFadden & Smith 1984; Randall & Antoni
    2011, section 2).
``looseness_force_n``, ``looseness_orders`` (optional, 0 = off; the orders are needed when the force is not 0)
    A loose fit (a bearing in its housing, an end shield on the frame, the machine on its base) takes up its play
    once per turn: the force through it jumps at one shaft angle instead of varying smoothly, which puts a comb of
    shaft harmonics into the vibration (Randall, *Vibration-based Condition Monitoring*, Wiley 2011; ISO 18436-2
    training material: looseness shows as many harmonics of 1x). The rule used here: a vertical force at
    ``misalignment_node`` (the coupling end of the shaft) whose k-th shaft harmonic, k = 1 .. ``looseness_orders``,
    has the amplitude ``looseness_force_n / k`` and the phase of a sine, ``F_k sin(k theta_shaft)``: the Fourier
    series of a sawtooth, the simplest periodic force with one jump per turn (the coefficients of any periodic
    function with one jump per period fall as 1/k). A model, not a law of looseness: ``looseness_force_n`` is the
    1x amplitude; how loose an assembly is changes from one assembly to the next. It is a force line on the FE
    only: the bearings' quasi-static model does not see it as a load (unlike the coupling force), and the half
    orders of a rub are not modelled.
``electrical_harmonics``, ``electrical_harmonic_forces_n`` (optional)
    Further magnetic force lines of an induction motor, at the given multiples of the supply frequency, each a
    vertical force of the given amplitude [N] on the rotor core as the 2 x line below. The radial magnetic force
    goes with the square of the air-gap flux density; on a symmetric supply the flux at a point of the stator holds
    odd harmonics of the supply only, so its square (the force) holds even ones only: the multiples must be even,
    and above 2 (the 2 x line is ``electrical_force_n``), e.g. 4, 6, 12 (Gieras, Wang & Lai, *Noise of Polyphase
    Electric Motors*, CRC 2006). Slot and eccentricity lines, which move with the speed, are not modelled.
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
#: The misalignment (2x), the coupling's running-speed force (1x) and the looseness (1x, 2x, ...) all act at the
#: coupling end of the shaft (``misalignment_node``): one pattern pair, "coupling.x" and "coupling.y".
PATTERNS = ("unbalance.x", "unbalance.y", "coupling.x", "coupling.y", "electrical.y")


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

    def coupling_end():
        for axis in ("x", "y"):
            v = np.zeros(rotor.ndof)
            v[idx(int(b["misalignment_node"]), axis)] = 1.0
            patterns[f"coupling.{axis}"] = v

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
        coupling_end()
        rows.append(((2, 0, 0, 0, 0, 0), {"coupling.x": f_mis, "coupling.y": -1j * f_mis}, 0))
    f_cp = float(b.get("coupling_force_n", 0.0))
    if f_cp > 0.0:
        coupling_end()
        a = f_cp * np.exp(1j * math.radians(b.get("coupling_phase_deg", 0.0)))
        rows.append(((1, 0, 0, 0, 0, 0), {"coupling.x": a, "coupling.y": -1j * a}, 0))
    f_loose = float(b.get("looseness_force_n", 0.0))
    if f_loose > 0.0:
        coupling_end()
        for k in range(1, int(b["looseness_orders"]) + 1):
            # F/k sin(k theta) = Re(-i F/k exp(i k theta)): the sawtooth's series (module docstring)
            rows.append(((k, 0, 0, 0, 0, 0), {"coupling.y": -1j * f_loose / k}, 0))
    f_el = float(b["electrical_force_n"])
    electrical = [(2, f_el)] + [(int(h), float(f)) for h, f in zip(b.get("electrical_harmonics", []),
                                                                    b.get("electrical_harmonic_forces_n", []))]
    electrical = [(h, f) for h, f in electrical if f > 0.0]
    if electrical and disks:
        core = [d for d in disks if str(d["name"]).startswith("core")] or list(disks)
        total = sum(float(d["mass_kg"]) for d in core)
        v = np.zeros(rotor.ndof)
        for d in core:
            v[idx(int(d["node"]), "y")] += float(d["mass_kg"]) / total
        patterns["electrical.y"] = v
        for h, f in electrical:
            rows.append(((0, 0, 0, 0, 0, h), {"electrical.y": f}, 0))
    names = tuple(n for n in PATTERNS if n in patterns)
    merged: dict = {}                 # one line per (coefficients, speed power): several patterns may share it
    for c, vals, p in rows:
        entry = merged.setdefault((tuple(c), p), {})
        for n, v in vals.items():
            entry[n] = entry.get(n, 0.0) + v
    coef = np.array([k[0] for k in merged], dtype=np.int64).reshape(-1, N_PHASES)
    amp = np.zeros((len(merged), len(names)), complex)
    for i, vals in enumerate(merged.values()):
        for n, v in vals.items():
            amp[i, names.index(n)] = v
    power = np.array([k[1] for k in merged], dtype=np.int64)
    lines = LineSet(coef, amp, names, rates_per_hz, float(b["line_frequency_hz"]), power)
    return lines, patterns
