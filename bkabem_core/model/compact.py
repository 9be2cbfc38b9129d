"""The compact form of a machine: a ``[machine]`` table from which the FE description of the case follows.

A case in the compact form describes the machine as an engineer would draw it, in metres from the DE shaft end,
and leaves the FE bookkeeping (node numbers, elements, housing nodes) to :func:`expand`::

    [machine]
    speed_range_hz = [5.0, 75.0]           # the operating range: lowest and highest shaft speed [Hz]
    max_sample_rate_hz = 51200.0           # optional (51200): the FE is converged up to half of it
    # load_hp = [0.0, 1.0, 2.0, 3.0]       # optional: a rig's load table [hp] and the shaft speed at each
    # load_speed_hz = [29.95, 29.53, 29.17, 28.83]   # [Hz] (bkabem_core.model.load_table)
    shaft_steps_m = [[0.080, 0.045], [0.030, 0.050], [0.300, 0.065], [0.030, 0.050], [0.060, 0.045]]
                                           # [length, outer diameter(, inner diameter)] from the DE end

    [[machine.disks]]                      # rigid disks by mass and inertia, at their centres
    name = "impeller"
    position_m = 0.040
    mass_kg = 9.79
    polar_inertia_kg_m2 = 0.069
    diametral_inertia_kg_m2 = 0.037        # about its own centre
    # length_m = 0.280, slices = 7         # a stack (a rotor core): lumped as equal slices at their centres

    [machine.bearings.de]                  # each position: where, which bearing, and any key of [bearings.de]
    position_m = 0.095
    designation = "6010"                   # the catalogue's (docs/catalogue.md); clearance_class = "C3", ...
    damping_n_s_m = 550.0

    [machine.bearings.nde]
    position_m = 0.445
    designation = "6010"
    damping_n_s_m = 550.0

    [machine.housings]                     # both housings; [machine.housings.de] / .nde give one its own values
    mass_kg = 3.17
    support_stiffness_n_m = 1.0e6          # both directions, or support_stiffness_vertical_n_m / _horizontal_n_m
    support_damping_n_s_m = 1.0e4

Expansion (:func:`expand`, every length taken to the micrometre):

* **Nodes.** Every step boundary, every disk (each slice of a stack), each bearing and the coupling
  (``[baseline] misalignment_position_m``, default the DE shaft end) is a shaft node; nodes are numbered 1, 2, ...
  from the DE end (``rotor.node_positions_m``). Each element between two nodes has the diameters of the step it
  lies in. The housings are nodes N + 1 (DE) and N + 2 (NDE), each bearing joins its shaft node to its housing.
  The FE mesh then follows from these elements by the case's convergence rule
  (:func:`bkabem_core.fe.rotor.mesh_for`: ``rotor.elements_per_wavelength`` pieces per shortest wavelength at the
  model's highest frequency), as for a case written node by node.
* **A stack** of ``slices`` slices keeps the stack's mass, polar inertia and diametral inertia about its centre:
  each slice has ``m / n``, ``I_p / n`` and the diametral inertia that, with the slices' masses at their offsets,
  sums to the stack's (a uniform cylinder's own ``I_p / 2 + m L^2 / 12`` gives every slice its cylinder's).
* **The other sections** stay those of the full form and may be left out or given in part: ``[rotor]`` (material,
  shear, damping, ``elements_per_wavelength``; not its geometry keys), ``[excitation]``, ``[baseline]``,
  ``[[defects]]`` (none: a healthy machine), ``[plausibility]``. A key left out takes the value of
  :data:`ROTOR_DEFAULTS`, :data:`EXCITATION_DEFAULTS`, :data:`BASELINE_DEFAULTS` (the embedded motor's); the 4-DOF
  model's masses and supports default to the machine's (its rotor mass, the DE housing).
* **The FE bearing of a position** (``table_*`` keys, used with ``linearisation = "table"``) defaults to the
  bearing model's own linearisation at the position's static load (gravity on the rotor, two supports: the lever
  rule; plus a radial load applied at the bearing, ``applied_radial_load_n``) and its axial load, with its damper: switching the position to ``"table"`` then changes nothing.

A compact case is validated as the full case it expands to, and every error names the key of the compact form
(``machine.bearings.nde.position_m``, ``machine.shaft_steps_m``, ``machine.disks[1].mass_kg``).
``[operating]``, ``[bearings]``, ``[[housings]]`` and the geometry keys of ``[rotor]`` belong to the full form and
are refused beside ``[machine]``.

Units: SI, every key with its unit as a suffix.
"""

