"""Benchmark: cost of MCAP recording and Rerun logging at the full 51.2 kHz x 8 channel rate.

    .venv/bin/python bench/bench_record.py [--seconds 20] [--node-seconds 20] [--repeats 3] [--json FILE]

Parts
-----
1. ``McapSink`` (what the node uses: serialize in the caller, write + zstd in a thread) fed with the
   node's message pattern for ``--seconds`` of data as fast as possible: CPU seconds per second of
   data = fraction of one core the recording adds. Checks that nothing is lost (every message in
   the file, ``first_sample_index`` gap-free).
2. ``RerunLogger`` to an ``.rrd`` (``send_columns`` per block) with the same data.
3. The real node (``bkabem_ros.node.vibration_node.VibrationNode``) at sample_rate 51200 Hz for ``--node-seconds``,
   once without and once with the MCAP sink (and once with MCAP + Rerun): process CPU per wall
   second; recorded messages vs published ones. Skipped with a note if the node cannot run here.

Data per 0.1 s chunk (as the node publishes it): 4 ``VibrationWaveform`` (DE/NDE x acceleration/
displacement, 2 channels x 5120 float32 each = 40 kB), 1 spectrum pair + fault frequencies per second,
speed at 50 Hz. Signals: sines plus Gaussian noise (noise hardly compresses: the worst case for zstd).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="bkabem_bench_log_"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import mcap_io  # noqa: E402

FS = 51_200.0
CHUNK_S = 0.1
N = int(FS * CHUNK_S)


def _cpu() -> float:
    """CPU seconds (user + system) of this process, all threads."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def make_stream(seconds: float, seed: int = 0):
    """Messages of ``seconds`` of node output: list of (topic, type, msg, stamp_ns), pre-built."""
    from std_msgs.msg import Float64

    rng = np.random.default_rng(seed)
    t0 = 1_700_000_000_000_000_000
    out = []
    n_chunks = int(round(seconds / CHUNK_S))
    k = np.arange(0, 40, dtype=float)
    for j in range(n_chunks):
        stamp = t0 + int(round(j * N / FS * 1e9))
        t = (j * N + np.arange(N)) / FS
        for b in ("de", "nde"):
            for q in ("acceleration", "displacement"):
                scale = 1.0 if q == "acceleration" else 1e-6
                x = scale * (np.sin(2 * np.pi * 157.0 * t) + 0.3 * rng.standard_normal((2, N)))
                m = msgs.waveform_message(x, sample_rate=FS, first_sample_index=j * N, shaft_speed=2 * math.pi * 25,
                                          machine_id="bench", location=b, quantity=q,
                                          channel_names=["vertical", "horizontal"], stamp=stamp)
                out.append((f"/bench/vibration/{b}/{q}", "bkabem_msgs/msg/VibrationWaveform", m, stamp))
        for i in range(5):
            out.append(("/bench/speed", "std_msgs/msg/Float64", Float64(data=2 * math.pi * 25), stamp + i * 20_000_000))
        if j % 10 == 0:
            for b in ("de", "nde"):
                for q in ("acceleration", "displacement"):
                    amp = np.stack([1 / (1 + k), 0.5 / (1 + k)])
                    s = msgs.spectrum_message(k * 89.4, k, amp, np.zeros_like(amp), shaft_speed=2 * math.pi * 25,
                                              machine_id="bench", location=b, quantity=q,
                                              channel_names=["vertical", "horizontal"], stamp=stamp)
                    out.append((f"/bench/vibration/{b}/spectrum", "bkabem_msgs/msg/VibrationSpectrum", s, stamp))
            f = msgs.fault_frequencies_message(shaft_speed=2 * math.pi * 25, ftf=9.9, bpfo=89.4, bpfi=135.6, bsf=58.9,
                                               machine_id="bench", bearing_designation="6010", defect_bearing="de",
                                               defect_length=1e-3, defect_depth=2e-5, defect_angle=0.0, stamp=stamp)
            out.append(("/bench/vibration/fault_frequencies", "bkabem_msgs/msg/BearingFaultFrequencies", f, stamp))
    return out


