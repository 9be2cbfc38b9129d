"""bkabem_ros.recording.mcap_io: ros2-profile MCAP written with the plain ``mcap`` writer, read by rosbags and
mcap_ros2; QoS / type-hash metadata; rotation; crash (kill -9) and recovery; write errors.

Needs the project venv with the ROS 2 wheels (tools/setup_ros.sh .venv): no skipping, a missing
rclpy is a failure.
"""

from __future__ import annotations

import os
import tempfile

import pytest

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="bkabem_ros_log_"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import textwrap  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402
from test_msgs import _truth  # noqa: E402  (a ground truth with two defects, labels)

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import mcap_io  # noqa: E402

pytestmark = pytest.mark.ros

T0 = 1_700_000_000_000_000_000
FS = 51_200.0
N = 5120
ROOT = Path(__file__).resolve().parents[2]


def _block(i: int) -> np.ndarray:
    t = (i * N + np.arange(N)) / FS
    x = np.sin(2 * np.pi * 157.3 * t) + 0.1 * np.cos(2 * np.pi * 3100 * t)
    return np.stack([x, -2.0 * x + 0.25])


def _stamp(i: int) -> int:
    return T0 + int(round(i * N / FS * 1e9))


def _waveform(i: int, loc: str = "de", q: str = "acceleration"):
    return msgs.waveform_message(
        _block(i), sample_rate=FS, first_sample_index=i * N, shaft_speed=2 * math.pi * (10 + i),
        machine_id="m1", location=loc, quantity=q, channel_names=["vertical", "horizontal"],
        stamp=_stamp(i), frame_id=f"{loc}_bearing")


def _spectrum(i: int):
    k = np.arange(0, 8, dtype=float)
    return msgs.spectrum_message(
        k * 89.4, k, np.stack([1e-3 / (1 + k), 2e-3 / (1 + k)]), np.stack([0.1 * k, -0.2 * k]),
        shaft_speed=2 * math.pi * 25.0, machine_id="m1", location="nde", quantity="acceleration",
        channel_names=["vertical", "horizontal"], stamp=_stamp(i), frame_id="nde_bearing", ground_truth=_truth())


def _faults(i: int):
    return msgs.fault_frequencies_message(
        shaft_speed=2 * math.pi * 25.0, ftf=9.9, bpfo=89.4 + i, bpfi=135.6, bsf=58.9,
        machine_id="m1", bearing_designation="6010", defect_bearing="de", defect_length=1.0e-3,
        defect_depth=20e-6, defect_angle=-math.pi / 2, stamp=_stamp(i), frame_id="de_bearing",
        ground_truth=_truth(), bearings=[           # a bearing of its own at each position (bkabem_msgs 0.3.0)
            {"bearing": "de", "designation": "6205", "n_balls": 9, "ball_diameter_m": 7.94e-3,
             "pitch_diameter_m": 39.04e-3, "ftf": 9.96, "bpfo": 89.4 + i, "bpfi": 135.4, "bsf": 58.9},
            {"bearing": "nde", "designation": "6203", "n_balls": 8, "ball_diameter_m": 6.746e-3,
             "pitch_diameter_m": 28.5e-3, "ftf": 9.54, "bpfo": 76.3, "bpfi": 123.7, "bsf": 49.8}])


def _speed(i: int):
    from std_msgs.msg import Float64

    return Float64(data=2 * math.pi * (10.0 + i))


SENSOR_QOS = {"reliability": "best_effort", "depth": 5, "durability": "volatile"}


def _messages(n: int = 6):
    """(topic, type, msg, log_ns, publish_ns, qos) in log-time order, as the node's sink sees them."""
    out = []
    for i in range(n):
        t = _stamp(i)
        out.append(("/m1/speed", "std_msgs/msg/Float64", _speed(i), t + 1000, t, None))
        out.append(("/m1/vibration/de/acceleration", msgs.type_name(_waveform(i)), _waveform(i),
                    t + 2000, t, SENSOR_QOS))
        out.append(("/m1/vibration/nde/displacement", "bkabem_msgs/VibrationWaveform",
                    _waveform(i, "nde", "displacement"), t + 3000, t, SENSOR_QOS))
        if i % 2 == 0:
            out.append(("/m1/vibration/nde/spectrum", "bkabem_msgs/msg/VibrationSpectrum", _spectrum(i),
                        t + 4000, t, SENSOR_QOS))
            out.append(("/m1/vibration/fault_frequencies", "bkabem_msgs/msg/BearingFaultFrequencies",
                        _faults(i), t + 5000, t, SENSOR_QOS))
    return out


