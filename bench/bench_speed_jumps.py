"""Benchmark: publish lateness of the node under speed jumps, to and from 0 included.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_speed_jumps.py [--repeats 3] [--json FILE]
        [--baseline DIR]      # also run an older checkout (DIR on PYTHONPATH, `python -m bkabem_core.cli`)

For each code version and scenario, real processes on loopback: ``bkabem node`` (25.6 kHz, 0.1 s chunks,
spectrum "exact", ``--wait-for-speed``: the stream starts at the profile's first speed) and ``bkabem speed``
publishing the profile at 50 Hz; the node's own exit statistics give
the publish lateness (waveforms handed to DDS minus the time the chunk's last sample was due), p50/p99/max.

Scenarios: ``steady`` (40 Hz: the reference of the same run), ``jumps`` (20 <-> 60 Hz every 0.7 s), ``via-zero``
(0 -> 75 -> 0 -> 40 -> 0 -> 75 -> 0 Hz every 0.7 s: start-ups and emergency stops). Reported: the median over the
repeats of each statistic, and the ratio of the worst lateness to that of ``steady`` in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CWD = tempfile.mkdtemp(prefix="bkabem_bj_cwd_")   # not the repo: a --baseline checkout must win on sys.path
SCENARIOS = {"steady": "constant:40", "jumps": "steps:20,60,20,60,20,60,20:0.7",
             "via-zero": "steps:0,75,0,40,0,75,0:0.7"}


def _env(pythonpath: str | None) -> dict:
    env = dict(os.environ)
    env.update({"ROS_DOMAIN_ID": str(random.SystemRandom().randint(101, 200)),
                "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_LOG_DIR": tempfile.mkdtemp(prefix="bkabem_bj_"),
                "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"})
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    return env


def run_once(cli: list[str], env: dict, profile: str) -> tuple[float, float, float]:
    ns = f"/bj{os.getpid()}_{random.randrange(1 << 24):x}"
    lines: list[str] = []
    node = subprocess.Popen(cli + ["node", "--namespace", ns, "--chunk-duration", "0.1", "--wait-for-speed"],
                            env=env, cwd=CWD,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    t = threading.Thread(target=lambda: lines.extend(ln.rstrip() for ln in node.stdout), daemon=True)
    t.start()
    t_end = time.monotonic() + 90
    while not any("waiting for the first speed" in ln or "streaming from t0" in ln for ln in lines):
        if time.monotonic() > t_end or node.poll() is not None:
            node.kill()
            raise RuntimeError("node did not start:\n" + "\n".join(lines[-20:]))
        time.sleep(0.05)
    seconds = ["--seconds", "4.9"] if profile.startswith("constant") else []
    subprocess.run(cli + ["speed", "--namespace", ns, "--profile", profile, "--rate", "50", "--hold", "0.5",
                          "--quiet", *seconds], env=env, cwd=CWD, check=True, timeout=60)
    time.sleep(0.3)
    node.send_signal(signal.SIGINT)
    node.wait(30)
    t.join(5)
    m = re.search(r"publish lateness p50 ([\d.]+) ms p99 ([\d.]+) ms max ([\d.]+) ms", "\n".join(lines))
    if not m:
        raise RuntimeError("no stats line:\n" + "\n".join(lines[-20:]))
    return tuple(map(float, m.groups()))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--baseline", default=None, help="checkout of an older version (its bkabem_core.cli)")
    ap.add_argument("--json", default=None, help="also write the medians per version and scenario here")
    a = ap.parse_args(argv)
    versions = [("this", [sys.executable, "-m", "bkabem_ros"], None)]
    if a.baseline:
        versions.insert(0, ("baseline", [sys.executable, "-m", "bkabem_core.cli"], a.baseline))
    print(f"{'version':9s} {'scenario':9s} {'p50 ms':>8s} {'p99 ms':>8s} {'max ms':>8s} {'max/steady':>10s}  "
          f"(median of {a.repeats})")
    out = []
    for name, cli, pp in versions:
        env = _env(pp)
        res = {}
        for r in range(a.repeats):                       # interleaved: load changes hit every scenario alike
            for sc, profile in SCENARIOS.items():
                res.setdefault(sc, []).append(run_once(cli, env, profile))
        steady_max = statistics.median(x[2] for x in res["steady"])
        for sc in SCENARIOS:
            p50, p99, mx = (statistics.median(x[i] for x in res[sc]) for i in range(3))
            print(f"{name:9s} {sc:9s} {p50:8.2f} {p99:8.2f} {mx:8.2f} {mx / steady_max:10.1f}", flush=True)
            out.append({"version": name, "scenario": sc, "profile": SCENARIOS[sc], "repeats": a.repeats,
                        "p50_ms": p50, "p99_ms": p99, "max_ms": mx, "max_over_steady": mx / steady_max})
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
