"""Issue 15, data sets: the run file's writer and the per-run work of a worker (bkabem_core.dataset.render).

- A run's Parquet file is byte for byte the file of a plain ``pyarrow.parquet.ParquetWriter`` written here with
  the documented options (docs/datasets.md) and pyarrow's defaults for everything else: the batch size, the
  buffered stream and the sink the writer uses change its speed, not one byte of the file.
- What depends only on the machine is made once per worker process, not per run or task: the case's hash (a
  SHA-256 of the whole case), the BLAS thread controller; each run still gets its own seed's samples and labels
  (equal to a fresh process's).
- A run that fails half-way leaves nothing under its final name and no temporary file.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from bkabem_core.dataset import engine as dataset
from bkabem_core.dataset import render as dataset_render
from bkabem_core.dataset.engine import _task, render_dataset
from bkabem_core.dataset.render import RunFile, render_run, run_path
from bkabem_core.dataset.spec import DatasetSpec
from bkabem_core.model import case as case_module
from bkabem_core.model.case import Case

pytestmark = pytest.mark.slow

SPEC = """
[dataset]
name = "writer_test"
schema_version = 1
sampling = "grid"
seed = 21

[run]
duration_s = 0.3
chunk_s = 0.1
quantities = ["acceleration"]
slip = 0.01
noise_acc = 1.0e-3

[grid]
fault = ["healthy"]
speed_hz = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0]
"""


def _reference_file(path: Path, chunks, names, units, dtype, compression: str) -> None:
    """The documented layout with a plain ParquetWriter: one row group per chunk, the channels PLAIN without
    statistics or dictionary in the spec's codec, speed and state under snappy (or the spec's codec)."""
    dt = pa.float32() if dtype == np.float32 else pa.float64()
    schema = pa.schema([pa.field(n, dt, nullable=False, metadata={"unit": u}) for n, u in zip(names, units)]
                       + [pa.field("speed_hz", pa.float32(), nullable=False, metadata={"unit": "Hz"}),
                          pa.field("state", pa.int16(), nullable=False)])
    aux = "snappy" if compression == "none" else compression
    codecs = {**{n: compression for n in names}, "speed_hz": aux, "state": aux}
    w = pq.ParquetWriter(str(path), schema, compression=codecs, write_statistics=False, use_dictionary=False)
    for x, speed, state in chunks:
        n = x.shape[1]
        cols = [pa.array(np.array(x[i])) for i in range(x.shape[0])]
        cols.append(pa.array(np.full(n, speed, np.float32) if np.ndim(speed) == 0
                             else np.asarray(speed, np.float32)))
        cols.append(pa.array(np.full(n, state, np.int16)))
        w.write_table(pa.Table.from_arrays(cols, schema=schema))
    w.add_key_value_metadata({"bkabem.run": json.dumps({"run": "reference"})})
    w.close()


@pytest.mark.parametrize("dtype,compression", [(np.float32, "none"), (np.float32, "zstd"), (np.float64, "none")])
def test_run_file_is_byte_for_byte_the_plain_writers_file(tmp_path, dtype, compression):
    rng = np.random.default_rng(5)
    names = ["de_vertical_acceleration", "de_horizontal_acceleration", "nde_vertical_acceleration"]
    units = ["m/s^2"] * 3
    chunks = []
    for k, n in enumerate([25600, 25600, 70000, 1000]):             # 1-s chunks, a long one, a short last one
        x = rng.standard_normal((n, 3)).astype(dtype).T              # sample-major, as the synthesiser's
        speed = 25.0 if k != 2 else np.linspace(25.0, 30.0, n)       # one chunk with a speed per sample
        chunks.append((x, speed, k // 2))
    ref, mine = tmp_path / "ref.parquet", tmp_path / "mine.parquet"
    _reference_file(ref, chunks, names, units, dtype, compression)
    f = RunFile(mine, names, units, dtype, compression)
    for x, speed, state in chunks:
        f.write(np.ascontiguousarray(x), speed, state)
    f.close({"bkabem.run": json.dumps({"run": "reference"})})
    assert f.size == mine.stat().st_size
    assert mine.read_bytes() == ref.read_bytes()
    t = pq.read_table(mine)
    assert t.num_rows == sum(x.shape[1] for x, _, _ in chunks)
    assert np.array_equal(t.column(names[1]).to_numpy(), np.concatenate([x[1] for x, _, _ in chunks]))


def test_run_file_missing_folder_and_abort_leave_nothing(tmp_path):
    with pytest.raises(FileNotFoundError):
        RunFile(tmp_path / "no" / "x.parquet", ["a"], ["m"], np.float32)
    p = tmp_path / "x.parquet"
    f = RunFile(p, ["a"], ["m"], np.float32)
    f.write(np.zeros((1, 100), np.float32), 10.0, 0)
    f.abort()
    md = pq.read_metadata(p)                # closed, without the run's metadata: never taken for finished
    assert dataset_render.META_KEY not in (md.metadata or {})   # (and render_run unlinks it)


class _Counts:
    """Counts SHA-256 digests of whole cases and BLAS controllers made."""

    def __init__(self, monkeypatch):
        self.hashes = self.controllers = 0
        real_sha = hashlib.sha256

        def sha256(blob):
            self.hashes += 1
            return real_sha(blob)
        monkeypatch.setattr(case_module, "hashlib", SimpleNamespace(sha256=sha256))
        import threadpoolctl

        real_ctl = threadpoolctl.ThreadpoolController

        class Controller(real_ctl):
            def __init__(ctl):
                self.controllers += 1
                super().__init__()
        monkeypatch.setattr(threadpoolctl, "ThreadpoolController", Controller)
        monkeypatch.setattr(dataset, "_BLAS", (None, None), raising=False)

    def take(self):
        out = (self.hashes, self.controllers)
        self.hashes = self.controllers = 0
        return out


def test_machine_work_once_per_process_not_per_run_or_task(tmp_path, monkeypatch):
    """Two tasks of three runs each of one machine in one process (as a worker runs them): the case's hash and
    the BLAS controller are made in the first task (for the run's case, the model and its synthesiser); the
    second task makes none of them (main made them for every run: 15 hashes and a controller). Its files and labels are those of a fresh process's render (the same spec in a subprocess)."""
    spec = DatasetSpec.from_toml(SPEC, "writer_test")
    runs = spec.runs
    counts = _Counts(monkeypatch)
    getattr(dataset_render, "_CASES", {}).clear()        # this process may have rendered these runs before
    out = tmp_path / "out"
    first = _task(runs[:3], str(out), "none", ())
    h1, c1 = counts.take()
    controller = getattr(dataset, "_BLAS", (None, None))[1]
    second = _task(runs[3:], str(out), "none", ())
    h2, c2 = counts.take()
    # the first task: the run's case, the model made for it and its synthesiser (each once); the second: nothing
    assert 1 <= c1 <= 3 and c2 == 0 and dataset._BLAS[1] is controller, (c1, c2)
    assert 1 <= h1 <= 3 and h2 == 0, (h1, h2)
    for r, run in zip(first + second, runs):
        assert r["run_id"] == run.run_id and run_path(out, run).exists()
        assert r["bytes"] == run_path(out, run).stat().st_size
        assert r["labels"][0]["case_hash"] == Case.of_valid(run.case_raw).case_hash == run.case_hash
        assert r["labels"][0]["seed"] == run.params["seed"]
    monkeypatch.undo()

    import subprocess

    (tmp_path / "spec.toml").write_text(SPEC)
    code = ("import sys; from bkabem_core.dataset.engine import render_dataset; from bkabem_core.dataset.spec import "
            "DatasetSpec; render_dataset(DatasetSpec.load(sys.argv[1]), sys.argv[2], workers=1, log=print)")
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "spec.toml"), str(tmp_path / "fresh")], check=True,
                   cwd=Path(__file__).resolve().parents[2])
    for run, r in zip(runs, first + second):
        fresh = run_path(tmp_path / "fresh", run)
        assert fresh.read_bytes() == run_path(out, run).read_bytes(), run.run_id
        meta = json.loads(pq.read_metadata(fresh).metadata[b"bkabem.run"])
        assert json.dumps(r["labels"]) == json.dumps(meta["labels"])     # what the worker reports, as a fresh one


