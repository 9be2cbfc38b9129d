"""Every file output gives the library's numbers for every defect kind of the fault library (the core commands'
table, JSON, CSV, JSON lines and figures: tests/unit/test_outputs.py).

- ``bkabem synth`` .npz: the samples are the library's :class:`Synthesizer` samples bit for bit, and their lines
  (a DFT at each line's exact frequency, Blackman-Harris window, written here) have the amplitudes of
  :meth:`BkaBem.spectrum`; the file names its arrays' axes and carries the fault multipliers.
- ``bkabem dataset`` Parquet: the lines of each run's samples against ``BkaBem`` of the run's case; its MCAP
  (``[output] mcap = true``, read with rosbags) holds the Parquet samples bit for bit.
- The node's spectrum messages in an MCAP (read with rosbags) and in Rerun (``bkabem replay --rerun-save``, read
  back with rerun's RrdReader): every line at its frequency with the library's amplitude.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from bkabem_core.model.vocabulary import DIRECTIONS

pytestmark = [pytest.mark.slow, pytest.mark.ros]

KINDS = ("outer", "inner", "ball", "healthy")
FS, SPEED_HZ, SECONDS = 51200.0, 25.0, 2.0
#: Lines compared: the largest, down to this fraction of the largest (the broadband floor of the fault library's
#: machine is ~1e-3 m/s^2 per 0.5-Hz bin), and below the synthesiser's Nyquist taper.
COMPARED = 0.05
TAPER = 0.85 * FS / 2


def _lines_of(x: np.ndarray, fs: float, freqs) -> np.ndarray:
    """Amplitude of the sinusoid at each exact frequency of ``freqs`` in ``x`` (4-term Blackman-Harris window,
    -92 dB side lobes: lines 10 Hz apart do not leak into each other over 2 s)."""
    n = x.size
    t = np.arange(n) / fs
    k = 2 * np.pi * np.arange(n) / n
    w = 0.35875 - 0.48829 * np.cos(k) + 0.14128 * np.cos(2 * k) - 0.01168 * np.cos(3 * k)
    xw = (x - x.mean()) * w
    return np.array([2 * abs(np.dot(xw, np.exp(-2j * np.pi * f * t))) / w.sum() for f in freqs])


def _compare_lines(x, fs, sp, location_index: int, direction: str, what: str) -> None:
    a = np.abs(sp.acceleration[:, location_index, DIRECTIONS.index(direction)])
    f = sp.frequency_hz
    order = np.argsort(f)
    gap = np.full(f.size, np.inf)                       # distance to the nearest other line [Hz]
    d = np.diff(f[order])
    gap[order[1:]] = np.minimum(gap[order[1:]], d)
    gap[order[:-1]] = np.minimum(gap[order[:-1]], d)
    isolated = gap > 8.0 / SECONDS                       # outside each other's main lobe (+-4 bins)
    pick = np.flatnonzero((a >= COMPARED * a[f < TAPER].max()) & (f < TAPER) & isolated)
    assert pick.size >= min(5, f.size // 3), (what, pick.size)   # the healthy machine: its 1x
    got = _lines_of(np.asarray(x, dtype=float), fs, f[pick])
    # the broadband floor of the fault library's machine adds ~0.01 m/s^2 per line at this resolution (random)
    np.testing.assert_allclose(got, a[pick], rtol=0.02, atol=0.02, err_msg=f"{what}: {[sp.labels[i] for i in pick]}")


def _de_vertical(model, names, **kw) -> np.ndarray:
    """The DE vertical acceleration of ``model`` as the library renders it (seed 0, 0.1-s chunks), with the
    synthesiser's keywords ``kw``. ``broadband_floor=False`` for the lines alone: the library's faulty bearing rolls
    15 dB rougher than a sound one (docs/faults.md), a floor of ~0.06 m/s^2 per line at this resolution, which would
    hide the lines' agreement (the floor itself: tests/unit/test_floor.py, tests/unit/test_roughness.py)."""
    from bkabem_core.synth.synthesizer import Synthesizer

    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=0, **kw)
    return np.concatenate([c.samples for c in s.render(f"constant:{SPEED_HZ}", SECONDS)], axis=1)[
        names.index("de_vertical_acceleration")]


