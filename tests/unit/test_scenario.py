"""Scenarios (issue 12, "Scenarios"): the timeline and its states, the ground truth of every chunk checked against
the timeline by an independent evaluation written here, continuity of the waveform across every change of the
machine, determinism by seed, models made in the helper process, the driver when models come late, bad files.

No ROS here (tests/integration/test_node_scenario.py runs the node).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from scenario_files import check_truth, defect, scenario_toml, speed_of_timeline, truth_of_timeline
from scenario_files import parse as _toml

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case
from bkabem_core.scenario.run import InlineModels, ScenarioClock, ScenarioDriver, ScenarioRun
from bkabem_core.scenario.timeline import MAX_STATES, Scenario, ScenarioError, embedded_scenarios
from bkabem_core.synth.synthesizer import Synthesizer

FS = 12800.0
CHUNK = 0.1
N = int(FS * CHUNK)

GROWTH = scenario_toml(
    "test_growth", duration_s=6.0, size_step=0.25, labels={"purpose": "test"},
    speed=([0.0, 3.0, 6.0], [20.0, 30.0, 25.0]),
    defects=[defect("de_outer", "de", "outer", angle_deg=-90.0, growth="exponential", time_s=[1.0, 2.5, 4.0],
                    length_m=[0.3e-3, 1.0e-3, 2.0e-3], depth_m=[8e-6, 25e-6, 50e-6]),
             defect("nde_outer", "nde", "outer", angle_deg=-90.0, time_s=[3.0, 5.0], length_m=[1.0e-3, 1.5e-3],
                    depth_m=[20e-6, 40e-6])])


#: an inner-race dent appearing in the NDE bearing at 0.4 s, at a constant speed
INNER = scenario_toml("test_growth", duration_s=6.0, size_step=0.25, labels={"purpose": "test"},
                      speed=([0.0, 3.0, 6.0], [25.0, 25.0, 25.0]),
                      defects=[defect("nde_inner", "nde", "inner", time_s=[0.4], length_m=[1.0e-3], depth_m=[30e-6])])


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def growth():
    return Scenario.from_toml(GROWTH, "test_growth.toml")


@pytest.fixture(scope="module")
def pool(growth, cached_pool):
    """A pool holding the models of every state of the scenarios run here (made once: tests/conftest.py)."""
    return cached_pool(growth, Scenario.from_toml(INNER, "inner.toml"))


@pytest.fixture(scope="module")
def growth_run(growth, pool):
    """The test scenario rendered offline at 12.8 kHz, 1 % slip, sensor noise: (chunks, truths, run)."""
    run = ScenarioRun(growth, time_scale=1.0, sample_rate_hz=FS, chunk_s=CHUNK, pool=pool, slip=0.01, seed=3,
                      noise_density={"acceleration": 2e-3}, band_limit="taper", features=False)
    chunks, truths = [], []
    for ch, gt in run.chunks(run.seconds_to_end()):
        chunks.append(np.array(ch.samples))
        truths.append(gt)
    return chunks, truths, run


# --------------------------------------------------------------------------- the timeline
def test_embedded_scenarios_load_and_their_states_follow_the_timeline():
    assert {"de_outer_run_to_failure", "outer_then_inner", "mixed"} <= set(embedded_scenarios())
    from importlib import resources

    rtf = Scenario.load("de_outer_run_to_failure")
    raw = _toml(resources.files("bkabem_core.embedded").joinpath("scenarios", "de_outer_run_to_failure.toml").read_text())
    hours = 3600.0
    assert rtf.duration_s == 12 * hours and rtf.case.name == "motor_6010_healthy"
    assert rtf.states[0].healthy and rtf.states[0].label == "healthy"
    d = raw["defects"][0]
    times = [t * hours for t in d["time_h"]]
    assert rtf.states[1].start_s == times[0]
    # every state: the timeline's sizes at its start (geometric between the points), growth between two states
    # about one size_step, the points themselves exactly
    for st in rtf.states[1:]:
        (name, size), = ((x["name"], x) for x in st.defects)
        t = st.start_s
        i = min(int(np.searchsorted(times, t, side="right") - 1), len(times) - 2)
        s = min((t - times[i]) / (times[i + 1] - times[i]), 1.0)
        want = d["length_m"][i] * (d["length_m"][i + 1] / d["length_m"][i]) ** s
        assert size["length_m"] == pytest.approx(want, rel=1e-9), st.label
        assert st.case.defects()[0].length_m == pytest.approx(want, rel=1e-9)
    starts = [st.start_s for st in rtf.states]
    for t in times:
        assert any(abs(t - s) < 1e-6 for s in starts), f"point {t / hours} h is not a state boundary"
    # a new state every size_step of growth (of the size, at least of a tenth of the largest size; a last step of
    # less than half a step merges into the point that ends it)
    for key in ("length_m", "depth_m"):
        v = np.array([st.defects[0][key] for st in rtf.states[1:]])
        assert np.all(np.diff(v) > 0)
        allowed = 1.5 * rtf.size_step * np.maximum(v[:-1], 0.1 * max(d[key]))
        assert np.all(np.diff(v) <= allowed + 1e-15), key
        assert np.median(np.diff(v) / np.maximum(v[:-1], 0.1 * max(d[key]))) == pytest.approx(rtf.size_step, rel=0.05)
    # state_at: before, inside, after
    assert rtf.state_at(0.0).index == 0 and rtf.state_at(times[0] - 1).index == 0
    assert rtf.state_at(times[0]).index == 1
    assert rtf.state_at(1e9).index == len(rtf.states) - 1
    assert rtf.speed_hz(5 * hours) == 24.6


def test_states_of_a_scenario_with_two_defects_and_their_cases(growth):
    raw = _toml(GROWTH)
    for st in growth.states:
        want = truth_of_timeline(raw, st.start_s)
        assert {d["name"] for d in st.defects} == set(want)
        case_defects = st.case.defects()
        assert len(case_defects) == len(want)
        for d, cd in zip(st.defects, case_defects):
            assert d["length_m"] == pytest.approx(want[d["name"]]["length_m"], rel=1e-9)
            assert (cd.bearing, cd.race) == (d["bearing"], d["race"])
    # the state holds between boundaries; the next state starts where the previous ends
    for a, b in zip(growth.states, growth.states[1:]):
        assert a.end_s == b.start_s
    assert math.isinf(growth.states[-1].end_s)


def test_scenario_without_defects_profile_or_name_of_case():
    sc = Scenario.of_case(Case.load("motor_6010_inner"))
    assert len(sc.states) == 1 and sc.name == "" and sc.scenario_hash == ""
    gt = sc.ground_truth(sc.states[0], 12.0, 25.0, 1.0)
    assert gt["scenario"] == "" and gt["scenario_time_s"] == 12.0
    (d,) = gt["defects"]
    assert d["race"] == "inner" and d["fault_frequency"] == "bpfi"
    assert d["strike_frequency_hz"] == pytest.approx(d["fault_multiplier"] * 25.0)


def test_load_profile_changes_the_fe_and_is_not_reused_by_like():
    text = GROWTH.replace("[[defects]]", "[load]\ntime_s = [0.0, 2.0]\nload_factor = [1.0, 1.8]\n\n[[defects]]", 1)
    sc = Scenario.from_toml(text, "load.toml")
    before, after = sc.state_at(1.5), sc.state_at(2.1)
    assert before.load_factor == 1.0 and after.load_factor == 1.8 and "load x1.8" in after.label
    g0 = before.case.gravity_m_s2
    assert after.case.gravity_m_s2 == pytest.approx(1.8 * g0)
    assert Machine.fe_key(before.case) != Machine.fe_key(after.case)       # the FE's linearisation load differs
    m0, m1 = Machine(before.case), Machine(after.case)
    assert m1.excitation_load_n("de") == pytest.approx(1.8 * m0.excitation_load_n("de"))
    # the FE bearing elements are linearised at the new load (with the 390 N axial preload the pitch-mean vertical
    # stiffness of the 6010 drops by ~5 % when the radial load goes from 495 to 890 N: fewer balls share it)
    assert abs(m1.sites["de"].stiffness_n_m[1] / m0.sites["de"].stiffness_n_m[1] - 1) > 0.01
    truth = sc.ground_truth(after, 2.1)
    assert truth["load_factor"] == 1.8


# --------------------------------------------------------------------------- every chunk's ground truth
def test_ground_truth_of_every_chunk_matches_the_timeline(growth_run):
    chunks, truths, run = growth_run
    raw = _toml(GROWTH)
    assert len(truths) == round(6.0 / CHUNK)
    seen = set()
    for j, gt in enumerate(truths):
        t = j * CHUNK                                     # scenario time of the chunk's first sample (scale 1)
        # the chunk's shaft speed (first sample) is the timeline's speed there
        check_truth(raw, gt, t, run.scenario.size_step, speed_of_timeline(raw, t))
        assert gt["scenario"] == "test_growth" and gt["time_scale"] == 1.0
        seen.add(gt["state_index"])
        # with inline models every state applies at the first chunk border at or after its start
        assert gt["state_index"] == run.scenario.state_index_at(t)
    # every state holding a chunk border was there; the others are shorter than a chunk of scenario time
    for st in run.scenario.states:
        if st.index not in seen:
            assert min(st.end_s, 6.0) - st.start_s < CHUNK, st
    assert len(seen) >= len(run.scenario.states) - 3


# --------------------------------------------------------------------------- continuity
def _render(model, n_chunks, speeds, pool_model_changes=None, **kw):
    synth = Synthesizer(model, sample_rate_hz=FS, chunk_s=CHUNK, initial_speed_hz=speeds[0], **kw)
    out = []
    for j in range(n_chunks):
        if pool_model_changes and j in pool_model_changes:
            synth.set_model(pool_model_changes[j])
        out.append(np.array(synth.next_chunk(speeds[j + 1]).samples, dtype=np.float64))
    return out


def _stream(model, speeds, **kw):
    """The chunks of ``model`` rendered alone, one by one as :func:`_render` renders them (chunk j at
    ``speeds[j + 1]``, from ``speeds[0]``)."""
    synth = Synthesizer(model, sample_rate_hz=FS, chunk_s=CHUNK, initial_speed_hz=speeds[0], **kw)
    for j in range(len(speeds) - 1):
        yield np.array(synth.next_chunk(speeds[j + 1]).samples, dtype=np.float64)


def _continuity(sc, chunks, truths, pool, opts, speeds, exact_blend: bool) -> set:
    """Check every change of state in a rendered run against the old and the new machine rendered alone; returns
    the kinds of change seen (defects before, after)."""
    changes = [j for j in range(1, len(truths)) if truths[j]["state_index"] != truths[j - 1]["state_index"]]
    assert len(changes) >= 5
    w = np.floor(np.arange(N) * (65536.0 / N)) / 65536.0
    kinds = set()
    # each state's machine alone is one stream, carried on as far as the changes need it: a state is the new
    # machine of one change and the old one of the next, and the first k chunks of a stream are the same however
    # many follow (the chunks _render(model, k + 2) gives, without rendering them again for every change)
    alone: dict[int, tuple] = {}

    def render_alone(index: int, n: int) -> list:
        if index not in alone:
            alone[index] = (_stream(pool.get(sc.states[index].case), speeds, **opts), [])
        stream, out = alone[index]
        while len(out) < n:
            out.append(next(stream))
        return out

    for k in changes:
        kinds.add((len(truths[k - 1]["defects"]), len(truths[k]["defects"])))
        c = render_alone(truths[k - 1]["state_index"], k + 2)   # the old machine all along
        b = render_alone(truths[k]["state_index"], k + 2)       # the new machine all along
        for ch in range(chunks[k].shape[0]):
            amp = np.abs(b[k][ch]).max() + np.abs(c[k][ch]).max() + 1e-30
            # before the change the old stream, one chunk after it the new one: same phase (no jump), same slip
            # walk and noise
            np.testing.assert_allclose(chunks[k - 1][ch], c[k - 1][ch], rtol=0, atol=1e-6 * amp)
            np.testing.assert_allclose(chunks[k + 1][ch], b[k + 1][ch], rtol=0, atol=1e-6 * amp)
            # the chunk of the change starts on the old stream and moves to the new one linearly in time (the old
            # model's amplitudes at the chunk's first-sample speed to the new one's at its end speed; at a
            # constant speed exactly the blend of the two streams)
            assert abs(chunks[k][ch][0] - c[k][ch][0]) <= 1e-6 * amp
            blend = (1 - w) * c[k][ch] + w * b[k][ch]
            # (under a changing speed the two differ by the lines' own change of amplitude with the speed within the
            # chunk: up to ~6 % of the largest sample near a resonance at 0.33 Hz per chunk here)
            np.testing.assert_allclose(chunks[k][ch], blend, rtol=0, atol=(2e-6 if exact_blend else 0.1) * amp)
        # no step at the border beyond the old stream's own sample-to-sample change
        step = np.abs(chunks[k][:, 0] - chunks[k - 1][:, -1])
        own = np.abs(np.diff(np.concatenate([c[k - 1], c[k]], axis=1), axis=1)).max(axis=1)
        assert np.all(step <= own * (1 + 1e-6) + 1e-12)
    return kinds


def test_waveform_is_continuous_across_every_change_of_the_machine(growth, growth_run, pool):
    """At every state change (a defect appearing, growing, a second one appearing), under a changing speed with
    slip and noise: the stream is the old machine's stream up to the change and the new machine's one chunk later
    (the same phases: no phase jump), and in between a move from one to the other that starts on the old one."""
    chunks, truths, run = growth_run
    opts = dict(slip=0.01, seed=3, noise_density={"acceleration": 2e-3}, band_limit="taper", features=False)
    raw = _toml(GROWTH)
    speeds = [20.0] + [speed_of_timeline(raw, (j + 1) * CHUNK) for j in range(len(chunks))]
    kinds = _continuity(growth, chunks, truths, pool, opts, speeds, exact_blend=False)
    assert (0, 1) in kinds and (1, 1) in kinds and (1, 2) in kinds          # appears, grows, a second one added


def test_at_constant_speed_the_change_is_exactly_a_blend_of_the_two_streams(pool):
    text = GROWTH.replace("speed_hz = [20.0, 30.0, 25.0]", "speed_hz = [25.0, 25.0, 25.0]")
    sc = Scenario.from_toml(text, "constant.toml")
    opts = dict(slip=0.01, seed=3, noise_density={"acceleration": 2e-3}, band_limit="taper", features=False)
    run = ScenarioRun(sc, sample_rate_hz=FS, chunk_s=CHUNK, pool=pool, **opts)
    got = [(np.array(ch.samples, dtype=np.float64), gt) for ch, gt in run.chunks(run.seconds_to_end())]
    kinds = _continuity(sc, [g[0] for g in got], [g[1] for g in got], pool, opts, [25.0] * (len(got) + 1),
                        exact_blend=True)
    assert (0, 1) in kinds and (1, 2) in kinds


def test_continuity_when_an_inner_race_dent_is_added(pool):
    """An inner-race dent (another line set: BPFI with shaft-order sidebands, ~350 lines) appears in the NDE bearing:
    the same continuity as for a growing dent (at a constant speed: exactly the blend of the two streams)."""
    sc = Scenario.from_toml(INNER, "inner.toml")
    opts = dict(slip=0.01, seed=5, band_limit="taper", features=False)
    run = ScenarioRun(sc, sample_rate_hz=FS, chunk_s=CHUNK, pool=pool, **opts)
    got = [(np.array(ch.samples, dtype=np.float64), gt) for ch, gt in run.chunks(0.8)]
    k = next(j for j, (_, gt) in enumerate(got) if gt["defects"])
    assert k == 4 and got[k][1]["defects"][0]["fault_frequency"] == "bpfi"
    speeds = [25.0] * (len(got) + 1)
    c = _render(pool.get(sc.states[0].case), k + 2, speeds, **opts)
    b = _render(pool.get(sc.states[1].case), k + 2, speeds, **opts)
    w = np.floor(np.arange(N) * (65536.0 / N)) / 65536.0
    for ch in range(got[k][0].shape[0]):
        amp = np.abs(b[k][ch]).max() + np.abs(c[k][ch]).max()
        np.testing.assert_allclose(got[k - 1][0][ch], c[k - 1][ch], rtol=0, atol=1e-6 * amp)
        np.testing.assert_allclose(got[k + 1][0][ch], b[k + 1][ch], rtol=0, atol=1e-6 * amp)
        assert abs(got[k][0][ch][0] - c[k][ch][0]) <= 1e-6 * amp
        np.testing.assert_allclose(got[k][0][ch], (1 - w) * c[k][ch] + w * b[k][ch], rtol=0, atol=2e-6 * amp)
    # and the dent is in the stream from then on: the NDE housing no longer moves as the healthy machine's
    ch = run.synth.channel_names.index("nde_vertical_acceleration")
    assert np.abs(got[k + 1][0][ch] - c[k + 1][ch]).max() > 0.1 * np.abs(c[k + 1][ch]).max()


# --------------------------------------------------------------------------- determinism
def test_same_seed_same_samples_other_seed_other_samples_same_truth(growth, pool, growth_run):
    chunks, truths, _ = growth_run

    def render(seed):
        run = ScenarioRun(growth, sample_rate_hz=FS, chunk_s=CHUNK, pool=pool, slip=0.01, seed=seed,
                          noise_density={"acceleration": 2e-3}, band_limit="taper", features=False)
        return [(np.array(ch.samples), gt) for ch, gt in run.chunks(2.0)]

    again = render(3)
    other = render(4)
    for j, (x, gt) in enumerate(again):
        np.testing.assert_array_equal(x, chunks[j])
        assert gt == truths[j]
    diff = [np.abs(x - chunks[j]).max() for j, (x, _) in enumerate(other)]
    assert max(diff) > 1e-3
    assert [gt["defects"] for _, gt in other] == [t["defects"] for t in truths[:len(other)]]


# --------------------------------------------------------------------------- models from the helper process


class _LateModels(InlineModels):
    """Models that come ``delay`` chunks after they are first asked for (a slow helper)."""

    def __init__(self, pool, delay):
        super().__init__(pool)
        self.delay, self.asked, self.clock_chunk = delay, {}, 0

    def get(self, state):
        first = self.asked.setdefault(state.index, self.clock_chunk)
        return self.pool.get(state.case) if self.clock_chunk - first >= self.delay else None

    def has(self, state):
        return False


def test_driver_holds_the_model_it_has_and_says_so_when_a_model_comes_late(growth, pool):
    models = _LateModels(pool, delay=7)
    clock = ScenarioClock(FS, 1.0)
    drv = ScenarioDriver(growth, clock, models, N)
    applied = []
    for j in range(60):
        models.clock_chunk = j
        drv.before_chunk(j * N)
        gt = drv.ground_truth(j * N, 20.0)
        applied.append(gt["state_index"])
        assert gt["state_index"] == drv.applied.index
        st = growth.states[gt["state_index"]]
        assert [d["length_m"] for d in gt["defects"]] == [d["length_m"] for d in st.defects]
        check_truth(_toml(GROWTH), gt, j * CHUNK, growth.size_step, 20.0, exact=False)
    due = [growth.state_index_at(j * CHUNK) for j in range(60)]
    assert applied[:10] == [0] * 10                      # state 1 is due at chunk 10; its model comes at 17
    assert all(a <= d for a, d in zip(applied, due))     # never ahead of the timeline
    assert applied[-1] == due[-1]                        # it catches up
    assert any("not ready" in e for e in drv.events) and any("came late" in e for e in drv.events)
    assert drv.late


# --------------------------------------------------------------------------- bad scenario files
BAD = [
    ("[scenario]\nname = 'x'\n", "scenario.schema_version"),
    (GROWTH.replace('schema_version = 1', 'schema_version = 7'), "scenario.schema_version"),
    (GROWTH.replace('case = "motor_6010_healthy"', 'case = "no_such_case"'), "scenario.case"),
    (GROWTH.replace("duration_s = 6.0", "duration_s = -1.0"), "scenario.duration_s"),
    (GROWTH.replace("duration_s = 6.0", "duration_s = 6.0\nduration_h = 1.0"), "scenario.duration_h"),
    (GROWTH.replace("size_step = 0.25", "size_step = 0.0"), "scenario.size_step"),
    (GROWTH.replace("size_step = 0.25", "size_step = 1e-6"), "scenario.size_step"),
    (GROWTH.replace("size_step = 0.25", "size_step = 0.25\ncolour = 'red'"), "scenario.colour"),
    (GROWTH + "\n[extra]\nx = 1\n", "extra"),
    (GROWTH.replace("speed_hz = [20.0, 30.0, 25.0]", "speed_hz = [20.0, 30.0]"), "speed.speed_hz"),
    (GROWTH.replace("speed_hz = [20.0, 30.0, 25.0]", "speed_hz = [20.0, 3000.0, 25.0]"), "speed.speed_hz[1]"),
    (GROWTH.replace("time_s = [0.0, 3.0, 6.0]", "time_s = [0.0, 3.0, 2.0]"), "speed.time_s[2]"),
    (GROWTH.replace('race = "outer"\nangle_deg = -90.0\ngrowth', 'race = "cage"\nangle_deg = -90.0\ngrowth'),
     "defects[0].race"),
    (GROWTH.replace("time_s = [1.0, 2.5, 4.0]", "time_s = [1.0, 2.5, 40.0]"), "defects[0].time_s[2]"),
    (GROWTH.replace("length_m = [0.0003, 0.001, 0.002]", "length_m = [0.0003, 0.001]"), "defects[0].length_m"),
    (GROWTH.replace("depth_m = [8e-06, 2.5e-05, 5e-05]", "depth_m = [0.0, 2.5e-05, 5e-05]"), "defects[0].depth_m"),
    (GROWTH.replace("length_m = [0.0003, 0.001, 0.002]", "length_m = [0.0003, 0.001, 0.02]"),
     "defects[0].length_m"),
    (GROWTH.replace('name = "nde_outer"', 'name = "de_outer"'), "defects[1].name"),
    (GROWTH.replace('race = "outer"\nangle_deg = -90.0\ntime_s = [3.0', 'race = "ball"\nangle_deg = -90.0\ntime_s = [3.0'),
     "defects[1].ball"),
    (GROWTH.replace("[labels]\npurpose = \"test\"", "[labels]\npurpose = 3"), "labels.purpose"),
    (GROWTH.replace("[[defects]]", "[load]\ntime_s = [0.0]\nload_factor = [50.0]\n\n[[defects]]", 1),
     "load.load_factor[0]"),
    ("[scenario\nname = 'x'", "toml"),
]


@pytest.mark.parametrize("text, key", BAD, ids=[k for _, k in BAD])
def test_bad_scenario_files_name_the_key(text, key):
    with pytest.raises(ScenarioError) as info:
        Scenario.from_toml(text, "bad.toml")
    assert info.value.key == key, str(info.value)
    assert "\n" not in str(info.value)
    assert str(info.value).startswith("bad.toml: ")


def test_many_states_are_refused():
    text = GROWTH.replace("size_step = 0.25", "size_step = 0.001")
    with pytest.raises(ScenarioError, match=rf"more than {MAX_STATES}") as info:
        Scenario.from_toml(text, "x.toml")
    assert info.value.key == "scenario.size_step"


# --------------------------------------------------------------------------- bkabem synth --scenario


def test_every_input_file_kind_refuses_a_too_deep_nesting_with_one_line():
    """Case, scenario, fleet scenario and data-set spec read TOML through one reader (case.parse_toml): a nesting
    too deep for the parser is the key ``toml`` of each file kind's own error, not a RecursionError."""
    from bkabem_core.dataset.spec import DatasetSpec, DatasetSpecError
    from bkabem_core.model.case import Case, CaseError
    from bkabem_core.scenario.fleet import FleetScenario
    from bkabem_core.scenario.timeline import Scenario, ScenarioError

    deep = "x = " + "[" * 5000 + "]" * 5000 + "\n"
    for load, error in [(Case.from_toml, CaseError), (Scenario.from_toml, ScenarioError),
                        (FleetScenario.from_toml, ScenarioError), (DatasetSpec.from_toml, DatasetSpecError)]:
        with pytest.raises(error) as info:
            load(deep, "deep.toml")
        assert info.value.key == "toml" and "nested too deeply" in info.value.reason


