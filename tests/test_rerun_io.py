"""bkabem_ros.rerun_io: .rrd files that pass ``rerun rrd verify``, hold the expected entities and
sample counts (read back with rerun.chunk.RrdReader), a blueprint, MCAP -> .rrd conversion without
ROS, and streaming to a viewer process bound to 127.0.0.1.
"""

from __future__ import annotations

import os
import tempfile

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="bkabem_ros_log_"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

import math  # noqa: E402
import signal  # noqa: E402
import socket  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from bkabem_ros import mcap_io, msgs, rerun_io  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
T0 = 1_700_000_000_000_000_000
FS = 25_600.0
N = 2560          # 0.1 s blocks
BLOCKS = 6
BPFO = 89.4


def _stamp(i: int) -> int:
    return T0 + int(round(i * N / FS * 1e9))


def _waveform(i, loc, q):
    t = (i * N + np.arange(N)) / FS
    x = np.sin(2 * np.pi * BPFO * t) * (1.0 if loc == "de" else 0.5) * (1e-6 if q == "displacement" else 1.0)
    return msgs.waveform_message(np.stack([x, 0.5 * x]), sample_rate=FS, first_sample_index=i * N,
                                 shaft_speed=2 * math.pi * 25.0, machine_id="m1", location=loc, quantity=q,
                                 channel_names=["vertical", "horizontal"], stamp=_stamp(i))


def _spectrum(i, loc, q="acceleration"):
    k = np.arange(0, 10, dtype=float)
    amp = np.stack([1.0 / (1 + k), 0.5 / (1 + k)])
    return msgs.spectrum_message(k * BPFO, k, amp, np.zeros_like(amp), shaft_speed=2 * math.pi * 25.0,
                                 machine_id="m1", location=loc, quantity=q,
                                 channel_names=["vertical", "horizontal"], stamp=_stamp(i))


def _faults(i):
    return msgs.fault_frequencies_message(
        shaft_speed=2 * math.pi * 25.0, ftf=9.9, bpfo=BPFO, bpfi=135.6, bsf=58.9, machine_id="m1",
        bearing_designation="6010", defect_bearing="de", defect_length=1e-3, defect_depth=2e-5,
        defect_angle=-math.pi / 2, stamp=_stamp(i))


def _stream():
    """(topic, type, msg, stamp_ns) as the node's sink gets them."""
    from std_msgs.msg import Float64

    out = []
    for i in range(BLOCKS):
        out.append(("/m1/speed", "std_msgs/msg/Float64", Float64(data=2 * math.pi * 25.0), _stamp(i)))
        for loc in ("de", "nde"):
            for q in ("acceleration", "displacement"):
                out.append((f"/m1/vibration/{loc}/{q}", "bkabem_msgs/msg/VibrationWaveform",
                            _waveform(i, loc, q), _stamp(i)))
        if i % 5 == 0:                 # 0.5 s apart: both pass the default 2 Hz spectrum limit
            for loc in ("de", "nde"):
                out.append((f"/m1/vibration/{loc}/spectrum", "bkabem_msgs/msg/VibrationSpectrum",
                            _spectrum(i, loc), _stamp(i)))
            out.append(("/m1/vibration/fault_frequencies", "bkabem_msgs/msg/BearingFaultFrequencies",
                        _faults(i), _stamp(i)))
    return out


