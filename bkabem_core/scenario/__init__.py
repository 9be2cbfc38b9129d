"""Scenarios: a machine over time, defects appearing and growing, speed and load profiles; fleets.

    Scenario        -- a machine over scenario time (module ``timeline``)
    ScenarioState   -- a stretch of scenario time with one machine
    DefectTrack     -- one defect over time
    ScenarioError   -- a scenario file is invalid: the key and why
    ScenarioRun     -- a scenario rendered offline with the ground truth of every chunk (module ``run``)
    ScenarioDriver  -- the state in effect at every chunk border of a stream, and its model
    ModelPool       -- models of a machine's states reusing each other's decompositions (module ``models``)
    FleetScenario   -- which machine of a fleet runs which case or scenario (module ``fleet``)
"""

from bkabem_core._face import lazy_face

__all__ = ["Scenario", "ScenarioState", "DefectTrack", "ScenarioError", "ScenarioRun", "ScenarioDriver", "ModelPool", "FleetScenario"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Scenario": "timeline",
    "ScenarioState": "timeline",
    "DefectTrack": "timeline",
    "ScenarioError": "timeline",
    "ScenarioRun": "run",
    "ScenarioDriver": "run",
    "ModelPool": "models",
    "FleetScenario": "fleet",
})
