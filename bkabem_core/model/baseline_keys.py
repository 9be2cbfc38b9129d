"""The keys of a case's ``[baseline]`` section (what every real motor has besides its bearings) and their rules.

The physics of each key, its unit and its source are in :mod:`bkabem_core.excitation.baseline` and
docs/faults.md; this module says which keys exist, which a case may leave out (default 0 = off, so that cases
written before them stay valid), and the rules that tie keys together (:func:`baseline_problem`).

Units: SI, each key with its unit as a suffix (``_n``, ``_deg``, ``_hz``, ``_mm_s``).
"""

from __future__ import annotations

__all__ = ["BASELINE_KEYS", "BASELINE_OPTIONAL", "BASELINE_OFF", "baseline_problem"]

_POS = ("gt", 0.0)
_NONNEG = ("ge", 0.0)
_ANGLE = ("range", -360.0, 360.0)

#: key -> (kind, check) as in the case schema.
BASELINE_KEYS: dict[str, tuple] = {
    "unbalance_grade_mm_s": ("float", _NONNEG),
    "unbalance_phase_deg": ("float", _ANGLE),
    "misalignment_force_n": ("float", _NONNEG),
    "misalignment_node": ("int", ("ge", 1)),
    "electrical_force_n": ("float", _NONNEG),
    "line_frequency_hz": ("float", _POS),
    "broadband_force_n_per_sqrt_hz": ("float", _NONNEG),
    "coupling_force_n": ("float", _NONNEG),
    "coupling_phase_deg": ("float", _ANGLE),
    "electrical_harmonics": ("float[]", ("range", 1.0, 1000.0)),
    "electrical_harmonic_forces_n": ("float[]", _NONNEG),
    "looseness_force_n": ("float", _NONNEG),
    "looseness_orders": ("int", ("range", 1, 200)),
}
#: keys a case may leave out (default: 0 = off, no harmonics)
BASELINE_OPTIONAL = ("broadband_force_n_per_sqrt_hz", "coupling_force_n", "coupling_phase_deg",
                     "electrical_harmonics", "electrical_harmonic_forces_n", "looseness_force_n", "looseness_orders")
#: [baseline] of a migrated older case: nothing but the bearings (what those versions computed)
BASELINE_OFF = {"unbalance_grade_mm_s": 0.0, "unbalance_phase_deg": 0.0, "misalignment_force_n": 0.0,
                "misalignment_node": 1, "electrical_force_n": 0.0, "line_frequency_hz": 50.0}


def baseline_problem(raw: dict) -> tuple[str, str] | None:
    """The first rule the ``[baseline]`` of a schema-valid case ``raw`` breaks, as ``("baseline.<key>", reason)``,
    or None.

    The coupling force turns a load in the bearings: the quasi-static bearing model carries it and the 4-DOF model
    does not.
    """
    baseline = raw["baseline"]
    if baseline.get("coupling_force_n", 0.0) > 0.0:
        if raw["excitation"]["method"] == "four_dof":
            return ("baseline.coupling_force_n", "the load it turns in the bearings needs excitation.method = "
                    "'quasi_static' ('four_dof' has no load that turns with the shaft)")
    harmonics, forces = baseline.get("electrical_harmonics", []), baseline.get("electrical_harmonic_forces_n", [])
    if len(harmonics) != len(forces):
        return ("baseline.electrical_harmonic_forces_n", f"must have one force per electrical harmonic "
                f"({len(harmonics)} harmonics, {len(forces)} forces)")
    for h in harmonics:
        if h != int(h) or int(h) % 2 or h < 4:
            return ("baseline.electrical_harmonics", f"must be even multiples of the line frequency above 2 (a "
                    f"magnetic force goes with the square of the flux; 2 x is electrical_force_n; got {h:g})")
    if len(set(harmonics)) != len(harmonics):
        return ("baseline.electrical_harmonics", f"each multiple once (got {harmonics})")
    if baseline.get("looseness_force_n", 0.0) > 0.0 and "looseness_orders" not in baseline:
        return ("baseline.looseness_orders", "missing (how many shaft harmonics the looseness force has, needed when "
                "looseness_force_n > 0)")
    return None
