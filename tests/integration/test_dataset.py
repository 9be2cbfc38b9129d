"""Issue 15, data sets: ``bkabem dataset SPEC --out DIR`` (bkabem_core.dataset.spec / dataset_render / dataset).

What a data scientist relies on, each checked against something computed here, not by the code under test:

- the labels table matches the spec (every run, its fault, bearing, size, speed, seed, the case hash of the case
  built here from the spec) and the ground truth (textbook fault frequencies from the bearing geometry);
- a textbook envelope analysis written here names the labelled fault frequency in the waveform files, for runs
  of every kind at two speeds, and none for the healthy machine;
- the same spec gives the same files, bit for bit, for 1 and 2 worker processes and on Dask's local cluster;
- a real ``bkabem dataset`` process killed mid-run resumes: finished runs are skipped, a truncated file planted
  under a run's name is rendered again, and the result equals an uninterrupted render;
- a bad spec gives exit 2 and one line naming the key (a table of cases and a fuzz over every key).
"""

from __future__ import annotations

import copy
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy import signal as sps

from bkabem_core.dataset.engine import _manifest, read_labels, render_dataset
from bkabem_core.dataset.spec import DatasetSpec
from bkabem_core.model.case import Case

pytestmark = pytest.mark.slow

FS = 25600.0

KINDS_SPEC = """
[dataset]
name = "kinds_test"
schema_version = 1
case = "motor_6010_healthy"
sampling = "grid"
seed = 11

[run]
duration_s = 2.0
sample_rate_hz = 25600.0
quantities = ["acceleration"]
slip = 0.01
noise_acc = 2.0e-4
length_m = 2.0e-3
depth_m = 50.0e-6
wander_revolutions = 0.0   # the ball's pit stays on the track: a clean 2 x BSF comb that the textbook rule names
spin_slip = 0.0            # (the wandering pit is checked in tests/unit/test_balltrack.py)

[grid]
fault = ["healthy", "outer", "inner", "ball"]
speed_hz = [15.0, 25.0]
"""

FAST_SPEC = """
[dataset]
name = "fast_test"
schema_version = 1
sampling = "grid"
seed = 3
replicates = 2

[run]
duration_s = 0.5
quantities = ["acceleration", "displacement"]
slip = 0.01
noise_acc = 1.0e-3

[grid]
fault = ["healthy", "outer", "nde:outer"]
speed_hz = [12.5, 30.0]
"""


def _spec(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "runs").glob("*.parquet"))}


@pytest.fixture(scope="module")
def kinds(tmp_path_factory):
    """The four kinds at 15 and 25 Hz, 2 s each, rendered once on two worker processes."""
    d = tmp_path_factory.mktemp("kinds")
    spec = DatasetSpec.load(_spec(d, KINDS_SPEC))
    out = d / "out"
    res = render_dataset(spec, out, workers=2, log=lambda line: None)
    assert res.rendered == len(spec.runs) == 8
    return spec, out


# --------------------------------------------------------------------------- labels
def _textbook_multipliers(b: dict) -> dict:
    """BPFO, BPFI, BSF, FTF per Hz of shaft speed from a bearing's geometry (stationary outer race, contact angle as
    given): e.g. Randall & Antoni, Mech. Syst. Signal Process. 25 (2011), eq. 1-4."""
    z, d, dp = b["n_balls"], b["ball_diameter_m"], b["pitch_diameter_m"]
    c = math.cos(math.radians(b["contact_angle_deg"]))
    r = d / dp * c
    return {"bpfo": z / 2 * (1 - r), "bpfi": z / 2 * (1 + r), "ftf": 0.5 * (1 - r),
            "bsf": dp / (2 * d) * (1 - r ** 2)}


