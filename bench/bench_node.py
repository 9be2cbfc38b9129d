"""Benchmark of the bkabem ROS 2 node: CPU, publish jitter, losses, speed-change latency, fleet size.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_node.py [--seconds 60] [--rates 25600,51200]
        [--chunk 0.1] [--qos reliable] [--fleet 1,2,4,8] [--fleet-seconds 20] [--json FILE]

Part 1, one node per sample rate: the node runs as its own process (``bkabem node``, all 8 channels:
DE/NDE x acceleration/displacement x vertical/horizontal) with reliable QoS; this process subscribes
(reliable, depth 100) to the four waveform topics and steps the speed between 20 and 40 Hz every 5 s.
Measured over ``--seconds`` after a 3 s warm-up:

- lost chunks: gaps in ``first_sample_index`` per topic (and chunks missing at the end);
- node CPU share: (utime + stime) of the node process / wall time, in % of one core;
- publish jitter: the node's own lateness log, from its exit line: time the chunk's four waveform messages had
  been handed to DDS minus the time its last sample was due (node clock), p50/p99/max; and the same for the
  start of the publication (the timer's wake-up delay);
- delivery: receive time here minus that due time (jitter + DDS + this subscriber);
- speed-change latency, from publishing a new speed: to receiving the chunk that ramps to it (the first one
  that responds), to receiving the first chunk that starts at it, and to the ramp chunk's first-sample stamp
  (where the change begins in the signal).

Part 2, fleet: ``bkabem fleet --machines N --seconds T`` for each N (machines spread over 2 processes from
N = 2), no subscribers; the per-machine exit statistics say whether every chunk was published before the
next was due (max lateness < one chunk) and the CPU of the fleet's processes is sampled from /proc.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DOMAIN = random.SystemRandom().randint(101, 200)
CLK_TCK = os.sysconf("SC_CLK_TCK")


def ros_env() -> dict:
    env = dict(os.environ)
    env.update({"ROS_DOMAIN_ID": str(DOMAIN), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                "ROS_LOG_DIR": tempfile.mkdtemp(prefix="bkabem_bench_log_"), "OPENBLAS_NUM_THREADS": "1",
                "PYTHONUNBUFFERED": "1", "RCUTILS_COLORIZED_OUTPUT": "0"})
    return env


def bkabem(*args) -> list[str]:
    return [sys.executable, "-m", "bkabem_ros", *args]


class Proc:
    def __init__(self, cmd, env, cwd=None):
        self.lines: list[str] = []
        self.p = subprocess.Popen(cmd, env=env, cwd=str(cwd or REPO), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  text=True, bufsize=1)
        self.t = threading.Thread(target=self._read, daemon=True)
        self.t.start()

    def _read(self):
        for line in self.p.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, pattern, timeout=90.0):
        rx = re.compile(pattern)
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            for ln in list(self.lines):
                m = rx.search(ln)
                if m:
                    return m
            if self.p.poll() is not None:
                break
            time.sleep(0.05)
        raise RuntimeError(f"no {pattern!r}; output:\n" + "\n".join(self.lines[-30:]))

    def stop(self, sig=signal.SIGINT, timeout=30):
        if self.p.poll() is None:
            self.p.send_signal(sig)
            self.p.wait(timeout)
        self.t.join(5)
        return self.p.returncode


def tree_pids(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        try:
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as fh:
                    todo += [int(c) for c in fh.read().split()]
        except OSError:
            pass
    return out


def cpu_seconds(pids) -> float:
    total = 0
    for p in pids:
        try:
            with open(f"/proc/{p}/stat") as fh:
                f = fh.read().rsplit(")", 1)[1].split()
            total += int(f[11]) + int(f[12])     # utime, stime (fields 14, 15)
        except OSError:
            pass
    return total / CLK_TCK


def pct(a, q):
    return float(np.percentile(a, q)) if len(a) else float("nan")


def parse_exit_stats(lines) -> dict:
    for ln in lines:
        m = re.search(r"(\d+) chunks .*lateness p50 ([-\d.]+) ms p99 ([-\d.]+) ms max ([-\d.]+) ms.*?"
                      r"\(start p50 ([-\d.]+) ms p99 ([-\d.]+) ms\)", ln)
        if m:
            return {"chunks": int(m.group(1)), "p50_ms": float(m.group(2)), "p99_ms": float(m.group(3)),
                    "max_ms": float(m.group(4)), "start_p50_ms": float(m.group(5)), "start_p99_ms": float(m.group(6))}
    return {}


# --------------------------------------------------------------------------- part 1: one node
def bench_node(rate: float, seconds: float, chunk: float, qos: str, prefix: list[str] | None = None) -> dict:
    env = ros_env()
    for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR"):
        os.environ[k] = env[k]
    import rclpy
    from bkabem_msgs.msg import VibrationWaveform
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64

    ns = f"/bench{os.getpid()}"
    node_p = Proc((prefix or []) + bkabem("node", "--namespace", ns, "--sample-rate", str(rate),
                                          "--chunk-duration", str(chunk), "--qos", qos, "--spectrum-rate", "1"), env)
    node_p.wait_for(r"streaming from t0")
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN)
    nd = rclpy.create_node("bench_sub", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(nd)
    rel = ReliabilityPolicy.RELIABLE if qos == "reliable" else ReliabilityPolicy.BEST_EFFORT
    sub_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=rel)
    recs = defaultdict(list)
    lock = threading.Lock()
    topics = [f"{ns}/vibration/{b}/{q}" for b in ("de", "nde") for q in ("acceleration", "displacement")]
    for t in topics:
        def cb(msg, _t=t):
            now = time.time_ns()
            st = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            with lock:
                recs[_t].append((now, int(msg.first_sample_index), st, float(msg.shaft_speed),
                                 int(msg.samples_per_channel)))
        nd.create_subscription(VibrationWaveform, t, cb, sub_qos)
    pub = nd.create_publisher(Float64, f"{ns}/speed", QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    stop = threading.Event()
    th = threading.Thread(target=lambda: [ex.spin_once(timeout_sec=0.05) for _ in iter(stop.is_set, True)],
                          daemon=True)
    th.start()
    t_wait = time.monotonic() + 15
    while pub.get_subscription_count() == 0 or any(nd.count_publishers(t) == 0 for t in topics):
        if time.monotonic() > t_wait:
            raise RuntimeError("no match with the node")
        time.sleep(0.05)
    steps = []         # (publish wall ns, speed rad/s)
    speeds_hz = [20.0, 40.0]

    def set_speed(hz):
        v = 2 * math.pi * hz
        for _ in range(3):            # a few copies: the first after matching may be dropped (best effort sub)
            pub.publish(Float64(data=v))
        return v

    set_speed(speeds_hz[0])
    time.sleep(3.0)                                                  # warm-up
    pids = tree_pids(node_p.p.pid)
    cpu0, wall0 = cpu_seconds(pids), time.monotonic()
    with lock:
        start_counts = {t: len(recs[t]) for t in topics}
    k = 0
    next_step = wall0 + 5.0
    while time.monotonic() - wall0 < seconds:
        if time.monotonic() >= next_step:
            k += 1
            t_pub = time.time_ns()
            v = set_speed(speeds_hz[k % 2])
            steps.append((t_pub, v))
            next_step += 5.0 + random.uniform(0.0, chunk)    # steps land at any phase of the chunk grid
        time.sleep(0.01)
    cpu1, wall1 = cpu_seconds(pids), time.monotonic()
    time.sleep(2 * chunk + 0.3)
    stop.set()
    th.join(5)
    rc = node_p.stop()
    node_stats = parse_exit_stats(node_p.lines)
    ex.shutdown()
    nd.destroy_node()
    rclpy.try_shutdown(context=ctx)

    n = int(round(rate * chunk))
    lost = 0
    delivered = []
    received = 0
    for t in topics:
        r = recs[t][start_counts[t]:]
        idx = np.array([x[1] for x in r], dtype=np.int64)
        lost += int(np.sum(np.diff(idx) // n - 1)) if idx.size > 1 else 0
        received += len(r)
        delivered += [(x[0] - x[2]) / 1e6 - chunk * 1e3 for x in r]
    acc = recs[topics[0]]
    lat_ramp, lat_recv, lat_stamp = [], [], []
    for t_pub, v in steps:
        i = next((i for i, x in enumerate(acc) if x[0] > t_pub and math.isclose(x[3], v)), None)
        if i is not None and i > 0:
            hit, ramp = acc[i], acc[i - 1]          # first chunk at the new speed; the chunk ramping to it
            lat_ramp.append((ramp[0] - t_pub) / 1e6)
            lat_recv.append((hit[0] - t_pub) / 1e6)
            lat_stamp.append((ramp[2] - t_pub) / 1e6)
    return {
        "sample_rate_hz": rate, "chunk_s": chunk, "qos": qos, "seconds": round(wall1 - wall0, 2),
        "samples_per_s": rate * 8, "messages_received": received, "lost_chunks": lost,
        "node_cpu_pct_of_one_core": round(100 * (cpu1 - cpu0) / (wall1 - wall0), 1),
        "publish_lateness_ms": node_stats,
        "delivery_ms_p50": round(pct(delivered, 50), 2), "delivery_ms_p99": round(pct(delivered, 99), 2),
        "speed_steps": len(steps),
        "speed_to_ramp_chunk_received_ms_median": round(pct(lat_ramp, 50), 1),
        "speed_to_ramp_chunk_received_ms_max": round(max(lat_ramp), 1) if lat_ramp else None,
        "speed_to_new_speed_chunk_received_ms_median": round(pct(lat_recv, 50), 1),
        "speed_to_new_speed_chunk_received_ms_max": round(max(lat_recv), 1) if lat_recv else None,
        "speed_to_ramp_start_in_signal_ms_median": round(pct(lat_stamp, 50), 1),
        "speed_to_ramp_start_in_signal_ms_max": round(max(lat_stamp), 1) if lat_stamp else None,
        "node_exit_code": rc, "node_command_prefix": " ".join(prefix or []),
        "load_average_1min_at_end": round(os.getloadavg()[0], 2),
    }


# --------------------------------------------------------------------------- part 2: fleet
def bench_fleet(machines: int, seconds: float, processes: int | None) -> dict:
    env = ros_env()
    procs = processes or (1 if machines == 1 else 2)
    warm = 8.0 + 2.0 * math.ceil(machines / procs) / 4     # model preparation + node start-up
    p = Proc(bkabem("fleet", "--machines", str(machines), "--processes", str(procs),
                    "--seconds", str(seconds + warm)), env)
    time.sleep(warm)
    pids = tree_pids(p.p.pid)
    cpu0, w0 = cpu_seconds(pids), time.monotonic()
    time.sleep(seconds - 1.0)
    cpu1, w1 = cpu_seconds(tree_pids(p.p.pid)), time.monotonic()
    p.p.wait(seconds + 120)
    p.t.join(5)
    stats = [json.loads(ln.split(" ", 1)[1]) for ln in p.lines if ln.startswith("FLEETSTATS ")]
    chunk_ms = 100.0
    worst_p99 = max((s["lateness_ms_p99"] for s in stats), default=float("nan"))
    worst_max = max((s["lateness_ms_max"] for s in stats), default=float("nan"))
    return {"machines": machines, "processes": procs, "reported": len(stats),
            "cpu_pct_of_one_core": round(100 * (cpu1 - cpu0) / (w1 - w0), 1),
            "lateness_ms_p50_median": round(float(np.median([s["lateness_ms_p50"] for s in stats])), 2)
            if stats else None,
            "lateness_ms_p99_worst": round(worst_p99, 2), "lateness_ms_max_worst": round(worst_max, 2),
            "reanchors": sum(s["reanchors"] for s in stats),
            "sustained": bool(stats) and len(stats) == machines and worst_max < chunk_ms
            and all(s["reanchors"] == 0 for s in stats)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rates", default="25600,51200")
    ap.add_argument("--chunk", type=float, default=0.1)
    ap.add_argument("--qos", choices=("reliable", "sensor_data"), default="reliable")
    ap.add_argument("--fleet", default="", help="comma list of machine counts (empty: skip)")
    ap.add_argument("--fleet-seconds", type=float, default=20.0)
    ap.add_argument("--processes", type=int, default=None, help="fleet processes (default 1 for N=1, else 2)")
    ap.add_argument("--json", default=None, help="also write the results here")
    ap.add_argument("--node-prefix", default="", help="run the node under this command, e.g. 'chrt -f 10'")
    args = ap.parse_args()
    results = {"node": [], "fleet": []}
    for r in [float(x) for x in args.rates.split(",") if x]:
        res = bench_node(r, args.seconds, args.chunk, args.qos, args.node_prefix.split())
        results["node"].append(res)
        print(json.dumps(res), flush=True)
    for n in [int(x) for x in args.fleet.split(",") if x]:
        res = bench_fleet(n, args.fleet_seconds, args.processes)
        results["fleet"].append(res)
        print(json.dumps(res), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