def _write(path, items, **opts):
    with mcap_io.McapRecorder(path, **opts) as rec:
        for topic, type_name, m, log_t, pub_t, qos in items:
            # half the messages as objects, half as CDR bytes (a raw subscription's input)
            data = m if log_t % 2000 else serialize_message(m)
            assert rec.add(topic, type_name, data, log_t, pub_t, qos=qos)
    return rec


def _same(decoded, m) -> None:
    for f in m.get_fields_and_field_types():
        want, got = getattr(m, f), getattr(decoded, f)
        if f == "header":
            assert (got.frame_id, got.stamp.sec, got.stamp.nanosec) == (
                want.frame_id, want.stamp.sec, want.stamp.nanosec)
        elif f == "ground_truth":            # nested messages: compared as what a reader gets (two defects, labels)
            assert msgs.ground_truth_dict(got) == msgs.ground_truth_dict(want)
        elif f == "bearings":                # each bearing's kinematics (0.3.0), as a reader gets them
            assert msgs.bearing_kinematics(decoded) == msgs.bearing_kinematics(m)
        elif isinstance(want, (list, tuple)) and want and hasattr(want[0], "get_fields_and_field_types"):
            assert len(got) == len(want), f                # a sequence of messages (DiagnosticStatus[]): each one
            for g, w in zip(got, want):
                _same(g, w)
        elif isinstance(want, (list, tuple)) or hasattr(want, "typecode") or isinstance(want, np.ndarray):
            np.testing.assert_array_equal(np.asarray(got), np.asarray(want), err_msg=f)
        elif isinstance(want, bytes) and len(want) == 1:   # a ROS byte: rclpy gives bytes, rosbags an int
            assert got in (want, want[0]), f
        else:
            assert got == want, f


# ----------------------------------------------------------------------------- layout + readers
def test_file_layout_metadata_and_times(tmp_path):
    from mcap.reader import make_reader
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    path = tmp_path / "run.mcap"
    items = _messages()
    _write(path, items)
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        assert reader.get_header().profile == "ros2"
        s = reader.get_summary()
        assert s.statistics.message_count == len(items)
        by_topic = {c.topic: c for c in s.channels.values()}
        assert set(by_topic) == {t for t, *_ in items}
        for topic, ch in by_topic.items():
            sc = s.schemas[ch.schema_id]
            assert sc.encoding == "ros2msg" and ch.message_encoding == "cdr"
            text = sc.data.decode()
            assert text == msgs.message_definition_text(sc.name)
            if sc.name.startswith("bkabem_msgs/"):
                assert "\nMSG: std_msgs/Header\n" in text and "\nMSG: builtin_interfaces/Time\n" in text
            assert ch.metadata["topic_type_hash"] == msgs.type_hash(sc.name)
            qos = mcap_io.parse_qos_yaml(ch.metadata["offered_qos_profiles"])
            assert len(qos) == 1
            if topic.endswith("speed"):
                assert qos[0]["reliability"] == "reliable" and qos[0]["depth"] == 10
            else:
                assert qos[0]["reliability"] == "best_effort" and qos[0]["depth"] == 5
            assert qos[0]["deadline"] == {"sec": 9223372036, "nsec": 854775807}
        times = [(c.topic, m.log_time, m.publish_time) for _s, c, m in reader.iter_messages(log_time_order=True)]
    assert times == [(t, lt, pt) for t, _ty, _m, lt, pt, _q in items]
    with open(path, "rb") as fh:
        chunks = [r for r in StreamReader(fh, emit_chunks=True).records if isinstance(r, Chunk)]
    assert chunks and all(c.compression == "zstd" for c in chunks)