def test_every_input_file_kind_finds_an_embedded_name_or_a_path_the_same_way(tmp_path):
    """Case, scenario, fleet scenario and data-set spec resolve "embedded name or path" with one function
    (case.read_input_text): the same errors, each for its own key and error class - an unknown name lists the
    embedded ones, a missing file, a file that is not UTF-8 (key ``toml``), an empty name - and a bare name that
    is a file here is read as that file."""
    from bkabem_core.dataset.spec import DatasetSpec, DatasetSpecError, embedded_specs
    from bkabem_core.model.case import Case, CaseError, embedded_cases
    from bkabem_core.scenario.fleet import FleetScenario

    binary = tmp_path / "latin1.toml"
    binary.write_bytes(b"name = '\xe9'\n")
    kinds = [(Case.load, CaseError, "case", "case", embedded_cases()),
             (Scenario.load, ScenarioError, "scenario", "scenario", embedded_scenarios()),
             (FleetScenario.load, ScenarioError, "scenario", "scenario", embedded_scenarios()),
             (DatasetSpec.load, DatasetSpecError, "spec", "data-set spec", embedded_specs())]
    for load, error, key, what, names in kinds:
        assert names
        with pytest.raises(error) as info:
            load("no_such_thing")
        assert info.value.key == key and info.value.reason == (
            f"no embedded {what} named 'no_such_thing' (available: {', '.join(names)})")
        with pytest.raises(error) as info:
            load(tmp_path / "missing.toml")
        assert info.value.key == key and info.value.reason == f"file not found: {tmp_path / 'missing.toml'}"
        with pytest.raises(error) as info:
            load(binary)
        assert info.value.key == "toml" and info.value.reason.startswith("not a UTF-8 text file (byte 8:")
        assert info.value.source == str(binary)
        with pytest.raises(error) as info:
            load("  ")
        assert info.value.key == key and info.value.reason == "empty name"
    # a bare name that names a file in the working directory is that file, not an embedded one
    here = tmp_path / "growth"
    here.write_text(GROWTH)
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        sc = Scenario.load("growth")
    finally:
        os.chdir(cwd)
    assert sc.name == "test_growth" and sc.source == "growth"


def test_scenario_ground_truth_has_the_fault_multipliers():
    """A scenario's ground truth states the bearing's fault multipliers, as a constant-speed synth's does."""
    from bkabem_core.bearing.deep_groove import Bearing
    from bkabem_core.scenario.timeline import Scenario

    s = Scenario.load("de_outer_run_to_failure")
    fm = Bearing(s.case.bearing_geometry("de")).fault_multipliers().to_dict()
    for state in (s.states[0], s.states[-1]):
        assert s.ground_truth(state, state.start_s, 24.6)["fault_multipliers"] == fm