def test_labels_match_the_spec_and_the_ground_truth(kinds):
    spec, out = kinds
    labels = read_labels(out).to_pylist()
    csv_lines = (out / "labels.csv").read_text().strip().splitlines()
    assert len(labels) == 8 and len(csv_lines) == 9                   # one row per run (one state each) + header
    base = Case.load("motor_6010_healthy")
    mult = _textbook_multipliers(base.bearing_table("de"))           # the 6010 at both positions
    expected = [(f, s) for f in ("healthy", "outer", "inner", "ball") for s in (15.0, 25.0)]
    for i, (row, (fault, speed)) in enumerate(zip(labels, expected)):
        assert row["run_index"] == i and row["fault"] == fault and row["healthy"] == (fault == "healthy")
        assert row["speed_hz_mean"] == pytest.approx(speed, abs=1e-9)
        assert row["duration_s"] == 2.0 and row["n_samples"] == 51200 and row["sample_rate_hz"] == FS
        seed = int(np.random.SeedSequence([11, i]).generate_state(1, np.uint64)[0] >> np.uint64(1))
        assert row["seed"] == seed
        # the case built here from the spec: the base machine with this run's defect
        raw = copy.deepcopy(base.raw)
        raw["defects"] = [] if fault == "healthy" else [dict(
            {"bearing": "de", "race": fault, "length_m": 2e-3, "depth_m": 50e-6, "angle_deg": -90.0, "edge": "ball",
             "edge_fraction": 0.1, "roughness_db": 0.0},   # the spec writes every own key of the kind, defaults too
            **({"ball": 1, "wander_revolutions": 0.0, "spin_slip": 0.0} if fault == "ball" else {"strike_spread": 1.0}))]
        assert row["case_hash"] == Case.from_dict(raw).case_hash
        for name, m in mult.items():
            assert row[f"{name}_hz"] == pytest.approx(m * speed, rel=1e-9), name
            for b in ("de", "nde"):                   # each bearing's own columns: the same 6010 here
                assert row[f"{b}_{name}_hz"] == pytest.approx(m * speed, rel=1e-9), (b, name)
        assert row["de_bearing_designation"] == row["nde_bearing_designation"] == "6010"
        if fault == "healthy":
            assert row["n_defects"] == 0 and row["d0_kind"] is None
        else:
            assert (row["n_defects"], row["d0_kind"], row["d0_bearing"]) == (1, fault, "de")
            assert row["d0_length_m"] == 2e-3 and row["d0_depth_m"] == 50e-6 and row["d0_angle_deg"] == -90.0
            strike = {"outer": mult["bpfo"], "inner": mult["bpfi"], "ball": 2 * mult["bsf"]}[fault]
            assert row["d0_strike_frequency_hz"] == pytest.approx(strike * speed, rel=1e-9)
        # the waveform file the row points to
        t = pq.read_table(out / row["file"])
        assert t.num_rows == 51200
        assert t.column_names == [f"{b}_{d}_acceleration" for b in ("de", "nde") for d in ("vertical", "horizontal")] \
            + ["speed_hz", "state"]
        assert t.schema.field("de_vertical_acceleration").metadata[b"unit"] == b"m/s^2"
        assert np.all(t.column("speed_hz").to_numpy() == np.float32(speed))
        x = t.column("de_vertical_acceleration").to_numpy()
        assert x.dtype == np.float32 and np.all(np.isfinite(x)) and x.std() > 0


def test_run_file_layout_as_documented(kinds):
    """docs/datasets.md "A run's Parquet file": plain float32 / int16 columns (no dictionary type for a reader to
    meet), one row group per 1-s chunk; the channels PLAIN and uncompressed (the spec's codec "none"), without
    statistics; speed and state under snappy, which keeps them small."""
    spec, out = kinds
    row = read_labels(out).to_pylist()[2]                                  # outer race, 15 Hz
    f = pq.ParquetFile(out / row["file"])
    types = {fl.name: fl.type for fl in f.schema_arrow}
    assert set(types.values()) == {pa.float32(), pa.int16()} and types["state"] == pa.int16()
    md = f.metadata
    assert md.num_row_groups == 2 and md.row_group(0).num_rows == int(FS)
    for i in range(md.num_columns):
        c = md.row_group(0).column(i)
        assert "RLE_DICTIONARY" not in c.encodings and "PLAIN" in c.encodings, c
        if c.path_in_schema in ("speed_hz", "state"):
            assert c.compression == "SNAPPY" and c.total_compressed_size < 0.1 * c.total_uncompressed_size, c
        else:
            assert c.compression == "UNCOMPRESSED" and not c.is_stats_set, c
    assert f.read(columns=["state"]).column(0).to_numpy().max() == 0