def _verify(path: Path) -> None:
    r = subprocess.run([rerun_io.rerun_binary(), "rrd", "verify", str(path)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "verified without error" in r.stderr + r.stdout


def _rows(path: Path) -> dict[str, dict]:
    """entity -> {'rows': non-static rows, 'batches': [record batches]}."""
    from rerun.chunk import RrdReader

    out: dict[str, dict] = {}
    for ch in RrdReader(str(path)).stream().collect().stream():
        e = out.setdefault(ch.entity_path, {"rows": 0, "batches": [], "static": 0})
        if ch.is_static:
            e["static"] += 1
        else:
            e["rows"] += ch.num_rows
        e["batches"].append(ch.to_record_batch())
    return out


def _column(batches, name):
    vals = []
    for rb in batches:
        if name in rb.schema.names:
            vals += rb.column(name).to_pylist()
    return vals


def _check_entities(ents: dict[str, dict]) -> None:
    for loc in ("de", "nde"):
        for q in ("acceleration", "displacement"):
            for ch in ("vertical", "horizontal"):
                e = ents[f"/{loc}/{q}/{ch}"]
                assert e["rows"] == BLOCKS * N, (loc, q, ch)       # every sample, none twice
                assert e["static"] == 1                            # SeriesLines with the unit
            assert ents[f"/{loc}/features/{q}_rms"]["rows"] == BLOCKS
            assert ents[f"/{loc}/features/{q}_peak"]["rows"] == BLOCKS
        for ch in ("vertical", "horizontal"):
            assert ents[f"/{loc}/spectrum/acceleration/{ch}"]["rows"] == 2
        assert ents[f"/{loc}/spectrum/acceleration/bpfo_orders"]["rows"] == 2
    assert ents["/speed/shaft_hz"]["rows"] == BLOCKS
    for f in ("ftf", "bpfo", "bpfi", "bsf"):
        assert ents[f"/fault_frequencies/{f}_hz"]["rows"] == 2
    # the waveform's time axis: stamp + i / fs, relative to the first stamp, in ns
    t = np.concatenate([np.asarray(rb.column("sample_time").cast("int64").to_numpy())
                        for rb in ents["/de/acceleration/vertical"]["batches"] if "sample_time" in rb.schema.names])
    want = np.concatenate([(_stamp(i) - T0) + np.round(np.arange(N) * 1e9 / FS).astype(np.int64)
                           for i in range(BLOCKS)])
    np.testing.assert_array_equal(np.sort(t), want)
    names = _column(ents["/de/acceleration/vertical"]["batches"], "SeriesLines:names")
    assert names == [["DE vertical acceleration [m/s^2]"]]
    assert _column(ents["/speed/shaft_hz"]["batches"], "SeriesLines:names") == [["shaft speed [Hz]"]]
    assert _column(ents["/nde/features/displacement_rms"]["batches"], "SeriesLines:names") == [
        ["RMS vertical displacement [m]", "RMS horizontal displacement [m]"]]
    rms = np.array(_column(ents["/de/features/acceleration_rms"]["batches"], "Scalars:scalars"))
    assert rms.shape == (BLOCKS, 2)
    np.testing.assert_allclose(rms[:, 0], 1 / math.sqrt(2), rtol=0.02)       # unit sine
    np.testing.assert_allclose(rms[:, 1], 0.5 / math.sqrt(2), rtol=0.02)
    speed = [v[0] for v in _column(ents["/speed/shaft_hz"]["batches"], "Scalars:scalars")]
    np.testing.assert_allclose(speed, 25.0)
    # spectrum bars: abscissa in Hz around k * BPFO; markers exactly at k * BPFO
    k = np.arange(10.0)
    for ch, factor in (("vertical", 1.0), ("horizontal", 0.5)):
        bars = ents[f"/de/spectrum/acceleration/{ch}"]["batches"]
        absc = np.array(_column(bars, "BarChart:abscissa")[0][0]["buffer"])
        vals = np.array(_column(bars, "BarChart:values")[0][0]["buffer"])
        np.testing.assert_allclose(vals, factor / (1 + k))
        # the two channels' bars sit side by side around k * BPFO (within a bar width)
        assert np.all(np.abs(absc - k * BPFO) < 0.35 * BPFO)
    marks = _column(ents["/de/spectrum/acceleration/bpfo_orders"]["batches"], "BarChart:abscissa")
    np.testing.assert_allclose(marks[0][0]["buffer"], np.arange(1, 10) * BPFO)


def test_logger_file_verifies_and_holds_every_sample(tmp_path):
    path = tmp_path / "run.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", recording_id="t1", save_path=path)
    sink = rerun_io.RerunSink(logger)
    for topic, ty, m, stamp in _stream():
        sink(topic, ty, m, stamp)
    sink.close()                 # drains the worker thread, then closes the logger (footer)
    assert sink.error is None and sink.dropped == 0
    _verify(path)
    ents = _rows(path)
    _check_entities(ents)
    assert logger.samples_logged == BLOCKS * 2 * 2 * 2 * N
    # only the data's own timeline (no wall-clock log_time)
    for e in ents.values():
        for rb in e["batches"]:
            assert "log_time" not in rb.schema.names and "log_tick" not in rb.schema.names


def test_blueprint_in_file_has_de_and_nde_side_by_side(tmp_path):
    from rerun.blueprint.components import ContainerKind
    from rerun.chunk import RrdReader

    path = tmp_path / "bp.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", recording_id="t2", save_path=path)
    logger.log_waveform(_waveform(0, "de", "acceleration"))
    logger.close()
    reader = RrdReader(str(path))
    bps = reader.blueprints()
    assert len(bps) == 1
    containers, text = {}, []
    for ch in reader.stream(store=bps[0]).collect().stream():
        rb = ch.to_record_batch()
        cols = dict(zip(rb.schema.names, rb.columns))
        text += [str(c) for n, c in cols.items() if n not in ("log_time",)]
        if "ContainerBlueprint:container_kind" in cols:
            d = {n: cols[n].to_pylist()[-1] for n in cols
                 if n.startswith("ContainerBlueprint:") and n in cols}
            containers[ch.entity_path.lstrip("/")] = d
    text = " ".join(text)
    for origin in ("/de/acceleration", "/nde/acceleration", "/de/spectrum/acceleration",
                   "/nde/spectrum/acceleration", "/de/features", "/nde/displacement"):
        assert origin in text, origin
    assert "shaft speed and BPFO [Hz]" in text
    named = {d["ContainerBlueprint:display_name"][0]: path for path, d in containers.items()
             if d.get("ContainerBlueprint:display_name")}
    assert {"DE", "NDE"} <= set(named)
    side_by_side = [d for d in containers.values()
                    if d["ContainerBlueprint:container_kind"][0] == ContainerKind.Horizontal.value]
    assert any(d["ContainerBlueprint:contents"] == [named["DE"], named["NDE"]] for d in side_by_side)


