"""bkabem_msgs + bkabem_ros.messages.convert: types, CDR round trip, MCAP schemas read by mcap_ros2 and rosbags.

Runs with the project's venv python after ``tools/setup_ros.sh .venv`` (nothing to source).
No skipping: a python without the ROS wheels fails here (the set-up installs them).
"""

from __future__ import annotations

import os
import tempfile

import pytest

# Before anything loads rcl: no ~/.ros/log writes, no discovery traffic off loopback.
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="bkabem_ros_log_"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import math  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import rclpy  # noqa: F401,E402  (fail, do not skip, when ROS is missing)
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402

from bkabem_ros.messages import convert as msgs  # noqa: E402

pytestmark = pytest.mark.ros

TYPES = ["VibrationWaveform", "VibrationSpectrum", "BearingFaultFrequencies"]

QOS_YAML = """\
- history: keep_last
  depth: 10
  reliability: reliable
  durability: volatile
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false
"""

T0_NS = 1_700_000_000_123_456_789
N = 4096
FS = 20_000.0


def _block(i: int) -> np.ndarray:
    """Two channels that differ (channel 1 = -2 x channel 0 + offset) so a transposed layout shows."""
    t = (i * N + np.arange(N)) / FS
    x = np.sin(2 * np.pi * 157.3 * t)
    return np.stack([x, -2.0 * x + 0.25])


def _waveform(i: int = 0):
    return msgs.waveform_message(
        _block(i), sample_rate=FS, first_sample_index=i * N, shaft_speed=2 * math.pi * 25.0,
        machine_id="m1", location="de", quantity="acceleration",
        channel_names=["vertical", "horizontal"], stamp=T0_NS + int(i * N / FS * 1e9),
        frame_id="de_sensor")


def _spectrum():
    k = np.arange(0, 6, dtype=float)
    amp = np.stack([1e-6 / (1 + k), 2e-6 / (1 + k)])
    ph = np.stack([0.1 * k, -0.2 * k])
    return msgs.spectrum_message(
        k * 89.4, k, amp, ph, shaft_speed=2 * math.pi * 25.0, machine_id="m1", location="nde",
        quantity="displacement", channel_names=["vertical", "horizontal"], stamp=T0_NS,
        frame_id="nde_sensor", ground_truth=_truth())


def _truth():
    """A ground truth with two defects (a DE outer-race dent, ball 3 of the NDE bearing), a scenario state, labels."""
    from bkabem_core.scenario.timeline import Scenario

    sc = Scenario.from_toml("""
[scenario]
name = "msgs_test"
schema_version = 1
case = "motor_6010_healthy"
duration_s = 10.0
[labels]
line = "7"
[[defects]]
name = "de_outer"
bearing = "de"
race = "outer"
angle_deg = -90.0
time_s = [1.0]
length_m = [1.0e-3]
depth_m = [20e-6]
[[defects]]
name = "nde_ball"
bearing = "nde"
race = "ball"
ball = 3
time_s = [2.0]
length_m = [0.8e-3]
depth_m = [10e-6]
""")
    return msgs.ground_truth_message(sc.ground_truth(sc.state_at(5.0), 5.0, 25.0, 60.0), {"site": "a"})


def _faults():
    return msgs.fault_frequencies_message(
        shaft_speed=2 * math.pi * 25.0, ftf=9.9, bpfo=89.4, bpfi=135.6, bsf=58.9,
        machine_id="m1", bearing_designation="6205", defect_bearing="de",
        defect_length=1.0e-3, defect_depth=20e-6, defect_angle=-math.pi / 2, stamp=T0_NS,
        frame_id="de_bearing", ground_truth=_truth())


# ----------------------------------------------------------------------------- types
def test_types_import_and_constants():
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationSpectrum, VibrationWaveform

    assert VibrationWaveform.LOCATION_DE == "de" and VibrationWaveform.LOCATION_NDE == "nde"
    assert VibrationWaveform.QUANTITY_ACCELERATION == "acceleration"
    assert VibrationWaveform.UNIT_ACCELERATION == msgs.SI_UNITS["acceleration"]
    assert BearingFaultFrequencies.RACE_OUTER == "outer"
    assert set(VibrationSpectrum.get_fields_and_field_types()) >= {
        "header", "machine_id", "location", "quantity", "unit", "channel_names", "shaft_speed",
        "frequency", "bpfo_order", "amplitude", "phase"}
    assert VibrationWaveform.get_fields_and_field_types()["data"] == "sequence<float>"
    assert VibrationWaveform.get_fields_and_field_types()["first_sample_index"] == "uint64"


