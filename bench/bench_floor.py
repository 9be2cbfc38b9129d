"""The broadband floor's set-up: what a new seed costs, against what the whole floor costs.

    .venv/bin/python bench/bench_floor.py                                            # the default settings
    .venv/bin/python bench/bench_floor.py --repeat 3 --json out.json

The fault library's healthy motor at 25.6 kHz with a stud accelerometer and the anti-alias filter, 4 channels
(housing acceleration) and 8 (+ shaft-relative displacement), one core (BLAS on one thread), medians of
``--repeat``:

transfer     ``FloorTransfer``: standstill state space, receptance at the 2^14 - 1 lines, chain, transfer, window:
             seed-independent, made once per model and channel set in the process
frames       ``FloorTransfer.frames`` of a new seed: what ``Synthesizer.reset()`` with a data set's next seed costs
whole floor  transfer + frames: what every new seed cost before the transfer was shared (the in-run reference)
machines     ``--machines`` synthesisers of one model (8 channels, a seed each, as a fleet's machines), each with its
             floor: wall time and traced memory per machine (run the same script of an older checkout to compare)
swing        the CWRU rig's twin (``cwru_rig``, healthy, whose coupling's load turns with the shaft) rendering
             ``--swing-seconds`` at its 12 kHz, 4 housing accelerations, with its floor swinging over the turn
             (:mod:`bkabem_core.synth.rolling`) and with the swing taken out of the same synthesiser, alternated
             (A B A B): the medians [x real time] and their ratio, measured in one run
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from threadpoolctl import threadpool_limits  # noqa: E402

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402
from bkabem_core.synth.floor import FloorTransfer  # noqa: E402
from bkabem_core.synth.sensors import Accelerometer, AntiAliasFilter  # noqa: E402
from bkabem_core.synth.synthesizer import Synthesizer  # noqa: E402

FS = 25600.0
CHANNEL_SETS = {"acc4": ["acceleration"], "acc+disp8": ["acceleration", "displacement"]}


def bench_set(model, quantities, repeat: int) -> dict:
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=1, features=False, quantities=quantities,
                    accelerometer=Accelerometer.mounted("stud"), anti_alias=AntiAliasFilter.for_rate(FS))
    ch = s._plan.channels
    args = (model, ch.combination, ch.cindex, ch.power, ch.scale, ch.housing_columns, FS, s.settings.sensors)
    transfer, frames = [], []
    for seed in range(repeat):
        t0 = time.perf_counter()
        path = FloorTransfer(*args)
        t1 = time.perf_counter()
        path.frames(s.floor_density, seed)
        t2 = time.perf_counter()
        transfer.append(t1 - t0)
        frames.append(t2 - t1)
    t, f = statistics.median(transfer), statistics.median(frames)
    return {"channels": len(s.channels), "transfer_ms": 1e3 * t, "frames_ms": 1e3 * f, "whole_ms": 1e3 * (t + f)}


def bench_machines(model, n: int) -> dict:
    Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=0, features=False)       # the model's bindings, once
    tracemalloc.start()
    t0 = time.perf_counter()
    keep = []
    for i in range(n):
        # its plan makes the floor's frames of its seed (the shared transfer once per model and channel set)
        keep.append(Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=100 + i, features=False))
    wall = time.perf_counter() - t0
    mem = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    return {"machines": n, "ms_each": 1e3 * wall / n, "mb_each": mem / 1e6 / n}


def bench_swing(seconds: float, repeat: int) -> dict:
    rig = Synthesizer(BkaBem(Case.load("cwru_rig")), sample_rate_hz=12000.0, chunk_s=0.1, seed=1, features=True,
                      quantities=["acceleration"])
    swing = rig._plan.rolling
    n = int(round(seconds * 12000.0))
    times = {"swing": [], "stationary": []}
    for _ in range(repeat):
        for name, part in (("swing", swing), ("stationary", None)):
            rig._plan.rolling = part
            rig.reset()
            done, t0 = 0, time.perf_counter()
            while done < n:
                done += rig.next_chunk(29.95, min(rig.chunk_samples, n - done)).samples.shape[1]
            times[name].append(time.perf_counter() - t0)
    rig._plan.rolling = swing
    a, b = statistics.median(times["swing"]), statistics.median(times["stationary"])
    return {"seconds": seconds, "x_real_time_swing": seconds / a, "x_real_time_stationary": seconds / b,
            "cost_ratio": a / b}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7, help="seeds timed; medians are reported (default 7)")
    ap.add_argument("--machines", type=int, default=12, help="synthesisers of one model made (default 12; 0: none)")
    ap.add_argument("--swing-seconds", type=float, default=20.0, help="signal rendered per swing run (default 20; "
                    "0: none)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    model = BkaBem(Case.load("motor_6010_healthy"))
    rows = []
    with threadpool_limits(limits=1, user_api="blas"):
        print(f"# {platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
              f"load {os.getloadavg()[0]:.2f} at start; {FS:g} Hz, median of {a.repeat}")
        print("| channels | transfer (once) [ms] | frames (per seed) [ms] | whole floor [ms] | whole / frames |")
        print("|---|---:|---:|---:|---:|")
        for name, quantities in CHANNEL_SETS.items():
            r = dict(bench_set(model, quantities, a.repeat), set=name)
            rows.append(r)
            print(f"| {name} | {r['transfer_ms']:.1f} | {r['frames_ms']:.1f} | {r['whole_ms']:.1f} | "
                  f"{r['whole_ms'] / r['frames_ms']:.1f} |", flush=True)
        fleet = bench_machines(model, a.machines) if a.machines > 0 else None
        if fleet:
            print(f"\n{fleet['machines']} synthesisers of one model (8 channels, a seed each) with their floor: "
                  f"{fleet['ms_each']:.0f} ms and {fleet['mb_each']:.1f} MB (traced) per machine")
        swing = bench_swing(a.swing_seconds, max(3, a.repeat // 2)) if a.swing_seconds > 0 else None
        if swing:
            print(f"\ncwru_rig, 12 kHz x 4 ch, {swing['seconds']:g} s: {swing['x_real_time_swing']:.0f} x real time with "
                  f"the floor swinging, {swing['x_real_time_stationary']:.0f} x without: {swing['cost_ratio']:.2f} x "
                  "the time")
        print(f"# load {os.getloadavg()[0]:.2f} at the end")
    if a.json:
        Path(a.json).write_text(json.dumps({"rows": rows, "machines": fleet, "swing": swing,
                                            "load": os.getloadavg()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
