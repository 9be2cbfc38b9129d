"""A rig's load table (bkabem_core.model.load_table): the shaft speed each dynamometer load gives, in the case's
[operating] (the compact form's [machine]), checked key by key and used by a data set's ``load_hp``."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources

import pytest

from bkabem_core.model.case import Case, CaseError
from bkabem_core.model.load_table import speed_at_load_hz

#: the CWRU rig's documentation: loads [hp] and motor speeds [r/min]
CWRU_LOADS = {0.0: 1797.0, 1.0: 1772.0, 2.0: 1750.0, 3.0: 1730.0}


def _cwru_raw() -> dict:
    text = resources.files("bkabem_core.embedded").joinpath("cases", "cwru_rig.toml").read_text()
    return tomllib.loads(text)


def test_cwru_rigs_table_is_its_documented_speeds_and_interpolates_between_them():
    case = Case.load("cwru_rig")
    for hp, rpm in CWRU_LOADS.items():
        assert case.speed_at_load_hz(hp) * 60.0 == pytest.approx(rpm, abs=1e-4)
    assert case.speed_at_load_hz(2.5) * 60.0 == pytest.approx(1740.0, abs=1e-4)     # linear between 2 and 3 hp


@pytest.mark.parametrize("load", [-0.5, 3.01, float("nan"), float("inf")])
def test_a_load_outside_the_table_is_refused_not_clamped(load):
    with pytest.raises(ValueError, match="outside the case's load table"):
        Case.load("cwru_rig").speed_at_load_hz(load)


def test_a_case_without_a_table_says_so():
    with pytest.raises(ValueError, match="no load table"):
        Case.load("electric_motor_6010").speed_at_load_hz(1.0)
    assert speed_at_load_hz({"load_hp": [1.0], "load_speed_hz": [20.0]}, 1.0) == 20.0     # one point: that load


def _edit(key, value):
    def change(raw):
        raw = copy.deepcopy(raw)
        if value is None:
            raw["machine"].pop(key)
        else:
            raw["machine"][key] = value
        return raw
    return change


BAD = [
    (_edit("load_speed_hz", None), "machine.load_speed_hz", "missing"),
    (_edit("load_hp", None), "machine.load_hp", "missing"),
    (_edit("load_speed_hz", [29.95, 29.5]), "machine.load_speed_hz", "one speed per load: 4 (got 2)"),
    (_edit("load_hp", [0.0, 2.0, 1.0, 3.0]), "machine.load_hp", "must increase"),
    (_edit("load_hp", []), "machine.load_hp", "at least one load"),
    (_edit("load_hp", [-1.0, 1.0, 2.0, 3.0]), "machine.load_hp", ">= 0"),
    (_edit("load_speed_hz", [29.95, 29.5, 29.2, 31.0]), "machine.load_speed_hz", "above the operating range"),
    (_edit("load_speed_hz", [29.95, 29.5, 29.2, 0.0]), "machine.load_speed_hz", "> 0"),
    (_edit("load_hp", "3 hp"), "machine.load_hp", ""),
]


@pytest.mark.parametrize("change,key,reason", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_a_bad_load_table_names_its_key(change, key, reason):
    with pytest.raises(CaseError) as info:
        Case.from_dict(change(_cwru_raw()), "rig.toml")
    assert info.value.key.startswith(key) and reason in info.value.reason, (info.value.key, info.value.reason)
    assert "\n" not in str(info.value)


def test_the_full_form_takes_the_table_in_operating():
    case = Case.load("electric_motor_6010").with_overrides({"operating.load_hp": [0.0, 10.0],
                                                            "operating.load_speed_hz": [50.0, 48.5]})
    assert case.speed_at_load_hz(5.0) == pytest.approx(49.25)
    with pytest.raises(CaseError) as info:
        Case.load("electric_motor_6010").with_overrides({"operating.load_hp": [0.0, 10.0]})
    assert info.value.key == "operating.load_speed_hz" and "missing" in info.value.reason


def test_case_check_lists_the_load_table():
    from bkabem_core.fe.summary import machine_summary
    from bkabem_ros.cli.case import summary_text

    s = machine_summary(Case.load("cwru_rig"))
    assert [row["load_hp"] for row in s["load_table"]] == list(CWRU_LOADS)
    line = next(ln for ln in summary_text(s).splitlines() if ln.startswith("loads"))
    assert all(f"{hp:g} hp: {rpm:g} r/min" in line for hp, rpm in CWRU_LOADS.items()), line
    assert machine_summary(Case.load("electric_motor_6010"))["load_table"] == []
