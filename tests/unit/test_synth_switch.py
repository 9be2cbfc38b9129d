"""Warm model switches (bkabem_core/synth/switch.py): ``set_model(synth.warm(model))`` gives the samples of
``set_model(model)`` bit for bit, and the chunk after it makes nothing model-specific (no floor transfer, no floor
frames, no speed cells, no line families or kernel plans, no exact solve): the work that would make the first chunk
after a switch cost more than two chunk periods of a streaming node.

The models are the fault library's (healthy, outer race, inner race, ball: one FE, each made like the one before,
as a scenario's helper makes them). No ROS here: the node's path is tests/integration/test_node_scenario.py.
"""

from __future__ import annotations

import json
import pickle
import threading
import time
from contextlib import contextmanager

import numpy as np
import pytest
from scenario_files import defect, scenario_toml

from bkabem_core.fe.modal import SpeedCells
from bkabem_core.model.case import Case
from bkabem_core.scenario.models import ModelHelper, ModelPool
from bkabem_core.scenario.run import BackgroundModels, ScenarioClock, ScenarioDriver, WarmWorker
from bkabem_core.scenario.timeline import Scenario
from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.floor import BroadbandFloor, FloorTransfer
from bkabem_core.synth.lines import LineFamilies
from bkabem_core.synth.render import FusedLines
from bkabem_core.synth.switch import WarmModel
from bkabem_core.synth.synthesizer import Synthesizer

FS = 25600.0
CHUNK = 0.1
KINDS = ("healthy", "inner", "ball", "outer")


@pytest.fixture(scope="module")
def models():
    pool = ModelPool()
    return {k: pool.get(Case.load(f"motor_6010_{k}")) for k in KINDS}


def _synth(model, **kw):
    opts = dict(sample_rate_hz=FS, chunk_s=CHUNK, seed=7, slip=0.01, band_limit="taper", features=False,
                spectrum="exact")
    opts.update(kw)
    s = Synthesizer(model, **opts)
    s.set_noise(noise_density={"acceleration": 2e-4})
    return s


@contextmanager
def _switch_counts():
    """:func:`_counting` with its own patcher."""
    with pytest.MonkeyPatch.context() as mp:
        with _counting(mp) as counts:
            yield counts


@contextmanager
def _counting(monkeypatch):
    """Counts of the model-specific set-up a switch needs, while the block runs."""
    counts = {}

    def count(cls, name, label):
        orig = getattr(cls, name)

        def wrapped(*a, **k):
            counts[label] = counts.get(label, 0) + 1
            return orig(*a, **k)
        monkeypatch.setattr(cls, name, wrapped)

    count(FloorTransfer, "__init__", "floor transfer")
    count(BroadbandFloor, "_seeded", "floor frames")
    count(SpeedCells, "_make", "speed cell")
    count(LineFamilies, "__init__", "line families")
    count(FusedLines, "__init__", "kernel plan")
    count(BkaBem, "response", "exact solve")
    yield counts
    monkeypatch.undo()


def _stream(models, sequence, warm: bool, speeds, **kw):
    """Chunks of a stream that switches to ``sequence[j]`` before chunk ``2 j + 2``."""
    s = _synth(models["healthy"], **kw)
    out = []
    switch = {2 * j + 2: k for j, k in enumerate(sequence)}
    for i, f in enumerate(speeds):
        if i in switch:
            m = models[switch[i]]
            s.set_model(s.warm(m) if warm else m)
        out.append(s.next_chunk(f))
    return out


@pytest.mark.parametrize("spectrum,features", [("exact", False), ("auto", True)])
def test_a_warm_switch_gives_the_samples_of_a_cold_one(models, spectrum, features):
    """healthy -> inner -> ball -> outer -> inner -> healthy, 1 % slip, sensor noise and the broadband floor, at a
    speed that changes every chunk (the warm knot's speed is then not the next knot's: the cells around it serve);
    samples, ground truth and features identical."""
    seq = ["inner", "ball", "outer", "inner", "healthy"]
    speeds = [25.0 + 0.05 * i for i in range(2 * len(seq) + 3)]
    cold = _stream(models, seq, False, speeds, spectrum=spectrum, features=features)
    warm = _stream(models, seq, True, speeds, spectrum=spectrum, features=features)
    for a, b in zip(cold, warm):
        assert np.array_equal(a.samples, b.samples), a.first_sample_index
        assert json.dumps(a.ground_truth, sort_keys=True, default=str) == \
            json.dumps(b.ground_truth, sort_keys=True, default=str)
        assert a.features.keys() == b.features.keys()
        for k in a.features:
            assert json.dumps(a.features[k], default=np.ndarray.tolist) == \
                json.dumps(b.features[k], default=np.ndarray.tolist), k
    assert cold[-1].ground_truth["case"] == "motor_6010_healthy" and cold[3].ground_truth["case"] == "motor_6010_inner"


