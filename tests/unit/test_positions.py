"""A bearing of its own at each position (case schema 4): each position's bearing from the catalogue with its own
overrides and clearance, through the excitation, the lines, the spectrum, the ground truth, the messages, the
viewer's lines and the data-set labels; a schema-3 case (one [bearing] for both) keeps its numbers; bad input is
one line naming the key.

The machine with two different bearings is the embedded 6010 machine with the CWRU rig's types at its positions:
a 6205 at the drive end and a 6203 at the non-drive end (geometry and clearance from the catalogue), an outer-race
dent in each."""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import numpy as np
import pytest
from case_files import embedded_text, textbook_multipliers, two_bearing_text

from bkabem_core.excitation.lines import LineSet
from bkabem_core.model.case import Case, CaseError
from bkabem_core.model.catalogue import lookup
from bkabem_core.solve.harmonic import BkaBem

FIXTURES = Path(__file__).parents[1] / "fixtures"
#: CWRU's published fault multipliers (bearing information page): drive end 6205, fan end 6203
CWRU = {"de": {"bpfi": 5.4152, "bpfo": 3.5848, "ftf": 0.39828, "bsf": 2.3567},
        "nde": {"bpfi": 4.9469, "bpfo": 3.0530, "ftf": 0.3817, "bsf": 1.9937}}
#: ISO 5753-1 radial internal clearance, normal group (CN) [um]: bores over 24 up to 30 mm and over 10 up to 18 mm
CN_UM = {"de": (5.0, 20.0), "nde": (3.0, 18.0)}


def _text() -> str:
    return embedded_text()


def _sub(text: str, pattern: str, repl: str, count: int = 1) -> str:
    out, n = re.subn(pattern, repl, text, count=count, flags=re.M)
    assert n == count, pattern
    return out


_textbook = textbook_multipliers


@pytest.fixture(scope="module")
def two() -> Case:
    return Case.from_toml(two_bearing_text(), "two.toml")


@pytest.fixture(scope="module")
def two_model(two, cached_model) -> BkaBem:
    return cached_model(two)


# --------------------------------------------------------------------------- the case
def test_each_position_takes_its_catalogue_bearing(two):
    """Geometry from the catalogue row of each position's designation, clearance the middle of the CN range of its
    bore, fault multipliers those CWRU publishes for the rig's two bearings (within 0.25 %: the catalogue's 6205 is
    GMN's, pitch 39.1 mm against SKF's 39.04 mm; docs/catalogue.md)."""
    for b, des in (("de", "6205"), ("nde", "6203")):
        g, row = two.bearing_geometry(b), lookup(des)
        assert (g.designation, g.n_balls, g.ball_diameter_m, g.pitch_diameter_m) == \
            (des, row.n_balls, row.ball_diameter_m, row.pitch_diameter_m)
        lo, hi = CN_UM[b]
        assert g.diametral_clearance_m == pytest.approx(0.5 * (lo + hi) * 1e-6, rel=1e-12)
        fm = two.fault_multipliers(b)
        for name, want in CWRU[b].items():
            assert getattr(fm, name) == pytest.approx(want, rel=2.5e-3), (b, name)    # GMN's 6205 pitch
        prov = two.bearing_provenance(b)
        assert prov["catalogue_key"] == des and prov["geometry_status"] == "published"
        assert prov["clearance_class"] == "CN" and "middle of" in prov["clearance"]
    assert not two.same_bearings and two.bearing_damping_n_s_m("nde") == 550.0


def test_a_schema_3_file_loads_to_the_same_numbers(cached_model):
    """The v3 file of the embedded machine (one [bearing] for both positions) migrates to both positions with every
    key: the same bearings, the same identity, and the same lines and spectra, bit for bit."""
    old, new = Case.load(FIXTURES / "electric_motor_6010_v3.toml"), Case.load()
    assert "bearing" not in old.raw and old.raw["case"]["schema_version"] == 4
    for b in ("de", "nde"):
        assert old.bearing_geometry(b) == new.bearing_geometry(b)
        assert old.bearing_damping_n_s_m(b) == new.bearing_damping_n_s_m(b)
    assert old.case_hash == new.case_hash
    a, b = cached_model(old), cached_model(new)
    assert a.phases.shared and not a.lines.coefficients[:, 3:5].any()
    for name in ("coefficients", "amplitude", "dc", "multipliers"):
        assert np.array_equal(getattr(a.lines, name), getattr(b.lines, name)), name
    for f in (12.0, 47.5):
        assert np.array_equal(a.spectrum(f).displacement, b.spectrum(f).displacement)


