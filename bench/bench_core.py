"""Benchmark of the BKA-BEM core (bench/run_all.py puts its numbers in BENCHMARKS.md).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_core.py [--repeats 5]

Measures, in one process on the embedded case (the core's targets):
  * one-time preparation: machine + excitation of both bearings + modal basis + one eigen-decomposition per order
    (BkaBem construction), target <= 2 s; and a model made `like` it for another defect (FE reused)
  * spectrum at a new speed, all kept orders, all outputs (the reduced modal form), target <= 1 ms median
  * sweep of 1000 speeds, target <= 1 s
  * the improved method (HillCorrection) at a new speed, target <= 1 ms
  * in-run references: the same spectrum by the exact block-tridiagonal solve of the full FE and by dense LAPACK
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

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402
from bkabem_core.solve.improved import HillCorrection  # noqa: E402


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times


def per_call(fn, speeds):
    out = []
    for s in speeds:
        t = time.perf_counter()
        fn(float(s))
        out.append(time.perf_counter() - t)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args()
    case = Case.load()
    prep, prep_all = median_time(lambda: BkaBem(case), args.repeats)
    model = BkaBem(case)
    stages = model.preparation_time_s
    other = case.with_overrides({"dent.depth_m": 20e-6})
    like, _ = median_time(lambda: BkaBem(other, like=model), args.repeats)
    block = BkaBem(case, excitation=model.excitations, solver="block", machine=model.machine)
    direct = BkaBem(case, excitation=model.excitations, solver="direct", machine=model.machine)
    hill_prep, _ = median_time(lambda: HillCorrection(model), args.repeats)
    hill = HillCorrection(model)
    rng = np.random.default_rng(1)
    speeds = rng.uniform(1.0, case.max_speed_hz, 300)
    model.spectrum(10.0)
    hill.spectrum(10.0)
    block.spectrum(10.0)
    t_modal = per_call(model.spectrum, speeds)
    t_hill = per_call(hill.spectrum, speeds[:100])
    t_block = per_call(block.spectrum, speeds[:30])
    t_direct = per_call(direct.spectrum, speeds[:3])
    sweep_speeds = np.linspace(0.5, case.max_speed_hz, 1000)
    sweep, _ = median_time(lambda: model.sweep(sweep_speeds), args.repeats)
    info = model.solver_info()
    res = {
        "machine": f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                   f"Python {platform.python_version()}, numpy {np.__version__}",
        "orders": int(model.orders.size), "ndof": model.rotor.ndof, "modal_basis": info["modal_basis_size"],
        "preparation_s_median": prep, "preparation_s_all": prep_all, "preparation_stages_s": stages,
        "like_preparation_s_median": like,
        "spectrum_modal_ms_median": 1e3 * statistics.median(t_modal),
        "spectrum_modal_ms_p90": 1e3 * float(np.percentile(t_modal, 90)),
        "hill_preparation_s_median": hill_prep,
        "hill_ms_median": 1e3 * statistics.median(t_hill),
        "hill_ms_p90": 1e3 * float(np.percentile(t_hill, 90)),
        "spectrum_block_ms_median": 1e3 * statistics.median(t_block),
        "spectrum_direct_ms_median": 1e3 * statistics.median(t_direct),
        "sweep_1000_s_median": sweep,
    }
    print(json.dumps(res, indent=1))
    print()
    m = res["spectrum_modal_ms_median"]
    print("| quantity | median | target | in-run reference |")
    print("|---|---|---|---|")
    print(f"| one-time preparation (machine, 2 excitations, modal basis, {res['orders']} line eigs) | {prep:.2f} s | "
          f"<= 2 s | excitations {stages['excitation']:.2f} s, solver set-up {stages['solver_setup']:.2f} s |")
    print(f"| model for another defect of the same machine (`like=`) | {like * 1e3:.0f} ms | | |")
    print(f"| spectrum at a new speed, {res['orders']} orders x 8 outputs | {m:.3f} ms (p90 "
          f"{res['spectrum_modal_ms_p90']:.3f}) | <= 1 ms | exact block solve of the {res['ndof']}-DOF FE "
          f"{res['spectrum_block_ms_median']:.1f} ms ({res['spectrum_block_ms_median'] / m:.0f}x), dense LAPACK "
          f"{res['spectrum_direct_ms_median']:.0f} ms |")
    print(f"| sweep of 1000 speeds | {sweep:.2f} s | <= 1 s | |")
    print(f"| improved method (Hill) at a new speed | {res['hill_ms_median']:.2f} ms (p90 {res['hill_ms_p90']:.2f}) | "
          f"<= 1 ms | {res['hill_ms_median'] / m:.1f}x the plain spectrum; preparation {hill_prep * 1e3:.0f} ms |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
