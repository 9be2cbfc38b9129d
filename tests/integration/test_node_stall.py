"""Issue 14, item 2: no speed change, of any size, may delay a chunk past its due time.

Real processes on loopback: ``bkabem node`` and ``bkabem speed`` publishing jumps to and from 0 and to the
case's top speed (0 -> 75 -> 0 -> 40 -> 0 -> 75 -> 0 Hz, every 0.7 s: start-ups and emergency stops). On main
such a jump cost one chunk ~0.5 s of spectrum solves (the synthesiser's 2 %-ratio knot rule asked for ~1250
knots from 0 Hz) and the stream stalled 0.52-0.76 s. Here the node's own publish lateness (waveforms handed
to DDS minus the time the chunk's last sample was due) and the arrival at a subscriber stay far below one chunk.
"""

from __future__ import annotations

import re
import signal

import numpy as np
import pytest
from ros_helpers import Listener, Proc, bkabem_cmd, unique_namespace

pytestmark = [pytest.mark.ros, pytest.mark.serial]   # measures time: run alone

FS = 25600.0
CHUNK = 0.1
N = int(round(FS * CHUNK))
PROFILE = "steps:0,75,0,40,0,75,0:0.7"


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def test_speed_jumps_to_and_from_zero_do_not_stall_the_stream():
    from bkabem_msgs.msg import VibrationWaveform

    ns = unique_namespace("stall")
    lis = Listener("stall_test_listener")
    node = speed = None
    try:
        topic = f"{ns}/vibration/de/acceleration"
        lis.subscribe(topic, VibrationWaveform)
        node = Proc(bkabem_cmd("node", "--namespace", ns, "--sample-rate", str(FS), "--chunk-duration", str(CHUNK)),
                    name="node")
        node.wait_for(r"streaming from t0", timeout=90)
        lis.wait_for(topic, timeout=30)
        speed = Proc(bkabem_cmd("speed", "--namespace", ns, "--profile", PROFILE, "--rate", "50", "--hold", "0.5",
                                "--wait-subscribers", "10", "--quiet"), name="speed")
        assert speed.p.wait(60) == 0, speed.text
        lis.wait_for(topic, lambda it: len(it) > 0 and it[-1][1].shaft_speed == 0.0 and
                     any(m.shaft_speed > 2 * np.pi * 70 for _, m in it), timeout=10)
        rc = node.stop(signal.SIGINT)
        assert rc == 0, node.text[-3000:]
    finally:
        for p in (speed, node):
            if p is not None:
                p.kill()
        items = lis.get(f"{ns}/vibration/de/acceleration")
        lis.close()
    # the stream went through every jump: top speed and standstill both reached, indices continuous
    speeds_hz = np.array([m.shaft_speed for _, m in items]) / (2 * np.pi)
    assert speeds_hz.max() > 70 and np.sum(speeds_hz == 0.0) > 5
    idx = [m.first_sample_index for _, m in items]
    assert all(b - a == N for a, b in zip(idx, idx[1:])), "gap or repeat in the stream"
    # the node's own measure over the whole run
    m = re.search(r"publish lateness p50 ([\d.]+) ms p99 ([\d.]+) ms max ([\d.]+) ms", node.text)
    assert m, node.text[-2000:]
    # margins for a loaded 2-core machine (other processes take the CPU for tens of ms at times); on main every
    # jump to or from 0 made 3-7 chunks late, the worst by 520-760 ms
    p50, p99, worst = map(float, m.groups())
    assert p50 < 10 and worst < 2.5 * CHUNK * 1e3, f"chunks published late: {m.group(0)}"
    # arrival here (the middleware's reception time, so not this test process' own pauses): at most two chunks
    # (of ~60) a chunk period late
    late_ms = np.array([(t - _ns(msg.header.stamp)) / 1e6 - CHUNK * 1e3 for t, msg in items])
    assert np.all(np.abs(late_ms) < 5e3), "reception and stamp clocks disagree"
    assert np.sum(late_ms > CHUNK * 1e3) <= 2, (m.group(0), np.sort(late_ms)[-8:])
    print(f"arrival lateness: median {np.median(late_ms):.2f} ms, max {late_ms.max():.2f} ms; node: {m.group(0)}")
