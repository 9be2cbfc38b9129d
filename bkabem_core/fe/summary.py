"""What a case's machine is, in the numbers an engineer checks first (``bkabem case check``).

:func:`machine_summary` makes the case's machine (:class:`bkabem_core.fe.machine.Machine`: the FE converged up to
the case's band, each bearing linearised at its own static load) and reports

* the rotor: mass, length, bearing span, shaft nodes, FE elements and DOF;
* each bearing: its type and where its numbers come from, its static radial load (gravity, the lever rule of the
  two supports) and axial load, its static safety ``s0 = C0 / P0`` (ISO 76: ``P0 = max(Fr, 0.6 Fr + 0.5 Fa)``),
  the FE bearing's stiffness and damping, its fault multipliers and frequencies at the lowest and the highest
  speed of the operating range;
* the modes in the band (undamped, at standstill, with each bearing's linearised stiffness): frequency, where the
  mode moves most, how much of its kinetic energy is in the housings;
* notes: what the plausibility bounds say (the FE mesh against ``rotor.fe_elements``, the bounds the case widens),
  and what deserves a look -- a mode inside the speed range (a critical speed the 1x unbalance excites), a static
  safety below 1, a speed above a bearing's limiting speed.

Nothing here changes the case; the notes are findings, not errors (a case that loads is valid). Units: SI.
"""

from __future__ import annotations

import math

import numpy as np

from bkabem_core.fe.budget import mesh_elements
from bkabem_core.fe.machine import Machine
from bkabem_core.model import plausibility
from bkabem_core.model.case import Case
from bkabem_core.model.catalogue import CatalogueError, lookup
from bkabem_core.model.vocabulary import BEARINGS

__all__ = ["machine_summary"]


def machine_summary(case: Case, speed_range_hz: tuple[float, float] | None = None,
                    machine: Machine | None = None) -> dict:
    """The summary of ``case`` (module docstring) as a JSON-ready dict.

    Parameters
    ----------
    case : Case
    speed_range_hz : (float, float), optional
        Lowest and highest shaft speed [Hz] (a compact case's ``machine.speed_range_hz``); default ``(0,
        operating.max_speed_hz)``.
    machine : Machine, optional
        The case's machine, made already.
    """
    lo, hi = speed_range_hz if speed_range_hz is not None else (0.0, case.max_speed_hz)
    machine = Machine(case) if machine is None else machine
    rotor = machine.rotor
    raw = case.raw
    op = raw["operating"]
    z = raw["rotor"]["node_positions_m"]
    z_b = {b: z[int(raw["bearings"][b]["rotor_node"]) - 1] for b in BEARINGS}
    notes: list[str] = []
    out = {"case": case.name, "source": case.source, "case_hash": case.case_hash,
           "speed_range_hz": [lo, hi], "band_hz": case.max_frequency_hz,
           "load_table": [{"load_hp": float(x), "speed_hz": float(f)} for x, f in
                          zip(op.get("load_hp", []), op.get("load_speed_hz", []))],
           "rotor": {"mass_kg": rotor.rotor_mass_kg, "length_m": z[-1] - z[0],
                     "bearing_positions_m": z_b, "span_m": abs(z_b["nde"] - z_b["de"]), "shaft_nodes": len(z),
                     "fe_elements": machine.mesh.n_elements, "dof": rotor.ndof},
           "bearings": {b: _bearing(case, machine, b, lo, hi, notes) for b in BEARINGS},
           "modes": _modes(case, machine, lo, hi, notes)}
    out["plausibility"] = _plausibility(case, machine, notes)
    out["notes"] = notes
    return out


