"""Scenarios: a machine whose bearings change over time (defects appearing and growing, speed and load profiles).

A scenario file (TOML, ``docs/scenarios.md``) names a machine (a case) and a timeline over *scenario time* (hours,
for a run to failure): defects that appear at a time and grow (length and depth given at points in time, linear or
exponential in between), the shaft speed and the radial load. The synthesiser cannot change its model at every
instant, so the timeline is cut into **states**: a new state begins whenever a defect appears, reaches one of its
points, or has grown by ``size_step`` of its size since the last state of its own, and at every load step. In a
state every defect has the size of the timeline at the state's start; the state's case (the machine with those
defects) is validated when the scenario is read, so a scenario that loads runs to its end.

    scenario = Scenario.load("de_outer_run_to_failure")     # embedded, or a TOML path
    state = scenario.state_at(7200.0)                       # scenario time [s] -> ScenarioState
    model = BkaBem(state.case, like=previous_model)         # bkabem_core.scenario.models does the pooling
    truth = scenario.ground_truth(state, 7200.0, speed_hz=25.0)

Speed is not part of a state (the synthesiser follows any speed profile continuously): :meth:`Scenario.speed_hz`.
Nothing here imports ROS. Bad input raises :class:`ScenarioError` naming the key (``defects[1].depth_m``) and the
reason, one line. Units: SI (s, m, Hz); times may be given in hours (``time_h``, ``duration_h``).
"""

from __future__ import annotations

import bisect
import copy
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bkabem_core.bearing.defects.profiles import EDGE_PROFILES
from bkabem_core.bearing.defects.registry import KINDS, kind, kinds_with, own_keys
from bkabem_core.model.case import (
    Case,
    CaseError,
    InputFileError,
    embedded_names,
    parse_toml,
    read_input_text,
    scale_radial_load,
)

SCHEMA_VERSION = 1
#: Most states a scenario may have (each one is a model to prepare; ~0.1-2 s each for a grown defect).
MAX_STATES = 500
#: Radial load factors a load profile may set (1 = the case's own load; the case's gravity bound applies too).
LOAD_FACTOR_RANGE = (0.1, 10.0)
DEFAULT_SIZE_STEP = 0.1
GROWTH = ("linear", "exponential")
_HOURS = 3600.0


class ScenarioError(InputFileError):
    """A scenario file is invalid. ``key`` is the dotted key at fault, ``reason`` says why."""


# --------------------------------------------------------------------------- reading helpers
def _type_name(v) -> str:
    return f"{type(v).__name__} {v!r}"


