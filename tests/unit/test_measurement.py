"""The acquisition of a rig as its case's defaults (bkabem_core.synth.measurement) and the new elements of the chain
(bkabem_core.synth.sensors): a steep linear-phase anti-alias filter, the AC coupling, interference tones, the
converter's step, the sensor noise and the rate; through the synthesiser, ``bkabem synth`` and a data set.

Each element is checked on the samples with a textbook measure written here: a line's level in a Hann-windowed FFT
against the same line without the element (the filters' -3 dB points), a tone's amplitude in an FFT, the
quantisation step from the differences of the sample values, the noise from the RMS at standstill.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from scipy import signal

from bkabem_core.model.case import Case, CaseError
from bkabem_core.synth.measurement import Measurement
from bkabem_core.synth.sensors import AntiAliasFilter, HighPassFilter, InterferenceTones, Quantiser
from bkabem_core.synth.synthesizer import SynthError, Synthesizer

#: A rig's acquisition with the facts of the CWRU 12 kHz drive-end records (docs/synthesis.md): a magnet-mounted
#: accelerometer, a digital anti-alias filter at 5.46 kHz (-40 dB at 5.87 kHz), an AC coupling, the 4.1 kHz
#: interference and a 0.16 mg converter step.
RIG = {"sample_rate_hz": 12000.0, "mounting": "magnet", "anti_alias_hz": 5460.0, "anti_alias_order": 64,
       "anti_alias_phase": "linear", "high_pass_hz": 10.0, "high_pass_order": 2,
       "tone_frequencies_hz": [4025.0, 4144.0], "tone_amplitudes_m_s2": [0.2, 0.57],
       "quantisation_step_m_s2": 1.6e-3, "noise_density_m_s2_per_sqrt_hz": 4.6e-6}


def _case(section: dict | None = RIG, name: str = "motor_6010_outer") -> Case:
    raw = copy.deepcopy(Case.load(name).raw)
    if section is not None:
        raw["measurement"] = dict(section)
    return Case.from_dict(raw, "test rig")


@pytest.fixture(scope="module")
def rig(fault_library, cached_model):
    """The fault library's outer race with the rig's acquisition (the same machine: the FE reused)."""
    return cached_model(_case(), like=fault_library["outer"])


def _line(x: np.ndarray, fs: float, f_hz: float) -> float:
    """Amplitude [unit] of a line at ``f_hz`` on an FFT bin (Hann window, amplitude-corrected)."""
    w = np.hanning(x.size)
    spec = np.abs(np.fft.rfft((x - x.mean()) * w)) * 2.0 / w.sum()
    return float(spec[int(round(f_hz * x.size / fs))])


def _samples(synth, profile: str, seconds: float) -> np.ndarray:
    return np.concatenate([c.samples for c in synth.render(profile, seconds)], axis=1).astype(float)


# --------------------------------------------------------------------------- the elements
def test_linear_phase_anti_alias_is_the_butterworth_magnitude():
    aa = AntiAliasFilter(5460.0, 64, "linear")
    g = aa.gain(np.array([0.0, 5460.0, 5870.0, 6000.0]))
    assert np.all(g.imag == 0.0) and g[0] == 1.0
    assert 20 * np.log10(abs(g[1])) == pytest.approx(-3.0103, abs=1e-4)
    assert 20 * np.log10(abs(g[2])) == pytest.approx(-40.0, abs=1.5)        # the CWRU records: -40 dB at 5.87 kHz
    # the analog filter of the same order would need a transfer polynomial of degree 64: refused
    with pytest.raises(ValueError, match="order"):
        AntiAliasFilter(5460.0, 64)
    with pytest.raises(ValueError, match="phase"):
        AntiAliasFilter(5460.0, 4, "minimum")


def test_high_pass_is_an_analog_butterworth():
    hp = HighPassFilter(20.0, 2)
    _, h = signal.freqs(*signal.butter(2, 2 * np.pi * 20.0, "highpass", analog=True), worN=2 * np.pi * np.array(
        [5.0, 20.0, 200.0]))
    assert np.allclose(hp.gain([5.0, 20.0, 200.0]), h, rtol=1e-12)
    assert abs(hp.gain(20.0)) == pytest.approx(2 ** -0.5, rel=1e-12)
    assert abs(hp.gain(5.0)) == pytest.approx((5 / 20) ** 2, rel=0.01)       # 12 dB per octave below the corner


def test_filters_on_the_samples_at_their_minus_3_db_points(fault_library):
    """A line exactly at the anti-alias cut-off (BPFO order 36 at 5460 Hz) and the 1x line at the AC coupling's
    corner come out 3.01 dB down against the same run without them (lines below Nyquist: ``band_limit="error"``);
    the displacement (a DC-coupled probe) keeps its 1x."""
    model = fault_library["outer"]
    fs = 12000.0
    speed = 5460.0 / (36 * model.bpfo_per_hz)
    kw = dict(quantities=("acceleration", "displacement"), band_limit="error", max_order=36, broadband_floor=False,
              features=False, measurement=False)
    plain = Synthesizer(model, fs, 0.25, **kw)
    chain = Synthesizer(model, fs, 0.25, anti_alias=AntiAliasFilter(5460.0, 64, "linear"),
                        high_pass=HighPassFilter(speed, 1), **kw)
    a, b = _samples(plain, f"constant:{speed}", 2.0), _samples(chain, f"constant:{speed}", 2.0)
    db = 20 * np.log10(_line(b[0], fs, 5460.0) / _line(a[0], fs, 5460.0))
    assert db == pytest.approx(-3.01, abs=0.05)
    bpfo = model.bpfo_per_hz * speed
    for k in (20, 30, 35):                                  # the roll-off below the corner, line by line
        want = 1 / math.sqrt(1 + (k * bpfo / 5460.0) ** 128)
        assert _line(b[0], fs, k * bpfo) / _line(a[0], fs, k * bpfo) == pytest.approx(want, rel=0.01)
    # 1x: the 2-s record puts it on bin 2 * speed only approximately: read the nearest bin of both
    one_x = 20 * np.log10(_line(b[0], fs, speed) / _line(a[0], fs, speed))
    assert one_x == pytest.approx(-3.01, abs=0.3)
    disp = chain.channel_names.index("de_vertical_displacement")
    assert _line(b[disp], fs, speed) / _line(a[disp], fs, speed) == pytest.approx(abs(
        AntiAliasFilter(5460.0, 64, "linear").gain(speed)), rel=1e-3)


def test_tones_have_their_amplitude_and_do_not_follow_the_speed(rig):
    """The tones' amplitudes in an FFT (1-s records: 1 Hz bins), the same at standstill and at 25 Hz, on the
    acceleration channels only, and independent of the chunking."""
    tones = InterferenceTones((4025.0, 4144.0), (0.2, 0.57))
    kw = dict(quantities=("acceleration", "displacement"), tones=tones, quantisation=None, features=False,
              strikes=False, broadband_floor=False)   # the pit's random strikes and its rough bearing's floor would
                                                      # spread power under the tones' bins
    for speed in (0.0, 25.0):
        s = Synthesizer(rig, 12000.0, 0.1, **kw)
        x = _samples(s, f"constant:{speed}", 1.0)
        disp = s.channel_names.index("de_vertical_displacement")
        for f_hz, amp in zip(tones.frequencies_hz, tones.amplitudes_m_s2):
            assert _line(x[0], 12000.0, f_hz) == pytest.approx(amp, rel=0.02), (speed, f_hz)
            assert _line(x[disp], 12000.0, f_hz) < 1e-9 * amp                     # the probe picks up none
    a = _samples(Synthesizer(rig, 12000.0, 0.1, seed=3, **kw), "constant:25", 0.5)
    b = _samples(Synthesizer(rig, 12000.0, 0.037, seed=3, **kw), "constant:25", 0.5)
    assert np.array_equal(a, b)
    with pytest.raises(SynthError, match="tones"):
        Synthesizer(rig, 8000.0, tones=tones)                                 # 4144 Hz above Nyquist
    with pytest.raises(ValueError, match="amplitudes"):
        InterferenceTones((4025.0,), (0.2, 0.3))


def test_quantisation_step_from_the_sample_values(rig):
    q = 1.6e-3
    s = Synthesizer(rig, 12000.0, 0.1, quantities=("acceleration", "displacement"), seed=2)
    x = np.concatenate([c.samples for c in s.render("constant:25", 0.5)], axis=1)
    acc = x[0].astype(np.float64)
    ulp = float(np.spacing(np.float32(np.abs(acc).max())))                # float32 samples: exact to an ulp
    steps = np.diff(np.unique(acc))
    assert steps.min() == pytest.approx(q, abs=4 * ulp)
    assert np.max(np.abs(acc - q * np.rint(acc / q))) <= ulp
    disp = x[s.channel_names.index("de_vertical_displacement")].astype(np.float64)
    assert np.diff(np.unique(disp)).min() < 1e-3 * q                             # the probe is not quantised
    with pytest.raises(ValueError, match="step"):
        Quantiser(0.0)


def test_features_are_those_of_the_recorded_samples(rig):
    s = Synthesizer(rig, 12000.0, 0.1, quantities=("acceleration",), seed=2)
    for chunk in s.render("constant:25", 0.3):
        x = chunk.samples.astype(np.float64)
        d = x - x.mean(axis=1, keepdims=True)
        assert np.allclose(chunk.features["rms"], np.sqrt((d ** 2).mean(axis=1)), rtol=1e-5)
        assert np.allclose(chunk.features["peak"], np.abs(d).max(axis=1), rtol=1e-5)


def test_sensor_noise_of_the_case_at_standstill(fault_library, cached_model):
    """At standstill only the sensor noise is left: RMS = density x sqrt(fs / 2)."""
    m = cached_model(_case({"noise_density_m_s2_per_sqrt_hz": 1e-3}), like=fault_library["outer"])
    x = _samples(Synthesizer(m, 25600.0, 0.5, quantities=("acceleration",), seed=4), "constant:0", 2.0)
    assert x.std(axis=1) == pytest.approx(np.full(4, 1e-3 * math.sqrt(12800.0)), rel=0.02)


# --------------------------------------------------------------------------- the case's defaults
def test_the_case_section_is_the_synthesisers_default_and_each_argument_overrides_it(rig, fault_library):
    s = Synthesizer(rig)
    assert s.sample_rate_hz == 12000.0 and s.noise_density == {"acceleration": 4.6e-6}
    assert s.accelerometer.mounting == "magnet" and s.anti_alias == AntiAliasFilter(5460.0, 64, "linear")
    assert s.settings.sensors.get("high_pass") == HighPassFilter(10.0, 2)
    assert s.settings.output.get("quantisation") == Quantiser(1.6e-3)
    assert s.settings.taper_band[1:3] == (0.95, 0.975)          # the steep filter band-limits: the guard taper
    gt = s.ground_truth()
    assert gt["quantisation"] == {"step_m_s2": 1.6e-3} and gt["high_pass"]["cutoff_hz"] == 10.0
    assert gt["interference_tones"]["frequencies_hz"] == [4025.0, 4144.0]
    o = Synthesizer(rig, 25600.0, accelerometer=None, anti_alias=None, noise_density=None, quantisation=None)
    assert o.sample_rate_hz == 25600.0 and o.accelerometer is None and o.anti_alias is None
    assert o.noise_density is None and o.settings.output.get("quantisation") is None
    assert o.settings.output.get("interference_tones") is not None            # the rest stays the case's
    assert Synthesizer(rig, snr_db=30.0).noise_density is None                 # an SNR replaces the density
    ideal = Synthesizer(rig, measurement=False)
    assert ideal.sample_rate_hz == 25600.0 and not ideal.settings.sensors and not ideal.settings.output
    # a case without the section: what it was before
    plain, before = Synthesizer(fault_library["outer"]), Synthesizer(fault_library["outer"], 25600.0,
                                                                     noise_density=None, accelerometer=None,
                                                                     anti_alias=None, measurement=False)
    assert plain.settings == before.settings and plain.settings.taper_band == (0.8, 0.85, 0.95, 0.1)
    assert "quantisation" not in plain.ground_truth() and "high_pass" not in plain.ground_truth()


def test_measurement_section_is_checked():
    assert not Measurement.of_case(Case.load("motor_6010_outer"))
    for section, key, match in (
            ({"tone_frequencies_hz": [4000.0], "tone_amplitudes_m_s2": [0.1, 0.2]}, "tone_amplitudes_m_s2",
             "one amplitude per tone"),
            ({"tone_frequencies_hz": [4000.0]}, "tone_amplitudes_m_s2", "missing"),
            ({"anti_alias_hz": 5000.0, "anti_alias_order": 64}, "anti_alias_order", "analog"),
            ({"anti_alias_order": 4}, "anti_alias_order", "anti_alias_hz"),
            ({"sample_rate_hz": 12000.0, "anti_alias_hz": 6000.0}, "anti_alias_hz", "Nyquist"),
            ({"mounting": "glue"}, "mounting", "must be one of"),
            ({"mounting": "custom"}, "mounting_resonance_hz", "missing"),
            ({"high_pass_hz": 6000.0, "anti_alias_hz": 5000.0}, "high_pass_hz", "below"),
            ({"quantisation_step_m_s2": -1e-3}, "quantisation_step_m_s2", "> 0"),
            ({"noise": 1.0}, "noise", "unknown key"),
            ({"slip": 0.5}, "slip", "0.1")):
        with pytest.raises(CaseError, match=match) as exc:
            _case(section)
        assert exc.value.key == f"measurement.{key}", section
    assert Measurement.of_case(_case({"mounting": "custom", "mounting_resonance_hz": 3000.0})).accelerometer \
        .resonance_hz == 3000.0
    over = Case.load("motor_6010_outer").with_overrides({"measurement.quantisation_step_m_s2": 1e-3})
    assert Measurement.of_case(over).quantisation == Quantiser(1e-3)


def test_the_rigs_slip_is_the_default_of_synthesis_node_and_data_sets(tmp_path, monkeypatch, fault_library,
                                                                    cached_model):
    """A rig's ball-pass jitter (``[measurement] slip``) is the synthesiser's, ``bkabem synth``'s, a data set's and
    the node's default; an explicit value wins, ``--no-measurement`` / ``measurement=False`` leaves it out."""
    import bkabem_core.solve.harmonic as harmonic
    from bkabem_core.dataset.spec import DatasetSpec
    from bkabem_ros.cli.main import main

    jittery = cached_model(_case(dict(RIG, slip=0.002)), like=fault_library["outer"])
    assert Synthesizer(jittery).settings.slip == 0.002
    assert Synthesizer(jittery, slip=0.0).settings.slip == 0.0
    assert Synthesizer(jittery, measurement=False).settings.slip == 0.0
    assert Synthesizer(fault_library["outer"]).settings.slip == 0.0               # no section: no slip, as before
    assert Measurement.of_case(Case.load("cwru_rig")).slip == 0.001               # the rig's (docs/rigs.md)

    real = harmonic.BkaBem
    monkeypatch.setattr(harmonic, "BkaBem", lambda case, **kw: real(case, like=fault_library["outer"]))
    path = tmp_path / "jitter.toml"
    path.write_text(_toml(_case(dict(RIG, slip=0.002)).raw))
    for extra, want in (([], 0.002), (["--slip", "0.01"], 0.01), (["--no-measurement"], 0.0)):
        out = tmp_path / f"s{len(extra)}{want}.npz"
        assert main(["synth", "--case", str(path), "--profile", "constant:25", "--seconds", "0.2", "--out", str(out),
                     "--no-progress", *extra]) == 0
        with np.load(out) as z:
            assert json.loads(str(z["metadata"]))["synthesizer"]["slip_std_fraction"] == want, extra

    text = (f'[dataset]\nname = "jitter"\nschema_version = 1\nseed = 1\ncase = "{path}"\n[run]\n'
            'duration_s = 0.25\n[grid]\nspeed_hz = [25.0]\n')
    assert DatasetSpec.from_toml(text).runs[0].params["slip"] == 0.002
    assert DatasetSpec.from_toml(text.replace("[grid]", "slip = 0.0\n[grid]")).runs[0].params["slip"] == 0.0