@pytest.mark.parametrize("spectrum", ["exact", "modal"])
def test_the_chunk_after_a_warm_switch_does_no_set_up(models, monkeypatch, spectrum):
    """Counted: the switch and the chunk after it make no floor transfer, frames, speed cell, line families,
    kernel plan or exact solve when the model is warm; a cold switch makes them (so the counters see them), but
    for the floor transfer, which the models of one machine share."""
    for dst in ("inner", "ball"):
        for warm_it in (True, False):
            s = _synth(models["healthy"], spectrum=spectrum)
            for _ in range(3):
                s.next_chunk(25.0)
            # a copy as the helper process hands it over: no floor transfer, speed cells or solves cached yet
            model = pickle.loads(pickle.dumps(models[dst], protocol=pickle.HIGHEST_PROTOCOL))
            target = s.warm(model) if warm_it else model
            with _counting(monkeypatch) as counts:
                s.set_model(target)
                s.next_chunk(25.0)
                s.next_chunk(25.0)
            if warm_it:
                assert counts == {}, (dst, counts)
                assert target.installed and target.speed_hz == 25.0
            else:
                # the floor transfer is the machine structure's, shared by all its defect models (test_floor):
                # a cold switch between two of them makes none either
                assert counts.get("floor transfer", 0) == 0 and counts.get("line families", 0) == 1, counts
                assert counts.get("speed cell" if spectrum == "modal" else "exact solve", 0) >= 1, counts


def test_a_warm_switch_costs_about_an_ordinary_chunk(models):
    """Timed against ordinary chunks of the same stream (generous: a switch chunk renders both line sets, and the
    machine is shared); before, the chunk after a switch took ~1000 ordinary chunks (the floor's transfer)."""
    s = _synth(models["healthy"])
    s.next_chunk(25.0)                                     # (a warm-up before the first chunk would not fit)
    ordinary, switched = [], []
    for r, dst in enumerate(("inner", "ball", "outer", "inner", "healthy", "ball")):
        w = s.warm(models[dst])
        for _ in range(4):
            t0 = time.perf_counter()
            s.next_chunk(25.0)
            ordinary.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        s.set_model(w)
        s.next_chunk(25.0)
        switched.append(time.perf_counter() - t0)
    typical = float(np.median(ordinary))
    assert min(switched) < 6.0 * typical and float(np.median(switched)) < 10.0 * typical, (switched, typical)


def test_a_warm_model_that_no_longer_fits_is_bound_afresh(models):
    """Other settings after the warm-up (the noise, here), a model installed already, another synthesiser: the
    model is bound as a bare one would be (the same samples as a cold switch)."""
    ref = _synth(models["healthy"])
    s = _synth(models["healthy"])
    other = _synth(models["healthy"])
    for x in (ref, s, other):
        x.next_chunk(25.0)
    w = s.warm(models["inner"])
    assert w.fits(s) and not w.fits(other)
    for x in (ref, s):
        x.set_noise(noise_density={"acceleration": 5e-4})
    assert not w.fits(s)
    ref.set_model(models["inner"])
    s.set_model(w)
    assert not w.installed                                # not installed: bound afresh
    assert np.array_equal(ref.next_chunk(25.0).samples, s.next_chunk(25.0).samples)
    w2 = s.warm(models["ball"])
    s.set_model(w2)
    ref.set_model(models["ball"])
    assert w2.installed
    s.set_model(models["inner"])
    ref.set_model(models["inner"])
    s.set_model(w2)                                        # spent: bound afresh
    ref.set_model(models["ball"])
    for _ in range(2):
        assert np.array_equal(ref.next_chunk(25.0).samples, s.next_chunk(25.0).samples)
    with pytest.raises(Exception, match="model"):
        s.warm("not a model")


def test_warming_in_another_thread_leaves_the_stream_as_it_is(models):
    """A thread warms models while the synthesiser streams: the stream's samples are those of a synthesiser
    without it (the warm-up writes only its new plan), and the warm models then switch as cold ones do."""
    s, ref = _synth(models["healthy"]), _synth(models["healthy"])
    assert np.array_equal(s.next_chunk(25.0).samples, ref.next_chunk(25.0).samples)
    made = []

    def warm_all():
        for k in ("inner", "ball", "outer"):
            made.append(s.warm(models[k]))

    th = threading.Thread(target=warm_all)
    th.start()
    i = 0
    while th.is_alive() or i < 4:
        assert np.array_equal(s.next_chunk(25.0).samples, ref.next_chunk(25.0).samples), i
        i += 1
    th.join()
    for w in made:
        s.set_model(w)
        ref.set_model(w.model)
        assert w.installed
        for _ in range(2):
            assert np.array_equal(s.next_chunk(25.0).samples, ref.next_chunk(25.0).samples)


def test_background_models_count_a_model_as_ready_only_when_it_is_warm_and_warm_ahead(models):
    """The node's provider: the helper process makes the models, the warm worker unpickles and warms them for the
    stream's synthesiser. The driver switches to the first state only when its model is warm (back but not warm:
    no switch, the ground truth has no state yet); the next state's model is warmed ahead, before it is due, and
    switched to exactly at its chunk border; neither switch does any set-up in the chunk after it."""
    sc = Scenario.from_toml(scenario_toml("warm_ahead", duration_s=100.0, defects=[
        defect("d", "de", "outer", time_s=[5.0], length_m=[1.0e-3], depth_m=[20e-6])]))
    s = _synth(models["inner"])
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
        with _switch_counts() as counts:
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
        with _switch_counts() as counts:
            s.set_model(nxt)
            s.next_chunk(25.0)
        assert counts == {} and nxt.installed
        assert drv.ground_truth(due, 25.0)["defects"][0]["race"] == "outer"
    finally:
        gate.set()
        helper.close()
