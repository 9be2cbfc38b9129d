"""Physical plausibility of case values, and the limits that keep a case computable in bounded time and memory.

The schema (``bkabem_core.model.case``) checks types and signs; this module checks that a value is one a real machine
can have, so that a unit slip is caught before it gives a plausible-looking but wrong result (a diameter in mm
written as m, a speed in rpm written as Hz, a stiffness of 1e30, a dent 1e300 m deep), or a value the models
cannot compute with (a zero gravity leaves the bearing unloaded; 1e-300 kg has no equilibrium; 1e9 s of settling
never ends; 1e9 samples per ball pass do not fit in memory).

:data:`BOUNDS` maps ``"section.key"`` to ``(low, high, why)`` (inclusive, SI units as the key says). Keys of
tables in arrays are written ``housings[].mass_kg``, ``rotor.disks[].mass_kg``, ``bearings.*.n_balls`` (every
element is checked and named, e.g. ``rotor.disks[3].mass_kg``, ``bearings.nde.n_balls``: each position's bearing
has its own bounds, checked on the values the model uses, the catalogue's included); an array value (``rotor.outer_diameters_m``)
is checked element by element. Bounds of keys a case does not have are skipped (the schema decides what exists).

Computing limits (:func:`cost_problem`), two derived quantities with bounds of their own: the 4-DOF integration
covers the settling time and the recorded cage periods, about 35 ms of computing per ball pass on the project
machine: ``excitation.ball_passes`` = settle_time_s x BPFO at the reference speed + record_cage_periods x n_balls,
at most 5000 (~3 min); it records ``excitation.recorded_samples`` = record_cage_periods x n_balls x
samples_per_ball_pass samples of 8 states, at most 2^22 (~270 MB). An inner-race or ball defect is solved on a 2-torus of
``excitation.torus_samples`` = samples_per_ball_pass x max(32, the power of 2 >= 4 n_balls) cage and shaft angles,
about 1 kB each while it is solved: at most 2^19 (~500 MB). ``excitation.max_order`` can be at most half of
``samples_per_ball_pass`` (the highest order a ball pitch of that many samples resolves).

The FE model's limits are checked where it is made, before anything is allocated
(:mod:`bkabem_core.fe.budget`): ``rotor.fe_elements``, the elements of the mesh at the model's highest frequency
(each a few ms of eigen-decomposition at the limit, every one a step shorter than a second), and
``model.line_modes``, lines x (reduced-model size)^3, the cost of the eigen-decompositions along every line.

Speed limits (:func:`speed_problem`): ``operating.max_speed_hz`` is at most each position's bearing's limiting speed
(``bearings.*.limiting_speed_ratio``, max_speed_hz / the limiting speed, at most 1), the mechanical limit a maker
prints for a bearing (:func:`bearing_limiting_speed`): the catalogue row's (:mod:`bkabem_core.model.catalogue`);
for a sealed or shielded variant, whose own speeds the catalogue leaves unknown, the open bearing's (an upper bound:
seals and shields lower it); for a bearing without a catalogue speed (one the catalogue does not have, a rig row
without published speeds) an estimate, the catalogue's highest ``n dm`` (speed x pitch diameter) over its open 60,
62 and 63 series rows (SKF 2017: 7.6e5 mm r/min, the 6001) divided by the bearing's pitch diameter: no bearing of
that size in the catalogue is allowed less, and a speed in rpm written as Hz (60 times too fast) is still caught.
Every speed a run asks for (``bkabem synth``, scenarios, data sets) is at most ``operating.max_speed_hz``, so at
most the lower of the two bearings' limits; the node checks each speed message against :func:`max_speed_bound`.

**Override.** A case that really is outside a bound says so explicitly, in a ``[plausibility]`` table of the case
file, with new bounds for that key::

    [plausibility]
    "rotor.density_kg_m3" = [500.0, 40000.0]      # tungsten-loaded rotor
    "excitation.settle_time_s" = [0.0, 60.0]

An override key that is not in :data:`BOUNDS` is an error (a typo must not switch a check off silently).
"""

