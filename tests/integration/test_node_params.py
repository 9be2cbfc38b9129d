"""Node parameters: --params-file, --ros-args -p, live changes through the parameter services, rejected
changes with their reason, bad parameter files. Real node processes on loopback DDS.

Two nodes start together: ``a`` from a parameter file written here (``--params-file`` shorthand plus
``--ros-args -p``), ``b`` from the example ``config/bkabem_node.yaml`` (``--ros-args --params-file``).
"""

from __future__ import annotations

import math
import subprocess
import time

import numpy as np
import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import REPO, Listener, Proc, bkabem_cmd, ros_env, unique_namespace

pytestmark = pytest.mark.ros

FS = 12800
CHUNK = 0.05
N = int(FS * CHUNK)

PARAMS_A = """\
/**:
  ros__parameters:
    sample_rate: {fs}
    chunk_duration: {chunk}
    machine_id: pump_7
    qos: reliable
    spectrum_rate: 4.0
    seed: 11
    frame_id:
      de: pump7_de
"""


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationSpectrum, VibrationWaveform
    from std_msgs.msg import Float64

    tmp = tmp_path_factory.mktemp("params")
    pfile = tmp / "a.yaml"
    pfile.write_text(PARAMS_A.format(fs=FS, chunk=CHUNK))
    ns_a, ns_b = unique_namespace("pa"), unique_namespace("pb")
    lis = Listener("params_listener")
    procs = {}
    try:
        lis.subscribe(f"{ns_a}/vibration/de/acceleration", VibrationWaveform, reliable=True)
        lis.subscribe(f"{ns_a}/vibration/de/spectrum", VibrationSpectrum, reliable=True)
        lis.subscribe(f"{ns_a}/vibration/fault_frequencies", BearingFaultFrequencies, reliable=True)
        lis.subscribe(f"{ns_b}/vibration/nde/displacement", VibrationWaveform)
        procs["a"] = Proc(bkabem_cmd("node", "--namespace", ns_a, "--params-file", str(pfile),
                                     "--ros-args", "-p", "seed:=5"), name="node a")
        procs["b"] = Proc(bkabem_cmd("node", "--namespace", ns_b, "--spectrum-rate", "0",
                                     "--ros-args", "--params-file", str(REPO / "config" / "bkabem_node.yaml")),
                          name="node b")
        for p in procs.values():
            p.wait_for(r"streaming from t0", timeout=60)
        speed_pub = lis.publisher(f"{ns_a}/speed", Float64)
        lis.wait_subscribers(speed_pub)
        lis.publish_until(speed_pub, Float64(data=2 * math.pi * 30.0), f"{ns_a}/vibration/de/acceleration",
                          lambda it: len(it) > 5 and math.isclose(it[-1][1].shaft_speed, 2 * math.pi * 30.0))
        yield {"lis": lis, "procs": procs, "a": f"{ns_a}/bkabem", "b": f"{ns_b}/bkabem", "ns_a": ns_a, "ns_b": ns_b,
               "speed_pub": speed_pub, "Float64": Float64, "tmp": tmp}
    finally:
        for p in procs.values():
            p.kill()
        lis.close()


def _acc(stack):
    return [m for _, m in stack["lis"].get(f"{stack['ns_a']}/vibration/de/acceleration")]


def _ok(results):
    return [r.successful for r in results]


def test_params_file_and_ros_args(stack):
    m = _acc(stack)[-1]          # received with a reliable subscription: qos=reliable took effect
    assert m.sample_rate == FS and m.samples_per_channel == N
    assert m.machine_id == "pump_7" and m.header.frame_id == "pump7_de"
    got = stack["lis"].get_parameters(stack["a"], ["sample_rate", "seed", "qos", "spectrum_rate", "frame_id.nde"])
    assert got == {"sample_rate": float(FS), "seed": 5, "qos": "reliable", "spectrum_rate": 4.0,
                   "frame_id.nde": "nde_bearing"}


