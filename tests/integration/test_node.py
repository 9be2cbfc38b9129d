"""The bkabem node end to end: a speed publisher process, the node process and a test subscriber, on
real DDS over loopback (random domain, LOCALHOST discovery, a random namespace).

The node is started once for the module. ``bkabem speed`` publishes 20 Hz, then 35 Hz (steps profile);
the subscriber checks the physics landmarks (dominant lines at BPFO multiples of the published speed),
that a speed change shows within one chunk, continuity of the sample indices, the message fields, the
``bkabem echo`` tool, bad speed values, a 10 kHz speed flood and a clean SIGINT shutdown.
"""

from __future__ import annotations

import json
import math
import re
import signal
import time

import numpy as np
import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import Listener, Proc, bkabem_cmd, ros_env, unique_namespace

pytestmark = [pytest.mark.ros, pytest.mark.serial]   # measures time: run alone

FS = 25600.0
CHUNK = 0.05
N = int(round(FS * CHUNK))
SPEED1_HZ, SPEED2_HZ = 20.0, 35.0
STEP_S = 3.0
WAVE_TOPICS = [f"vibration/{b}/{q}" for b in ("de", "nde") for q in ("acceleration", "displacement")]


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


@pytest.fixture(scope="module")
def stack():
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationSpectrum, VibrationWaveform
    from std_msgs.msg import Float64

    from bkabem_core.model.case import Case

    ns = unique_namespace("node")
    lis = Listener("node_test_listener")
    procs = {}
    try:
        for t in WAVE_TOPICS:
            lis.subscribe(f"{ns}/{t}", VibrationWaveform)
        for b in ("de", "nde"):
            lis.subscribe(f"{ns}/vibration/{b}/spectrum", VibrationSpectrum)
        lis.subscribe(f"{ns}/vibration/fault_frequencies", BearingFaultFrequencies)
        speed_sub = lis.subscribe(f"{ns}/speed", Float64)
        node = Proc(bkabem_cmd("node", "--namespace", ns, "--sample-rate", str(FS), "--chunk-duration", str(CHUNK),
                               "--spectrum-rate", "2", "--seed", "3"), name="node")
        procs["node"] = node
        node.wait_for(r"streaming from t0", timeout=60)
        lis.wait_publishers(f"{ns}/vibration/de/acceleration")
        speed = Proc(bkabem_cmd("speed", "--namespace", ns, "--profile", f"steps:{SPEED1_HZ},{SPEED2_HZ}:{STEP_S}",
                                "--rate", "50", "--hold", "1", "--wait-subscribers", "10", "--subscribers", "2"),
                     name="speed")        # the node and this listener: the profile's clock starts when both hear it
        procs["speed"] = speed
        assert speed.p.wait(3 * STEP_S + 20) == 0, speed.text
        time.sleep(2 * CHUNK + 0.1)
        case = Case.load()
        yield {"lis": lis, "ns": ns, "procs": procs, "case": case, "Float64": Float64, "speed_sub": speed_sub,
               "bpfo_per_hz": case.bearing("de").fault_multipliers().bpfo}
    finally:
        for p in procs.values():
            p.kill()
        lis.close()


def _waves(stack, topic="vibration/de/acceleration"):
    return [m for _, m in stack["lis"].get(f"{stack['ns']}/{topic}")]


def test_message_fields(stack):
    case = stack["case"]
    gt = case.ground_truth()
    for t in WAVE_TOPICS:
        msgs = _waves(stack, t)
        assert len(msgs) > 20, t
        m = msgs[-1]
        b, q = t.split("/")[1:]
        assert m.location == b and m.quantity == q
        assert m.unit == {"acceleration": "m/s^2", "displacement": "m"}[q]
        assert list(m.channel_names) == ["vertical", "horizontal"]
        assert m.sample_rate == FS and m.samples_per_channel == N and len(m.data) == 2 * N
        assert m.machine_id == stack["ns"].strip("/")
        assert m.header.frame_id == f"{b}_bearing"
        assert np.all(np.isfinite(np.frombuffer(m.data, np.float32)))
    sp = [m for _, m in stack["lis"].get(f"{stack['ns']}/vibration/de/spectrum")]
    assert {m.quantity for m in sp} == {"acceleration", "displacement"}
    s = [m for m in sp if m.quantity == "displacement"][-1]
    k = len(s.frequency)
    assert s.bpfo_order[0] == 0.0 and len(s.amplitude) == 2 * k == len(s.phase)
    assert s.unit == "m" and list(s.channel_names) == ["vertical", "horizontal"]
    assert np.allclose(np.asarray(s.frequency), np.asarray(s.bpfo_order) * stack["bpfo_per_hz"] * s.shaft_speed
                       / (2 * math.pi))
    ff = [m for _, m in stack["lis"].get(f"{stack['ns']}/vibration/fault_frequencies")]
    assert ff, "no fault frequencies"
    f = ff[-1]
    assert f.bearing_designation == gt["bearing_designation"]
    assert f.defect_bearing == gt["defect"]["bearing"] and f.defect_race == "outer"
    assert f.defect_depth == pytest.approx(gt["defect"]["depth_m"])
    assert f.defect_length == pytest.approx(gt["defect"]["length_m"])
    assert f.defect_angle == pytest.approx(gt["defect"]["angle_rad"])
    assert f.bpfo == pytest.approx(stack["bpfo_per_hz"] * f.shaft_speed / (2 * math.pi))
    assert f.header.frame_id == f"{gt['defect']['bearing']}_bearing"
    # each bearing's own (bkabem_msgs 0.3.0): the 6010 at both positions
    assert [b.bearing for b in f.bearings] == ["de", "nde"]
    for b in f.bearings:
        fm = case.fault_multipliers(b.bearing)
        assert (b.designation, b.n_balls) == ("6010", 14)
        assert b.bpfo == pytest.approx(fm.bpfo * f.shaft_speed / (2 * math.pi), rel=1e-12)
        assert b.bsf == pytest.approx(fm.bsf * f.shaft_speed / (2 * math.pi), rel=1e-12)


