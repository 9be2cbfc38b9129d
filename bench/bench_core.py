"""Benchmark of the BKA-BEM core (issue 2 targets). Not a test: run it, read the table, update BENCHMARKS.md.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_core.py [--repeats 5]

Measures, in one process on the embedded case:
  * one-time preparation: 4-DOF excitation + FE assembly + solver set-up (BkaBem construction), target <= 2 s
  * spectrum at a new speed, all kept orders, all outputs (block solver), target <= 1 ms median
  * sweep of 1000 speeds, target <= 1 s
  * the same spectrum with the direct (LAPACK, full matrix) solver, as the in-run reference ratio
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bkabem_core.case import Case  # noqa: E402
from bkabem_core.harmonic import BkaBem  # noqa: E402


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args()
    case = Case.load()
    prep, prep_all = median_time(lambda: BkaBem(case), args.repeats)
    model = BkaBem(case)
    stages = model.preparation_time_s
    direct = BkaBem(case, excitation=model.excitation, solver="direct")
    rng = np.random.default_rng(1)
    speeds = rng.uniform(1.0, case.max_speed_hz, 300)
    model.spectrum(10.0)
    t_block = []
    for s in speeds:
        t = time.perf_counter()
        model.spectrum(float(s))
        t_block.append(time.perf_counter() - t)
    t_direct = []
    for s in speeds[:60]:
        t = time.perf_counter()
        direct.spectrum(float(s))
        t_direct.append(time.perf_counter() - t)
    sweep_speeds = np.linspace(0.5, case.max_speed_hz, 1000)
    sweep, _ = median_time(lambda: model.sweep(sweep_speeds), args.repeats)
    res = {
        "machine": f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                   f"Python {platform.python_version()}, numpy {np.__version__}",
        "orders": int(model.orders.size), "ndof": model.rotor.ndof,
        "preparation_s_median": prep, "preparation_s_all": prep_all,
        "preparation_stages_s": stages,
        "spectrum_block_ms_median": 1e3 * statistics.median(t_block),
        "spectrum_block_ms_p90": 1e3 * float(np.percentile(t_block, 90)),
        "spectrum_direct_ms_median": 1e3 * statistics.median(t_direct),
        "sweep_1000_s_median": sweep,
    }
    res["direct_over_block"] = res["spectrum_direct_ms_median"] / res["spectrum_block_ms_median"]
    print(json.dumps(res, indent=1))
    print()
    print("| quantity | median | target | in-run reference |")
    print("|---|---|---|---|")
    print(f"| one-time preparation (4-DOF + FE + solver set-up) | {prep:.2f} s | <= 2 s | "
          f"4-DOF {stages['excitation']:.2f} s |")
    print(f"| spectrum at a new speed, {res['orders']} orders x 8 outputs | "
          f"{res['spectrum_block_ms_median']:.2f} ms (p90 {res['spectrum_block_ms_p90']:.2f}) | <= 1 ms | "
          f"direct LAPACK solve {res['spectrum_direct_ms_median']:.2f} ms ({res['direct_over_block']:.1f}x slower) |")
    print(f"| sweep of 1000 speeds | {sweep:.2f} s | <= 1 s | |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