# ----------------------------------------------------------------------------- CDR round trip
def test_waveform_roundtrip_channel_major():
    from bkabem_msgs.msg import VibrationWaveform

    m = _waveform(3)
    assert m.unit == "m/s^2" and m.samples_per_channel == N and len(m.data) == 2 * N
    assert m.header.stamp.sec == (T0_NS + int(3 * N / FS * 1e9)) // 10**9
    back = deserialize_message(serialize_message(m), VibrationWaveform)
    assert back == m
    a = msgs.waveform_array(back)
    assert a.shape == (2, N) and a.dtype == np.float32
    np.testing.assert_array_equal(a, _block(3).astype(np.float32))
    # channel-major in the flat field: first N values are channel 0
    flat = np.frombuffer(back.data, dtype=np.float32)
    np.testing.assert_array_equal(flat[:N], _block(3)[0].astype(np.float32))
    np.testing.assert_array_equal(flat[N:], _block(3)[1].astype(np.float32))
    # zero-copy view of the message field
    back.data[0] = 42.0
    assert a[0, 0] == 42.0
    assert back.first_sample_index == 3 * N and back.shaft_speed == 2 * math.pi * 25.0


def test_spectrum_and_faults_roundtrip():
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationSpectrum

    s = _spectrum()
    s2 = deserialize_message(serialize_message(s), VibrationSpectrum)
    assert s2 == s
    f, k, amp, ph = msgs.spectrum_arrays(s2)
    assert amp.shape == ph.shape == (2, 6) and amp.dtype == np.float64
    np.testing.assert_array_equal(k, np.arange(6.0))
    np.testing.assert_array_equal(f, np.arange(6.0) * 89.4)
    np.testing.assert_array_equal(amp[1], 2e-6 / (1 + np.arange(6.0)))
    np.testing.assert_array_equal(ph[1], -0.2 * np.arange(6.0))

    b = _faults()
    b2 = deserialize_message(serialize_message(b), BearingFaultFrequencies)
    assert b2 == b
    assert (b2.defect_bearing, b2.defect_race, b2.bearing_designation) == ("de", "outer", "6205")
    assert b2.defect_depth == 20e-6 and b2.defect_angle == -math.pi / 2 and b2.bpfo == 89.4


def test_builders_reject_bad_input():
    with pytest.raises(ValueError, match="location"):
        msgs.waveform_message(np.zeros(4), sample_rate=FS, first_sample_index=0, shaft_speed=1.0,
                              machine_id="m", location="middle", quantity="acceleration")
    with pytest.raises(ValueError, match="channel_names"):
        msgs.waveform_message(np.zeros((2, 4)), sample_rate=FS, first_sample_index=0,
                              shaft_speed=1.0, machine_id="m", location="de",
                              quantity="acceleration", channel_names=["x"])
    with pytest.raises(ValueError, match="sample_rate"):
        msgs.waveform_message(np.zeros(4), sample_rate=0, first_sample_index=0, shaft_speed=1.0,
                              machine_id="m", location="de", quantity="velocity")
    with pytest.raises(TypeError, match="stamp"):
        msgs.time_msg(1.5)
    with pytest.raises(ValueError, match="phase"):
        msgs.spectrum_message([1.0, 2.0], [1, 2], [[1.0, 2.0]], [[0.0]], shaft_speed=1.0,
                              machine_id="m", location="de", quantity="displacement")


def test_builders_accept_numpy_scalars_and_single_channel():
    m = msgs.waveform_message(np.arange(5, dtype=np.float64), sample_rate=np.int64(1000),
                              first_sample_index=np.uint64(7), shaft_speed=np.float32(3.0),
                              machine_id="m", location="nde", quantity="velocity",
                              stamp=np.int64(5))
    assert m.unit == "m/s" and m.channel_names == ["ch0"] and m.first_sample_index == 7
    assert msgs.stamp_to_ns(m.header) == 5
    np.testing.assert_array_equal(msgs.waveform_array(m), [np.arange(5.0)])


