"""The node's sample rate against the machine's lines (bkabem_ros/node/band.py, docs/ros_node.md "Band limit"):
real ``bkabem node`` / ``bkabem synth`` processes, DDS on loopback (tests/integration/ros_helpers.py).

* at start, a scenario whose [speed] profile puts a line of its first model at or above Nyquist: the node refuses
  ``sample_rate`` with one line and exit 2, where ``bkabem synth --scenario`` refuses ``--rate`` (the same check);
  the same file at a rate that carries it streams;
* while it runs: a speed (from the topic) or a new model that makes the taper act gives one warning naming
  ``sample_rate`` per event (not per chunk), the stream goes on, and the spectrum says which lines are gone (the
  frequencies against Nyquist are evaluated here, not by the code under test).
"""

from __future__ import annotations

import math
import re
import signal
import subprocess
import time

import numpy as np
import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import Listener, Proc, bkabem_cmd, ros_env, unique_namespace
from scenario_files import capped_case, defect, scenario_toml

pytestmark = pytest.mark.ros

BAND_WARNING = r"WARN.*parameter sample_rate: .* too low for"


def _outer_from_start(speed_hz: float, case: str) -> str:
    """A scenario with a DE outer-race dent from t = 0 at a constant speed (its 50 BPFO orders reach ~50 x 6 x f)."""
    return scenario_toml("band_test", duration_s=100.0, speed=([0.0], [speed_hz]), case=case,
                         defects=[defect("de_outer", "de", "outer", time_s=[0.0], length_m=[1.0e-3],
                                         depth_m=[30e-6])])


def test_a_scenario_rate_too_low_is_refused_at_start_like_synth(tmp_path):
    src = tmp_path / "band.toml"
    src.write_text(_outer_from_start(25.0, capped_case(tmp_path)))
    r = subprocess.run(bkabem_cmd("node", "--scenario", str(src), "--sample-rate", "6400"), env=ros_env(),
                       capture_output=True, text=True, timeout=90)
    assert r.returncode == 2, (r.returncode, r.stdout[-2000:], r.stderr[-2000:])
    err = [ln for ln in r.stderr.splitlines() if "error" in ln.lower()]
    assert len(err) == 1 and "parameter sample_rate: 6400 Hz" in err[0] and "Traceback" not in r.stderr, r.stderr
    # the highest line it names: above Nyquist, as the library says the lines are
    top = float(re.search(r"highest line .*?: ([0-9.]+) Hz at 25 Hz", err[0]).group(1))
    assert top > 3200.0
    need = float(re.search(r"needs sample_rate > ([0-9.]+) Hz", err[0]).group(1))
    assert need == pytest.approx(2 * top, rel=1e-4)
    # bkabem synth refuses the same file at the same rate, naming --rate
    s = subprocess.run(bkabem_cmd("synth", "--scenario", str(src), "--rate", "6400", "--seconds", "0.5",
                                  "--out", str(tmp_path / "x.npz")), capture_output=True, text=True, timeout=90)
    assert s.returncode == 2 and "--rate" in s.stderr and f"{top:.1f} Hz" in s.stderr, s.stderr
    # just above twice the highest line the node starts (as synth would), and warns that the taper fades the top
    # lines (from 0.85 of Nyquist); above 2 x highest / 0.85 it streams every line in full, without a word
    for rate, warned in ((int(need) + 200, True), (int(need / 0.85) + 2000, False)):
        node = Proc(bkabem_cmd("node", "--namespace", unique_namespace("bandok"), "--scenario", str(src),
                               "--sample-rate", str(rate)), name=f"band node {rate}")
        try:
            node.wait_for(r"streaming from t0", timeout=90)
            time.sleep(1.0)
            assert node.p.poll() is None
            assert node.stop(signal.SIGINT) == 0, node.text[-3000:]
        finally:
            node.kill()
        got = [ln for ln in node.lines if re.search(BAND_WARNING, ln)]
        assert len(got) == (1 if warned else 0), (rate, node.text[-3000:])
        if warned:
            assert re.search(r"too low for \d+ of the \d+ lines of scenario 'band_test' state 0 \(DE outer .* at 25 Hz"
                             r" shaft speed: \d+ fade out .* and \d+ are dropped", got[0]), got[0]


