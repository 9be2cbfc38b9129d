"""Recordings that cannot bomb, crash or hang replay, and a recover that keeps every intact chunk (issue 25,
items 2-4, the recording parts of 5, 7 and 9).

Each file is made here from a small recording of 40 waveform messages in 9 chunks:

- **Bombs**: one chunk's data replaced by a 64 kB zstd frame of 2 GiB of zeros (RLE blocks), declaring 2 GiB, or
  lying (the chunk declares its old 42 kB, the frame 2 GiB, or no size at all). On main ``replay --info`` and every
  other mode ran for minutes at GBs. Now each mode ends within 5 s below 300 MB of peak RSS (measured with
  ``wait4``): refused (exit 2), or the intact part replayed / recovered.
- **Recover**: garbage in the middle of the file, garbage over a chunk's length, a chunk whose inner record length
  runs past its end, a chunk CRC field of 0: the recovered file holds every message of every intact chunk (35 or
  40 of 40; main kept 0-15 or called the file complete) and says what it skipped; what is not an MCAP recording
  (empty, garbage, TOML, the magic alone) is refused, exit 2 (main: exit 0, "0 messages").
- **Bad payloads** in a valid container (garbage, cut, empty, a sequence length of 2^31, a definition that does not
  parse): ``--info`` decodes every message and calls the file damaged (main: "intact", then exit 1 "(a bug)" in
  every other mode); ``--allow-damaged`` leaves them out and counts them.
- A corrupt footer summary offset and a second recording appended are damage (rosbags refuses the first).
- A 31-year gap in the log times is refused before publishing (main waited for ever); ``--topics`` that the file
  does not have, a directory or a FIFO as FILE: one line, exit 2.
"""

from __future__ import annotations

import os
import random
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from ros_helpers import random_domain

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import mcap_check, mcap_io

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
TOPIC = "/m1/vibration/de/acceleration"
TYPE = "bkabem_msgs/msg/VibrationWaveform"
T0 = 1_700_000_000_000_000_000
BOMB = 2 << 30


def _waveform(i: int, n: int = 1024):
    x = np.sin(2 * np.pi * 50 * (i * n + np.arange(n)) / 10240.0)
    return msgs.waveform_message(np.stack([x, -x]), sample_rate=10240.0, first_sample_index=i * n, shaft_speed=10.0,
                                 machine_id="m1", location="de", quantity="acceleration",
                                 channel_names=["vertical", "horizontal"], stamp=T0 + i * 100_000_000)


def _record(path: Path, compression: str = "zstd", n: int = 40) -> Path:
    with mcap_io.McapRecorder(path, chunk_size_bytes=40_000, background_flush=False, compression=compression) as rec:
        for i in range(n):
            t = T0 + i * 100_000_000
            rec.add(TOPIC, TYPE, _waveform(i), t, t)
    return path


def _chunks(path: Path):
    info = mcap_check.verify(path)
    assert info.ok and info.messages == 40 and info.chunks >= 8, info.summary_line()
    return sorted(info.intact_chunks)


def _rle_zstd_frame(total: int, with_size: bool = True) -> bytes:
    """A zstd frame of ``total`` zero bytes in RLE blocks of 128 kiB (4 bytes each): 64 kB for 2 GiB."""
    out = bytearray(struct.pack("<I", 0xFD2FB528))
    out += bytes([0xE0]) + struct.pack("<Q", total) if with_size else bytes([0x00, 0x50])
    left = total
    while left > 0:
        n = min(1 << 17, left)
        left -= n
        out += struct.pack("<I", (left == 0) | (1 << 1) | (n << 3))[:3] + b"\x00"
    return bytes(out)