def test_example_config_loads(stack):
    lis = stack["lis"]
    items = lis.wait_for(f"{stack['ns_b']}/vibration/nde/displacement", timeout=10)
    assert items[-1][1].sample_rate == 25600.0
    got = lis.get_parameters(stack["b"], ["case", "chunk_duration", "speed_unit", "spectrum_rate", "frame_id.de"])
    assert got == {"case": "electric_motor_6010", "chunk_duration": 0.1, "speed_unit": "rad/s",
                   "spectrum_rate": 0.0, "frame_id.de": "de_bearing"}   # --spectrum-rate beats the file
    assert lis.get_parameters(stack["b"], ["slip"]) == {"slip": 0.0}      # a case without [measurement] slip


def test_a_rig_cases_acquisition_is_the_nodes_default(stack):
    """The node takes its slip and sample rate from the case's [measurement] section (cwru_rig: 0.001 and 12 kHz)
    unless they are given."""
    lis = stack["lis"]
    ns = {k: unique_namespace(f"slip{k}") for k in ("rig", "given")}
    procs = {}
    try:
        for k, extra in (("rig", []), ("given", ["-p", "slip:=0.02", "-p", "sample_rate:=25600.0"])):
            procs[k] = Proc(bkabem_cmd("node", "--namespace", ns[k], "--ros-args", "-p", "case:=cwru_rig", *extra),
                            name=f"node {k}")
        for p in procs.values():
            p.wait_for(r"streaming from t0", timeout=60)
        assert lis.get_parameters(f"{ns['rig']}/bkabem", ["slip", "sample_rate"]) == {"slip": 0.001,
                                                                                     "sample_rate": 12000.0}
        assert lis.get_parameters(f"{ns['given']}/bkabem", ["slip", "sample_rate"]) == {"slip": 0.02,
                                                                                       "sample_rate": 25600.0}
    finally:
        for p in procs.values():
            p.kill()


def test_unsafe_and_invalid_changes_are_rejected_with_a_reason(stack):
    lis = stack["lis"]
    for name, value, needle in (("sample_rate", 25600.0, "fixed while the node runs"),
                                ("case", "other", "fixed while the node runs"),
                                ("qos", "sensor_data", "fixed while the node runs"),
                                ("spectrum_rate", 1000.0, "out of range"),
                                ("speed_unit", "furlongs", "not one of"),
                                ("max_speed", 10.0, "below the current speed"),
                                ("max_speed", 5000.0, "above the bearings' limiting speed")):
        (res,) = lis.set_parameters(stack["a"], {name: value})
        assert not res.successful, name
        assert needle in res.reason, (name, res.reason)
    got = lis.get_parameters(stack["a"], ["sample_rate", "spectrum_rate"])
    assert got == {"sample_rate": float(FS), "spectrum_rate": 4.0}


def test_live_spectrum_rate(stack):
    lis, topic = stack["lis"], f"{stack['ns_a']}/vibration/de/spectrum"
    assert _ok(lis.set_parameters(stack["a"], {"spectrum_rate": 10.0})) == [True]
    time.sleep(0.3)
    mark = len(lis.get(topic))
    time.sleep(2.0)
    n = sum(1 for _, m in lis.get(topic)[mark:] if m.quantity == "acceleration")
    assert 14 <= n <= 24, n      # ~10 per second (aligned to 50 ms chunks)
    assert _ok(lis.set_parameters(stack["a"], {"spectrum_rate": 4.0})) == [True]


def test_live_speed_unit(stack):
    lis, pub, F = stack["lis"], stack["speed_pub"], stack["Float64"]
    assert _ok(lis.set_parameters(stack["a"], {"speed_unit": "rpm"})) == [True]
    target = 2 * math.pi * 15.0
    lis.publish_until(pub, F(data=900.0), f"{stack['ns_a']}/vibration/de/acceleration",   # 900 rpm
                      lambda it: math.isclose(it[-1][1].shaft_speed, target), timeout=5)
    assert _ok(lis.set_parameters(stack["a"], {"speed_unit": "rad/s"})) == [True]
    lis.publish_until(pub, F(data=2 * math.pi * 30.0), f"{stack['ns_a']}/vibration/de/acceleration",
                      lambda it: math.isclose(it[-1][1].shaft_speed, 2 * math.pi * 30.0), timeout=5)