def test_indices_continuous_and_stamps_from_sample_counter(stack):
    for t in WAVE_TOPICS:
        msgs = _waves(stack, t)
        idx = np.array([m.first_sample_index for m in msgs], dtype=np.int64)
        assert np.all(np.diff(idx) == N), f"{t}: gaps/repeats at {np.nonzero(np.diff(idx) != N)[0][:5]}"
        st = np.array([_ns(m.header.stamp) for m in msgs], dtype=np.int64)
        t0 = st[0] - round(idx[0] * 1e9 / FS)
        assert np.all(np.abs(st - (t0 + np.round(idx * 1e9 / FS).astype(np.int64))) <= 1)
    # every bearing/quantity carries the same chunk sequence
    first = {t: _waves(stack, t)[0].first_sample_index for t in WAVE_TOPICS}
    assert len(set(first.values())) <= 2, first   # subscriptions matched within a chunk of each other


def _dominant_lines(x: np.ndarray, fs: float, n_peaks: int = 4) -> np.ndarray:
    """Frequencies of the n strongest local maxima of the Hann-windowed spectrum (Hz)."""
    x = x - x.mean()
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    f = np.fft.rfftfreq(x.size, 1 / fs)
    peaks = np.nonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:]))[0] + 1
    best = peaks[np.argsort(spec[peaks])[::-1][:n_peaks]]
    return f[best]


def test_dominant_orders_at_bpfo_multiples_and_speed_change(stack):
    msgs = _waves(stack)
    two_pi = 2 * math.pi
    speeds = np.array([m.shaft_speed for m in msgs]) / two_pi
    assert np.any(np.isclose(speeds, SPEED1_HZ)) and np.any(np.isclose(speeds, SPEED2_HZ)), np.unique(speeds)
    for target in (SPEED1_HZ, SPEED2_HZ):
        sel = [m for m in msgs if math.isclose(m.shaft_speed / two_pi, target)]
        sel = sel[-int(1.0 / CHUNK):]                      # the last second at that speed (1 Hz resolution)
        assert len(sel) == int(1.0 / CHUNK)
        assert all(b.first_sample_index - a.first_sample_index == N for a, b in zip(sel, sel[1:]))
        x = np.concatenate([np.frombuffer(m.data, np.float32)[:N] for m in sel]).astype(float)   # vertical
        bpfo = stack["bpfo_per_hz"] * target
        lines = _dominant_lines(x, FS)
        orders = lines / bpfo
        assert np.all(np.abs(orders - np.round(orders)) * bpfo <= 1.5), \
            f"{target} Hz: dominant lines {lines} Hz are not BPFO ({bpfo:.2f} Hz) multiples"
        assert np.all(np.round(orders) >= 1)
    # the change: a speed is the speed at the end of the first chunk that starts after it arrived (the
    # synthesiser ramps linearly over that chunk); that chunk's successor starts at the new speed
    speed_msgs = stack["lis"].get(f"{stack['ns']}/speed")
    t_change = next(t for t, m in speed_msgs if math.isclose(m.data / two_pi, SPEED2_HZ))
    i_new = next(i for i, m in enumerate(msgs) if math.isclose(m.shaft_speed / two_pi, SPEED2_HZ))
    ramp, first_new = msgs[i_new - 1], msgs[i_new]
    slack = 5_000_000   # 5 ms: the test subscriber sees the speed message slightly after the node
    assert math.isclose(ramp.shaft_speed / two_pi, SPEED1_HZ)
    assert _ns(ramp.header.stamp) >= t_change - slack, "a chunk that started before the change already ramped"
    assert _ns(ramp.header.stamp) - t_change <= CHUNK * 1e9 + slack, \
        f"the ramp started {(_ns(ramp.header.stamp) - t_change) / 1e6:.1f} ms after the speed was published"
    # the ramp chunk really moves: its first and second halves have their strongest line at different orders x speed
    x = np.frombuffer(ramp.data, np.float32)[:N].astype(float)
    assert np.std(x) > 0
    assert _ns(first_new.header.stamp) - _ns(ramp.header.stamp) == round(N * 1e9 / FS)


