"""Data sets: the whole path of a run, synthesis + writing, per core, for every fault kind.

    .venv/bin/python bench/bench_dataset.py --repeat 3                                   # the full table
    .venv/bin/python bench/bench_dataset.py --repeat 1 --seconds 2 --kinds outer --json out.json

Per fault kind (the fault library's motor with the spec's 2 mm x 50 um DE defect, or healthy), one process on one
core (BLAS on one thread), runs of ``--seconds`` at 25.6 kHz, constant speeds 15-35 Hz, each with its own seed:

model          ``BkaBem`` of the kind's case (once per machine and worker; reported, not in the rate)
synth only     the run's chunks rendered and dropped (what the synthesiser costs on its own)
run set-up     of it, per run: the first chunk's time less a later chunk's (median): what a run costs before its
               samples (the seed's noise, slip walk and broadband floor; the knots)
writing alone  one run's chunks, rendered once and kept, written with the data set's writer
               (``dataset_render.RunFile``: the Parquet file, its metadata; no fsync), per run of ``--seconds``
whole path     a worker's task of the runs (:func:`bkabem_core.dataset.engine._task`: ``render_run`` per run, synthesis,
               Parquet file under a temporary name, the label rows; fsync and atomic rename in the worker's
               finishing thread, overlapping the next run; the task returns when every file is in place):
               everything a worker does for the runs once its model is made

Configurations: ``acc4`` = 4 accelerometer channels with 1 % slip and 5e-4 m/s^2/sqrt(Hz) sensor noise (the
realistic path, the dataset_example spec's settings); ``acc4-plain`` the same without slip and noise; ``acc+disp8``
8 channels (acceleration + displacement) with slip and noise. Real-time factor = signal seconds / wall seconds of
one core, median of ``--repeat`` passes over the runs (and signal seconds / CPU seconds of the process, which
other processes on a shared machine disturb less but which leaves out the fsync's wait for the disk); the per-run
wall time (median) too. ``--code DIR`` renders with another checkout's ``bkabem_core`` (before/after alternated in one
session; a checkout before ``RunFile`` writes with the writer it had). A last block renders
the dataset_example spec end to end (``render_dataset``, every core, models included) for the wall-clock picture.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if "--code" in sys.argv[:-1]:                      # another checkout's bkabem_core (before/after in one session)
    ROOT = Path(sys.argv[sys.argv.index("--code") + 1]).resolve()
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from bkabem_core.dataset import render as dataset_render  # noqa: E402
from bkabem_core.dataset.engine import _task, render_dataset  # noqa: E402
from bkabem_core.dataset.spec import DatasetSpec  # noqa: E402

KINDS = ("healthy", "outer", "inner", "ball")
CONFIGS = {
    "acc4": dict(quantities=["acceleration"], slip=0.01, noise_acc=5e-4),
    "acc4-plain": dict(quantities=["acceleration"], slip=0.0, noise_acc=0.0),
    "acc+disp8": dict(quantities=["acceleration", "displacement"], slip=0.01, noise_acc=5e-4),
}


def _toml(v) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, str):
        return f'"{v}"'
    return repr(v)


def spec_for(kind: str, config: dict, seconds: float, runs: int, compression: str) -> DatasetSpec:
    run = dict(config, duration_s=seconds, sample_rate_hz=25600.0, length_m=2e-3, depth_m=50e-6, fault=kind)
    speeds = [15.0 + 20.0 * i / max(runs - 1, 1) for i in range(runs)]
    text = (f'[dataset]\nname = "bench_{kind}"\nschema_version = 1\nseed = 5\n[run]\n'
            + "\n".join(f"{k} = {_toml(v)}" for k, v in run.items())
            + f"\n[grid]\nspeed_hz = {_toml(speeds)}\n[output]\ncompression = \"{compression}\"\n")
    return DatasetSpec.from_toml(text, "bench")


def bench_kind(kind: str, cname: str, seconds: float, runs: int, repeat: int, compression: str, tmp: Path,
               chunk_s: float = 1.0) -> dict:
    spec = spec_for(kind, dict(CONFIGS[cname], chunk_s=chunk_s), seconds, runs, compression)
    t0 = time.perf_counter()
    dataset_render.pool().get(_case(spec.runs[0]))
    model_s = time.perf_counter() - t0
    for run in spec.runs:                                   # warm: imports, the synthesiser of the machine
        dataset_render.render_run(run, tmp / "warm", compression)
    shutil.rmtree(tmp / "warm", ignore_errors=True)
    kept = _kept_chunks(spec.runs[0])                       # one run's chunks, for the writer alone
    synth_rates, whole_rates, cpu_rates, per_run, setup, write_ms = [], [], [], [], [], []
    for rep in range(repeat):
        sig = t_synth = 0.0
        for run in spec.runs:
            t0 = time.perf_counter()
            synth, chunks, _ = dataset_render._chunks(run)
            ends = []
            for _chunk in chunks:
                ends.append(time.perf_counter())
            t_synth += ends[-1] - t0
            steps = np.diff([t0] + ends)
            setup.append(steps[0] - (float(np.median(steps[1:])) if steps.size > 1 else 0.0))
            sig += run.params["duration_s"]
        synth_rates.append(sig / t_synth)
        write_ms.append(1e3 * _write_alone(kept, tmp / "w.parquet", compression))
        out = tmp / f"{kind}_{cname}_{rep}"
        c0 = time.process_time()
        t0 = time.perf_counter()
        _task(spec.runs, str(out), compression, ())          # what a worker runs: the runs of one machine
        t_all = time.perf_counter() - t0
        per_run.append(t_all / len(spec.runs))
        cpu_rates.append(sig / (time.process_time() - c0))
        whole_rates.append(sig / t_all)
        shutil.rmtree(out, ignore_errors=True)
    return {"kind": kind, "config": cname, "chunk_s": chunk_s, "model_s": model_s,
            "synth_x": statistics.median(synth_rates), "setup_ms": 1e3 * statistics.median(setup),
            "write_ms": statistics.median(write_ms) * seconds / kept["seconds"],
            "whole_x": statistics.median(whole_rates), "whole_cpu_x": statistics.median(cpu_rates),
            "run_wall_ms": 1e3 * statistics.median(per_run),
            "writing_share": 1.0 - statistics.median(synth_rates) ** -1 / statistics.median(whole_rates) ** -1}


def _kept_chunks(run) -> dict:
    synth, chunks, _ = dataset_render._chunks(run)
    kept = [(np.array(c.samples), speed if np.ndim(speed) == 0 else np.array(speed), 0) for c, speed, _t in chunks]
    return {"chunks": kept, "names": list(synth.channel_names), "units": list(synth.units), "dtype": synth.dtype,
            "seconds": run.params["duration_s"]}


def _write_alone(kept: dict, path: Path, compression: str) -> float:
    """Seconds to write one run's kept chunks with the data set's writer (no fsync: the finishing thread's)."""
    t0 = time.perf_counter()
    if hasattr(dataset_render, "RunFile"):
        f = dataset_render.RunFile(path, kept["names"], kept["units"], kept["dtype"], compression)
        for x, speed, state in kept["chunks"]:
            f.write(x, speed, state)
        f.close({"bkabem.run": "{}"})
    else:                                                   # main before RunFile: its writer, as render_run had it
        import pyarrow as pa
        import pyarrow.parquet as pq

        schema = pa.schema([pa.field(n, pa.float32(), nullable=False, metadata={"unit": u})
                            for n, u in zip(kept["names"], kept["units"])]
                           + [pa.field("speed_hz", pa.float32(), nullable=False, metadata={"unit": "Hz"}),
                              pa.field("state", pa.int16(), nullable=False)])
        w = pq.ParquetWriter(str(path), schema, compression=compression, write_statistics=False,
                             use_dictionary=["speed_hz", "state"])
        for x, speed, state in kept["chunks"]:
            cols = [pa.array(np.ascontiguousarray(x[i])) for i in range(x.shape[0])]
            cols.append(pa.array(np.asarray(speed, dtype=np.float32)))
            cols.append(pa.array(np.full(x.shape[1], state, dtype=np.int16)))
            w.write_batch(pa.RecordBatch.from_arrays(cols, schema=schema))
        w.add_key_value_metadata({"bkabem.run": "{}"})
        w.close()
    t = time.perf_counter() - t0
    path.unlink()
    return t


def _case(run):
    from bkabem_core.model.case import Case

    return Case.of_valid(run.case_raw, "bench")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="signal seconds per run (default 10)")
    ap.add_argument("--runs", type=int, default=5, help="runs per kind and configuration (default 5)")
    ap.add_argument("--repeat", type=int, default=3, help="passes; medians are reported (default 3)")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--configs", default=",".join(CONFIGS))
    ap.add_argument("--compression", default="none")
    ap.add_argument("--chunk-s", type=float, default=1.0, help="the runs' chunk_s [s] (default 1, the spec's)")
    ap.add_argument("--code", default=None, help="render with the bkabem_core of this checkout (default: this one)")
    ap.add_argument("--no-end-to-end", action="store_true")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_dataset_") as td, threadpool_limits(limits=1, user_api="blas"):
        tmp = Path(td)
        print(f"# {platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
              f"load {os.getloadavg()[0]:.2f} at start; code {ROOT}; {a.seconds:g} s runs at 25.6 kHz, "
              f"chunks of {a.chunk_s:g} s, {a.runs} runs, median of {a.repeat}, compression {a.compression}")
        print("| kind | config | model [s] | synth only [x real time] | run set-up [ms] | writing alone [ms] | "
              "whole path [x real time per core] | whole path, CPU time [x] | per run [ms] | writing share |")
        print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for kind in a.kinds.split(","):
            for cname in a.configs.split(","):
                r = bench_kind(kind, cname, a.seconds, a.runs, a.repeat, a.compression, tmp, a.chunk_s)
                rows.append(r)
                print(f"| {kind} | {cname} | {r['model_s']:.2f} | {r['synth_x']:.0f} | {r['setup_ms']:.1f} | "
                      f"{r['write_ms']:.1f} | {r['whole_x']:.0f} | {r['whole_cpu_x']:.0f} | "
                      f"{r['run_wall_ms']:.1f} | {100 * r['writing_share']:.0f} % |", flush=True)
        end = None
        if not a.no_end_to_end:
            dataset_render._POOL = None                      # models made afresh, as a new command would
            spec = DatasetSpec.load("dataset_example")
            t0 = time.perf_counter()
            res = render_dataset(spec, tmp / "example", log=lambda line: None)
            wall = time.perf_counter() - t0
            workers = len(os.sched_getaffinity(0))
            end = {"runs": res.rendered, "signal_s": res.signal_s, "wall_s": wall, "workers": workers,
                   "model_worker_s": res.model_s, "render_worker_s": res.render_s}
            print(f"\nend to end, dataset_example ({res.rendered} runs, {res.signal_s:g} s of signal, {workers} "
                  f"workers): {wall:.1f} s wall, models {res.model_s:.1f} s and synthesis + writing "
                  f"{res.render_s:.2f} s of worker time ({res.signal_s / res.render_s:.0f}x real time per core "
                  f"without the models)")
        print(f"# load {os.getloadavg()[0]:.2f} at the end")
    if a.json:
        Path(a.json).write_text(json.dumps({"rows": rows, "end_to_end": end, "load": os.getloadavg()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