@pytest.mark.parametrize("kind", KINDS)
def test_synth_npz_is_the_library(kind, fault_library, classic_ball, tmp_path):
    from bkabem_core.synth.synthesizer import Synthesizer
    from bkabem_ros.cli.main import main

    out = tmp_path / f"{kind}.npz"
    assert main(["synth", "--case", f"motor_6010_{kind}", "--profile", f"constant:{SPEED_HZ}", "--seconds",
                 str(SECONDS), "--rate", str(FS), "--out", str(out), "--no-progress"]) == 0
    z = np.load(out)
    meta = json.loads(str(z["metadata"]))
    model = fault_library[kind]
    lib = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=0)
    ref = np.concatenate([c.samples for c in lib.render(f"constant:{SPEED_HZ}", SECONDS)], axis=1)
    assert np.array_equal(z["samples"], ref)                                   # what the library gives, bit for bit
    names = meta["synthesizer"]["channels"] if "channels" in meta["synthesizer"] else list(meta["units"])
    x = z["samples"][names.index("de_vertical_acceleration")]
    if kind == "ball":
        # the library's ball wanders on and off the contact track (its strikes are intermittent), so its samples
        # carry less than the quasi-static model's lines; with the pit held on the track they are those lines
        xp = _de_vertical(classic_ball, names)
        sp = classic_ball.spectrum(SPEED_HZ)
        _compare_lines(_de_vertical(classic_ball, names, broadband_floor=False), FS, sp, 1, "vertical",
                       "ball (pit on the track) npz")
        big = np.argsort(np.abs(sp.acceleration[:, 1, DIRECTIONS.index("vertical")]))[-20:]
        assert _lines_of(np.asarray(x, float), FS, sp.frequency_hz[big]).sum() < 0.8 * _lines_of(
            np.asarray(xp, float), FS, sp.frequency_hz[big]).sum()
    elif kind == "healthy":
        _compare_lines(x, FS, model.spectrum(SPEED_HZ), 1, "vertical", f"{kind} npz")
    else:
        # a race pit's strikes vary in strength (synth/strikes.py): the library with every strike alike is the
        # quasi-static model's lines; with its strikes the file keeps their power, part of it off the lines
        xa = _de_vertical(model, names, strikes=False)
        sp = model.spectrum(SPEED_HZ)
        _compare_lines(_de_vertical(model, names, strikes=False, broadband_floor=False), FS, sp, 1, "vertical",
                       f"{kind} (strikes alike) npz")
        xf, xaf = np.asarray(x, float), np.asarray(xa, float)
        assert np.std(xf) == pytest.approx(np.std(xaf), rel=0.1)
        big = np.argsort(np.abs(sp.acceleration[:, 1, DIRECTIONS.index("vertical")]))[-20:]
        assert _lines_of(xf, FS, sp.frequency_hz[big]).sum() < _lines_of(xaf, FS, sp.frequency_hz[big]).sum()
    # every array's axes are named; the ISO velocity's labels are in the file too
    assert meta["axes"]["iso10816_velocity_rms_mm_s"][1:] == [["bearing", ["de", "nde"]],
                                                            ["direction", ["vertical", "horizontal", "overall"]]]
    assert list(z["iso10816_bearing"]) == ["de", "nde"] and z["iso10816_velocity_rms_mm_s"].shape[1:] == (2, 3)
    assert set(meta["axes"]) >= {k for k in z.files if k != "metadata"}
    assert meta["ground_truth"]["fault_multipliers"]["bpfo"] == pytest.approx(model.bpfo_per_hz)