from __future__ import annotations

import functools
import math

from bkabem_core.model.catalogue import SEAL_SUFFIXES, CatalogueError, designations, lookup

SECTION = "plausibility"

_UNIT_SLIP = " (a unit slip? SI units, as the key's suffix says)"
#: Bounds that limit computing rather than physics: no unit-slip hint.
_COMPUTING = frozenset({"bearings.*.axial_load_ratio", "excitation.settle_time_s", "excitation.record_cage_periods",
                        "excitation.samples_per_ball_pass", "excitation.atol_m", "excitation.rtol", "excitation.ball_passes",
                        "excitation.recorded_samples", "excitation.torus_samples", "rotor.fe_elements",
                        "model.line_modes"})

_SUPPORT_STIFFNESS = (1e3, 1e11, "supports are 1e3 .. 1e11 N/m")
_SUPPORT_DAMPING = (0.0, 1e8, "support damping is 0 .. 1e8 N s/m")
_BEARING_STIFFNESS = (1e5, 1e11, "ball bearing stiffnesses are 1e5 .. 1e11 N/m")
_BEARING_DAMPING = (0.0, 1e7, "bearing damping is 0 .. 1e7 N s/m")
_HOUSING_MASS = (1e-2, 1e5, "housings weigh 10 g .. 100 t")
_DISK_INERTIA = (0.0, 1e5, "disk inertias are 0 .. 1e5 kg m^2")