# --------------------------------------------------------------------------- command line and data sets
def test_bkabem_synth_takes_the_case_acquisition(tmp_path, monkeypatch, fault_library, capsys):
    import bkabem_core.solve.harmonic as harmonic
    from bkabem_ros.cli.main import main

    real = harmonic.BkaBem
    monkeypatch.setattr(harmonic, "BkaBem", lambda case, **kw: real(case, like=fault_library["outer"]))
    path = tmp_path / "rig.toml"
    raw = _case().raw
    path.write_text(_toml(raw))
    out = tmp_path / "a.npz"
    assert main(["synth", "--case", str(path), "--profile", "constant:25", "--seconds", "0.5", "--out", str(out),
                 "--no-progress"]) == 0
    with np.load(out) as z:
        meta = json.loads(str(z["metadata"]))
        acc = z["samples"][0].astype(np.float64)
    assert meta["synthesizer"]["sample_rate_hz"] == 12000.0
    assert meta["ground_truth"]["quantisation"] == {"step_m_s2": 1.6e-3}
    assert np.max(np.abs(acc - 1.6e-3 * np.rint(acc / 1.6e-3))) <= np.spacing(np.float32(np.abs(acc).max()))
    out2 = tmp_path / "b.npz"
    assert main(["synth", "--case", str(path), "--profile", "constant:25", "--seconds", "0.5", "--out", str(out2),
                 "--rate", "24000", "--noise-acc", "0", "--no-measurement", "--no-progress"]) == 0
    with np.load(out2) as z:
        meta = json.loads(str(z["metadata"]))
    assert meta["synthesizer"]["sample_rate_hz"] == 24000.0
    assert meta["ground_truth"]["anti_alias"] is None and "quantisation" not in meta["ground_truth"]
    capsys.readouterr()
    assert main(["synth", "--case", str(path), "--profile", "constant:25", "--seconds", "0.5", "--out",
                 str(tmp_path / "c.npz"), "--rate", "8000", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--rate" in err[0] and "4144" in err[0]


def test_a_data_set_that_sets_fault_size_and_speed_gets_the_rig_acquisition(tmp_path):
    from bkabem_core.dataset.render import render_run
    from bkabem_core.dataset.spec import DatasetSpec

    path = tmp_path / "rig.toml"
    path.write_text(_toml(_case(name="motor_6010_healthy").raw))
    spec = DatasetSpec.from_toml(f"""
[dataset]
name = "rig"
schema_version = 1
seed = 1
case = "{path}"
[run]
duration_s = 0.25
[grid]
fault = ["outer"]
length_m = [1e-3]
speed_hz = [25.0]
""")
    run = spec.runs[0]
    p = run.params
    assert p["sample_rate_hz"] == 12000.0 and p["noise_acc"] == 4.6e-6
    assert p["accelerometer"] == "case" and p["anti_alias"] is None
    res = render_run(run, str(tmp_path / "out"))
    row = res["labels"][0]
    assert row["sample_rate_hz"] == 12000.0 and row["anti_alias"] and row["accelerometer"] == "case"
    explicit = DatasetSpec.from_toml(spec_text := f"""
[dataset]
name = "rig"
schema_version = 1
seed = 1
case = "{path}"
[run]
duration_s = 0.25
sample_rate_hz = 25600.0
accelerometer = "stud"
anti_alias = false
noise_acc = 0.0
[grid]
fault = ["outer"]
""")
    q = explicit.runs[0].params
    assert spec_text and q["sample_rate_hz"] == 25600.0 and q["accelerometer"] == "stud"
    assert q["anti_alias"] is False and q["noise_acc"] == 0.0


def _toml(raw: dict) -> str:
    """A case dict as TOML (tables, arrays of tables, numbers, strings, booleans, arrays of numbers)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []
    for sec, body in raw.items():
        if isinstance(body, list):
            for item in body:
                lines.append(f"[[{sec}]]")
                lines += [f"{k} = {value(v)}" for k, v in item.items()]
            if not body:
                lines.insert(0, f"{sec} = []")
            continue
        subs = {k: v for k, v in body.items() if isinstance(v, dict)}
        arrays = {k: v for k, v in body.items() if isinstance(v, list) and v and isinstance(v[0], dict)}
        lines.append(f"[{sec}]")
        lines += [f"{k} = {value(v)}" for k, v in body.items() if k not in subs and k not in arrays]
        for k, v in subs.items():
            lines.append(f"[{sec}.{k}]")
            lines += [f"{kk} = {value(vv)}" for kk, vv in v.items()]
        for k, items in arrays.items():
            for item in items:
                lines.append(f"[[{sec}.{k}]]")
                lines += [f"{kk} = {value(vv)}" for kk, vv in item.items()]
    return "\n".join(lines) + "\n"


def test_the_labels_of_a_rig_with_electrical_harmonics_write_to_parquet_and_csv(tmp_path):
    """A list-valued baseline key (``electrical_harmonics``, ``cwru_rig``) is one JSON string in a labels row, so
    labels.csv can be written (a list column has no CSV form) and parquet and CSV hold the same type."""
    import json

    import pyarrow as pa
    import pyarrow.csv as pacsv

    from bkabem_core.dataset.render import render_run
    from bkabem_core.dataset.spec import DatasetSpec

    spec = DatasetSpec.from_toml("""
[dataset]
name = "rig"
schema_version = 1
seed = 1
case = "cwru_rig"
[run]
fault = "healthy"
duration_s = 0.1
speed_hz = 29.9
""")
    row = render_run(spec.runs[0], str(tmp_path / "out"))["labels"][0]
    assert json.loads(row["baseline_electrical_harmonics"]) == [6.0]
    pacsv.write_csv(pa.Table.from_pylist([row]), tmp_path / "labels.csv")
    back = pacsv.read_csv(tmp_path / "labels.csv")
    assert json.loads(back.column("baseline_electrical_harmonic_forces_n")[0].as_py()) == [5.3]
