"""The scenario's background models with their real helper process (bkabem_core/scenario/models.py and run.py): a
model counts as ready only once it is back from the helper and warm, the next state's model is warmed ahead, and
neither switch does set-up in the chunk after it. The switches themselves without a process:
tests/unit/test_synth_switch.py."""

from __future__ import annotations

import threading
import time

from scenario_files import defect, scenario_toml
from switch_check import FS, switch_counts, switch_synth

from bkabem_core.model.case import Case
from bkabem_core.scenario.models import ModelHelper, ModelPool
from bkabem_core.scenario.run import BackgroundModels, ScenarioClock, ScenarioDriver, WarmWorker
from bkabem_core.scenario.timeline import Scenario
from bkabem_core.synth.switch import WarmModel


def test_background_models_count_a_model_as_ready_only_when_it_is_warm_and_warm_ahead():
    """The node's provider: the helper process makes the models, the warm worker unpickles and warms them for the
    stream's synthesiser. The driver switches to the first state only when its model is warm (back but not warm:
    no switch, the ground truth has no state yet); the next state's model is warmed ahead, before it is due, and
    switched to exactly at its chunk border; neither switch does any set-up in the chunk after it."""
    sc = Scenario.from_toml(scenario_toml("warm_ahead", duration_s=100.0, defects=[
        defect("d", "de", "outer", time_s=[5.0], length_m=[1.0e-3], depth_m=[20e-6])]))
    s = switch_synth(ModelPool().get(Case.load("motor_6010_inner")))
    s.next_chunk(25.0)
    n = s.chunk_samples
    helper = ModelHelper()
    gate = threading.Event()

    def warm(model):
        gate.wait(60)                                     # held until the test has seen the model back, not warm
        return s.warm(model)

    bg = BackgroundModels(helper, warm=warm, worker=WarmWorker())
    drv = ScenarioDriver(sc, ScenarioClock(FS, 1.0), bg, n, start_applied=False)
    keys = [st.case.case_hash for st in sc.states]
    index = n                                             # stream time 0.1 s: state 0 due, state 1 at 5 s
    try:
        t_end = time.monotonic() + 120
        while not helper.ready(keys[0]):
            assert helper.failed(keys[0]) is None, helper.failed(keys[0])
            assert drv.before_chunk(index) is None and time.monotonic() < t_end, "the helper made no model"
            time.sleep(0.02)
        for _ in range(3):                                # back, but not warm yet: no switch
            assert drv.before_chunk(index) is None and drv.applied is None
        gate.set()
        while (got := drv.before_chunk(index)) is None:
            assert time.monotonic() < t_end, "the warm model never came"
            time.sleep(0.01)
        assert isinstance(got, WarmModel) and got.model.case.case_hash == keys[0] and drv.applied is sc.states[0]
        assert bg.warm_times_s[keys[0]] > 0
        # the next state: made and warmed while state 0 streams, before it is due
        with switch_counts() as counts:
            s.set_model(got)
            s.next_chunk(25.0)
        assert counts == {} and got.installed and s.model is got.model
        while keys[1] not in bg._warmed:
            assert helper.failed(keys[1]) is None and bg.failed(sc.states[1]) is None
            assert drv.before_chunk(index) is None and time.monotonic() < t_end, "state 1 was not warmed ahead"
            time.sleep(0.02)
        due = int(5.0 * FS) // n * n + (n if int(5.0 * FS) % n else 0)
        assert drv.before_chunk(due - n) is None
        nxt = drv.before_chunk(due)
        assert isinstance(nxt, WarmModel) and drv.applied is sc.states[1] and drv.applied_at[1] == due
        with switch_counts() as counts:
            s.set_model(nxt)
            s.next_chunk(25.0)
        assert counts == {} and nxt.installed
        assert drv.ground_truth(due, 25.0)["defects"][0]["race"] == "outer"
    finally:
        gate.set()
        helper.close()