def test_live_noise(stack):
    lis = stack["lis"]

    def rms_now(k=10):
        time.sleep((k + 2) * CHUNK)
        msgs = _acc(stack)[-k:]
        x = np.concatenate([np.frombuffer(m.data, np.float32)[:N] for m in msgs]).astype(float)
        return float(np.sqrt(np.mean((x - x.mean()) ** 2)))

    base = rms_now()
    noise = 20.0 * max(base, 1e-3)
    # the density, as bkabem synth --noise-acc and a data set's noise_acc: RMS = density x sqrt(fs / 2)
    assert _ok(lis.set_parameters(stack["a"], {"noise_acc": noise / math.sqrt(FS / 2)})) == [True]
    time.sleep(3 * CHUNK)
    noisy = rms_now()
    assert noisy == pytest.approx(math.hypot(base, noise), rel=0.2), (base, noise, noisy)
    assert _ok(lis.set_parameters(stack["a"], {"noise_acc": 0.0})) == [True]
    time.sleep(3 * CHUNK)
    assert rms_now() == pytest.approx(base, rel=0.2)
    # the RMS of earlier versions (parameter files in use) still works, converted with a deprecation warning
    n0 = len(stack["procs"]["a"].lines)
    assert _ok(lis.set_parameters(stack["a"], {"noise.acceleration": noise})) == [True]
    stack["procs"]["a"].wait_for(r"noise\.acceleration .*deprecated.* noise_acc", start=n0, timeout=5)
    time.sleep(3 * CHUNK)
    noisy = rms_now()
    assert noisy == pytest.approx(math.hypot(base, noise), rel=0.2), (base, noise, noisy)
    assert _ok(lis.set_parameters(stack["a"], {"noise.acceleration": 0.0})) == [True]
    time.sleep(3 * CHUNK)
    assert rms_now() == pytest.approx(base, rel=0.2)


def test_live_defect_depth(stack):
    lis, topic = stack["lis"], f"{stack['ns_a']}/vibration/fault_frequencies"
    before = lis.get(topic)[-1][1]
    new_depth = before.defect_depth / 2.5
    n0 = len(stack["procs"]["a"].lines)
    assert _ok(lis.set_parameters(stack["a"], {"defect_depth": new_depth})) == [True]
    items = lis.wait_for(topic, lambda it: math.isclose(it[-1][1].defect_depth, new_depth), timeout=30)
    assert items[-1][1].bpfo == pytest.approx(before.bpfo)
    stack["procs"]["a"].wait_for(r"defect_depth .* in effect", start=n0, timeout=5)
    # the stream went on without a gap while the excitation was recomputed
    idx = [m.first_sample_index for m in _acc(stack)]
    assert all(b - a == N for a, b in zip(idx, idx[1:]))


@pytest.mark.parametrize("body, needle", [
    ("sample_rate: 5.0", "sample_rate"),
    ("qos: fast", "qos"),
    ("chunk_duration: 'long'", "chunk_duration"),
])
def test_bad_params_file_exits_2(stack, body, needle):
    f = stack["tmp"] / "bad.yaml"
    f.write_text(f"/**:\n  ros__parameters:\n    {body}\n")
    r = subprocess.run(bkabem_cmd("node", "--params-file", str(f)), env=ros_env(), capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 2, (r.returncode, r.stdout[-2000:], r.stderr[-2000:])
    err = [ln for ln in r.stderr.splitlines() if "error" in ln.lower()]
    assert len(err) == 1 and needle in err[0], r.stderr