#: "section.key" -> (low, high, why): inclusive physical bounds.
BOUNDS: dict[str, tuple[float, float, str]] = {
    # each position's bearing: geometry and material (deep-groove ball bearings from miniature to slewing sizes)
    "bearings.*.bore_diameter_m": (1e-3, 2.0, "ball bearing bores are 1 mm .. 2 m"),
    "bearings.*.outer_diameter_m": (2e-3, 3.0, "ball bearing outer diameters are 2 mm .. 3 m"),
    "bearings.*.pitch_diameter_m": (1.5e-3, 2.5, "ball bearing pitch diameters are 1.5 mm .. 2.5 m"),
    "bearings.*.ball_diameter_m": (0.3e-3, 0.3, "rolling balls are 0.3 mm .. 300 mm"),
    "bearings.*.n_balls": (3, 200, "3 .. 200 balls"),
    "bearings.*.diametral_clearance_m": (0.0, 1e-3, "diametral clearances are 0 .. 1 mm (C5 of large bearings ~0.3 mm)"),
    "bearings.*.inner_conformity": (0.5, 0.7, "groove radius / ball diameter is 0.5 .. 0.7 (typically 0.51-0.54)"),
    "bearings.*.outer_conformity": (0.5, 0.7, "groove radius / ball diameter is 0.5 .. 0.7 (typically 0.51-0.54)"),
    "bearings.*.static_load_rating_n": (10.0, 1e8, "static load ratings are 10 N .. 100 MN"),
    "bearings.*.youngs_modulus_pa": (1e9, 1e12, "bearing materials are 1 GPa (polymers) .. 1 TPa (ceramics ~0.3 TPa)"),
    "bearings.*.pressure_viscosity_m2_n": (0.0, 1e-7, "pressure-viscosity coefficients are 0 .. 1e-7 m^2/N "
                                                   "(mineral oils ~2e-8)"),
    "bearings.*.dynamic_viscosity_pa_s": (0.0, 10.0, "lubricant viscosities are 0 .. 10 Pa s"),
    "bearings.*.damping_n_s_m": _BEARING_DAMPING,
    # the defects (schema 3; a schema-2 [dent] is migrated to the first entry)
    "defects[].length_m": (1e-6, 0.1, "dents are 1 um .. 100 mm long"),
    "defects[].depth_m": (0.0, 1e-3, "dents are 0 .. 1 mm deep"),
    # the machine baseline
    "baseline.unbalance_grade_mm_s": (0.0, 4000.0, "ISO 21940-11 balance grades are G 0.4 .. G 4000 mm/s (0 = off; "
                                                   "electric motors G 2.5-6.3)"),
    "baseline.misalignment_force_n": (0.0, 1e6, "misalignment forces are 0 .. 1 MN"),
    "baseline.coupling_force_n": (0.0, 1e6, "coupling forces are 0 .. 1 MN"),
    "baseline.electrical_harmonic_forces_n": (0.0, 1e6, "magnetic forces are 0 .. 1 MN"),
    "baseline.looseness_force_n": (0.0, 1e5, "the knock of a loose fit is 0 .. 100 kN per harmonic"),
    "baseline.electrical_force_n": (0.0, 1e6, "magnetic pull forces are 0 .. 1 MN"),
    "baseline.broadband_force_n_per_sqrt_hz": (0.0, 100.0, "broadband bearing forces are 0 .. 100 N/sqrt(Hz) "
                                                          "(roughness of a new bearing: ~0.01-0.05; docs/faults.md)"),
    "baseline.line_frequency_hz": (1.0, 1000.0, "supply frequencies are 1 .. 1000 Hz (grids 50/60 Hz, drives up "
                                                "to a few hundred)"),
    # the 4-DOF excitation model
    "excitation.rotor_mass_kg": (1e-2, 1e5, "rotors weigh 10 g .. 100 t"),
    "excitation.housing_mass_kg": _HOUSING_MASS,
    "excitation.support_stiffness_n_m": _SUPPORT_STIFFNESS,
    "excitation.support_damping_n_s_m": _SUPPORT_DAMPING,
    "excitation.gravity_m_s2": (1.0, 100.0, "the 4-DOF model is loaded by the rotor's weight: 1 .. 100 m/s^2 "
                                            "(0 leaves the bearing unloaded, without an equilibrium)"),
    "excitation.reference_speed_hz": (0.1, 1000.0, "the 4-DOF reference speed is 0.1 .. 1000 Hz (its integration "
                                                   "time grows as 1 / speed)"),
    "excitation.settle_time_s": (0.0, 60.0, "settling is integrated: 0 .. 60 s (and at most excitation.ball_passes)"),
    "excitation.record_cage_periods": (1, 64, "1 .. 64 cage periods are recorded for the FFT"),
    "excitation.samples_per_ball_pass": (64, 65536, "64 .. 65536 samples per ball pass (orders up to half of it)"),
    "excitation.atol_m": (1e-18, 1e-6, "absolute tolerances on displacements are 1e-18 .. 1e-6 m"),
    "excitation.rtol": (1e-12, 1e-2, "relative tolerances are 1e-12 .. 1e-2 (the integrator raises a smaller one "
                                     "to what double precision can meet)"),
    # derived: the cost of the 4-DOF integration (cost_problem)
    "excitation.ball_passes": (0.0, 5000.0, "ball passes to integrate (~35 ms each: 5000 is ~3 min)"),
    "excitation.recorded_samples": (0.0, float(1 << 22), "recorded samples of 8 states (2^22 is ~270 MB)"),
    # derived: the quasi-static 2-torus of inner-race and ball defects (cost_problem)
    "excitation.torus_samples": (0.0, float(1 << 19), "angles of the defect's 2-torus, ~1 kB each while solved "
                                                      "(2^19 is ~500 MB)"),
    # derived: the FE model's size and cost (bkabem_core.fe.budget, checked before the model is made)
    "rotor.fe_elements": (1.0, 256.0, "FE elements of the mesh; at 256 (~1000 DOF) each dense eigen-decomposition "
                                      "takes a fraction of a second and the preparation ~5-30 s"),
    "model.line_modes": (0.0, 3e9, "lines x (reduced-model size)^3, the eigen-decompositions along every line "
                                   "(3e9 is ~1 min on two cores)"),
    # FE bearing and support elements
    "bearings.*.axial_load_n": (0.0, 1e7, "axial bearing loads are 0 .. 10 MN"),
    "bearings.*.applied_radial_load_n": (0.0, 1e7, "radial loads applied at a bearing are 0 .. 10 MN"),
    # derived: applied radial load / the position's static_load_rating_n (above C0 the races dent permanently)
    "bearings.*.applied_radial_load_ratio": (0.0, 1.0, "the applied radial load is at most the bearing's static "
                                                       "load rating static_load_rating_n"),
    # derived: axial load / the position's static_load_rating_n (deep-groove ball bearings carry ~0.5 C0 axially)
    "bearings.*.axial_load_ratio": (0.0, 1.0, "the axial load is at most the bearing's static load rating "
                                              "static_load_rating_n"),
    # derived: operating.max_speed_hz / the position's bearing's limiting speed (speed_problem)
    "bearings.*.limiting_speed_ratio": (0.0, 1.0, "a bearing runs at most at its limiting speed (the maker's "
                                                  "mechanical limit; seals and shields lower it)"),
    "bearings.*.table_stiffness_vertical_n_m": _BEARING_STIFFNESS,
    "bearings.*.table_stiffness_horizontal_n_m": _BEARING_STIFFNESS,
    "bearings.*.table_damping_vertical_n_s_m": _BEARING_DAMPING,
    "bearings.*.table_damping_horizontal_n_s_m": _BEARING_DAMPING,
    "housings[].mass_kg": _HOUSING_MASS,
    "housings[].support_stiffness_vertical_n_m": _SUPPORT_STIFFNESS,
    "housings[].support_stiffness_horizontal_n_m": _SUPPORT_STIFFNESS,
    "housings[].support_damping_vertical_n_s_m": _SUPPORT_DAMPING,
    "housings[].support_damping_horizontal_n_s_m": _SUPPORT_DAMPING,
    # the FE rotor
    "rotor.youngs_modulus_pa": (1e9, 1e12, "shaft materials are 1 GPa .. 1 TPa (steel 206 GPa)"),
    "rotor.density_kg_m3": (500.0, 25000.0, "shaft materials are 500 .. 25000 kg/m^3 (steel 7850)"),
    "rotor.damping_reference_hz": (0.1, 1e5, "damping reference frequencies are 0.1 Hz .. 100 kHz"),
    "rotor.node_positions_m": (-20.0, 20.0, "shaft nodes lie within 20 m"),
    "rotor.outer_diameters_m": (1e-3, 2.0, "shaft diameters are 1 mm .. 2 m"),
    "rotor.inner_diameters_m": (0.0, 2.0, "bore diameters are 0 .. 2 m"),
    "rotor.disks[].mass_kg": (1e-6, 1e5, "disks weigh 1 mg .. 100 t"),
    "rotor.disks[].polar_inertia_kg_m2": _DISK_INERTIA,
    "rotor.disks[].diametral_inertia_kg_m2": _DISK_INERTIA,
    # operation
    "operating.max_speed_hz": (0.1, 2000.0, "shaft speeds are 0.1 .. 2000 Hz (120 000 rpm; a speed in rpm "
                                            "written as Hz?)"),
    "operating.max_sample_rate_hz": (100.0, 1e6, "sensor sample rates are 100 Hz .. 1 MHz (the FE mesh is refined "
                                                 "up to the frequency it needs)"),
}


