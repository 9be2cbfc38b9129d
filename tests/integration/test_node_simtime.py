"""The node on simulated time (/clock) and with wait_for_speed: real processes, real DDS on loopback.

Two node processes (started together, they prepare their models in parallel):
- ``sim``: ``use_sim_time`` true. Before the first /clock it publishes nothing; then its stamps are sim
  time, derived from the sample counter, and the number of chunks follows sim time, not wall time.
- ``wait``: ``wait_for_speed`` true. Nothing is published until the first valid speed; the stream then
  starts at sample index 0 with that speed.
"""

from __future__ import annotations

import time

import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import Listener, Proc, bkabem_cmd, unique_namespace

pytestmark = pytest.mark.ros

FS = 12800.0
CHUNK = 0.05
N = int(FS * CHUNK)
T0_SIM_NS = 1_000_000_000_000   # sim time starts at 1000 s


@pytest.fixture(scope="module")
def stack():
    from bkabem_msgs.msg import VibrationWaveform
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Float64

    ns_sim, ns_wait = unique_namespace("sim"), unique_namespace("wait")
    common = ["--sample-rate", str(FS), "--chunk-duration", str(CHUNK), "--spectrum-rate", "0"]
    lis = Listener("simtime_listener")
    procs = []
    try:
        lis.subscribe(f"{ns_sim}/vibration/de/acceleration", VibrationWaveform)
        lis.subscribe(f"{ns_wait}/vibration/de/acceleration", VibrationWaveform)
        clock_pub = lis.publisher("/clock", Clock, reliable=False)   # /clock is absolute: the node uses it
        speed_pub = lis.publisher(f"{ns_wait}/speed", Float64)
        sim = Proc(bkabem_cmd("node", "--namespace", ns_sim, "--sim-time", *common), name="sim node")
        procs.append(sim)
        wait = Proc(bkabem_cmd("node", "--namespace", ns_wait, "--wait-for-speed", *common), name="wait node")
        procs.append(wait)
        sim.wait_for(r"waiting for /clock", timeout=60)
        wait.wait_for(r"waiting for the first speed message", timeout=60)
        yield {"lis": lis, "sim": sim, "wait": wait, "ns_sim": ns_sim, "ns_wait": ns_wait,
               "clock_pub": clock_pub, "speed_pub": speed_pub, "Clock": Clock, "Float64": Float64}
    finally:
        for p in procs:
            p.kill()
        lis.close()


def _publish_clock(stack, start_ns: int, seconds_sim: float, speedup: float, step_ns: int = 5_000_000) -> int:
    """Publish /clock from start_ns for seconds_sim of sim time at `speedup` x real time; returns the end."""
    from builtin_interfaces.msg import Time

    Clock = stack["Clock"]
    pub = stack["clock_pub"]
    t = start_ns
    end = start_ns + int(seconds_sim * 1e9)
    wall0 = time.monotonic()
    while t <= end:
        pub.publish(Clock(clock=Time(sec=t // 1_000_000_000, nanosec=t % 1_000_000_000)))
        t += step_ns
        delay = wall0 + (t - start_ns) / 1e9 / speedup - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    return t


def test_sim_time_nothing_before_clock_then_sim_stamps(stack):
    lis, ns = stack["lis"], stack["ns_sim"]
    topic = f"{ns}/vibration/de/acceleration"
    lis.wait_publishers(topic)
    time.sleep(0.5)
    assert lis.get(topic) == [], "the node published before the first /clock"
    lis.wait_subscribers(stack["clock_pub"])
    # 2 s of sim time at real-time speed
    t_end = _publish_clock(stack, T0_SIM_NS, 2.0, speedup=1.0)
    # ~2 s of sim time -> ~40 chunks of 50 ms; on a loaded machine the last ones may arrive after the clock stops
    items = lis.wait_for(topic, lambda it: len(it) >= int(1.9 / CHUNK) - 2, timeout=20)
    stack["sim"].wait_for(r"streaming from t0 = 1000\.", timeout=5)
    msgs = [m for _, m in items]
    idx = [m.first_sample_index for m in msgs]
    assert idx[0] == 0 and all(b - a == N for a, b in zip(idx, idx[1:])), idx[:10]
    stamps = [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in msgs]
    t0 = stamps[0]
    assert T0_SIM_NS <= t0 < T0_SIM_NS + 100_000_000, f"first stamp {t0} is not sim time"
    for m, st in zip(msgs, stamps):     # stamps from the sample counter, exact to 1 ns
        assert abs(st - (t0 + round(m.first_sample_index * 1e9 / FS))) <= 1
    # chunks follow sim time: ~2 s of sim time -> ~40 chunks of 50 ms (the last one needs its end due)
    assert stamps[-1] + CHUNK * 1e9 <= t_end + 1e6
    assert len(msgs) >= int(1.9 / CHUNK) - 2, len(msgs)
    stack["t_end"] = t_end


def test_sim_time_faster_than_real_time(stack):
    lis, ns = stack["lis"], stack["ns_sim"]
    topic = f"{ns}/vibration/de/acceleration"
    before = len(lis.get(topic))
    last_idx = lis.get(topic)[-1][1].first_sample_index
    wall0 = time.monotonic()
    t_end = _publish_clock(stack, stack["t_end"], 4.0, speedup=4.0)   # 4 s of sim time in ~1 s
    wall = time.monotonic() - wall0
    time.sleep(0.5)
    items = lis.get(topic)[before:]
    n_sim = 4.0 / CHUNK
    assert len(items) >= 0.85 * n_sim, f"{len(items)} chunks for {n_sim:.0f} chunks of sim time in {wall:.2f} s"
    idx = [m.first_sample_index for _, m in items]
    assert idx[0] == last_idx + N and all(b - a == N for a, b in zip(idx, idx[1:]))
    last = items[-1][1].header.stamp
    assert last.sec * 1_000_000_000 + last.nanosec <= t_end


def test_wait_for_speed(stack):
    lis, ns = stack["lis"], stack["ns_wait"]
    topic = f"{ns}/vibration/de/acceleration"
    lis.wait_publishers(topic)
    time.sleep(0.5)
    assert lis.get(topic) == [], "published before any speed arrived"
    pub = stack["speed_pub"]
    lis.wait_subscribers(pub)
    speed = 2 * 3.141592653589793 * 15.0
    pub.publish(stack["Float64"](data=float("nan")))      # not a valid speed: still waiting
    time.sleep(0.3)
    assert lis.get(topic) == []
    t_send = time.time_ns()
    pub.publish(stack["Float64"](data=speed))
    items = lis.wait_for(topic, lambda it: len(it) >= 3, timeout=10)
    first = items[0][1]
    assert first.first_sample_index == 0
    assert first.shaft_speed == pytest.approx(speed)
    st = first.header.stamp.sec * 1_000_000_000 + first.header.stamp.nanosec
    assert 0 <= st - t_send < 0.5e9


def test_clean_shutdown_sigterm(stack):
    import signal

    for key in ("sim", "wait"):
        p = stack[key]
        assert p.stop(signal.SIGTERM) == 0, p.text[-2000:]
        assert "shutting down" in p.text
        assert "Traceback" not in p.text, p.text[-3000:]