# ----------------------------------------------------------------------------- definitions
@pytest.mark.parametrize("name", TYPES)
def test_definition_text_layout(name):
    text = msgs.message_definition_text(f"bkabem_msgs/msg/{name}")
    parts = text.split("\n" + "=" * 80 + "\n")
    assert parts[0].lstrip().startswith("#") and "std_msgs/Header header" in parts[0]
    heads = [p.split("\n", 1)[0] for p in parts[1:]]
    # rosbag2's order (LocalMessageDefinitionSource: each type's dependencies as a std::set, i.e. sorted, each
    # followed by its own, every type once): BearingKinematics (0.3.0, fault frequencies only), GroundTruth (0.2.0)
    # and its Defect, then Header and its Time
    kin = ["MSG: bkabem_msgs/BearingKinematics"] if name == "BearingFaultFrequencies" else []
    assert heads == kin + ["MSG: bkabem_msgs/GroundTruth", "MSG: bkabem_msgs/Defect", "MSG: std_msgs/Header",
                           "MSG: builtin_interfaces/Time"]
    assert msgs.message_definition_text(f"bkabem_msgs/{name}") == text
    assert msgs.type_hash(f"bkabem_msgs/{name}").startswith("RIHS01_")
    assert len(msgs.type_hash(f"bkabem_msgs/msg/{name}")) == len("RIHS01_") + 64


def test_definition_text_accepted_by_rosbags_with_same_hash():
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    for name in TYPES:
        full = f"bkabem_msgs/msg/{name}"
        store = get_typestore(Stores.EMPTY)   # nested types must come from the text itself
        store.register(get_types_from_msg(msgs.message_definition_text(full), full))
        assert store.hash_rihs01(full) == msgs.type_hash(full), name


# ----------------------------------------------------------------------------- MCAP
def _write_mcap(path: Path) -> dict[str, list]:
    from mcap.writer import Writer

    written = {"/m1/vibration/de/acceleration": [_waveform(i) for i in range(3)],
               "/m1/vibration/nde/spectrum": [_spectrum()],
               "/m1/vibration/fault_frequencies": [_faults()]}
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start(profile="ros2", library="bkabem tests")
        for topic, ms in written.items():
            full = msgs.type_name(ms[0])
            sid = w.register_schema(name=full, encoding="ros2msg",
                                    data=msgs.message_definition_text(full).encode())
            cid = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid,
                                     metadata={"offered_qos_profiles": QOS_YAML,
                                               "topic_type_hash": msgs.type_hash(full)})
            for seq, m in enumerate(ms):
                t = msgs.stamp_to_ns(m.header)
                w.add_message(channel_id=cid, log_time=t, publish_time=t, sequence=seq,
                              data=serialize_message(m))
        w.finish()
    return written


def _same(decoded, m) -> None:
    """Compare a message decoded by another library with the rclpy original, field by field."""
    for field in m.get_fields_and_field_types():
        want, got = getattr(m, field), getattr(decoded, field)
        if field == "header":
            assert (got.frame_id, got.stamp.sec, got.stamp.nanosec) == (
                want.frame_id, want.stamp.sec, want.stamp.nanosec)
        elif field in ("data", "frequency", "bpfo_order", "amplitude", "phase"):
            np.testing.assert_array_equal(np.asarray(got), np.asarray(want), err_msg=field)
        elif field == "channel_names":
            assert list(got) == list(want)
        elif field == "ground_truth":
            assert msgs.ground_truth_dict(got) == msgs.ground_truth_dict(want)
            if want.available:                 # (the fixtures' ground truth: two defects, labels)
                gt = msgs.ground_truth_dict(got)
                assert [(d["kind"], d["bearing"], d["ball"], d["fault_frequency"]) for d in gt["defects"]] == \
                    [("outer", "de", 0, "bpfo"), ("ball", "nde", 3, "bsf")]
                assert gt["defects"][1]["strike_frequency_hz"] == pytest.approx(
                    2 * gt["defects"][1]["fault_multiplier"] * 25.0)
                assert gt["labels"] == {"line": "7", "site": "a"} and gt["time_scale"] == 60.0
        else:
            assert got == want, field


def test_mcap_read_by_mcap_ros2(tmp_path):
    from mcap_ros2.reader import read_ros2_messages

    path = tmp_path / "t.mcap"
    written = _write_mcap(path)
    got: dict[str, list] = {}
    for r in read_ros2_messages(str(path)):
        got.setdefault(r.channel.topic, []).append(r.ros_msg)
        assert r.schema.encoding == "ros2msg" and r.channel.message_encoding == "cdr"
        assert r.channel.metadata["topic_type_hash"] == msgs.type_hash(r.schema.name)
    assert {t: len(v) for t, v in got.items()} == {t: len(v) for t, v in written.items()}
    for topic, ms in written.items():
        for d, m in zip(got[topic], ms):
            _same(d, m)
    wf = got["/m1/vibration/de/acceleration"]
    np.testing.assert_array_equal(msgs.waveform_array(wf[1]), _block(1).astype(np.float32))
    assert [w.first_sample_index for w in wf] == [0, N, 2 * N]


