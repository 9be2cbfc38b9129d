"""bkabem replay / bkabem record over DDS on loopback: messages and their spacing reproduced,
/clock for sim time, rate / remap / start offset / loop, rosbag2-written files, and the
replay -> record round trip through the graph (raw subscriptions, QoS from the graph).

Every process runs with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, a random ROS_DOMAIN_ID and
ROS_LOG_DIR in a temporary directory. No skipping: a missing rclpy is a failure.
"""

from __future__ import annotations

import os
import random
import tempfile

import pytest
from ros_helpers import random_domain

os.environ["ROS_DOMAIN_ID"] = str(random_domain())
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="bkabem_ros_log_"))

import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import (
    mcap_io,  # noqa: E402
    replay,
)

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
T0 = 1_700_000_000_000_000_000
FS = 10_240.0
N = 1024
# irregular spacing on purpose (s): the replay must reproduce it, not a fixed rate
OFFSETS = [0.0, 0.10, 0.15, 0.35, 0.40, 0.45, 0.70, 0.80, 1.00, 1.05, 1.30, 1.40]
SENSOR = {"reliability": "best_effort", "depth": 10}


def _items():
    from std_msgs.msg import Float64

    out = []
    for i, off in enumerate(OFFSETS):
        t = T0 + int(round(off * 1e9))
        x = np.sin(2 * np.pi * 50 * (i * N + np.arange(N)) / FS)
        wf = msgs.waveform_message(np.stack([x, -x]), sample_rate=FS, first_sample_index=i * N,
                                   shaft_speed=2 * math.pi * i, machine_id="m1", location="de",
                                   quantity="acceleration", channel_names=["vertical", "horizontal"], stamp=t)
        out.append(("/m1/vibration/de/acceleration", "bkabem_msgs/msg/VibrationWaveform", wf, t, SENSOR))
        if i % 2 == 0:
            out.append(("/m1/speed", "std_msgs/msg/Float64", Float64(data=float(i)), t + 1000, None))
    return out


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "in.mcap"
    with mcap_io.McapRecorder(path) as rec:
        for topic, ty, m, t, qos in _items():
            rec.add(topic, ty, m, t, t, qos=qos)
    return path


@pytest.fixture(scope="module")
def ros():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


class Listener:
    """Subscriptions in a spinning thread; records (topic, monotonic receive time, msg)."""

    def __init__(self, ctx, topics: dict[str, type], *, clock: bool = False, sim_time: bool = False):
        from rclpy.parameter import Parameter

        self.node = rclpy.create_node(f"listener_{os.getpid()}_{random.randint(0, 1 << 30)}", context=ctx,
                                      parameter_overrides=[Parameter("use_sim_time", value=sim_time)])
        self.got: list[tuple[str, float, object]] = []
        self.clock: list[int] = []
        self.subs = []
        for topic, cls in topics.items():
            qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
            self.subs.append(self.node.create_subscription(
                cls, topic, lambda m, topic=topic: self.got.append((topic, time.monotonic(), m)), qos))
        if clock:
            from rosgraph_msgs.msg import Clock

            self.subs.append(self.node.create_subscription(
                Clock, "/clock", lambda m: self.clock.append(msgs.stamp_to_ns(m.clock)),
                QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)))
        self.ex = SingleThreadedExecutor(context=ctx)
        self.ex.add_node(self.node)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        while not self._stop.is_set():
            self.ex.spin_once(timeout_sec=0.02)

    def close(self):
        self._stop.set()
        self.thread.join(5)
        self.ex.remove_node(self.node)
        self.node.destroy_node()


def _run_cli(module: str, *args, timeout=90) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *map(str, args)], capture_output=True, text=True,
                          cwd=ROOT, env=dict(os.environ), timeout=timeout)


