"""Case files: TOML with every parameter of a machine, validated key by key.

A case describes one machine: the bearing at each position (``[bearings.de]``, ``[bearings.nde]``: its type by
catalogue designation with any number overridden, and its FE element; :mod:`bkabem_core.model.positions`), the
defects, the baseline, the excitation model, the FE rotor with its housings, and the operating range. The embedded default ``electric_motor_6010`` ships in
``bkabem_core/embedded/cases/``; user cases are loaded by path. Every key carries its unit as a suffix.

Validation is strict and explains itself: a missing key, an unknown key, a wrong type or a value outside its
physical range raises :class:`CaseError` naming the key (``section.key``) and the reason. Nothing is clamped.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from bkabem_core.bearing.deep_groove import Bearing, BearingGeometry, Dent, FaultFrequencies
from bkabem_core.bearing.defects.profiles import EDGE_PROFILES, SHAPES
from bkabem_core.bearing.defects.registry import KINDS, kind, kinds_with, moving_kinds, own_keys, periodic_kinds
from bkabem_core.model import plausibility
from bkabem_core.model.baseline_keys import BASELINE_KEYS, BASELINE_OFF, BASELINE_OPTIONAL, baseline_problem
from bkabem_core.model.compact import machine_case
from bkabem_core.model.files import InputFileError, embedded_names, parse_toml, read_input_text
from bkabem_core.model.load_table import LOAD_KEYS, load_table_problem, speed_at_load_hz
from bkabem_core.model.measurement_keys import MEASUREMENT_KEYS, measurement_problem
from bkabem_core.model.positions import (
    BEARING_KEYS,
    OPTIONAL,
    BearingTableError,
    geometry_of,
    migrate_shared,
    resolve,
)
from bkabem_core.model.vocabulary import BEARINGS

DEFAULT_CASE = "electric_motor_6010"
#: Version of the case format this code reads; older files are migrated (:func:`migrate_v1`, :func:`migrate_v2`,
#: :func:`migrate_v3`).
SCHEMA_VERSION = 4


class CaseError(InputFileError):
    """A case file is invalid. ``key`` is the dotted key at fault (or the file)."""


# --------------------------------------------------------------------------- schema
# Each entry: key -> (kind, check). kind in {"float", "int", "bool", "str", "float[]"}.
# check: None or a tuple ("gt", x) / ("ge", x) / ("range_open", lo, hi) / ("in", {...}) / ("range", lo, hi).
_POS = ("gt", 0.0)
_NONNEG = ("ge", 0.0)

SCHEMA: dict[str, dict[str, tuple]] = {
    "case": {
        "name": ("str", None),
        "description": ("str", None),
        "schema_version": ("int", ("in", {SCHEMA_VERSION})),
    },
    "defects[]": {
        "bearing": ("str", ("in", {"de", "nde"})),
        "race": ("str", ("in", set(KINDS))),
        "length_m": ("float", _POS),
        "depth_m": ("float", _NONNEG),
        "angle_deg": ("float", ("range", -360.0, 360.0)),
        "edge": ("str", ("in", set(EDGE_PROFILES))),
        "edge_fraction": ("float", ("range", 0.0, 1.0)),    # optional: edge = "cubic" only
        **{k.name: k.schema for k in own_keys()},           # the keys only some kinds have (a ball defect's ball)
        "shape": ("str", ("in", set(SHAPES))), "clock": ("int", ("range", 1, 12)),  # optional (docs/faults.md 3a)
    },
    "baseline": BASELINE_KEYS,
    "excitation": {
        "method": ("str", ("in", {"quasi_static", "four_dof"})),
        "load": ("str", ("in", {"fe_share", "rotor_weight"})),
        "bearings": ("str", ("in", {"all", "faulty"})),
        "force": ("str", ("in", {"spring", "paper"})),
        "rotor_mass_kg": ("float", _POS),
        "housing_mass_kg": ("float", _POS),
        "support_stiffness_n_m": ("float", _POS),
        "support_damping_n_s_m": ("float", _NONNEG),
        "gravity_m_s2": ("float", _POS),
        "reference_speed_hz": ("float", _POS),
        "settle_time_s": ("float", _NONNEG),
        "record_cage_periods": ("int", ("ge", 1)),
        "samples_per_ball_pass": ("int", ("ge", 64)),
        "rtol": ("float", ("range_open", 0.0, 1e-2)),
        "atol_m": ("float", _POS),
        "relative_amplitude_threshold": ("float", ("range", 0.0, 1.0)),
        "max_order": ("int", ("ge", 0)),
    },
    "bearings.*": {
        **BEARING_KEYS,                        # the bearing type of the position (model/positions.py)
        "rotor_node": ("int", ("ge", 1)),
        "housing_node": ("int", ("ge", 1)),
        "axial_load_n": ("float", _NONNEG),
        "applied_radial_load_n": ("float", _NONNEG),   # a loader's radial load at the bearing (optional; 0)
        "linearisation": ("str", ("in", {"model", "table"})),
        "table_stiffness_vertical_n_m": ("float", _POS),
        "table_stiffness_horizontal_n_m": ("float", _POS),
        "table_damping_vertical_n_s_m": ("float", _NONNEG),
        "table_damping_horizontal_n_s_m": ("float", _NONNEG),
    },
    "housings[]": {
        "name": ("str", ("in", {"de", "nde"})),
        "node": ("int", ("ge", 1)),
        "mass_kg": ("float", _POS),
        "support_stiffness_vertical_n_m": ("float", _POS),
        "support_stiffness_horizontal_n_m": ("float", _POS),
        "support_damping_vertical_n_s_m": ("float", _NONNEG),
        "support_damping_horizontal_n_s_m": ("float", _NONNEG),
    },
    "rotor": {
        "youngs_modulus_pa": ("float", _POS),
        "poisson_ratio": ("float", ("range_open", 0.0, 0.5)),
        "density_kg_m3": ("float", _POS),
        "shear_effects": ("bool", None),
        "rotary_inertia": ("bool", None),
        "gyroscopic": ("bool", None),
        "damping_model": ("str", ("in", {"stiffness", "modal", "none"})),
        "damping_ratio": ("float", ("range", 0.0, 0.5)),
        "damping_reference_hz": ("float", _POS),
        "elements_per_wavelength": ("float", ("range", 0.0, 64.0)),
        "node_positions_m": ("float[]", None),
        "outer_diameters_m": ("float[]", _POS),
        "inner_diameters_m": ("float[]", _NONNEG),
        "disks": ("table[]", None),
    },
    "rotor.disks[]": {
        "name": ("str", None),
        "node": ("int", ("ge", 1)),
        "mass_kg": ("float", _POS),
        "polar_inertia_kg_m2": ("float", _NONNEG),
        "diametral_inertia_kg_m2": ("float", _NONNEG),
    },
    "operating": {
        "max_speed_hz": ("float", _POS),
        "max_sample_rate_hz": ("float", _POS),
        "load_hp": ("float[]", _NONNEG),           # a rig's load table (bkabem_core.model.load_table)
        "load_speed_hz": ("float[]", _POS),
    },
    "measurement": MEASUREMENT_KEYS,
}
#: The one ``[bearing]`` of a schema-3 case, used at both positions (:func:`migrate_v3`): every key but the class.
SCHEMA_V3_BEARING = {k: v for k, v in BEARING_KEYS.items() if k != "clearance_class"}
TOP_LEVEL = ("case", "defects", "baseline", "excitation", "bearings", "housings", "rotor", "operating", "measurement")
#: keys a section may leave out (their default: 0 = off; a position's bearing keys: the catalogue's or the model's;
#: the acquisition's: the synthesiser's), so that cases written before them stay valid
_OPTIONAL = {"baseline": BASELINE_OPTIONAL, "bearings.*": OPTIONAL + ("applied_radial_load_n",),
             "operating": LOAD_KEYS, "measurement": tuple(SCHEMA["measurement"])}
#: keys of a [[defects]] table that only some kinds have: key -> the kinds that need it; keys any table may leave out
_KIND_KEYS = {key.name: tuple(k.name for k in kinds_with(key.name)) for key in own_keys()}
#: keys any [[defects]] table may leave out: a slot, as before; angle_deg instead of the clock; edge_fraction, which
#: only edge = "cubic" uses (as a scenario's defect, default :attr:`Dent.edge_fraction`)
_DEFECT_OPTIONAL = ("shape", "clock", "edge_fraction")
BEARING_NAMES = BEARINGS


def _type_ok(kind: str, value) -> bool:
    if kind == "float":
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == "bool":
        return isinstance(value, bool)
    if kind == "str":
        return isinstance(value, str)
    if kind == "float[]":
        return isinstance(value, list) and all(_type_ok("float", v) for v in value)
    if kind == "table[]":
        return isinstance(value, list) and all(isinstance(v, dict) for v in value)
    raise AssertionError(kind)


_KIND_TEXT = {"float": "a number", "int": "an integer", "bool": "true or false", "str": "a string",
              "float[]": "an array of numbers", "table[]": "an array of tables"}


def _check_value(key: str, value, check, source: str):
    if check is None:
        return
    values = value if isinstance(value, list) else [value]
    for v in values:
        if isinstance(v, float) and not math.isfinite(v):
            raise CaseError(key, f"must be finite (got {v})", source)
        op = check[0]
        if op == "gt" and not v > check[1]:
            raise CaseError(key, f"must be > {check[1]:g} (got {v!r})", source)
        if op == "ge" and not v >= check[1]:
            raise CaseError(key, f"must be >= {check[1]:g} (got {v!r})", source)
        if op == "range" and not check[1] <= v <= check[2]:
            raise CaseError(key, f"must be in [{check[1]:g}, {check[2]:g}] (got {v!r})", source)
        if op == "range_open" and not check[1] < v < check[2]:
            raise CaseError(key, f"must be in ({check[1]:g}, {check[2]:g}) (got {v!r})", source)
        if op == "in" and v not in check[1]:
            allowed = ", ".join(repr(a) for a in sorted(check[1], key=str))
            raise CaseError(key, f"must be one of {allowed} (got {v!r})", source)


def _check_table(prefix: str, table, schema: dict, source: str, optional=()):
    if not isinstance(table, dict):
        raise CaseError(prefix, "must be a table", source)
    for k in table:
        if k not in schema:
            raise CaseError(f"{prefix}.{k}", f"unknown key (allowed: {', '.join(schema)})", source)
    for k, (kind, check) in schema.items():
        key = f"{prefix}.{k}"
        if k not in table:
            if k in optional:
                continue
            raise CaseError(key, "missing", source)
        v = table[k]
        if not _type_ok(kind, v):
            raise CaseError(key, f"must be {_KIND_TEXT[kind]} (got {type(v).__name__} {v!r})", source)
        if isinstance(v, float) and not math.isfinite(v):
            raise CaseError(key, f"must be finite (got {v})", source)
        if kind == "float[]" and any(not math.isfinite(x) for x in v):
            raise CaseError(key, "must hold finite numbers only", source)
        _check_value(key, v, check, source)


def migrate_v1(raw: dict, source: str = "") -> dict:
    """A schema-version-1 case as version 4 (through 2 and 3: :func:`migrate_v2`), describing the model version 1
    computed.

    Version 1 had the paper's configuration built in: FE bearings from Table 1 (``stiffness_*`` keys), the 4-DOF
    excitation with the whole rotor weight on the faulty bearing only, Eq. 5 as printed, cubic dent edges, no
    axial load, no structural damping, one FE element per case element and the damper in ``[excitation]``.
    """
    raw = copy.deepcopy(raw)
    exc = raw.get("excitation", {})
    damper = exc.pop("bearing_damping_n_s_m", 550.0)
    raw.setdefault("bearing", {})["damping_n_s_m"] = damper
    raw.setdefault("dent", {}).setdefault("edge", "cubic")
    raw.setdefault("case", {})["schema_version"] = 2
    return migrate_v2(_migrate_v1_to_v2(raw), source)


def _migrate_v1_to_v2(raw: dict) -> dict:
    """The version-1 -> 2 steps of :func:`migrate_v1` (on a copy made there)."""
    exc = raw.get("excitation", {})
    exc.update({"method": "four_dof", "load": "rotor_weight", "bearings": "faulty", "force": "paper"})
    for b in raw.get("bearings", {}).values():
        if isinstance(b, dict):
            for k in ("stiffness_vertical_n_m", "stiffness_horizontal_n_m", "damping_vertical_n_s_m",
                      "damping_horizontal_n_s_m"):
                if k in b:
                    b[f"table_{k}"] = b.pop(k)
            b.update({"axial_load_n": 0.0, "linearisation": "table"})
    rot = raw.setdefault("rotor", {})
    rot.setdefault("damping_model", "none")
    rot.setdefault("damping_ratio", 0.0)
    rot.setdefault("damping_reference_hz", 1000.0)
    rot.setdefault("elements_per_wavelength", 0.0)
    raw.setdefault("operating", {}).setdefault("max_sample_rate_hz", 51200.0)
    return raw


def migrate_v2(raw: dict, source: str = "") -> dict:
    """A schema-version-2 case as version 4 (through 3), describing the model version 2 computed.

    Version 2 had one outer-race ``[dent]`` and nothing but the bearings: the dent becomes the single entry of
    ``[[defects]]`` (depth 0: a defect no ball feels, as before), ``[baseline]`` is switched off.
    """
    raw = copy.deepcopy(raw)
    dent = raw.pop("dent", None)
    if isinstance(dent, dict):
        raw["defects"] = [dent]
    raw.setdefault("baseline", dict(BASELINE_OFF))
    raw.setdefault("case", {})["schema_version"] = 3
    return migrate_v3(raw, source)


def migrate_v3(raw: dict, source: str = "") -> dict:
    """A schema-version-3 case as version 4, computing exactly the same numbers.

    Version 3 had one ``[bearing]`` table, the bearing type used at both positions (every key required): it is
    checked as version 3 checked it (the errors name ``bearing.<key>``), then written with every key into
    ``[bearings.de]`` and ``[bearings.nde]`` (:func:`bkabem_core.model.positions.migrate_shared`), so no value comes
    from the catalogue. ``[plausibility]`` bounds named ``bearing.<key>`` become ``bearings.*.<key>``.
    """
    raw = copy.deepcopy(raw)
    if "bearing" not in raw:
        raise CaseError("bearing", "missing section (a schema-3 case has one [bearing] table; schema 4 gives each "
                        "position's bearing in [bearings.de] and [bearings.nde])", source)
    _check_table("bearing", raw["bearing"], SCHEMA_V3_BEARING, source)
    migrate_shared(raw, BEARING_NAMES)
    raw.setdefault("case", {})["schema_version"] = SCHEMA_VERSION
    return raw


def validate_case_dict(raw: dict, source: str = "") -> None:
    """Validate a parsed case; raise :class:`CaseError` at the first problem."""
    for k in raw:
        if k not in TOP_LEVEL:
            raise CaseError(k, f"unknown section (allowed: {', '.join(TOP_LEVEL)})", source)
    for sec in ("case", "baseline", "excitation", "rotor", "operating"):
        if sec not in raw:
            raise CaseError(sec, "missing section", source)
        _check_table(sec, raw[sec], SCHEMA[sec], source, optional=_OPTIONAL.get(sec, ()))
    # defects: [[defects]] tables (none: a healthy machine, `defects = []`)
    if "defects" not in raw:
        raise CaseError("defects", "missing ([[defects]] tables, or `defects = []` for a healthy machine)", source)
    if not _type_ok("table[]", raw["defects"]):
        raise CaseError("defects", "must be an array of tables ([[defects]])", source)
    for i, d in enumerate(raw["defects"]):
        race = d.get("race") if isinstance(d, dict) else None
        others = tuple(k for k, names in _KIND_KEYS.items() if race not in names)
        may_omit = tuple(o.name for o in (kind(race).own_keys if race in KINDS else ()) if not o.required)
        may_omit += _DEFECT_OPTIONAL + (("angle_deg",) if isinstance(d, dict) and "clock" in d else ())   # or clock
        _check_table(f"defects[{i}]", d, SCHEMA["defects[]"], source, optional=others + may_omit)
        for k in others:
            if k in d:
                raise CaseError(f"defects[{i}].{k}", f"only for race = {' or '.join(map(repr, _KIND_KEYS[k]))} "
                                f"(this one is {race!r})", source)
    if (bad := load_table_problem(raw["operating"])) is not None:
        raise CaseError(f"operating.{bad[0]}", bad[1], source)
    if "measurement" in raw:
        _check_table("measurement", raw["measurement"], SCHEMA["measurement"], source, _OPTIONAL["measurement"])
        if (bad := measurement_problem(raw["measurement"])) is not None:
            raise CaseError(f"measurement.{bad[0]}", bad[1], source)
    # bearings.de / bearings.nde
    if "bearings" not in raw:
        raise CaseError("bearings", "missing section", source)
    brg = raw["bearings"]
    if not isinstance(brg, dict):
        raise CaseError("bearings", "must be a table with sub-tables de and nde", source)
    for name in brg:
        if name not in BEARING_NAMES:
            raise CaseError(f"bearings.{name}", "unknown bearing (allowed: de, nde)", source)
    for name in BEARING_NAMES:
        if name not in brg:
            raise CaseError(f"bearings.{name}", "missing (each position has its bearing: designation, damper, FE "
                            "element)", source)
        _check_table(f"bearings.{name}", brg[name], SCHEMA["bearings.*"], source, optional=_OPTIONAL["bearings.*"])
    # housings
    hs = raw.get("housings")
    if hs is None:
        raise CaseError("housings", "missing (two [[housings]] tables: de and nde)", source)
    if not _type_ok("table[]", hs):
        raise CaseError("housings", "must be an array of tables ([[housings]])", source)
    for i, h in enumerate(hs):
        _check_table(f"housings[{i}]", h, SCHEMA["housings[]"], source)
    names = [h["name"] for h in hs]
    if sorted(names) != ["de", "nde"]:
        raise CaseError("housings", f"need exactly one housing named 'de' and one named 'nde' (got {names})", source)
    for i, d in enumerate(raw["rotor"]["disks"]):
        _check_table(f"rotor.disks[{i}]", d, SCHEMA["rotor.disks[]"], source)


def resolve_bearings(raw: dict, source: str = "") -> dict:
    """Each position's bearing of a schema-valid case (:func:`bkabem_core.model.positions.resolve`):
    ``{"de": ResolvedBearing, "nde": ResolvedBearing}``; :class:`CaseError` naming the key when one cannot be."""
    out = {}
    for name in BEARING_NAMES:
        try:
            out[name] = resolve(raw["bearings"][name], f"bearings.{name}")
        except BearingTableError as exc:
            raise CaseError(exc.key, exc.reason, source) from None
    return out


def resolved_raw(raw: dict, bearings: dict) -> dict:
    """The case with each position table holding every key of its bearing (:func:`resolve_bearings`)."""
    out = copy.deepcopy(raw)
    for name, rb in bearings.items():
        out["bearings"][name].update(rb.table)
    return out


def _check_bearing(prefix: str, b: dict, source: str) -> None:
    if b["ball_diameter_m"] >= b["pitch_diameter_m"]:
        raise CaseError(f"{prefix}.ball_diameter_m", f"must be smaller than {prefix}.pitch_diameter_m "
                        f"({b['ball_diameter_m']} >= {b['pitch_diameter_m']})", source)
    if not b["bore_diameter_m"] < b["pitch_diameter_m"] < b["outer_diameter_m"]:
        raise CaseError(f"{prefix}.pitch_diameter_m", f"must lie between {prefix}.bore_diameter_m and "
                        f"{prefix}.outer_diameter_m", source)
    if b["n_balls"] * b["ball_diameter_m"] >= math.pi * b["pitch_diameter_m"]:
        raise CaseError(f"{prefix}.n_balls", f"{b['n_balls']} balls of {b['ball_diameter_m']} m do not fit on the "
                        f"pitch circle of {b['pitch_diameter_m']} m", source)


def _check_cross(raw: dict, source: str) -> None:
    """Relations between keys of a schema-valid case whose position tables are resolved (:func:`resolved_raw`)."""
    if not raw["case"]["name"].strip():
        raise CaseError("case.name", "must not be empty (it names the case in every output)", source)
    for name in BEARING_NAMES:
        _check_bearing(f"bearings.{name}", raw["bearings"][name], source)
    # each defect against its own bearing: its kind's own keys (a ball number) and its size against its surface
    for i, d in enumerate(raw["defects"]):
        problem = kind(d["race"]).check_table(d, raw["bearings"][d["bearing"]])
        if problem is not None:
            raise CaseError(f"defects[{i}].{problem[0]}", problem[1], source)
    _check_overlaps(raw["defects"], raw["bearings"], source)
    # rotor geometry
    r = raw["rotor"]
    z = r["node_positions_m"]
    n_nodes = len(z)
    if n_nodes < 2:
        raise CaseError("rotor.node_positions_m", "needs at least two shaft nodes", source)
    if any(z1 <= z0 for z0, z1 in zip(z, z[1:])):
        raise CaseError("rotor.node_positions_m", "must be strictly increasing", source)
    for k in ("outer_diameters_m", "inner_diameters_m"):
        if len(r[k]) != n_nodes - 1:
            raise CaseError(f"rotor.{k}", f"needs one value per element: {n_nodes - 1} (got {len(r[k])})", source)
    for i, (do, di) in enumerate(zip(r["outer_diameters_m"], r["inner_diameters_m"])):
        if di >= do:
            raise CaseError("rotor.inner_diameters_m", f"element {i + 1}: inner diameter {di} must be smaller "
                            f"than the outer diameter {do}", source)
    shaft_nodes = set(range(1, n_nodes + 1))
    for i, dk in enumerate(r["disks"]):
        if dk["node"] not in shaft_nodes:
            raise CaseError(f"rotor.disks[{i}].node", f"must be a shaft node 1..{n_nodes} (got {dk['node']})", source)
    housing_nodes = {h["name"]: h["node"] for h in raw["housings"]}
    for name, h_node in housing_nodes.items():
        if h_node in shaft_nodes:
            raise CaseError(f"housings.{name}.node", f"{h_node} is a shaft node; housings need their own node "
                            f"label > {n_nodes}", source)
    if len(set(housing_nodes.values())) != 2:
        raise CaseError("housings", "the two housings need different nodes", source)
    for name in BEARING_NAMES:
        e = raw["bearings"][name]
        if e["rotor_node"] not in shaft_nodes:
            raise CaseError(f"bearings.{name}.rotor_node", f"must be a shaft node 1..{n_nodes} "
                            f"(got {e['rotor_node']})", source)
        if e["housing_node"] != housing_nodes[name]:
            raise CaseError(f"bearings.{name}.housing_node", f"must be the node of housing '{name}' "
                            f"({housing_nodes[name]}, got {e['housing_node']})", source)
    if raw["bearings"]["de"]["rotor_node"] == raw["bearings"]["nde"]["rotor_node"]:
        raise CaseError("bearings.nde.rotor_node", "DE and NDE bearings must sit on different shaft nodes", source)
    if raw["excitation"]["method"] == "four_dof" and any(not kind(d["race"]).periodic for d in raw["defects"]):
        periodic = " and ".join(k.adjective for k in periodic_kinds())
        moving = " and ".join(k.adjective for k in moving_kinds())
        raise CaseError("excitation.method", f"'four_dof' models {periodic} dents only; {moving} defects need "
                        f"'quasi_static'", source)
    problem = baseline_problem(raw)
    if problem is not None:
        raise CaseError(*problem, source)
    for name in BEARING_NAMES:
        if raw["bearings"][name].get("applied_radial_load_n", 0.0) > 0.0 and raw["excitation"]["load"] != "fe_share":
            raise CaseError(f"bearings.{name}.applied_radial_load_n", "an applied radial load needs excitation.load = "
                            "'fe_share' (with 'rotor_weight' the excitation would carry the weight alone)", source)
    if raw["baseline"]["misalignment_node"] not in shaft_nodes:
        raise CaseError("baseline.misalignment_node", f"must be a shaft node 1..{n_nodes} "
                        f"(got {raw['baseline']['misalignment_node']})", source)


def _check_overlaps(defects: list, bearings: dict, source: str) -> None:
    """Two defects on the same surface (bearing and kind, and the kind's own place: the same ball) must not overlap:
    the model would take the deeper of the two pits where they meet, one defect silently standing for both."""
    seen: dict[tuple, list] = {}
    for i, d in enumerate(defects):
        k = kind(d["race"])
        bearing = bearings[d["bearing"]]
        where = (d["bearing"], d["race"], k.part_name(d))
        radius = k.table_race_radius_m(bearing) if hasattr(k, "table_race_radius_m") else \
            bearing["ball_diameter_m"] / 2.0
        half = d["length_m"] / (2.0 * radius)                       # half the angle it spans [rad]
        centre = math.radians(k.table_angle_deg(d))
        for j, (c, h) in seen.get(where, []):
            gap = abs(math.remainder(centre - c, 2.0 * math.pi))
            if gap < half + h:
                what = "the same defect as" if gap == 0.0 and half == h else "overlaps"
                raise CaseError(f"defects[{i}]", f"{what} defects[{j}] on the {d['bearing']} {k.place} "
                                f"(centres {math.degrees(gap):.3g} deg apart, they span {math.degrees(half + h):.3g} "
                                f"deg together): describe one pit once, or one longer defect", source)
        seen.setdefault(where, []).append((i, (centre, half)))


def scale_radial_load(raw: dict, factor: float) -> None:
    """Scale the radial load of a case's full form ``raw`` in place by ``factor`` (a scenario's or a data set's
    ``load_factor``): the gravity on its masses and any radial load applied at a bearing."""
    raw["excitation"]["gravity_m_s2"] = float(raw["excitation"]["gravity_m_s2"]) * factor
    for table in raw["bearings"].values():
        if table.get("applied_radial_load_n", 0.0) > 0.0:
            table["applied_radial_load_n"] = float(table["applied_radial_load_n"]) * factor


# --------------------------------------------------------------------------- the Case object
@dataclass
class Case:
    """A validated machine case.

    Attributes
    ----------
    name : str
    source : str
        Path of the file, or ``"embedded:<name>"``.
    raw : dict
        The parsed TOML (migrated to the current schema, validated) as written: what :meth:`with_overrides` edits
        and builders such as ``rotor_from_case`` read.
    resolved : dict
        ``raw`` with each position table (``bearings.de``, ``bearings.nde``) holding every key of its bearing,
        the catalogue's values and the model's defaults filled in (:mod:`bkabem_core.model.positions`): the
        numbers every model uses, and the case's identity (:attr:`case_hash`).
    positions : dict
        ``{"de": ResolvedBearing, "nde": ResolvedBearing}``: each position's bearing with its provenance.
    """

    name: str
    source: str
    raw: dict
    resolved: dict = field(repr=False, default_factory=dict)
    positions: dict = field(repr=False, default_factory=dict)

    # -- loading --
    @classmethod
    def load(cls, name_or_path: str | Path | None = None) -> "Case":
        """Load the embedded case ``name`` (default ``electric_motor_6010``) or a TOML file by path."""
        if name_or_path is None:
            name_or_path = DEFAULT_CASE
        text, source, _base = read_input_text(name_or_path, "cases", "case", "case", CaseError)
        return cls.from_toml(text, source=source)

    @classmethod
    def from_toml(cls, text: str, source: str = "") -> "Case":
        return cls.from_dict(parse_toml(text, source, CaseError), source)

    @classmethod
    def from_dict(cls, raw: dict, source: str = "") -> "Case":
        if "machine" in raw:                # the compact form (model/compact.py): loaded as the full form it gives
            return machine_case(raw, source, cls.from_dict, CaseError)
        raw = copy.deepcopy(raw)
        version = raw["case"].get("schema_version") if isinstance(raw.get("case"), dict) else None
        if version == 1:
            raw = migrate_v1(raw, source)
        elif version == 2:
            raw = migrate_v2(raw, source)
        elif version == 3:
            raw = migrate_v3(raw, source)
        validate_case_dict({k: v for k, v in raw.items() if k != plausibility.SECTION}, source)
        positions = resolve_bearings(raw, source)
        full = resolved_raw(raw, positions)
        _check_cross(full, source)
        bad = plausibility.problem(full)           # physical bounds (unit slips) and computing limits
        if bad is not None:
            raise CaseError(*bad, source)
        return cls(name=raw["case"]["name"], source=source, raw=raw, resolved=full, positions=positions)

    @classmethod
    def of_valid(cls, raw: dict, source: str = "") -> "Case":
        """The case of ``raw`` that was validated already (a :meth:`raw` of a case made by :meth:`from_dict`, kept
        with a data-set run): its bearings resolved again, nothing checked again."""
        positions = resolve_bearings(raw, source)
        return cls(name=raw["case"]["name"], source=source, raw=raw, resolved=resolved_raw(raw, positions),
                   positions=positions)

    # -- identity --
    @property
    def case_hash(self) -> str:
        """SHA-256 (first 16 hex digits) of the canonical JSON of the resolved parameters (:attr:`resolved`): the
        case identity (two files that give the same numbers, one by designation and one key by key, are one
        machine)."""
        blob = json.dumps(self.resolved, sort_keys=True, separators=(",", ":")).encode()
        return hashlib.sha256(blob).hexdigest()[:16]

    # -- the bearing of each position --
    def _position(self, location: str) -> str:
        if location not in BEARING_NAMES:
            raise ValueError(f"bearing position: one of {', '.join(BEARING_NAMES)} (got {location!r})")
        return location

    def bearing_table(self, location: str) -> dict:
        """The resolved table of the bearing at ``location`` (``"de"``/``"nde"``): its type (every key of
        :data:`~bkabem_core.model.positions.BEARING_KEYS`) and its FE element (a copy)."""
        return dict(self.resolved["bearings"][self._position(location)])

    def bearing_geometry(self, location: str) -> BearingGeometry:
        """Geometry and material of the bearing at ``location`` (``"de"``/``"nde"``)."""
        return geometry_of(self.resolved["bearings"][self._position(location)])

    def bearing_provenance(self, location: str) -> dict:
        """Where the bearing at ``location`` comes from: designation, catalogue row, geometry status and source,
        the keys the case overrides, how the clearance was found (:meth:`ResolvedBearing.provenance`)."""
        return self.positions[self._position(location)].provenance()

    def fault_multipliers(self, location: str) -> FaultFrequencies:
        """FTF, BPFO, BPFI, BSF per shaft Hz of the bearing at ``location`` (its own kinematics)."""
        return Bearing(self.bearing_geometry(location)).fault_multipliers()

    def kinematics(self, speed_hz: float) -> dict:
        """Each bearing's type and fault frequencies at shaft speed ``speed_hz`` [Hz]: ``{"de": {...}, "nde":
        {...}}`` with ``designation``, ``n_balls``, ``ball_diameter_m``, ``pitch_diameter_m``, ``contact_angle_rad``
        and ``ftf``, ``bpfo``, ``bpfi``, ``bsf`` [Hz]."""
        out = {}
        for name in BEARING_NAMES:
            g = self.bearing_geometry(name)
            ff = Bearing(g).fault_frequencies_hz(speed_hz)
            out[name] = {"designation": g.designation, "n_balls": g.n_balls, "ball_diameter_m": g.ball_diameter_m,
                         "pitch_diameter_m": g.pitch_diameter_m, "contact_angle_rad": g.contact_angle_rad,
                         **ff.to_dict()}
        return out

    @property
    def same_bearings(self) -> bool:
        """Whether both positions carry the same bearing (identical geometry and material)."""
        return self.bearing_geometry("de") == self.bearing_geometry("nde")

    def defects(self, location: str | None = None) -> list[Dent]:
        """The case's defects (``[[defects]]``), all or those of bearing ``location`` (``"de"``/``"nde"``)."""
        out = []
        for d in self.raw["defects"]:
            if location is not None and d["bearing"] != location:
                continue
            k = kind(d["race"])
            out.append(Dent(length_m=float(d["length_m"]), depth_m=float(d["depth_m"]), shape=d.get("shape", SHAPES[0]),
                            angle_rad=math.radians(k.table_angle_deg(d)),
                            edge_fraction=float(d.get("edge_fraction", Dent.edge_fraction)),
                            bearing=d["bearing"], race=d["race"], edge=d["edge"], **k.dent_fields(d)))
        return out

    def dent(self) -> Dent:
        """The first defect (the single-defect view of earlier versions); a healthy case gives a depth-0 outer-race
        placeholder of length 0 at the DE bearing (no ball feels it)."""
        found = self.defects()
        if found:
            return found[0]
        return Dent(length_m=0.0, depth_m=0.0, angle_rad=0.0, bearing="de")

    @property
    def defect_depth_m(self) -> float:
        """Depth of the first defect [m] (0 for a healthy case)."""
        return float(self.raw["defects"][0]["depth_m"]) if self.raw["defects"] else 0.0

    def with_defect_depth(self, depth_m: float) -> "Case":
        """The same case with the first defect at another depth [m] (a healthy case accepts only 0)."""
        if not self.raw["defects"]:
            if float(depth_m) != 0.0:
                raise CaseError("defects", "the case has no defect whose depth could change", self.source)
            return self
        return self.with_overrides({"defects.0.depth_m": float(depth_m)})

    def bearing(self, location: str) -> Bearing:
        """The bearing at ``location`` (``"de"``/``"nde"``) with its defects, if any."""
        return Bearing(self.bearing_geometry(location), defects=self.defects(location))

    def axial_load_n(self, location: str) -> float:
        """Axial load of bearing ``location`` [N]."""
        return float(self.raw["bearings"][self._position(location)]["axial_load_n"])

    def applied_radial_load_n(self, location: str) -> float:
        """The radial load a loader applies to the shaft at bearing ``location`` [N], downward like the weight; the
        bearing carries it on top of its share of the rotor's weight (0: none)."""
        return float(self.raw["bearings"][self._position(location)].get("applied_radial_load_n", 0.0))

    def bearing_damping_n_s_m(self, location: str) -> float:
        """The viscous damper across the bearing at ``location``, rotor to housing [N s/m]."""
        return float(self.resolved["bearings"][self._position(location)]["damping_n_s_m"])

    def ehl_film(self, location: str) -> bool:
        """Whether the bearing at ``location`` adds the EHL film thickness to its ball deformations (TDSM)."""
        return bool(self.resolved["bearings"][self._position(location)]["ehl_film"])

    @property
    def gravity_m_s2(self) -> float:
        return float(self.raw["excitation"]["gravity_m_s2"])

    @property
    def max_frequency_hz(self) -> float:
        """Highest frequency the model must serve [Hz]: half the case's highest sample rate, or the highest kept
        order of either bearing's BPFO at the highest speed if that is more (the FE mesh is converged up to it)."""
        op, ex = self.raw["operating"], self.raw["excitation"]
        bpfo = max(self.fault_multipliers(b).bpfo for b in BEARING_NAMES)
        top = ex["max_order"] * bpfo * op["max_speed_hz"]
        return float(max(0.5 * op["max_sample_rate_hz"], top))

    @property
    def faulty_bearing(self) -> str:
        """The bearing of the first defect (``"de"`` for a healthy case)."""
        return self.raw["defects"][0]["bearing"] if self.raw["defects"] else "de"

    @property
    def baseline(self) -> dict:
        """``[baseline]``: unbalance, misalignment and electrical settings (docs/faults.md)."""
        return dict(self.raw["baseline"])

    @property
    def max_speed_hz(self) -> float:
        return float(self.raw["operating"]["max_speed_hz"])

    def speed_at_load_hz(self, load_hp: float) -> float:
        """Shaft speed [Hz] at a load [hp] by the case's load table (bkabem_core.model.load_table; ValueError
        without a table or outside it)."""
        return speed_at_load_hz(self.raw["operating"], load_hp)

    def with_overrides(self, overrides: dict) -> "Case":
        """A new validated case with ``{"section.key": value}`` overrides (e.g. ``{"defects.0.depth_m": 20e-6}``:
        an integer picks an entry of an array of tables; ``bearings.nde.designation``, ``bearings.de.n_balls``: a
        position's bearing, a key the table leaves to the catalogue included; ``dent.<key>``, the single defect of
        schema 2, is the first defect; ``bearing.<key>``, the shared bearing of schema 3, is that key at both
        positions)."""
        raw = copy.deepcopy(self.raw)
        expanded = {}
        for dotted, value in overrides.items():
            if dotted.startswith("bearing."):                    # schema 3's shared [bearing]: both positions
                for name in BEARING_NAMES:
                    expanded[f"bearings.{name}.{dotted[8:]}"] = value
            else:
                expanded[dotted] = value
        for dotted, value in expanded.items():
            if dotted.startswith("dent.") and raw["defects"]:       # schema 2's single [dent]: the first defect
                dotted = "defects.0." + dotted[5:]
            *path, last = dotted.split(".")
            if path == ["measurement"]:                             # an optional section: made by its first key
                raw.setdefault("measurement", {})
            node = raw
            for p in path:
                if isinstance(node, list) and p.isdigit() and int(p) < len(node):
                    node = node[int(p)]
                    continue
                if not isinstance(node, dict) or p not in node or not isinstance(node[p], (dict, list)):
                    raise CaseError(dotted, "unknown key", self.source)
                node = node[p]
            optional = (len(path) == 1 and last in _OPTIONAL.get(path[0], ())) or \
                (len(path) == 2 and path[0] == "bearings" and last in _OPTIONAL["bearings.*"])
            if path[:1] == ["defects"] and isinstance(node, dict) and node.get("race") in KINDS:
                optional = optional or last in _DEFECT_OPTIONAL or any(o.name == last and not o.required
                                                                       for o in kind(node["race"]).own_keys)
            if not isinstance(node, dict) or (last not in node and not optional):
                raise CaseError(dotted, "unknown key", self.source)
            node[last] = value
        return Case.from_dict(raw, self.source + " (overridden)")

    def ground_truth(self) -> dict:
        """What a labelled data set needs: each position's bearing (designation, geometry, fault multipliers,
        provenance), every defect (kind, bearing, size, position, its own bearing's designation and fault-frequency
        multiplier), the machine baseline, case identity.

        ``bearings``: ``{"de": {...}, "nde": {...}}``. ``defects``: one entry per ``[[defects]]`` table, with
        ``fault_frequency`` (``"bpfo"``, ``"bpfi"`` or ``"bsf"``) and ``fault_multiplier`` [Hz per shaft Hz] of its
        textbook signature **of its own bearing** (a ball defect strikes at 2 x BSF: ``strike_multiplier``),
        ``bearing_designation``. ``defect``: the first one (as in earlier versions; ``None`` if healthy).
        ``bearing_designation`` and ``bearing_geometry`` are the DE bearing's (the fields of earlier versions,
        where both positions had one bearing).
        """
        per = {}
        for name in BEARING_NAMES:
            g = self.bearing_geometry(name)
            fm = Bearing(g).fault_multipliers()
            per[name] = {"designation": g.designation,
                         "geometry": {"ball_diameter_m": g.ball_diameter_m, "pitch_diameter_m": g.pitch_diameter_m,
                                      "n_balls": g.n_balls, "diametral_clearance_m": g.diametral_clearance_m,
                                      "contact_angle_rad": g.contact_angle_rad},
                         "fault_multipliers": fm.to_dict(), "provenance": self.bearing_provenance(name)}
        defects = []
        for d in self.defects():
            k = kind(d.race)
            fm = FaultFrequencies(**per[d.bearing]["fault_multipliers"])
            entry = {"kind": d.race, "bearing": d.bearing, "race": d.race, "length_m": d.length_m,
                     "depth_m": d.depth_m, "angle_rad": d.angle_rad, "edge": d.edge, "shape": d.shape,
                     "bearing_designation": per[d.bearing]["designation"],
                     "fault_frequency": k.fault_frequency, "fault_multiplier": k.fault_multiplier(fm),
                     "strike_multiplier": k.strike_multiplier(fm)}
            entry.update(k.table_fields(d))
            defects.append(entry)
        first = defects[0] if defects else None
        return {
            "case": self.name,
            "case_hash": self.case_hash,
            "bearing_designation": per["de"]["designation"],
            "bearing_geometry": dict(per["de"]["geometry"]),
            "fault_multipliers": dict(per["de"]["fault_multipliers"]),
            "bearings": per,
            "healthy": not any(d["depth_m"] > 0 for d in defects),
            "defects": defects,
            "defect": None if first is None else {k: first[k] for k in ("bearing", "race", "length_m", "depth_m",
                                                                       "angle_rad")},
            "baseline": self.baseline,
        }


def embedded_cases() -> list[str]:
    """Names of the cases shipped inside the package."""
    return embedded_names("cases")
