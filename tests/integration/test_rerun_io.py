"""bkabem_ros.viewer.rerun_io: .rrd files that pass ``rerun rrd verify``, hold the expected entities and
sample counts (read back with rerun.chunk.RrdReader), a blueprint, MCAP -> .rrd conversion without
ROS, and streaming to a viewer process bound to 127.0.0.1.
"""

from __future__ import annotations

import os
import tempfile

import pytest

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
from scenario_files import defect, scenario_toml  # noqa: E402

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import mcap_io  # noqa: E402
from bkabem_ros.viewer import blueprint as rerun_blueprint
from bkabem_ros.viewer import rerun_io
from bkabem_ros.viewer.screenshots import listening_addresses as _listening  # noqa: E402

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
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
    amp = np.stack([1.0 / (1 + k), 0.5 / (1 + k)]) * (1 + 0.01 * i)     # a changing speed: new lines
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


def _static(ents, path, column):
    """Values of a static component column (e.g. ``SeriesLines:names``) of ``path``."""
    return [v for rb in ents[path]["batches"] if column in rb.schema.names for v in rb.column(column).to_pylist()]


def _bars(ents, path):
    """[(abscissa, values)] of the bar charts logged at ``path``, in log order (chunks are in
    time order for these single-writer entities)."""
    out, absc = [], None
    for rb in ents[path]["batches"]:
        if "BarChart:values" not in rb.schema.names:
            continue
        ab = rb.column("BarChart:abscissa").to_pylist() if "BarChart:abscissa" in rb.schema.names else None
        for i, v in enumerate(rb.column("BarChart:values").to_pylist()):
            if ab is not None and ab[i] is not None:      # latest-at: logged only when it changes
                absc = np.array(ab[i][0]["buffer"])
            out.append((absc, np.array(v[0]["buffer"])))
    return out


