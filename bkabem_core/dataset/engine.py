"""Rendering a data set: its folder, resuming, the labels table, and the engines that run it.

    spec = DatasetSpec.load("dataset_example")          # bkabem_core.dataset.spec
    result = render_dataset(spec, "out/kinds", engine="local", workers=2)

The output folder (docs/datasets.md)::

    DIR/manifest.json        the spec's summary and hash, every run (id, hash, parameters); complete = true at the end
    DIR/spec.toml            the spec as given (when rendered from a file)
    DIR/runs/<index>_<hash>.parquet   one file per run (bkabem_core.dataset.render)
    DIR/labels.parquet       ONE table, one row per segment of every run (every ground-truth field, the case hash)
    DIR/labels.csv           the same table as CSV

**Resuming.** The folder is locked while a process renders into it (``DIR/.lock``, ``flock``). At the start the
runs whose file is complete (footer readable, its run hash, its row count) are skipped; anything else under a run's
name (a truncated file planted or left by a crash) is reported and rendered again, and stale temporary files are
removed. A run's file appears under its final name only complete (temporary name, fsync, atomic rename), so a
killed process leaves at worst temporaries. A folder that holds another spec's data set is refused.

**Engines.** ``local``: the runs in worker processes on this machine (``workers``, default every core), or in
this process with ``workers = 1``. ``dask``: the same tasks on a Dask ``distributed`` cluster (``scheduler``
``tcp://HOST:8786``), or on a ``LocalCluster`` of worker processes bound to 127.0.0.1 when no scheduler is given.
Runs are submitted grouped by machine so that a worker reuses its models. Every run's samples depend only on the
run (its seed and parameters), so every engine and worker count gives the same files, bit for bit.
"""

from __future__ import annotations

import fcntl
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from bkabem_core.dataset.render import (
    RUNS_DIR,
    TEMP_MARK,
    Finisher,
    check_run_file,
    commit,
    fsync_dir,
    render_run,
    run_path,
)
from bkabem_core.dataset.spec import DatasetSpec, Run

ENGINES = ("local", "dask")
MANIFEST = "manifest.json"
#: Most runs in one task.
TASK_RUNS = 16
#: What a data set's folder holds before its manifest is written (a crash right at the start).
_OWN = (".lock", "spec.toml")


class DatasetError(RuntimeError):
    """The data set cannot be rendered into this folder or on this engine; ``argument`` names the option."""

    def __init__(self, argument: str, reason: str):
        self.argument = argument
        self.reason = reason
        super().__init__(f"{argument}: {reason}")


@dataclass
class DatasetResult:
    """What :func:`render_dataset` did. Times in s of wall clock; ``signal_s`` in s of signal."""

    out_dir: Path
    runs: int
    skipped: int = 0
    rendered: int = 0
    damaged: list = field(default_factory=list)
    signal_s: float = 0.0
    render_s: float = 0.0
    model_s: float = 0.0
    wall_s: float = 0.0
    bytes: int = 0
    labels_rows: int = 0


# --------------------------------------------------------------------------- the folder
def _write_json_atomic(path: Path, obj) -> None:
    tmp = path.with_name(f".{path.name}{TEMP_MARK}-{os.getpid()}")
    with open(tmp, "w") as fh:
        json.dump(obj, fh, indent=1, sort_keys=True, default=str)
        fh.write("\n")
        fh.flush()
        os.fsync(fh.fileno())
    commit(tmp, path)


def _manifest(spec: DatasetSpec, complete: bool) -> dict:
    return {"bkabem_dataset": spec.summary(), "complete": complete,
            "runs": [{"run_id": r.run_id, "run_hash": r.run_hash, "machine_hash": r.case_hash, "params": r.params}
                     for r in spec.runs]}