def test_a_schema_3_plausibility_bound_follows_the_bearing_keys():
    text = (FIXTURES / "electric_motor_6010_v3.toml").read_text() + \
        '\n[plausibility]\n"bearing.n_balls" = [3, 10]\n'
    with pytest.raises(CaseError) as info:
        Case.from_toml(text, "v3.toml")
    assert info.value.key == "bearings.de.n_balls" and "overridden" in str(info.value)


def _second(text: str, old: str, new: str) -> str:
    """``text`` with the second occurrence of ``old`` (the NDE table's) replaced."""
    i = text.index(old, text.index(old) + 1)
    return text[:i] + new + text[i + len(old):]


def _without_nde_table(text: str) -> str:
    start = text.index("[bearings.nde]")
    return text[:start] + text[text.index("[[housings]]"):]


def _bearing_of_its_own(text: str) -> str:
    """A DE bearing the catalogue does not have, with every geometry key given."""
    return _sub(text, r'^designation = "6010"', 'designation = "ACME 42"\nbore_diameter_m = 0.05\n'
                'outer_diameter_m = 0.08\npitch_diameter_m = 0.065\nn_balls = 13\ncontact_angle_deg = 0.0\n'
                'static_load_rating_n = 15000.0')


@pytest.mark.parametrize("edit, key, reason", [
    (lambda t: _sub(t, r'^designation = "6010"', 'designation = "6299"'), "bearings.de.designation",
     "unknown designation '6299'"),
    (lambda t: _second(t, 'designation = "6010"', 'designation = "ACME 42"'), "bearings.nde.designation",
     "needs bore_diameter_m, outer_diameter_m, pitch_diameter_m, n_balls, contact_angle_deg, static_load_rating_n"),
    (lambda t: _sub(t, r'^diametral_clearance_m = .*', 'clearance_class = "C7"'), "bearings.de.clearance_class",
     "must be one of"),
    (lambda t: _sub(t, r'^diametral_clearance_m = .*', 'clearance_class = "C4"\nbore_diameter_m = 5.0e-3'),
     "bearings.de.clearance_class", "no ISO 5753-1 value for a bore of 5 mm"),
    (lambda t: _sub(t, r'^diametral_clearance_m = .*', 'diametral_clearance_m = 0.059e-3\nclearance_class = "C3"'),
     "bearings.de.diametral_clearance_m", "not both"),
    (lambda t: _sub(_sub(t, r'^designation = "6010"', 'designation = "6010/C3"'), r'^diametral_clearance_m = .*',
                    'clearance_class = "C4"'), "bearings.de.clearance_class", "contradicts"),
    (lambda t: _sub(_sub(t, r'^designation = "6010"', 'designation = "NICE (MFPT)"'), r'^ball_diameter_m = .*\n',
                    ""), "bearings.de.bore_diameter_m", "the catalogue has no value"),
    (_without_nde_table, "bearings.nde", "missing"),
    (lambda t: _sub(t, r'^damping_n_s_m = .*\n', ""), "bearings.de.damping_n_s_m", "missing"),
])
def test_bad_position_tables_are_one_line_naming_the_key(tmp_path, edit, key, reason):
    p = tmp_path / "bad.toml"
    p.write_text(edit(_text()))
    with pytest.raises(CaseError) as info:
        Case.load(p)
    assert info.value.key == key, str(info.value)
    assert reason in str(info.value) and str(p) in str(info.value) and "\n" not in str(info.value)


def test_a_bearing_the_catalogue_does_not_have_with_every_number_given():
    c = Case.from_toml(_bearing_of_its_own(_text()), "own.toml")
    g = c.bearing_geometry("de")
    assert (g.designation, g.n_balls, g.pitch_diameter_m) == ("ACME 42", 13, 0.065)
    assert c.bearing_provenance("de")["geometry_status"] == "case"
    assert c.bearing_geometry("nde").n_balls == 14