def test_speed_into_the_taper_warns_once_per_event_and_streams_on():
    """Case alone at 6400 Hz, speed from the topic: 5 Hz (every line in band), then 30 Hz (most orders above
    Nyquist): one warning however many chunks run at 30 Hz; back to 5 Hz and up again: a second one."""
    from bkabem_msgs.msg import VibrationSpectrum, VibrationWaveform
    from std_msgs.msg import Float64

    fs, chunk = 6400.0, 0.05
    ns = unique_namespace("band")
    lis = Listener("band_listener")
    acc, spec = f"{ns}/vibration/de/acceleration", f"{ns}/vibration/de/spectrum"
    lis.subscribe(acc, VibrationWaveform, reliable=True, depth=5000)
    lis.subscribe(spec, VibrationSpectrum, reliable=True, depth=5000)
    node = Proc(bkabem_cmd("node", "--namespace", ns, "--sample-rate", str(fs), "--chunk-duration", str(chunk),
                           "--qos", "reliable", "--ros-args", "-p", "qos_depth:=200"), name="band node")
    try:
        node.wait_for(r"streaming from t0", timeout=90)
        # the start-up line says up to which speed every line is carried
        limit = float(node.wait_for(r"sample_rate 6400 Hz carries every line of case .* in full up to ([0-9.]+) Hz",
                                    timeout=5).group(1))
        assert 5.0 < limit < 30.0
        pub = lis.publisher(f"{ns}/speed", Float64)
        lis.wait_subscribers(pub)

        def run_at(hz: float, chunks: int) -> None:
            lis.publish_until(pub, Float64(data=2 * math.pi * hz), acc,
                              lambda it: len(it) > 2 and math.isclose(it[-1][1].shaft_speed, 2 * math.pi * hz))
            n = len(lis.get(acc))
            lis.wait_for(acc, lambda it: len(it) >= n + chunks, timeout=30)

        run_at(5.0, 5)
        assert not re.search(BAND_WARNING, node.text), node.text[-3000:]
        run_at(30.0, 20)
        warnings = [ln for ln in node.lines if re.search(BAND_WARNING, ln)]
        assert len(warnings) == 1, warnings
        m = re.search(r"too low for (\d+) of the (\d+) lines .* at ([0-9.]+) Hz shaft speed: (\d+) fade out .* and "
                      r"(\d+) are dropped", warnings[0])
        assert m, warnings[0]
        # the spectrum at 30 Hz (the node's own account of the lines in the waveform): the lines the warning counts
        # as dropped are those at or above 0.95 of Nyquist, and their amplitude is 0 (nothing aliases)
        s30 = next(msg for _, msg in reversed(lis.get(spec))
                   if msg.quantity == "acceleration" and math.isclose(msg.shaft_speed, 2 * math.pi * 30.0))
        f = np.asarray(s30.frequency)
        a = np.asarray(s30.amplitude).reshape(len(s30.channel_names), f.size)
        gone = f >= 0.95 * fs / 2
        assert gone.any() and np.all(a[:, gone] == 0.0)
        assert np.all(a[:, (f > 0) & (f < 0.85 * fs / 2)].max(axis=0) > 0.0)
        warned_speed = float(m.group(3))
        assert int(m.group(5)) == int(np.count_nonzero(f[1:] >= 0.95 * fs / 2)) or warned_speed != 30.0
        # a second event: back into the band, then up again
        run_at(5.0, 5)
        run_at(30.0, 5)
        warnings = [ln for ln in node.lines if re.search(BAND_WARNING, ln)]
        assert len(warnings) == 2, warnings
        # the stream went on through all of it: no gap
        idx = [msg.first_sample_index for _, msg in lis.get(acc)]
        n = int(fs * chunk)
        assert all(b - a_ == n for a_, b in zip(idx, idx[1:]))
        assert node.stop(signal.SIGINT) == 0, node.text[-3000:]
    finally:
        node.kill()
        lis.close()


def test_a_later_scenario_state_beyond_the_rate_warns_and_streams_on(tmp_path):
    """Healthy at start (its lines carried at 6400 Hz: the node starts), a DE outer dent from 1 s: when its model is
    in the signal, one warning naming sample_rate and the state; the stream goes on."""
    from bkabem_msgs.msg import VibrationWaveform

    src = tmp_path / "later.toml"
    src.write_text(scenario_toml("band_later", duration_s=100.0, speed=([0.0], [25.0]), case=capped_case(tmp_path),
                                 defects=[defect("de_outer", "de", "outer", time_s=[1.0], length_m=[1.0e-3],
                                                 depth_m=[30e-6])]))
    ns = unique_namespace("bandl")
    lis = Listener("band_later_listener")
    topic = f"{ns}/vibration/de/acceleration"
    lis.subscribe(topic, VibrationWaveform)
    node = Proc(bkabem_cmd("node", "--namespace", ns, "--scenario", str(src), "--sample-rate", "6400"),
                name="band later node")
    try:
        node.wait_for(r"streaming from t0", timeout=90)
        line = node.wait_for(BAND_WARNING + r".*scenario 'band_later' state 1 \(DE outer", timeout=90).string
        assert "at 25 Hz shaft speed" in line
        n = len(lis.get(topic))
        lis.wait_for(topic, lambda it: len(it) >= n + 10, timeout=30)      # streams on
        assert node.p.poll() is None
        assert node.stop(signal.SIGINT) == 0, node.text[-3000:]
    finally:
        node.kill()
        lis.close()
    assert len([ln for ln in node.lines if re.search(BAND_WARNING, ln)]) == 1, node.text[-3000:]


def test_lines_to_the_band_start_and_stream_without_a_warning():
    """The fault library's run to failure at the default 25.6 kHz: its lines reach 26 kHz at 24.6 Hz, beyond any
    such rate by design (max_order = 0); the node starts (no refusal), says up to where the lines are carried, and
    the taper is no warning."""
    node = Proc(bkabem_cmd("node", "--namespace", unique_namespace("bandlib"), "--scenario", "de_outer_run_to_failure",
                           "--time-scale", "3600"), name="band library node")
    try:
        node.wait_for(r"streaming from t0", timeout=120)
        node.wait_for(r"carries its lines up to the acquisition's band: in full up to 10880 Hz", timeout=5)
        time.sleep(2.0)
        assert node.p.poll() is None
        assert node.stop(signal.SIGINT) == 0, node.text[-3000:]
    finally:
        node.kill()
    assert not [ln for ln in node.lines if re.search(BAND_WARNING, ln)], node.text[-3000:]