def test_scenario_npz_ground_truth_has_the_fault_multipliers(tmp_path):
    from bkabem_ros.cli.main import main

    out = tmp_path / "rtf.npz"
    assert main(["synth", "--scenario", "de_outer_run_to_failure", "--time-scale", "3600", "--seconds", "0.3",
                 "--out", str(out), "--no-progress"]) == 0
    meta = json.loads(str(np.load(out)["metadata"]))
    fm = meta["ground_truth"]["fault_multipliers"]
    assert fm["bpfo"] == pytest.approx(6.0598, abs=1e-4) and set(fm) == {"ftf", "bpfo", "bpfi", "bsf"}
    assert all(s["fault_multipliers"] == fm for s in meta["states_ground_truth"])
    assert meta["axes"]["chunk_state_index"] == [["chunk", "one per chunk, first sample chunk_first_sample"]]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A data set of the four kinds at 25 Hz, 51.2 kHz, with an MCAP per run, rendered in this process."""
    from bkabem_core.dataset.engine import render_dataset
    from bkabem_core.dataset.spec import DatasetSpec
    from bkabem_ros.recording.dataset_sink import SINK

    tmp = tmp_path_factory.mktemp("kinds")
    spec = tmp / "spec.toml"
    spec.write_text(f'[dataset]\nname = "kinds"\nschema_version = 1\nsampling = "grid"\n\n[run]\n'
                    f'duration_s = {SECONDS}\nsample_rate_hz = {FS}\nspeed_hz = {SPEED_HZ}\n'
                    # the ball's pit on the track and every strike of a race pit alike: the quasi-static model's
                    # lines (the wander: test_balltrack.py; the strikes: test_strikes.py)
                    f'wander_revolutions = 0.0\nspin_slip = 0.0\nstrike_spread = 0.0\n\n'
                    f'[grid]\nfault = {list(KINDS)!r}\n\n[output]\nmcap = true\n'.replace("'", '"'))
    s = DatasetSpec.load(spec)
    render_dataset(s, tmp / "out", workers=1, sinks=(SINK,), log=lambda line: None)
    return s, tmp / "out"


def test_dataset_parquet_and_mcap_are_the_library(dataset):
    import pyarrow.parquet as pq
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from bkabem_core.dataset.render import _run_case, run_path
    from bkabem_core.solve.harmonic import BkaBem

    spec, out = dataset
    store = get_typestore(Stores.ROS2_KILTED)
    for run in spec.runs:
        table = pq.read_table(run_path(out, run))
        x = table.column("de_vertical_acceleration").to_numpy()
        model = BkaBem(_run_case(run))
        _compare_lines(x, FS, model.spectrum(SPEED_HZ), 1, "vertical", f"{run.params['fault']} parquet")
        mcap = run_path(out, run, ".mcap")
        with AnyReader([mcap], default_typestore=store) as reader:
            conns = [c for c in reader.connections if c.topic.endswith("/vibration/de/acceleration")]
            msgs = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
        rec = np.concatenate([np.frombuffer(bytes(m.data), np.float32).reshape(-1, m.samples_per_channel)[0]
                              for m in msgs])
        assert np.array_equal(rec, x), run.params["fault"]                 # the MCAP holds the Parquet samples


@pytest.fixture(scope="module")
def spectra_recording(tmp_path_factory, fault_library):
    """The node's spectrum messages of each kind at 25 Hz (its MachineSource), recorded into one MCAP."""
    from bkabem_ros.node.source import MachineSource
    from bkabem_ros.recording.mcap_io import McapSink

    tmp = tmp_path_factory.mktemp("spectra")
    path = tmp / "spectra.mcap"
    sink = McapSink(path, threaded=False)
    t0 = 1_700_000_000_000_000_000
    for i, kind in enumerate(KINDS):
        src = MachineSource(fault_library[kind].case, sample_rate_hz=FS, samples_per_chunk=5120, seed=0, slip=0.0,
                            machine_id=kind, frames={"de": "de", "nde": "nde"})
        src.next_chunk(0, SPEED_HZ)
        chunk, truth = src.next_chunk(5120, SPEED_HZ)
        stamp = t0 + i * 10**9
        for bearing, type_name, msg in src.spectrum_messages(chunk, stamp, truth):
            topic = f"/{kind}/vibration/" + (f"{bearing}/spectrum" if bearing else "fault_frequencies")
            sink(topic, type_name, msg, stamp)
    sink.close()
    assert sink.error is None
    return path