from __future__ import annotations

import copy
import math

from bkabem_core.bearing.deep_groove import Bearing
from bkabem_core.model import plausibility
from bkabem_core.model.vocabulary import BEARINGS

__all__ = ["SECTION", "ROTOR_DEFAULTS", "EXCITATION_DEFAULTS", "BASELINE_DEFAULTS", "machine_case", "expand",
           "speed_range_hz", "static_loads_n"]

SECTION = "machine"
#: positions are taken to the micrometre (decimal places of a length in m)
_DIGITS = 6
_MACHINE_KEYS = ("speed_range_hz", "max_sample_rate_hz", "load_hp", "load_speed_hz", "shaft_steps_m", "disks",
                 "bearings", "housings")
_DISK_KEYS = ("name", "position_m", "mass_kg", "polar_inertia_kg_m2", "diametral_inertia_kg_m2", "length_m", "slices")
_DIRECTED = ("support_stiffness", "support_damping")
_HOUSING_KEYS = ("mass_kg", "support_stiffness_n_m", "support_stiffness_vertical_n_m",
                 "support_stiffness_horizontal_n_m", "support_damping_n_s_m", "support_damping_vertical_n_s_m",
                 "support_damping_horizontal_n_s_m")
_ROTOR_GEOMETRY = ("node_positions_m", "outer_diameters_m", "inner_diameters_m", "disks")
_FE_BEARING_NODES = ("rotor_node", "housing_node")
_TABLE = {"table_stiffness_horizontal_n_m": "stiffness_horizontal_n_m",
          "table_stiffness_vertical_n_m": "stiffness_vertical_n_m",
          "table_damping_horizontal_n_s_m": "damping_horizontal_n_s_m",
          "table_damping_vertical_n_s_m": "damping_vertical_n_s_m"}
#: the full form's sections that [machine] replaces, and where the compact form gives them
_REPLACED = {"operating": "machine.speed_range_hz and machine.max_sample_rate_hz", "bearings": "[machine.bearings]",
             "housings": "[machine.housings]"}
DEFAULT_SAMPLE_RATE_HZ = 51200.0

#: ``[rotor]`` keys a compact case may leave out: a solid steel shaft as the embedded motor's (docs/method.md).
ROTOR_DEFAULTS = {"youngs_modulus_pa": 206.0e9, "poisson_ratio": 0.3, "density_kg_m3": 7850.0, "shear_effects": True,
                  "rotary_inertia": True, "gyroscopic": True, "damping_model": "stiffness", "damping_ratio": 0.01,
                  "damping_reference_hz": 2000.0, "elements_per_wavelength": 16.0}
#: ``[excitation]`` keys a compact case may leave out (the embedded motor's); ``rotor_mass_kg``,
#: ``housing_mass_kg``, ``support_stiffness_n_m`` and ``support_damping_n_s_m`` (4-DOF model only) default to the
#: machine's own: its rotor mass and the DE housing.
EXCITATION_DEFAULTS = {"method": "quasi_static", "load": "fe_share", "bearings": "all", "force": "spring",
                       "gravity_m_s2": 9.80665, "reference_speed_hz": 1.0, "settle_time_s": 0.3,
                       "record_cage_periods": 1, "samples_per_ball_pass": 2048, "rtol": 1.0e-7, "atol_m": 1.0e-12,
                       "relative_amplitude_threshold": 1.0e-3, "max_order": 50}
#: ``[baseline]`` keys a compact case may leave out: the bearings alone (docs/faults.md).
BASELINE_DEFAULTS = {"unbalance_grade_mm_s": 0.0, "unbalance_phase_deg": 0.0, "misalignment_force_n": 0.0,
                     "electrical_force_n": 0.0, "line_frequency_hz": 50.0}
_BEARING_DEFAULTS = {"axial_load_n": 0.0, "linearisation": "model"}


