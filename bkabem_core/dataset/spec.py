"""Data-set specs: a TOML file that names a grid or a seeded random sample of runs, validated key by key.

A data set is a list of **runs**; each run is one machine (the base case with the run's defects and load, or a
scenario of the fault library) rendered under one speed or speed profile, with its own noise, slip and seed, for
``duration_s`` at ``sample_rate_hz``. The spec (``docs/datasets.md``) says which runs::

    [dataset]
    name = "kinds"
    schema_version = 1
    case = "motor_6010_healthy"     # the base machine: each run's defects replace its [[defects]]
    sampling = "grid"               # "grid": every combination of [grid]; "random": `runs` draws from [random]
    seed = 7                        # master seed: the draws and every run's seed derive from it
    replicates = 2                  # grid: runs per grid point, each with its own seed

    [run]                           # fixed values of any run parameter (else its default, PARAMETERS)
    duration_s = 1.0
    sample_rate_hz = 25600.0

    [grid]                          # a list of values per parameter; the runs are their Cartesian product
    fault = ["healthy", "outer", "inner", "ball"]
    speed_hz = [15.0, 25.0]

    [output]
    compression = "none"
    mcap = false

Every run's case is built and validated here (:meth:`Case.from_dict`, with the plausibility bounds), so a spec
that loads renders to its end; a scenario is loaded once per name. Bad input raises :class:`DatasetSpecError`
naming the key (``grid.depth_m[2]``, ``random.slip.max``) and the reason, one line.

A run's identity is the hash of its resolved parameters and of its case (or scenario) hash
(:attr:`Run.run_hash`): the same spec gives the same runs, the same seeds and the same hashes, whatever the
engine, the worker count or the order. Nothing here renders or writes. Units: SI (s, Hz, m, deg where named).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bkabem_core.bearing.defects.profiles import EDGE_PROFILES, SHAPES
from bkabem_core.bearing.defects.registry import KINDS, kind, own_keys
from bkabem_core.model.case import Case, CaseError, InputFileError, parse_toml, read_input_text, scale_radial_load
from bkabem_core.model.vocabulary import BEARINGS

SCHEMA_VERSION = 1
#: Version of the run files' layout and of the run hash; part of every run hash.
FORMAT_VERSION = 1
MAX_RUNS = 1_000_000
SAMPLINGS = ("grid", "random")
QUANTITY_NAMES = ("acceleration", "displacement", "velocity")
COMPRESSIONS = ("none", "snappy", "zstd", "lz4")
ACCELEROMETERS = ("none", "stud", "adhesive", "magnet", "probe", "case")
MAX_DURATION_S = 3600.0
#: Bounds of the noise densities (as `bkabem synth`: beyond them float32 samples overflow).
MAX_NOISE = {"noise_acc": 1e3, "noise_disp": 1e-2, "noise_vel": 1e5}


class DatasetSpecError(InputFileError):
    """A data-set spec is invalid. ``key`` is the dotted key at fault, ``reason`` says why."""


# --------------------------------------------------------------------------- the run parameters
@dataclass(frozen=True)
class Parameter:
    """One run parameter: its kind (``float``, ``int``, ``str``, ``bool``, ``quantities``), unit, default, bounds."""

    kind: str
    unit: str
    default: object
    lo: float | None = None
    hi: float | None = None
    strict_lo: bool = False
    choices: tuple = ()
    doc: str = ""


PARAMETERS: dict[str, Parameter] = {
    "fault": Parameter("str", "", "healthy", doc=f"healthy, or defects joined by '+': {', '.join(KINDS)}, each "
                       "optionally with its bearing (nde:inner); e.g. 'outer+inner', 'de:outer+nde:ball'"),
    "bearing": Parameter("str", "", "de", choices=BEARINGS, doc="bearing of the defects that name none"),
    "length_m": Parameter("float", "m", 2.0e-3, 0.0, 20e-3, strict_lo=True, doc="defect length (along the race)"),
    "depth_m": Parameter("float", "m", 50.0e-6, 0.0, 2e-3, strict_lo=True, doc="defect depth"),
    "angle_deg": Parameter("float", "deg", -90.0, -360.0, 360.0,
                           doc="defect position: outer race fixed (-90 = bottom, in the load zone), inner race at "
                               "shaft angle 0"),
    **{k.name: Parameter(k.type, k.unit, k.default, k.lo, None, doc=k.doc) for k in own_keys()},
    "edge": Parameter("str", "", EDGE_PROFILES[0], choices=EDGE_PROFILES, doc="edge profile of the defects"),
    "shape": Parameter("str", "", SHAPES[0], choices=SHAPES,
                       doc="defect shape: slot (across the ball track) or round_pit (length_m is its diameter; the "
                           "contact can bridge it; edge must be 'ball')"),
    "speed_hz": Parameter("float", "Hz", 25.0, 0.0, None, strict_lo=True,
                          doc="constant shaft speed (or give profile)"),
    "profile": Parameter("str", "", None, doc="speed profile over run time: constant:F, ramp:F0:F1:T, "
                         "steps:F1,F2,...:T (Hz, s); instead of speed_hz"),
    "load_factor": Parameter("float", "", 1.0, 0.1, 10.0, doc="radial load / the case's own (gravity and the "
                             "radial loads applied at the bearings scaled)"),
    "load_hp": Parameter("float", "hp", None, 0.0, None,
                         doc="a rig's load: the shaft speed follows from the case's load table (cwru_rig: 0-3 hp at "
                             "1797-1730 r/min; bkabem_core.model.load_table), unless speed_hz or profile gives it"),
    "radial_load_n": Parameter("float", "N", None, 0.0, 1e7,
                               doc="a rig's radial load on its loaded bearing, the one whose applied_radial_load_n "
                                   "the case gives (mfpt_rig: the test bearing, 0-300 lbf = 0-1334 N)"),
    "noise_acc": Parameter("float", "m/s^2/sqrt(Hz)", None, 0.0, MAX_NOISE["noise_acc"],
                           doc="accelerometer noise density (default: the case's measurement section, else 0)"),
    "noise_disp": Parameter("float", "m/sqrt(Hz)", 0.0, 0.0, MAX_NOISE["noise_disp"],
                            doc="proximity-probe noise density"),
    "noise_vel": Parameter("float", "mm/s/sqrt(Hz)", 0.0, 0.0, MAX_NOISE["noise_vel"], doc="velocity noise density"),
    "slip": Parameter("float", "", None, 0.0, 0.1, doc="random slip: std of the ball-pass interval / its mean "
                      "(default: the case's measurement section, else 0)"),
    "seed": Parameter("int", "", None, 0, float(2 ** 63 - 1),
                      doc="seed of slip and noise (default: derived from dataset.seed and the run index)"),
    "duration_s": Parameter("float", "s", 1.0, 0.0, MAX_DURATION_S, strict_lo=True, doc="signal length"),
    "sample_rate_hz": Parameter("float", "Hz", None, 0.0, 1.0e6, strict_lo=True,
                                doc="sample rate (default: the case's measurement section, else 25600)"),
    "quantities": Parameter("quantities", "", ("acceleration",),
                            doc="channels: acceleration (housing, m/s^2), displacement (shaft to housing, m), "
                                "velocity (housing, mm/s); each gives DE/NDE x vertical/horizontal"),
    "accelerometer": Parameter("str", "", None, choices=ACCELEROMETERS,
                               doc="mounting resonance of the accelerometer (bkabem_core.synth.sensors; default and "
                                   "'case': the case's measurement section, else none)"),
    "anti_alias": Parameter("bool", "", None, doc="the acquisition's anti-alias low-pass (fs / 2.56, 6th order; "
                                                  "default: the case's measurement section, else none)"),
    "chunk_s": Parameter("float", "s", 1.0, 0.0, 10.0, strict_lo=True,
                         doc="synthesis block and Parquet row group; a scenario's states change at its borders"),
    "scenario": Parameter("str", "", None, doc="a scenario of the fault library (embedded name or TOML path) "
                          "instead of fault/bearing/size/load"),
    "time_scale": Parameter("float", "", 1.0, 1e-3, 1e7, doc="scenario seconds per second of signal"),
    "scenario_start_s": Parameter("float", "s", 0.0, 0.0, None, doc="scenario time of the first sample"),
}
#: Parameters that describe the defects or the load (not with a scenario, which has its own).
MACHINE_PARAMETERS = ("fault", "bearing", "length_m", "depth_m", "angle_deg", *(k.name for k in own_keys()), "edge",
                      "shape", "load_factor", "load_hp", "radial_load_n")
SCENARIO_ONLY = ("time_scale", "scenario_start_s")

_TOP = ("dataset", "run", "grid", "random", "output")
_DATASET_KEYS = ("name", "description", "schema_version", "case", "sampling", "seed", "runs", "replicates")
_OUTPUT_KEYS = ("compression", "mcap")


def _measurement_defaults(params: dict, case) -> None:
    """The run parameters of the acquisition that the spec leaves out (None), from the case's ``[measurement]``
    section (bkabem_core.synth.measurement): its rate, noise density and slip as numbers, its mounting and
    anti-alias filter as ``"case"`` / None (the synthesiser takes them from the case); without the section, the
    values of a spec that gives none (25.6 kHz, no noise, no slip, no sensor, no filter)."""
    m = case.raw.get("measurement") or {}
    if params["slip"] is None:
        params["slip"] = float(m.get("slip", 0.0))
    if params["sample_rate_hz"] is None:
        params["sample_rate_hz"] = float(m.get("sample_rate_hz", 25600.0))
    if params["noise_acc"] is None:
        params["noise_acc"] = float(m.get("noise_density_m_s2_per_sqrt_hz", 0.0))
    if params["accelerometer"] is None or (params["accelerometer"] == "case" and not
                                           ("mounting" in m or "mounting_resonance_hz" in m)):
        params["accelerometer"] = "case" if ("mounting" in m or "mounting_resonance_hz" in m) else "none"
    if params["anti_alias"] is None and "anti_alias_hz" not in m:
        params["anti_alias"] = False


# --------------------------------------------------------------------------- reading helpers
def _type_name(v) -> str:
    return f"{type(v).__name__} {v!r}"


def _table(key: str, v, source: str, allowed) -> dict:
    if not isinstance(v, dict):
        raise DatasetSpecError(key, f"must be a table (got {_type_name(v)})", source)
    for k in v:
        if k not in allowed:
            raise DatasetSpecError(f"{key}.{k}" if key else k, f"unknown key (allowed: {', '.join(allowed)})", source)
    return v


def _int(key: str, v, source: str, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise DatasetSpecError(key, f"must be an integer (got {_type_name(v)})", source)
    if lo is not None and v < lo:
        raise DatasetSpecError(key, f"must be >= {lo} (got {v})", source)
    if hi is not None and v > hi:
        raise DatasetSpecError(key, f"must be <= {hi} (got {v})", source)
    return v


def check_value(name: str, key: str, v, source: str = ""):
    """The value ``v`` of run parameter ``name`` checked and normalised (raises naming ``key``)."""
    p = PARAMETERS[name]
    if p.kind == "float":
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise DatasetSpecError(key, f"must be a number [{p.unit or '1'}] (got {_type_name(v)})", source)
        x = float(v)
        if not math.isfinite(x):
            raise DatasetSpecError(key, f"must be finite (got {v})", source)
        if p.lo is not None and (x <= p.lo if p.strict_lo else x < p.lo):
            raise DatasetSpecError(key, f"must be {'>' if p.strict_lo else '>='} {p.lo:g} {p.unit} (got {x:g})",
                                   source)
        if p.hi is not None and x > p.hi:
            raise DatasetSpecError(key, f"must be <= {p.hi:g} {p.unit} (got {x:g})", source)
        return x
    if p.kind == "int":
        return _int(key, v, source, None if p.lo is None else int(p.lo), None if p.hi is None else int(p.hi))
    if p.kind == "bool":
        if not isinstance(v, bool):
            raise DatasetSpecError(key, f"must be true or false (got {_type_name(v)})", source)
        return v
    if p.kind == "str":
        if not isinstance(v, str) or not v.strip():
            raise DatasetSpecError(key, f"must be a non-empty string (got {_type_name(v)})", source)
        if p.choices and v not in p.choices:
            raise DatasetSpecError(key, f"must be one of {', '.join(map(repr, p.choices))} (got {v!r})", source)
        if name == "fault":
            parse_fault(v, "de", key, source)
        if name == "profile":
            _check_profile(key, v, source)
        return v
    if p.kind == "quantities":                       # a list of names, or one comma-separated string
        items = [s.strip() for s in v.split(",")] if isinstance(v, str) else v
        if not isinstance(items, list) or not items or not all(isinstance(s, str) for s in items):
            raise DatasetSpecError(key, f"must be a list of {', '.join(QUANTITY_NAMES)} (got {_type_name(v)})",
                                   source)
        for s in items:
            if s not in QUANTITY_NAMES:
                raise DatasetSpecError(key, f"unknown quantity {s!r} (use {', '.join(QUANTITY_NAMES)})", source)
        if len(set(items)) != len(items):
            raise DatasetSpecError(key, f"names a quantity twice ({items})", source)
        return tuple(items)
    raise AssertionError(p.kind)


def parse_fault(text: str, bearing: str, key: str = "fault", source: str = "") -> list[tuple[str, str]]:
    """``"healthy"`` -> ``[]``; ``"outer+nde:ball"`` -> ``[("de", "outer"), ("nde", "ball")]`` (``bearing`` for the
    defects that name none)."""
    s = text.strip().lower()
    if s == "healthy":
        return []
    out = []
    for tok in s.split("+"):
        tok = tok.strip()
        b, _, name = tok.rpartition(":")
        b = b or bearing
        if name not in KINDS or b not in BEARINGS:
            raise DatasetSpecError(key, f"{text!r}: each defect is {', '.join(KINDS[:-1])} or {KINDS[-1]}, "
                                   f"optionally as de:KIND or nde:KIND, joined by '+'; or 'healthy' (got {tok!r})",
                                   source)
        if (b, name) in out:
            raise DatasetSpecError(key, f"{text!r}: names the {name} defect of the {b.upper()} bearing twice", source)
        out.append((b, name))
    return out


def _check_profile(key: str, text: str, source: str):
    from bkabem_core.synth.profile import SynthError, parse_profile

    if text.strip().lower().endswith(".csv"):
        raise DatasetSpecError(key, "a CSV profile is not part of the spec's identity: use constant:, ramp: or "
                               "steps: (or a scenario's [speed])", source)
    try:
        return parse_profile(text)
    except SynthError as exc:
        raise DatasetSpecError(key, f"{text!r}: {exc.reason}", source) from None


# --------------------------------------------------------------------------- a run
@dataclass(frozen=True)
class Run:
    """One run of a data set.

    Attributes
    ----------
    index : int
        Position in the spec's run list (0-based); the file name starts with it.
    params : dict
        Every run parameter (PARAMETERS), resolved: fixed, drawn or gridded value, else the default; ``seed`` set.
    case_hash : str
        The run's machine: its case hash, or for a scenario its scenario hash.
    run_hash : str
        SHA-256 (16 hex) of the format version, the parameters and ``case_hash``: the run's identity.
    """

    index: int
    params: dict
    case_hash: str
    run_hash: str
    case_raw: dict | None = field(default=None, repr=False, compare=False)
    scenario_path: str | None = field(default=None, repr=False, compare=False)

    @property
    def run_id(self) -> str:
        return f"{self.index:06d}_{self.run_hash}"

    @property
    def is_scenario(self) -> bool:
        return self.params.get("scenario") is not None


def derive_seed(master: int, index: int) -> int:
    """Seed of run ``index`` from the master seed (numpy SeedSequence: independent streams, < 2^63)."""
    return int(np.random.SeedSequence([int(master), int(index)]).generate_state(1, np.uint64)[0] >> np.uint64(1))


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=list)


# --------------------------------------------------------------------------- the spec
class DatasetSpec:
    """A parsed and validated data-set spec (module docstring) and its runs.

    Attributes
    ----------
    name, description, source : str
    sampling : {"grid", "random"}
    seed : int
        Master seed.
    base_case : Case
    runs : list of Run
    compression : str
        Parquet codec of the waveform files' channel columns (``speed_hz`` and ``state`` take snappy under
        ``"none"``: :class:`bkabem_core.dataset.render.RunFile`).
    mcap : bool
        Also write an MCAP recording per run.
    spec_hash : str
        SHA-256 (16 hex) of the parsed spec and its runs' hashes.
    """

    def __init__(self, raw: dict, source: str = "", base_dir: Path | None = None):
        if not isinstance(raw, dict):
            raise DatasetSpecError("dataset", "the file is not a TOML table", source)
        self.raw = copy.deepcopy(raw)
        self.source = source
        self.base_dir = base_dir
        _table("", raw, source, _TOP)
        if "dataset" not in raw:
            raise DatasetSpecError("dataset", "missing section ([dataset] with name, schema_version)", source)
        ds = _table("dataset", raw["dataset"], source, _DATASET_KEYS)
        for k in ("name", "schema_version"):
            if k not in ds:
                raise DatasetSpecError(f"dataset.{k}", "missing", source)
        if not isinstance(ds["name"], str) or not ds["name"].strip():
            raise DatasetSpecError("dataset.name", f"must be a non-empty string (got {_type_name(ds['name'])})",
                                   source)
        self.name = ds["name"]
        self.description = ds.get("description", "")
        if not isinstance(self.description, str):
            raise DatasetSpecError("dataset.description", f"must be a string (got {_type_name(self.description)})",
                                   source)
        v = ds["schema_version"]
        if isinstance(v, bool) or v != SCHEMA_VERSION:
            raise DatasetSpecError("dataset.schema_version", f"must be {SCHEMA_VERSION} (got {v!r})", source)
        self.sampling = ds.get("sampling", "grid")
        if self.sampling not in SAMPLINGS:
            raise DatasetSpecError("dataset.sampling", f"must be one of {', '.join(map(repr, SAMPLINGS))} (got "
                                   f"{self.sampling!r})", source)
        self.seed = _int("dataset.seed", ds.get("seed", 0), source, 0, 2 ** 63 - 1)
        case_ref = ds.get("case", "motor_6010_healthy")
        if not isinstance(case_ref, str) or not case_ref.strip():
            raise DatasetSpecError("dataset.case", f"must be a case name or TOML path (got {_type_name(case_ref)})",
                                   source)
        self.base_case = self._load_case(case_ref)
        out = _table("output", raw.get("output", {}), source, _OUTPUT_KEYS)
        self.compression = out.get("compression", "none")
        if self.compression not in COMPRESSIONS:
            raise DatasetSpecError("output.compression", f"must be one of {', '.join(map(repr, COMPRESSIONS))} "
                                   f"(got {self.compression!r})", source)
        self.mcap = out.get("mcap", False)
        if not isinstance(self.mcap, bool):
            raise DatasetSpecError("output.mcap", f"must be true or false (got {_type_name(self.mcap)})", source)
        fixed = self._fixed(raw.get("run", {}))
        points = self._points(ds, fixed)
        self._scenarios: dict[str, object] = {}
        self._scenario_paths: dict[str, str] = {}
        self._cases: dict[str, Case] = {}
        self.runs = [self._make_run(i, key_of, p) for i, (key_of, p) in enumerate(points)]
        self.spec_hash = hashlib.sha256(_canonical({"spec": self.raw, "runs": [r.run_hash for r in self.runs]})
                                        .encode()).hexdigest()[:16]

    # -- sections --
    def _load_case(self, ref: str) -> Case:
        try:
            if (ref.endswith(".toml") or "/" in ref) and self.base_dir is not None and not Path(ref).is_absolute():
                return Case.load(self.base_dir / ref)
            return Case.load(ref)
        except CaseError as exc:
            raise DatasetSpecError("dataset.case", f"{exc.key}: {exc.reason}", self.source) from None

    def _fixed(self, table) -> dict:
        _table("run", table, self.source, tuple(PARAMETERS))
        return {k: check_value(k, f"run.{k}", v, self.source) for k, v in table.items()}

    def _points(self, ds: dict, fixed: dict) -> list[tuple[dict, dict]]:
        """``(key of each given parameter, values)`` per run, before defaults."""
        src = self.source
        other = "random" if self.sampling == "grid" else "grid"
        if other in self.raw:
            raise DatasetSpecError(other, f"only with dataset.sampling = {other!r} (this spec samples "
                                   f"{self.sampling!r})", src)
        if self.sampling == "grid":
            if "runs" in ds:
                raise DatasetSpecError("dataset.runs", "only with sampling = 'random' (a grid has as many runs "
                                       "as combinations x replicates)", src)
            reps = _int("dataset.replicates", ds.get("replicates", 1), src, 1, MAX_RUNS)
            grid = _table("grid", self.raw.get("grid", {}), src, tuple(PARAMETERS))
            axes = []
            for k, values in grid.items():
                key = f"grid.{k}"
                if k in fixed:
                    raise DatasetSpecError(key, "also given in [run]: give a parameter in one place", src)
                if not isinstance(values, list) or not values:
                    raise DatasetSpecError(key, f"must be a non-empty list of values (got {_type_name(values)})", src)
                axes.append((k, [(f"{key}[{i}]", check_value(k, f"{key}[{i}]", v, src))
                                 for i, v in enumerate(values)]))
            n = reps
            for _, vals in axes:
                n *= len(vals)
            if n > MAX_RUNS:
                raise DatasetSpecError("grid", f"{n} runs, more than {MAX_RUNS}", src)
            if "seed" in grid and reps > 1:
                raise DatasetSpecError("dataset.replicates", "replicates differ by their seed: not with grid.seed",
                                       src)
            points = []
            for combo in itertools.product(*[vals for _, vals in axes]):
                for _ in range(reps):
                    keys = {k: "run." + k for k in fixed}
                    values = dict(fixed)
                    for (k, _), (key, v) in zip(axes, combo):
                        keys[k], values[k] = key, v
                    points.append((keys, values))
            return points
        # random
        if "replicates" in ds:
            raise DatasetSpecError("dataset.replicates", "only with sampling = 'grid' (draw more runs instead)", src)
        if "runs" not in ds:
            raise DatasetSpecError("dataset.runs", "missing (how many runs to draw)", src)
        n = _int("dataset.runs", ds["runs"], src, 1, MAX_RUNS)
        table = _table("random", self.raw.get("random", {}), src, tuple(PARAMETERS))
        draws = []
        for k, d in table.items():
            key = f"random.{k}"
            if k in fixed:
                raise DatasetSpecError(key, "also given in [run]: give a parameter in one place", src)
            draws.append((k, key, self._distribution(k, key, d)))
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([self.seed, 0x5EED])))
        points = []
        for _ in range(n):
            keys = {k: "run." + k for k in fixed}
            values = dict(fixed)
            for k, key, dist in draws:
                keys[k], values[k] = key, dist(rng)
            points.append((keys, values))
        return points

    def _distribution(self, name: str, key: str, d):
        """A draw function for ``[random] name = [choices]`` or ``{min, max, log}``."""
        src = self.source
        p = PARAMETERS[name]
        if isinstance(d, list):
            if not d:
                raise DatasetSpecError(key, "must be a non-empty list of choices or a table {min, max, log}", src)
            vals = [check_value(name, f"{key}[{i}]", v, src) for i, v in enumerate(d)]
            return lambda rng: vals[int(rng.integers(len(vals)))]
        if not isinstance(d, dict):
            raise DatasetSpecError(key, f"must be a list of choices or a table {{min, max, log}} (got "
                                   f"{_type_name(d)})", src)
        if p.kind not in ("float", "int"):
            raise DatasetSpecError(key, f"{name} is not a number: give a list of choices", src)
        _table(key, d, src, ("min", "max", "log"))
        for k in ("min", "max"):
            if k not in d:
                raise DatasetSpecError(f"{key}.{k}", "missing", src)
        lo = check_value(name, f"{key}.min", d["min"], src)
        hi = check_value(name, f"{key}.max", d["max"], src)
        if not hi >= lo:
            raise DatasetSpecError(f"{key}.max", f"must be >= min ({d['max']!r} < {d['min']!r})", src)
        log = d.get("log", False)
        if not isinstance(log, bool):
            raise DatasetSpecError(f"{key}.log", f"must be true or false (got {_type_name(log)})", src)
        if log and not lo > 0:
            raise DatasetSpecError(f"{key}.min", f"must be > 0 with log = true (got {lo:g})", src)
        if p.kind == "int":
            if log:
                raise DatasetSpecError(f"{key}.log", f"{name} is an integer: uniform only", src)
            return lambda rng: int(rng.integers(int(lo), int(hi) + 1))
        if log:
            a, b = math.log(lo), math.log(hi)
            return lambda rng: float(min(max(math.exp(a + (b - a) * rng.random()), lo), hi))
        return lambda rng: float(lo + (hi - lo) * rng.random())

    # -- runs --
    def _make_run(self, index: int, keys: dict, given: dict) -> Run:
        src = self.source
        params = {k: (p.default if k not in given else given[k]) for k, p in PARAMETERS.items()}
        if params["seed"] is None:
            params["seed"] = derive_seed(self.seed, index)
        where = f" (run {index})"

        def key(k):
            return keys.get(k, f"run.{k}")

        if "profile" in given and "speed_hz" in given:
            raise DatasetSpecError(key("profile"), "give speed_hz or profile, not both" + where, src)
        if params["scenario"] is not None:
            for k in MACHINE_PARAMETERS:
                if k in given:
                    raise DatasetSpecError(key(k), "not with a scenario (its timeline sets defects and load)" + where,
                                           src)
            scenario = self._scenario(params["scenario"], key("scenario"))
            if scenario.has_speed:
                for k in ("speed_hz", "profile"):
                    if k in given:
                        raise DatasetSpecError(key(k), f"scenario {scenario.name!r} has its own [speed] profile"
                                               + where, src)
                params["speed_hz"] = None
            machine_hash, case = scenario.scenario_hash, scenario.case
            for k in MACHINE_PARAMETERS:
                params[k] = None
        else:
            for k in SCENARIO_ONLY:
                if k in given:
                    raise DatasetSpecError(key(k), "only with a scenario" + where, src)
                params[k] = None
            if params["fault"] == "healthy":
                for k in ("length_m", "depth_m", "angle_deg", *(o.name for o in own_keys()), "edge", "shape",
                          "bearing"):
                    params[k] = None                    # no defect: sizes would be labels of nothing
            case = self._run_case(params, keys, where)
            machine_hash = case.case_hash
        _measurement_defaults(params, case)
        if params["load_hp"] is not None:                  # the rig's load sets its speed (its load table) ...
            try:
                speed = case.speed_at_load_hz(params["load_hp"])
            except ValueError as exc:
                raise DatasetSpecError(key("load_hp"), f"{exc}{where}", src) from None
            if "speed_hz" not in given and "profile" not in given:
                params["speed_hz"] = speed                 # ... unless the run gives the speed measured at it
        if params["profile"] is not None:
            params["speed_hz"] = None
            top = _check_profile(key("profile"), params["profile"], src).max_speed_hz(params["duration_s"])
            speed_key = key("profile")
        else:
            top = params["speed_hz"] or 0.0
            speed_key = key("speed_hz")
        if top > case.max_speed_hz:
            raise DatasetSpecError(speed_key, f"{top:g} Hz is above the case's operating.max_speed_hz "
                                   f"({case.max_speed_hz:g} Hz)" + where, src)
        n = params["duration_s"] * params["sample_rate_hz"]
        if n < 1:
            raise DatasetSpecError(key("duration_s"), f"less than one sample at {params['sample_rate_hz']:g} Hz"
                                   + where, src)
        if int(round(params["chunk_s"] * params["sample_rate_hz"])) < 1:
            raise DatasetSpecError(key("chunk_s"), "less than one sample" + where, src)
        params["quantities"] = list(params["quantities"])
        run_hash = hashlib.sha256(_canonical({"format": FORMAT_VERSION, "params": params, "machine": machine_hash})
                                  .encode()).hexdigest()[:16]
        if params["scenario"] is not None:
            return Run(index=index, params=params, case_hash=machine_hash, run_hash=run_hash,
                       scenario_path=self._scenario_paths[params["scenario"]])
        return Run(index=index, params=params, case_hash=machine_hash, run_hash=run_hash, case_raw=case.raw)

    def _scenario(self, ref: str, key: str):
        from bkabem_core.scenario.timeline import Scenario, ScenarioError

        s = self._scenarios.get(ref)
        if s is None:
            path = ref
            if (ref.endswith(".toml") or "/" in ref) and self.base_dir is not None and not Path(ref).is_absolute():
                path = str(self.base_dir / ref)
            try:
                s = Scenario.load(path)
            except ScenarioError as exc:
                raise DatasetSpecError(key, f"{ref!r}: {exc}", self.source) from None
            self._scenarios[ref] = s
            self._scenario_paths[ref] = str(Path(path).resolve()) if (path.endswith(".toml") or "/" in path) \
                else path
        return s

    def scenario(self, ref: str):
        """The loaded scenario of a run's ``scenario`` parameter."""
        return self._scenario(ref, "scenario")

    def _run_case(self, params: dict, keys: dict, where: str) -> Case:
        """The base case with the run's defects and load, validated (cached by its parameters)."""
        src = self.source
        fkey = keys.get("fault", "run.fault")
        defects = parse_fault(params["fault"], params["bearing"] or "de", fkey, src)
        tables = []
        used = set()
        for b, name in defects:
            k = kind(name)
            t = {"bearing": b, "race": name, "length_m": params["length_m"], "depth_m": params["depth_m"],
                 "angle_deg": params["angle_deg"], "edge": params["edge"], "edge_fraction": 0.1}
            if params["shape"] != SHAPES[0]:         # a slot is the case's default shape: its tables name none
                t["shape"] = params["shape"]
            for o in k.own_keys:                     # the keys only this kind has (a ball defect's ball number)
                reason = k.check_own_key(o.name, params[o.name], self.base_case.bearing_table(b))
                if reason:
                    raise DatasetSpecError(keys.get(o.name, f"run.{o.name}"), reason + where, src)
                t[o.name] = params[o.name]
                used.add(o.name)
            tables.append(t)
        for o in own_keys():
            if o.name not in used:
                params[o.name] = None
        loaded = None
        if params["radial_load_n"] is not None:
            lkey = keys.get("radial_load_n", "run.radial_load_n")
            if params["load_factor"] != 1.0:
                raise DatasetSpecError(lkey, "give radial_load_n or load_factor, not both" + where, src)
            loaded = [b for b in BEARINGS if "applied_radial_load_n" in self.base_case.raw["bearings"][b]]
            if len(loaded) != 1:
                why = "none" if not loaded else "both"
                raise DatasetSpecError(lkey, f"the case's loaded bearing is the one whose applied_radial_load_n it "
                                       f"gives; {why} of {self.base_case.name}'s bearings give it" + where, src)
        ident = _canonical([tables, params["load_factor"], params["radial_load_n"]])
        case = self._cases.get(ident)
        if case is None:
            raw = copy.deepcopy(self.base_case.raw)
            raw["defects"] = tables
            scale_radial_load(raw, params["load_factor"])
            if loaded is not None:                          # the loader's load of this run (load_factor is 1)
                raw["bearings"][loaded[0]]["applied_radial_load_n"] = float(params["radial_load_n"])
            try:
                case = Case.from_dict(raw, f"{self.source or self.name} run")
            except CaseError as exc:
                k = exc.key
                if k.startswith("defects[") and "." in k:
                    k = keys.get(k.split(".", 1)[1], f"run.{k.split('.', 1)[1]}")
                elif k == "excitation.gravity_m_s2":
                    k = keys.get("load_factor", "run.load_factor")
                elif k.endswith(".applied_radial_load_n"):
                    k = keys.get("radial_load_n", keys.get("load_factor", "run.radial_load_n"))
                else:
                    k = f"dataset.case ({k})"
                raise DatasetSpecError(k, f"{exc.reason}" + where, src) from None
            self._cases[ident] = case
        return case

    # -- loading --
    @classmethod
    def from_toml(cls, text: str, source: str = "", base_dir: Path | None = None) -> "DatasetSpec":
        return cls(parse_toml(text, source, DatasetSpecError), source, base_dir)

    @classmethod
    def load(cls, name_or_path: str | Path) -> "DatasetSpec":
        """An embedded spec (:func:`embedded_specs`) by name, or a TOML file by path (relative case, scenario paths
        inside it are relative to the file)."""
        text, source, base = read_input_text(name_or_path, "datasets", "data-set spec", "spec", DatasetSpecError)
        return cls.from_toml(text, source, base)

    def summary(self) -> dict:
        """For the manifest: name, source, sampling, seed, hashes, the number of runs."""
        return {"name": self.name, "description": self.description, "source": self.source,
                "sampling": self.sampling, "seed": self.seed, "case": self.base_case.name,
                "case_hash": self.base_case.case_hash, "spec_hash": self.spec_hash, "runs": len(self.runs),
                "format_version": FORMAT_VERSION, "compression": self.compression, "mcap": self.mcap}


def embedded_specs() -> list[str]:
    """Names of the data-set specs shipped inside the package."""
    from importlib import resources

    try:
        files = resources.files("bkabem_core.embedded").joinpath("datasets").iterdir()
    except FileNotFoundError:
        return []
    return sorted(p.name[:-5] for p in files if p.name.endswith(".toml"))
