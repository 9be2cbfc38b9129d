"""Case files: the embedded default loads; bad values give one clear error naming the key."""

import re

import numpy as np
import pytest

from bkabem_core.model.case import Case, CaseError, embedded_cases

EMBEDDED = Case.load().raw


def _text():
    from importlib import resources

    return resources.files("bkabem_core.embedded").joinpath("cases", "electric_motor_6010.toml").read_text()


def _sub(pattern, repl, count=1):
    text, n = re.subn(pattern, repl, _text(), count=count, flags=re.M)
    assert n == count, pattern
    return text


def test_embedded_case_loads_and_has_an_identity():
    c = Case.load()
    assert c.name == "electric_motor_6010" and "electric_motor_6010" in embedded_cases()
    assert len(c.case_hash) == 16 and c.case_hash == Case.load("electric_motor_6010").case_hash
    assert c.bearing("de").fault_multipliers().bpfo == pytest.approx(6.0598, abs=1e-4)
    assert c.dent().bearing == "de"


def test_user_case_by_path(tmp_path):
    p = tmp_path / "mine.toml"
    p.write_text(_sub(r"^depth_m = 50.0e-6", "depth_m = 20.0e-6"))
    c = Case.load(p)
    assert c.dent().depth_m == 20e-6 and c.source == str(p)
    assert c.case_hash != Case.load().case_hash


@pytest.mark.parametrize("text_fn, key, reason", [
    (lambda: _sub(r"^designation = .*\n", ""), "bearings.de.designation", "missing"),
    (lambda: _sub(r"^damping_n_s_m = .*\n", ""), "bearings.de.damping_n_s_m", "missing"),
    (lambda: _sub(r"^ball_diameter_m = .*", 'ball_diameter_m = 8.73e-3\nn_balls = "14"'), "bearings.de.n_balls",
     "must be an integer"),
    (lambda: _sub(r"^ball_diameter_m = .*", "ball_diameter_m = 8.73e-3\nn_balls = 14.0"), "bearings.de.n_balls",
     "must be an integer"),
    (lambda: _sub(r"^length_m = 2.0e-3", "length_m = -2.0e-3"), "defects[0].length_m", "must be > 0"),
    (lambda: _sub(r"^length_m = 2.0e-3", "length_m = 0.25"), "defects[0].length_m", "circumference"),
    (lambda: _sub(r"^length_m = 2.0e-3", "length_m = 0.02"), "defects[0].length_m", "ball pitch"),
    (lambda: _sub(r"^diametral_clearance_m = .*", "diametral_clearance_m = -1e-6"),
     "bearings.de.diametral_clearance_m", "must be >= 0"),
    (lambda: _sub(r"^ball_diameter_m = .*", "ball_diameter_m = 8.73e-3\nball_count = 3"), "bearings.de.ball_count",
     "unknown key"),
    (lambda: _text() + "\n[extra]\nx = 1\n", "extra", "unknown section"),
    (lambda: _sub(r"^inner_conformity = 0.52", "inner_conformity = 0.5"), "bearings.de.inner_conformity", "> 0.5"),
    (lambda: _sub(r"^poisson_ratio = 0.3", "poisson_ratio = nan"), "bearings.de.poisson_ratio", "finite"),
    (lambda: _sub(r'^bearing = "de"', 'bearing = "middle"'), "defects[0].bearing", "one of"),
    (lambda: _sub(r'^race = "outer"', 'race = "cage"'), "defects[0].race", "one of"),
    (lambda: _sub(r'^race = "outer"', 'race = "ball"'), "defects[0].ball", "missing"),
    (lambda: _sub(r'^race = "outer"', 'race = "outer"\nball = 3'), "defects[0].ball", "only for race = 'ball'"),
    (lambda: _sub(r'^race = "outer"', 'race = "ball"\nball = 15'), "defects[0].ball", "ball number 1..14"),
    (lambda: _sub(r"^unbalance_grade_mm_s = 0.0", "unbalance_grade_mm_s = -1.0"),
     "baseline.unbalance_grade_mm_s", ">= 0"),
    (lambda: _sub(r"^misalignment_node = 1", "misalignment_node = 15"), "baseline.misalignment_node",
     "shaft node"),
    (lambda: _sub(r"^\[\[defects\]\]", "[defects]"), "defects", "array of tables"),
    (lambda: _sub(r'^method = "quasi_static"', 'method = "four_dof"').replace('race = "outer"', 'race = "inner"'),
     "excitation.method", "outer-race"),
    (lambda: _sub(r"^rotor_node = 5", "rotor_node = 40"), "bearings.de.rotor_node", "shaft node"),
    (lambda: _sub(r"^max_order = 50", "max_order = -1"), "excitation.max_order", ">= 0"),
    (lambda: _sub(r"^ehl_film = false", "ehl_film = 0"), "bearings.de.ehl_film", "true or false"),
    (lambda: "not = [valid", "toml", "not valid TOML"),
])
def test_bad_case_values_name_the_key(tmp_path, text_fn, key, reason):
    p = tmp_path / "bad.toml"
    p.write_text(text_fn())
    with pytest.raises(CaseError) as info:
        Case.load(p)
    assert info.value.key == key
    assert reason in str(info.value)
    assert str(p) in str(info.value)
    assert "\n" not in str(info.value)