def _bearing(case: Case, machine: Machine, name: str, lo: float, hi: float, notes: list) -> dict:
    site = machine.sites[name]
    table = case.bearing_table(name)
    fr = float(math.hypot(*site.radial_load_n))
    fa = site.axial_load_n
    p0 = max(fr, 0.6 * fr + 0.5 * fa)
    c0 = float(table["static_load_rating_n"])
    s0 = c0 / p0 if p0 > 0 else math.inf
    if s0 < 1.0:
        notes.append(f"{name.upper()} bearing: static safety s0 = C0 / P0 = {s0:.2g} < 1 (ISO 76: permanent "
                     f"deformation of the raceways under the static load)")
    mult = case.fault_multipliers(name)
    prov = case.bearing_provenance(name)
    limit = _limiting_speed_hz(table["designation"])
    if limit is not None and hi > limit:
        notes.append(f"{name.upper()} bearing: the highest speed {hi:g} Hz is above its limiting speed "
                     f"{limit:g} Hz ({limit * 60:g} r/min, catalogue)")
    return {"designation": table["designation"], "geometry_status": prov["geometry_status"],
            "clearance": prov["clearance"], "diametral_clearance_m": float(table["diametral_clearance_m"]),
            "n_balls": int(table["n_balls"]), "ball_diameter_m": float(table["ball_diameter_m"]),
            "pitch_diameter_m": float(table["pitch_diameter_m"]),
            "static_radial_load_n": fr, "applied_radial_load_n": case.applied_radial_load_n(name),
            "axial_load_n": fa, "static_load_rating_n": c0, "static_safety": s0,
            "limiting_speed_hz": limit,
            "fe_bearing": {"source": site.source,
                           "stiffness_n_m": {"horizontal": float(site.stiffness_n_m[0]),
                                             "vertical": float(site.stiffness_n_m[1])},
                           "damping_n_s_m": {"horizontal": float(site.damping_n_s_m[0]),
                                             "vertical": float(site.damping_n_s_m[1])},
                           "stiffness_variation": site.linearisation.stiffness_variation},
            "fault_multipliers": mult.to_dict(),
            "fault_frequencies_hz": {f"{s:g}": mult.at_speed(s).to_dict() for s in sorted({lo, hi}) if s > 0}}


def _limiting_speed_hz(designation: str) -> float | None:
    try:
        rpm = lookup(designation).limiting_speed_rpm
    except CatalogueError:
        return None
    return rpm / 60.0 if math.isfinite(rpm) else None


def _modes(case: Case, machine: Machine, lo: float, hi: float, notes: list) -> list[dict]:
    """The undamped modes at standstill below the band: frequency, the node of most kinetic energy, housing share."""
    rotor = machine.rotor
    f, phi = rotor.undamped_modes()
    band = case.max_frequency_hz
    raw = case.raw
    z = raw["rotor"]["node_positions_m"]
    pos = rotor.shaft_node_positions_m
    housing = {int(h["node"]): h["name"] for h in raw["housings"]}
    what = {int(raw["bearings"][b]["rotor_node"]): f"{b.upper()} bearing" for b in BEARINGS}
    for d in raw["rotor"]["disks"]:
        what.setdefault(int(d["node"]), d["name"])
    nodes = list(rotor.node_labels)
    energy = phi * (rotor.M @ phi)                        # kinetic energy of each DOF in each mode (columns)
    out = []
    for k in np.flatnonzero(f < band):
        node_energy = np.array([energy[rotor.node_dofs(n), k].sum() for n in nodes])
        n_max = nodes[int(np.argmax(node_energy))]
        if n_max in housing:
            where = f"{housing[n_max].upper()} housing"
        else:
            where = what.get(n_max, "shaft") + f" (z = {pos[n_max] + z[0]:.3f} m)"
        share = float(sum(node_energy[i] for i, n in enumerate(nodes) if n in housing) / node_energy.sum())
        out.append({"frequency_hz": float(f[k]), "most_energy_at": where, "housing_energy": share,
                    "in_speed_range": bool(lo <= f[k] <= hi)})
    crit = [e for e in out if e["in_speed_range"]]
    if crit:
        notes.append(f"{len(crit)} mode(s) inside the speed range {lo:g}-{hi:g} Hz (critical speeds the 1x "
                     f"unbalance excites): " + ", ".join(f"{e['frequency_hz']:.1f} Hz ({e['most_energy_at']})"
                                                        for e in crit))
    return out


def _plausibility(case: Case, machine: Machine, notes: list) -> dict:
    raw = case.raw
    lo, hi, why = plausibility.bound(raw, "rotor.fe_elements")
    n = mesh_elements(raw, case.max_frequency_hz, float(raw["rotor"]["elements_per_wavelength"]))
    widened = sorted(raw.get(plausibility.SECTION, {}))
    if widened:
        notes.append(f"the case widens {len(widened)} plausibility bound(s): {', '.join(widened)}")
    return {"within_bounds": True, "fe_elements": {"elements": n, "bound": [lo, hi], "why": why},
            "widened_bounds": widened}