def test_overrides_address_each_position(two):
    c = two.with_overrides({"bearings.nde.n_balls": 7})                    # a key the table leaves to the catalogue
    assert (c.bearing_geometry("nde").n_balls, c.bearing_geometry("de").n_balls) == (7, 9)
    assert c.bearing_provenance("nde")["overridden"] == ["n_balls"]
    c = two.with_overrides({"bearings.nde.designation": "6205"})
    assert c.bearing_geometry("nde") == two.bearing_geometry("de") and c.same_bearings
    c = two.with_overrides({"bearing.diametral_clearance_m": 20e-6})        # schema 3's shared key: both positions
    assert c.bearing_geometry("de").diametral_clearance_m == c.bearing_geometry("nde").diametral_clearance_m == 20e-6
    for bad in ("bearings.de.colour", "bearings.middle.n_balls"):
        with pytest.raises(CaseError, match="unknown key"):
            two.with_overrides({bad: 1})
    with pytest.raises(ValueError, match="bearing position"):
        two.bearing_geometry("middle")


def test_plausibility_bounds_apply_to_each_positions_own_values(two):
    """The bounds check the values the model uses (the catalogue's included), and a position's axial load is
    measured against its own bearing's static load rating."""
    raw = copy.deepcopy(Case.load().raw)
    raw["plausibility"] = {"bearings.*.n_balls": [3, 10]}
    with pytest.raises(CaseError) as info:                                 # 14 balls of the catalogue's 6010
        Case.from_dict(raw)
    assert info.value.key == "bearings.de.n_balls"
    raw = copy.deepcopy(two.raw)
    raw["plausibility"] = {"bearings.*.n_balls": [3, 10]}
    Case.from_dict(raw)                                                     # 9 and 8 balls
    for pos, fine in (("de", True), ("nde", False)):                       # C0: 7.8 kN (6205), 4.75 kN (6203)
        raw = copy.deepcopy(two.raw)
        raw["bearings"][pos]["axial_load_n"] = 5000.0
        if fine:
            Case.from_dict(raw)
        else:
            with pytest.raises(CaseError) as info:
                Case.from_dict(raw)
            assert info.value.key == "bearings.nde.axial_load_n" and "4750" in str(info.value)


# --------------------------------------------------------------------------- the model
def test_each_bearing_is_linearised_and_excited_as_its_own(two, two_model):
    from bkabem_core.bearing.deep_groove import Bearing

    m = two_model.machine
    for b in ("de", "nde"):
        site, g = m.sites[b], two.bearing_geometry(b)
        assert site.bearing.geometry == g
        lin = Bearing(g).linearise(*site.radial_load_n, axial_load_n=two.axial_load_n(b),
                                   damping_n_s_m=two.bearing_damping_n_s_m(b), average_over_pitch=True)
        assert site.stiffness_n_m[1] == lin.stiffness_vertical_n_m
        ex = two_model.excitations[b]
        assert ex.n_balls == g.n_balls and ex.bpfo_per_hz == pytest.approx(_textbook(two.bearing_table(b))["bpfo"],
                                                                           rel=1e-12)
    assert m.sites["de"].stiffness_n_m[1] != m.sites["nde"].stiffness_n_m[1]


def test_lines_of_two_bearings_at_their_own_multipliers(two, two_model):
    """Every line follows one bearing's cage and spin (or the shaft and supply only); its frequency is its
    coefficients on that bearing's own rates; each bearing's BPFO orders are in the spectrum at its own BPFO."""
    m, f = two_model, 30.0
    assert not m.phases.shared and not m.one_ball_pass and not m.is_order_set
    rates = {b: _textbook(two.bearing_table(b)) for b in ("de", "nde")}
    sp = m.spectrum(f)
    c = m.lines.coefficients
    for i, which in enumerate(sp.line_bearings):
        assert which in ("de", "nde", "")
        if which:
            cage, spin = (1, 2) if which == "de" else (3, 4)
            other = (3, 4) if which == "de" else (1, 2)
            assert not c[i, list(other)].any()
            nu = c[i, 0] + c[i, cage] * rates[which]["ftf"] + c[i, spin] * rates[which]["bsf"]
            assert sp.frequency_hz[i] == pytest.approx(nu * f, rel=1e-12)
    for b in ("de", "nde"):
        bpfo = rates[b]["bpfo"] * f
        for k in (1, 2, 3):
            hit = [i for i, w in enumerate(sp.line_bearings) if w == b and abs(sp.frequency_hz[i] - k * bpfo) < 1e-9]
            assert len(hit) == 1, (b, k)
            # the dented bearing's housing moves at its own ball pass (an outer-race dent in each bearing)
            assert np.abs(sp.acceleration[hit[0], 1 if b == "de" else 3, 0]) > 1e-3
        d = sp.to_dict()["bearing_fault_frequencies_hz"][b]
        assert d["bpfo"] == pytest.approx(bpfo, rel=1e-12) and d["bpfi"] == pytest.approx(rates[b]["bpfi"] * f)
    assert sp.fault_frequencies_hz.bpfo == pytest.approx(rates["de"]["bpfo"] * f)     # the single field: the DE's
    with pytest.raises(ValueError, match="different kinematics"):
        m.fault_multipliers
    with pytest.raises(ValueError, match="different bearings"):
        m.shared_phase_lines()