def test_node_spectra_in_mcap_are_the_library(spectra_recording, fault_library):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    got = {}
    with AnyReader([spectra_recording], default_typestore=get_typestore(Stores.ROS2_KILTED)) as reader:
        for conn, _, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic.endswith("/de/spectrum") and msg.quantity == "acceleration":
                got[conn.topic.split("/")[1]] = msg
    assert set(got) == set(KINDS)
    for kind, msg in got.items():
        sp = fault_library[kind].spectrum(SPEED_HZ)
        f = np.asarray(msg.frequency)
        amp = np.asarray(msg.amplitude).reshape(len(msg.channel_names), f.size)
        assert f[0] == 0.0                                                  # the static part first
        np.testing.assert_allclose(f[1:], sp.frequency_hz, rtol=1e-12)
        below = sp.frequency_hz < TAPER
        for c, direction in enumerate(msg.channel_names):
            want = np.abs(sp.acceleration[:, 1, DIRECTIONS.index(direction)])
            np.testing.assert_allclose(amp[c, 1:][below], want[below], rtol=1e-6, err_msg=kind)


def test_node_spectra_in_rerun_draw_every_line_at_its_frequency(spectra_recording, fault_library, tmp_path):
    from rerun.chunk import RrdReader

    from bkabem_ros.cli.main import main
    from bkabem_ros.viewer.rerun_io import LINE_DISPLAY_FLOOR

    for kind in KINDS:
        assert main(["replay", str(spectra_recording), "--rerun-save", str(tmp_path / f"{kind}.rrd"), "--topics",
                     f"/{kind}/vibration/de/spectrum", f"/{kind}/vibration/fault_frequencies", "--quiet"]) == 0
        bars = {}
        for ch in RrdReader(str(tmp_path / f"{kind}.rrd")).stream().collect().stream():
            if ch.entity_path.startswith("/de/spectrum/acceleration/") and "markers" not in ch.entity_path:
                rb = ch.to_record_batch()
                if "BarChart:values" in rb.schema.names:
                    bars[ch.entity_path.rsplit("/", 1)[-1]] = (
                        np.array(rb.column("BarChart:abscissa").to_pylist()[0][0]["buffer"]),
                        np.array(rb.column("BarChart:values").to_pylist()[0][0]["buffer"]),
                        np.array(rb.column("BarChart:widths").to_pylist()[0]))
        sp = fault_library[kind].spectrum(SPEED_HZ)
        a = np.abs(sp.acceleration[:, 1, :])
        shown = np.flatnonzero(a.max(axis=1) >= LINE_DISPLAY_FLOOR * a.max())
        n = int(shown[-1]) + 1                                               # up to the last line shown
        assert set(bars) == {"vertical", "horizontal"}, kind
        for direction, (absc, values, widths) in bars.items():
            np.testing.assert_allclose(absc, sp.frequency_hz[:n], rtol=1e-12, err_msg=kind)   # at its frequency
            below = sp.frequency_hz[:n] < TAPER
            np.testing.assert_allclose(values[below], a[:n, DIRECTIONS.index(direction)][below], rtol=1e-6)
            gaps = np.diff(np.sort(sp.frequency_hz[:n]))
            if gaps.size:                                                    # no bar covers most neighbours
                assert np.all(widths <= 0.7 * np.percentile(gaps[gaps > 0], 10) * (1 + 1e-6)), kind
