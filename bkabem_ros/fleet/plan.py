"""``bkabem fleet --scenario``: the machines of a fleet scenario (or one machine scenario for all) as node parameters.

:func:`load` reads a fleet scenario (:class:`bkabem_core.scenario.fleet.FleetScenario`: machine ``i`` runs entry
``i mod n``, a case or a scenario, with its labels) or a machine scenario (every machine runs it: their seeds make
them differ). :func:`apply` writes each machine's entry into the parameter overrides of the plan that
:func:`bkabem_ros.fleet.launcher.plan` made (``case``, or ``scenario`` with ``scenario_time_scale`` and ``scenario_start``;
``labels`` = the entry's labels and ``fleet=<name>``), so every message of a machine carries its ground truth and
labels. No rclpy here.
"""

from __future__ import annotations

from bkabem_core.scenario.fleet import FleetEntry, FleetScenario
from bkabem_core.scenario.timeline import Scenario, ScenarioError

__all__ = ["apply", "load"]


def load(ref: str) -> FleetScenario:
    """A fleet scenario, or a machine scenario as a fleet of one entry (ScenarioError naming the key)."""
    try:
        return FleetScenario.load(ref)
    except ScenarioError as exc:
        if not (exc.key == "fleet" and "missing section" in exc.reason):
            raise
    scenario = Scenario.load(ref)                       # a machine scenario: its own errors
    fleet = FleetScenario.__new__(FleetScenario)
    fleet.name, fleet.description, fleet.source = scenario.name, scenario.description, scenario.source
    fleet.entries = [FleetEntry(case=None, scenario=str(ref), time_scale=1.0, start_s=0.0, labels={})]
    return fleet


def apply(machines: list[dict], fleet: FleetScenario, time_scale: float | None = None) -> list[dict]:
    """Each machine's entry of ``fleet`` into its ``overrides`` (in place; returned). ``time_scale`` replaces the
    entries' scenario time scales."""
    for m in machines:
        e = fleet.entry_of(int(m["index"]))
        ov = m["overrides"]
        ov.pop("case", None)
        if e.case is not None:
            ov["case"] = e.case
        else:
            ov["scenario"] = e.scenario
            ov["scenario_time_scale"] = float(time_scale if time_scale is not None else e.time_scale)
            ov["scenario_start"] = float(e.start_s)
        labels = {"fleet": fleet.name, **e.labels}
        ov["labels"] = ",".join(f"{k}={v}" for k, v in labels.items())
        m["entry"] = e.describe()
    return machines