def test_a_line_never_mixes_two_bearings():
    rates = [1.0, 0.4, 2.3, 0.38, 1.99, 0.0]
    LineSet([[1, 9, 0, 0, 0, 0], [0, 0, 0, 8, 1, 0]], np.ones((2, 1)), ("x",), rates)
    with pytest.raises(ValueError, match="mixes the DE and NDE"):
        LineSet([[0, 9, 0, 8, 0, 0]], np.ones((1, 1)), ("x",), rates)


def test_one_bearing_type_folds_onto_one_cage_and_spin(model):
    """Both positions with the 6010: one cage and one spin phase, the lines on the DE's columns, the same lines on
    one bearing's phases (what the synthesiser takes), the same multipliers bit for bit."""
    assert model.phases.shared and not model.lines.coefficients[:, 3:5].any()
    four = model.shared_phase_lines()
    assert np.array_equal(four.coefficients, model.lines.coefficients[:, [0, 1, 2, 5]])
    assert np.array_equal(four.multipliers, model.lines.multipliers)
    assert model.fault_multipliers == model.bearing_multipliers["de"] == model.bearing_multipliers["nde"]
    assert set(model.phases.line_bearings(model.lines.coefficients)) == {"de+nde"}


# --------------------------------------------------------------------------- ground truth, messages, viewer, labels
def test_ground_truth_gives_each_defect_its_own_bearings_frequency(two):
    gt = two.ground_truth()
    assert {b: v["designation"] for b, v in gt["bearings"].items()} == {"de": "6205", "nde": "6203"}
    assert [(d["bearing"], d["kind"], d["bearing_designation"]) for d in gt["defects"]] == \
        [("de", "outer", "6205"), ("nde", "outer", "6203")]
    for d in gt["defects"]:
        assert d["fault_multiplier"] == pytest.approx(_textbook(two.bearing_table(d["bearing"]))["bpfo"], rel=1e-12)
    assert gt["bearing_designation"] == "6205"                               # the field of one bearing type: DE's


def test_messages_carry_each_bearings_fault_frequencies(two):
    from bkabem_msgs.msg import BearingFaultFrequencies
    from rclpy.serialization import deserialize_message, serialize_message

    from bkabem_core.analysis import fault_lines
    from bkabem_core.scenario.timeline import Scenario
    from bkabem_ros.messages import convert as msgs

    f = 30.0
    sc = Scenario.of_case(two)
    truth = msgs.ground_truth_message(sc.ground_truth(sc.states[0], 1.0, f))
    kin = two.kinematics(f)
    m = msgs.fault_frequencies_message(
        shaft_speed=2 * math.pi * f, ftf=kin["de"]["ftf"], bpfo=kin["de"]["bpfo"], bpfi=kin["de"]["bpfi"],
        bsf=kin["de"]["bsf"], machine_id="two", bearing_designation="6205", defect_bearing="de", defect_length=2e-3,
        defect_depth=5e-5, defect_angle=-math.pi / 2, ground_truth=truth,
        bearings=[{"bearing": b, **k} for b, k in kin.items()])
    back = deserialize_message(serialize_message(m), BearingFaultFrequencies)
    got = msgs.bearing_kinematics(back)
    for b in ("de", "nde"):
        want = _textbook(two.bearing_table(b))
        assert got[b]["designation"] == two.bearing_geometry(b).designation
        assert got[b]["n_balls"] == two.bearing_geometry(b).n_balls
        for name in ("ftf", "bpfo", "bpfi", "bsf"):
            assert got[b][name] == pytest.approx(want[name] * f, rel=1e-12)
        lines = fault_lines.bearing_line_frequencies(back)[b]
        assert lines["BPFO"] == pytest.approx(want["bpfo"] * f) and lines["2xBSF"] == pytest.approx(2 * want["bsf"] * f)
    assert back.bpfo == pytest.approx(_textbook(two.bearing_table("de"))["bpfo"] * f)
    gt = msgs.ground_truth_dict(back)
    assert [(d["bearing"], d["bearing_designation"]) for d in gt["defects"]] == [("de", "6205"), ("nde", "6203")]
    assert gt["defects"][1]["strike_frequency_hz"] == pytest.approx(_textbook(two.bearing_table("nde"))["bpfo"] * f)