def _check_entities(ents: dict[str, dict]) -> None:
    for loc in ("de", "nde"):
        for q in ("acceleration", "displacement"):
            e = ents[f"/{loc}/{q}"]
            assert e["rows"] == BLOCKS * N, (loc, q)        # every sample, none twice
            assert e["static"] == 1                         # SeriesLines with the units
            # peaks keep their height when zoomed out: min/max aggregation
            from rerun.components import AggregationPolicy
            assert _static(ents, f"/{loc}/{q}", "SeriesLines:aggregation_policy") == [[AggregationPolicy.MinMax.value]]
            for rb in e["batches"]:
                if rerun_io.SAMPLES_COMPONENT in rb.schema.names:   # one row per sample, one float32 per channel
                    assert str(rb.schema.field(rerun_io.SAMPLES_COMPONENT).type) == "list<item: float>"
                    assert {len(v) for v in rb.column(rerun_io.SAMPLES_COMPONENT).to_pylist()} == {2}
        assert ents[f"/{loc}/overview/acceleration"]["rows"] == BLOCKS
        assert ents[f"/{loc}/overview/acceleration/rms"]["rows"] == BLOCKS
        assert ents[f"/{loc}/trend/displacement"]["rows"] == BLOCKS
        for ch in ("vertical", "horizontal"):
            assert ents[f"/{loc}/spectrum/acceleration/{ch}"]["rows"] == 2
        assert f"/{loc}/acceleration/vertical" not in ents          # no entity per channel
    assert ents["/speed/shaft_hz"]["rows"] == BLOCKS
    assert ents["/fault_frequencies"]["rows"] == 2
    # the waveform's time axis: stamp + i / fs, relative to the first stamp, in ns
    t = np.concatenate([np.asarray(rb.column("sample_time").cast("int64").to_numpy())
                        for rb in ents["/de/acceleration"]["batches"] if "sample_time" in rb.schema.names])
    want = np.concatenate([(_stamp(i) - T0) + np.round(np.arange(N) * 1e9 / FS).astype(np.int64)
                           for i in range(BLOCKS)])
    np.testing.assert_array_equal(np.sort(t), want)
    assert _static(ents, "/de/acceleration", "SeriesLines:names") == [["DE vertical [m/s²]", "DE horizontal [m/s²]"]]
    assert _static(ents, "/nde/displacement", "SeriesLines:names") == [["NDE vertical [µm]", "NDE horizontal [µm]"]]
    assert _static(ents, "/speed/shaft_hz", "SeriesLines:names") == [["shaft speed [Hz]"]]
    # displacement in µm (the recording is SI: 1e-6 m amplitude -> 1 µm); acceleration as is
    x = np.concatenate([np.array(_column([rb], rerun_io.SAMPLES_COMPONENT)) for rb in ents["/de/displacement"]["batches"]
                        if rerun_io.SAMPLES_COMPONENT in rb.schema.names])
    np.testing.assert_allclose(np.abs(x).max(axis=0), [1.0, 0.5], rtol=1e-3)
    rms = np.array(_column(ents["/de/overview/acceleration/rms"]["batches"], "Scalars:scalars"))
    assert rms.shape == (BLOCKS, 2)
    np.testing.assert_allclose(rms[:, 0], 1 / math.sqrt(2), rtol=0.02)       # unit sine
    np.testing.assert_allclose(rms[:, 1], 0.5 / math.sqrt(2), rtol=0.02)
    mm = np.array(_column(ents["/de/overview/acceleration"]["batches"], "Scalars:scalars"))
    np.testing.assert_allclose(mm[:, 0], 1.0, rtol=1e-3)                      # vertical max
    np.testing.assert_allclose(mm[:, 1], -1.0, rtol=1e-3)                     # vertical min
    # a channel's max and min share one legend entry: 4 entries in the view, not 6 (the row's height holds ~5)
    assert _static(ents, "/de/overview/acceleration", "SeriesLines:names") == [
        ["vertical min/max [m/s²]"] * 2 + ["horizontal min/max [m/s²]"] * 2]
    pp = np.array(_column(ents["/nde/trend/displacement"]["batches"], "Scalars:scalars"))
    np.testing.assert_allclose(pp, [[1.0, 0.5]] * BLOCKS, rtol=1e-3)          # 0.5 µm sine: 1 µm p-p
    speed = [v[0] for v in _column(ents["/speed/shaft_hz"]["batches"], "Scalars:scalars")]
    np.testing.assert_allclose(speed, 25.0)
    # order spectrum bars: lines k >= 1 only (the static part is not drawn), around k * BPFO
    k = np.arange(1.0, 10.0)
    for ch, factor in (("vertical", 1.0), ("horizontal", 0.5)):
        absc, vals = _bars(ents, f"/de/spectrum/acceleration/{ch}")[0]
        np.testing.assert_allclose(vals, factor / (1 + k))
        assert np.all(np.abs(absc - k * BPFO) < 0.35 * BPFO)
    # markers: BPFO (the outer-race defect's line) at 1-3 x BPFO, not on every line; the other
    # lines at their fundamentals; below the zero line
    absc, vals = _bars(ents, "/de/spectrum/acceleration/markers/BPFO")[-1]     # after the fault message
    np.testing.assert_allclose(absc, [BPFO, 2 * BPFO, 3 * BPFO])
    assert np.all(vals < 0)
    for name, f0 in (("BPFI", 135.6), ("BSF", 58.9), ("2xBSF", 117.8), ("FTF", 9.9), ("1x", 25.0)):
        absc, vals = _bars(ents, f"/de/spectrum/acceleration/markers/{name}")[-1]
        np.testing.assert_allclose(absc, [f0])
    assert _column(ents["/fault_frequencies"]["batches"], "Scalars:scalars")[0] == pytest.approx(
        [25.0, 9.9, BPFO, 135.6, 58.9, 117.8])


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
    from rerun.blueprint.components import ContainerKind, PlayState
    from rerun.chunk import RrdReader

    from bkabem_ros.viewer.blueprint import view_names

    path = tmp_path / "bp.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", recording_id="t2", save_path=path)
    logger.log_waveform(_waveform(0, "de", "acceleration"))
    logger.close()
    reader = RrdReader(str(path))
    bps = reader.blueprints()
    assert len(bps) == 1
    containers, views, cols_by_path = {}, {}, {}
    for ch in reader.stream(store=bps[0]).collect().stream():
        rb = ch.to_record_batch()
        cols = {n: rb.column(n).to_pylist()[-1] for n in rb.schema.names if n != "log_time"}
        cols_by_path.setdefault(ch.entity_path, {}).update(cols)
    for p, cols in cols_by_path.items():
        if "ContainerBlueprint:container_kind" in cols:
            containers[p.lstrip("/")] = cols
        if "ViewBlueprint:display_name" in cols:
            views[cols["ViewBlueprint:display_name"][0]] = (p, cols)
    # every view of the layout, named with its unit
    assert set(views) == set(view_names())
    assert "DE displacement [µm]" in views and "NDE envelope spectrum [m/s²]" in views
    # no tab row holds more views than fit: every title in full in a bearing's column of the screenshots' window
    # (1920 px: 954 px per column), the last TAB_BAR_END_PX left to the viewer's icons (the viewer test looks)
    tab_kind = ContainerKind.Tabs.value
    by_path = {str(vp).strip("/"): n for n, (vp, _c) in views.items()}
    tab_rows = [[by_path[str(q).strip("/")] for q in d["ContainerBlueprint:contents"]]
                for d in containers.values() if d["ContainerBlueprint:container_kind"][0] == tab_kind]
    assert sorted(map(sorted, tab_rows)) == sorted(map(sorted, rerun_blueprint.tab_rows()))
    assert len(tab_rows) == 9                        # 4 per bearing, the machine's tabs
    for row in tab_rows:
        assert 2 <= len(row) <= rerun_blueprint.MAX_TABS, row
        assert rerun_blueprint.tab_row_width_px(row) <= 954 - rerun_blueprint.TAB_BAR_END_PX, row
    # the ground truth is the first tab of its row: in view as the recording opens
    assert any(row[0].endswith("ground truth: depth [µm]") for row in tab_rows)
    named = {d["ContainerBlueprint:display_name"][0]: p for p, d in containers.items()
             if d.get("ContainerBlueprint:display_name")}
    assert {"DE", "NDE"} <= set(named)
    side_by_side = [d for d in containers.values()
                    if d["ContainerBlueprint:container_kind"][0] == ContainerKind.Horizontal.value]
    assert any(d["ContainerBlueprint:contents"] == [named["DE"], named["NDE"]] for d in side_by_side)
    # opens following the latest data (not at t = 0, playing)
    assert cols_by_path["/time_panel"]["TimePanelBlueprint:play_state"] == [PlayState.Following.value]
    # waveforms: the last second before the cursor; trends: the whole run (no range set)
    ranges = {p.split("/")[2]: c["VisibleTimeRanges:ranges"][0]["range"] for p, c in cols_by_path.items()
              if "VisibleTimeRanges:ranges" in c}
    wave_ids = {views[n][0].split("/")[2] for loc in ("de", "nde")
                for _g, n, kind, _o in rerun_blueprint._views(loc, ("acceleration", "displacement")) if kind == "wave"}
    assert set(ranges) == wave_ids and len(wave_ids) == 4
    assert all(r == {"start": -1_000_000_000, "end": 0} for r in ranges.values())
    # bar charts have no legend (it would show entity paths); the marker key is in the health panel
    legends = {p.split("/")[2]: c.get("PlotLegend:visible") for p, c in cols_by_path.items() if "PlotLegend" in p}
    for n, (p, _c) in views.items():
        if "spectrum" in n:
            assert legends[p.split("/")[2]] == [False], n