# --------------------------------------------------------------------------- small checks
class _Checks:
    """The compact form's own checks, raising the case's error class with the file's name."""

    def __init__(self, error, source: str):
        self.error, self.source = error, source

    def fail(self, key: str, reason: str):
        raise self.error(key, reason, self.source)

    def table(self, key: str, value, allowed=None) -> dict:
        if not isinstance(value, dict):
            self.fail(key, "must be a table")
        for k in value if allowed is not None else ():
            if k not in allowed:
                self.fail(f"{key}.{k}", f"unknown key (allowed: {', '.join(allowed)})")
        return value

    def number(self, key: str, value, low: float | None = None, strict: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"must be a number (got {type(value).__name__} {value!r})")
        if not math.isfinite(value):
            self.fail(key, f"must be finite (got {value})")
        if low is not None and (value <= low if strict else value < low):
            self.fail(key, f"must be {'>' if strict else '>='} {low:g} (got {value!r})")
        return float(value)

    def present(self, key: str, table: dict, name: str, what: str):
        if name not in table:
            self.fail(f"{key}.{name}", f"missing ({what})")
        return table[name]


def _m(z: float) -> float:
    """A length to the micrometre (the same position written two ways is one node)."""
    return round(float(z), _DIGITS) + 0.0


# --------------------------------------------------------------------------- the expansion
def speed_range_hz(raw: dict) -> tuple[float, float] | None:
    """``machine.speed_range_hz`` of a parsed compact case as (low, high) [Hz]; None for a case in the full form
    (or a range that is not two numbers: the expansion reports it)."""
    m = raw.get(SECTION) if isinstance(raw, dict) else None
    r = m.get("speed_range_hz") if isinstance(m, dict) else None
    if isinstance(r, list) and len(r) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                   for v in r):
        return float(r[0]), float(r[1])
    return None