def _with_chunk(src: Path, dst: Path, index: int, data: bytes, declared: int) -> Path:
    """``src`` with chunk ``index``'s compressed data replaced (its CRC field 0: the bound, not the CRC, must
    catch it)."""
    ref = _chunks(src)[index]
    raw = src.read_bytes()
    start, end = struct.unpack_from("<QQ", raw, ref.offset)
    body = struct.pack("<QQQII", start, end, declared, 0, 4) + b"zstd" + struct.pack("<Q", len(data)) + data
    dst.write_bytes(raw[:ref.offset - 9] + struct.pack("<BQ", 6, len(body)) + body + raw[ref.offset + ref.length:])
    return dst


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    good = _record(d / "good.mcap")
    refs = _chunks(good)
    raw = good.read_bytes()
    declared = struct.unpack_from("<Q", raw, refs[2].offset + 16)[0]
    _with_chunk(good, d / "bomb.mcap", 2, _rle_zstd_frame(BOMB), BOMB)
    _with_chunk(good, d / "bomb_lying.mcap", 2, _rle_zstd_frame(BOMB), declared)
    _with_chunk(good, d / "bomb_unsized.mcap", 2, _rle_zstd_frame(BOMB, with_size=False), declared)
    g = bytearray(raw)
    at = len(g) // 3
    g[at:at + 16] = random.Random(1).randbytes(16)
    (d / "garbage16_third.mcap").write_bytes(g)
    h = bytearray(raw)
    struct.pack_into("<BQ", h, refs[4].offset - 9, 6, 1 << 62)                 # garbage over a chunk's length
    (d / "chunk_length.mcap").write_bytes(h)
    c = bytearray(raw)
    struct.pack_into("<I", c, refs[3].offset + 24, 0)                          # a CRC field of 0: not checked
    (d / "crc0.mcap").write_bytes(c)
    none = _record(d / "none.mcap", compression="none")
    ref = _chunks(none)[3]
    b = bytearray(none.read_bytes())
    _s, _e, usize, _crc, n_comp = struct.unpack_from("<QQQII", b, ref.offset)
    data_at = ref.offset + 32 + n_comp + 8
    i = data_at
    while b[i] != 5:                                                            # the chunk's first message record
        i += 9 + struct.unpack_from("<Q", b, i + 1)[0]
    struct.pack_into("<Q", b, i + 1, 1 << 40)
    struct.pack_into("<I", b, ref.offset + 24, zlib.crc32(bytes(b[data_at:data_at + usize])))   # CRC made right
    (d / "inner_length.mcap").write_bytes(b)
    (d / "appended.mcap").write_bytes(raw + raw)
    f = bytearray(raw)
    footer = len(f) - 8 - 20
    assert f[footer - 9] == 2
    struct.pack_into("<Q", f, footer, struct.unpack_from("<Q", f, footer)[0] + 7)
    (d / "footer_offset.mcap").write_bytes(f)
    (d / "empty.mcap").write_bytes(b"")
    (d / "garbage.mcap").write_bytes(random.Random(2).randbytes(5000))
    (d / "case.mcap").write_text('[case]\nname = "x"\n')
    (d / "magic.mcap").write_bytes(mcap_check.MAGIC)
    return d


def _env():
    return dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_DOMAIN_ID=str(random_domain()),
                ROS_LOG_DIR=tempfile.mkdtemp(prefix="bkabem_hostile_log_"), PYTHONUNBUFFERED="1")


def _bkabem(*args, deadline: float = 60.0):
    """Run ``bkabem ARGS``; returns (exit code, stdout, stderr, seconds). Killed at ``deadline``."""
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-m", "bkabem_ros", *map(str, args)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=ROOT, env=_env())
    try:
        out, err = p.communicate(timeout=deadline)
    except subprocess.TimeoutExpired:
        p.kill()
        out, err = p.communicate()
    return p.returncode, out, err, time.monotonic() - t0


#: Runs a command and writes its peak RSS [kB] to a file. Linux keeps a process's peak RSS across fork and exec, so
#: a child of this (large) test process would report the test's own peak; a child of this small launcher reports its
#: own.
_LAUNCHER = ("import resource, subprocess, sys\n"
             "code = subprocess.call(sys.argv[2:])\n"
             "open(sys.argv[1], 'w').write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))\n"
             "sys.exit(code)\n")


def _bkabem_rss(*args, deadline: float = 60.0):
    """Like :func:`_bkabem`, with the command's own peak RSS [MB] (through :data:`_LAUNCHER`)."""
    t0 = time.monotonic()
    with tempfile.TemporaryFile("w+") as fo, tempfile.TemporaryFile("w+") as fe, \
            tempfile.NamedTemporaryFile("r") as peak:
        p = subprocess.Popen([sys.executable, "-c", _LAUNCHER, peak.name, sys.executable, "-m", "bkabem_ros",
                              *map(str, args)], stdout=fo, stderr=fe, text=True, cwd=ROOT, env=_env(),
                             start_new_session=True)
        try:
            p.wait(timeout=deadline)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
        fo.seek(0)
        fe.seek(0)
        text = Path(peak.name).read_text()
        return p.returncode, fo.read(), fe.read(), time.monotonic() - t0, (int(text) / 1024 if text else float("inf"))


