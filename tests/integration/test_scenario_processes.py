"""Scenarios through processes: the command line (synth, node, fleet) and the helper process that makes models."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest
from scenario_files import defect, scenario_toml, speed_of_timeline
from scenario_files import parse as _toml

from bkabem_core.scenario.models import ModelHelper, ModelPool
from bkabem_core.scenario.timeline import Scenario
from bkabem_core.synth.synthesizer import Synthesizer

pytestmark = pytest.mark.ros

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


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def growth():
    return Scenario.from_toml(GROWTH, "test_growth.toml")


@pytest.fixture(scope="module")
def pool():
    return ModelPool(size=64)


# --------------------------------------------------------------------------- models from the helper process
def test_a_model_made_in_the_helper_process_gives_the_same_samples(growth, pool):
    helper = ModelHelper()
    try:
        st = growth.states[2]
        helper.request(st.case)
        t_end = time.monotonic() + 120
        while not helper.ready(st.case.case_hash):
            assert helper.failed(st.case.case_hash) is None, helper.failed(st.case.case_hash)
            assert time.monotonic() < t_end, "the helper made no model in 120 s"
            time.sleep(0.05)
        there = helper.take(st.case.case_hash)
        assert helper.take(st.case.case_hash) is there           # unpickled once, then shared
        here = pool.get(st.case)
        opts = dict(sample_rate_hz=FS, chunk_s=CHUNK, band_limit="taper", features=False, spectrum="exact",
                    dtype=np.float64, slip=0.01, seed=1)
        a, b = Synthesizer(there, **opts), Synthesizer(here, **opts)
        for f in (20.0, 22.0, 22.0, 30.0):
            np.testing.assert_allclose(a.next_chunk(f).samples, b.next_chunk(f).samples, rtol=1e-9, atol=1e-12)
        # the helper dies while it makes a model: the request fails (no hang), the next one restarts it
        slow = growth.states[-1].case
        helper.request(slow)
        assert helper.pending(slow.case_hash)
        helper._proc.kill()
        t_end = time.monotonic() + 30
        while helper.failed(slow.case_hash) is None:
            assert time.monotonic() < t_end, "a dead helper's request never failed"
            time.sleep(0.05)
        assert "ended" in helper.failed(slow.case_hash) and not helper.busy
        helper.request(slow)
        t_end = time.monotonic() + 120
        while not helper.ready(slow.case_hash):
            assert helper.failed(slow.case_hash) is None and time.monotonic() < t_end
            time.sleep(0.05)
    finally:
        helper.close()


# --------------------------------------------------------------------------- bad scenario files


@pytest.mark.parametrize("command", ["synth", "node", "node -p", "fleet"])
def test_bad_scenario_file_is_one_line_and_exit_2(tmp_path, command):
    bad = tmp_path / "bad.toml"
    bad.write_text(GROWTH.replace("time_s = [1.0, 2.5, 4.0]", "time_s = [1.0, 2.5, 40.0]"))
    args = {"synth": ["synth", "--scenario", str(bad), "--out", str(tmp_path / "x.npz")],
            "node": ["node", "--scenario", str(bad)],
            "node -p": ["node", "--ros-args", "-p", f"scenario:={bad}"],
            "fleet": ["fleet", "--machines", "2", "--scenario", str(bad)]}[command]
    r = subprocess.run([sys.executable, "-m", "bkabem_ros", *args], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and "discovery" not in ln]
    assert len(lines) == 1 and "defects[0].time_s[2]" in lines[0] and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "x.npz").exists()


# --------------------------------------------------------------------------- bkabem synth --scenario
def test_synth_cli_writes_the_ground_truth_of_every_chunk(tmp_path):
    out = tmp_path / "g.npz"
    src = tmp_path / "growth.toml"
    src.write_text(GROWTH)
    r = subprocess.run([sys.executable, "-m", "bkabem_ros", "synth", "--scenario", str(src), "--time-scale", "2",
                        "--rate", str(FS), "--out", str(out), "--band-limit", "taper", "--seed", "3"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    import json

    d = np.load(out)
    meta = json.loads(str(d["metadata"]))
    n_chunks = round(3.0 / CHUNK)                      # 6 s of scenario time at x2
    assert d["chunk_state_index"].size == n_chunks and d["samples"].shape[1] == n_chunks * N
    t = d["chunk_scenario_time_s"]
    np.testing.assert_allclose(t, 2.0 * np.arange(n_chunks) * CHUNK)
    sc = Scenario.from_toml(GROWTH)
    assert list(d["chunk_state_index"]) == [sc.state_index_at(x) for x in t]
    assert list(d["chunk_healthy"]) == [sc.state_at(x).healthy for x in t]
    assert len(meta["states_ground_truth"]) == len(sc.states) and meta["time_scale"] == 2.0
    assert meta["states_ground_truth"][-1]["defects"][1]["name"] == "nde_outer"
    np.testing.assert_allclose(d["speed_hz"][::N][1:], [speed_of_timeline(_toml(GROWTH), 2 * CHUNK * j)
                                                        for j in range(1, n_chunks)], rtol=1e-6)


@pytest.mark.parametrize("rate", ["100", "600"])
def test_synth_cli_too_low_a_rate_for_the_scenario_names_rate(tmp_path, rate):
    """``--band-limit error`` (every line the case keeps, or a refusal; the default for a case that caps its lines):
    the scenario's own speed puts its lines above the Nyquist frequency of ``--rate``: at the first chunk
    (100 Hz) or once the dent's lines appear mid-run (600 Hz: the healthy machine's highest line is ~250 Hz, the
    dented one's ~7 kHz). One line naming the option the user typed (not the library's ``speed_hz``), exit 2, no
    file left."""
    src = tmp_path / "growth.toml"
    src.write_text(GROWTH)
    out = tmp_path / "r.npz"
    r = subprocess.run([sys.executable, "-m", "bkabem_ros", "synth", "--scenario", str(src), "--time-scale", "2",
                        "--rate", rate, "--band-limit", "error", "--out", str(out)], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith(f"bkabem synth: error: --rate: sample rate {rate} Hz is below twice"), lines[0]
    assert "speed_hz" not in lines[0] and "--band-limit taper" in lines[0]
    assert not out.exists()
