"""Scenarios: the model of a scenario state from nothing against one made like the previous state's,
the cost of handing a model over from the helper process, and an offline run to failure.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_scenario.py --repeat 3          # the full table

Per defect kind (a DE outer-race, a DE inner-race dent, a defect on ball 2 of the DE bearing of the fault library's
``motor_6010_healthy``, growing linearly with ``size_step`` 0.25):

from nothing   ``BkaBem(case of state 2)`` (the defect grown once): excitation, FE, modal basis, every line's modes
like           ``BkaBem(case of state 2, like=model of state 1)``: what ``ModelPool`` and the node's helper do
               (FE, basis and the line modes of the lines state 1 had are reused)
hand-over      ``pickle.dumps`` + ``pickle.loads`` of that model (the helper process sends it pickled) [s, MB]

and ``ScenarioRun`` of the embedded ``de_outer_run_to_failure`` at x3600 (12 h in 12 s of signal, 21 states, every
model made inline like the one before) at 25.6 kHz, 8 channels, slip 1 % and noise: wall time and the real-time
factor. Medians of ``--repeat``; the in-run reference is the from-nothing time of the outer race.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import platform
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bkabem_core.scenario.timeline import Scenario  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402

TEMPLATE = """
[scenario]
name = "bench_{kind}"
schema_version = 1
case = "motor_6010_healthy"
duration_s = 100.0
size_step = 0.25

[[defects]]
name = "d"
bearing = "de"
race = "{kind}"
{ball}time_s = [10.0, 100.0]
length_m = [1.0e-3, 2.0e-3]
depth_m = [25e-6, 50e-6]
"""


def kind_row(kind: str, repeat: int) -> dict:
    sc = Scenario.from_toml(TEMPLATE.format(kind=kind, ball="ball = 2\n" if kind == "ball" else ""))
    s1, s2 = sc.states[1], sc.states[2]
    fresh, like, dump, load, mb = [], [], [], [], 0.0
    m2 = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        BkaBem(s2.case)
        fresh.append(time.perf_counter() - t0)
        m1 = BkaBem(s1.case)
        t0 = time.perf_counter()
        m2 = BkaBem(s2.case, like=m1)
        like.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        blob = pickle.dumps(m2, protocol=pickle.HIGHEST_PROTOCOL)
        dump.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        pickle.loads(blob)
        load.append(time.perf_counter() - t0)
        mb = len(blob) / 1e6
    return {"kind": kind, "state_1": s1.label, "state_2": s2.label, "lines": len(m2.lines),
            "from_nothing_s": statistics.median(fresh), "like_s": statistics.median(like),
            "pickle_s": statistics.median(dump), "unpickle_s": statistics.median(load), "model_mb": mb}


def run_to_failure(repeat: int, seconds: float) -> dict:
    from bkabem_core.scenario.run import ScenarioRun

    sc = Scenario.load("de_outer_run_to_failure")
    walls, states = [], 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        run = ScenarioRun(sc, time_scale=sc.duration_s / seconds, sample_rate_hz=25600.0, chunk_s=0.1, slip=0.01,
                          seed=1, noise_density={"acceleration": 1e-3, "displacement": 1e-9})
        seen = set()
        for _chunk, gt in run.chunks(seconds):
            seen.add(gt["state_index"])
        walls.append(time.perf_counter() - t0)
        states = len(seen)
    wall = statistics.median(walls)
    return {"signal_s": seconds, "states": states, "wall_s": wall, "x_real_time": seconds / wall}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=12.0, help="signal seconds of the run to failure")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    rows = [kind_row(k, a.repeat) for k in ("outer", "inner", "ball")]
    rtf = run_to_failure(a.repeat, a.seconds)
    load1 = os.getloadavg()[0]
    ref = rows[0]["from_nothing_s"]
    print(f"machine: {platform.node()} {os.cpu_count()} cores, load {load0:.1f} -> {load1:.1f}; medians of {a.repeat}")
    print("| defect | states 1 -> 2 | lines | from nothing [s] | like state 1 [s] | ratio | pickle + unpickle [s] "
          "| model [MB] | from nothing / outer's |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['kind']} | {r['state_1']} -> {r['state_2']} | {r['lines']} | {r['from_nothing_s']:.2f} | "
              f"{r['like_s']:.2f} | {r['from_nothing_s'] / r['like_s']:.1f}x | {r['pickle_s'] + r['unpickle_s']:.3f} | "
              f"{r['model_mb']:.1f} | {r['from_nothing_s'] / ref:.1f} |")
    print(f"run to failure: {rtf['signal_s']:g} s of signal, {rtf['states']} states, {rtf['wall_s']:.1f} s wall, "
          f"{rtf['x_real_time']:.2f}x real time")
    if a.json:
        Path(a.json).write_text(json.dumps({"rows": rows, "run_to_failure": rtf, "load": [load0, load1]}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
