"""``bkabem case new`` and ``bkabem case check``, run in-process: the starting case loads and checks, its summary
agrees with textbook statics and kinematics, bad input is one line and exit code 2."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import pytest

from bkabem_core.model.case import Case
from bkabem_core.model.catalogue import lookup
from bkabem_ros.cli.main import main

G = 9.80665
COMPACT_MOTOR = Path(__file__).resolve().parents[1] / "fixtures" / "electric_motor_6010_compact.toml"


def bkabem(capsys, *argv):
    try:
        rc = main(list(argv))
    except SystemExit as exc:                    # argparse's own errors
        rc = exc.code
    out, err = capsys.readouterr()
    return rc, out, err


def textbook_bpfo(designation: str) -> float:
    b = lookup(designation)
    return b.n_balls / 2.0 * (1.0 - b.ball_diameter_m / b.pitch_diameter_m)


def test_case_new_writes_a_compact_case_that_loads_and_checks(capsys, tmp_path):
    out = tmp_path / "pump_motor.toml"
    rc, text, err = bkabem(capsys, "case", "new", "--de", "6205", "--nde", "6203", "--rotor-mass", "12",
                           "--speed-range", "5:60", "--clearance", "C3", "-o", str(out))
    assert rc == 0 and err == "" and f"wrote {out}" in text
    raw = tomllib.loads(out.read_text())
    assert "machine" in raw and "rotor" not in raw and raw["case"]["name"] == "pump_motor"
    assert out.read_text().count("#") > 30                         # documented: every number says where it is from
    case = Case.load(out)
    assert case.bearing_table("de")["clearance_class"] == "C3" and case.bearing_geometry("nde").designation == "6203"
    # the rotor weighs what was asked, to the millimetre rounding of its dimensions
    rotor_kg = sum(d["mass_kg"] for d in case.raw["rotor"]["disks"]) + sum(
        7850.0 * math.pi / 4.0 * do ** 2 * (b - a) for a, b, do in
        zip(case.raw["rotor"]["node_positions_m"], case.raw["rotor"]["node_positions_m"][1:],
            case.raw["rotor"]["outer_diameters_m"]))
    assert rotor_kg == pytest.approx(12.0, rel=0.02)

    rc, text, err = bkabem(capsys, "case", "check", str(out), "--json")
    assert rc == 0 and err == ""
    s = json.loads(text)
    assert s["speed_range_hz"] == [5.0, 60.0] and s["rotor"]["mass_kg"] == pytest.approx(rotor_kg, rel=1e-9)
    b = s["bearings"]
    assert b["de"]["static_radial_load_n"] + b["nde"]["static_radial_load_n"] == pytest.approx(rotor_kg * G, rel=1e-9)
    z_de, z_nde = s["rotor"]["bearing_positions_m"]["de"], s["rotor"]["bearing_positions_m"]["nde"]
    assert z_nde - z_de == pytest.approx(s["rotor"]["span_m"])
    for name, des in (("de", "6205"), ("nde", "6203")):
        assert b[name]["designation"] == des
        assert b[name]["fault_multipliers"]["bpfo"] == pytest.approx(textbook_bpfo(des), rel=1e-9)
        assert b[name]["fault_frequencies_hz"]["60"]["bpfo"] == pytest.approx(60 * textbook_bpfo(des), rel=1e-9)
        p0 = max(b[name]["static_radial_load_n"], 0.6 * b[name]["static_radial_load_n"] + 0.5 * b[name]["axial_load_n"])
        assert b[name]["static_safety"] == pytest.approx(lookup(des).static_load_rating_n / p0)
        assert 1e7 < b[name]["fe_bearing"]["stiffness_n_m"]["vertical"] < 1e9
    modes = s["modes"]
    assert modes and all(m["frequency_hz"] < s["band_hz"] for m in modes)
    assert [m["in_speed_range"] for m in modes] == [5.0 <= m["frequency_hz"] <= 60.0 for m in modes]
    rc, text, err = bkabem(capsys, "case", "check", str(out))
    assert rc == 0 and "DE bearing" in text and "BPFO 3.5864" in text and "modes" in text


def test_case_check_any_case_full_form_included(capsys):
    rc, text, err = bkabem(capsys, "case", "check", "motor_6010_outer", "--json")
    assert rc == 0
    s = json.loads(text)
    assert s["speed_range_hz"] == [0.0, 75.0] and s["rotor"]["mass_kg"] == pytest.approx(82.0, abs=1e-3)
    assert s["bearings"]["de"]["static_radial_load_n"] == pytest.approx(495.0, abs=0.1)


@pytest.mark.parametrize("argv,needle", [
    (["--de", "6299X"], "--de: unknown designation '6299X'"),
    (["--nde", "NICE (MFPT)"], "--nde: the catalogue has no bore for NICE (MFPT)"),
    (["--clearance", "C7"], "--clearance: unknown clearance class 'C7'"),
    (["--speed-range", "60:5"], "--speed-range: the lowest speed must be below the highest"),
    (["--speed-range", "60"], "--speed-range must be LO:HI"),
    (["--rotor-mass", "-3"], "--rotor-mass must be > 0"),
    (["--rotor-mass", "0.2"], "--rotor-mass: 0.2 kg: the shaft these bearings need weighs"),
    (["--rotor-mass", "1e9"], "--rotor-mass: 1e+09 kg is more than a rotor core of 10 m"),
])
def test_case_new_bad_input_is_one_line_and_exit_2(capsys, tmp_path, argv, needle):
    base = {"--de": "6205", "--nde": "6203", "--rotor-mass": "12", "--speed-range": "5:60"}
    args = dict(base)
    extra = []
    for k, v in zip(argv[::2], argv[1::2]):
        if k in args:
            args[k] = v
        else:
            extra += [k, v]
    out = tmp_path / "x.toml"
    cmd = ["case", "new", *[t for kv in args.items() for t in kv], *extra, "-o", str(out)]
    rc, text, err = bkabem(capsys, *cmd)
    assert rc == 2 and err.count("\n") == 1 and needle in err, err
    assert not out.exists()


def test_case_check_bad_case_is_one_line_and_exit_2(capsys, tmp_path):
    text = COMPACT_MOTOR.read_text()
    cut = text.index("[machine.bearings.nde]")
    bad = tmp_path / "one_bearing.toml"
    bad.write_text(text[:cut] + text[text.index("[machine.housings]"):])
    rc, out, err = bkabem(capsys, "case", "check", str(bad))
    assert rc == 2 and err.count("\n") == 1 and "machine.bearings.nde: missing" in err, err
    rc, out, err = bkabem(capsys, "case", "check", str(tmp_path / "nothing.toml"))
    assert rc == 2 and "file not found" in err