def _number(key: str, v, source: str, lo=None, hi=None, strict_lo=False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ScenarioError(key, f"must be a number (got {_type_name(v)})", source)
    v = float(v)
    if not math.isfinite(v):
        raise ScenarioError(key, f"must be finite (got {v})", source)
    if lo is not None and (v <= lo if strict_lo else v < lo):
        raise ScenarioError(key, f"must be {'>' if strict_lo else '>='} {lo:g} (got {v:g})", source)
    if hi is not None and v > hi:
        raise ScenarioError(key, f"must be <= {hi:g} (got {v:g})", source)
    return v


#: Labels ride in the ground truth of every message and every data-set row: at most this many bytes (UTF-8, keys
#: and values together; a waveform chunk's samples are ~10 kB), keys of at most 64 and values of at most 256.
MAX_LABEL_BYTES = 1024
MAX_LABEL_KEY = 64
MAX_LABEL_VALUE = 256


def label_problem(labels: dict) -> tuple[str, str] | None:
    """``(key, reason)`` of the first label beyond the size bounds above, or None."""
    total = 0
    for k, v in labels.items():
        if not str(k).strip():
            return "labels", "a label needs a key"
        if len(str(k)) > MAX_LABEL_KEY:
            return f"labels.{str(k)[:20]}...", f"key of {len(str(k))} characters, more than {MAX_LABEL_KEY}"
        if len(str(v)) > MAX_LABEL_VALUE:
            return f"labels.{k}", f"value of {len(str(v))} characters, more than {MAX_LABEL_VALUE}"
        total += len(str(k).encode()) + len(str(v).encode())
    if total > MAX_LABEL_BYTES:
        return "labels", (f"{len(labels)} labels of {total} bytes together, more than {MAX_LABEL_BYTES} (they ride in "
                          f"every message's ground truth)")
    return None


def _string(key: str, v, source: str, choices=None) -> str:
    if not isinstance(v, str):
        raise ScenarioError(key, f"must be a string (got {_type_name(v)})", source)
    if choices is not None and v not in choices:
        raise ScenarioError(key, f"must be one of {', '.join(map(repr, choices))} (got {v!r})", source)
    return v


def _table(key: str, v, source: str, allowed) -> dict:
    if not isinstance(v, dict):
        raise ScenarioError(key, f"must be a table (got {_type_name(v)})", source)
    for k in v:
        if k not in allowed:
            raise ScenarioError(f"{key}.{k}" if key else k, f"unknown key (allowed: {', '.join(allowed)})", source)
    return v


def _array(key: str, v, source: str, lo=None, hi=None, strict_lo=False) -> list[float]:
    if not isinstance(v, list) or not v:
        raise ScenarioError(key, f"must be a non-empty array of numbers (got {_type_name(v)})", source)
    return [_number(f"{key}[{i}]", x, source, lo, hi, strict_lo) for i, x in enumerate(v)]


def _times(key: str, table: dict, source: str, stem: str = "time", required: bool = True):
    """``<stem>_s`` or ``<stem>_h`` of a table, in s (exactly one of them); None if neither and not required."""
    has_s, has_h = f"{stem}_s" in table, f"{stem}_h" in table
    if has_s and has_h:
        raise ScenarioError(f"{key}.{stem}_h", f"give {stem}_s or {stem}_h, not both", source)
    if not (has_s or has_h):
        if required:
            raise ScenarioError(f"{key}.{stem}_s", f"missing ({stem}_s in s, or {stem}_h in hours)", source)
        return None, None
    name = f"{stem}_s" if has_s else f"{stem}_h"
    scale = 1.0 if has_s else _HOURS
    return name, scale


def _time_points(key: str, table: dict, source: str, duration_s: float | None) -> tuple[str, list[float]]:
    name, scale = _times(key, table, source)
    values = _array(f"{key}.{name}", table[name], source, lo=0.0)
    t = [v * scale for v in values]
    for i in range(1, len(t)):
        if not t[i] > t[i - 1]:
            raise ScenarioError(f"{key}.{name}[{i}]", f"times must be strictly increasing ({values[i - 1]:g} then "
                                f"{values[i]:g})", source)
    if duration_s is not None and t[-1] > duration_s * (1 + 1e-12):
        unit = "h" if scale != 1.0 else "s"
        raise ScenarioError(f"{key}.{name}[{len(t) - 1}]", f"{values[-1]:g} {unit} is after the end of the scenario "
                            f"({duration_s / scale:g} {unit}, scenario.duration_s/_h)", source)
    return name, t


# --------------------------------------------------------------------------- the timeline's parts
@dataclass(frozen=True)
class DefectTrack:
    """One defect of the scenario over time: where it is and how it grows.

    Attributes
    ----------
    name : str
        Its name in the scenario (``[[defects]] name``), unique: the id in the ground truth.
    bearing, race : str
        ``"de"``/``"nde"``; its kind (:data:`~bkabem_core.bearing.defects.registry.KINDS`).
    own : tuple of (str, object)
        The keys only its kind has, as in a case's ``[[defects]]`` (a ball defect: ``(("ball", 3),)``, the ball
        number 1..z).
    angle_deg, edge, edge_fraction
        As in a case's ``[[defects]]`` (deg; ``"ball"``/``"cubic"``; -).
    time_s : tuple of float
        Times of the size points [s of scenario time]; the defect appears at the first one.
    length_m, depth_m : tuple of float
        Size at those times [m].
    growth : str
        ``"linear"`` or ``"exponential"`` (geometric between points: a constant relative growth rate, how spalls
        grow in run-to-failure tests) between points; held after the last one.
    key : str
        Its key in the file (``defects[2]``) for messages.
    """

    name: str
    bearing: str
    race: str
    own: tuple
    angle_deg: float
    edge: str
    edge_fraction: float
    time_s: tuple
    length_m: tuple
    depth_m: tuple
    growth: str
    key: str

    def present(self, t_s: float) -> bool:
        return t_s >= self.time_s[0]

    def size_at(self, t_s: float) -> tuple[float, float] | None:
        """(length [m], depth [m]) at scenario time ``t_s`` [s]; None before the defect appears."""
        if t_s < self.time_s[0]:
            return None
        return _interp(self.time_s, self.length_m, t_s, self.growth), _interp(self.time_s, self.depth_m, t_s,
                                                                             self.growth)

    def boundaries(self, step: float, end_s: float, limit: int = MAX_STATES) -> list[float]:
        """Times [s] at which this defect makes a new state: its appearance, its points, and every time its length
        or depth has moved by ``step`` of its size at the last one (at least ``step`` x a tenth of its largest
        size, so that growth from 0 takes finitely many states). Stops past ``limit`` boundaries."""
        out = [self.time_s[0]]
        floors = (0.1 * max(self.length_m), 0.1 * max(self.depth_m))
        for i in range(len(self.time_s) - 1):
            ta, tb = self.time_s[i], self.time_s[i + 1]
            t = ta
            while True:
                nxt = tb
                for values, floor in ((self.length_m, floors[0]), (self.depth_m, floors[1])):
                    va, vb = values[i], values[i + 1]
                    v0 = _interp_seg(ta, tb, va, vb, t, self.growth)
                    delta = step * max(abs(v0), floor)
                    if delta <= 0 or va == vb:
                        continue
                    target = v0 + delta if vb > va else v0 - delta
                    tc = _time_of(ta, tb, va, vb, target, self.growth)
                    if tc is not None and t < tc < nxt:
                        nxt = tc
                if nxt >= tb or nxt > end_s or tb - nxt < 0.5 * (nxt - t) or len(out) > limit:
                    break                       # (a last step of less than half a step: the point ends it)
                out.append(nxt)
                t = nxt
            out.append(tb)
        return sorted({x for x in out if x <= end_s})


def _interp_seg(ta, tb, va, vb, t, growth) -> float:
    s = (t - ta) / (tb - ta)
    if growth == "exponential" and va > 0 and vb > 0:
        return va * (vb / va) ** s
    return va + (vb - va) * s


def _time_of(ta, tb, va, vb, target, growth) -> float | None:
    """Time in (ta, tb) where the segment reaches ``target``, or None."""
    if growth == "exponential" and va > 0 and vb > 0 and target > 0:
        s = math.log(target / va) / math.log(vb / va)
    else:
        s = (target - va) / (vb - va)
    return ta + s * (tb - ta) if 0.0 < s < 1.0 else None


def _interp(times, values, t, growth) -> float:
    if t <= times[0]:
        return float(values[0])
    if t >= times[-1]:
        return float(values[-1])
    i = bisect.bisect_right(times, t) - 1
    return float(_interp_seg(times[i], times[i + 1], values[i], values[i + 1], t, growth))


@dataclass(frozen=True)
class ScenarioState:
    """A stretch of scenario time with one machine: every defect at its size at ``start_s``.

    Attributes
    ----------
    index : int
        Position in :attr:`Scenario.states` (0 first).
    start_s, end_s : float
        Scenario time it covers [s] (``end_s`` = the next state's start; inf for the last).
    defects : tuple of dict
        Its defects: ``name`` (scenario name, or ``defects[i]`` of the case), ``bearing``, ``race``, ``length_m``,
        ``depth_m``, ``angle_deg`` (+ ``ball``) as in a case's ``[[defects]]``.
    load_factor : float
        Radial load of the bearings relative to the case's own (gravity and the radial loads applied at the
        bearings scaled).
    label : str
        For people: ``"healthy"`` or e.g. ``"DE outer 0.20 mm x 10 um"``.
    case : Case
        The machine in this state (validated).
    """

    index: int
    start_s: float
    end_s: float
    defects: tuple
    load_factor: float
    label: str
    case: Case = field(repr=False, compare=False)

    @property
    def healthy(self) -> bool:
        return not any(d["depth_m"] > 0 for d in self.defects)

    def to_dict(self) -> dict:
        return {"index": self.index, "start_s": self.start_s, "end_s": self.end_s if math.isfinite(self.end_s)
                else None, "label": self.label, "load_factor": self.load_factor, "healthy": self.healthy,
                "defects": [dict(d) for d in self.defects], "case_hash": self.case.case_hash}


def _label(defects, load_factor: float) -> str:
    parts = []
    for d in defects:
        if d["depth_m"] <= 0:
            continue
        what = kind(d["race"]).label_of(d)
        parts.append(f"{d['bearing'].upper()} {what} {d['length_m'] * 1e3:.2f} mm x {d['depth_m'] * 1e6:.0f} um")
    text = " + ".join(parts) if parts else "healthy"
    if load_factor != 1.0:
        text += f", load x{load_factor:g}"
    return text


# --------------------------------------------------------------------------- the scenario
_SCENARIO_KEYS = ("name", "description", "schema_version", "case", "duration_s", "duration_h", "size_step")
_DEFECT_KEYS = ("name", "bearing", "race", *(k.name for k in own_keys()), "angle_deg", "edge", "edge_fraction",
                "time_s", "time_h", "length_m", "depth_m", "growth")
_TOP = ("scenario", "speed", "load", "defects", "labels")


class Scenario:
    """A machine over scenario time (module docstring). Use :meth:`load` / :meth:`from_toml` / :meth:`from_dict`.

    Attributes
    ----------
    name, description, source : str
    case : Case
        The machine at the start (its own ``[[defects]]`` stay throughout, at their size).
    duration_s : float
        Length of the scenario [s of scenario time]; after it the last state holds.
    size_step : float
        Relative growth that makes a new state.
    tracks : tuple of DefectTrack
    speed_points : (times [s], speeds [Hz]) or None
        The shaft speed over scenario time, linear between points and held after the last; None: no profile (the
        speed comes from elsewhere, e.g. the node's ``speed`` topic).
    load_points : (times [s], factors) or None
        Radial load factor steps (each holds until the next).
    labels : dict str -> str
        Free labels that go into every ground truth (``[labels]``).
    states : list of ScenarioState
    """

    def __init__(self, raw: dict, source: str = "", base_dir: Path | None = None):
        self.raw = copy.deepcopy(raw)
        self.source = source
        if not isinstance(raw, dict):
            raise ScenarioError("scenario", "the file is not a TOML table", source)
        if "fleet" in raw:
            raise ScenarioError("fleet", "this is a fleet scenario (machines and their cases): use it with "
                                "`bkabem fleet --scenario FILE`", source)
        _table("", raw, source, _TOP)
        if "scenario" not in raw:
            raise ScenarioError("scenario", "missing section ([scenario] with name, schema_version, case, "
                                "duration_s)", source)
        sc = _table("scenario", raw["scenario"], source, _SCENARIO_KEYS)
        for k in ("name", "schema_version", "case"):
            if k not in sc:
                raise ScenarioError(f"scenario.{k}", "missing", source)
        self.name = _string("scenario.name", sc["name"], source)
        if not self.name.strip():
            raise ScenarioError("scenario.name", "must not be empty", source)
        self.description = _string("scenario.description", sc.get("description", ""), source)
        v = sc["schema_version"]
        if isinstance(v, bool) or v != SCHEMA_VERSION:
            raise ScenarioError("scenario.schema_version", f"must be {SCHEMA_VERSION} (got {v!r})", source)
        name, scale = _times("scenario", sc, source, "duration")
        self.duration_s = _number(f"scenario.{name}", sc[name], source, 0.0, strict_lo=True) * scale
        self.size_step = _number("scenario.size_step", sc.get("size_step", DEFAULT_SIZE_STEP), source, 0.0, 1.0,
                                 strict_lo=True)
        case_ref = _string("scenario.case", sc["case"], source)
        self.case = self._load_case(case_ref, base_dir, source)
        self.labels = self._labels(raw.get("labels", {}), source)
        self.speed_points = self._speed(raw.get("speed"), source)
        self.load_points = self._load(raw.get("load"), source)
        self.tracks = self._tracks(raw.get("defects", []), source)
        self.states = self._make_states(source)
        self._starts = [s.start_s for s in self.states]

    # -- reading --
    @staticmethod
    def _load_case(ref: str, base_dir: Path | None, source: str) -> Case:
        looks_like_path = ref.endswith(".toml") or "/" in ref
        try:
            if looks_like_path and base_dir is not None and not Path(ref).is_absolute():
                return Case.load(base_dir / ref)
            return Case.load(ref)
        except CaseError as exc:
            where = f" ({exc.source})" if exc.source and exc.source != ref else ""
            raise ScenarioError("scenario.case", f"{exc.key}: {exc.reason}{where}", source) from None

    @staticmethod
    def _labels(labels, source: str) -> dict:
        if not isinstance(labels, dict):
            raise ScenarioError("labels", f"must be a table of strings (got {_type_name(labels)})", source)
        out = {}
        for k, v in labels.items():
            out[k] = _string(f"labels.{k}", v, source)
        bad = label_problem(out)
        if bad is not None:
            raise ScenarioError(*bad, source)
        return out

    def _speed(self, sp, source: str):
        if sp is None:
            return None
        _table("speed", sp, source, ("time_s", "time_h", "speed_hz"))
        name, t = _time_points("speed", sp, source, self.duration_s)
        if "speed_hz" not in sp:
            raise ScenarioError("speed.speed_hz", "missing (one shaft speed per time, Hz)", source)
        top = self.case.max_speed_hz
        f = _array("speed.speed_hz", sp["speed_hz"], source, 0.0, top)
        if len(f) != len(t):
            raise ScenarioError("speed.speed_hz", f"needs one speed per time: {len(t)} (got {len(f)})", source)
        if t[0] > 0:
            t, f = [0.0] + t, [f[0]] + f
        return tuple(t), tuple(f)

    def _load(self, ld, source: str):
        if ld is None:
            return None
        _table("load", ld, source, ("time_s", "time_h", "load_factor"))
        name, t = _time_points("load", ld, source, self.duration_s)
        if "load_factor" not in ld:
            raise ScenarioError("load.load_factor", "missing (one radial load factor per time; 1 = the case's load)",
                                source)
        f = _array("load.load_factor", ld["load_factor"], source, *LOAD_FACTOR_RANGE)
        if len(f) != len(t):
            raise ScenarioError("load.load_factor", f"needs one factor per time: {len(t)} (got {len(f)})", source)
        if t[0] > 0:
            t, f = [0.0] + t, [1.0] + f
        return tuple(t), tuple(f)

    def _own_keys(self, key: str, d: dict, k, source: str, position: str) -> tuple:
        """The keys only kind ``k`` has of the ``[[defects]]`` table ``d`` (checked against the case's bearing at
        ``position``), as ``((key, value), ...)``; a key of another kind is refused."""
        bearing = self.case.bearing_table(position)
        mine = {o.name: o for o in k.own_keys}
        out = []
        for o in own_keys():
            if o.name not in mine:
                if o.name in d:
                    having = " or ".join(repr(x.name) for x in kinds_with(o.name))
                    raise ScenarioError(f"{key}.{o.name}", f"only for race = {having} (this one is {k.name!r})",
                                        source)
                continue
            if o.name not in d:
                if not o.required:
                    continue
                raise ScenarioError(f"{key}.{o.name}", f"missing ({o.doc})", source)
            reason = k.check_own_key(o.name, d[o.name], bearing)
            if reason:
                raise ScenarioError(f"{key}.{o.name}", reason, source)
            out.append((o.name, d[o.name]))
        return tuple(out)

    def _tracks(self, defects, source: str) -> tuple:
        if not isinstance(defects, list) or not all(isinstance(d, dict) for d in defects):
            raise ScenarioError("defects", "must be an array of tables ([[defects]])", source)
        out, names = [], set()
        for i, d in enumerate(defects):
            key = f"defects[{i}]"
            _table(key, d, source, _DEFECT_KEYS)
            for k in ("name", "bearing", "race", "length_m", "depth_m"):
                if k not in d:
                    raise ScenarioError(f"{key}.{k}", "missing", source)
            name = _string(f"{key}.name", d["name"], source)
            if not name.strip() or name in names:
                raise ScenarioError(f"{key}.name", f"must be a unique, non-empty name (got {name!r})", source)
            names.add(name)
            bearing = _string(f"{key}.bearing", d["bearing"], source, ("de", "nde"))
            race = _string(f"{key}.race", d["race"], source, KINDS)
            own = self._own_keys(key, d, kind(race), source, bearing)
            angle = _number(f"{key}.angle_deg", d.get("angle_deg", 0.0), source, -360.0, 360.0)
            edge = _string(f"{key}.edge", d.get("edge", EDGE_PROFILES[0]), source, EDGE_PROFILES)
            edge_fraction = _number(f"{key}.edge_fraction", d.get("edge_fraction", 0.1), source, 0.0, 1.0)
            growth = _string(f"{key}.growth", d.get("growth", "linear"), source, GROWTH)
            tname, t = _time_points(key, d, source, self.duration_s)
            length = _array(f"{key}.length_m", d["length_m"], source, 0.0, strict_lo=True)
            depth = _array(f"{key}.depth_m", d["depth_m"], source, 0.0)
            for k, vals in (("length_m", length), ("depth_m", depth)):
                if len(vals) != len(t):
                    raise ScenarioError(f"{key}.{k}", f"needs one value per time in {tname}: {len(t)} (got "
                                        f"{len(vals)})", source)
            if growth == "exponential":
                for k, vals in (("length_m", length), ("depth_m", depth)):
                    if len(vals) > 1 and any(v <= 0 for v in vals):
                        raise ScenarioError(f"{key}.{k}", "must be > 0 everywhere with growth = 'exponential' "
                                            "(geometric between points)", source)
            out.append(DefectTrack(name=name, bearing=bearing, race=race, own=own, angle_deg=angle, edge=edge,
                                   edge_fraction=edge_fraction, time_s=tuple(t), length_m=tuple(length),
                                   depth_m=tuple(depth), growth=growth, key=key))
        return tuple(out)

    # -- states --
    def _boundaries(self) -> list[float]:
        times = {0.0}
        for tr in self.tracks:
            times.update(tr.boundaries(self.size_step, self.duration_s))
        if self.load_points is not None:
            times.update(t for t in self.load_points[0] if t <= self.duration_s)
        return sorted(times)

    def load_factor_at(self, t_s: float) -> float:
        """Radial load factor at scenario time ``t_s`` [s] (steps; 1 without a load profile)."""
        if self.load_points is None:
            return 1.0
        times, values = self.load_points
        i = bisect.bisect_right(times, t_s) - 1
        return float(values[max(i, 0)])

    def defects_at(self, t_s: float) -> list[dict]:
        """The scenario's defects present at scenario time ``t_s`` [s] with their sizes *on the timeline* (not
        quantised into states), as ``[[defects]]`` tables of a case plus ``name``."""
        out = []
        for tr in self.tracks:
            size = tr.size_at(t_s)
            if size is None:
                continue
            d = {"name": tr.name, "bearing": tr.bearing, "race": tr.race, "length_m": size[0], "depth_m": size[1],
                 "angle_deg": tr.angle_deg, "edge": tr.edge, "edge_fraction": tr.edge_fraction}
            d.update(tr.own)
            out.append(d)
        return out

    def _make_states(self, source: str) -> list[ScenarioState]:
        bounds = self._boundaries()
        if len(bounds) > MAX_STATES:
            raise ScenarioError("scenario.size_step", f"{self.size_step:g} cuts the timeline into {len(bounds)} "
                                f"states, more than {MAX_STATES} (each is a model to prepare): use a larger step",
                                source)
        base = self.case.raw
        base_defects = [dict(d, name=f"defects[{i}]") for i, d in enumerate(base["defects"])]
        states: list[ScenarioState] = []
        for t in bounds:
            defects = base_defects + self.defects_at(t)
            load = self.load_factor_at(t)
            key = (tuple(tuple(sorted(d.items())) for d in defects), load)
            if states and (tuple(tuple(sorted(d.items())) for d in states[-1].defects), states[-1].load_factor) == key:
                continue
            raw = copy.deepcopy(base)
            raw["defects"] = [{k: v for k, v in d.items() if k != "name"} for d in defects]
            raw["case"]["name"] = f"{base['case']['name']}"
            scale_radial_load(raw, load)
            try:
                case = Case.from_dict(raw, f"{source or self.name} at {t:g} s")
            except CaseError as exc:
                raise ScenarioError(self._key_of(exc.key, defects, t), f"{exc.reason} (state at scenario time "
                                    f"{t:g} s = {t / _HOURS:.4g} h)", source) from None
            if states:
                states[-1] = _with_end(states[-1], t)
            states.append(ScenarioState(index=len(states), start_s=t, end_s=math.inf, defects=tuple(defects),
                                        load_factor=load, label=_label(defects, load), case=case))
        return states

    def _key_of(self, case_key: str, defects, t: float) -> str:
        """A key of a state's case -> the key of this file (the defect's table, or the load profile)."""
        if case_key.startswith("defects[") and "]" in case_key:
            i = int(case_key[8:case_key.index("]")])
            rest = case_key[case_key.index("]") + 1:]
            name = defects[i]["name"] if i < len(defects) else ""
            for tr in self.tracks:
                if tr.name == name:
                    return f"{tr.key}{rest}"
            return f"scenario.case ({case_key})"
        if case_key == "excitation.gravity_m_s2" or case_key.endswith(".applied_radial_load_n"):
            return "load.load_factor"
        return f"scenario.case ({case_key})"

    # -- evaluation --
    def state_index_at(self, t_s: float) -> int:
        """Index of the state at scenario time ``t_s`` [s] (0 before the start, the last after the end)."""
        return max(bisect.bisect_right(self._starts, float(t_s)) - 1, 0)

    def state_at(self, t_s: float) -> ScenarioState:
        return self.states[self.state_index_at(t_s)]

    @property
    def has_speed(self) -> bool:
        return self.speed_points is not None

    def speed_hz(self, t_s) -> np.ndarray | float:
        """Shaft speed [Hz] at scenario time(s) ``t_s`` [s] (linear between the points, held after the last).
        Raises ScenarioError when the scenario has no ``[speed]``."""
        if self.speed_points is None:
            raise ScenarioError("speed", "this scenario has no [speed] profile", self.source)
        times, values = self.speed_points
        out = np.interp(np.asarray(t_s, dtype=float), times, values)
        return float(out) if np.ndim(out) == 0 else out

    @property
    def scenario_hash(self) -> str:
        """SHA-256 (16 hex digits) of the parsed timeline and the machine's case hash: the scenario's identity ("" for
        :meth:`of_case`)."""
        if not self.name:
            return ""
        blob = json.dumps({"scenario": self.raw, "case": self.case.case_hash}, sort_keys=True,
                          separators=(",", ":"), default=str).encode()
        return hashlib.sha256(blob).hexdigest()[:16]

    def ground_truth(self, state: ScenarioState, t_s: float, speed_hz: float | None = None,
                     time_scale: float | None = None) -> dict:
        """What a labelled data set needs at scenario time ``t_s`` [s] in ``state`` (the state whose model is in
        the signal): :meth:`Case.ground_truth` of the state's case (every defect with kind, bearing, size, fault
        frequency multiplier; the baseline; healthy), each defect with its scenario ``name`` and, with
        ``speed_hz``, its ``fault_frequency_hz`` and ``strike_frequency_hz`` [Hz]; the scenario's name, hash,
        labels, the state (index, label, start [s]), the load factor and ``scenario_time_s``."""
        gt = state.case.ground_truth()
        for d, sd in zip(gt["defects"], state.defects):
            d["name"] = sd["name"]
        add_frequencies(gt, speed_hz)
        gt.update({"scenario": self.name, "scenario_hash": self.scenario_hash, "labels": dict(self.labels),
                   "state_index": state.index, "state_label": state.label, "state_start_s": state.start_s,
                   "scenario_time_s": float(t_s), "load_factor": state.load_factor,
                   "time_scale": None if time_scale is None else float(time_scale)})
        gt["healthy"] = state.healthy
        return gt

    def to_dict(self) -> dict:
        """Summary for metadata: name, description, source, hash, case, duration, the states."""
        return {"name": self.name, "description": self.description, "source": self.source,
                "scenario_hash": self.scenario_hash, "case": self.case.name, "case_source": self.case.source,
                "duration_s": self.duration_s if math.isfinite(self.duration_s) else None, "size_step": self.size_step, "labels": dict(self.labels),
                "speed": None if self.speed_points is None else {"time_s": list(self.speed_points[0]),
                                                                  "speed_hz": list(self.speed_points[1])},
                "states": [s.to_dict() for s in self.states]}

    # -- loading --
    @classmethod
    def of_case(cls, case: Case) -> "Scenario":
        """A machine that does not change: one state (the case with its own defects), no speed or load profile,
        no name (its ground truth has ``scenario`` ""), open-ended."""
        self = cls.__new__(cls)
        self.raw, self.source, self.name = {}, case.source, ""
        self.description = f"the case {case.name} alone"
        self.duration_s, self.size_step = math.inf, DEFAULT_SIZE_STEP
        self.case, self.labels, self.speed_points, self.load_points, self.tracks = case, {}, None, None, ()
        defects = tuple(dict(d, name=f"defects[{i}]") for i, d in enumerate(case.raw["defects"]))
        self.states = [ScenarioState(index=0, start_s=0.0, end_s=math.inf, defects=defects, load_factor=1.0,
                                     label=_label(defects, 1.0), case=case)]
        self._starts = [0.0]
        return self

    @classmethod
    def from_dict(cls, raw: dict, source: str = "", base_dir: Path | None = None) -> "Scenario":
        return cls(raw, source, base_dir)

    @classmethod
    def from_toml(cls, text: str, source: str = "", base_dir: Path | None = None) -> "Scenario":
        return cls(parse_toml(text, source, ScenarioError), source, base_dir)

    @classmethod
    def load(cls, name_or_path: str | Path) -> "Scenario":
        """The embedded scenario ``name`` (:func:`embedded_scenarios`) or a TOML file by path; a relative case path
        inside the file is relative to the file."""
        text, source, base = read_scenario_text(name_or_path)
        return cls.from_toml(text, source, base)


def read_scenario_text(name_or_path: str | Path) -> tuple[str, str, Path | None]:
    """(text, source, base directory) of an embedded scenario or a file; ScenarioError if neither."""
    return read_input_text(name_or_path, "scenarios", "scenario", "scenario", ScenarioError)


def _with_end(state: ScenarioState, end_s: float) -> ScenarioState:
    return ScenarioState(index=state.index, start_s=state.start_s, end_s=end_s, defects=state.defects,
                         load_factor=state.load_factor, label=state.label, case=state.case)


def add_frequencies(gt: dict, speed_hz: float | None) -> dict:
    """Each defect of a ground truth (:meth:`Case.ground_truth`) gets ``fault_frequency_hz`` and
    ``strike_frequency_hz`` [Hz] at shaft speed ``speed_hz`` [Hz] (nothing when None); returns ``gt``."""
    gt["shaft_speed_hz"] = None if speed_hz is None else float(speed_hz)
    for d in gt["defects"]:
        d.setdefault("name", "")
        if speed_hz is not None:
            d["fault_frequency_hz"] = d["fault_multiplier"] * float(speed_hz)
            d["strike_frequency_hz"] = d["strike_multiplier"] * float(speed_hz)
    return gt


def embedded_scenarios() -> list[str]:
    """Names of the scenarios shipped inside the package (machine and fleet scenarios)."""
    return embedded_names("scenarios")