def test_edge_fraction_may_be_left_out_and_a_bad_one_is_named(tmp_path):
    """``edge_fraction`` sets the width of a ``"cubic"`` edge only: a [[defects]] table may leave it out (0.1, as a
    scenario's defect does), and then has the lines of a table that gives 0.1; a value out of range is refused with
    its key."""
    p = tmp_path / "no_edge_fraction.toml"
    p.write_text(_sub(r"^edge_fraction = .*\n", ""))
    assert Case.load(p).dent().edge_fraction == 0.1
    for edge in ("ball", "cubic"):
        given, left_out = (Case.from_toml(_sub(r'^edge = "ball"', f'edge = "{edge}"').replace(
            "edge_fraction = 0.1 ", cut, 1), "c.toml") for cut in ("edge_fraction = 0.1 ", "#"))
        wider = Case.from_toml(_sub(r'^edge = "ball"', f'edge = "{edge}"').replace("edge_fraction = 0.1 ",
                                                                                   "edge_fraction = 0.5 ", 1), "c.toml")
        assert "edge_fraction" not in left_out.raw["defects"][0] and left_out.dent().edge_fraction == 0.1
        assert left_out.dent().edge == edge
        beta = np.linspace(-np.pi, np.pi, 20001)[:, None]                 # ~200 points over the 2 mm dent
        zero = np.zeros_like(beta)
        drop = [c.bearing("de").defect_set.drop_m(beta, zero, zero) for c in (given, left_out, wider)]
        assert drop[0].max() > 0 and np.array_equal(drop[0], drop[1])
        assert np.array_equal(drop[0], drop[2]) == (edge == "ball")     # a wider edge shows on a "cubic" one
    p.write_text(_sub(r"^edge_fraction = 0.1", "edge_fraction = 2.0"))
    with pytest.raises(CaseError) as info:
        Case.load(p)
    assert info.value.key == "defects[0].edge_fraction" and "\n" not in str(info.value)


def test_unknown_embedded_case_and_missing_file():
    with pytest.raises(CaseError, match="no embedded case"):
        Case.load("no_such_machine")
    with pytest.raises(CaseError, match="file not found"):
        Case.load("/nonexistent/case.toml")


def test_overrides_are_validated_too():
    c = Case.load()
    assert c.with_overrides({"defects.0.depth_m": 1e-5}).dent().depth_m == 1e-5
    assert c.with_defect_depth(2e-5).defect_depth_m == 2e-5
    with pytest.raises(CaseError, match=r"defects\[0\].depth_m"):
        c.with_overrides({"defects.0.depth_m": -1.0})
    with pytest.raises(CaseError, match="unknown key"):
        c.with_overrides({"defects.0.colour": "red"})
    with pytest.raises(CaseError, match="unknown key"):
        c.with_overrides({"defects.3.depth_m": 1e-5})


def _v3_text() -> str:
    """The embedded case as schema version 3 wrote it: one [bearing] for both positions."""
    from pathlib import Path

    return (Path(__file__).parents[1] / "fixtures" / "electric_motor_6010_v3.toml").read_text()


def _v2_text() -> str:
    """The embedded case as schema version 2 wrote it: one [dent], no [baseline]."""
    text = _v3_text()
    start, mid, end = text.index("[[defects]]"), text.index("[baseline]"), text.index("[excitation]")
    dent = "\n".join(line.split("#")[0].rstrip() for line in text[start:mid].splitlines()
                     if line.strip() and not line.lstrip().startswith("#") and not line.startswith("["))
    body = text[:start] + "[dent]\n" + "\n".join(x for x in dent.splitlines() if x.strip()) + "\n\n" + text[end:]
    return body.replace("schema_version = 3", "schema_version = 2")


def test_version_2_cases_migrate_to_the_same_machine(tmp_path):
    """A v2 file (single [dent]) is read as v4: its dent is the one defect, the baseline is off, and its bearing
    excitation is the embedded case's, bit for bit."""
    from bkabem_core.fe.machine import Machine

    p = tmp_path / "v2.toml"
    p.write_text(_v2_text())
    old = Case.load(p)
    new = Case.load()
    assert old.raw["case"]["schema_version"] == 4 and "dent" not in old.raw and "bearing" not in old.raw
    assert old.defects() == new.defects()
    assert old.baseline["unbalance_grade_mm_s"] == 0.0
    a, b = Machine(old).excitation("de"), Machine(new).excitation("de")
    assert np.array_equal(a.complex_amplitude_m(), b.complex_amplitude_m())
    assert np.array_equal(a.orders, b.orders)


def test_healthy_case_and_ground_truth_of_every_defect(tmp_path):
    text = _text()
    start, end = text.index("[[defects]]"), text.index("[baseline]")
    healthy = text[:start] + text[end:]
    healthy = healthy.replace("[case]", "defects = []\n\n[case]", 1)
    p = tmp_path / "healthy.toml"
    p.write_text(healthy)
    c = Case.load(p)
    gt = c.ground_truth()
    assert c.defects() == [] and gt["healthy"] and gt["defects"] == [] and gt["defect"] is None
    several = text.replace("[baseline]", '[[defects]]\nbearing = "nde"\nrace = "ball"\nball = 3\nlength_m = 1.0e-3\n'
                           'depth_m = 20.0e-6\nangle_deg = 0.0\nedge = "ball"\nedge_fraction = 0.1\n\n[baseline]')
    p.write_text(several)
    gt = Case.load(p).ground_truth()
    assert [(d["kind"], d["bearing"]) for d in gt["defects"]] == [("outer", "de"), ("ball", "nde")]
    assert gt["defects"][1]["ball"] == 3 and gt["defects"][1]["fault_frequency"] == "bsf"
    assert gt["defects"][0]["fault_multiplier"] == pytest.approx(6.0598, abs=1e-4)