def bound(raw: dict, key: str) -> tuple[float, float, str]:
    """``(low, high, why)`` of ``key`` in :data:`BOUNDS`, or as the case's ``[plausibility]`` table widens it (a bad
    override table is reported by :func:`problem` when the case is loaded)."""
    return _bounds_with_overrides(raw)[0][key]


def override_hint(key: str) -> str:
    """How a case widens the bound of ``key``."""
    return f'widen it in the case: [{SECTION}] "{key}" = [low, high]'


def _bounds_with_overrides(raw: dict) -> tuple[dict, tuple[str, str] | None]:
    bounds = dict(BOUNDS)
    ov = raw.get(SECTION)
    if ov is None:
        return bounds, None
    if not isinstance(ov, dict):
        return bounds, (SECTION, 'must be a table of "section.key" = [low, high]')
    for key, value in ov.items():
        name = f'{SECTION}."{key}"'
        if key not in BOUNDS:
            return bounds, (name, f"no plausibility bound of that name (known: {', '.join(sorted(BOUNDS))})")
        ok = (isinstance(value, list) and len(value) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
              and value[0] <= value[1])
        if not ok:
            return bounds, (name, f"must be [low, high] with finite low <= high (got {value!r})")
        bounds[key] = (float(value[0]), float(value[1]), f"overridden in the case's [{SECTION}] table")
    return bounds, None


