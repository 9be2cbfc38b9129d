"""The health panels' envelope verdict knows where a fault line comes from (bkabem_core/analysis/health.py): a real
``bkabem node`` (the embedded case: an outer-race dent in the DE bearing, the NDE bearing healthy) writing its
Rerun recording, speed over DDS on loopback (tests/integration/ros_helpers.py).

The NDE acceleration carries BPFO too (the DE dent's force reaches the NDE housing through the shaft): shown here
with a textbook envelope spectrum of the NDE waveform (Hilbert envelope of the 1-10 kHz band, written in this
test). Its panel must say that line is the DE defect's, transmitted, and never read like an NDE fault; the DE
panel keeps its own verdict.
"""

from __future__ import annotations

import math
import re
import signal
import time

import numpy as np
import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import Listener, Proc, bkabem_cmd, unique_namespace
from scipy.signal import hilbert

pytestmark = pytest.mark.ros

FS = 25600.0
SPEED_HZ = 25.0


def _envelope_db_at(x: np.ndarray, fs: float, f0: float) -> float:
    """Textbook envelope analysis: FFT band-pass 1-10 kHz, |analytic signal|, Hann spectrum of the envelope; the
    peak within 1 % of ``f0`` over the median of the spectrum [dB]."""
    X = np.fft.rfft(x - x.mean())
    f = np.fft.rfftfreq(x.size, 1 / fs)
    X[(f < 1000.0) | (f > 10000.0)] = 0.0
    env = np.abs(hilbert(np.fft.irfft(X, x.size)))
    w = np.hanning(env.size)
    E = np.abs(np.fft.rfft((env - env.mean()) * w))
    m = np.abs(f - f0) <= max(0.01 * f0, 2 * (f[1] - f[0]))
    return 20 * math.log10(E[m].max() / np.median(E[1:]))


def _last_text(rrd, entity: str) -> str:
    from rerun.chunk import RrdReader

    texts = []
    for ch in RrdReader(str(rrd)).stream().collect().stream():
        if ch.entity_path == entity:
            rb = ch.to_record_batch()
            if "TextDocument:text" in rb.schema.names:
                texts += [v[0] for v in rb.column("TextDocument:text").to_pylist()]
    assert texts, entity
    return texts[-1]


def test_nde_panel_says_the_bpfo_it_sees_is_the_de_defect_transmitted(tmp_path):
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationWaveform
    from std_msgs.msg import Float64

    rrd = tmp_path / "health.rrd"
    ns = unique_namespace("hlth")
    lis = Listener("health_listener")
    nde, ff = f"{ns}/vibration/nde/acceleration", f"{ns}/vibration/fault_frequencies"
    lis.subscribe(nde, VibrationWaveform, reliable=True, depth=2000)
    lis.subscribe(ff, BearingFaultFrequencies, reliable=True)
    node = Proc(bkabem_cmd("node", "--namespace", ns, "--sample-rate", str(FS), "--qos", "reliable",
                           "--rerun-save", str(rrd), "--ros-args", "-p", "noise.acceleration:=0.05",
                           "-p", "qos_depth:=100"), name="health node")
    try:
        node.wait_for(r"streaming from t0", timeout=90)
        pub = lis.publisher(f"{ns}/speed", Float64)
        lis.wait_subscribers(pub)
        w = 2 * math.pi * SPEED_HZ
        lis.publish_until(pub, Float64(data=w), nde, lambda it: len(it) > 1 and math.isclose(it[-1][1].shaft_speed, w))
        n0 = len(lis.get(nde))
        lis.wait_for(nde, lambda it: len(it) >= n0 + 35, timeout=30)      # > 3 condition windows at speed
        time.sleep(0.3)
        assert node.stop(signal.SIGINT, timeout=60) == 0, node.text[-3000:]
    finally:
        node.kill()
        lis.close()
    fmsg = lis.get(ff)[-1][1]
    bpfo = fmsg.bpfo
    from bkabem_ros.messages.convert import ground_truth_dict

    gt = ground_truth_dict(fmsg)
    assert [(d["bearing"], d["kind"]) for d in gt["defects"]] == [("de", "outer")]
    # the NDE acceleration does carry BPFO (harmonics of it in its envelope): a pipeline reading it alone would flag it
    waves = [m for _, m in lis.get(nde) if math.isclose(m.shaft_speed, 2 * math.pi * SPEED_HZ)]
    x = np.concatenate([np.frombuffer(m.data, dtype=np.float32)[:m.samples_per_channel] for m in waves[-10:]])
    assert _envelope_db_at(x.astype(float), FS, bpfo) > 10.0
    de_text, nde_text = _last_text(rrd, "/de/health"), _last_text(rrd, "/nde/health")
    nde_env = next(ln for ln in nde_text.splitlines() if ln.startswith("**Envelope**"))
    de_env = next(ln for ln in de_text.splitlines() if ln.startswith("**Envelope**"))
    assert re.search(rf"BPFO {bpfo:.1f} Hz: from the DE outer-race defect \(transmitted\), not a fault of the NDE "
                     r"bearing; harmonics 1-3 at", nde_env), nde_env
    assert "stands out" not in nde_env and "no defect in this bearing" in nde_text
    assert re.search(rf"BPFO \({bpfo:.1f} Hz\) stands out: harmonics 1-3", de_env), de_env
    assert "transmitted" not in de_env