class _Folder:
    """The output folder, locked for this process."""

    def __init__(self, out_dir, spec: DatasetSpec):
        if not str(out_dir).strip():
            raise DatasetError("--out", "empty: give the data set's folder")
        self.path = Path(out_dir)
        if self.path.exists() and not self.path.is_dir():
            raise DatasetError("--out", f"{self.path} exists and is not a folder")
        if self.path.is_dir() and not (self.path / MANIFEST).exists():
            other = [p.name for p in self.path.iterdir() if p.name not in _OWN and TEMP_MARK not in p.name
                     and not (p.name == RUNS_DIR and p.is_dir() and not any(p.iterdir()))]
            if other:
                raise DatasetError("--out", f"{self.path} holds other files ({', '.join(sorted(other)[:3])}"
                                   f"{', ...' if len(other) > 3 else ''}) and no bkabem data set: give a new or "
                                   f"empty folder")
        try:
            (self.path / RUNS_DIR).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DatasetError("--out", f"{self.path}: cannot create: {exc.strerror}") from None
        self._lock = open(self.path / ".lock", "w")
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._lock.close()
            raise DatasetError("--out", f"{self.path} is being rendered by another process (locked)") from None
        mf = self.path / MANIFEST
        if mf.exists():
            try:
                old = json.loads(mf.read_text())["bkabem_dataset"]["spec_hash"]
            except (ValueError, KeyError, TypeError, OSError):
                old = None
            if old != spec.spec_hash:
                self.close()
                raise DatasetError("--out", f"{self.path} holds another data set (spec hash {old}, this spec "
                                   f"{spec.spec_hash}): give a new folder")
        self.spec = spec

    def close(self) -> None:
        try:
            self._lock.close()
        except OSError:
            pass

    def clean_temporaries(self) -> int:
        n = 0
        for d in (self.path, self.path / RUNS_DIR):
            for p in d.iterdir():
                if p.name.startswith(".") and TEMP_MARK in p.name:
                    try:
                        p.unlink()
                        n += 1
                    except OSError:
                        pass
        return n

    def scan(self, log) -> tuple[dict, list, list]:
        """``({run_id: label rows} of finished runs, runs to render, damaged [(run_id, why)])``."""
        done, todo, damaged = {}, [], []
        for run in self.spec.runs:
            path = run_path(self.path, run)
            rows, why = check_run_file(path, run)
            if rows is not None:
                done[run.run_id] = rows
                continue
            if why != "missing":
                damaged.append((run.run_id, why))
                log(f"run {run.run_id}: {path.name} is {why}: rendering it again")
                aside = path.with_name(f".{path.name}.damaged{TEMP_MARK}-{os.getpid()}")
                os.replace(path, aside)
                aside.unlink()
            todo.append(run)
        return done, todo, damaged

    def write_labels(self, rows: list[dict]) -> None:
        """``labels.parquet`` and ``labels.csv``: every row, columns the union over rows (in first-seen order)."""
        import pyarrow as pa
        import pyarrow.csv as pacsv
        import pyarrow.parquet as pq

        cols: dict[str, None] = {}
        for r in rows:
            for k in r:
                cols.setdefault(k, None)
        table = pa.Table.from_pylist([{k: r.get(k) for k in cols} for r in rows])
        for name, write in (("labels.parquet", lambda fh: pq.write_table(table, fh, compression="zstd")),
                            ("labels.csv", lambda fh: pacsv.write_csv(table, fh))):
            final = self.path / name
            tmp = final.with_name(f".{name}{TEMP_MARK}-{os.getpid()}")
            with open(tmp, "wb") as fh:
                write(fh)
                fh.flush()
                os.fsync(fh.fileno())
            commit(tmp, final)