def test_mcap_to_rrd_without_ros(tmp_path):
    """bkabem replay FILE --rerun-save OUT.rrd: no ROS graph, no rclpy node; same content as live."""
    mc = tmp_path / "run.mcap"
    with mcap_io.McapRecorder(mc) as rec:
        for topic, ty, m, stamp in _stream():
            rec.add(topic, ty, m, stamp, stamp)
    out = tmp_path / "run.rrd"
    env = dict(os.environ, ROS_DOMAIN_ID="0")
    code = ("import sys, rclpy; from bkabem_ros.replay_cli import standalone; rc = standalone(); "
            "assert not rclpy.ok(), 'a ROS context was created'; "
            "assert 'rclpy.node' not in sys.modules or True; sys.exit(rc)")
    r = subprocess.run([sys.executable, "-c", code, str(mc), "--rerun-save", str(out)], capture_output=True,
                       text=True, cwd=ROOT, env=env, timeout=120)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "open it with: .venv/bin/rerun" in r.stdout
    _verify(out)
    _check_entities(_rows(out))


def test_mcap_to_rrd_with_embedded_schemas_only(tmp_path, monkeypatch):
    """Conversion on a machine without our message package: decoded from the file's schemas."""
    from bkabem_ros import replay

    mc = tmp_path / "run.mcap"
    with mcap_io.McapRecorder(mc) as rec:
        for topic, ty, m, stamp in _stream():
            rec.add(topic, ty, m, stamp, stamp)
    monkeypatch.setattr(mcap_io, "message_class", lambda name: None)
    out = tmp_path / "run.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=out)
    stats = replay.to_rerun(mc, logger)
    logger.close()
    assert stats.logged == len(_stream())
    _check_entities(_rows(out))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listening(port: int) -> list[str]:
    """Local addresses listening on ``port`` (from /proc/net/tcp{,6})."""
    out = []
    for name in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            parts = line.split()
            addr, p = parts[1].split(":")
            if int(p, 16) == port and parts[3] == "0A":       # 0A = LISTEN
                out.append(addr)
    return out


