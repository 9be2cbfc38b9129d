"""TDSM cost per step (median of several runs) and what it is made of; harmonic-balance solve times.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python3 bench/bench_tdsm.py [--steps 20000] [--repeats 5] [--json FILE]

Prints markdown tables (bench/run_all.py puts them in BENCHMARKS.md, "TDSM and validation"). The machine is shared:
the medians are what to quote, the spread says how noisy the run was.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import timeit

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case
from bkabem_core.reference.periodic import harmonic_balance
from bkabem_core.reference.tdsm import Tdsm


def per_step(case, speed, scheme, steps, repeats, max_step_s=1e-5, machine=None):
    # the exponential scheme on the converged machine; Newmark (dense, 3 ndof states) on the case's own elements
    m = Tdsm(case, speed, max_step_s=max_step_s, scheme=scheme, machine=machine if scheme == "exponential" else None,
             mesh="auto" if scheme == "exponential" else None)
    duration = steps * m.h
    m.run(0.01, settle_s=0.0, progress=False)                       # warm-up
    ms, newton = [], []
    for _ in range(repeats):
        r = m.run(duration, settle_s=0.02, progress=False)
        ms.append(r.ms_per_step)
        newton.append(r.newton_iterations_mean)
    return m, np.array(ms), float(np.mean(newton))


def breakdown(m, n=20000):
    """Cost of the pieces of one step [us] (timeit medians)."""
    s = m.the_integrator()
    z = np.random.default_rng(0).standard_normal(s.T.shape[0]) * 1e-9 + 0j
    u = m._u_static.copy()
    f = np.zeros(4)
    _, kt = m.forces.evaluate(u, 5)
    g = {"T": s.T, "W": s.W, "Bz": s.Bz, "H": s.H, "z": z, "u": u, "f": f, "kt": kt, "ev": m.forces.evaluate}
    items = {
        "state propagation T z (diagonal) and W_p f": "T * z; W.dot(f)",
        "predictor u_pred = Re(B_z z_pred) (+ H f)": "Bz.dot(z).real; H.dot(f)",
        "ball forces + tangents, both bearings (28 balls)": "ev(u, 5)",
        "Newton update (4 x 4, I - H K)": "r = u - u - H.dot(f); du = r - H.dot(kt.dot(r)); u - du; f + kt.dot(du); du.dot(du)",
        "state update z = z_pred + W f": "z + W.dot(f)",
    }
    out = {}
    for name, stmt in items.items():
        t = timeit.repeat(stmt, globals=g, number=n, repeat=5)
        out[name] = 1e6 * float(np.median(t)) / n
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--speeds", default="15,30,50")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    case = Case.load()
    speeds = [float(s) for s in a.speeds.split(",")]
    res = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                      f"Python {platform.python_version()}, numpy {np.__version__}", "runs": []}
    print(f"# TDSM ms/step ({a.steps} steps x {a.repeats} runs, median [min-max]); {res['machine']}\n")
    print("| speed [Hz] | scheme | step [us] | ms/step median | min-max | Newton iterations/step |")
    print("|---:|---|---:|---:|---|---:|")
    last = None
    machine = Machine(case)
    for s in speeds:
        for scheme in ("exponential", "newmark"):
            m, ms, newton = per_step(case, s, scheme, a.steps, a.repeats, machine=machine)
            res["runs"].append({"speed_hz": s, "scheme": scheme, "step_s": m.h, "ndof": m.ndof,
                                "ms_per_step": ms.tolist(), "newton": newton})
            print(f"| {s:g} | {scheme} ({m.ndof} DOF) | {m.h * 1e6:.2f} | {np.median(ms):.4f} | "
                  f"{ms.min():.4f}-{ms.max():.4f} | {newton:.3f} |")
            if scheme == "exponential" and s == 30.0:
                last = m
    last = last or m
    bd = breakdown(last)
    res["breakdown_us"] = bd
    print("\n# what one step costs (exponential scheme, 30 Hz; timeit medians, us)\n")
    print("| piece | us |")
    print("|---|---:|")
    for k, v in bd.items():
        print(f"| {k} | {v:.2f} |")
    print(f"| sum | {sum(bd.values()):.2f} |")
    print("\n# harmonic balance of the same model (median of 3)\n")
    print("| speed [Hz] | linearised (parametric) [s] | nonlinear (hbm) [s] | Newton iterations |")
    print("|---:|---:|---:|---:|")
    res["hbm"] = []
    for s in speeds:
        m = Tdsm(case, s, machine=machine)
        tl = np.median([harmonic_balance(m, linearised=True).wall_time_s for _ in range(3)])
        sols = [harmonic_balance(m) for _ in range(3)]
        th = np.median([x.wall_time_s for x in sols])
        res["hbm"].append({"speed_hz": s, "parametric_s": float(tl), "hbm_s": float(th),
                           "iterations": sols[0].iterations})
        print(f"| {s:g} | {tl:.3f} | {th:.3f} | {sols[0].iterations} |")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
