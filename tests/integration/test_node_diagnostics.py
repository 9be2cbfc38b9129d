"""The node's health on /diagnostics (REP 107, diagnostic_msgs/msg/DiagnosticArray), received by an independent
subscriber in this process and read back from the node's MCAP with rosbags: stream on time, model, band limit and
the ISO zone per bearing, whose velocity is recomputed here from the received waveforms (textbook: the
acceleration's spectrum divided by 2 pi f in 10-1000 Hz, Parseval)."""

from __future__ import annotations

import math
import signal
import time

import numpy as np
import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import Listener, Proc, bkabem_cmd, unique_namespace

pytestmark = pytest.mark.ros

FS, SPEED_HZ = 12800.0, 25.0
PARTS = ("stream", "model", "band limit", "DE bearing", "NDE bearing")


def _iso_velocity_mm_s(acc: np.ndarray, fs: float) -> float:
    n = acc.size
    spec = np.fft.rfft(acc - acc.mean()) / n
    f = np.fft.rfftfreq(n, 1.0 / fs)
    band = (f >= 10.0) & (f <= 1000.0)
    v = np.abs(spec[band]) / (2 * np.pi * f[band])                # one-sided amplitude / 2 -> velocity
    return float(np.sqrt(2 * np.sum(v ** 2)) * 1e3)


def _values(status) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_diagnostics_received_by_an_independent_subscriber_and_recorded(tmp_path):
    from bkabem_msgs.msg import VibrationWaveform
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import Float64

    ns = unique_namespace("diag")
    mcap = tmp_path / "diag.mcap"
    lis = Listener("diagnostics_listener")
    acc = f"{ns}/vibration/de/acceleration"
    lis.subscribe("/diagnostics", DiagnosticArray, reliable=True)
    lis.subscribe(acc, VibrationWaveform, reliable=True, depth=5000)
    node = Proc(bkabem_cmd("node", "--namespace", ns, "--case", "motor_6010_outer", "--sample-rate", str(FS),
                           "--qos", "reliable", "--record", str(mcap), "--ros-args", "-p", "qos_depth:=200"),
                name="diagnostics node")
    try:
        node.wait_for(r"streaming from t0", timeout=120)
        mine = lambda it: [m for _, m in it if m.status and m.status[0].name.startswith(ns.lstrip("/"))]  # noqa: E731
        lis.wait_for("/diagnostics", lambda it: len(mine(it)) >= 1, timeout=10)
        pub = lis.publisher(f"{ns}/speed", Float64)
        lis.wait_subscribers(pub)
        w = 2 * math.pi * SPEED_HZ
        lis.publish_until(pub, Float64(data=w), acc, lambda it: len(it) > 1 and math.isclose(it[-1][1].shaft_speed, w))
        n0 = len(mine(lis.get("/diagnostics")))
        lis.wait_for("/diagnostics", lambda it: len(mine(it)) >= n0 + 3, timeout=20)    # 3 s at speed
        time.sleep(0.2)
        assert node.stop(signal.SIGINT, timeout=60) == 0, node.text[-3000:]
    finally:
        node.kill()
        lis.close()
    reports = mine(lis.get("/diagnostics"))
    last = reports[-1]
    names = [s.name for s in last.status]
    assert names == [f"{ns.lstrip('/')}/bkabem: {p}" for p in PARTS], names
    by = {s.name.split(": ", 1)[1]: s for s in last.status}
    assert all(s.hardware_id == ns.lstrip("/") for s in last.status)
    # the stream: on time (REP 107 level OK = 0), its counters
    st = _values(by["stream"])
    assert by["stream"].level == b"\x00", by["stream"].message
    assert int(st["chunks_in_period"]) >= 5 and float(st["shaft_speed_hz"]) == pytest.approx(SPEED_HZ)
    # the model and the band limit: the fault library's outer race carries its lines to the band
    md = _values(by["model"])
    assert md["case"] == "motor_6010_outer" and int(md["lines"]) > 50
    bl = _values(by["band limit"])
    assert by["band limit"].level == b"\x00" and bl["lines_to_band"] == "true"
    assert float(bl["carried_in_full_up_to_hz"]) == pytest.approx(0.85 * FS / 2)
    # the ISO zone of the DE bearing, against the velocity of the last second of waveforms received here
    de = _values(by["DE bearing"])
    waves = [m for _, m in lis.get(acc) if math.isclose(m.shaft_speed, 2 * math.pi * SPEED_HZ)]
    n_sec = int(FS // waves[-1].samples_per_channel)
    x = np.concatenate([np.frombuffer(m.data, np.float32).reshape(2, -1) for m in waves[-n_sec - 2:-2]], axis=1)
    want = [_iso_velocity_mm_s(x[c].astype(float), FS) for c in range(2)]
    got = [float(de["velocity_rms_vertical_mm_s"]), float(de["velocity_rms_horizontal_mm_s"])]
    np.testing.assert_allclose(got, want, rtol=0.15)
    from bkabem_core.analysis.condition import DEFAULT_ISO_ZONES, ISO_ZONE_SETS, iso_zone

    assert de["zone"] == iso_zone(max(got), ISO_ZONE_SETS[DEFAULT_ISO_ZONES])
    assert by["DE bearing"].level == {"A": b"\x00", "B": b"\x00", "C": b"\x01", "D": b"\x02"}[de["zone"]]
    # recorded in the MCAP like the rest
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([mcap], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
        conns = [c for c in reader.connections if c.topic == "/diagnostics"]
        assert conns and conns[0].msgtype == "diagnostic_msgs/msg/DiagnosticArray"
        rec = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
    assert len(rec) >= 3 and [s.name for s in rec[-1].status] == names