def expand(raw: dict, source: str, error) -> tuple[dict, dict]:
    """The full form of the compact case ``raw`` (module docstring) and where each of its keys comes from.

    Parameters
    ----------
    raw : dict
        A parsed case with a ``[machine]`` table.
    source : str
        The file, for the errors.
    error : type
        The error class to raise, called ``error(key, reason, source)`` (the case's ``CaseError``).

    Returns
    -------
    full : dict
        The case in the full form; the ``table_*`` keys of a position the compact form does not give are missing
        (:func:`machine_case` fills them once the case is valid).
    where : dict
        Dotted key (or key prefix) of the full form -> the key of the compact form it comes from.
    """
    chk = _Checks(error, source)
    raw = copy.deepcopy(raw)
    m = chk.table(SECTION, raw.pop(SECTION), _MACHINE_KEYS)
    for sec, instead in _REPLACED.items():
        if sec in raw:
            chk.fail(sec, f"a case with [{SECTION}] gives it as {instead} (the full form's [{sec}] and the compact "
                          f"[{SECTION}] are two ways of writing one machine: give one of them)")
    case = raw.get("case")
    if isinstance(case, dict) and case.get("schema_version", 4) != 4:
        chk.fail("case.schema_version", f"the compact [{SECTION}] form is schema 4 (got {case['schema_version']!r})")
    where: dict[str, str] = {"operating": SECTION, "operating.max_speed_hz": f"{SECTION}.speed_range_hz",
                             "operating.max_sample_rate_hz": f"{SECTION}.max_sample_rate_hz"}
    # operating range
    rng = chk.present(SECTION, m, "speed_range_hz", "[lowest, highest] shaft speed in Hz")
    if not isinstance(rng, list) or len(rng) != 2:
        chk.fail(f"{SECTION}.speed_range_hz", f"must be [lowest, highest] shaft speed in Hz (got {rng!r})")
    lo = chk.number(f"{SECTION}.speed_range_hz", rng[0], 0.0)
    hi = chk.number(f"{SECTION}.speed_range_hz", rng[1], 0.0, strict=True)
    if not lo < hi:
        chk.fail(f"{SECTION}.speed_range_hz", f"the lowest speed must be below the highest (got {rng!r})")
    fs = chk.number(f"{SECTION}.max_sample_rate_hz", m.get("max_sample_rate_hz", DEFAULT_SAMPLE_RATE_HZ), 0.0, True)
    raw["operating"] = {"max_speed_hz": hi, "max_sample_rate_hz": fs}
    for k in ("load_hp", "load_speed_hz"):            # a rig's load table (bkabem_core.model.load_table)
        if k in m:
            raw["operating"][k] = m[k]
            where[f"operating.{k}"] = f"{SECTION}.{k}"
    # the shaft, the features on it, the nodes
    steps = _steps(chk, m)
    length = steps[-1][1]
    bearing_tables = _bearings(chk, m, length)
    disks, disk_of = _disks(chk, m, length)
    baseline = dict(BASELINE_DEFAULTS)
    given = raw.get("baseline", {})
    if isinstance(given, dict):
        if "misalignment_node" in given:
            chk.fail("baseline.misalignment_node", "a compact case places the coupling by misalignment_position_m "
                                                   "(m from the DE end; it numbers its nodes itself)")
        baseline.update(given)
        where["baseline.misalignment_node"] = "baseline.misalignment_position_m"
    coupling = _m(chk.number("baseline.misalignment_position_m", baseline.pop("misalignment_position_m", 0.0), 0.0))
    if coupling > length:
        chk.fail("baseline.misalignment_position_m", f"{coupling:g} m is beyond the shaft (0 .. {length:g} m)")
    raw["baseline"] = baseline if isinstance(given, dict) else given
    z = sorted({0.0, *(e for _, e, _, _ in steps), *(d["z"] for d in disks),
                *(t["z"] for t in bearing_tables.values()), coupling})
    node = {p: i + 1 for i, p in enumerate(z)}
    if isinstance(raw["baseline"], dict):
        raw["baseline"]["misalignment_node"] = node[coupling]
    outer, inner = [], []
    for a, b in zip(z, z[1:]):
        mid = 0.5 * (a + b)
        step = next(s for s in steps if s[0] <= mid <= s[1])
        outer.append(step[2])
        inner.append(step[3])
    rotor = raw.get("rotor", {})
    if isinstance(rotor, dict):
        for k in _ROTOR_GEOMETRY:
            if k in rotor:
                chk.fail(f"rotor.{k}", f"a case with [{SECTION}] gives the shaft as machine.shaft_steps_m and the "
                                       f"disks as [[machine.disks]]")
        rotor = {**ROTOR_DEFAULTS, **rotor}
        for k in ("node_positions_m", "outer_diameters_m", "inner_diameters_m"):
            where[f"rotor.{k}"] = f"{SECTION}.shaft_steps_m"
    rotor_geometry = {"node_positions_m": z, "outer_diameters_m": outer, "inner_diameters_m": inner,
                      "disks": [{k: v for k, v in d.items() if k != "z"} | {"node": node[d["z"]]} for d in disks]}
    raw["rotor"] = {**rotor, **rotor_geometry} if isinstance(rotor, dict) else rotor
    for i, j in enumerate(disk_of):
        where[f"rotor.disks[{i}]"] = f"{SECTION}.disks[{j}]"
    # housings and bearings
    n = len(z)
    housings, h_where = _housings(chk, m)
    raw["housings"] = [dict(name=name, node=n + 1 + i, **housings[name]) for i, name in enumerate(BEARINGS)]
    where["housings"] = f"{SECTION}.housings"
    for i, name in enumerate(BEARINGS):
        where[f"housings[{i}]"] = f"{SECTION}.housings"
        for k, src in h_where[name].items():
            where[f"housings[{i}].{k}"] = src
    raw["bearings"] = {}
    for i, name in enumerate(BEARINGS):
        t = dict(bearing_tables[name])
        zb = t.pop("z")
        raw["bearings"][name] = {**_BEARING_DEFAULTS, **t, "rotor_node": node[zb], "housing_node": n + 1 + i}
        where[f"bearings.{name}"] = f"{SECTION}.bearings.{name}"
        for k in _FE_BEARING_NODES:
            where[f"bearings.{name}.{k}"] = f"{SECTION}.bearings.{name}.position_m"
    # the excitation's defaults, the 4-DOF model's from the machine
    ex = raw.get("excitation", {})
    if isinstance(ex, dict):
        de = raw["housings"][0]
        derived = {"rotor_mass_kg": _rotor_mass_kg(raw["rotor"]), "housing_mass_kg": de["mass_kg"],
                   "support_stiffness_n_m": de["support_stiffness_vertical_n_m"],
                   "support_damping_n_s_m": de["support_damping_vertical_n_s_m"]}
        raw["excitation"] = {**EXCITATION_DEFAULTS, **derived, **ex}
        for k in derived:
            if k not in ex:
                where[f"excitation.{k}"] = SECTION
    raw.setdefault("defects", [])
    return raw, where


