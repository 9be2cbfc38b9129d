"""Benchmark: the cost of Rerun logging at 51.2 kHz x 8 channels, this tree against a baseline tree.

    .venv/bin/python bench/bench_rerun.py [--seconds 10] [--repeats 3] [--baseline /path/to/main-checkout] [--json F]

The data is ``bench/bench_record.py``'s node pattern (0.1 s chunks of 4 ``VibrationWaveform`` of
2 x 5120 float32 samples: DE/NDE x acceleration/displacement, sines + Gaussian noise; spectra and
fault frequencies at 1 Hz; speed at 50 Hz), built once per process before timing. Each run is a
fresh process that imports ``bkabem_ros`` from the tree under test (this one, or ``--baseline``,
e.g. ``git worktree add --detach ../bkabem-base main``), feeds the data through ``RerunSink`` ->
``RerunLogger`` -> ``.rrd`` as fast as it can, closes the file, and reports process CPU seconds
(all threads, Rerun's encoder included) per second of data = the fraction of one core that
logging costs in real time, and the file size per recorded second. The one-off set-up (logger
and blueprint, once per recording) and, for this tree, the chunk compaction that
``RerunLogger.close()`` runs on a file (``rerun rrd optimize``, a child process) are timed apart. Runs alternate baseline /
this tree, so both see the same machine load; the ratio of medians is the number to compare.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

CHILD = r"""
import importlib.util, json, os, resource, sys, tempfile, time
tree, seconds = sys.argv[1], float(sys.argv[2])
spec = importlib.util.spec_from_file_location("bkabem_ros", os.path.join(tree, "bkabem_ros", "__init__.py"),
                                              submodule_search_locations=[os.path.join(tree, "bkabem_ros")])
pkg = importlib.util.module_from_spec(spec); sys.modules["bkabem_ros"] = pkg; spec.loader.exec_module(pkg)
sys.path.insert(0, sys.argv[3])
import bench_record
from bkabem_ros.viewer.rerun_io import RerunLogger, RerunSink
import bkabem_ros.viewer.rerun_io as rio
assert rio.__file__.startswith(tree), rio.__file__
stream = bench_record.make_stream(seconds)
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF); return r.ru_utime + r.ru_stime
path = os.path.join(tempfile.mkdtemp(), "bench.rrd")
c_start = cpu()
import inspect
kw = {"optimize": False} if "optimize" in inspect.signature(RerunLogger).parameters else {}
logger = RerunLogger("bkabem-bench", save_path=path, **kw)    # the compaction after close is timed apart
sink = RerunSink(logger)
setup = cpu() - c_start                      # once per recording (the blueprint): reported apart
c0, w0 = cpu(), time.perf_counter()
for topic, ty, m, stamp in stream:
    sink(topic, ty, m, stamp)
sink.close()
c, w = cpu() - c0, time.perf_counter() - w0
size = os.path.getsize(path)
opt_s = None
if kw:                                       # this tree: compact the file as close() would
    ch0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    err = rio.optimize_rrd(path)
    ch1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert err is None, err
    opt_s = (ch1.ru_utime + ch1.ru_stime) - (ch0.ru_utime + ch0.ru_stime)
    opt_size = os.path.getsize(path)
print(json.dumps({"cpu_s": c, "wall_s": w, "setup_cpu_s": setup, "optimize_cpu_s": opt_s,
                  "optimized_bytes_per_s": (opt_size / seconds) if opt_s is not None else None, "cpu_percent_of_one_core": 100 * c / seconds,
                  "bytes_per_s": size / seconds, "bytes_per_sample": size / logger.samples_logged,
                  "samples": logger.samples_logged, "dropped": sink.dropped, "error": str(sink.error or "")}))
os.remove(path)
"""


def run(tree: Path, seconds: float) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1",
               ROS_LOG_DIR=os.environ.get("ROS_LOG_DIR") or tempfile.mkdtemp(prefix="bkabem_bench_log_"))
    r = subprocess.run([sys.executable, "-c", CHILD, str(tree), str(seconds), str(HERE)], capture_output=True,
                       text=True, env=env, timeout=1200)
    if r.returncode != 0:
        raise SystemExit(f"run in {tree} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seconds", type=float, default=10.0, help="seconds of data per run (default 10)")
    p.add_argument("--repeats", type=int, default=3, help="runs per tree (default 3)")
    p.add_argument("--baseline", type=Path, default=None, help="another checkout to compare with")
    p.add_argument("--json", type=Path, default=None, help="also write the summary and the runs here")
    args = p.parse_args(argv)
    trees = {"this tree": ROOT}
    if args.baseline is not None:
        trees = {"baseline": args.baseline.resolve(), "this tree": ROOT}
    res: dict[str, list[dict]] = {k: [] for k in trees}
    for i in range(args.repeats):
        for name, tree in trees.items():
            r = run(tree, args.seconds)
            res[name].append(r)
            print(f"run {i + 1} {name:9s}: {r['cpu_percent_of_one_core']:5.1f} % of one core, "
                  f"{r['bytes_per_s'] / 1e6:5.2f} MB per recorded second, {r['bytes_per_sample']:5.2f} B/sample, "
                  f"wall {r['wall_s']:.2f} s, set-up {r['setup_cpu_s'] * 1e3:.0f} ms CPU, dropped {r['dropped']}",
                  flush=True)
    summary = {}
    for name, runs in res.items():
        summary[name] = {
            "cpu_percent_median": statistics.median(r["cpu_percent_of_one_core"] for r in runs),
            "mb_per_recorded_s": statistics.median(r["bytes_per_s"] for r in runs) / 1e6,
            "bytes_per_sample": statistics.median(r["bytes_per_sample"] for r in runs),
            "setup_cpu_ms": 1e3 * statistics.median(r["setup_cpu_s"] for r in runs)}
        if runs[0]["optimize_cpu_s"] is not None:
            summary[name]["optimize_cpu_s_per_recorded_s"] = statistics.median(
                r["optimize_cpu_s"] / args.seconds for r in runs)
            summary[name]["optimized_mb_per_recorded_s"] = statistics.median(
                r["optimized_bytes_per_s"] for r in runs) / 1e6
    if "baseline" in summary:
        b, t = summary["baseline"], summary["this tree"]
        summary["ratio this/baseline"] = {"cpu": t["cpu_percent_median"] / b["cpu_percent_median"],
                                          "size": t["mb_per_recorded_s"] / b["mb_per_recorded_s"]}
    print(json.dumps(summary, indent=1))
    if args.json:
        args.json.write_text(json.dumps({"summary": summary, "runs": res, "seconds": args.seconds}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