def _one_line(err: str, *fragments: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and all(f in lines[0] for f in fragments), err[-3000:]
    return lines[0]


def _rosbags_count(path: Path) -> int:
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return sum(1 for _ in reader.messages())


# --------------------------------------------------------------------------- bombs
@pytest.mark.parametrize("name, reason", [("bomb", "declares 2147483648 bytes uncompressed"),
                                          ("bomb_lying", "its zstd frame declares 2147483648 bytes"),
                                          ("bomb_unsized", "decompresses to more bytes")])
def test_a_zstd_bomb_is_refused_quickly_in_every_mode(files, tmp_path, name, reason):
    f = files / f"{name}.mcap"
    runs = {"info": ["replay", f, "--info"], "rerun": ["replay", f, "--rerun-save", tmp_path / "a.rrd"],
            "publish": ["replay", f, "--rate", "100"],
            "allow": ["replay", f, "--allow-damaged", "--rerun-save", tmp_path / "b.rrd"],
            "recover": ["record", "--recover", f, tmp_path / "fixed.mcap"]}
    for mode, args in runs.items():
        rc, out, err, secs, rss = _bkabem_rss(*args, deadline=30)
        print(f"{name} {mode}: exit {rc}, {secs:.2f} s, {rss:.0f} MB")
        assert secs < 5.0 and rss < 300, (mode, secs, rss)
        if mode in ("info", "rerun", "publish"):
            assert rc == 2, (mode, rc, err[-2000:])
            _one_line(err, "is damaged", "chunk 3", reason)
        else:
            assert rc == 0, (mode, rc, err[-2000:])
    assert (tmp_path / "b.rrd").stat().st_size > 0
    assert _rosbags_count(tmp_path / "fixed.mcap") == 35                       # every chunk but the bomb


# --------------------------------------------------------------------------- recover
@pytest.mark.parametrize("name, kept, skipped", [("garbage16_third", 35, 1), ("chunk_length", 35, 0),
                                                 ("inner_length", 35, 1), ("crc0", 40, 0)])
def test_recover_keeps_every_intact_chunk(files, tmp_path, name, kept, skipped):
    fixed = tmp_path / "fixed.mcap"
    rc, out, err, _ = _bkabem("record", "--recover", files / f"{name}.mcap", fixed)
    assert rc == 0 and not err.strip(), (rc, err)
    assert f"wrote {fixed}: {kept} messages" in out, out
    if kept < 40:
        assert "was damaged" in out and "of the 40 its summary counts" in out, out
    if skipped:
        assert f"skipped {skipped} damaged chunk" in out, out
    assert mcap_check.verify(fixed).ok and _rosbags_count(fixed) == kept
    got = [m.msg.first_sample_index // 1024 for m in mcap_io.iter_messages(fixed)]
    assert got == sorted(got) and len(set(got)) == kept


@pytest.mark.parametrize("name", ["empty", "garbage", "case", "magic"])
def test_recover_refuses_what_is_not_an_mcap_recording(files, tmp_path, name):
    rc, out, err, _ = _bkabem("record", "--recover", files / f"{name}.mcap", tmp_path / "fixed.mcap")
    assert rc == 2, (rc, out, err)
    _one_line(err, "--recover", "not an MCAP")
    assert not (tmp_path / "fixed.mcap").exists()


@pytest.mark.parametrize("name, fragment", [("footer_offset", "footer's summary offset"),
                                            ("appended", "bytes after the end of the recording")])
def test_summary_offsets_and_appended_recordings_are_damage(files, name, fragment):
    rc, out, err, _ = _bkabem("replay", files / f"{name}.mcap", "--info")
    assert rc == 2 and "integrity:" in out, (rc, out, err)
    _one_line(err, "is damaged", fragment)
    if name == "footer_offset":
        with pytest.raises(Exception):
            _rosbags_count(files / f"{name}.mcap")


# --------------------------------------------------------------------------- bad payloads
def _write_raw(path: Path, payloads: list[bytes], schema: bytes | None = None) -> Path:
    from mcap.writer import Writer

    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(TYPE, "ros2msg", schema if schema is not None
                                else msgs.message_definition_text(TYPE).encode())
        cid = w.register_channel(TOPIC, "cdr", sid, {"offered_qos_profiles": ""})
        for i, data in enumerate(payloads):
            t = T0 + i * 250_000_000
            w.add_message(channel_id=cid, log_time=t, publish_time=t, sequence=i, data=data)
        w.finish()
    return path


@pytest.fixture(scope="module")
def payloads(tmp_path_factory):
    from rclpy.serialization import serialize_message

    d = tmp_path_factory.mktemp("payloads")
    good = [serialize_message(_waveform(i, 256)) for i in range(12)]
    g = good[5]
    at = g.find(struct.pack("<I", 512))                                 # the samples' length (2 x 256)
    bad = {"garbage": b"\x00\x01\x00\x00" + bytes(range(256)) * 2, "cut": g[: len(g) // 2], "empty": b"",
           "huge_sequence": g[:at] + struct.pack("<I", 0x7FFFFFF0) + g[at + 4:]}
    for name, data in bad.items():
        _write_raw(d / f"{name}.mcap", good[:5] + [data] + good[6:])
    _write_raw(d / "schema.mcap", good, schema=b"\xff\xfe garbage\nint32[ x\n=====\nMSG: no/such")
    return d


@pytest.mark.parametrize("name, bad", [("garbage", 1), ("cut", 1), ("empty", 1), ("huge_sequence", 1),
                                       ("schema", 12)])
def test_bad_payloads_are_damage_refused_or_left_out_with_a_count(payloads, tmp_path, name, bad):
    f = payloads / f"{name}.mcap"
    rc, out, err, _ = _bkabem("replay", f, "--info")
    assert rc == 2, (rc, err)
    _one_line(err, "is damaged", "not decode", TOPIC)
    rc, out, err, _ = _bkabem("replay", f, "--rerun-save", tmp_path / "a.rrd")
    assert rc == 2 and not (tmp_path / "a.rrd").exists(), (rc, err)
    _one_line(err, "not decode")
    rc, out, err, _ = _bkabem("replay", f, "--allow-damaged", "--rerun-save", tmp_path / "b.rrd")
    assert rc == 0, (rc, err[-2000:])
    assert f"logged {12 - bad} messages" in out, out
    assert "Traceback" not in err and "exceeds remaining buffer" not in err, err
    if bad < 12:
        assert f"left out {bad} message that did not decode" in err, err
        rc, out, err, _ = _bkabem("replay", f, "--allow-damaged", "--rate", "20")
        assert rc == 0 and f"published {12 - bad} messages" in out, (rc, out, err[-2000:])


# --------------------------------------------------------------------------- limits and contract
def test_a_log_time_gap_of_31_years_is_refused_before_publishing(tmp_path):
    from rclpy.serialization import serialize_message

    f = tmp_path / "gap.mcap"
    data = serialize_message(_waveform(0, 64))
    with open(f, "wb") as fh:
        from mcap.writer import Writer

        w = Writer(fh)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(TYPE, "ros2msg", msgs.message_definition_text(TYPE).encode())
        cid = w.register_channel(TOPIC, "cdr", sid, {})
        for t in (T0, T0 + 100_000_000, T0 + 31 * 365 * 86400 * 10**9):
            w.add_message(channel_id=cid, log_time=t, publish_time=t, sequence=0, data=data)
        w.finish()
    rc, out, err, secs = _bkabem("replay", f, "--rate", "1000", deadline=60)
    assert rc == 2 and secs < 30, (rc, secs, err)
    _one_line(err, "gap of 9.77616e+08 s", "--max-gap")
    rc, out, err, _ = _bkabem("replay", f, "--rerun-save", tmp_path / "g.rrd")            # no waiting to do
    assert rc == 0 and "logged 3 messages" in out, (rc, out, err)


def test_topics_the_file_does_not_have_and_inputs_that_are_no_files(files, tmp_path):
    rc, out, err, _ = _bkabem("replay", files / "good.mcap", "--topics", "/nope", "--rerun-save", tmp_path / "a.rrd")
    assert rc == 2
    _one_line(err, "--topics", "/nope", "is not a topic", TOPIC)
    rc, out, err, _ = _bkabem("replay", tmp_path, "--info")
    assert rc == 2
    _one_line(err, "FILE", "is a directory")
    fifo = tmp_path / "fifo.mcap"
    os.mkfifo(fifo)
    rc, out, err, secs = _bkabem("replay", fifo, "--info", deadline=20)
    assert rc == 2 and secs < 10
    _one_line(err, "FILE", "is a FIFO")
    rc, out, err, _ = _bkabem("record", "--recover", fifo, tmp_path / "x.mcap", deadline=20)
    assert rc == 2
    _one_line(err, "--recover SRC", "is a FIFO")