# --------------------------------------------------------------------------- tasks
def plan_tasks(todo: list[Run], workers: int) -> list[list[Run]]:
    """The runs as tasks: runs of one machine together (its model is built once per task and kept by the worker),
    in index order; a machine's runs split into pieces of at most ``ceil(runs / (2 workers))`` so that every
    worker has work, and at most :data:`TASK_RUNS` (the progress bar moves per task)."""
    groups: dict[str, list[Run]] = {}
    for r in sorted(todo, key=lambda r: r.index):
        groups.setdefault(r.case_hash, []).append(r)
    piece = max(1, min(-(-len(todo) // (2 * max(1, workers))), TASK_RUNS))
    tasks = []
    for runs in groups.values():
        n = -(-len(runs) // piece)                       # pieces of this machine, as equal as can be
        size = -(-len(runs) // n)
        tasks.extend(runs[i:i + size] for i in range(0, len(runs), size))
    return tasks


_BLAS: tuple = (None, None)


def _blas_controller():
    """The process's ``threadpoolctl.ThreadpoolController``, made once (finding the loaded BLAS libraries costs ~3-4
    ms, ~0.2-0.7 ms a run of a task, measured) and again only when modules were imported since (a new extension
    module may have brought another BLAS)."""
    global _BLAS
    if _BLAS[0] != len(sys.modules):
        from threadpoolctl import ThreadpoolController

        controller = ThreadpoolController()
        _BLAS = (len(sys.modules), controller)       # counted after threadpoolctl's own first import
    return _BLAS[1]


def _task(runs: list[Run], out_dir: str, compression: str, sinks: tuple) -> list[dict]:
    """What a worker runs: one BLAS thread (small matrices; determinism), then the runs one after the other."""
    fin = Finisher()
    try:
        with _blas_controller().limit(limits=1, user_api="blas"):
            # the last run's fsync overlaps nothing: its disk writes start while it is written
            out = [render_run(run, out_dir, compression, sinks, finish=fin, writeback=k == len(runs) - 1)
                   for k, run in enumerate(runs)]
        fin.wait()                     # every run of the task fsync-ed and in place before it is reported
    finally:
        fin.close()
    return out


def _worker_init() -> None:
    """Local worker processes: SIGINT is the parent's to handle; die with the parent (Linux PR_SET_PDEATHSIG)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def _local(tasks: list[list[Run]], out_dir: str, compression: str, sinks: tuple, workers: int):
    if workers <= 1:
        for runs in tasks:
            yield _task(runs, out_dir, compression, sinks)
        return
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    # spawn: the workers are children of this process, so PR_SET_PDEATHSIG ends them when it is killed (forkserver
    # workers are the fork server's children and outlived a kill -9 of the command, measured)
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"), initializer=_worker_init)
    try:
        pending = set()
        it = iter(tasks)
        for runs in it:                        # keep ~2 tasks per worker queued: grouped order is kept
            pending.add(ex.submit(_task, runs, out_dir, compression, sinks))
            if len(pending) >= 2 * workers:
                break
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in finished:
                yield f.result()
                nxt = next(it, None)
                if nxt is not None:
                    pending.add(ex.submit(_task, nxt, out_dir, compression, sinks))
    finally:
        procs = list(getattr(ex, "_processes", {}).values())
        ex.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join(timeout=5)


def _dask(tasks: list[list[Run]], out_dir: str, compression: str, sinks: tuple, workers: int, scheduler: str | None,
          log):
    try:
        import distributed
    except ImportError:
        raise DatasetError("--engine", "dask needs the distributed package (pip install 'bkabem[cluster]')") from None
    import logging

    cluster = None
    if scheduler is None:
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                           host="127.0.0.1", dashboard_address=None, scheduler_port=0,
                                           silence_logs=logging.ERROR, worker_class="distributed.Nanny")
        client = distributed.Client(cluster)
        log(f"dask: local cluster of {workers} worker processes on 127.0.0.1 ({cluster.scheduler_address})")
    else:
        try:
            client = distributed.Client(scheduler, timeout=30)
        except (OSError, TimeoutError) as exc:
            raise DatasetError("--scheduler", f"{scheduler}: cannot connect ({exc})") from None
        n = len(client.scheduler_info().get("workers", {}))
        log(f"dask: scheduler {scheduler} with {n} workers")
    try:
        futures = client.map(_task, tasks, out_dir=out_dir, compression=compression, sinks=sinks,
                             key=[f"bkabem-runs-{t[0].run_id}-{len(t)}" for t in tasks], pure=False)
        for f in distributed.as_completed(futures):
            yield f.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# --------------------------------------------------------------------------- the command
def render_dataset(spec: DatasetSpec, out_dir, *, engine: str = "local", workers: int | None = None,
                   scheduler: str | None = None, progress: bool = False, sinks: tuple = (), spec_text: str | None = None,
                   log=None) -> DatasetResult:
    """Render every run of ``spec`` not yet finished in ``out_dir`` (module docstring), then the labels table.

    Parameters
    ----------
    engine : {"local", "dask"}
    workers : int or None
        Worker processes (default: the cores this process may use); for ``dask`` with a scheduler, ignored.
    scheduler : str or None
        ``tcp://HOST:8786`` of a running Dask scheduler (engine ``dask``).
    progress : bool
        A tqdm progress bar on stderr (runs, signal seconds, x real time).
    sinks : tuple of str
        Further per-run writers (``module:factory``, :func:`bkabem_core.dataset.render.render_run`).
    log : callable or None
        Called with one line per event (damaged files, the cluster); default: stderr.
    """
    if log is None:
        def log(line):
            sys.stderr.write(f"bkabem dataset: {line}\n")
    if engine not in ENGINES:
        raise DatasetError("--engine", f"must be one of {', '.join(ENGINES)} (got {engine!r})")
    if scheduler is not None and engine != "dask":
        raise DatasetError("--scheduler", "only with --engine dask")
    if spec.mcap and not sinks:
        raise DatasetError("output.mcap", "the spec asks for an MCAP per run: give the writer, sinks = "
                           "('bkabem_ros.recording.dataset_sink:McapRunSink',) (the bkabem dataset command does)")
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    t0 = time.perf_counter()
    folder = _Folder(out_dir, spec)
    try:
        out = folder.path
        res = DatasetResult(out_dir=out, runs=len(spec.runs))
        folder.clean_temporaries()
        if not (out / MANIFEST).exists():
            _write_json_atomic(out / MANIFEST, _manifest(spec, False))
        if spec_text is not None and not (out / "spec.toml").exists():
            tmp = out / f".spec.toml{TEMP_MARK}-{os.getpid()}"
            tmp.write_text(spec_text)
            commit(tmp, out / "spec.toml")
        done, todo, res.damaged = folder.scan(log)
        res.skipped = len(done)
        tasks = plan_tasks(todo, workers)
        bar = None
        if progress and tasks:
            from tqdm import tqdm
            bar = tqdm(total=len(todo), unit="run", desc="dataset", file=sys.stderr, dynamic_ncols=True)
        abs_out = str(out.resolve())
        runner = (_local(tasks, abs_out, spec.compression, sinks, workers) if engine == "local"
                  else _dask(tasks, abs_out, spec.compression, sinks, workers, scheduler, log))
        try:
            for results in runner:
                for r in results:
                    done[r["run_id"]] = r["labels"]
                    res.rendered += 1
                    res.signal_s += r["seconds"]
                    res.render_s += r["render_s"]
                    res.model_s += r["model_s"]
                    res.bytes += r["bytes"]
                if bar is not None:
                    wall = time.perf_counter() - t0
                    bar.set_postfix_str(f"{res.signal_s:.0f} s signal, {res.signal_s / max(wall, 1e-9):.0f}x "
                                        f"real time", refresh=False)
                    bar.update(len(results))
        finally:
            if bar is not None:
                bar.close()
        rows = [row for run in spec.runs for row in done[run.run_id]]
        folder.write_labels(rows)
        res.labels_rows = len(rows)
        _write_json_atomic(out / MANIFEST, _manifest(spec, True))
        fsync_dir(out / RUNS_DIR)
        fsync_dir(out)
        res.wall_s = time.perf_counter() - t0
        return res
    finally:
        folder.close()


def read_labels(out_dir):
    """The labels table of a rendered data set (a ``pyarrow.Table``)."""
    import pyarrow.parquet as pq

    return pq.read_table(Path(out_dir) / "labels.parquet")


def read_run(out_dir, run_id_or_file: str):
    """``(table, metadata dict)`` of one run's waveform file (by run id or the labels' ``file`` column)."""
    import pyarrow.parquet as pq

    p = Path(out_dir) / run_id_or_file
    if not p.suffix:
        p = Path(out_dir) / RUNS_DIR / f"{run_id_or_file}.parquet"
    t = pq.read_table(p)
    kv = pq.read_metadata(p).metadata or {}          # the file footer's key-value metadata (pyarrow >= 26 does not
    if b"bkabem.run" not in kv:                      # copy it onto the table's schema)
        raise DatasetError("file", f"{p}: no bkabem run metadata (not a run file of a bkabem data set)")
    return t, json.loads(kv[b"bkabem.run"])