def test_replay_reproduces_messages_spacing_and_clock(recording, ros):
    from bkabem_msgs.msg import VibrationWaveform
    from std_msgs.msg import Float64

    lis = Listener(ros, {"/m1/vibration/de/acceleration": VibrationWaveform, "/m1/speed_in": Float64},
                   clock=True, sim_time=True)
    try:
        rate = 2.0
        r = _run_cli("bkabem_ros.cli.replay", recording, "--rate", rate, "--clock", 50,
                     "--remap", "/m1/speed:=/m1/speed_in", "--wait-subscribers", 20)
        assert r.returncode == 0, r.stderr[-3000:]
        time.sleep(0.3)
    finally:
        lis.close()
    items = _items()
    waves = [(t, m) for topic, t, m in lis.got if topic.endswith("acceleration")]
    speeds = [(t, m) for topic, t, m in lis.got if topic.endswith("speed_in")]
    want_waves = [m for topic, _ty, m, _t, _q in items if topic.endswith("acceleration")]
    assert [m for _t, m in waves] == want_waves                 # every message, equal, in order
    assert [m.data for _t, m in speeds] == [float(i) for i in range(0, len(OFFSETS), 2)]
    # spacing: receive-time differences = log-time differences / rate
    got_dt = np.diff([t for t, _m in waves])
    want_dt = np.diff(OFFSETS) / rate
    err = np.abs(got_dt - want_dt)
    # (tolerances for a loaded 2-core machine: typical errors are ~1 ms)
    assert np.median(err) < 0.015 and np.percentile(err, 90) < 0.05 and err.max() < 0.15, (got_dt, want_dt)
    total = waves[-1][0] - waves[0][0]
    assert abs(total - OFFSETS[-1] / rate) < 0.1
    # /clock: the recording's time, non-decreasing, every message's log time announced
    clk = np.array(lis.clock)
    assert clk.size > len(OFFSETS)
    assert np.all(np.diff(clk) >= 0)
    log_times = {t for _topic, _ty, _m, t, _q in items}
    assert clk[0] >= T0 and clk[-1] == max(log_times)
    assert len(log_times & set(clk.tolist())) >= 0.9 * len(log_times)
    # between messages the clock advances at ~50 Hz of wall time, i.e. steps of ~rate/50 s
    assert clk.size >= 0.6 * (OFFSETS[-1] / rate) * 50
    # a node with use_sim_time follows /clock
    assert lis.node.get_clock().now().nanoseconds == int(clk[-1])