# --------------------------------------------------------------------------- envelope analysis
def _envelope_ratios(x: np.ndarray, fs: float, candidates: dict, f_r: float) -> dict:
    """Textbook envelope analysis: the strongest 1 kHz band above 1 kHz (Welch PSD), 4th-order Butterworth
    band-pass, squared Hilbert envelope, its Hann-windowed spectrum; for each candidate its peak (largest bin within
    1 % of it and of its second harmonic) over the median of the envelope spectrum within +- 0.4 x shaft speed."""
    f, pxx = sps.welch(x, fs, nperseg=4096)
    los = np.arange(1000.0, 0.4 * fs, 500.0)
    lo = los[int(np.argmax([pxx[(f >= a) & (f < a + 1000.0)].sum() for a in los]))]
    sos = sps.butter(4, [lo, lo + 1000.0], btype="bandpass", fs=fs, output="sos")
    env = np.abs(sps.hilbert(sps.sosfiltfilt(sos, x))) ** 2
    env -= env.mean()
    spec = np.abs(np.fft.rfft(env * np.hanning(env.size)))
    fr = np.fft.rfftfreq(env.size, 1.0 / fs)
    tol = 1.5 * fr[1]
    out = {}
    for name, fc in candidates.items():
        peak = floor = 0.0
        for h in (1, 2):
            sel = np.abs(fr - h * fc) <= max(0.01 * h * fc, tol)
            around = (np.abs(fr - h * fc) < 0.4 * f_r) & ~sel
            peak += spec[sel].max()
            floor += np.median(spec[around])
        out[name] = peak / floor
    return out


def _named(ratios: dict, stands_out: float = 4.0):
    """The reading of the envelope spectrum: a ball defect shows 2 x BSF with the cage (FTF) standing out, an
    inner race BPFI, an outer race BPFO; None when nothing stands out."""
    up = {k for k, v in ratios.items() if v > stands_out}
    if {"2bsf", "ftf"} <= up:
        return "ball"
    if "bpfi" in up and ratios["bpfi"] >= ratios["bpfo"]:
        return "inner"
    if "bpfo" in up:
        return "outer"
    return None


def test_envelope_analysis_of_the_files_names_the_labelled_fault(kinds):
    """Read as a pipeline would: each file's DE vertical acceleration, the candidates from the labels' fault
    frequencies; the named fault is the labelled one (none for healthy), at both speeds."""
    _, out = kinds
    named = []
    for row in read_labels(out).to_pylist():
        x = pq.read_table(out / row["file"], columns=["de_vertical_acceleration"]).column(0).to_numpy()
        f_r = row["shaft_hz"]
        cand = {"bpfo": row["bpfo_hz"], "bpfi": row["bpfi_hz"], "2bsf": 2 * row["bsf_hz"], "ftf": row["ftf_hz"]}
        ratios = _envelope_ratios(x.astype(float), row["sample_rate_hz"], cand, f_r)
        got = _named(ratios)
        named.append((row["fault"], row["speed_hz_mean"], got))
        assert got == (None if row["fault"] == "healthy" else row["fault"]), (row["fault"], f_r, ratios)
        if row["fault"] != "healthy":
            key = {"outer": "bpfo", "inner": "bpfi", "ball": "2bsf"}[row["fault"]]
            assert cand[key] == pytest.approx(row["d0_strike_frequency_hz"], rel=1e-9)
    assert len(named) == 8


# --------------------------------------------------------------------------- determinism
def test_same_files_for_one_and_two_workers_and_any_order(tmp_path):
    spec_path = _spec(tmp_path, FAST_SPEC)
    spec = DatasetSpec.load(spec_path)
    a, b = tmp_path / "w1", tmp_path / "w2"
    render_dataset(spec, a, workers=1, log=lambda line: None)
    # the other folder: the last runs first (a partial render of them), then the rest on two workers
    partial = DatasetSpec.load(spec_path)
    later = partial.runs[6:]
    partial.runs = later
    render_dataset(partial, b, workers=1, log=lambda line: None)
    (b / "labels.parquet").unlink()                 # the partial spec's; the folder becomes the full spec's
    (b / "labels.csv").unlink()
    (b / "manifest.json").write_text(json.dumps(_manifest(spec, False)))
    render_dataset(spec, b, workers=2, log=lambda line: None)
    fa, fb = _files(a), _files(b)
    assert len(fa) == 12 and fa.keys() == fb.keys()
    assert all(fa[k] == fb[k] for k in fa), [k for k in fa if fa[k] != fb[k]]
    assert (a / "labels.parquet").read_bytes() == (b / "labels.parquet").read_bytes()
    assert (a / "labels.csv").read_bytes() == (b / "labels.csv").read_bytes()
    # and the seeds make a difference: replicates of a grid point differ
    t0, t1 = (pq.read_table(a / "runs" / k).column(0).to_numpy() for k in sorted(fa)[:2])
    assert not np.array_equal(t0, t1)