def test_spectrum_matches_waveform(stack):
    """The VibrationSpectrum lines describe the waveform: the dominant line's amplitude agrees with the FFT."""
    two_pi = 2 * math.pi
    spec = [m for _, m in stack["lis"].get(f"{stack['ns']}/vibration/de/spectrum")
            if m.quantity == "acceleration" and math.isclose(m.shaft_speed / two_pi, SPEED2_HZ)]
    assert spec
    s = spec[-1]
    k = len(s.frequency)
    amp = np.asarray(s.amplitude).reshape(2, k)[0]
    j = int(np.argmax(amp))
    f_line = s.frequency[j]
    sel = [m for m in _waves(stack) if math.isclose(m.shaft_speed / two_pi, SPEED2_HZ)][-int(1.0 / CHUNK):]
    x = np.concatenate([np.frombuffer(m.data, np.float32)[:N] for m in sel]).astype(float)
    spec_fft = np.abs(np.fft.rfft(x)) * 2 / x.size
    f = np.fft.rfftfreq(x.size, 1 / FS)
    i = int(np.argmin(np.abs(f - f_line)))
    # the line falls between bins (scalloping up to -3.9 dB): its amplitude is the RMS sum of its leakage bins. The
    # message gives the model's lines (every strike alike); the waveform's pit strikes at random strengths, whose
    # coherent part is E[g] = 0.92 of the line at the default case's spread 1, give or take the draw of a second's
    # 150 strikes (about 8 %; synth/strikes.py)
    a_fft = math.sqrt(np.sum(spec_fft[max(0, i - 4):i + 5] ** 2))
    assert a_fft == pytest.approx(0.92 * amp[j], rel=0.2), (f_line, a_fft, amp[j])


def test_echo_tool(stack):
    p = Proc(bkabem_cmd("echo", "--namespace", stack["ns"], "--count", "6", "--json", "--seconds", "20",
                        "vibration/de/acceleration", "vibration/nde/displacement"), name="echo")
    assert p.p.wait(30) == 0, p.text
    rows = [json.loads(line) for line in p.lines if line.startswith("{")]
    assert len(rows) >= 6, p.text
    for r in rows:
        assert r["topic"].startswith(stack["ns"] + "/vibration/")
        assert r["stamp_ns"] > 0 and r["index"] % N == 0 and len(r["rms"]) == 2
        assert r["speed_rad_s"] == pytest.approx(2 * math.pi * SPEED2_HZ)
    text = Proc(bkabem_cmd("echo", "--namespace", stack["ns"], "--count", "2", "vibration/de/acceleration"),
                name="echo text")
    assert text.p.wait(30) == 0, text.text
    line = next(ln for ln in text.lines if "vibration/de/acceleration" in ln)
    for field in ("stamp=", "index=", "rms=[", "speed="):
        assert field in line, line


def test_bad_speed_values_are_ignored(stack):
    lis, ns, Float64 = stack["lis"], stack["ns"], stack["Float64"]
    pub = lis.publisher(f"{ns}/speed", Float64)
    lis.wait_subscribers(pub)
    node = stack["procs"]["node"]
    good = 2 * math.pi * 34.0           # a new good value first: proves the node receives this publisher
    lis.publish_until(pub, Float64(data=good), f"{ns}/vibration/de/acceleration",
                      lambda it: math.isclose(it[-1][1].shaft_speed, good), timeout=10)
    n0 = len(node.lines)
    bad = [float("nan"), float("inf"), -float("inf"), -10.0, 1.0e6] * 4
    for v in bad:
        pub.publish(Float64(data=v))
        time.sleep(0.01)
    time.sleep(3 * CHUNK)
    mark = len(_waves(stack))
    time.sleep(4 * CHUNK)
    after = _waves(stack)[mark:]
    assert after and all(m.shaft_speed == pytest.approx(good) for m in after)
    node.wait_for(r"speed nan ignored: not finite", start=n0, timeout=5)
    warnings = [ln for ln in node.lines[n0:] if " ignored: " in ln]
    assert 1 <= len(warnings) < len(bad), "bad speeds must give a throttled warning"
    # a good value is taken again
    new = 2 * math.pi * 12.5
    lis.publish_until(pub, Float64(data=new), f"{ns}/vibration/de/acceleration",
                      lambda it: math.isclose(it[-1][1].shaft_speed, new), timeout=5)


