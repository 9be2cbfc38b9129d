"""A shaft speed is bounded by each bearing's limiting speed: ``operating.max_speed_hz = 1797`` (1797 r/min written
as Hz) on a 6205 was accepted (it is below the generic 2000 Hz bound) and computed a machine at 108 000 r/min. The
bound is the catalogue's limiting speed (18 000 r/min = 300 Hz for the open 6205), overridable in the case's
``[plausibility]`` table like every bound; the CLI refuses such a case in one line with exit 2, scenarios and data
sets naming it are refused as they load, and the node refuses a ``max_speed`` above it and ignores faster speeds."""

from __future__ import annotations

import copy
import math
from importlib import resources

import pytest

from bkabem_core.model import plausibility
from bkabem_core.model.case import Case, CaseError, embedded_cases
from bkabem_core.model.catalogue import lookup

RATIO = "bearings.*.limiting_speed_ratio"
#: The embedded machine with a 6205 at both positions (the CWRU size), as a case file's text.
MOTOR = resources.files("bkabem_core.embedded").joinpath("cases", "electric_motor_6010.toml").read_text()
assert MOTOR.count('designation = "6010"') == 2 and MOTOR.count("max_speed_hz = 75.0") == 1
MOTOR_6205 = MOTOR.replace('designation = "6010"', 'designation = "6205"')


def _text(max_speed_hz: float, plausibility_table: str = "") -> str:
    return MOTOR_6205.replace("max_speed_hz = 75.0", f"max_speed_hz = {max_speed_hz!r}") + plausibility_table


def _raw(de: str = "6205", nde: str = "6205", max_speed_hz: float = 75.0) -> dict:
    raw = copy.deepcopy(Case.load().raw)
    raw["bearings"]["de"]["designation"], raw["bearings"]["nde"]["designation"] = de, nde
    raw["operating"]["max_speed_hz"] = max_speed_hz
    return raw


def test_rpm_written_as_hz_on_a_6205_is_refused_naming_the_field_the_value_the_limit_and_the_override():
    assert lookup("6205").limiting_speed_rpm == 18000.0          # SKF 2017, the open bearing
    with pytest.raises(CaseError) as ei:
        Case.from_toml(_text(1797.0), "cwru.toml")
    e = ei.value
    assert e.key == "operating.max_speed_hz", str(e)
    text = str(e)
    assert "\n" not in text
    for fragment in ("cwru.toml", "1797", "6205", "18000 r/min", "300 Hz", "bearings.de",
                     f'[plausibility] "{RATIO}" = [low, high]'):
        assert fragment in text, (fragment, text)


def test_the_override_lets_it_through_and_travels_with_the_case():
    case = Case.from_toml(_text(1797.0, f'\n[plausibility]\n"{RATIO}" = [0.0, 6.0]\n'), "fast.toml")
    assert case.max_speed_hz == 1797.0
    assert case.with_overrides({"dent.depth_m": 1e-5}).max_speed_hz == 1797.0
    # the override widens this bound only: the generic one of operating.max_speed_hz still holds
    with pytest.raises(CaseError) as ei:
        Case.from_toml(_text(4000.0, f'\n[plausibility]\n"{RATIO}" = [0.0, 20.0]\n'))
    assert ei.value.key == "operating.max_speed_hz" and "2000" in str(ei.value)
    # and an override too narrow is an override: 1797 is 5.99 x 300 Hz
    with pytest.raises(CaseError, match="overridden"):
        Case.from_toml(_text(1797.0, f'\n[plausibility]\n"{RATIO}" = [0.0, 5.9]\n'))


@pytest.mark.parametrize("max_speed_hz", [29.95, 250.0, 300.0])      # 1797 r/min; 15 000 r/min; the limit itself
def test_a_speed_within_the_limit_passes(max_speed_hz):
    assert Case.from_toml(_text(max_speed_hz)).max_speed_hz == max_speed_hz


def test_just_above_the_limit_is_refused():
    with pytest.raises(CaseError, match=r"1\.01 x the limiting speed of bearings\.de"):
        Case.from_toml(_text(303.0))