def test_mcap_read_by_rosbags(tmp_path):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = tmp_path / "t.mcap"
    written = _write_mcap(path)
    got: dict[str, list] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
        # rosbags builds the types from the embedded schemas; its RIHS01 of them must equal
        # rosidl's (it does not compare with the channel's topic_type_hash for a bare .mcap).
        for conn in reader.connections:
            assert reader.typestore.hash_rihs01(conn.msgtype) == msgs.type_hash(conn.msgtype)
        for conn, _t, raw in reader.messages():
            got.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    assert {t: len(v) for t, v in got.items()} == {t: len(v) for t, v in written.items()}
    for topic, ms in written.items():
        for d, m in zip(got[topic], ms):
            _same(d, m)
    a = msgs.waveform_array(got["/m1/vibration/de/acceleration"][2])
    np.testing.assert_array_equal(a, _block(2).astype(np.float32))


def test_rclpy_reads_mcap_ros2_encoded_bytes():
    """Bytes from another CDR encoder decode to equal values (bytes may differ in padding)."""
    from bkabem_msgs.msg import VibrationWaveform
    from mcap_ros2._dynamic import serialize_dynamic

    m = _waveform(0)
    full = msgs.type_name(m)
    enc = serialize_dynamic(full, msgs.message_definition_text(full))[full]
    as_dict = {f: getattr(m, f) for f in m.get_fields_and_field_types()}
    as_dict["header"] = {"stamp": {"sec": m.header.stamp.sec, "nanosec": m.header.stamp.nanosec},
                         "frame_id": m.header.frame_id}
    as_dict["data"] = list(m.data)
    back = deserialize_message(enc(as_dict), VibrationWaveform)
    assert back == m


# --------------------------------------------------------------------------- waveform CDR fast path (issue 15)
def _cdr_truth(n: int):
    """A ground truth with every field type set (two defects with strings of lengths that move the alignment)."""
    gt = {"healthy": False, "case": "c" * (n % 5 + 1), "case_hash": "h" * 64, "scenario": "s" * (n % 3),
          "scenario_hash": "x", "state_index": n, "state_label": "dent" + "!" * (n % 7), "state_start_s": 1.5 * n,
          "scenario_time_s": 10.25 * n, "time_scale": 60.0, "load_factor": 1.1, "bearing_designation": "6010",
          "baseline": {"unbalance_grade_mm_s": 2.5, "unbalance_phase_rad": 0.3},
          "labels": {"condition": "run" * (n % 4), "k": "v"},
          "defects": [{"name": "d" * (i + n % 3), "race": race, "bearing": b, "length_m": 2e-3 * (i + 1),
                       "depth_m": 5e-5, "angle_rad": -1.57, "edge": "cubic", "fault_frequency": ff,
                       "fault_multiplier": 3.58, "strike_multiplier": 3.58, "ball": i, "strike_frequency_hz": 89.6}
                      for i, (race, b, ff) in enumerate([("outer", "de", "bpfo"), ("ball", "nde", "bsf")])]}
    return msgs.ground_truth_message(gt)