@pytest.mark.serial                                 # measures time: run alone
def test_start_offset_rate_and_loop_in_process(recording, ros):
    from bkabem_msgs.msg import VibrationWaveform

    node = rclpy.create_node("replayer", context=ros)
    lis = Listener(ros, {"/ns/m1/vibration/de/acceleration": VibrationWaveform})
    try:
        t_end = time.monotonic() + 10
        pub_probe = node.create_publisher(VibrationWaveform, "/ns/m1/vibration/de/acceleration", 10)
        while pub_probe.get_subscription_count() == 0 and time.monotonic() < t_end:
            time.sleep(0.05)
        node.destroy_publisher(pub_probe)
        stop = threading.Event()
        loops = []

        def progress(text):
            if text.startswith("loop"):
                loops.append(text)
                if len(loops) >= 2:
                    stop.set()

        t0 = time.monotonic()
        stats = replay.replay(recording, rate=4.0, start_offset_s=0.7, loop=True, node=node, namespace="/ns",
                              topics=["/m1/vibration/de/acceleration"], wait_for_subscribers_s=10,
                              stop=stop, progress=progress)
        wall = time.monotonic() - t0
        time.sleep(0.3)
    finally:
        lis.close()
        node.destroy_node()
    kept = [i for i, off in enumerate(OFFSETS) if off >= 0.7 - 1e-9]
    assert stats.loops == 2 or (stats.loops == 2 and stop.is_set())
    assert stats.published == {"/ns/m1/vibration/de/acceleration": 2 * len(kept)}
    idx = [m.first_sample_index // N for _topic, _t, m in lis.got]
    assert idx == kept + kept
    one_pass = (OFFSETS[-1] - 0.7) / 4.0
    assert 2 * one_pass - 0.05 < wall < 2 * one_pass + 1.5


def test_replay_of_rosbag2_written_file(tmp_path, ros):
    from bkabem_msgs.msg import VibrationWaveform
    from rclpy.serialization import serialize_message
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    full = "bkabem_msgs/msg/VibrationWaveform"
    store.register(get_types_from_msg(msgs.message_definition_text(full), full))
    bag = tmp_path / "bag"
    items = [it for it in _items() if it[0].endswith("acceleration")]
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/m1/vibration/de/acceleration", full, typestore=store)
        for _topic, _ty, m, t, _q in items:
            w.write(conn, t, serialize_message(m))
    path = next(bag.glob("*.mcap"))
    node = rclpy.create_node("replayer2", context=ros)
    lis = Listener(ros, {"/m1/vibration/de/acceleration": VibrationWaveform})
    try:
        stats = replay.replay(path, rate=10.0, node=node, wait_for_subscribers_s=10)
        time.sleep(0.3)
    finally:
        lis.close()
        node.destroy_node()
    assert stats.messages == len(items)
    assert [m for _topic, _t, m in lis.got] == [m for _topic, _ty, m, _t, _q in items]


def test_replay_then_record_through_the_graph(recording, tmp_path):
    """bkabem record (raw subscriptions, types and QoS from the graph) captures bkabem replay."""
    out = tmp_path / "rec.mcap"
    rec = subprocess.Popen([sys.executable, "-m", "bkabem_ros.cli.record", "--out", str(out), "--namespace", "/m1",
                            "--duration", "30", "--chunk-duration", "0.5"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT, env=dict(os.environ))
    try:
        r = _run_cli("bkabem_ros.cli.replay", recording, "--rate", 4, "--wait-subscribers", 20)
        assert r.returncode == 0, r.stderr[-3000:]
        time.sleep(1.0)
    finally:
        rec.send_signal(2)        # SIGINT: the recorder finishes the file
        out_text, err_text = rec.communicate(timeout=30)
    assert rec.returncode == 0, err_text[-3000:]
    assert "recording /m1/vibration/de/acceleration" in out_text and "recording /m1/speed" in out_text
    got = list(mcap_io.iter_messages(out))
    items = _items()
    by_topic = {}
    for g in got:
        by_topic.setdefault(g.topic, []).append(g.msg)
    assert by_topic["/m1/vibration/de/acceleration"] == [m for t, _ty, m, _lt, _q in items if t.endswith("acceleration")]
    assert [m.data for m in by_topic["/m1/speed"]] == [float(i) for i in range(0, len(OFFSETS), 2)]
    meta = {r.topic: r.metadata for r in mcap_io.iter_raw(out)}
    wf_qos = mcap_io.parse_qos_yaml(meta["/m1/vibration/de/acceleration"]["offered_qos_profiles"])
    assert wf_qos[0]["reliability"] == "best_effort"         # as recorded and republished
    assert mcap_io.parse_qos_yaml(meta["/m1/speed"]["offered_qos_profiles"])[0]["reliability"] == "reliable"
    assert meta["/m1/speed"]["topic_type_hash"] == msgs.type_hash("std_msgs/msg/Float64")
    # log times are receive times: same spacing (/4) as the original, within scheduling noise
    lt = np.array([g.log_time for g in got if g.topic.endswith("acceleration")]) / 1e9
    np.testing.assert_allclose(np.diff(lt), np.diff(OFFSETS) / 4, atol=0.05)


def test_cli_errors_are_one_line_exit_2(tmp_path):
    r = _run_cli("bkabem_ros.cli.replay", tmp_path / "missing.mcap")
    assert r.returncode == 2 and "no such file" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap")
    r = _run_cli("bkabem_ros.cli.replay", bad)
    assert r.returncode == 2 and "not a readable MCAP" in r.stderr
    r = _run_cli("bkabem_ros.cli.replay", bad, "--remap", "nonsense")
    assert r.returncode == 2 and "OLD:=NEW" in r.stderr