def test_read_by_rosbags_with_qos_and_hash(tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import QosReliability
    from rosbags.typesys import Stores, get_typestore

    path = tmp_path / "run.mcap"
    items = _messages()
    _write(path, items)
    got: dict[str, list] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
        for conn in reader.connections:
            # rosbags builds the types from the embedded definitions; same RIHS01 as rosidl's
            assert reader.typestore.hash_rihs01(conn.msgtype) == msgs.type_hash(conn.msgtype)
            qos = conn.ext.offered_qos_profiles
            assert len(qos) == 1
            want = QosReliability.RELIABLE if conn.topic.endswith("speed") else QosReliability.BEST_EFFORT
            assert qos[0].reliability == want
        for conn, t, raw in reader.messages():
            got.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    want: dict[str, list] = {}
    for topic, _ty, m, lt, _pt, _q in items:
        want.setdefault(topic, []).append((lt, m))
    assert {k: len(v) for k, v in got.items()} == {k: len(v) for k, v in want.items()}
    for topic in want:
        for (t_got, d), (t_want, m) in zip(got[topic], want[topic]):
            assert t_got == t_want
            _same(d, m)
    wf = [d for _t, d in got["/m1/vibration/de/acceleration"]]
    np.testing.assert_array_equal(msgs.waveform_array(wf[3]), _block(3).astype(np.float32))


def test_read_by_mcap_ros2(tmp_path):
    from mcap_ros2.reader import read_ros2_messages

    path = tmp_path / "run.mcap"
    items = _messages()
    _write(path, items)
    got = [(r.channel.topic, r.log_time_ns, r.publish_time_ns, r.ros_msg) for r in read_ros2_messages(str(path))]
    assert len(got) == len(items)
    for (topic, lt, pt, d), (t2, _ty, m, lt2, pt2, _q) in zip(got, items):
        assert (topic, lt, pt) == (t2, lt2, pt2)
        _same(d, m)


def test_iter_messages_reads_ours_and_rosbag2_written(tmp_path):
    """iter_messages: our files and a rosbag2-style MCAP (rosbags' writer, mcap storage)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    items = _messages(4)
    ours = tmp_path / "ours.mcap"
    _write(ours, items)
    got = list(mcap_io.iter_messages(ours))
    assert [(g.topic, g.log_time) for g in got] == [(t, lt) for t, _ty, _m, lt, _pt, _q in items]
    for g, (_t, ty, m, *_r) in zip(got, items):
        assert g.type_name == msgs.type_name(ty)
        assert type(g.msg) is type(m) and g.msg == m

    store = get_typestore(Stores.ROS2_KILTED)
    for name in ("VibrationWaveform", "VibrationSpectrum", "BearingFaultFrequencies"):
        full = f"bkabem_msgs/msg/{name}"
        store.register(get_types_from_msg(msgs.message_definition_text(full), full))
    bag = tmp_path / "bag"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for topic, ty, m, lt, _pt, _q in items:
            full = msgs.type_name(ty)
            if topic not in conns:
                conns[topic] = w.add_connection(topic, full, typestore=store)
            w.write(conns[topic], lt, serialize_message(m))
    files = list(bag.glob("*.mcap"))
    assert len(files) == 1
    got2 = list(mcap_io.iter_messages(files[0]))
    assert [(g.topic, g.log_time) for g in got2] == [(t, lt) for t, _ty, _m, lt, _pt, _q in items]
    for g, (_t, _ty, m, *_r) in zip(got2, items):
        assert g.msg == m
    s = mcap_io.summary(files[0])
    assert s["topics"]["/m1/vibration/de/acceleration"]["count"] == 4


def test_iter_messages_without_python_types_uses_embedded_schema(tmp_path, monkeypatch):
    """No importable message package (e.g. a viewer machine): decode from the file's schemas."""
    path = tmp_path / "run.mcap"
    items = _messages(2)
    _write(path, items)
    monkeypatch.setattr(mcap_io, "message_class", lambda name: None)
    got = list(mcap_io.iter_messages(path, topics=["/m1/vibration/de/acceleration"]))
    assert len(got) == 2
    np.testing.assert_array_equal(msgs.waveform_array(got[1].msg), _block(1).astype(np.float32))
    assert got[1].msg.first_sample_index == N


# ----------------------------------------------------------------------------- rotation, chunks
def test_rotation_by_size_and_by_duration(tmp_path):
    items = _messages(12)
    rec = _write(tmp_path / "big.mcap", items, rotate_size_bytes=60_000, chunk_size_bytes=20_000)
    assert len(rec.paths) >= 3 and rec.paths[0].name == "big_0.mcap"
    assert not (tmp_path / "big.mcap").exists()
    total = []
    for p in rec.paths:
        assert p.exists()
        got = list(mcap_io.iter_messages(p))      # every file stands alone (schemas + channels)
        assert got
        total += got
    assert [(g.topic, g.log_time) for g in total] == [(t, lt) for t, _ty, _m, lt, _pt, _q in items]

    span_s = (items[-1][3] - items[0][3]) / 1e9          # 12 blocks of 0.1 s
    rec = _write(tmp_path / "dur.mcap", items, rotate_duration_s=0.3)
    assert len(rec.paths) == math.ceil(span_s / 0.3 + 1e-9)
    for p in rec.paths:
        s = mcap_io.summary(p)
        assert s["end_ns"] - s["start_ns"] < 0.3e9
    assert sum(mcap_io.summary(p)["messages"] for p in rec.paths) == len(items)


def test_idle_chunk_is_written_within_chunk_duration(tmp_path):
    """An open recording: what was added more than chunk_duration_s ago is on disk and readable."""
    path = tmp_path / "open.mcap"
    rec = mcap_io.McapRecorder(path, chunk_duration_s=0.3)
    try:
        for i in range(3):
            rec.add("/m1/vibration/de/acceleration", "bkabem_msgs/msg/VibrationWaveform", _waveform(i),
                    _stamp(i), _stamp(i))
        time.sleep(0.45)
        copy = tmp_path / "copy.mcap"
        copy.write_bytes(path.read_bytes())        # the file as a crash would leave it
        res = mcap_io.recover(copy, tmp_path / "fixed.mcap")
        assert res.truncated and res.messages == 3 and res.channels == 1
    finally:
        rec.close()


# ----------------------------------------------------------------------------- kill -9 + recover
CHILD = textwrap.dedent("""
    import sys, time, math
    import numpy as np
    from bkabem_ros.recording import mcap_io
    from bkabem_ros.messages import convert as msgs
    path, rate = sys.argv[1], float(sys.argv[2])
    rec = mcap_io.McapRecorder(path, chunk_duration_s=0.25, chunk_size_bytes=1 << 24)
    x = np.sin(np.arange(2 * 1024) * 0.01).reshape(2, 1024)
    t0 = time.monotonic()
    i = 0
    while True:
        m = msgs.waveform_message(x, sample_rate=10240.0, first_sample_index=i * 1024, shaft_speed=1.0,
                                  machine_id="m", location="de", quantity="acceleration", stamp=10**18 + i)
        rec.add("/vibration/de/acceleration", "bkabem_msgs/msg/VibrationWaveform", m, 10**18 + i, 10**18 + i)
        print(i, time.monotonic(), flush=True)
        i += 1
        time.sleep(max(0.0, t0 + i / rate - time.monotonic()))
""")


def test_kill_9_then_recover_keeps_all_but_the_last_chunk(tmp_path):
    from mcap.reader import make_reader

    path = tmp_path / "killed.mcap"
    rate = 200.0
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(path), str(rate)], stdout=subprocess.PIPE,
                            text=True, cwd=ROOT)
    added: list[tuple[int, float]] = []
    try:
        for line in proc.stdout:
            i, t = line.split()
            added.append((int(i), float(t)))
            if len(added) >= 400:                 # ~2 s of recording, several chunks
                break
        proc.kill()                               # SIGKILL: no close(), no footer
        t_kill = time.monotonic()
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -9
    with pytest.raises(Exception):                # the cut file has no summary / footer
        with open(path, "rb") as fh:
            list(make_reader(fh).iter_messages())

    fixed = tmp_path / "fixed.mcap"
    res = mcap_io.recover(path, fixed)
    assert res.truncated and res.messages > 0
    got = [m.msg.first_sample_index // 1024 for m in mcap_io.iter_messages(fixed)]
    assert got == list(range(len(got)))           # a gap-free prefix
    # everything added more than chunk_duration_s (+ scheduling slack) before the kill is there
    old_enough = [i for i, t in added if t < t_kill - 0.25 - 0.25]
    assert old_enough and got[-1] >= old_enough[-1], (len(got), old_enough[-1])
    print(f"added {len(added)}, recovered {len(got)}, required >= {old_enough[-1] + 1}")
    # the recovered file is complete for the independent readers too
    from rosbags.highlevel import AnyReader
    with AnyReader([fixed]) as reader:
        assert sum(1 for _ in reader.messages()) == len(got)


def test_recover_cli(tmp_path):
    path = tmp_path / "a.mcap"
    _write(path, _messages(2))
    cut = tmp_path / "cut.mcap"
    data = path.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    r = subprocess.run([sys.executable, "-m", "bkabem_ros.cli.record", "--recover", str(cut),
                        str(tmp_path / "ok.mcap")],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "was cut" in r.stdout
    r = subprocess.run([sys.executable, "-m", "bkabem_ros.cli.record", "--recover",
                        str(tmp_path / "nope.mcap"), str(tmp_path / "x.mcap")],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert r.returncode == 2 and "no such file" in r.stderr and len(r.stderr.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- errors
def test_unwritable_path_and_full_disk_raise_one_clear_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(mcap_io.RecorderError, match=r"cannot record to .*file/x\.mcap: Not a directory"):
        mcap_io.McapRecorder(blocker / "x.mcap")
    with pytest.raises(mcap_io.RecorderError, match="No such file or directory"):
        mcap_io.McapRecorder(tmp_path / "missing" / "x.mcap")
    with pytest.raises(mcap_io.RecorderError, match="No space left on device"):
        mcap_io.McapRecorder("/dev/full")


DISK_FULL_CHILD = textwrap.dedent("""
    import resource, signal, sys
    import numpy as np
    from bkabem_ros.recording import mcap_io
    from bkabem_ros.messages import convert as msgs
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)          # writes past the limit fail with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))
    rec = mcap_io.McapRecorder(sys.argv[1], chunk_size_bytes=30_000, compression="none")
    rng = np.random.default_rng(0)
    ok, errors, after = 0, [], 0
    for i in range(100):
        m = msgs.waveform_message(rng.standard_normal((2, 2048)), sample_rate=1e4, first_sample_index=i * 2048,
                                  shaft_speed=1.0, machine_id="m", location="de", quantity="acceleration")
        try:
            if rec.add("/a", "bkabem_msgs/msg/VibrationWaveform", m, i + 1, i + 1):
                ok += 1
            else:
                after += 1
        except mcap_io.RecorderError as exc:
            errors.append(str(exc))
    rec.close()
    print(ok, len(errors), after)
    print(errors[0])
""")


def test_disk_full_mid_recording_stops_cleanly_and_keeps_the_start(tmp_path):
    path = tmp_path / "full.mcap"
    r = subprocess.run([sys.executable, "-c", DISK_FULL_CHILD, str(path)], capture_output=True, text=True,
                       cwd=ROOT, timeout=60)
    assert r.returncode == 0, r.stderr
    counts, err = r.stdout.strip().splitlines()
    ok, n_err, after = map(int, counts.split())
    assert n_err == 1 and 0 < ok < 100 and ok + 1 + after == 100
    assert "stopped: File too large" in err
    res = mcap_io.recover(path, tmp_path / "fixed.mcap")
    assert res.truncated and 0 < res.messages <= ok


def test_sink_reports_once_and_never_raises(tmp_path):
    errors = []
    sink = mcap_io.McapSink(tmp_path / "no" / "dir.mcap", log_error=errors.append)
    sink("/a", "std_msgs/msg/Float64", _speed(0), 1)          # disabled, silent
    sink.close()
    assert len(errors) == 1 and "publishing continues" in errors[0]

    path = tmp_path / "sink.mcap"
    sink = mcap_io.McapSink(path, qos={"/m1/vibration/de/acceleration": SENSOR_QOS}, log_error=errors.append)
    for topic, ty, m, _lt, pt, _q in _messages(5):
        sink(topic, ty, m, pt)
    sink.close()
    assert len(errors) == 1 and sink.dropped == 0
    got = list(mcap_io.iter_messages(path))
    assert len(got) == len(_messages(5))
    meta = {r.topic: r.metadata for r in mcap_io.iter_raw(path)}
    assert mcap_io.parse_qos_yaml(meta["/m1/vibration/de/acceleration"]["offered_qos_profiles"])[0][
        "reliability"] == "best_effort"


def test_qos_yaml_from_rclpy_profile():
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from rosbags.rosbag2.metadata import parse_qos

    text = mcap_io.qos_yaml([qos_profile_sensor_data,
                             QoSProfile(depth=3, reliability=ReliabilityPolicy.RELIABLE,
                                        deadline=Duration(seconds=1, nanoseconds=5))])
    ours = mcap_io.parse_qos_yaml(text)
    theirs = parse_qos(text)
    assert [q["reliability"] for q in ours] == ["best_effort", "reliable"]
    assert [q.depth for q in theirs] == [5, 3]
    assert theirs[1].deadline.sec == 1 and theirs[1].deadline.nsec == 5
    assert text.startswith("- history: keep_last\n  depth: 5\n  reliability: best_effort\n")


# ----------------------------------------------------------------------------- the node's recording
def test_node_recording_read_by_independent_readers(tmp_path):
    """The node with attach_sinks (MCAP + .rrd): rosbags and mcap_ros2 read back exactly what the node
    published (and the speed it received); QoS = the node's publishers'; the .rrd verifies and holds every
    published sample."""
    import rclpy
    from mcap_ros2.reader import read_ros2_messages
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rosbags.highlevel import AnyReader
    from std_msgs.msg import Float64

    from bkabem_ros.node.vibration_node import VibrationNode
    from bkabem_ros.recording.record import attach_sinks
    from bkabem_ros.viewer.rerun_io import rerun_binary

    path, rrd = tmp_path / "node.mcap", tmp_path / "node.rrd"
    published: list = []
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        node = VibrationNode("bkabem", namespace="/m7", context=ctx, start=False, parameter_overrides=[
            Parameter("sample_rate", value=5120.0), Parameter("spectrum_rate", value=2.0)])
        node.add_sink(lambda topic, ty, m, stamp: published.append((topic, ty, m, stamp)))
        detach = attach_sinks(node, record=path, rerun_save=rrd)
        speed = rclpy.create_node("speed_pub", namespace="/m7", context=ctx)
        pub = speed.create_publisher(Float64, "speed", 10)
        speed.create_timer(0.05, lambda: pub.publish(Float64(data=2 * math.pi * 20.0)))
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        ex.add_node(speed)
        node.start()
        t_end = time.monotonic() + 2.5
        while time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.05)
        ex.remove_node(node)
        ex.remove_node(speed)
        detach()
        qos = {p.topic_name: p.qos_profile for p in node.publishers}
        speed.destroy_node()
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)
    want: dict[str, list] = {}
    for topic, ty, m, stamp in published:
        want.setdefault(topic, []).append((ty, m, stamp))
    assert {"/m7/speed", "/m7/vibration/de/acceleration", "/m7/vibration/nde/displacement",
            "/m7/vibration/de/spectrum", "/m7/vibration/fault_frequencies"} <= set(want)
    assert len(want["/m7/vibration/de/acceleration"]) >= 15

    got: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for conn in reader.connections:
            assert reader.typestore.hash_rihs01(conn.msgtype) == msgs.type_hash(conn.msgtype)
            if conn.topic in qos:
                assert conn.ext.offered_qos_profiles[0].depth == qos[conn.topic].depth
                assert conn.ext.offered_qos_profiles[0].reliability.name.lower() == \
                    qos[conn.topic].reliability.name.lower()
        for conn, _t, raw in reader.messages():
            got.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    assert {k: len(v) for k, v in got.items()} == {k: len(v) for k, v in want.items()}
    for topic in want:
        for d, (_ty, m, _s) in zip(got[topic], want[topic]):
            _same(d, m)
    got2: dict[str, list] = {}
    for r in read_ros2_messages(str(path)):
        got2.setdefault(r.channel.topic, []).append(r)
        assert r.channel.metadata["topic_type_hash"] == msgs.type_hash(r.schema.name)
    for topic in want:
        assert len(got2[topic]) == len(want[topic])
        for r, (_ty, m, stamp) in zip(got2[topic], want[topic]):
            _same(r.ros_msg, m)
            assert r.publish_time_ns == stamp
    # the same stream in the .rrd
    v = subprocess.run([rerun_binary(), "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=60)
    assert v.returncode == 0, v.stderr[-2000:]
    from rerun.chunk import RrdReader

    rows: dict[str, int] = {}
    for ch in RrdReader(str(rrd)).stream().collect().stream():
        if not ch.is_static:
            rows[ch.entity_path] = rows.get(ch.entity_path, 0) + ch.num_rows
    waves = want["/m7/vibration/nde/acceleration"]
    assert rows["/nde/acceleration"] == sum(m.samples_per_channel for _ty, m, _s in waves)   # one row per sample
    assert rows["/speed/shaft_hz"] == len(want["/m7/speed"])


def test_sink_skips_a_topic_it_cannot_describe(tmp_path):
    """A type without a .msg definition in this environment: that topic is skipped, the rest recorded."""
    errors = []
    path = tmp_path / "s.mcap"
    sink = mcap_io.McapSink(path, log_error=errors.append)
    sink("/odd", "nonexistent_msgs/msg/Thing", b"\x00\x01\x00\x00", 1)
    sink("/odd", "nonexistent_msgs/msg/Thing", b"\x00\x01\x00\x00", 2)
    sink("/m1/speed", "std_msgs/msg/Float64", _speed(0), 3)
    sink.close()
    assert len(errors) == 1 and "not recording /odd" in errors[0]
    assert [m.topic for m in mcap_io.iter_messages(path)] == ["/m1/speed"]
