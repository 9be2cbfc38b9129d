"""The CWRU rig's twin (``cwru_rig``, docs/rigs.md) against what is public about the rig and against the measured
excerpts (tests/fixtures/cwru/, CWRU Bearing Data Center, https://engineering.case.edu/bearingdatacenter).

- Its bearings are CWRU's: the fault frequencies CWRU publishes for the 6205 (drive end) and the 6203 (fan end).
- Its healthy drive end, rendered as the bench renders a record's twin, is the healthy record's level and 1x.
- A seeded pit (a round pit of CWRU's size and depth, a data-set run parameter ``shape``) is read by a textbook
  envelope analysis (written in bench/realdata, not the product's) as the record of the same fault is; the
  coupling's turning load puts 1x in the envelope of an outer-race fault as it is in the rig's records.
- At each of the rig's documented speeds (0-3 hp) its race pits are named by that analysis.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))

from realdata.diagnostics import decimate, envelope_analysis, moments  # noqa: E402
from realdata.records import EFFECTIVE_6205  # noqa: E402

pytestmark = pytest.mark.slow                  # renders of the rig's twin held against its records

FIXTURE = ROOT / "tests" / "fixtures" / "cwru" / "excerpts.npz"
#: CWRU's published fault frequencies [multiples of the shaft speed] ("Bearing information" page of the Data Center)
CWRU_6205 = {"bpfi": 5.4152, "bpfo": 3.5848, "ftf": 0.39828, "bsf": 2.3570}
CWRU_6203 = {"bpfi": 4.9469, "bpfo": 3.0530, "ftf": 0.3817, "bsf": 1.9881}


@pytest.fixture(scope="module")
def excerpts():
    with np.load(FIXTURE) as d:
        prov = json.loads(str(d["provenance"]))
        return {k: (d[k].astype(np.float64), prov["records"][k]) for k in prov["records"]}


def _line(x: np.ndarray, fs: float, f: float) -> float:
    """Amplitude of the sinusoid at ``f`` [Hz] in ``x`` (Hann window, a DFT at the exact frequency)."""
    t = np.arange(x.size) / fs
    w = np.hanning(x.size)
    return 2.0 * abs(np.dot((x - x.mean()) * w, np.exp(-2j * np.pi * f * t))) / w.sum()


def test_the_rigs_bearings_have_cwrus_fault_frequencies(cached_model):
    from bkabem_core.model.case import Case

    model = cached_model(Case.load("cwru_rig"))
    for name, published in (("de", CWRU_6205), ("nde", CWRU_6203)):
        mult = model.bearing_multipliers[name]
        for k, v in published.items():
            # the kinematic frequencies at the loaded contact angle: within 1 % of CWRU's (which take 0 deg)
            assert abs(getattr(mult, k) / v - 1.0) < 0.01, (name, k, getattr(mult, k), v)


def test_healthy_twin_has_the_healthy_records_level_and_shaft_line(excerpts):
    from realdata.twin import Condition, synthesize

    x, meta = excerpts["1797_Normal"]
    speed = meta["speed_hz"]
    twin = synthesize(Condition("healthy"), "cwru_rig", 1, speed, 12000.0, 2.0)["DE"]
    measured = decimate(x, meta["sample_rate_hz"])
    rms_t, rms_m = np.std(twin), np.std(measured)
    assert 0.5 < rms_t / rms_m < 2.0, (rms_t, rms_m)
    k_t, k_m = moments(twin)["kurtosis"], moments(measured)["kurtosis"]
    assert abs(k_t - k_m) < 0.6, (k_t, k_m)                 # near-Gaussian (the tones take it below 3)
    one_t, one_m = _line(twin, 12000.0, speed), _line(measured, 12000.0, speed)
    assert 0.5 < one_t / one_m < 2.0, (one_t, one_m)        # the coupling's turning force at the drive end [g]


@pytest.mark.parametrize("name, kind", [("1797_ORat6_7_DE12", "outer"), ("1797_IR_7_DE12", "inner")])
def test_a_pit_reads_as_the_record_of_the_same_fault(excerpts, name, kind):
    from realdata.twin import Condition, synthesize

    x, meta = excerpts[name]
    speed = meta["speed_hz"]
    cond = Condition(kind, 7, 0, 6 if kind == "outer" else None)
    sig = synthesize(cond, "cwru_rig", 1, speed, 12000.0, 2.0)
    twin = envelope_analysis(sig["DE"], 12000.0, (2000.0, 4000.0), speed, sig["mult"])
    real = envelope_analysis(x, 12000.0, (2000.0, 4000.0), speed, EFFECTIVE_6205)
    assert twin["verdict"] == real["verdict"] == kind
    line = {"outer": "BPFO", "inner": "BPFI"}[kind]
    assert abs(twin["levels"][line] - real["levels"][line]) < 15.0, (twin["levels"], real["levels"])
    # the shaft-rate content of a real rig: 1x stands out of the envelope (the coupling's load turning in the
    # bearing, and for the inner race the pit turning through the load zone)
    assert twin["levels"]["1x"] > 15.0 and real["levels"]["1x"] > 15.0


def test_a_round_pit_is_a_data_set_run_parameter(tmp_path):
    from bkabem_core.dataset.spec import DatasetSpec, DatasetSpecError

    text = ('[dataset]\nname = "pits"\nschema_version = 1\ncase = "cwru_rig"\nsampling = "grid"\n\n[run]\n'
            'fault = "inner"\nlength_m = 5.3e-4\ndepth_m = 2.8e-4\nedge = "ball"\n\n[grid]\n'
            'shape = ["slot", "round_pit"]\n')
    spec = DatasetSpec.from_toml(text, "pits.toml")
    shapes = [r.case_raw["defects"][0].get("shape", "slot") for r in spec.runs]
    assert shapes == ["slot", "round_pit"] and [r.params["shape"] for r in spec.runs] == shapes
    healthy = DatasetSpec.from_toml(text.replace('"inner"', '"healthy"').replace('shape = ["slot", "round_pit"]',
                                                                               'speed_hz = [20.0]'), "h.toml")
    assert healthy.runs[0].params["shape"] is None                       # no defect: no shape to label
    with pytest.raises(DatasetSpecError) as exc:
        DatasetSpec.from_toml(text.replace('"round_pit"]', '"square"]'), "bad.toml")
    assert "grid.shape" in str(exc.value) and "square" in str(exc.value)
    with pytest.raises(DatasetSpecError) as exc:                         # a round pit's entry follows its contact
        DatasetSpec.from_toml(text.replace('edge = "ball"', 'edge = "cubic"'), "edge.toml")
    assert "edge" in str(exc.value)


@pytest.mark.parametrize("kind", ["outer", "inner"])
def test_every_documented_speed_reads_as_its_fault(kind):
    """At each of CWRU's loads (0-3 hp: 1797, 1772, 1750, 1730 rpm) a 7 mil pit of the twin is named by the
    textbook envelope analysis at the twin's own fault frequency, and its line stands well clear of the floor."""
    from realdata.twin import Condition, synthesize

    line = {"outer": "BPFO", "inner": "BPFI"}[kind]
    for load_hp, rpm in enumerate((1797, 1772, 1750, 1730)):
        speed = rpm / 60.0
        sig = synthesize(Condition(kind, 7, load_hp, 6 if kind == "outer" else None), "cwru_rig", 3, speed,
                         12000.0, 2.0)
        res = envelope_analysis(sig["DE"], 12000.0, (2000.0, 4000.0), speed, sig["mult"])
        assert sig["label"]["load_hp"] == load_hp and sig["label"]["speed_hz_mean"] == pytest.approx(speed)
        assert res["verdict"] == kind, (rpm, res["verdict"], res["levels"])
        assert res["levels"][line] > 20.0, (rpm, res["levels"])
