"""Warm model switches (bkabem_core/synth/switch.py): ``set_model(synth.warm(model))`` gives the samples of
``set_model(model)`` bit for bit, and the chunk after it makes nothing model-specific (no floor transfer, no floor
frames, no speed cells, no line families or kernel plans, no exact solve): the work that would make the first chunk
after a switch cost more than two chunk periods of a streaming node.

The models are the fault library's (healthy, outer race, inner race, ball: one FE, each made like the one before,
as a scenario's helper makes them). No ROS and no process here: the scenario's helper process is tests/integration/test_scenario_helper.py,
the node's path tests/integration/test_node_scenario.py.
"""

from __future__ import annotations

import json
import pickle
import threading
import time

import numpy as np
import pytest
from switch_check import counting, switch_synth


@pytest.fixture(scope="module")
def models(fault_library):
    """The fault library's models (tests/conftest.py: one machine, each made like the one before)."""
    return fault_library


def _stream(models, sequence, warm: bool, speeds, **kw):
    """Chunks of a stream that switches to ``sequence[j]`` before chunk ``2 j + 2``."""
    s = switch_synth(models["healthy"], **kw)
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
            s = switch_synth(models["healthy"], spectrum=spectrum)
            for _ in range(3):
                s.next_chunk(25.0)
            # a copy as the helper process hands it over: no floor transfer, speed cells or solves cached yet
            model = pickle.loads(pickle.dumps(models[dst], protocol=pickle.HIGHEST_PROTOCOL))
            target = s.warm(model) if warm_it else model
            with counting(monkeypatch) as counts:
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
    """Timed against ordinary chunks of the same stream. The failure it guards against is the chunk after a switch
    paying the floor's transfer again (~1000 ordinary chunks); a switch chunk renders both line sets, so it may
    honestly cost a few, and on a loaded machine (other test workers) single chunks vary by several times: the bound
    is an order of magnitude, the rest is bench/'s job."""
    s = switch_synth(models["healthy"])
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
    assert min(switched) < 20.0 * typical and float(np.median(switched)) < 50.0 * typical, (switched, typical)


def test_a_warm_model_that_no_longer_fits_is_bound_afresh(models):
    """Other settings after the warm-up (the noise, here), a model installed already, another synthesiser: the
    model is bound as a bare one would be (the same samples as a cold switch)."""
    ref = switch_synth(models["healthy"])
    s = switch_synth(models["healthy"])
    other = switch_synth(models["healthy"])
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
    s, ref = switch_synth(models["healthy"]), switch_synth(models["healthy"])
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