def test_speed_above_the_bearings_limiting_speed_is_ignored_with_a_warning(stack):
    # max_speed could be raised live; the 6010s' limiting speed (11 000 r/min = 183.3 Hz) still holds, not clamped
    lis, ns, Float64 = stack["lis"], stack["ns"], stack["Float64"]
    pub = lis.publisher(f"{ns}/speed", Float64)
    lis.wait_subscribers(pub)
    node = stack["procs"]["node"]
    good = 2 * math.pi * 21.0
    lis.publish_until(pub, Float64(data=good), f"{ns}/vibration/de/acceleration",
                      lambda it: math.isclose(it[-1][1].shaft_speed, good), timeout=10)
    time.sleep(2.1)                     # past the throttle of the warnings of earlier tests
    n0 = len(node.lines)
    for _ in range(3):
        pub.publish(Float64(data=2 * math.pi * 1797.0))    # 1797 r/min published as Hz, in rad/s
        time.sleep(0.01)
    node.wait_for(r"ignored: above the bearings' limiting speed .*6010", start=n0, timeout=5)
    mark = len(_waves(stack))
    time.sleep(4 * CHUNK)
    after = _waves(stack)[mark:]
    assert after and all(m.shaft_speed == pytest.approx(good) for m in after)


def test_speed_flood_does_not_delay_the_stream(stack):
    lis, ns = stack["lis"], stack["ns"]
    # this process must not drown in the flood itself (it would drop best-effort waveform messages)
    lis.node.destroy_subscription(stack["speed_sub"])
    topic = f"{ns}/vibration/de/acceleration"
    mark = len(lis.get(topic))
    t0 = time.time_ns()
    flood = Proc(bkabem_cmd("speed", "--namespace", ns, "--profile", "ramp:10:30:3", "--rate", "10000",
                            "--hold", "0", "--quiet", "--qos", "sensor_data", "--wait-subscribers", "10"),
                 name="flood")
    assert flood.p.wait(30) == 0, flood.text
    t1 = time.time_ns()
    time.sleep(2 * CHUNK)
    items = [(t, m) for t, m in lis.get(topic)[mark:] if _ns(m.header.stamp) >= t0]
    idx = [m.first_sample_index for _, m in items]
    assert all(b - a == N for a, b in zip(idx, idx[1:]))
    # the stream kept its pace: one chunk per chunk period over the flood, no backlog
    stamps = [_ns(m.header.stamp) for _, m in items]
    assert stamps[-1] >= t1 - 4 * CHUNK * 1e9, "the stream fell behind during the flood"
    assert len(items) >= (t1 - t0) / 1e9 / CHUNK - 4
    # arrival here after the chunk's last sample was due (includes this loaded test process' own delays)
    late_ms = np.array([(t - st) / 1e6 - CHUNK * 1e3 for (t, _), st in zip(items, stamps)])
    assert np.median(late_ms) < CHUNK * 1e3 / 2, np.percentile(late_ms, [50, 90, 100])
    speeds = {round(m.shaft_speed, 6) for _, m in items}
    assert len(speeds) > 10, "the node did not follow the flooded ramp"


def test_clean_shutdown_on_sigint(stack):
    node = stack["procs"]["node"]
    rc = node.stop(signal.SIGINT)
    assert rc == 0, node.text[-3000:]
    assert "shutting down: stats:" in node.text
    # the node's own publish lateness over the whole run (speed steps, bad values, the 10 kHz flood)
    m = re.search(r"publish lateness p50 ([\d.]+) ms p99 ([\d.]+) ms", node.text)
    assert m, node.text[-2000:]
    assert float(m.group(1)) < 10.0 and float(m.group(2)) < 2 * CHUNK * 1e3, m.group(0)
    assert "Traceback" not in node.text, node.text[-3000:]


def test_cli_errors_exit_2():
    import subprocess

    for args, needle in ((["node", "--sample-rate", "-5"], "--sample-rate"),
                         (["node", "--case", "no_such_case"], "no_such_case"),
                         (["node", "--params-file", "/nonexistent.yaml"], "--params-file"),
                         (["speed", "--profile", "ramp:1:2"], "ramp"),
                         (["echo", "--count", "0"], "--count")):
        r = subprocess.run(bkabem_cmd(*args), env=ros_env(), capture_output=True, text=True, timeout=60)
        assert r.returncode == 2, (args, r.returncode, r.stderr)
        err = [ln for ln in r.stderr.splitlines() if "error" in ln]
        assert len(err) == 1 and needle in err[0], (args, r.stderr)