def test_blas_limited_to_one_thread_inside_a_task_and_restored(tmp_path, monkeypatch):
    from threadpoolctl import threadpool_info

    spec = DatasetSpec.from_toml(SPEC, "writer_test")
    seen = []
    real = dataset.render_run

    def spy(*a, **k):
        seen.append({i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})
        return real(*a, **k)
    monkeypatch.setattr(dataset, "render_run", spy)
    before = {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    _task(spec.runs[:2], str(tmp_path / "out"), "none", ())
    _task(spec.runs[2:3], str(tmp_path / "out"), "none", ())
    assert len(seen) == 3 and all(s and set(s.values()) == {1} for s in seen), seen
    assert {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"} == before


def test_blas_controller_made_again_after_new_imports(monkeypatch):
    monkeypatch.setattr(dataset, "_BLAS", (None, None), raising=False)
    a = dataset._blas_controller()
    assert dataset._blas_controller() is a
    monkeypatch.setitem(sys.modules, "bkabem_test_fake_module", SimpleNamespace())
    assert dataset._blas_controller() is not a


def test_a_run_failing_half_way_leaves_no_file(tmp_path, monkeypatch):
    spec = DatasetSpec.from_toml(SPEC, "writer_test")
    run = spec.runs[0]
    real = dataset_render._chunks

    def failing(r):
        synth, chunks, model_s = real(r)

        def it():
            yield next(chunks)
            raise RuntimeError("the machine broke")
        return synth, it(), model_s
    monkeypatch.setattr(dataset_render, "_chunks", failing)
    with pytest.raises(RuntimeError, match="the machine broke"):
        render_run(run, str(tmp_path / "out"), "none")
    assert list((tmp_path / "out" / "runs").iterdir()) == []
    monkeypatch.undo()
    res = render_dataset(spec, tmp_path / "out", workers=1, log=lambda line: None)
    assert res.rendered == len(spec.runs) and res.damaged == []
