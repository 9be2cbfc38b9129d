"""``bkabem bearing``, run in-process: geometry, provenance, clearance and multipliers; bad input one line, exit 2."""

from __future__ import annotations

import json
import math

import pytest

from bkabem_core.model.catalogue import designations, lookup
from bkabem_ros.cli.main import main


def bkabem(capsys, *argv):
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def textbook_multipliers(n_balls, ball_m, pitch_m):
    """FTF, BPFO, BPFI, BSF per shaft Hz (outer ring fixed, no slip, contact angle 0)."""
    g = ball_m / pitch_m
    return {"ftf": 0.5 * (1 - g), "bpfo": n_balls * 0.5 * (1 - g), "bpfi": n_balls * 0.5 * (1 + g),
            "bsf": pitch_m / (2 * ball_m) * (1 - g * g)}


def test_json_document_of_a_catalogue_bearing(capsys):
    rc, out, err = bkabem(capsys, "bearing", "6205-2RS JEM", "--json")
    assert rc == 0 and err == ""
    d = json.loads(out)
    assert d["catalogue_key"] == "6205-2RS JEM" and d["geometry_status"] == "published"
    assert d["n_balls"] == 9 and d["bore_diameter_m"] == pytest.approx(0.025)
    assert "Case Western Reserve" in d["geometry_source"]
    m = d["fault_multipliers_per_shaft_hz"]
    expected = textbook_multipliers(d["n_balls"], d["ball_diameter_m"], d["pitch_diameter_m"])
    for k, v in expected.items():
        assert m[k] == pytest.approx(v, rel=1e-9), k
    assert m["two_bsf"] == pytest.approx(2 * expected["bsf"], rel=1e-9)
    for k, published in {"bpfi": 5.4152, "bpfo": 3.5848, "ftf": 0.39828, "bsf": 2.3567}.items():
        assert m[k] == pytest.approx(published, rel=0.005), k        # CWRU's bearing information page
    c = d["radial_clearance"]
    assert (c["clearance_class"], c["min_m"], c["max_m"]) == ("CN", pytest.approx(5e-6), pytest.approx(20e-6))
    assert d["reference_speed_rpm"] is None                              # unknown -> null, never NaN


def test_clearance_from_the_suffix_and_from_the_option(capsys):
    d = json.loads(bkabem(capsys, "bearing", "6205-2RS1/C3", "--json")[1])
    assert d["radial_clearance"]["clearance_class"] == "C3"
    assert d["radial_clearance"]["min_m"] == pytest.approx(13e-6) and d["radial_clearance"]["max_m"] == \
        pytest.approx(28e-6)
    assert d["limiting_speed_rpm"] is None and d["suffixes"] == ["2RS1", "C3"]
    d = json.loads(bkabem(capsys, "bearing", "6310", "--clearance", "c4", "--json")[1])
    assert d["radial_clearance"]["clearance_class"] == "C4"
    assert (d["radial_clearance"]["min_m"], d["radial_clearance"]["max_m"]) == (pytest.approx(30e-6),
                                                                                pytest.approx(51e-6))


def test_text_says_whether_the_geometry_is_published_or_estimated(capsys):
    for key in designations():
        rc, out, _ = bkabem(capsys, "bearing", key)
        assert rc == 0
        status = lookup(key).geometry_status
        assert ("ESTIMATED" in out) == (status == "estimated"), key
        line = next(x for x in out.splitlines() if x.startswith("internal geometry"))
        assert status.upper() in line.upper(), key
        for name in ("FTF", "BPFO", "BPFI", "BSF", "2 x BSF"):
            assert f"  {name}" in out, (key, name)
    rc, out, _ = bkabem(capsys, "bearing", "6205")
    b = lookup("6205")
    bpfo = next(x for x in out.splitlines() if x.strip().startswith("BPFO")).split()[-1]
    assert float(bpfo) == pytest.approx(textbook_multipliers(b.n_balls, b.ball_diameter_m,
                                                             b.pitch_diameter_m)["bpfo"], abs=1e-5)
    assert "5 .. 20 um" in out and "C 14.8 kN, C0 7.8 kN" in out


def test_list(capsys):
    rc, out, _ = bkabem(capsys, "bearing", "--list")
    lines = out.splitlines()
    assert rc == 0 and len(lines) == 1 + len(designations()) + 1
    assert lines[-1].startswith(f"{len(designations())} bearings: 28 published, 1 derived, 47 estimated")
    assert any(x.startswith("6310 ") and " estimated " in x for x in lines)
    rows = json.loads(bkabem(capsys, "bearing", "--list", "--json")[1])
    assert [r["designation"] for r in rows] == list(designations())
    assert next(r for r in rows if r["designation"] == "NICE (MFPT)")["bore_diameter_m"] is None


@pytest.mark.parametrize("argv, start", [
    (["6299"], "DESIGNATION: unknown designation '6299' (nearest: "),
    (["6205-E"], "DESIGNATION: designation '6205-E': suffix 'E'"),
    (["6205", "--clearance", "C7"], "--clearance: unknown clearance class 'C7'"),
    (["6205/C3", "--clearance", "C4"], "--clearance: C4 contradicts the clearance class C3"),
    (["NICE (MFPT)", "--clearance", "C3"], "--clearance: the bore of NICE (MFPT) is not published"),
    ([], "DESIGNATION: missing"),
    (["6205", "--list"], "--list: takes no DESIGNATION"),
])
def test_bad_input_is_one_line_and_exit_2(capsys, argv, start):
    rc, out, err = bkabem(capsys, "bearing", *argv)
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("bkabem bearing: error: " + start), err


def test_a_bearing_without_a_bore_still_shows_its_multipliers(capsys):
    rc, out, _ = bkabem(capsys, "bearing", "NICE (MFPT)")
    assert rc == 0 and "not known (the bore is not published)" in out
    bpfo = float(next(x for x in out.splitlines() if x.strip().startswith("BPFO")).split()[-1])
    assert 25 * bpfo == pytest.approx(81.125, rel=0.005) and math.isfinite(bpfo)    # MFPT: BPFO 81.125 Hz at 25 Hz


@pytest.mark.parametrize("designation", ["62\x01", "6205" * 3000, "ünïcode", "nan", "0.0", "/C3", "C3", "(MFPT)",
                                         "6205 NSK (KAIST) 2RS", "6205//C3", "-6205", "6205-", "6205 NSK (KAIST)/C3"])
def test_hostile_designations_exit_0_or_2_with_one_line(capsys, designation):
    rc, out, err = bkabem(capsys, "bearing", "--json", "--", designation)
    assert (rc, err) == (0, "") or (rc == 2 and out == "" and err.count("\n") == 1), (rc, err[:200])
    if rc == 0:
        json.loads(out)
    assert "NSK" not in err or "suffix 'NSK'" in err                  # the whole word, not 'SK' after a snap ring 'N'