def test_dask_local_cluster_gives_the_local_files_bit_for_bit(tmp_path):
    import distributed  # noqa: F401  (installed by make install, '.[dev]': fail, do not skip, when it is missing)

    spec = DatasetSpec.load(_spec(tmp_path, FAST_SPEC))
    lines = []
    render_dataset(spec, tmp_path / "local", workers=1, log=lambda line: None)
    render_dataset(spec, tmp_path / "dask", engine="dask", workers=2, log=lines.append)
    assert any("127.0.0.1" in line for line in lines), lines            # the local cluster is on loopback only
    fa, fb = _files(tmp_path / "local"), _files(tmp_path / "dask")
    assert len(fa) == 12 and fa == fb
    assert (tmp_path / "local" / "labels.parquet").read_bytes() == (tmp_path / "dask" / "labels.parquet").read_bytes()


# --------------------------------------------------------------------------- resume
RESUME_SPEC = """
[dataset]
name = "resume_test"
schema_version = 1
sampling = "random"
runs = 40
seed = 99

[run]
duration_s = 4.0
quantities = ["acceleration", "displacement"]
slip = 0.01
noise_acc = 1.0e-3

[random]
fault = ["healthy", "outer"]
speed_hz = {min = 10.0, max = 40.0}
depth_m = [20.0e-6, 50.0e-6]
"""


def _children(pid: int) -> list[int]:
    out = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        out += [int(c) for c in (task / "children").read_text().split()]
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def _cli(*args) -> list[str]:
    return [sys.executable, "-m", "bkabem_ros", "dataset", *map(str, args)]


