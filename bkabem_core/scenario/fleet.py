"""Fleet scenarios: which machine of a fleet runs which case or scenario, with which labels.

A fleet scenario file (TOML, ``docs/scenarios.md``, "Fleets") has a ``[fleet]`` table and one ``[[fleet.machines]]``
entry per kind of machine; machine ``i`` of a fleet gets entry ``i mod n``:

.. code-block:: toml

    [fleet]
    name = "mixed"
    schema_version = 1

    [[fleet.machines]]
    case = "motor_6010_healthy"             # a case (embedded name or TOML path relative to this file) ...
    labels = { condition = "healthy" }

    [[fleet.machines]]
    scenario = "de_outer_run_to_failure"    # ... or a machine scenario
    scenario_time_scale = 3600.0
    labels = { condition = "run_to_failure" }

Every machine's labels (the entry's, plus ``fleet = <name>``) go into the ground truth of each of its messages.
Nothing here imports ROS; ``bkabem fleet --scenario`` (:mod:`bkabem_ros.fleet.plan`) turns the entries into node
parameters. Bad input raises :class:`~bkabem_core.scenario.timeline.ScenarioError` naming the key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from bkabem_core.model.case import Case, CaseError, parse_toml
from bkabem_core.scenario.run import TIME_SCALE_RANGE
from bkabem_core.scenario.timeline import (
    SCHEMA_VERSION,
    Scenario,
    ScenarioError,
    _number,
    _string,
    _table,
    read_scenario_text,
)

_ENTRY_KEYS = ("case", "scenario", "scenario_time_scale", "scenario_start_s", "scenario_start_h", "labels")


@dataclass(frozen=True)
class FleetEntry:
    """One kind of machine: a case or a scenario (as a name or an absolute path), its time scale and start
    [s of scenario time], its labels."""

    case: str | None
    scenario: str | None
    time_scale: float
    start_s: float
    labels: dict = field(default_factory=dict)

    def describe(self) -> str:
        what = f"scenario {self.scenario} (x{self.time_scale:g})" if self.scenario else f"case {self.case}"
        lab = ", ".join(f"{k}={v}" for k, v in self.labels.items())
        return what + (f" [{lab}]" if lab else "")


class FleetScenario:
    """The machines of a fleet (module docstring). Use :meth:`load` / :meth:`from_toml`.

    Attributes
    ----------
    name, description, source : str
    entries : list of FleetEntry
    """

    def __init__(self, raw: dict, source: str = "", base_dir: Path | None = None):
        if not isinstance(raw, dict) or "fleet" not in raw:
            raise ScenarioError("fleet", "missing section [fleet] (a machine scenario has [scenario]: give it to "
                                "`bkabem node --scenario` or as a fleet entry)", source)
        _table("", raw, source, ("fleet",))
        fl = _table("fleet", raw["fleet"], source, ("name", "description", "schema_version", "machines"))
        for k in ("name", "schema_version", "machines"):
            if k not in fl:
                raise ScenarioError(f"fleet.{k}", "missing", source)
        self.source = source
        self.name = _string("fleet.name", fl["name"], source)
        if not self.name.strip():
            raise ScenarioError("fleet.name", "must not be empty", source)
        self.description = _string("fleet.description", fl.get("description", ""), source)
        v = fl["schema_version"]
        if isinstance(v, bool) or v != SCHEMA_VERSION:
            raise ScenarioError("fleet.schema_version", f"must be {SCHEMA_VERSION} (got {v!r})", source)
        machines = fl["machines"]
        if not isinstance(machines, list) or not machines or not all(isinstance(m, dict) for m in machines):
            raise ScenarioError("fleet.machines", "must be one or more [[fleet.machines]] tables", source)
        self.entries = [self._entry(i, m, source, base_dir) for i, m in enumerate(machines)]

    @staticmethod
    def _ref(ref: str, base_dir: Path | None) -> str:
        if (ref.endswith(".toml") or "/" in ref) and base_dir is not None and not Path(ref).is_absolute():
            return str((base_dir / ref).resolve())
        return ref

    def _entry(self, i: int, m: dict, source: str, base_dir: Path | None) -> FleetEntry:
        key = f"fleet.machines[{i}]"
        _table(key, m, source, _ENTRY_KEYS)
        if ("case" in m) == ("scenario" in m):
            raise ScenarioError(key, "needs a case or a scenario (exactly one of them)", source)
        case = scenario = None
        if "case" in m:
            case = self._ref(_string(f"{key}.case", m["case"], source), base_dir)
            try:
                Case.load(case)
            except CaseError as exc:
                raise ScenarioError(f"{key}.case", str(exc), source) from None
        else:
            scenario = self._ref(_string(f"{key}.scenario", m["scenario"], source), base_dir)
            try:
                Scenario.load(scenario)
            except ScenarioError as exc:
                raise ScenarioError(f"{key}.scenario", str(exc), source) from None
        scale = _number(f"{key}.scenario_time_scale", m.get("scenario_time_scale", 1.0), source, *TIME_SCALE_RANGE)
        if "scenario_start_s" in m and "scenario_start_h" in m:
            raise ScenarioError(f"{key}.scenario_start_h", "give scenario_start_s or scenario_start_h, not both",
                                source)
        start = _number(f"{key}.scenario_start_s", m.get("scenario_start_s", 0.0), source, 0.0)
        if "scenario_start_h" in m:
            start = _number(f"{key}.scenario_start_h", m["scenario_start_h"], source, 0.0) * 3600.0
        if case is not None and ("scenario_time_scale" in m or start):
            raise ScenarioError(key, "scenario_time_scale and scenario_start are for scenario entries", source)
        labels = m.get("labels", {})
        if not isinstance(labels, dict):
            raise ScenarioError(f"{key}.labels", "must be a table of strings", source)
        for k, v in labels.items():
            _string(f"{key}.labels.{k}", v, source)
            if "," in k or "=" in k or "," in v or "=" in v:
                raise ScenarioError(f"{key}.labels.{k}", "labels may not hold ',' or '='", source)
        return FleetEntry(case=case, scenario=scenario, time_scale=scale, start_s=start, labels=dict(labels))

    def entry_of(self, index: int) -> FleetEntry:
        """The entry of machine ``index`` (entries cycled)."""
        return self.entries[index % len(self.entries)]

    @classmethod
    def from_toml(cls, text: str, source: str = "", base_dir: Path | None = None) -> "FleetScenario":
        return cls(parse_toml(text, source, ScenarioError), source, base_dir)

    @classmethod
    def load(cls, name_or_path: str | Path) -> "FleetScenario":
        """An embedded fleet scenario (``mixed``) or a TOML file."""
        text, source, base = read_scenario_text(name_or_path)
        return cls.from_toml(text, source, base)