def bench_mcap(stream, seconds: float, tmp: Path) -> dict:
    path = tmp / "bench.mcap"
    c0, w0 = _cpu(), time.perf_counter()
    sink = mcap_io.McapSink(path)
    for topic, ty, m, stamp in stream:
        sink(topic, ty, m, stamp)
    sink.close()
    cpu, wall = _cpu() - c0, time.perf_counter() - w0
    # nothing lost: every message, gap-free sample indices per waveform stream
    n_file, gaps, last = 0, 0, {}
    for r in mcap_io.iter_messages(path):
        n_file += 1
        if r.type_name.endswith("VibrationWaveform"):
            prev = last.get(r.topic)
            if prev is not None and r.msg.first_sample_index != prev + N:
                gaps += 1
            last[r.topic] = r.msg.first_sample_index
    size = path.stat().st_size
    raw = sum(len(m.data) * 4 for _t, ty, m, _s in stream if ty.endswith("VibrationWaveform"))
    return {"data_s": seconds, "messages": len(stream), "in_file": n_file, "dropped": sink.dropped,
            "index_gaps": gaps, "cpu_s": round(cpu, 3), "wall_s": round(wall, 3),
            "cpu_percent_of_one_core": round(100 * cpu / seconds, 2),
            "file_mb": round(size / 1e6, 2), "raw_sample_mb": round(raw / 1e6, 2),
            "mb_per_hour": round(size / 1e6 * 3600 / seconds, 0)}


def bench_rerun(stream, seconds: float, tmp: Path) -> dict:
    from bkabem_ros.viewer.rerun_io import RerunLogger, RerunSink

    path = tmp / "bench.rrd"
    c0, w0 = _cpu(), time.perf_counter()
    logger = RerunLogger("bkabem-bench", save_path=path)
    sink = RerunSink(logger)
    for topic, ty, m, stamp in stream:
        sink(topic, ty, m, stamp)
    sink.close()
    cpu, wall = _cpu() - c0, time.perf_counter() - w0
    return {"data_s": seconds, "samples": logger.samples_logged, "cpu_s": round(cpu, 3), "wall_s": round(wall, 3),
            "cpu_percent_of_one_core": round(100 * cpu / seconds, 2),
            "file_mb": round(path.stat().st_size / 1e6, 2),
            "mb_per_hour": round(path.stat().st_size / 1e6 * 3600 / seconds, 0)}


# --------------------------------------------------------------------------- the node
NODE_CHILD = r"""
import json, os, resource, sys, time, threading
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from std_msgs.msg import Float64
from bkabem_ros.node.vibration_node import VibrationNode
mode, seconds, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
rclpy.init()
node = VibrationNode("bench", namespace="/bench", start=False, parameter_overrides=[
    Parameter("sample_rate", value=51200.0), Parameter("chunk_duration", value=0.1),
    Parameter("noise_acc", value=3.125e-3), Parameter("spectrum_rate", value=1.0)])     # 0.5 m/s^2 RMS
cleanup = None
published = {"n": 0}
node.add_sink(lambda topic, t, m, s: published.__setitem__("n", published["n"] + 1))
if mode == "mcap_inline":
    from bkabem_ros.recording.mcap_io import McapSink
    _s = McapSink(out + ".mcap", threaded=False)
    node.add_sink(_s)
    cleanup = _s.close
elif mode != "plain":
    from bkabem_ros.recording.record import attach_sinks
    cleanup = attach_sinks(node, record=out + ".mcap",
                           rerun_save=(out + ".rrd") if mode == "mcap+rerun" else None)
speed_node = rclpy.create_node("bench_speed", namespace="/bench")
pub = speed_node.create_publisher(Float64, "speed", 10)
ex = SingleThreadedExecutor(); ex.add_node(node); ex.add_node(speed_node)
speed_node.create_timer(0.02, lambda: pub.publish(Float64(data=2 * 3.141592653589793 * 25.0)))
node.start()
for _ in range(20):            # warm-up 0.2 s+
    ex.spin_once(timeout_sec=0.05)
r0 = resource.getrusage(resource.RUSAGE_SELF); t0 = time.perf_counter(); chunks0 = node.stats()["chunks"]
t_end = t0 + seconds
while time.perf_counter() < t_end:
    ex.spin_once(timeout_sec=0.05)
r1 = resource.getrusage(resource.RUSAGE_SELF); t1 = time.perf_counter(); st = node.stats()
if cleanup:
    cleanup()
cpu = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
print(json.dumps({"mode": mode, "wall_s": t1 - t0, "cpu_s": cpu, "cpu_percent": 100 * cpu / (t1 - t0),
                  "chunks": st["chunks"] - chunks0, "sink_messages": published["n"],
                  "lateness_ms_p99": st["lateness_ms_p99"]}))
node.destroy_node(); speed_node.destroy_node(); rclpy.shutdown()
"""


