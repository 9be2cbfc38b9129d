"""The bkabem synth command: files written, bad input refused with one line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


# ----------------------------------------------------------------------------------------- CLI
def _cli(args, tmp_path):
    return subprocess.run([sys.executable, "-m", "bkabem_ros", "synth", *args], cwd=tmp_path,
                          capture_output=True, text=True, env={"PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1",
                                                               "MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"})


def test_cli_npz_csv_png(tmp_path):
    r = _cli(["--profile", "ramp:5:20:0.4", "--rate", "25600", "--out", "run.npz", "--png", "run.png",
              "--slip", "0.01", "--noise-acc", "1e-3", "--seed", "4"], tmp_path)
    assert r.returncode == 0, r.stderr
    z = np.load(tmp_path / "run.npz")
    assert z["samples"].shape == (8, 10240) and z["samples"].dtype == np.float32
    assert z["speed_hz"].shape == (10240,) and z["speed_hz"][-1] == pytest.approx(20.0, rel=1e-3)
    assert z["features_rms"].shape == (4, 8) and z["iso10816_velocity_rms_mm_s"].shape == (4, 2, 3)
    meta = json.loads(str(z["metadata"]))
    assert meta["synthesizer"]["channel_names"][0] == "de_vertical_acceleration"
    assert meta["ground_truth"]["seed"] == 4 and meta["units"]["de_vertical_displacement"] == "m"
    assert (tmp_path / "run.png").stat().st_size > 10000
    r = _cli(["--profile", "constant:12", "--seconds", "0.05", "--rate", "25600", "--out", "run.csv"], tmp_path)
    assert r.returncode == 0, r.stderr
    lines = (tmp_path / "run.csv").read_text().splitlines()
    assert lines[0].startswith("# metadata: {")
    assert lines[1].startswith("time_s,speed_hz,de_vertical_acceleration_m_s2,de_horizontal_acceleration_m_s2,"
                               "de_vertical_displacement_m")
    assert len(lines) == 2 + 1280
    data = np.loadtxt(tmp_path / "run.csv", delimiter=",", comments="#", skiprows=2)
    np.testing.assert_allclose(data[:, 0], np.arange(1280) / 25600)


@pytest.mark.parametrize("args, needle", [
    (["--profile", "warp:9", "--seconds", "1"], "--profile: unknown profile kind"),
    (["--profile", "constant:nan", "--seconds", "1"], "--profile.speed_hz: must be finite"),
    (["--profile", "constant:20", "--seconds", "-1"], "--seconds: must be > 0"),
    (["--profile", "constant:20"], "--seconds: is required"),
    (["--profile", "constant:50", "--seconds", "1", "--rate", "8000"], "--rate: sample rate 8000 Hz is below twice"),
    (["--profile", "constant:20", "--seconds", "1", "--slip", "2"], "--slip: must be <= 0.1"),
])
def test_cli_bad_input(tmp_path, args, needle):
    r = _cli([*args, "--out", "x.npz"], tmp_path)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and needle in r.stderr, r.stderr
    assert not (tmp_path / "x.npz").exists()