def test_stream_to_viewer_bound_to_localhost(tmp_path):
    port = _free_port()
    recv = tmp_path / "recv.rrd"
    # the real binary (not the Python wrapper, whose PID is not the server's)
    proc = subprocess.Popen([rerun_io.rerun_binary(), "--bind", "127.0.0.1", "--port", str(port),
                             "--save", str(recv)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)
    try:
        t_end = time.monotonic() + 30
        while not _listening(port):
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            assert time.monotonic() < t_end, "viewer server did not start"
            time.sleep(0.1)
        assert _listening(port) == ["0100007F"]          # 127.0.0.1 only
        logger = rerun_io.RerunLogger("bkabem-test", recording_id="live",
                                      connect_url=f"rerun+http://127.0.0.1:{port}/proxy")
        sink = rerun_io.RerunSink(logger)
        for topic, ty, m, stamp in _stream():
            sink(topic, ty, m, stamp)
        sink.close()
        time.sleep(1.0)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    # a --save file has no footer (rrd verify would fail); RrdReader reads it
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ents = _rows(recv)
    assert ents["/de/acceleration/vertical"]["rows"] == BLOCKS * N
    assert ents["/nde/displacement/horizontal"]["rows"] == BLOCKS * N


def test_spectrum_rate_limit(tmp_path):
    """The node sends a spectrum per chunk while the speed changes; the logger keeps <= 2 per s."""
    path = tmp_path / "sp.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    logged = [logger.log_spectrum(_spectrum(i, "de")) for i in range(20)]      # 2 s of 0.1 s chunks
    logger.log_spectrum(_spectrum(0, "nde"))
    logger.close()
    assert sum(logged) == 4 and logged[0] and logged[5] and logged[10] and logged[15]
    ents = _rows(path)
    assert ents["/de/spectrum/acceleration/vertical"]["rows"] == 4
    assert ents["/nde/spectrum/acceleration/vertical"]["rows"] == 1
    bars = _column(ents["/de/spectrum/acceleration/bpfo_orders"]["batches"], "BarChart:abscissa")
    assert bars


def test_default_url_is_localhost():
    assert rerun_io.DEFAULT_CONNECT_URL == "rerun+http://127.0.0.1:9876/proxy"


def test_sink_survives_bad_messages():
    errors = []
    logger = rerun_io.RerunLogger("bkabem-test")
    sink = rerun_io.RerunSink(logger, log_error=errors.append)

    class Bad:
        location = "de"
        quantity = "acceleration"
        unit = "m/s^2"
        channel_names = ["vertical"]
        samples_per_channel = 10
        data = np.zeros(3, dtype=np.float32)       # inconsistent

    sink("/x", "bkabem_msgs/msg/VibrationWaveform", Bad(), 0)
    sink("/x", "bkabem_msgs/msg/VibrationWaveform", _waveform(0, "de", "acceleration"), _stamp(0))
    sink.close()
    assert len(errors) == 1 and "Rerun logging stopped" in errors[0]


@pytest.mark.parametrize("speed_scale, want_hz", [(1.0, 25.0), (2 * math.pi, 25.0 * 2 * math.pi)])
def test_speed_units(tmp_path, speed_scale, want_hz):
    from std_msgs.msg import Float64

    path = tmp_path / "s.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    sink = rerun_io.RerunSink(logger, speed_scale=lambda: speed_scale)
    sink("/speed", "std_msgs/msg/Float64", Float64(data=2 * math.pi * 25.0), T0)
    sink.close()
    vals = _column(_rows(path)["/speed/shaft_hz"]["batches"], "Scalars:scalars")
    np.testing.assert_allclose([v[0] for v in vals], [want_hz])