def test_the_lower_of_the_two_bearings_limits():
    # DE 6205 (18 000 r/min = 300 Hz), NDE 6010 (11 000 r/min = 183.3 Hz): 200 Hz is over the NDE bearing's
    with pytest.raises(CaseError) as ei:
        Case.from_dict(_raw("6205", "6010", 200.0))
    assert ei.value.key == "operating.max_speed_hz" and "bearings.nde" in str(ei.value)
    assert "11000 r/min" in str(ei.value)
    Case.from_dict(_raw("6205", "6010", 180.0))
    hz, who = plausibility.max_speed_bound(Case.from_dict(_raw("6205", "6010", 180.0)).resolved)
    assert hz == pytest.approx(11000.0 / 60.0) and who.startswith("bearings.nde (6010")


@pytest.mark.parametrize("designation, rpm, fragment", [
    ("6205", 18000.0, "the catalogue's"),
    ("6205-2RS1/C3", 18000.0, "the open 6205's (seals and shields lower it)"),   # the catalogue leaves it NaN
    ("6205-2RS JEM", 8500.0, "the catalogue's"),                                  # the CWRU rig's own row
])
def test_limiting_speed_of_catalogue_bearings(designation, rpm, fragment):
    hz, src = plausibility.bearing_limiting_speed({"designation": designation, "pitch_diameter_m": 0.039})
    assert hz == pytest.approx(rpm / 60.0) and fragment in src, src


def test_a_bearing_without_a_catalogue_speed_gets_the_n_dm_estimate():
    # the highest n dm of the catalogue's open series rows, recomputed here from the rows themselves
    from bkabem_core.model.catalogue import designations

    rows = [lookup(k) for k in designations() if lookup(k).description.endswith(" series")]
    n_dm = max(r.limiting_speed_rpm * r.pitch_diameter_m for r in rows)
    assert 650.0 < n_dm < 800.0       # m r/min (6.5e5 .. 8e5 mm r/min): SKF's open deep-groove ball bearings
    for designation in ("ACME 42", "6203 FAG (Paderborn)"):     # not in the catalogue; a rig row without speeds
        hz, src = plausibility.bearing_limiting_speed({"designation": designation, "pitch_diameter_m": 0.0285})
        assert hz == pytest.approx(n_dm / 0.0285 / 60.0) and "estimated" in src, src
    # every catalogue series row is within the estimate for its own pitch diameter (the estimate is the envelope)
    for r in rows:
        assert r.limiting_speed_rpm <= n_dm / r.pitch_diameter_m * (1 + 1e-12), r.catalogue_key


def test_explicit_geometry_case_bearing_is_bounded_by_the_estimate():
    base = Case.load()
    raw = _raw("6010", "6010", 1797.0)
    geometry = {k: base.positions["de"].table[k] for k in ("bore_diameter_m", "outer_diameter_m", "pitch_diameter_m",
                                                           "ball_diameter_m", "n_balls", "contact_angle_deg",
                                                           "static_load_rating_n")}
    for name in ("de", "nde"):
        raw["bearings"][name].update(geometry, designation="MOTOR-OWN 1")
    with pytest.raises(CaseError) as ei:
        Case.from_dict(raw)
    assert ei.value.key == "operating.max_speed_hz" and "estimated" in str(ei.value)
    raw["operating"]["max_speed_hz"] = 75.0
    Case.from_dict(raw)


def test_every_embedded_case_scenario_and_data_set_still_loads():
    from bkabem_core.dataset.spec import DatasetSpec
    from bkabem_core.model.case import embedded_names
    from bkabem_core.scenario.fleet import FleetScenario
    from bkabem_core.scenario.timeline import Scenario, ScenarioError

    names = embedded_cases()
    assert len(names) >= 5
    for name in names:
        case = Case.load(name)
        hz, _ = plausibility.max_speed_bound(case.resolved)
        assert case.max_speed_hz <= hz, name
    for name in embedded_names("scenarios"):
        try:
            Scenario.load(name)
        except ScenarioError as exc:
            assert exc.key == "fleet", exc                        # a fleet scenario: loaded as one below
            FleetScenario.load(name)
    for name in embedded_names("datasets"):
        DatasetSpec.load(name)


