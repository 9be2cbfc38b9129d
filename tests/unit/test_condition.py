"""What the Rerun view computes from the acceleration (bkabem_core.analysis.condition, bkabem_core.analysis.fault_lines)
against textbook implementations written here (scipy filters + Hilbert transform, closed forms),
and what the logger writes from it: ISO velocity with zone limits, envelope spectrum with the
fault-frequency markers, health panels saying what the envelope shows next to the ground truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal as ss

from bkabem_core.analysis import condition, fault_lines
from bkabem_ros.messages import convert as msgs

FS = 25_600.0
BPFO = 87.3


def _impacts(seconds: float, bpfo: float = BPFO, fs: float = FS, f_res: float = 3000.0, seed: int = 0):
    """Outer-race dent as a diagnostician pictures it: an impact every 1/BPFO exciting a 3 kHz
    housing resonance (damping 3 %), plus a little sensor noise [m/s^2]."""
    rng = np.random.default_rng(seed)
    n = int(round(seconds * fs))
    t = np.arange(n) / fs
    x = np.zeros(n)
    tau = 1.0 / (0.03 * 2 * np.pi * f_res)
    ring = np.exp(-np.arange(int(8 * tau * fs)) / fs / tau) * np.sin(2 * np.pi * f_res * np.arange(int(8 * tau * fs)) / fs)
    for t_k in np.arange(0.0, seconds, 1.0 / bpfo):
        i = int(round(t_k * fs))
        m = min(ring.size, n - i)
        x[i:i + m] += 50.0 * ring[:m]
    return t, x + 0.2 * rng.standard_normal(n)


def _textbook_envelope(x, fs, band):
    """Butterworth band-pass (order 4, zero phase), Hilbert magnitude, mean removed, Hann,
    amplitude-corrected one-sided spectrum."""
    sos = ss.butter(4, band, btype="bandpass", fs=fs, output="sos")
    env = np.abs(ss.hilbert(ss.sosfiltfilt(sos, x)))
    env -= env.mean()
    w = np.hanning(env.size)
    return np.fft.rfftfreq(env.size, 1 / fs), np.abs(np.fft.rfft(env * w)) * 2 / w.sum()


def test_envelope_spectrum_matches_the_textbook():
    _t, x = _impacts(1.0)
    band = condition.default_envelope_band(FS)
    assert band == (1000.0, 10000.0)
    f, amp = condition.envelope_spectrum(x, FS, band, f_max=1000.0)
    fr, ref = _textbook_envelope(x, FS, band)
    assert f[1] - f[0] == pytest.approx(1.0)
    for h in (1, 2, 3):
        m = np.abs(f - h * BPFO) <= 2
        mr = np.abs(fr - h * BPFO) <= 2
        assert f[m][np.argmax(amp[0, m])] == pytest.approx(fr[mr][np.argmax(ref[mr])])
        assert amp[0, m].max() == pytest.approx(ref[mr].max(), rel=0.15)
    # the strongest envelope line is BPFO, far above the floor
    assert abs(f[np.argmax(amp[0])] - BPFO) <= 1.0
    assert amp[0].max() > 30 * np.median(amp[0])


def test_envelope_of_noise_has_no_line():
    rng = np.random.default_rng(3)
    f, amp = condition.envelope_spectrum(rng.standard_normal(int(FS)), FS, f_max=1000.0)
    assert amp[0].max() < 6 * np.median(amp[0, 1:])


def test_envelope_band_is_checked():
    with pytest.raises(ValueError, match="band_hz"):
        condition.envelope_spectrum(np.zeros(1000), 5120.0, (1000.0, 4000.0))


def test_iso_velocity_rms_closed_form():
    t = np.arange(int(FS)) / FS
    # 10 m/s^2 at 100 Hz: v = a / (2 pi f), RMS = peak / sqrt 2; 5 Hz and 2 kHz are outside 10-1000 Hz
    x = 10 * np.sin(2 * np.pi * 100 * t) + 3 * np.sin(2 * np.pi * 5 * t) + 40 * np.sin(2 * np.pi * 2000 * t)
    v = condition.iso_velocity_rms(np.stack([x, 0.5 * x]), FS)
    want = 10 / (2 * np.pi * 100) / math.sqrt(2) * 1e3
    np.testing.assert_allclose(v, [want, want / 2], rtol=1e-3)
    assert condition.iso_velocity_rms_mm_s(x, FS) == pytest.approx(want, rel=1e-3)


@pytest.mark.parametrize("v, zone", [(0.5, "A"), (1.39, "A"), (1.4, "B"), (2.9, "C"), (4.5, "D"), (20, "D")])
def test_iso_zone_boundaries(v, zone):
    assert condition.iso_zone(v, condition.ISO_ZONE_SETS["ISO 10816-3 group 2, rigid"]) == zone


def test_kurtosis_and_crest_factor():
    rng = np.random.default_rng(1)
    t = np.arange(100_000) / FS
    sine = np.sin(2 * np.pi * 50 * t)
    k = condition.kurtosis(np.stack([rng.standard_normal(t.size), sine]))
    np.testing.assert_allclose(k, [3.0, 1.5], rtol=0.03)
    assert condition.crest_factor(sine)[0] == pytest.approx(math.sqrt(2), rel=1e-3)
    _t, x = _impacts(1.0)
    assert condition.kurtosis(x)[0] > 6          # impacts are impulsive


def test_marker_plan_is_data_driven_for_several_defects():
    lines = {"1x": 25.0, "FTF": 9.9, "BPFO": 89.4, "BPFI": 135.6, "BSF": 58.9, "2xBSF": 117.8}
    defects = [fault_lines.Defect("outer", "de", depth_m=5e-5), fault_lines.Defect("inner", "nde", depth_m=3e-5),
               fault_lines.Defect("ball", "de", depth_m=2e-5)]
    # a defect of depth 0 (a scenario's defect before it appears) excites nothing: no harmonics for it
    plan0 = fault_lines.marker_plan(lines, [fault_lines.Defect("inner", "nde")], f_max=400.0)
    assert [m.label for m in plan0] == ["1x", "FTF", "BPFO", "BPFI", "BSF", "2xBSF"]
    plan = fault_lines.marker_plan(lines, defects, f_max=400.0)
    by = {}
    for m in plan:
        by.setdefault(m.line, []).append(m.harmonic)
    assert by == {"1x": [1], "FTF": [1], "BPFO": [1, 2, 3], "BPFI": [1, 2], "BSF": [1], "2xBSF": [1, 2, 3]}
    assert len({m.color for m in plan}) == 6
    assert [m.label for m in plan if m.line == "BPFO"] == ["BPFO", "2xBPFO", "3xBPFO"]
    # one defect, outer race: only BPFO gets harmonics; nothing at 0 Hz (standstill)
    plan = fault_lines.marker_plan(dict(lines, BPFI=0.0), defects[:1], f_max=1000.0)
    assert [m.label for m in plan] == ["1x", "FTF", "BPFO", "2xBPFO", "3xBPFO", "BSF", "2xBSF"]


def test_defects_from_message():
    m = msgs.fault_frequencies_message(
        shaft_speed=2 * math.pi * 25.0, ftf=9.9, bpfo=89.4, bpfi=135.6, bsf=58.9, machine_id="m1",
        bearing_designation="6010", defect_bearing="de", defect_length=2e-3, defect_depth=5e-5,
        defect_angle=-math.pi / 2)
    (d,) = fault_lines.defects_from_message(m)
    assert (d.kind, d.bearing, d.line) == ("outer", "de", "BPFO")
    assert fault_lines.describe_defect(d) == "outer-race defect, DE bearing 6010, 2.00 mm x 50 um at -90 deg"
    assert fault_lines.line_frequencies(m)["1x"] == pytest.approx(25.0)
    assert fault_lines.line_frequencies(m)["2xBSF"] == pytest.approx(117.8)


# --------------------------------------------------------------------------- through the logger
def _run_logger(tmp_path, seconds=2.0):
    """DE: impacts at BPFO; NDE: 100 Hz sine + noise (healthy). 0.1 s blocks, fault message first."""
    from bkabem_ros.viewer import rerun_io

    path = tmp_path / "cond.rrd"
    logger = rerun_io.RerunLogger("bkabem-test", save_path=path)
    t0 = 1_700_000_000_000_000_000
    speed = 2 * math.pi * 25.0
    logger.log_fault_frequencies(msgs.fault_frequencies_message(
        shaft_speed=speed, ftf=9.9, bpfo=BPFO, bpfi=135.6, bsf=58.9, machine_id="m1",
        bearing_designation="6010", defect_bearing="de", defect_length=2e-3, defect_depth=5e-5,
        defect_angle=-math.pi / 2, stamp=t0))
    t, de = _impacts(seconds)
    rng = np.random.default_rng(5)
    nde = 10 * np.sin(2 * np.pi * 100 * t) + 0.5 * rng.standard_normal(t.size)
    n = int(FS * 0.1)
    for i in range(int(seconds / 0.1)):
        for loc, x in (("de", de), ("nde", nde)):
            blk = x[i * n:(i + 1) * n]
            logger.log_waveform(msgs.waveform_message(
                np.stack([blk, 0.5 * blk]), sample_rate=FS, first_sample_index=i * n, shaft_speed=speed,
                machine_id="m1", location=loc, quantity="acceleration", channel_names=["vertical", "horizontal"],
                stamp=t0 + int(round(i * n / FS * 1e9))))
    logger.close()
    from rerun.chunk import RrdReader

    out = {}
    for ch in RrdReader(str(path)).stream().collect().stream():
        out.setdefault(ch.entity_path, []).append(ch.to_record_batch())
    return out, nde


def _latest_bars(batches):
    """(abscissa, values) of the last bar chart, latest-at: the abscissa is only logged when it
    changes."""
    absc = vals = None
    for rb in batches:
        if "BarChart:values" not in rb.schema.names:
            continue
        ab = rb.column("BarChart:abscissa").to_pylist() if "BarChart:abscissa" in rb.schema.names else None
        for i, v in enumerate(rb.column("BarChart:values").to_pylist()):
            vals = np.array(v[0]["buffer"])
            if ab is not None and ab[i] is not None:
                absc = np.array(ab[i][0]["buffer"])
    return absc, vals


def _col(batches, name):
    return [v for rb in batches if name in rb.schema.names for v in rb.column(name).to_pylist()]


def test_logger_condition_views(tmp_path):
    ents, nde = _run_logger(tmp_path)
    # ISO velocity per 1-s window with the zone limits; NDE: 10 m/s^2 at 100 Hz
    iso = np.array(_col(ents["/nde/iso_velocity"], "Scalars:scalars"))
    assert iso.shape == (2, 2)
    want = 10 / (2 * np.pi * 100) / math.sqrt(2) * 1e3
    np.testing.assert_allclose(iso[:, 0], want, rtol=0.02)
    np.testing.assert_allclose(iso[:, 1], want / 2, rtol=0.02)
    assert _col(ents["/de/iso_velocity/zones"], "Scalars:scalars")[0] == [1.4, 2.8, 4.5]
    # the window's value sits at its last sample (t = 1 s - 1 sample, 2 s - 1 sample)
    t = sorted(int(v) for rb in ents["/de/iso_velocity"] if "sample_time" in rb.schema.names
               for v in rb.column("sample_time").cast("int64").to_pylist())
    np.testing.assert_allclose(t, [1e9 - 1e9 / FS, 2e9 - 1e9 / FS], atol=1)
    # envelope spectrum: its highest bar at BPFO; BPFO markers at 1-3 x BPFO below zero
    absc, vals = _latest_bars(ents["/de/envelope/vertical"])
    assert abs(absc[np.argmax(vals)] - BPFO) <= 3.0
    marks = [np.array(a[0]["buffer"]) for rb in ents["/de/envelope/markers/BPFO"]
             for a in rb.column("BarChart:abscissa").to_pylist()]
    np.testing.assert_allclose(marks[-1], [BPFO, 2 * BPFO, 3 * BPFO])
    # health: the envelope finding next to the ground truth
    de_text = _col(ents["/de/health"], "TextDocument:text")[-1][0]
    nde_text = _col(ents["/nde/health"], "TextDocument:text")[-1][0]
    assert f"BPFO ({BPFO:.1f} Hz) stands out" in de_text
    assert "outer-race defect, DE bearing 6010, 2.00 mm x 50 um at -90 deg" in de_text
    assert "does not stand out" in nde_text and "no defect in this bearing" in nde_text
    zone = condition.iso_zone(want, condition.ISO_ZONE_SETS[condition.DEFAULT_ISO_ZONES])
    assert f"NDE bearing: ISO zone {zone}" in nde_text
    kurt = np.array(_col(ents["/de/trend/impulsiveness"], "Scalars:scalars"))
    assert kurt.shape == (2, 4) and np.all(kurt[:, 0] > 6)