def _steps(chk: _Checks, m: dict) -> list[tuple[float, float, float, float]]:
    """(start, end, outer, inner diameter) of every shaft step [m], from the DE end."""
    key = f"{SECTION}.shaft_steps_m"
    steps = chk.present(SECTION, m, "shaft_steps_m", "[[length, outer diameter], ...] in m from the DE end")
    if not isinstance(steps, list) or not steps:
        chk.fail(key, "must be one or more [length, outer diameter] or [length, outer, inner diameter] in m")
    out, start, total = [], 0.0, 0.0
    for i, s in enumerate(steps):
        k = f"{key}[{i}]"
        if not isinstance(s, list) or len(s) not in (2, 3):
            chk.fail(k, f"must be [length, outer diameter] or [length, outer, inner diameter] in m (got {s!r})")
        length = chk.number(k, s[0], 0.0, strict=True)
        do = chk.number(k, s[1], 0.0, strict=True)
        di = chk.number(k, s[2], 0.0) if len(s) == 3 else 0.0
        if not di < do:
            chk.fail(k, f"the inner diameter {di:g} m must be smaller than the outer diameter {do:g} m")
        total += length
        end = _m(total)
        if not end > start:
            chk.fail(k, f"a step of {length:g} m is shorter than a micrometre (lengths are taken to the micrometre)")
        out.append((start, end, do, di))
        start = end
    return out


def _disks(chk: _Checks, m: dict, length: float) -> tuple[list[dict], list[int]]:
    """The disks of the full form (slices of a stack each its own) with their position ``z``, and for each the index
    of the compact disk it comes from."""
    disks = m.get("disks", [])
    if not isinstance(disks, list) or not all(isinstance(d, dict) for d in disks):
        chk.fail(f"{SECTION}.disks", "must be an array of tables ([[machine.disks]])")
    out, origin = [], []
    for i, d in enumerate(disks):
        key = f"{SECTION}.disks[{i}]"
        chk.table(key, d, _DISK_KEYS)
        for k in ("name", "position_m", "mass_kg", "polar_inertia_kg_m2", "diametral_inertia_kg_m2"):
            chk.present(key, d, k, "a disk has a name, its centre's position_m, its mass_kg and inertias")
        if not isinstance(d["name"], str) or not d["name"].strip():
            chk.fail(f"{key}.name", f"must be a non-empty string (got {d['name']!r})")
        z = chk.number(f"{key}.position_m", d["position_m"], 0.0)
        mass = chk.number(f"{key}.mass_kg", d["mass_kg"], 0.0, strict=True)
        ip = chk.number(f"{key}.polar_inertia_kg_m2", d["polar_inertia_kg_m2"], 0.0)
        idia = chk.number(f"{key}.diametral_inertia_kg_m2", d["diametral_inertia_kg_m2"], 0.0)
        if ("length_m" in d) != ("slices" in d):
            chk.fail(f"{key}.{'slices' if 'length_m' in d else 'length_m'}", "a stack gives both length_m and "
                     "slices (the slices are lumped at their centres)")
        stack = chk.number(f"{key}.length_m", d["length_m"], 0.0, strict=True) if "length_m" in d else 0.0
        n = d.get("slices", 1)
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            chk.fail(f"{key}.slices", f"must be an integer >= 1 (got {n!r})")
        if z - 0.5 * stack < 0.0 or _m(z + 0.5 * stack) > length:
            where = f"{z:g} m" if not stack else f"{z - 0.5 * stack:g} .. {z + 0.5 * stack:g} m"
            chk.fail(f"{key}.position_m", f"the disk ({where}) is not on the shaft (0 .. {length:g} m, "
                                          f"machine.shaft_steps_m)")
        offsets = [(k + 0.5) * stack / n - 0.5 * stack for k in range(n)]
        ms = mass / n
        own = (idia - ms * sum(o * o for o in offsets)) / n
        if own < 0.0:
            chk.fail(f"{key}.diametral_inertia_kg_m2", f"{idia:g} kg m^2 is less than the {n} slices' masses at "
                     f"their offsets give ({ms * sum(o * o for o in offsets):.4g} kg m^2): a stack of "
                     f"{stack:g} m and {mass:g} kg has at least that about its centre")
        for k, o in enumerate(offsets):
            out.append({"name": d["name"] if n == 1 else f"{d['name']}_{k + 1}", "z": _m(z + o), "mass_kg": ms,
                        "polar_inertia_kg_m2": ip / n, "diametral_inertia_kg_m2": own})
            origin.append(i)
    return out, origin