def _values(raw: dict, dotted: str):
    """(concrete key, value) for every occurrence of a bound's key in the case; none when it does not exist."""
    section, _, key = dotted.rpartition(".")
    if section.endswith("[]"):                        # housings[], rotor.disks[]
        path = section[:-2].split(".")
        node = raw
        for p in path:
            node = node.get(p) if isinstance(node, dict) else None
        if isinstance(node, list):
            for i, item in enumerate(node):
                if isinstance(item, dict) and key in item:
                    yield f"{section[:-2]}[{i}].{key}", item[key]
        return
    if section.endswith(".*"):                        # bearings.*
        node = raw.get(section[:-2])
        if isinstance(node, dict):
            for name, item in node.items():
                if isinstance(item, dict) and key in item:
                    yield f"{section[:-2]}.{name}.{key}", item[key]
        return
    node = raw.get(section)
    if isinstance(node, dict) and key in node:
        yield dotted, node[key]


def _fmt(v: float) -> str:
    return f"{v:g}"


def problem(raw: dict) -> tuple[str, str] | None:
    """The first implausible value of a schema-valid case as ``(key, reason)``, or None."""
    bounds, bad = _bounds_with_overrides(raw)
    if bad is not None:
        return bad
    for dotted, (lo, hi, why) in bounds.items():
        for key, value in _values(raw, dotted):
            for v in (value if isinstance(value, list) else [value]):
                if isinstance(v, bool) or not isinstance(v, (int, float)):
                    continue                          # the schema reports types
                if not lo <= v <= hi:
                    return key, (f"{v!r} is outside [{_fmt(lo)}, {_fmt(hi)}]: {why}"
                                 + (_UNIT_SLIP if "overridden" not in why and dotted not in _COMPUTING else "")
                                 + f'; if it is right, widen it in the case: [{SECTION}] "{dotted}" = [low, high]')
    return relation_problem(raw, bounds) or speed_problem(raw, bounds) or cost_problem(raw, bounds)


def relation_problem(raw: dict, bounds: dict | None = None) -> tuple[str, str] | None:
    """Bounds on ratios of two keys (``bearings.*.axial_load_ratio`` and ``applied_radial_load_ratio``: each
    position's axial and applied radial load over its own bearing's static load rating), or None (also when a key
    does not exist)."""
    bounds = BOUNDS if bounds is None else bounds
    brg = raw.get("bearings")
    for name, table in (brg.items() if isinstance(brg, dict) else ()):
        if not isinstance(table, dict):
            continue
        for key, ratio in (("axial_load_n", "axial_load_ratio"),
                           ("applied_radial_load_n", "applied_radial_load_ratio")):
            lo, hi, why = bounds[f"bearings.*.{ratio}"]
            c0, f = table.get("static_load_rating_n"), table.get(key)
            if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (c0, f)) or not c0 > 0:
                continue
            if not lo <= f / c0 <= hi:
                return f"bearings.{name}.{key}", (
                    f"{f!r} N is {f / c0:.3g} x bearings.{name}.static_load_rating_n ({c0:g} N), outside "
                    f"[{_fmt(lo)}, {_fmt(hi)}]: {why}{_UNIT_SLIP}; if it is right, widen it in the case: "
                    f'[{SECTION}] "bearings.*.{ratio}" = [low, high]')
    return None


