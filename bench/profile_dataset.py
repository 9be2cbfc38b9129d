"""Data sets: where a worker's task spends a run, piece by piece (perf_counter around each piece).

    .venv/bin/python bench/profile_dataset.py --kinds inner,ball
    .venv/bin/python bench/profile_dataset.py --kinds inner --code DIR        # another checkout's code

The runs of ``bench_dataset.py`` (10 s at 25.6 kHz in 1-s chunks, constant speeds 15-35 Hz, a seed each, 5 runs per
task) rendered by :func:`bkabem_core.dataset.engine._task` ``--passes`` times; each piece's time per run, the minimum and
the median over the passes (the minimum: the least disturbed pass of that piece on a shared machine; the pieces'
minima come from different passes and do not add up to the task's). Pieces (nested ones indented):

synthesis            the chunks' rendering (the time spent inside the run's chunk iterator)
run set-up           ``dataset_render._chunks`` before the first chunk: the run's case and model look-up, the
                     synthesiser of the model with the run's seed (of it: the seed's floor frames)
writer               ``RunFile``: opening the file, writing the chunks (Arrow arrays, Parquet encoding, the
                     kernel's copy), the footer
finishing            ``Finisher.submit`` (the hand-over of a written run; it waits when two runs are behind) and
                     ``Finisher.wait`` at the task's end (the last run's fsync and rename)
everything else      the case hash, the ground truth, label rows, metadata JSON, the BLAS controller, ...

``--code DIR`` profiles another checkout's ``bkabem_core`` (pieces it does not have are left out).
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if "--code" in sys.argv[:-1]:
    ROOT = Path(sys.argv[sys.argv.index("--code") + 1]).resolve()
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import threadpoolctl  # noqa: E402

from bkabem_core.dataset import engine as dataset  # noqa: E402
from bkabem_core.dataset import render as dataset_render
from bkabem_core.model import case as case_module  # noqa: E402
from bkabem_core.scenario import timeline as scenario
from bkabem_core.synth import floor as synth_floor

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_dataset import CONFIGS, _case, spec_for  # noqa: E402

_acc: dict = {}
#: Pieces in the order of a run (nested ones after their parent); any other piece after them, largest first.
_ORDER = ("synthesis (the chunks)", "run set-up (_chunks)", "  of it: the seed's floor frames", "  of it: model look-up",
          "writer: open", "writer: chunks", "writer: footer, close", "finishing: hand-over",
          "finishing: wait at the task's end")


def _add(label: str, t: float) -> None:
    _acc[label] = _acc.get(label, 0.0) + t


def _wrap(obj, name: str, label: str) -> None:
    if not hasattr(obj, name):
        return
    f = getattr(obj, name)

    @functools.wraps(f)
    def timed(*a, **k):
        t0 = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            _add(label, time.perf_counter() - t0)
    setattr(obj, name, timed)


def _instrument() -> None:
    chunks = dataset_render._chunks

    def timed_chunks(run):
        t0 = time.perf_counter()
        synth, it, model_s = chunks(run)
        _add("run set-up (_chunks)", time.perf_counter() - t0)

        def timed_it():
            while True:
                t0 = time.perf_counter()
                try:
                    item = next(it)
                except StopIteration:
                    _add("synthesis (the chunks)", time.perf_counter() - t0)
                    return
                _add("synthesis (the chunks)", time.perf_counter() - t0)
                yield item
        return synth, timed_it(), model_s
    dataset_render._chunks = timed_chunks
    _wrap(synth_floor.BroadbandFloor, "reseeded", "  of it: the seed's floor frames")
    _wrap(dataset_render.pool(), "get", "  of it: model look-up")
    _wrap(dataset_render.RunFile, "__init__", "writer: open")
    _wrap(dataset_render.RunFile, "write", "writer: chunks")
    _wrap(dataset_render.RunFile, "close", "writer: footer, close")
    _wrap(np, "ascontiguousarray", "np.ascontiguousarray (mostly the chunks' copy)")
    _wrap(dataset_render.Finisher, "submit", "finishing: hand-over")
    _wrap(dataset_render.Finisher, "wait", "finishing: wait at the task's end")
    _wrap(dataset_render, "label_row", "label rows")
    _wrap(scenario.Scenario, "ground_truth", "ground truth")
    _wrap(json, "dumps", "JSON dumps (metadata, labels, keys; and the case hash's)")
    _wrap(json, "loads", "JSON loads (labels read back)")
    _wrap(threadpoolctl, "threadpool_limits", "BLAS thread limit (threadpoolctl)")
    _wrap(dataset, "_blas_controller", "BLAS thread limit (threadpoolctl)")
    fget = case_module.Case.case_hash.fget

    def case_hash(self):
        t0 = time.perf_counter()
        try:
            return fget(self)
        finally:
            _add("case hash", time.perf_counter() - t0)
    case_module.Case.case_hash = property(case_hash)


def profile(kind: str, cname: str, passes: int, runs: int, seconds: float) -> tuple[list, dict]:
    spec = spec_for(kind, dict(CONFIGS[cname], chunk_s=1.0), seconds, runs, "none")
    tmp = Path(tempfile.mkdtemp(prefix="profile_dataset_"))
    try:
        dataset_render.pool().get(_case(spec.runs[0]))
        dataset._task(spec.runs, str(tmp / "warm"), "none", ())
        tasks, pieces = [], {}
        for i in range(passes):
            _acc.clear()
            t0 = time.perf_counter()
            dataset._task(spec.runs, str(tmp / f"p{i}"), "none", ())
            tasks.append((time.perf_counter() - t0) / runs)
            for k, v in _acc.items():
                pieces.setdefault(k, []).append(v / runs)
            shutil.rmtree(tmp / f"p{i}")
        return tasks, pieces
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kinds", default="inner,ball")
    ap.add_argument("--configs", default="acc4")
    ap.add_argument("--passes", type=int, default=12)
    ap.add_argument("--runs", type=int, default=5, help="runs per task (default 5, as bench_dataset.py)")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--code", default=None, help="profile the bkabem_core of this checkout")
    a = ap.parse_args(argv)
    _instrument()
    print(f"# code {ROOT}; load {os.getloadavg()[0]:.2f} at start; {a.runs} runs of {a.seconds:g} s per task, "
          f"{a.passes} passes; ms per run, min / median over the passes")
    with threadpoolctl.threadpool_limits(limits=1, user_api="blas"):
        for kind in a.kinds.split(","):
            for cname in a.configs.split(","):
                tasks, pieces = profile(kind, cname, a.passes, a.runs, a.seconds)
                print(f"\n{kind} {cname}: the task {1e3 * min(tasks):.2f} / {1e3 * statistics.median(tasks):.2f} "
                      f"ms per run")
                order = [label for label in _ORDER if label in pieces]
                order += sorted((k for k in pieces if k not in _ORDER), key=lambda k: -statistics.median(pieces[k]))
                for k in order:
                    v = pieces[k]
                    if len(v) < len(tasks):
                        v = v + [0.0] * (len(tasks) - len(v))
                    print(f"  {k:50s} {1e3 * min(v):7.3f} / {1e3 * statistics.median(v):7.3f}")
    print(f"# load {os.getloadavg()[0]:.2f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