def _bearings(chk: _Checks, m: dict, length: float) -> dict[str, dict]:
    """Each position's table of the full form without its nodes, with its position ``z``."""
    brg = chk.present(SECTION, m, "bearings", "[machine.bearings.de] and [machine.bearings.nde]: each position's "
                                              "bearing and where it sits")
    chk.table(f"{SECTION}.bearings", brg, BEARINGS)
    out = {}
    for name in BEARINGS:
        key = f"{SECTION}.bearings.{name}"
        t = chk.table(key, chk.present(f"{SECTION}.bearings", brg, name, "every machine has a bearing at the DE and "
                                       "at the NDE: its position_m, designation and damping_n_s_m"))
        for k in _FE_BEARING_NODES:
            if k in t:
                chk.fail(f"{key}.{k}", "a compact case places the bearing by position_m (m from the DE end)")
        z = _m(chk.number(f"{key}.position_m", chk.present(key, t, "position_m", "m from the DE end"), 0.0))
        if z > length:
            chk.fail(f"{key}.position_m", f"{z:g} m is beyond the shaft's steps (they end at {length:g} m): the "
                                          f"shaft must reach every bearing")
        out[name] = {k: v for k, v in t.items() if k != "position_m"} | {"z": z}
    if out["de"]["z"] == out["nde"]["z"]:
        chk.fail(f"{SECTION}.bearings.nde.position_m", f"the DE and NDE bearings are both at {out['de']['z']:g} m")
    return out


def _housings(chk: _Checks, m: dict) -> tuple[dict, dict]:
    """Each housing's table of the full form (without name and node), and where each key comes from."""
    key = f"{SECTION}.housings"
    h = chk.table(key, chk.present(SECTION, m, "housings", "the housings' mass_kg and their supports' stiffness "
                                   "and damping"), _HOUSING_KEYS + BEARINGS)
    out, where = {}, {}
    for name in BEARINGS:
        own = chk.table(f"{key}.{name}", h.get(name, {}), _HOUSING_KEYS)
        both = {k: v for k, v in h.items() if k not in BEARINGS}
        t, src = {}, {}
        for k in _HOUSING_KEYS:
            for table, prefix in ((own, f"{key}.{name}"), (both, key)):
                if k in table:
                    t[k], src[k] = table[k], f"{prefix}.{k}"
                    break
        full, full_src = {}, {}
        if "mass_kg" in t:
            full["mass_kg"], full_src["mass_kg"] = t["mass_kg"], src["mass_kg"]
        for what in _DIRECTED:
            unit = "n_m" if what == "support_stiffness" else "n_s_m"
            for d in ("vertical", "horizontal"):
                k = f"{what}_{d}_{unit}"
                for cand in (k, f"{what}_{unit}"):
                    if cand in t:
                        full[k], full_src[k] = t[cand], src[cand]
                        break
                else:
                    chk.fail(f"{key}.{what}_{unit}", f"missing (the {name.upper()} support's {d} "
                                                     f"{what.split('_')[1]}: {what}_{unit} for both directions, or "
                                                     f"{k})")
        chk.present(key, full, "mass_kg", f"the {name.upper()} housing's mass")
        out[name], where[name] = full, full_src
    return out, where


def _rotor_mass_kg(rotor: dict) -> float:
    """Shaft and disks [kg] of a ``[rotor]`` table with its geometry (nothing checked: 0 when it does not add)."""
    try:
        return sum(mass for mass, _ in _masses(rotor))
    except (KeyError, TypeError, ValueError):
        return 0.0


def _masses(rotor: dict) -> list[tuple[float, float]]:
    """(mass [kg], axial position of its centre [m]) of every shaft element and disk of a ``[rotor]`` table."""
    z = rotor["node_positions_m"]
    rho = float(rotor["density_kg_m3"])
    out = [(rho * math.pi / 4.0 * (do * do - di * di) * (b - a), 0.5 * (a + b))
           for a, b, do, di in zip(z, z[1:], rotor["outer_diameters_m"], rotor["inner_diameters_m"])]
    out += [(float(d["mass_kg"]), z[int(d["node"]) - 1]) for d in rotor["disks"]]
    return out