@functools.cache
def _n_dm_envelope() -> tuple[float, str]:
    """The highest ``n dm`` [m r/min] (limiting speed x pitch diameter) of the catalogue's open series rows, and the
    row that has it."""
    rows = [lookup(k) for k in designations()]
    best = max((r for r in rows if r.description.endswith(" series") and math.isfinite(r.limiting_speed_rpm)),
               key=lambda r: r.limiting_speed_rpm * r.pitch_diameter_m)
    return best.limiting_speed_rpm * best.pitch_diameter_m, best.catalogue_key


def bearing_limiting_speed(table: dict) -> tuple[float, str] | None:
    """The limiting speed [Hz] of a position's bearing (a resolved table: ``designation``, ``pitch_diameter_m``)
    and where it comes from, for people; None when neither the catalogue nor the pitch diameter gives one.

    The catalogue row's limiting speed; the open bearing's for a sealed or shielded variant (an upper bound);
    otherwise the estimate of the module docstring (the catalogue's highest ``n dm`` / the pitch diameter).
    """
    designation = table.get("designation")
    try:
        row = lookup(designation)
    except CatalogueError:
        row = None
    if row is not None and math.isfinite(row.limiting_speed_rpm):
        return row.limiting_speed_rpm / 60.0, f"{row.catalogue_key}: {row.limiting_speed_rpm:g} r/min, the catalogue's"
    if row is not None and any(s in SEAL_SUFFIXES for s in row.suffixes):
        open_row = lookup(row.catalogue_key)
        if math.isfinite(open_row.limiting_speed_rpm):
            return open_row.limiting_speed_rpm / 60.0, (
                f"{row.designation}: {open_row.limiting_speed_rpm:g} r/min, the open {open_row.catalogue_key}'s (seals "
                f"and shields lower it)")
    pd = table.get("pitch_diameter_m")
    if isinstance(pd, bool) or not isinstance(pd, (int, float)) or not (math.isfinite(pd) and pd > 0):
        return None
    n_dm, key = _n_dm_envelope()
    rpm = n_dm / pd
    return rpm / 60.0, (f"{designation}: {rpm:.0f} r/min, estimated as the catalogue's highest n dm "
                        f"({n_dm * 1e3:.3g} mm r/min, {key}) / its pitch diameter {pd * 1e3:g} mm")


def _speed_limits(raw: dict, bounds: dict):
    """(ratio low, ratio high, why) and each position's (name, limiting speed [Hz], source)."""
    lo, hi, why = bounds["bearings.*.limiting_speed_ratio"]
    brg = raw.get("bearings")
    out = []
    for name, table in (brg.items() if isinstance(brg, dict) else ()):
        lim = bearing_limiting_speed(table) if isinstance(table, dict) else None
        if lim is not None:
            out.append((name, *lim))
    return (lo, hi, why), out


def max_speed_bound(raw: dict) -> tuple[float, str] | None:
    """The highest shaft speed [Hz] the case's bearings allow (the lowest limiting speed x the upper bound of
    ``bearings.*.limiting_speed_ratio``, as the case's ``[plausibility]`` table sets it) and which bearing sets it,
    for people; None when no bearing has a limiting speed. ``raw``: a case's resolved table (``Case.resolved``)."""
    (_lo, hi, _why), limits = _speed_limits(raw, _bounds_with_overrides(raw)[0])
    if not limits:
        return None
    name, hz, src = min(limits, key=lambda x: x[1])
    return hi * hz, f"bearings.{name} ({src}) x {_fmt(hi)}, the upper bound of bearings.*.limiting_speed_ratio"


