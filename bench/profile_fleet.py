"""Where a fleet machine's CPU goes: py-spy samples of one fleet process, grouped by what the code is doing.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/profile_fleet.py --machines 32 --seconds 20 [--code DIR]
        [--executor events|single] [--rate 100]

Needs ``py-spy`` (``.venv/bin/pip install py-spy``; not a dependency of bkabem). Runs ``bkabem fleet --machines N
--processes 1`` (from ``--code DIR`` when given, e.g. a checkout of the previous main) with every machine at 25 Hz
(one ``bkabem speed`` at 2 Hz, all speed topics remapped onto it), waits until all streams run, then records the
process's Python thread with native frames (``py-spy record --native``, 50 samples/s: each sample pauses the
process briefly) and reads the CPU time of every thread from /proc. Samples whose innermost frames are a wait
(pthread_cond_*wait, epoll_wait, poll, futex, nanosleep: the executor idling between timers) are idle and left
out; the groups are shares of the busy samples. (Without native frames py-spy counts the EventsExecutor's
condition-variable wait as busy.) A sample is put in the first group whose pattern is on its stack, in this order:
synthesis (bkabem_core), serialize_message, the waveform CDR encoder, publish (rclpy -> rmw -> Fast DDS write), message building
(bkabem_ros/messages/convert.py, the generated message classes), clock and time objects, the node's own Python
(_on_tick/_prepare), the executor (wait set, dispatch); the rest is listed by its leaf frame.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import thread_cpu  # noqa: E402
from bench_node import REPO, Proc, bkabem, ros_env  # noqa: E402

GROUPS = [
    ("synthesis (bkabem_core, C kernels)", re.compile(r"bkabem_core/|_synth|_modalsum|_blocktri")),
    ("serialize_message (message -> CDR)", re.compile(r"serialize_message")),
    ("waveform CDR fast path (waveform_cdr.py)", re.compile(r"bkabem_ros/waveform_cdr\.py")),
    ("publish (rclpy -> rmw -> Fast DDS write)", re.compile(r"Publisher\.publish")),
    ("message building (msgs.py, message classes)", re.compile(r"bkabem_ros/msgs\.py|bkabem_msgs/msg/|std_msgs/msg/")),
    ("clock and time objects", re.compile(r"Clock\.now|rclpy/time\.py")),
    ("node Python (_on_tick, _prepare, stats)", re.compile(r"bkabem_ros/node\.py")),
    ("executor (wait set, dispatch, tasks)", re.compile(r"rclpy/executors\.py|rclpy/task\.py|rclpy/wait|"
                                                        r"events_executor|\(bkabem_ros/fleet\.py")),
]


IDLE = re.compile(r"pthread_cond_(timed)?wait|epoll_wait|\bpoll\b|futex|nanosleep|sem_(timed)?wait|select \(")


def group(raw_path: str) -> tuple[list, int, int]:
    tot: collections.Counter = collections.Counter()
    n = idle = 0
    for ln in open(raw_path):
        stack, cnt = ln.rstrip().rsplit(" ", 1)
        cnt = int(cnt)
        frames = stack.split(";")
        if any(IDLE.search(f) for f in frames[-3:]):
            idle += cnt
            continue
        n += cnt
        for name, rx in GROUPS:
            if any(rx.search(f) for f in frames):
                tot[name] += cnt
                break
        else:
            leaf = re.sub(r"0x[0-9a-f]+ ", "", frames[-1])
            tot["other: " + leaf[:60]] += cnt
    return [(k, round(100 * v / max(n, 1), 1)) for k, v in tot.most_common(12)], n, idle


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machines", type=int, default=32)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--code", default=None, help="run the fleet of this checkout (PYTHONPATH)")
    ap.add_argument("--executor", default=None, choices=("events", "single"))
    ap.add_argument("--rate", type=int, default=50, help="py-spy samples per second")
    args = ap.parse_args()
    spy = shutil.which("py-spy") or str(Path(sys.executable).with_name("py-spy"))
    if not Path(spy).exists():
        sys.exit("profile_fleet: py-spy not found (pip install py-spy)")
    env = ros_env()
    cwd = str(REPO)
    if args.code:
        env["PYTHONPATH"] = args.code
        cwd = args.code
    speed = Proc(bkabem("speed", "--namespace", "/prof", "--profile", "constant:25", "--rate", "2"),
                 {k: v for k, v in env.items() if k != "PYTHONPATH"})
    extra = ["--executor", args.executor] if args.executor else []
    fleet = Proc(bkabem("fleet", "--machines", str(args.machines), "--processes", "1", "--prefix", "pf_",
                        "--seconds", "100000", *extra, "--ros-args", "-r", "speed:=/prof/speed"), env, cwd)
    t0 = time.monotonic()
    while sum("streaming from t0" in ln for ln in list(fleet.lines)) < args.machines:
        if time.monotonic() - t0 > 300 or fleet.p.poll() is not None:
            sys.exit("fleet did not start:\n" + "\n".join(fleet.lines[-20:]))
        time.sleep(0.2)
    time.sleep(3.0)
    raw = tempfile.mktemp(suffix=".txt", prefix="bkabem_prof_")
    pid = fleet.p.pid
    c0, w0 = thread_cpu([pid]), time.monotonic()
    subprocess.run([spy, "record", "--native", "-p", str(pid), "-d", str(int(args.seconds)),
                    "-r", str(args.rate), "--format", "raw", "-o", raw], capture_output=True, check=True)
    c1, w1 = thread_cpu([pid]), time.monotonic()
    fleet.stop(signal.SIGINT, timeout=60)
    speed.stop()
    groups, samples, idle = group(raw)
    os.unlink(raw)
    cpu = {k: round(100 * (c1[k] - c0[k]) / (w1 - w0), 1) for k in c0}
    out = {"machines": args.machines, "code": args.code or "this checkout", "executor": args.executor or "default",
           "cpu_pct_of_one_core": cpu, "cpu_pct_per_machine": round(sum(cpu.values()) / args.machines, 2),
           "python_thread_busy_samples": samples, "python_thread_idle_samples": idle,
           "python_thread_groups_pct": groups,
           "load_average_1min": round(os.getloadavg()[0], 2), "cwd": cwd}
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
