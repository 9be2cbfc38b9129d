"""Rendering one run of a data set into its files: waveforms (Parquet), its label rows, optionally more sinks.

:func:`render_run` is what an engine's worker calls (:mod:`bkabem_core.dataset.engine`): it builds (or reuses) the run's
model, synthesises the run chunk by chunk and streams every chunk into the run's Parquet file, written under a
temporary name, flushed and ``fsync``-ed, then renamed into place (atomic on POSIX): a file under its final name is
always complete. Its label rows (one per *segment*: a stretch of the run in one machine state, the whole run for
a grid or random run, one per scenario state otherwise) go into the file's metadata and back to the caller.

Models are kept per worker process (:data:`_POOL`, a :class:`~bkabem_core.scenario.models.ModelPool`): runs of
the same machine reuse the model, and a grown defect reuses its predecessor's decompositions. A model made "like"
another gives bit-identical samples to one made from nothing (tested), so the files do not depend on which worker
rendered which run, nor in which order.

The waveform file of a run (``runs/<index>_<run hash>.parquet``): one float32 (or float64) column per channel in
its unit (``de_vertical_acceleration`` [m/s^2], ...), ``speed_hz`` (float32, shaft speed per sample [Hz]) and
``state`` (int16, the scenario state per sample, 0 for a grid run); one row group per chunk; the key-value
metadata ``bkabem.run`` holds the run (parameters, hashes, units, sample rate) and its label rows as JSON.

No ROS here; a further sink (the MCAP writer of ``bkabem_ros``) is named by ``module:factory`` and imported
here when asked for. Units: SI (s, Hz, m), samples as the synthesiser's channels.
"""

from __future__ import annotations

import functools
import importlib
import json
import math
import os
import time
from collections import OrderedDict
from pathlib import Path

import numpy as np

from bkabem_core.bearing.defects.registry import own_keys
from bkabem_core.dataset.spec import Run, parse_fault
from bkabem_core.model.case import Case
from bkabem_core.scenario.models import ModelPool
from bkabem_core.scenario.timeline import Scenario, add_frequencies
from bkabem_core.synth.profile import SpeedProfile, parse_profile
from bkabem_core.synth.sensors import Accelerometer, AntiAliasFilter
from bkabem_core.synth.synthesizer import Synthesizer

#: Models a worker keeps (each ~10-50 MB for the fault library's motor; a scenario run has ~20 states).
POOL_SIZE = 24
_POOL: ModelPool | None = None
RUNS_DIR = "runs"
#: Knot spacing of a run under a speed profile [s] (the synthesiser's default).
KNOT_S = 0.1
META_KEY = b"bkabem.run"
TEMP_MARK = ".partial"


def pool() -> ModelPool:
    """This process's model pool."""
    global _POOL
    if _POOL is None:
        _POOL = ModelPool(size=POOL_SIZE)
    return _POOL


def run_path(out_dir, run: Run, suffix: str = ".parquet") -> Path:
    return Path(out_dir) / RUNS_DIR / f"{run.run_id}{suffix}"


def temp_path(final: Path) -> Path:
    """The temporary name a file is written under (hidden, in the same folder: the rename stays atomic)."""
    return final.with_name(f".{final.name}{TEMP_MARK}-{os.getpid()}")