def speed_problem(raw: dict, bounds: dict | None = None) -> tuple[str, str] | None:
    """``operating.max_speed_hz`` against each position's bearing's limiting speed (``bearings.*.limiting_speed_ratio``,
    module docstring), the lower limit first; None when fine or a key does not exist."""
    bounds = BOUNDS if bounds is None else bounds
    op = raw.get("operating")
    f = op.get("max_speed_hz") if isinstance(op, dict) else None
    if isinstance(f, bool) or not isinstance(f, (int, float)):
        return None
    (lo, hi, why), limits = _speed_limits(raw, bounds)
    for name, hz, src in sorted(limits, key=lambda x: x[1]):
        if not lo <= f / hz <= hi:
            slip = " (a unit slip? a speed in r/min written as Hz?)" if "overridden" not in why else ""
            return "operating.max_speed_hz", (
                f"{f!r} Hz ({f * 60.0:g} r/min) is {f / hz:.3g} x the limiting speed of bearings.{name}, {hz:.4g} Hz "
                f"({src}), outside [{_fmt(lo)}, {_fmt(hi)}]: {why}{slip}; if it is right, "
                + override_hint("bearings.*.limiting_speed_ratio"))
    return None


def cost_problem(raw: dict, bounds: dict | None = None) -> tuple[str, str] | None:
    """The 4-DOF computing limits (``excitation.ball_passes``, ``excitation.recorded_samples``; see the module
    docstring) for the bearing of each position, or None (also when the keys they are made of do not exist)."""
    bounds = BOUNDS if bounds is None else bounds
    try:
        e = raw["excitation"]
        f_ref = float(e["reference_speed_hz"])
        settle, periods, per_pass = float(e["settle_time_s"]), int(e["record_cage_periods"]), \
            int(e["samples_per_ball_pass"])
        sets = []
        for b in raw["bearings"].values():
            d, pd, z = float(b["ball_diameter_m"]), float(b["pitch_diameter_m"]), int(b["n_balls"])
            sets.append((d, pd, z, math.radians(float(b["contact_angle_deg"]))))
    except (KeyError, TypeError, ValueError, AttributeError):
        return None
    override = f'widen it in the case: [{SECTION}] "%s" = [low, high]'
    max_order = e.get("max_order")
    if isinstance(max_order, int) and not isinstance(max_order, bool) and max_order > per_pass // 2:
        return ("excitation.max_order",
                f"{max_order} is more than the {per_pass // 2} orders excitation.samples_per_ball_pass = {per_pass} "
                f"resolves (half of it); 0 keeps every resolved order")
    kinds = {dd.get("race") for dd in raw.get("defects", []) if isinstance(dd, dict)}
    for d, pd, z, alpha in sets:
        n_rec = periods * z * per_pass
        lo, hi, why = bounds["excitation.recorded_samples"]
        if not lo <= n_rec <= hi:
            return ("excitation.samples_per_ball_pass",
                    f"record_cage_periods x n_balls x samples_per_ball_pass = {periods} x {z} x {per_pass} = "
                    f"{n_rec} recorded samples, more than {_fmt(hi)}: {why}; "
                    + override % "excitation.recorded_samples")
        if kinds & {"inner", "ball"}:
            slow = max(32, 1 << math.ceil(math.log2(4 * z)))
            n_torus = per_pass * slow
            lo, hi, why = bounds["excitation.torus_samples"]
            if not lo <= n_torus <= hi:
                return ("excitation.samples_per_ball_pass",
                        f"an inner-race or ball defect is solved on samples_per_ball_pass x {slow} = {per_pass} x "
                        f"{slow} = {n_torus} angles, more than {_fmt(hi)}: {why}; "
                        + override % "excitation.torus_samples")
        f_bp = z * 0.5 * (1.0 - d / pd * math.cos(alpha)) * f_ref
        passes = settle * f_bp + periods * z
        lo, hi, why = bounds["excitation.ball_passes"]
        if not lo <= passes <= hi:
            return ("excitation.settle_time_s",
                    f"settle_time_s {settle:g} s at reference_speed_hz {f_ref:g} Hz + {periods} cage period(s) = "
                    f"{passes:.0f} ball passes to integrate, more than {_fmt(hi)}: {why}; "
                    + override % "excitation.ball_passes")
    return None