def test_mcap_to_rrd_without_ros(tmp_path):
    """bkabem replay FILE --rerun-save OUT.rrd: no ROS graph, no rclpy node; same content as live."""
    mc = tmp_path / "run.mcap"
    with mcap_io.McapRecorder(mc) as rec:
        for topic, ty, m, stamp in _stream():
            rec.add(topic, ty, m, stamp, stamp)
    out = tmp_path / "run.rrd"
    env = dict(os.environ, ROS_DOMAIN_ID="0")
    code = ("import sys, rclpy; from bkabem_ros.cli.replay import standalone; rc = standalone(); "
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
    from bkabem_ros.recording import replay

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
    assert ents["/de/acceleration"]["rows"] == BLOCKS * N
    assert ents["/nde/displacement"]["rows"] == BLOCKS * N


def test_unchanged_spectrum_is_not_logged_again(tmp_path):
    """At a steady speed the node sends the same spectrum again: latest-at already shows it."""
    path = tmp_path / "same.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    m = _spectrum(0, "de")
    for i in range(4):
        m.header.stamp.sec += 1
        assert logger.log_spectrum(m)
    logger.close()
    assert _rows(path)["/de/spectrum/acceleration/vertical"]["rows"] == 1


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
    assert len(_bars(ents, "/de/spectrum/acceleration/markers/BPFO")) == 1     # markers only when they move


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


def test_each_plot_has_one_unit_and_the_health_panel_says_what_is_not_drawn(tmp_path):
    """No view mixes m/s², µm and mm/s (they were on one axis); the static displacement, left out
    of the spectrum, and the spectrum's BPFO and orders are stated in the health panel."""
    import re

    from bkabem_ros.viewer.blueprint import _views

    path = tmp_path / "units.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    for topic, ty, m, stamp in _stream():
        logger.log_message(topic, ty, m, stamp)
    k = np.arange(0, 10, dtype=float)
    amp = np.stack([np.r_[42e-6, 1e-6 / (1 + k[1:])], np.r_[3e-6, 0.5e-6 / (1 + k[1:])]])
    logger.log_spectrum(msgs.spectrum_message(
        k * BPFO, k, amp, np.zeros_like(amp), shaft_speed=2 * math.pi * 25.0, machine_id="m1", location="de",
        quantity="displacement", channel_names=["vertical", "horizontal"], stamp=_stamp(BLOCKS)))
    # one more condition window so that the health text includes the displacement spectrum
    for i in range(BLOCKS, BLOCKS + 11):
        for loc in ("de", "nde"):
            logger.log_waveform(_waveform(i, loc, "acceleration"))
    logger.close()
    ents = _rows(path)
    for loc in ("de", "nde"):
        for _group, name, kind, origin in _views(loc, ("acceleration", "displacement")):
            if kind not in ("wave", "trend"):
                continue
            units = set()
            for e in ents:
                if e == origin or e.startswith(origin + "/"):
                    for names in _static(ents, e, "SeriesLines:names"):
                        units |= {u for n in names for u in re.findall(r"\[([^\]]+)\]", n)}
            want = set(re.findall(r"\[([^\]]+)\]", name)) - {"-"}
            assert units == want, (name, units)
    absc, vals = _bars(ents, "/de/spectrum/displacement/vertical")[-1]
    assert absc.min() > 0.5 * BPFO                                  # no bar at 0 Hz
    np.testing.assert_allclose(vals, 1.0 / (1 + k[1:]))             # µm
    text = _column(ents["/de/health"]["batches"], "TextDocument:text")[-1][0]
    assert "static part (order 0, not drawn): vertical 42 µm, horizontal 3 µm" in text
    assert f"BPFO {BPFO:.2f} Hz, orders 1-9" in text
    assert "markers (below the zero line of the spectra): 1x 25.0 Hz grey" in text


TWO_DEFECTS = scenario_toml(
    "view_test", duration_s=10.0, size_step=0.5, labels={"purpose": "view"},
    defects=[defect("de_outer", "de", "outer", angle_deg=-90.0, time_s=[1.0, 5.0], length_m=[0.5e-3, 2.0e-3],
                    depth_m=[10e-6, 40e-6]),
             defect("nde_ball", "nde", "ball", ball=2, time_s=[3.0], length_m=[1.0e-3], depth_m=[20e-6])])


def test_health_panel_and_ground_truth_trend_follow_the_messages(tmp_path):
    """Fault-frequency messages of a scenario with two defects (DE outer race growing, a ball of the NDE bearing
    from 3 s), one per 0.5 s, then the machine healthy again (a new scenario switched on): the ground-truth trend
    of each bearing has one series per defect with the depth [µm] each message states (0 once it is gone), and
    each bearing's health panel names its own defects, the scenario state and the labels."""
    from bkabem_core.scenario.timeline import Scenario

    sc = Scenario.from_toml(TWO_DEFECTS, "view_test.toml")
    path = tmp_path / "truth.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    speed = 25.0
    sent = []
    n_msgs = 20
    for j in range(n_msgs + 2):
        t = 0.5 * j
        state = sc.state_at(t) if j < n_msgs else Scenario.of_case(sc.case).states[0]
        gt = (sc if j < n_msgs else Scenario.of_case(sc.case)).ground_truth(state, t, speed, 1.0)
        truth = msgs.ground_truth_message(gt, {"site": "lab"})
        first = gt["defects"][0] if gt["defects"] else None
        logger.log_fault_frequencies(msgs.fault_frequencies_message(
            shaft_speed=2 * math.pi * speed, ftf=9.9, bpfo=BPFO, bpfi=135.6, bsf=58.9, machine_id="m1",
            bearing_designation="6010", defect_bearing=first["bearing"] if first else "de",
            defect_race=first["race"] if first else "outer", defect_length=first["length_m"] if first else 0.0,
            defect_depth=first["depth_m"] if first else 0.0, defect_angle=0.0, stamp=_stamp(5 * j),
            ground_truth=truth))
        sent.append({d["name"]: d["depth_m"] * 1e6 for d in gt["defects"]})
        if j == n_msgs - 1:            # a condition window while the scenario runs: the health panels
            for i in range(5 * j, 5 * j + 11):
                for loc in ("de", "nde"):
                    logger.log_waveform(_waveform(i, loc, "acceleration"))
    logger.close()
    _verify(path)
    ents = _rows(path)
    # named as a diagnostics engineer reads them: bearing, place, quantity, unit (not the scenario's defect names)
    for loc, name, place, series in (("de", "de_outer", "outer_race", "DE outer race depth [µm]"),
                                     ("nde", "nde_ball", "ball_2", "NDE ball 2 depth [µm]")):
        p = f"/{loc}/trend/ground_truth/{place}_depth"
        vals = [v[0] for v in _column(ents[p]["batches"], "Scalars:scalars")]
        want = [s[name] for s in sent if name in s] + [0.0, 0.0]
        np.testing.assert_allclose(vals, want, rtol=1e-12)
        assert _static(ents, p, "SeriesLines:names") == [[series]]
    assert not any(e.startswith("/de/trend/ground_truth/nde") or e.startswith("/nde/trend/ground_truth/de")
                   for e in ents)
    # until a bearing has a defect its trend is a 0 line, named so (not an empty plot)
    for loc, t_first in (("de", 1.0), ("nde", 3.0)):
        p = f"/{loc}/trend/ground_truth/no_defect"
        vals = [v[0] for v in _column(ents[p]["batches"], "Scalars:scalars")]
        assert vals == [0.0] * round(t_first / 0.5), (loc, vals)
        assert _static(ents, p, "SeriesLines:names") == [["no defect in this bearing [µm]"]]
    # growth in steps: the depths of the states, not of the timeline
    de = [s["de_outer"] for s in sent if "de_outer" in s]
    assert len(set(de)) >= 3 and de == sorted(de)
    last_state = sc.state_at(0.5 * (n_msgs - 1))
    for loc, own, other in (("de", "outer-race defect, DE bearing 6010, 2.00 mm x 40 um at -90 deg", "ball 2"),
                            ("nde", "ball 2 defect, NDE bearing 6010, 1.00 mm x 20 um", "outer-race")):
        text = _column(ents[f"/{loc}/health"]["batches"], "TextDocument:text")[-1][0]
        L = loc.upper()
        assert f"**Ground truth, {L} bearing**: {own}" in text, text
        assert other not in text.split(f"**Ground truth, {L} bearing**")[1].split("\n")[0]
        assert other in text.split("**Elsewhere in the machine**")[1].split("\n")[0]
        assert "machine **faulty**: 2 defect(s)" in text
        assert f"scenario view_test: state {last_state.index} ({last_state.label}) since" in text
        assert "labels: purpose=view, site=lab" in text


def test_two_defects_at_one_place_get_two_named_trends(tmp_path):
    """Two outer-race dents in the DE bearing: the first is "DE outer race depth [µm]", the second adds its name (the
    names of a run stay as first seen); the old "<scenario name> (<kind>) depth" naming is gone."""
    from bkabem_core.scenario.timeline import Scenario

    sc = Scenario.from_toml(scenario_toml(
        "two_outer", duration_s=10.0,
        defects=[defect("spall_a", "de", "outer", angle_deg=-90.0, time_s=[1.0], length_m=[1e-3], depth_m=[10e-6]),
                 defect("spall_b", "de", "outer", angle_deg=90.0, time_s=[2.0], length_m=[1e-3], depth_m=[20e-6])]),
        "two_outer.toml")
    path = tmp_path / "two.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    for j, t in enumerate((0.5, 1.5, 2.5, 3.5)):
        gt = sc.ground_truth(sc.state_at(t), t, 25.0, 1.0)
        logger.log_fault_frequencies(msgs.fault_frequencies_message(
            shaft_speed=2 * math.pi * 25.0, ftf=9.9, bpfo=BPFO, bpfi=135.6, bsf=58.9, machine_id="m1",
            bearing_designation="6010", defect_bearing="de", defect_race="outer", defect_length=1e-3,
            defect_depth=10e-6, defect_angle=0.0, stamp=_stamp(5 * j), ground_truth=msgs.ground_truth_message(gt)))
    logger.close()
    ents = _rows(path)
    a, b = "/de/trend/ground_truth/outer_race_depth", "/de/trend/ground_truth/outer_race_spall_b_depth"
    assert _static(ents, a, "SeriesLines:names") == [["DE outer race depth [µm]"]]
    assert _static(ents, b, "SeriesLines:names") == [["DE outer race (spall_b) depth [µm]"]]
    assert [v[0] for v in _column(ents[a]["batches"], "Scalars:scalars")] == pytest.approx([10.0, 10.0, 10.0])
    assert [v[0] for v in _column(ents[b]["batches"], "Scalars:scalars")] == pytest.approx([20.0, 20.0])
    assert sorted(e for e in ents if "/trend/ground_truth/" in e) == sorted(
        [a, b, "/de/trend/ground_truth/no_defect", "/nde/trend/ground_truth/no_defect"])


def test_envelope_verdict_says_when_a_line_is_another_bearings_defect():
    """An envelope spectrum with BPFO and its harmonics standing out (and a weaker BPFI): on the NDE panel of a
    machine whose only defect is a DE outer-race dent, the verdict names the DE defect as the source, transmitted;
    on the DE panel it stays the bearing's own finding; with an NDE outer-race defect too, the NDE finding is its
    own and says the DE one adds to it; without ground truth it is the plain finding."""
    from bkabem_core.analysis import fault_lines, health

    fs, n = 8192.0, 8192
    f = np.fft.rfftfreq(n, 1 / fs)[: 1024]
    rng = np.random.default_rng(1)
    env = np.abs(rng.normal(1e-3, 2e-4, (2, f.size)))
    lines = {"1x": 25.0, "FTF": 9.9, "BPFO": 89.6, "BPFI": 135.6, "BSF": 58.9, "2xBSF": 117.8}
    for h, a in ((1, 0.05), (2, 0.03), (3, 0.02)):
        env[:, np.argmin(np.abs(f - h * 89.6))] = a
    env[:, np.argmin(np.abs(f - 135.6))] = 0.004
    de = fault_lines.Defect("outer", "de", 2e-3, 50e-6, -math.pi / 2, "6010", "defects[0]")
    nde = fault_lines.Defect("outer", "nde", 1e-3, 20e-6, 0.0, "6010", "defects[1]")
    names = ["vertical", "horizontal"]
    text = health.envelope_finding(f, env, lines, names, "nde", [de])
    assert text.startswith("BPFO 89.6 Hz: from the DE outer-race defect (transmitted), not a fault of the NDE "
                           "bearing; harmonics 1-3 at "), text
    assert "stands out" not in text
    assert health.envelope_finding(f, env, lines, names, "de", [de]).startswith("BPFO (89.6 Hz) stands out: ")
    both = health.envelope_finding(f, env, lines, names, "nde", [de, nde])
    assert both.startswith("BPFO (89.6 Hz) stands out: ") and both.endswith(
        "; the DE outer-race defect has it too (transmitted)"), both
    assert "transmitted" not in health.envelope_finding(f, env, lines, names)
    # a line of no defect, or one that does not stand out: no source is claimed
    ball = fault_lines.Defect("ball", "de", 1e-3, 20e-6, 0.0, "6010", "b", ball=2)
    assert "transmitted" not in health.envelope_finding(f, env, lines, names, "nde", [ball])
    quiet = np.abs(rng.normal(1e-3, 2e-4, (2, f.size)))
    assert "transmitted" not in health.envelope_finding(f, quiet, lines, names, "nde", [de])


def test_health_text_says_what_is_in_this_bearing_and_what_is_elsewhere():
    """A panel's ground-truth line names only its own bearing's defects; the other bearing's
    defects are on their own line, so an NDE panel never reads "no defect ... (outer-race
    defect, DE bearing ...)"."""
    from bkabem_core.analysis import fault_lines, health

    de = fault_lines.Defect("outer", "de", 4e-3, 100e-6, -math.pi / 2, "6010", "de_outer_spall")
    nde = fault_lines.Defect("ball", "nde", 1e-3, 20e-6, 0.0, "6010", "nde_ball", ball=2)
    faulty = fault_lines.Truth(available=True, defects=(de,), healthy=False)

    def panel(loc, defects, truth):
        return health.health_text(loc, {}, list(defects), {}, "ISO 10816-3 group 2, rigid", 1.0, truth)

    def para(text, head):
        """The paragraph after ``head`` ("" if there is none)."""
        return text.split(head, 1)[1].split("\n")[0] if head in text else ""

    de_text = "outer-race defect, DE bearing 6010, 4.00 mm x 100 um at -90 deg"
    text = panel("nde", [de], faulty)
    own = para(text, "**Ground truth, NDE bearing**: ")
    assert own == "no defect in this bearing", text
    assert para(text, "**Elsewhere in the machine**: ") == de_text
    assert "(" not in own and "DE" not in own
    # the faulty bearing: its own defect, nothing elsewhere
    text = panel("de", [de], faulty)
    assert para(text, "**Ground truth, DE bearing**: ") == de_text
    assert "Elsewhere" not in text
    # a defect in each bearing: each panel its own first, the other's on the elsewhere line
    both = fault_lines.Truth(available=True, defects=(de, nde), healthy=False)
    for loc, mine, theirs in (("de", de, nde), ("nde", nde, de)):
        text = panel(loc, [de, nde], both)
        assert para(text, f"**Ground truth, {loc.upper()} bearing**: ") == fault_lines.describe_defect(mine)
        assert para(text, "**Elsewhere in the machine**: ") == fault_lines.describe_defect(theirs)
    # a healthy machine: no defect, no elsewhere line; before any message: says so
    text = panel("nde", [], fault_lines.Truth(available=True))
    assert para(text, "**Ground truth, NDE bearing**: ") == "no defect in this bearing" and "Elsewhere" not in text
    assert para(panel("de", [], None), "**Ground truth, DE bearing**: ") == "no fault-frequency message yet"