def test_a_scenario_and_a_data_set_naming_such_a_case_are_refused(tmp_path):
    from bkabem_core.dataset.spec import DatasetSpec, DatasetSpecError
    from bkabem_core.scenario.timeline import Scenario, ScenarioError

    (tmp_path / "cwru.toml").write_text(_text(1797.0))
    sc = tmp_path / "s.toml"
    sc.write_text('[scenario]\nname = "s"\nschema_version = 1\ncase = "cwru.toml"\nduration_h = 1.0\n')
    with pytest.raises(ScenarioError, match="operating.max_speed_hz"):
        Scenario.load(sc)
    ds = tmp_path / "d.toml"
    ds.write_text(f'[dataset]\nname = "d"\nschema_version = 1\ncase = "{tmp_path / "cwru.toml"}"\n')
    with pytest.raises(DatasetSpecError, match="operating.max_speed_hz"):
        DatasetSpec.load(ds)


def _main(argv, capsys):
    from bkabem_ros.cli.main import main

    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_cli_refuses_the_case_in_one_line_exit_2(tmp_path, capsys):
    (tmp_path / "cwru.toml").write_text(_text(1797.0))
    rc, out, err = _main(["synth", "--case", str(tmp_path / "cwru.toml"), "--profile", "constant:29.95",
                          "--seconds", "0.1", "--out", str(tmp_path / "o.npz")], capsys)
    assert rc == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "operating.max_speed_hz" in lines[0] and RATIO in lines[0], err
    assert "Traceback" not in err and not (tmp_path / "o.npz").exists()


def test_cli_synth_above_the_overridden_case_range_is_still_refused(tmp_path, capsys):
    # the override lets the case run to 400 Hz (1.33 x the 6205's limit); a profile above the case's operating range
    # stays refused: every speed a run asks for is at most operating.max_speed_hz
    (tmp_path / "fast.toml").write_text(_text(400.0, f'\n[plausibility]\n"{RATIO}" = [0.0, 2.0]\n'))
    rc, out, err = _main(["synth", "--case", str(tmp_path / "fast.toml"), "--profile", "constant:500",
                          "--seconds", "0.1", "--out", str(tmp_path / "o.npz")], capsys)
    assert rc == 2 and "max_speed_hz" in err, (out, err)


# --------------------------------------------------------------------------- the node's speed input (no ROS)
def test_node_speed_check_names_the_bearing_limit():
    from bkabem_ros.node.speed import bearing_limit_rad_s, check_speed, max_speed_refusal

    case = Case.from_toml(_text(250.0))
    limit = bearing_limit_rad_s(case)
    assert limit[0] == pytest.approx(2 * math.pi * 300.0) and "6205" in limit[1]
    fast = 2 * math.pi * 1797.0
    why = check_speed(fast, 1.0e5, limit)          # even with max_speed raised: the bearings' limit holds
    assert why is not None and "limiting speed" in why and "6205" in why
    assert check_speed(2 * math.pi * 250.0, 2 * math.pi * 250.0, limit) is None
    assert "above max_speed" in check_speed(2 * math.pi * 260.0, 2 * math.pi * 250.0, limit)
    # the max_speed parameter above the limit is refused, with the override named
    why = max_speed_refusal(fast, limit)
    assert why is not None and RATIO in why
    assert max_speed_refusal(2 * math.pi * 300.0, limit) is None
    # the case's override moves the node's limit with it
    wide = Case.from_toml(_text(1797.0, f'\n[plausibility]\n"{RATIO}" = [0.0, 6.0]\n'))
    assert bearing_limit_rad_s(wide)[0] == pytest.approx(2 * math.pi * 1800.0)
    assert check_speed(fast, fast, bearing_limit_rad_s(wide)) is None