def test_killed_process_resumes_skips_finished_runs_and_rerenders_a_truncated_file(tmp_path):
    spec_path = _spec(tmp_path, RESUME_SPEC)
    out = tmp_path / "out"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen(_cli(spec_path, "--out", out, "--workers", "2", "--no-progress"), env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    t0 = time.monotonic()
    try:
        while len(list((out / "runs").glob("*.parquet"))) < 4:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() - t0 < 240, "no run finished in 240 s"
            time.sleep(0.05)
        children = _children(proc.pid)
        assert len(children) >= 2, children                    # the worker processes
        os.kill(proc.pid, signal.SIGKILL)                       # the command only, mid-run: its workers follow it
        proc.wait()
        t1 = time.monotonic()
        while any(_alive(c) for c in children):
            assert time.monotonic() - t1 < 10, f"workers {children} outlived the killed command"
            time.sleep(0.05)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)                 # whatever is left of that process group
        except ProcessLookupError:
            pass
        proc.wait()
    time.sleep(0.2)
    finished = sorted(p.name for p in (out / "runs").glob("*.parquet"))
    assert 4 <= len(finished) < 40, len(finished)
    assert not (out / "labels.parquet").exists()
    # a truncated file under the name of a finished run (what a crash of a naive writer would leave)
    victim = out / "runs" / finished[1]
    victim.write_bytes(victim.read_bytes()[: victim.stat().st_size // 2])
    r = subprocess.run(_cli(spec_path, "--out", out, "--workers", "2", "--no-progress"), env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert f"{len(finished) - 1} already there" in r.stdout and "1 damaged files rendered again" in r.stdout, r.stdout
    assert "not a complete Parquet file" in r.stderr and finished[1][:-8] in r.stderr, r.stderr
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]          # no temporaries left
    # the same as an uninterrupted render
    ref = tmp_path / "ref"
    render_dataset(DatasetSpec.load(spec_path), ref, workers=1, log=lambda line: None)
    fa, fb = _files(out), _files(ref)
    assert len(fa) == 40 and fa == fb
    assert (out / "labels.parquet").read_bytes() == (ref / "labels.parquet").read_bytes()


@pytest.mark.parametrize("out", ["", "{tmp}/file", "{tmp}/busy"])
def test_an_output_that_is_no_data_set_folder_is_refused(tmp_path, capsys, out):
    """An empty --out, a file, a folder with other files (not a data set's): exit 2, one line, nothing written."""
    (tmp_path / "file").write_text("x")
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    rc, _, err = _main(["dataset", "dataset_example", "--out", out.format(tmp=tmp_path)], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--out:" in err, err
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_another_spec_in_the_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    spec = DatasetSpec.load(_spec(tmp_path, FAST_SPEC.replace("replicates = 2", "replicates = 1")
                                  .replace('"nde:outer"', "").replace(", ]", "]")))
    render_dataset(spec, out, workers=1, log=lambda line: None)
    other = _spec(tmp_path, FAST_SPEC.replace("seed = 3", "seed = 4"), "other.toml")
    r = subprocess.run(_cli(other, "--out", out), capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "--out" in r.stderr and "another data set" in r.stderr


# --------------------------------------------------------------------------- bad specs
BAD = [
    ("[dataset]\nname='x'\nschema_version=1\nbogus=1\n", "dataset.bogus", "unknown key"),
    ("[dataset]\nname='x'\nschema_version=2\n", "dataset.schema_version", "must be 1"),
    ("[dataset]\nschema_version=1\n", "dataset.name", "missing"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nspeed_hz=[10.0, -5.0]\n", "grid.speed_hz[1]", "> 0"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nspeed_hz=[500.0]\n", "grid.speed_hz[0]", "max_speed_hz"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nfault=['outer', 'crack']\n", "grid.fault[1]", "outer, inner"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nfault='outer'\ndepth_m=nan\n", "run.depth_m", "finite"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nfault='inner'\nlength_m=0.015\n", "run.length_m", "ball pitch"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nslip=0.5\n", "run.slip", "<= 0.1"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nquantities=['acceleration','pressure']\n", "run.quantities",
     "unknown quantity"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nspeed_hz=20.0\nprofile='ramp:0:30:1'\n", "run.profile",
     "not both"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nprofile='ramp:0:30'\n", "run.profile", "three values"),
    ("[dataset]\nname='x'\nschema_version=1\n[random]\nslip=[0.0]\n", "random", "only with dataset.sampling"),
    ("[dataset]\nname='x'\nschema_version=1\nsampling='random'\n", "dataset.runs", "missing"),
    ("[dataset]\nname='x'\nschema_version=1\nsampling='random'\nruns=3\n[random]\nslip={min=0.02, max=0.01}\n",
     "random.slip.max", ">= min"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nscenario='de_outer_run_to_failure'\nfault='outer'\n",
     "run.fault", "not with a scenario"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nscenario='nope'\n", "run.scenario", "no embedded scenario"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\ntime_scale=10.0\n", "run.time_scale", "only with a scenario"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nfault='ball'\nball=15\n", "run.ball", "1..14"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nslip=0.01\n", "grid.slip", "non-empty list"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nload_factor=0.01\n", "run.load_factor", ">= 0.1"),
    ("[dataset]\nname='x'\nschema_version=1\ncase='no_such_case'\n", "dataset.case", "no embedded case"),
    ("[dataset\nname='x'\n", "toml", "not valid TOML"),
]


def _main(argv, capsys) -> tuple[int, str, str]:
    from bkabem_ros.cli.main import main

    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_bad_spec_exit_2_as_a_process(tmp_path):
    """The console command itself (not only main()): exit code 2, one line, no traceback."""
    p = _spec(tmp_path, BAD[3][0])
    r = subprocess.run(_cli(p, "--out", tmp_path / "o"), capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "grid.speed_hz[1]" in r.stderr, r.stderr


# --------------------------------------------------------------------------- scenarios and MCAP
SCENARIO_SPEC = """
[dataset]
name = "scenario_test"
schema_version = 1
sampling = "grid"
seed = 1

[run]
scenario = "de_outer_run_to_failure"
time_scale = 7200.0
duration_s = 6.0
chunk_s = 0.25
quantities = ["acceleration"]

[output]
mcap = true
"""


def test_scenario_runs_label_every_state_and_record_mcap(tmp_path):
    """A run to failure: one label row per scenario state in the signal (the state due at each chunk border),
    each at the scenario's own size for the state's start (the timeline evaluated here from the scenario file),
    the state column of the file switching at those samples; the MCAP of the run holds the node's waveform
    messages with the same ground truth."""
    from bkabem_core.scenario.timeline import Scenario
    from bkabem_ros.recording.dataset_sink import SINK

    spec = DatasetSpec.load(_spec(tmp_path, SCENARIO_SPEC))
    out = tmp_path / "out"
    render_dataset(spec, out, workers=1, sinks=(SINK,), log=lambda line: None)
    rows = read_labels(out).to_pylist()
    sc = Scenario.load("de_outer_run_to_failure")
    fs, scale = 25600.0, 7200.0
    n_chunk = int(0.25 * fs)
    # the state in effect at each chunk border: the one due there (a state shorter than a chunk is skipped)
    due = [sc.state_index_at(k * n_chunk / fs * scale) for k in range(int(6.0 * fs) // n_chunk)]
    segments = [(k * n_chunk, j) for k, j in enumerate(due) if k == 0 or due[k - 1] != j]
    assert len(rows) == len(segments) > 10 and rows[0]["fault"] == "healthy" and rows[-1]["fault"] == "outer"
    state = pq.read_table(out / rows[0]["file"], columns=["state"]).column(0).to_numpy()
    t_h = [2.0, 6.0, 9.0, 11.0, 12.0]
    depth = [5e-6, 15e-6, 35e-6, 65e-6, 100e-6]
    for row, (first, k) in zip(rows, segments):
        assert row["first_sample"] == first and row["state_index"] == k
        assert np.all(state[first:first + row["n_samples"]] == k)
        assert row["state_start_s"] == sc.states[k].start_s
        if k:
            th = sc.states[k].start_s / 3600.0
            j = min(max(i for i in range(len(t_h)) if t_h[i] <= th + 1e-12), len(t_h) - 2)
            w = (th - t_h[j]) / (t_h[j + 1] - t_h[j])
            d = depth[j] * (depth[j + 1] / depth[j]) ** w                  # exponential growth between points
            assert row["d0_depth_m"] == pytest.approx(d, rel=1e-6) and row["d0_bearing"] == "de"
            assert row["d0_fault_frequency_hz"] == pytest.approx(row["bpfo_hz"], rel=1e-12)
    assert sum(r["n_samples"] for r in rows) == int(6.0 * fs)
    from bkabem_ros.recording.mcap_io import iter_messages

    mcap = out / rows[0]["file"].replace(".parquet", ".mcap")
    msgs = list(iter_messages(mcap))
    assert len(msgs) == 2 * int(6.0 / 0.25)                                  # DE + NDE acceleration per chunk
    depths = [m.msg.ground_truth.defects[0].depth if m.msg.ground_truth.defects else 0.0
              for m in msgs if "/de/" in m.topic]
    want = [0.0 if not r["n_defects"] else r["d0_depth_m"] for r in rows for _ in range(r["n_samples"] // n_chunk)]
    assert depths == pytest.approx(want, rel=1e-9)


def test_speed_profile_runs_carry_their_speed_per_sample(tmp_path):
    """A ramp 10 -> 40 Hz over 1 s, held for the rest of a 1.5-s run: the file's speed column is that ramp at
    every sample's time (evaluated here), the labels give its min, max and mean and the fault frequencies at the
    mean; an outer-race run in the same spec too."""
    text = FAST_SPEC.replace("replicates = 2", "replicates = 1").replace("speed_hz = [12.5, 30.0]", "") \
        .replace("duration_s = 0.5", "duration_s = 1.5\nprofile = \"ramp:10:40:1\"")
    spec = DatasetSpec.load(_spec(tmp_path, text))
    render_dataset(spec, tmp_path / "out", workers=1, log=lambda line: None)
    n = int(1.5 * FS)
    t = np.arange(n) / FS
    want = np.where(t < 1.0, 10.0 + 30.0 * t, 40.0)
    rows = read_labels(tmp_path / "out").to_pylist()
    assert [r["fault"] for r in rows] == ["healthy", "outer", "outer"]
    for row in rows:
        v = pq.read_table(tmp_path / "out" / row["file"], columns=["speed_hz"]).column(0).to_numpy()
        assert np.allclose(v, want, rtol=1e-6, atol=1e-4)
        assert row["profile"] == "ramp:10:40:1"
        assert row["speed_hz_min"] == pytest.approx(10.0) and row["speed_hz_max"] == pytest.approx(40.0)
        assert row["speed_hz_mean"] == pytest.approx(want.mean(), rel=1e-6)
        assert row["bpfo_hz"] == pytest.approx(row["bpfo_per_hz"] * want.mean(), rel=1e-6)