def static_loads_n(full: dict) -> dict[str, float]:
    """Each bearing's static radial load [N] (downward on the bearing) of a valid case in the full form: the rotor's
    weight shared by the lever rule, plus the radial load applied at the bearing (``applied_radial_load_n``, carried
    by that bearing alone). Two supports make the rotor statically determinate, so this is the FE's static solution
    (:func:`bkabem_core.fe.machine.static_force_n`)."""
    r = full["rotor"]
    g = float(full["excitation"]["gravity_m_s2"])
    z = r["node_positions_m"]
    z_de, z_nde = (z[int(full["bearings"][b]["rotor_node"]) - 1] for b in BEARINGS)
    masses = _masses(r)
    weight = g * sum(mass for mass, _ in masses)
    moment = g * sum(mass * (z_nde - zc) for mass, zc in masses)      # about the NDE bearing
    de = moment / (z_nde - z_de)
    applied = {b: float(full["bearings"][b].get("applied_radial_load_n", 0.0)) for b in BEARINGS}
    return {"de": de + applied["de"], "nde": weight - de + applied["nde"]}


# --------------------------------------------------------------------------- the case
def machine_case(raw: dict, source: str, from_dict, error):
    """The case of the compact form ``raw``: expanded (:func:`expand`), validated and loaded by ``from_dict`` (the
    full form's ``Case.from_dict``), every error named by the key of the compact form.

    The FE bearing keys (``table_*``) that a position does not give are the bearing model's linearisation at its
    static load (module docstring); they are found on the valid case and the case is loaded again with them.
    """
    full, where = expand(raw, source, error)
    missing = {name: [k for k in _TABLE if k not in full["bearings"][name]] for name in BEARINGS}
    for name in BEARINGS:
        if missing[name] and full["bearings"][name].get("linearisation") == "table":
            raise error(f"{SECTION}.bearings.{name}.{missing[name][0]}", 'missing (linearisation = "table" takes '
                        'the FE bearing from the table_* keys)', source)
    if not any(missing.values()):
        return _load(full, where, source, from_dict, error)
    trial = copy.deepcopy(full)
    for name in BEARINGS:                   # any valid value: the case is checked, then these are replaced
        trial["bearings"][name].update({k: plausibility.bound(full, f"bearings.*.{k}")[0] for k in missing[name]})
    case = _load(trial, where, source, from_dict, error)
    loads = static_loads_n(case.raw)
    for name in BEARINGS:
        if not missing[name]:
            continue
        b = case.raw["bearings"][name]
        try:
            lin = Bearing(case.bearing_geometry(name)).linearise(
                0.0, -loads[name], axial_load_n=float(b["axial_load_n"]),
                damping_n_s_m=case.bearing_damping_n_s_m(name), average_over_pitch=True)
        except (ValueError, RuntimeError) as exc:
            raise error(f"{SECTION}.bearings.{name}.axial_load_n", f"the {name.upper()} bearing has no static "
                        f"equilibrium under {loads[name]:.4g} N radial and {b['axial_load_n']:g} N axial ({exc}): "
                        f"a light rotor in a loose bearing; give it an axial preload", source) from None
        for k in missing[name]:
            value = float(getattr(lin, _TABLE[k]))
            lo_b, hi_b, why = plausibility.bound(case.raw, f"bearings.*.{k}")
            if not lo_b <= value <= hi_b:
                raise error(f"{SECTION}.bearings.{name}.axial_load_n", f"the bearing model's {_TABLE[k]} at the "
                            f"{name.upper()} bearing's static load ({loads[name]:.4g} N radial, {b['axial_load_n']:g} "
                            f"N axial) is {value:.4g}, outside [{lo_b:g}, {hi_b:g}]: {why}; give it a preload, or "
                            f"its FE bearing ({k} with linearisation = \"table\")", source)
            full["bearings"][name][k] = value
    return _load(full, where, source, from_dict, error)


def _load(full: dict, where: dict, source: str, from_dict, error):
    """``from_dict(full)``, its error's key named in the compact form (:func:`expand`'s ``where``)."""
    try:
        return from_dict(full, source)
    except error as exc:
        raise error(_compact_key(exc.key, where), exc.reason, source) from None


def _compact_key(key: str, where: dict) -> str:
    """The compact form's key of the full form's ``key``: its own entry, else that of its longest prefix."""
    if key in where:
        return where[key]
    best = ""
    for prefix in where:
        if key.startswith(prefix) and key[len(prefix):len(prefix) + 1] in (".", "[") and len(prefix) > len(best):
            best = prefix
    return where[best] + key[len(best):] if best else key