@pytest.mark.parametrize("machine_id, frame_id, names, n", [
    ("machine_07", "de_bearing", ["vertical", "horizontal"], 2560),   # the node's stream
    ("", "", ["vertical", "horizontal"], 0),
    ("m", "x" * 5, ["a"], 1),
    ("abcdefg", "nde_bearing", ["ab", "c", "def"], 3),
    ("maschine_ü", "f", ["v", "h"], 7),                                 # UTF-8: length in bytes
])
def test_waveform_encoder_bytes_equal_serialize_message(machine_id, frame_id, names, n):
    """WaveformEncoder (the node's publication path) writes the bytes rclpy/Fast DDS would: equal to
    serialize_message outside the alignment padding (Fast CDR leaves old buffer bytes there), the same length,
    and deserialised the same message; string lengths here move every later field's alignment."""
    from bkabem_ros.messages.cdr import WaveformEncoder

    rng = np.random.default_rng(len(machine_id) + n)
    enc = WaveformEncoder(machine_id=machine_id, location="nde", quantity="displacement", unit="m",
                          channel_names=names, sample_rate=51200.0, samples_per_channel=n, frame_id=frame_id)
    for (idx, speed, stamp), truth in zip([(0, 0.0, 0), (2560 * 12345, 157.07963, 1_764_600_000_123_456_789),
                                           (2**40 + 3, -12.5, 999_999_999), (5, 1.0, 7), (6, 2.0, 8)],
                                          [None, _cdr_truth(n), _cdr_truth(n), _cdr_truth(n + 1), None]):
        data = rng.normal(size=(len(names), n)) * 1e-6
        ref_msg = msgs.waveform_message(data, sample_rate=51200.0, first_sample_index=idx, shaft_speed=speed,
                                        machine_id=machine_id, location="nde", quantity="displacement",
                                        channel_names=names, stamp=stamp, frame_id=frame_id, ground_truth=truth)
        ref = serialize_message(ref_msg)
        raw = enc.encode(data, first_sample_index=idx, shaft_speed=speed, stamp_ns=stamp, ground_truth=truth)
        assert len(raw) == len(ref)
        if truth is None:
            assert len(raw) == enc.size
        keep = np.ones(len(ref), bool)
        for a, b in enc.padding:
            keep[a:b] = False
        assert keep.sum() > len(ref) - 64           # alignment bytes (a few per string before a number), not fields
        assert np.array_equal(np.frombuffer(raw, np.uint8)[keep], np.frombuffer(ref, np.uint8)[keep])
        assert deserialize_message(raw, type(ref_msg)) == ref_msg


def test_waveform_encoder_rejects_bad_input():
    from bkabem_ros.messages.cdr import WaveformEncoder

    enc = WaveformEncoder(machine_id="m", location="de", quantity="acceleration", unit="m/s^2",
                          channel_names=["v", "h"], sample_rate=25600.0, samples_per_channel=4, frame_id="f")
    ok = np.zeros((2, 4))
    for kw, word in [(dict(data=np.zeros((2, 5))), "shape"), (dict(first_sample_index=-1), "first_sample_index"),
                     (dict(first_sample_index=1.5), "first_sample_index"), (dict(shaft_speed=math.nan), "shaft_speed"),
                     (dict(stamp_ns=-1), "stamp")]:
        args = dict(data=ok, first_sample_index=0, shaft_speed=1.0, stamp_ns=0) | kw
        with pytest.raises(ValueError, match=word):
            enc.encode(args.pop("data"), **args)
    with pytest.raises(ValueError, match="sample_rate"):
        WaveformEncoder(machine_id="m", location="de", quantity="acceleration", unit="m/s^2", channel_names=["v"],
                        sample_rate=math.inf, samples_per_channel=4, frame_id="f")
    with pytest.raises(ValueError, match="NUL"):
        WaveformEncoder(machine_id="a\x00b", location="de", quantity="acceleration", unit="m/s^2",
                        channel_names=["v"], sample_rate=1.0, samples_per_channel=4, frame_id="f")


def test_with_stamp_rewrites_only_the_header_stamp():
    """waveform_cdr.with_stamp (the node's re-stamping of a prepared chunk): every bkabem message starts with its
    header, so the new stamp replaces bytes 4..12 and the message deserialises with it and nothing else changed."""
    from bkabem_ros.messages.cdr import with_stamp

    wave = msgs.waveform_message(np.arange(6.0).reshape(2, 3), sample_rate=100.0, first_sample_index=7,
                                 shaft_speed=3.0, machine_id="m", location="de", quantity="acceleration",
                                 stamp=5, frame_id="f")
    spec = msgs.spectrum_message([0.0, 10.0], [0.0, 1.0], np.ones((2, 2)), np.zeros((2, 2)), shaft_speed=3.0,
                                 machine_id="m", location="de", quantity="acceleration", stamp=5, frame_id="f")
    for m in (wave, spec):
        out = deserialize_message(with_stamp(serialize_message(m), 1_764_600_000_987_654_321), type(m))
        assert msgs.stamp_to_ns(out.header) == 1_764_600_000_987_654_321
        out.header.stamp = m.header.stamp
        assert out == m
    with pytest.raises(ValueError):
        with_stamp(b"\x00\x00\x00\x00" + bytes(20), 0)
    with pytest.raises(ValueError):
        with_stamp(serialize_message(wave), -1)
