"""Issue 14, item 1: replay must not pass damaged recordings off as good.

A file cut at 50 %, one with corrupted bytes inside a chunk, and one cut inside its header are refused by
``bkabem replay`` (exit 2, one line naming FILE and the damage) in both modes (publish and --rerun-save);
``--info`` reports the damage (exit 2); ``--allow-damaged`` replays exactly the messages of the intact chunks
(also those after the damaged chunk) and says what it skipped. On main the cut file replayed 555 of 1314
messages with exit 0, the corrupted one published a message with NaN samples, exit 0.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from ros_helpers import random_domain

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import mcap_check, mcap_io, replay

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
FS = 10_240.0
N = 1024
T0 = 1_700_000_000_000_000_000


def _record(path: Path, compression: str) -> Path:
    with mcap_io.McapRecorder(path, chunk_size_bytes=40_000, background_flush=False, compression=compression) as rec:
        for i in range(40):
            t = T0 + i * 100_000_000
            x = np.sin(2 * np.pi * 50 * (i * N + np.arange(N)) / FS)
            wf = msgs.waveform_message(np.stack([x, -x]), sample_rate=FS, first_sample_index=i * N,
                                       shaft_speed=10.0, machine_id="m1", location="de", quantity="acceleration",
                                       channel_names=["vertical", "horizontal"], stamp=t)
            rec.add("/m1/vibration/de/acceleration", "bkabem_msgs/msg/VibrationWaveform", wf, t, t)
    info = mcap_check.verify(path)
    assert info.ok and info.messages == 40 and info.chunks >= 5, info.summary_line()
    return path


@pytest.fixture(scope="module")
def intact(tmp_path_factory):
    """40 waveform messages of a sine in >= 5 chunks (small chunk size), zstd: a tiny recording of the node."""
    return _record(tmp_path_factory.mktemp("dmg") / "intact.mcap", "zstd")


def _corrupt(src: Path, dst: Path, chunk: int = 2, n_bytes: int = 16) -> mcap_check.Integrity:
    """Flip ``n_bytes`` in the compressed data of one chunk (not the first: its channel definition must
    survive elsewhere, in the summary)."""
    info = mcap_check.verify(src)
    ref = sorted(info.intact_chunks)[chunk]
    data = bytearray(src.read_bytes())
    rng = random.Random(7)
    for _ in range(n_bytes):
        data[ref.offset + ref.length - 1 - rng.randrange(ref.length // 2)] ^= 0x5A
    dst.write_bytes(bytes(data))
    return info


def _run(*args, timeout=120):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(random_domain()),
               ROS_LOG_DIR=tempfile.mkdtemp(prefix="bkabem_dmg_log_"))
    return subprocess.run([sys.executable, "-m", "bkabem_ros", "replay", *map(str, args)], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=timeout)


def _one_error(p, *fragments):
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert len(lines) == 1 and all(f in lines[0] for f in fragments), p.stderr


@pytest.fixture(scope="module")
def damaged(intact, tmp_path_factory):
    d = tmp_path_factory.mktemp("dmg2")
    data = intact.read_bytes()
    (d / "half.mcap").write_bytes(data[: len(data) // 2])
    (d / "header.mcap").write_bytes(data[:40])
    _corrupt(intact, d / "corrupt.mcap")                    # zstd notices: decompression fails
    # uncompressed chunks: the flipped bytes land in the samples (NaN, garbage) and only the CRC notices
    _corrupt(_record(d / "raw.mcap", "none"), d / "corrupt_raw.mcap")
    return d


@pytest.mark.parametrize("name, fragment", [("half", "cut at byte"), ("header", "inside the header"),
                                            ("corrupt", "decompression failed"), ("corrupt_raw", "CRC mismatch")])
def test_damaged_file_is_refused_in_both_modes(damaged, tmp_path, name, fragment):
    f = damaged / f"{name}.mcap"
    _one_error(_run(f, "--rerun-save", tmp_path / "o.rrd"), "FILE", str(f), fragment, "--allow-damaged")
    assert not (tmp_path / "o.rrd").exists()
    _one_error(_run(f, "--rate", "50"), "FILE", fragment)          # publish mode: refused before any DDS


def test_info_reports_damage(damaged, intact):
    p = _run(damaged / "corrupt_raw.mcap", "--info")
    _one_error(p, "CRC mismatch")
    assert "integrity:" in p.stdout and "damaged at byte" in p.stdout
    p = _run(intact, "--info")
    assert p.returncode == 0 and "integrity: intact (40 messages" in p.stdout, p.stdout + p.stderr


class _Collect:
    """A Rerun-logger stand-in that keeps what replay hands it (the sink interface of RerunLogger)."""

    def __init__(self):
        self.msgs = []

    def log_speed(self, stamp_ns, rad_s):
        self.msgs.append(("speed", stamp_ns, rad_s))

    def log_message(self, topic, type_name, msg, stamp_ns):
        self.msgs.append((topic, stamp_ns, msg))
        return True


@pytest.mark.parametrize("name", ["corrupt", "corrupt_raw"])
def test_allow_damaged_replays_exactly_the_intact_chunks(damaged, tmp_path, name):
    bad = damaged / f"{name}.mcap"
    info = mcap_check.verify(bad)
    assert len(info.damaged) == 1 and info.missing > 0
    with pytest.raises(mcap_check.DamagedRecording, match="corrupted bytes"):
        replay.replay(bad, publish=False, rerun_logger=_Collect())
    sink = _Collect()
    stats = replay.replay(bad, publish=False, rerun_logger=sink, allow_damaged=True)
    assert stats.logged == info.messages == 40 - info.missing
    assert stats.damage and "corrupted bytes" in stats.damage
    idx = [m.first_sample_index // N for _, _, m in sink.msgs]
    assert idx == sorted(idx) and max(idx) == 39           # messages after the damaged chunk are kept
    for _, _, m in sink.msgs:
        assert np.all(np.isfinite(msgs.waveform_array(m)))
    p = _run(bad, "--rerun-save", tmp_path / "o.rrd", "--allow-damaged")
    assert p.returncode == 0, p.stderr
    assert f"logged {info.messages} messages" in p.stdout and "skipped the damaged part" in p.stderr


def test_recovered_cut_file_replays(damaged, tmp_path):
    fixed = tmp_path / "fixed.mcap"
    res = mcap_io.recover(damaged / "half.mcap", fixed)
    assert res.truncated and mcap_check.verify(fixed).ok
    p = _run(fixed, "--rerun-save", tmp_path / "o.rrd")
    assert p.returncode == 0 and f"logged {res.messages} messages" in p.stdout, p.stdout + p.stderr
