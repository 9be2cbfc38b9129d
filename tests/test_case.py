"""Case files: the embedded default loads; bad values give one clear error naming the key."""

import re

import pytest

from bkabem_core.case import Case, CaseError, embedded_cases

EMBEDDED = Case.load().raw


def _text():
    from importlib import resources

    return resources.files("bkabem_core").joinpath("cases", "electric_motor_6010.toml").read_text()


def _sub(pattern, repl, count=1):
    text, n = re.subn(pattern, repl, _text(), count=count, flags=re.M)
    assert n == count, pattern
    return text


def test_embedded_case_loads_and_has_an_identity():
    c = Case.load()
    assert c.name == "electric_motor_6010" and "electric_motor_6010" in embedded_cases()
    assert len(c.case_hash) == 16 and c.case_hash == Case.load("electric_motor_6010").case_hash
    assert c.bearing().fault_multipliers().bpfo == pytest.approx(6.0598, abs=1e-4)
    assert c.dent().bearing == "de"


def test_user_case_by_path(tmp_path):
    p = tmp_path / "mine.toml"
    p.write_text(_sub(r"^depth_m = 50.0e-6", "depth_m = 20.0e-6"))
    c = Case.load(p)
    assert c.dent().depth_m == 20e-6 and c.source == str(p)
    assert c.case_hash != Case.load().case_hash


@pytest.mark.parametrize("text_fn, key, reason", [
    (lambda: _sub(r"^ball_diameter_m = .*\n", ""), "bearing.ball_diameter_m", "missing"),
    (lambda: _sub(r"^n_balls = 14", 'n_balls = "14"'), "bearing.n_balls", "must be an integer"),
    (lambda: _sub(r"^n_balls = 14", "n_balls = 14.0"), "bearing.n_balls", "must be an integer"),
    (lambda: _sub(r"^length_m = 2.0e-3", "length_m = -2.0e-3"), "dent.length_m", "must be > 0"),
    (lambda: _sub(r"^length_m = 2.0e-3", "length_m = 0.25"), "dent.length_m", "circumference"),
    (lambda: _sub(r"^length_m = 2.0e-3", "length_m = 0.02"), "dent.length_m", "ball pitch"),
    (lambda: _sub(r"^diametral_clearance_m = .*", "diametral_clearance_m = -1e-6"),
     "bearing.diametral_clearance_m", "must be >= 0"),
    (lambda: _sub(r"^n_balls = 14", "n_balls = 14\nball_count = 3"), "bearing.ball_count", "unknown key"),
    (lambda: _text() + "\n[extra]\nx = 1\n", "extra", "unknown section"),
    (lambda: _sub(r"^inner_conformity = 0.52", "inner_conformity = 0.5"), "bearing.inner_conformity", "> 0.5"),
    (lambda: _sub(r"^poisson_ratio = 0.3", "poisson_ratio = nan"), "bearing.poisson_ratio", "finite"),
    (lambda: _sub(r'^bearing = "de"', 'bearing = "middle"'), "dent.bearing", "one of"),
    (lambda: _sub(r"^rotor_node = 5", "rotor_node = 40"), "bearings.de.rotor_node", "shaft node"),
    (lambda: _sub(r"^max_order = 50", "max_order = -1"), "excitation.max_order", ">= 0"),
    (lambda: _sub(r"^ehl_film = false", "ehl_film = 0"), "bearing.ehl_film", "true or false"),
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


def test_unknown_embedded_case_and_missing_file():
    with pytest.raises(CaseError, match="no embedded case"):
        Case.load("no_such_machine")
    with pytest.raises(CaseError, match="file not found"):
        Case.load("/nonexistent/case.toml")


def test_overrides_are_validated_too():
    c = Case.load()
    assert c.with_overrides({"dent.depth_m": 1e-5}).dent().depth_m == 1e-5
    with pytest.raises(CaseError, match="dent.depth_m"):
        c.with_overrides({"dent.depth_m": -1.0})
    with pytest.raises(CaseError, match="unknown key"):
        c.with_overrides({"dent.colour": "red"})