def fsync_file(path: Path) -> None:
    """Flush a written file's data to the disk (Linux: fsync on any descriptor of the file)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def commit(tmp: Path, final: Path) -> None:
    """``tmp`` (flushed and fsync-ed by its writer) renamed to ``final`` atomically. The folder is not fsync-ed
    per file (4 ms a file here): a rename lost in a power cut leaves the run unfinished, and a resume renders it
    again; a file under its final name is complete either way."""
    os.replace(tmp, final)


# --------------------------------------------------------------------------- the synthesiser of a run
def _synth_options(p: dict) -> dict:
    dens = {q: p[k] for k, q in (("noise_acc", "acceleration"), ("noise_disp", "displacement"),
                                 ("noise_vel", "velocity")) if p[k] and q in p["quantities"]}
    mount = p["accelerometer"]
    acc = None if mount == "none" else ("case" if mount == "case" else Accelerometer.mounted(mount))
    # anti_alias None: the case's filter (the spec gave none and the case has one: spec._measurement_defaults)
    aa = "case" if p["anti_alias"] is None else (AntiAliasFilter.for_rate(p["sample_rate_hz"]) if p["anti_alias"]
                                                 else None)
    return dict(quantities=list(p["quantities"]), noise_density=dens or None, slip=p["slip"], seed=p["seed"],
                band_limit="taper", features=False, accelerometer=acc, anti_alias=aa)


_SYNTHS: "OrderedDict[str, Synthesizer]" = OrderedDict()


def _synth_for(model, p: dict, case_hash: str) -> Synthesizer:
    """A synthesiser of ``model`` (the model of the case of hash ``case_hash``) with the run's settings: one kept
    per model and settings (binding a line set costs ~1-8 ms), given the run's seed and noise and reset to sample
    0, which makes it the synthesiser a fresh one would be (bit for bit, tested)."""
    opts = _synth_options(p)
    seed, dens = opts.pop("seed"), opts.pop("noise_density")
    key = json.dumps([case_hash, p["sample_rate_hz"], p["chunk_s"], p["accelerometer"], p["anti_alias"],
                      opts["quantities"], opts["slip"]])
    synth = _SYNTHS.get(key)
    if synth is None or synth.model is not model:
        synth = Synthesizer(model, sample_rate_hz=p["sample_rate_hz"], chunk_s=p["chunk_s"], seed=seed,
                            noise_density=dens, **opts)
        _SYNTHS[key] = synth
        while len(_SYNTHS) > POOL_SIZE:
            _SYNTHS.popitem(last=False)
    else:
        synth.seed = seed
        synth.set_noise(noise_density=dens)
        synth.reset()
    _SYNTHS.move_to_end(key)
    return synth


class _RunCase(Case):
    """The case of a data set's runs: a :class:`~bkabem_core.model.case.Case` whose hash (SHA-256 of the canonical JSON
    of the whole case, ~0.13 ms) is computed once. Made once per machine and process (:func:`_run_case`) and never
    changed, it is asked for its hash ~5 times a run (the model pool, the synthesiser's key, the ground truth)."""

    case_hash = functools.cached_property(Case.case_hash.fget)


_CASES: "OrderedDict[str, _RunCase]" = OrderedDict()


def _run_case(run: Run) -> _RunCase:
    """The case of a grid or random ``run``, one object per machine (the spec's machine hash) in the process."""
    case = _CASES.get(run.case_hash)
    if case is None:
        case = _CASES[run.case_hash] = _RunCase.of_valid(run.case_raw, "dataset run")
        while len(_CASES) > POOL_SIZE:
            _CASES.popitem(last=False)
    _CASES.move_to_end(run.case_hash)
    return case


def _profile(p: dict) -> SpeedProfile | None:
    if p["profile"] is not None:
        return parse_profile(p["profile"])
    if p["speed_hz"] is not None:
        return SpeedProfile.constant(p["speed_hz"])
    return None


def _chunks(run: Run):
    """``(synth, iterator of (chunk, shaft speed [Hz], ground truth or None), model seconds)``; the speed is one
    float where it is constant over the chunk (every chunk of a constant-speed run: no per-sample array to make,
    cast and reduce), else per sample (n,)."""
    p = run.params
    fs, seconds = p["sample_rate_hz"], p["duration_s"]
    t0 = time.perf_counter()
    profile = _profile(p)
    if run.is_scenario:
        from bkabem_core.scenario.run import ScenarioRun
        from bkabem_core.scenario.timeline import Scenario

        scenario = Scenario.load(run.scenario_path or p["scenario"])
        # spectrum "exact": one solve per chunk border (~1 ms), not a modal form per state (~1 s each to set up)
        sr = ScenarioRun(scenario, time_scale=p["time_scale"], start_s=p["scenario_start_s"], sample_rate_hz=fs,
                         chunk_s=p["chunk_s"], speed=profile, pool=pool(), spectrum="exact", **_synth_options(p))
        model_s = time.perf_counter() - t0

        def it():
            for chunk, truth in sr.chunks(seconds):
                m = chunk.n_samples
                f0, f1 = chunk.shaft_speed_hz, chunk.shaft_speed_end_hz
                yield chunk, (float(f0) if f0 == f1 else f0 + (f1 - f0) * (np.arange(m) / m)), truth
        return sr.synth, it(), model_s
    model = pool().get(_run_case(run))
    synth = _synth_for(model, p, run.case_hash)
    # at a constant speed the line amplitudes are constant: knots at the run's ends only (the default 0.1 s knots
    # cost a spectrum and a table each, ~10-20 % of an inner-race run); a profile keeps the default knots
    constant = float(profile.speeds_hz[0]) if np.ptp(profile.speeds_hz) == 0 else None
    synth.knot_s = max(KNOT_S, p["duration_s"]) if constant is not None else KNOT_S
    model_s = time.perf_counter() - t0

    def it():
        for chunk in synth.render(profile, seconds):
            yield chunk, (constant if constant is not None else profile.speed_hz(chunk.time_s)), None
    return synth, it(), model_s


# --------------------------------------------------------------------------- labels
def _fault_label(defects: list[dict]) -> tuple[str, str, str]:
    """(class label e.g. ``"inner+outer"`` or ``"healthy"``, bearings e.g. ``"de"``, full ``"de:outer+nde:ball"``)."""
    live = [d for d in defects if d["depth_m"] > 0]
    if not live:
        return "healthy", "", "healthy"
    kinds = "+".join(sorted({d["kind"] for d in live}))
    bearings = "+".join(b for b in ("de", "nde") if any(d["bearing"] == b for d in live))
    full = "+".join(f"{d['bearing']}:{d['kind']}" for d in live)
    return kinds, bearings, full


def label_row(run: Run, gt: dict, segment: int, first: int, n: int, speeds: tuple, mult: dict,
              channels, file: str, *, anti_alias: bool) -> dict:
    """One row of the labels table: the segment of ``run`` from sample ``first`` (``n`` samples) in the machine
    state of ground truth ``gt`` (docs/datasets.md, "Labels"); ``speeds`` = the segment's shaft speed (mean, min,
    max) [Hz]; ``mult`` = each bearing's fault multipliers (``{"de": FaultFrequencies, "nde": ...}``);
    ``channels`` = the names of the run's channels; ``anti_alias`` = whether its acquisition has a low-pass."""
    p = run.params
    fs = p["sample_rate_hz"]
    mean, lo, hi = speeds
    gt = add_frequencies(gt, mean)
    fault, fbear, full = _fault_label(gt["defects"])
    row = {"run_id": run.run_id, "run_index": run.index, "run_hash": run.run_hash, "file": file,
           "segment": segment, "first_sample": int(first), "n_samples": int(n), "start_time_s": first / fs,
           "duration_s": n / fs, "fault": fault, "fault_bearing": fbear, "faults": full,
           "healthy": bool(gt["healthy"]), "n_defects": len(gt["defects"]),
           "speed_hz_mean": mean, "speed_hz_min": lo, "speed_hz_max": hi,
           "profile": p["profile"] if p["profile"] is not None else
           (f"constant:{p['speed_hz']:g}" if p["speed_hz"] is not None else "scenario"),
           "load_factor": float(gt.get("load_factor", p["load_factor"] if p["load_factor"] is not None else 1.0)),
           "load_hp": p.get("load_hp"), "radial_load_n": p.get("radial_load_n"),
           "seed": p["seed"], "slip": p["slip"], "noise_acc": p["noise_acc"], "noise_disp": p["noise_disp"],
           "noise_vel": p["noise_vel"], "sample_rate_hz": fs, "quantities": ",".join(p["quantities"]),
           "channels": ",".join(channels), "accelerometer": p["accelerometer"],
           "anti_alias": anti_alias}
    for name in ("bpfo", "bpfi", "bsf", "ftf"):           # the DE bearing's (the columns of one bearing type)
        m = float(getattr(mult["de"], name))
        row[f"{name}_per_hz"] = m
        row[f"{name}_hz"] = m * mean
    for b in ("de", "nde"):                                # each bearing's own
        row[f"{b}_bearing_designation"] = gt["bearings"][b]["designation"] if "bearings" in gt else \
            gt["bearing_designation"]
        for name in ("bpfo", "bpfi", "bsf", "ftf"):
            m = float(getattr(mult[b], name))
            row[f"{b}_{name}_per_hz"] = m
            row[f"{b}_{name}_hz"] = m * mean
    row["shaft_hz"] = mean
    for i, d in enumerate(gt["defects"]):
        pre = f"d{i}_"
        row.update({pre + "name": d.get("name", ""), pre + "kind": d["kind"], pre + "bearing": d["bearing"],
                    pre + "bearing_designation": d.get("bearing_designation", gt["bearing_designation"]),
                    pre + "length_m": d["length_m"], pre + "depth_m": d["depth_m"],
                    pre + "angle_deg": math.degrees(d["angle_rad"]),
                    **{pre + k.name: d.get(k.name) for k in own_keys()},      # a ball defect's ball number
                    pre + "edge": d["edge"], pre + "shape": d.get("shape", "slot"),
                    pre + "fault_frequency": d["fault_frequency"],
                    pre + "fault_multiplier": d["fault_multiplier"],
                    pre + "fault_frequency_hz": d["fault_frequency_hz"],
                    pre + "strike_frequency_hz": d["strike_frequency_hz"]})
    row.update({"case": gt["case"], "case_hash": gt["case_hash"], "bearing_designation": gt["bearing_designation"]})
    for k, v in gt["baseline"].items():             # a list (electrical_harmonics) as JSON: one type in every table
        row[f"baseline_{k}"] = json.dumps(list(v)) if isinstance(v, (list, tuple)) else v
    row.update({"scenario": gt.get("scenario", "") or "", "scenario_hash": gt.get("scenario_hash", "") or "",
                "state_index": int(gt.get("state_index", 0)), "state_label": gt.get("state_label", ""),
                "state_start_s": float(gt.get("state_start_s", 0.0)),
                "scenario_time_s": float(gt.get("scenario_time_s", 0.0)),
                "time_scale": gt.get("time_scale"), "labels_json": json.dumps(gt.get("labels", {}), sort_keys=True),
                "ground_truth_json": json.dumps(gt, sort_keys=True, default=str)})
    return row


# --------------------------------------------------------------------------- the waveform file
#: Codec of the ``speed_hz`` and ``state`` columns when the spec asks for none: they are constant (a grid run) or
#: nearly so, and snappy (every Parquet reader's default codec) shrinks them to almost nothing for less CPU than
#: the dictionary encoding they had (BENCHMARKS.md "Data sets": ~2 ms of ~6 ms per 10-s run of 4 channels).
AUX_CODEC = "snappy"
#: Values the Parquet column writer takes at a time (pyarrow's ``write_batch_size``; its default 1024 cut a 1-s
#: chunk's 25 600 values of each column into 25 pieces, each with its own page-size check and level bookkeeping:
#: ~0.7 of ~5 ms a 10-s run of 4 channels, measured). A column chunk's pages still close at pyarrow's 1-MB
#: ``data_page_size`` (checked after each batch: pages of at most ~1.25 MB of float32); a column chunk under 1 MB
#: is one page either way, and its file byte for byte the default's (tested with chunks of 1 000-70 000 samples).
WRITE_BATCH = 1 << 16
#: Bytes the file's stream gathers before a ``write`` call (an Arrow ``BufferedOutputStream``): the writer's
#: ~120 writes of a page or a page header each (a 10-s run of 4 channels) become 2-4, and each write on ext4 also
#: updates the inode's times (~1 of ~4 ms a run, measured; the bytes are the same).
WRITE_BUFFER = 2 << 20
#: With ``writeback`` (:class:`RunFile`): the file's written bytes are handed to the disk each time this many more
#: have reached the file, so that the fsync right after the file (the last run of a task, whose fsync nothing
#: overlaps) waits for the tail only (fsync of a 10-s run of 4 channels ~3.4 -> ~1.3 ms for ~0.5 ms of writing,
#: measured).
WRITEBACK_STEP = 1 << 20
_FADVISE = getattr(os, "posix_fadvise", None)


@functools.lru_cache(maxsize=64)
def _file_schema(names: tuple, units: tuple, dtype: str):
    """The Arrow schema of a run's file (made once per channel set and sample type in the process)."""
    import pyarrow as pa

    dt = pa.float32() if np.dtype(dtype) == np.float32 else pa.float64()
    schema = pa.schema([pa.field(n, dt, nullable=False, metadata={"unit": u}) for n, u in zip(names, units)]
                       + [pa.field("speed_hz", pa.float32(), nullable=False, metadata={"unit": "Hz"}),
                          pa.field("state", pa.int16(), nullable=False)])
    return schema


class RunFile:
    """The Parquet file of one run (module docstring), written chunk by chunk: one row group per chunk.

    Encodings (measured, BENCHMARKS.md "Data sets"): the channels PLAIN, without statistics or dictionary (noisy
    float32: a dictionary or min/max only cost time, and no codec shrinks them by more than ~8 %), in the spec's
    codec; ``speed_hz`` and ``state`` PLAIN under :data:`AUX_CODEC` (or the spec's codec when it names one).

    Parameters
    ----------
    path : Path
        Where to write (the run's temporary name).
    names, units : list of str
        The channels and their units (field metadata ``unit``).
    dtype : numpy dtype
        float32 or float64 samples.
    compression : str
        The spec's ``output.compression`` (``none``, ``snappy``, ``zstd``, ``lz4``).
    writeback : bool
        Start the disk writes while the file is written (every :data:`WRITEBACK_STEP` bytes: Linux
        ``posix_fadvise(POSIX_FADV_DONTNEED)`` on the new, still dirty, range starts their writeback and drops no
        page of it): for a file that is fsync-ed at once. Durability is still the fsync's.

    The file is opened here (``FileNotFoundError`` when its folder is missing) as an Arrow ``OSFile`` behind a
    :data:`WRITE_BUFFER` buffer that the writer writes to (no file-system resolution per file); :attr:`size` is
    its length in bytes once closed (everything flushed to the file; the fsync is the caller's).
    """

    def __init__(self, path: Path, names: list, units: list, dtype, compression: str = "none",
                 writeback: bool = False):
        import pyarrow as pa
        import pyarrow.parquet as pq

        self._pa = pa
        self.names = list(names)
        self.schema = _file_schema(tuple(self.names), tuple(units), np.dtype(dtype).str)
        aux = AUX_CODEC if compression == "none" else compression
        codecs = {n: compression for n in self.names}
        codecs.update(speed_hz=aux, state=aux)
        self.size = None
        self._file = pa.OSFile(str(path), "wb")
        try:
            self._sink = pa.BufferedOutputStream(self._file, WRITE_BUFFER)
            self._writer = pq.ParquetWriter(self._sink, self.schema, compression=codecs, write_statistics=False,
                                            use_dictionary=False, write_batch_size=WRITE_BATCH)
        except BaseException:
            self._file.close()
            raise
        self._const: dict = {}                  # constant columns of the last chunks, reused while they hold
        self._written = 0 if (writeback and _FADVISE is not None) else None    # bytes handed to the disk

    def _constant(self, name: str, value, n: int, dtype):
        key = (value, n)
        col = self._const.get(name)
        if col is None or col[0] != key:
            col = self._const[name] = (key, self._pa.array(np.full(n, value, dtype=dtype)))
        return col[1]

    def write(self, samples: np.ndarray, speed_hz, state: int) -> None:
        """One chunk: ``samples`` (C, n) in the channels' units, ``speed_hz`` [Hz] per sample (n,) or one float
        for the chunk, ``state`` (the scenario state of every sample)."""
        pa = self._pa
        n = samples.shape[1]
        x = np.ascontiguousarray(samples)              # the synthesiser's chunk is sample-major: one copy
        cols = [pa.array(x[i]) for i in range(x.shape[0])]
        cols.append(self._constant("speed_hz", float(speed_hz), n, np.float32) if np.ndim(speed_hz) == 0
                    else pa.array(np.asarray(speed_hz, dtype=np.float32)))
        cols.append(self._constant("state", int(state), n, np.int16))
        self._writer.write_table(pa.Table.from_arrays(cols, schema=self.schema))
        if self._written is not None:
            pos = self._file.tell()
            if pos - self._written >= WRITEBACK_STEP:
                try:
                    _FADVISE(self._file.fileno(), self._written, pos - self._written, os.POSIX_FADV_DONTNEED)
                except OSError:                 # only a hint
                    pass
                self._written = pos

    def close(self, metadata: dict) -> None:
        """Add the key-value ``metadata`` ({key: str}), write the footer and close the file (its length in
        :attr:`size`)."""
        w, self._writer = self._writer, None
        try:
            w.add_key_value_metadata(metadata)
            w.close()
            self._sink.flush()
            self.size = self._file.tell()
        except BaseException:
            try:
                self._close_files()
            except Exception:  # noqa: BLE001 - the first failure is the one to report
                pass
            raise
        self._close_files()

    def _close_files(self) -> None:
        try:
            self._sink.close()                  # flushes the buffer, closes the file
        finally:
            if not self._file.closed:
                self._file.close()

    def abort(self) -> None:
        w, self._writer = self._writer, None
        if w is not None:
            try:
                w.close()
            except Exception:  # noqa: BLE001 - already failing
                pass
        try:
            self._close_files()
        except Exception:  # noqa: BLE001 - already failing
            pass


class _Segment:
    """A stretch of a run in one machine state: its first sample, ground truth and shaft-speed statistics, kept
    as running sums (a long run holds no per-sample copy of its speed)."""

    __slots__ = ("state", "first", "truth", "n", "total", "lo", "hi")

    def __init__(self, state: int, first: int, truth):
        self.state, self.first, self.truth = state, first, truth
        self.n, self.total, self.lo, self.hi = 0, 0.0, math.inf, -math.inf

    def add(self, speed, n: int) -> None:
        """``n`` samples at ``speed`` [Hz]: one float, or per sample (n,)."""
        if n <= 0:
            return
        self.n += n
        if np.ndim(speed) == 0:
            v = float(speed)
            self.total += v * n
            self.lo, self.hi = min(self.lo, v), max(self.hi, v)
        else:
            self.total += float(np.sum(speed, dtype=float))
            self.lo = min(self.lo, float(np.min(speed)))
            self.hi = max(self.hi, float(np.max(speed)))

    def speeds(self) -> tuple[float, float, float]:
        """(mean, min, max) [Hz] (0 for an empty segment; a constant speed exactly)."""
        if not self.n:
            return 0.0, 0.0, 0.0
        return (self.lo if self.lo == self.hi else self.total / self.n), self.lo, self.hi


# --------------------------------------------------------------------------- rendering a run
def _load_sink(name: str):
    mod, _, attr = name.partition(":")
    return getattr(importlib.import_module(mod), attr)


def render_run(run: Run, out_dir: str, compression: str = "none", sinks: tuple = (), finish=None,
               writeback: bool | None = None) -> dict:
    """Render ``run`` into ``out_dir/runs/`` (module docstring) and return ``{"run_id", "labels": [rows],
    "seconds": signal seconds, "render_s": synthesis + writing [s], "model_s": model [s], "bytes"}``.

    ``sinks``: ``"module:factory"`` names; ``factory(run, final_path_stem, synth)`` returns an object with
    ``write(chunk, truth)``, ``finish()`` (complete, fsync-ed, renamed into place) and ``abort()``. They finish
    before the Parquet file is renamed into place, so a run whose Parquet file exists is complete.

    ``finish``: None (the file is fsync-ed and renamed before this returns), or a :class:`Finisher` that does it
    in its thread while the caller renders the next run (the fsync and the rename wait for the disk: ~1/3 of a
    healthy machine's run, measured); the result then has ``"pending"``, and the run is finished only once
    :meth:`Finisher.wait` has returned.

    ``writeback``: the file's disk writes start while it is written (:class:`RunFile`), for a run whose fsync
    nothing overlaps (default: when ``finish`` is None; a task's last run)."""
    final = run_path(out_dir, run)
    tmp = temp_path(final)
    if writeback is None:
        writeback = finish is None
    t_all = time.perf_counter()
    synth, chunks, model_s = _chunks(run)
    p = run.params
    fs = synth.sample_rate_hz
    n_total = int(round(p["duration_s"] * fs))
    names = list(synth.channel_names)
    mult = synth.model.bearing_multipliers
    if sinks:                                       # they write beside the Parquet file from the start
        final.parent.mkdir(parents=True, exist_ok=True)
    open_sinks = [_load_sink(s)(run, final.with_suffix(""), synth) for s in sinks]
    segs: list[_Segment] = []
    out = None
    try:
        try:
            out = RunFile(tmp, names, synth.units, synth.dtype, compression, writeback)
        except FileNotFoundError:                   # the first run into this folder (a stat a run saved)
            final.parent.mkdir(parents=True, exist_ok=True)
            out = RunFile(tmp, names, synth.units, synth.dtype, compression, writeback)
        for chunk, speed, truth in chunks:
            x = np.ascontiguousarray(chunk.samples)      # channel-major: the columns (one copy of the chunk)
            if not np.isfinite(x).all():
                raise ValueError(f"run {run.run_id}: samples {chunk.first_sample_index}..: not finite")
            state = 0 if truth is None else int(truth["state_index"])
            if not segs or segs[-1].state != state:
                segs.append(_Segment(state, chunk.first_sample_index, truth))
            segs[-1].add(speed, chunk.n_samples)
            out.write(x, speed, state)
            for s in open_sinks:
                s.write(chunk, truth)
        rows = []
        rel = f"{RUNS_DIR}/{final.name}"
        for k, seg in enumerate(segs):
            end = segs[k + 1].first if k + 1 < len(segs) else n_total
            truth = seg.truth
            if truth is None:                       # a grid run: the case alone (one state, no scenario)
                alone = Scenario.of_case(_run_case(run))
                truth = alone.ground_truth(alone.states[0], seg.first / fs)
            rows.append(label_row(run, dict(truth), k, seg.first, end - seg.first, seg.speeds(), mult,
                                  synth.channel_names, rel, anti_alias=synth.anti_alias is not None))
        meta = {"run_id": run.run_id, "run_hash": run.run_hash, "run_index": run.index, "params": run.params,
                "machine_hash": run.case_hash, "sample_rate_hz": fs, "n_samples": n_total,
                "channel_names": names, "units": list(synth.units),
                "sample_time": "sample i is at i / sample_rate_hz seconds; cage angle 0 at t = 0",
                "labels": rows}
        text = json.dumps(meta, default=str)            # insertion order: the labels' column order
        rows = json.loads(text)["labels"]                # what a resumed run reads back: the same types and order
        done_file, out = out, None
        done_file.close({META_KEY.decode(): text})
        size = done_file.size
        done_sinks, open_sinks = open_sinks, []
        if finish is None:
            _finish(tmp, final, done_sinks)
        else:
            finish.submit(tmp, final, done_sinks)
    except BaseException:
        for s in open_sinks:
            s.abort()
        if out is not None:
            out.abort()
        try:
            tmp.unlink()
        except OSError:
            pass
        raise
    t = time.perf_counter() - t_all
    return {"run_id": run.run_id, "labels": rows, "seconds": n_total / fs, "render_s": t - model_s,
            "model_s": model_s, "bytes": size}


def _finish(tmp: Path, final: Path, sinks: list) -> None:
    """fsync the written file, finish the further sinks, rename into place; on failure nothing is left."""
    try:
        fsync_file(tmp)
        for s in sinks:
            s.finish()
        sinks = []
        commit(tmp, final)
    except BaseException:
        for s in sinks:
            s.abort()
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


class Finisher:
    """Finishes written runs (:func:`_finish`) in one background thread, in order: the fsync and the rename of a
    run overlap the rendering of the next. :meth:`wait` returns when every submitted run is in place (and raises
    the first failure)."""

    def __init__(self):
        from concurrent.futures import ThreadPoolExecutor

        self._ex = ThreadPoolExecutor(max_workers=1, thread_name_prefix="bkabem-finish")
        self._pending: list = []

    def submit(self, tmp: Path, final: Path, sinks: list) -> None:
        self._pending = [f for f in self._pending if not f.done() or f.exception() is not None]
        if len(self._pending) >= 2:                       # at most two runs behind: wait for the oldest
            self._pending.pop(0).result()
        self._pending.append(self._ex.submit(_finish, tmp, final, sinks))

    def wait(self) -> None:
        pending, self._pending = self._pending, []
        for f in pending:
            f.result()

    def close(self) -> None:
        try:
            self.wait()
        finally:
            self._ex.shutdown(wait=True)


def check_run_file(path: Path, run: Run) -> tuple[list | None, str]:
    """``(label rows, "")`` if ``path`` is the complete file of ``run``, else ``(None, why not)``."""
    import pyarrow.parquet as pq

    try:
        md = pq.read_metadata(path)
    except FileNotFoundError:
        return None, "missing"
    except Exception as exc:  # noqa: BLE001 - pyarrow raises ArrowInvalid/OSError for damaged files
        return None, f"not a complete Parquet file ({' '.join(str(exc).split())[:120]})"
    kv = md.metadata or {}
    if META_KEY not in kv:
        return None, "no bkabem run metadata"
    try:
        meta = json.loads(kv[META_KEY])
    except ValueError:
        return None, "damaged run metadata"
    if meta.get("run_hash") != run.run_hash:
        return None, f"another run's file (run hash {meta.get('run_hash')!r})"
    n = int(round(run.params["duration_s"] * run.params["sample_rate_hz"]))
    if md.num_rows != n:
        return None, f"{md.num_rows} rows, expected {n}"
    return meta["labels"], ""


__all__ = ["Finisher", "RunFile", "render_run", "check_run_file", "run_path", "temp_path", "commit", "label_row", "parse_fault", "pool"]