def bench_node(seconds: float, tmp: Path, repeats: int = 3, modes=None) -> dict:
    import subprocess

    res = {}
    root = Path(__file__).resolve().parents[1]
    for mode in modes or (("plain", "mcap") * repeats + ("mcap+rerun",)):
        out = tmp / f"node_{mode}"
        env = dict(os.environ, ROS_DOMAIN_ID=str(100 + os.getpid() % 100))
        r = subprocess.run([sys.executable, "-c", NODE_CHILD, mode, str(seconds), str(out)], capture_output=True,
                           text=True, cwd=root, env=env, timeout=seconds * 4 + 120)
        if r.returncode != 0:
            return {"skipped": f"node did not run: {r.stderr.strip().splitlines()[-1] if r.stderr.strip() else r.returncode}"}
        d = json.loads(r.stdout.strip().splitlines()[-1])
        if mode != "plain":
            path = Path(str(out) + ".mcap")
            s = mcap_io.summary(path)
            d["in_file"] = s["messages"]
            d["file_mb"] = round(path.stat().st_size / 1e6, 2)
            waves = [m.msg.first_sample_index for m in mcap_io.iter_messages(path, ["/bench/vibration/de/acceleration"])]
            step = int(51200 * 0.1)
            d["index_gaps"] = int(sum(1 for a, b in zip(waves, waves[1:]) if b != a + step))
        res.setdefault(mode, []).append({k: (round(v, 3) if isinstance(v, float) else v) for k, v in d.items()})
    if modes:
        return res
    plain = float(np.median([x["cpu_percent"] for x in res["plain"]]))
    rec = float(np.median([x["cpu_percent"] for x in res["mcap"]]))
    # paired differences (runs alternate, so slow phases of the machine hit both alike)
    pairs = [m["cpu_percent"] - p["cpu_percent"] for p, m in zip(res["plain"], res["mcap"])]
    res["node_cpu_percent_median"] = round(plain, 2)
    res["node_with_mcap_cpu_percent_median"] = round(rec, 2)
    res["overhead_mcap_percent_of_one_core"] = round(rec - plain, 2)
    res["overhead_mcap_paired"] = [round(x, 2) for x in pairs]
    res["overhead_mcap_rerun_percent_of_one_core"] = round(res["mcap+rerun"][0]["cpu_percent"] - plain, 2)
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="seconds of data for parts 1-2")
    ap.add_argument("--node-seconds", type=float, default=20.0, help="seconds per node run (part 3); 0: skip")
    ap.add_argument("--repeats", type=int, default=3, help="alternating plain/mcap node runs (part 3)")
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bkabem_bench_") as d:
        tmp = Path(d)
        stream = make_stream(args.seconds)
        result = {"mcap_sink": bench_mcap(stream, args.seconds, tmp),
                  "rerun_logger": bench_rerun(stream, args.seconds, tmp)}
        if args.node_seconds > 0:
            result["node"] = bench_node(args.node_seconds, tmp, args.repeats)
    result["machine"] = {"cpus": os.cpu_count(), "load_avg_1min": round(os.getloadavg()[0], 2)}
    print(json.dumps(result, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