def test_the_viewer_reads_each_bearings_lines():
    """Each bearing's panel marks its own lines; a line that stands out in the DE bearing's envelope at the NDE
    bearing's BPFO is the NDE defect's, transmitted."""
    from bkabem_core.analysis import fault_lines, health

    de = {"1x": 30.0, "FTF": 11.95, "BPFO": 107.6, "BPFI": 162.4, "BSF": 70.8, "2xBSF": 141.7}
    nde = {"1x": 30.0, "FTF": 11.45, "BPFO": 91.6, "BPFI": 148.4, "BSF": 59.8, "2xBSF": 119.6}
    lines = {"de": de, "nde": nde}
    nde_defect = fault_lines.Defect("outer", "nde", 1e-3, 2e-5, designation="6203")
    assert fault_lines.defects_with_lines_of([nde_defect], lines, "de") == []
    assert fault_lines.defects_with_lines_of([nde_defect], {"de": de, "nde": de}, "de") == [nde_defect]
    plan = fault_lines.marker_plan(nde, [nde_defect], 400.0)
    assert [m.frequency_hz for m in plan if m.line == "BPFO"] == pytest.approx([91.6, 183.2, 274.8])
    f = np.arange(0, 500.0, 0.5)
    env = np.full((1, f.size), 1e-3)
    for h in (1, 2, 3):
        env[0, np.argmin(np.abs(f - h * 91.6))] = 1.0
    text = health.envelope_finding(f, env, de, ["vertical"], "de", [nde_defect], lines)
    assert text.startswith("NDE BPFO 91.6 Hz: from the NDE outer-race defect (transmitted), not a fault of the DE")
    own = health.envelope_finding(f, env, nde, ["vertical"], "nde", [nde_defect], lines)
    assert own.startswith("BPFO (91.6 Hz) stands out")


def test_labels_carry_each_bearings_frequencies(two, tmp_path):
    from bkabem_core.dataset.render import _run_case, label_row
    from bkabem_core.dataset.spec import DatasetSpec
    from bkabem_core.scenario.timeline import Scenario

    case_file = tmp_path / "two.toml"
    case_file.write_text(two_bearing_text())
    spec = DatasetSpec.from_toml(f'[dataset]\nname = "two"\nschema_version = 1\ncase = "{case_file}"\n'
                                 'sampling = "grid"\nseed = 1\n[run]\nduration_s = 0.5\nsample_rate_hz = 12800.0\n'
                                 '[grid]\nfault = ["outer"]\nbearing = ["nde"]\nspeed_hz = [25.0]\n')
    (run,) = spec.runs
    case = _run_case(run)
    alone = Scenario.of_case(case)
    gt = alone.ground_truth(alone.states[0], 0.0)
    mult = {b: case.fault_multipliers(b) for b in ("de", "nde")}
    row = label_row(run, gt, 0, 0, 6400, (25.0, 25.0, 25.0), mult, ["de_vertical"], "runs/x.parquet", anti_alias=False)
    for b in ("de", "nde"):
        want = _textbook(two.bearing_table(b))
        assert row[f"{b}_bpfo_per_hz"] == pytest.approx(want["bpfo"], rel=1e-12)
        assert row[f"{b}_bpfi_hz"] == pytest.approx(want["bpfi"] * 25.0, rel=1e-12)
        assert row[f"{b}_bearing_designation"] == two.bearing_geometry(b).designation
    assert (row["fault"], row["fault_bearing"], row["d0_bearing"], row["d0_bearing_designation"]) == \
        ("outer", "nde", "nde", "6203")
    assert row["d0_fault_multiplier"] == pytest.approx(_textbook(two.bearing_table("nde"))["bpfo"], rel=1e-12)
    assert row["bpfo_per_hz"] == row["de_bpfo_per_hz"]
