"""The bkabem CLI: JSON contract field names, human tables, bad input -> one line on stderr, exit 2."""

import csv
import io
import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow

CLI = [sys.executable, "-m", "bkabem_ros"]


def run(*args, check=True):
    p = subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=300)
    if check and p.returncode != 0:
        raise AssertionError(f"rc={p.returncode}\n{p.stderr}")
    return p


def test_excitation_json_contract():
    d = json.loads(run("excitation", "--json").stdout)
    for key in ("bpfo_per_hz", "reference_speed_hz", "dc_m", "orders", "amplitude_m", "phase_rad",
                "peak_to_peak_m", "clearance_m"):
        assert key in d
    assert set(d["dc_m"]) == {"vertical", "horizontal"}
    assert len(d["amplitude_m"]["vertical"]) == len(d["orders"]) == len(d["phase_rad"]["horizontal"])
    assert d["orders"][0] == 1 and d["bpfo_per_hz"] == pytest.approx(6.0598, abs=1e-4)


def test_spectrum_json_contract_and_png(tmp_path):
    png = tmp_path / "s.png"
    d = json.loads(run("spectrum", "--speed-hz", "25", "--json", "--png", str(png)).stdout)
    for loc in ("de_rotor", "de_housing", "nde_rotor", "nde_housing"):
        for direction in ("vertical", "horizontal"):
            e = d[loc][direction]
            assert len(e["frequency_hz"]) == len(e["displacement_m"]) == len(e["acceleration_m_s2"]) \
                == len(e["phase_rad"])
    assert d["fault_frequencies_hz"]["bpfo"] == pytest.approx(25 * 6.059846, rel=1e-6)
    assert png.stat().st_size > 10_000


def test_sweep_csv_and_json(tmp_path):
    out = run("sweep", "--from-hz", "10", "--to-hz", "30", "--steps", "3", "--csv").stdout
    rows = list(csv.DictReader(io.StringIO(out)))
    assert {r["speed_hz"] for r in rows} == {"10", "20", "30"}
    assert set(rows[0]) == {"speed_hz", "order", "frequency_hz", "location", "direction", "displacement_m",
                            "acceleration_m_s2", "phase_rad", "line"}
    d = json.loads(run("sweep", "--from-hz", "10", "--to-hz", "30", "--steps", "3", "--json",
                       "--png", str(tmp_path / "w.png")).stdout)
    assert d["speeds_hz"] == [10.0, 20.0, 30.0]
    assert len(d["de_housing"]["vertical"]["rms_acceleration_m_s2"]) == 3
    assert (tmp_path / "w.png").exists()


def test_human_readable_tables():
    out = run("spectrum", "--speed-hz", "50").stdout
    assert "BPFO 302.992 Hz" in out and "de_housing" in out


@pytest.mark.parametrize("args, fragment", [
    (["spectrum", "--speed-hz", "nan"], "--speed-hz must be finite"),
    (["spectrum", "--speed-hz", "-3"], "--speed-hz must be >= 0"),
    (["spectrum", "--speed-hz", "fast"], "--speed-hz must be a number"),
    (["spectrum"], "--speed-hz"),
    (["sweep", "--from-hz", "10", "--to-hz", "5", "--steps", "3"], "--to-hz"),
    (["sweep", "--from-hz", "1", "--to-hz", "5", "--steps", "0"], "--steps must be >= 1"),
    (["sweep", "--from-hz", "1", "--to-hz", "5", "--steps", "3", "--json", "--csv"], "not allowed"),
    (["nonsense"], "invalid choice"),
    (["spectrum", "--speed-hz", "5", "--case", "/nonexistent.toml"], "file not found"),
])
def test_bad_arguments_one_line_exit_2(args, fragment):
    p = run(*args, check=False)
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert fragment in lines[0]


def test_bad_case_file_exit_2(tmp_path):
    bad = tmp_path / "bad.toml"
    from importlib import resources

    text = resources.files("bkabem_core.embedded").joinpath("cases", "electric_motor_6010.toml").read_text()
    bad.write_text(text.replace("depth_m = 50.0e-6", "depth_m = -50.0e-6"))
    p = run("excitation", "--case", str(bad), check=False)
    assert p.returncode == 2
    assert p.stderr.strip().count("\n") == 0 and "defects[0].depth_m" in p.stderr and "must be >= 0" in p.stderr


# --------------------------------------------------------------------------- a bearing of its own at each position
@pytest.mark.parametrize("old, new, key, fragment", [
    ('designation = "6010"', 'designation = "6299"', "bearings.de.designation", "unknown designation '6299'"),
    ("diametral_clearance_m = 0.059e-3", 'clearance_class = "C4"\nbore_diameter_m = 5.0e-3',
     "bearings.de.clearance_class", "no ISO 5753-1 value"),
    ("diametral_clearance_m = 0.059e-3", 'clearance_class = "C9"', "bearings.de.clearance_class", "must be one of"),
    ("[bearings.nde]", "[bearings.middle]", "bearings.middle", "unknown bearing"),
])
def test_bad_position_bearing_exit_2(tmp_path, old, new, key, fragment):
    from case_files import embedded_text

    bad = tmp_path / "bad.toml"
    bad.write_text(embedded_text().replace(old, new, 1))
    for cmd in (["spectrum", "--speed-hz", "20"], ["excitation"]):
        p = run(*cmd, "--case", str(bad), check=False)
        assert p.returncode == 2
        assert p.stderr.strip().count("\n") == 0 and key in p.stderr and fragment in p.stderr, p.stderr


def test_two_bearings_in_the_tables_and_json(tmp_path):
    """A 6205 DE and 6203 NDE: the spectrum table states each bearing's fault frequencies and which bearing each
    line follows; the JSON gives each bearing's; the excitation of every bearing has its own BPFO multiplier."""
    from case_files import textbook_multipliers, two_bearing_text

    from bkabem_core.model.case import Case

    f = tmp_path / "two.toml"
    f.write_text(two_bearing_text())
    case = Case.load(f)
    mult = {b: textbook_multipliers(case.bearing_table(b)) for b in ("de", "nde")}
    out = run("spectrum", "--case", str(f), "--speed-hz", "30").stdout
    assert f"DE bearing 6205: FTF {mult['de']['ftf'] * 30:.3f} Hz, BPFO {mult['de']['bpfo'] * 30:.3f} Hz" in out
    assert f"NDE bearing 6203: FTF {mult['nde']['ftf'] * 30:.3f} Hz, BPFO {mult['nde']['bpfo'] * 30:.3f} Hz" in out
    rows = [ln.split() for ln in out.splitlines() if ln.strip() and ln.split()[0].isdigit()]
    # each row: "k BPFO (DE|NDE) f ...": the line's name says whose BPFO it is an order of
    assert {r[2] for r in rows} == {"(DE)", "(NDE)"} and {r[1] for r in rows} == {"BPFO"}
    for r in rows:                                       # order k of its own bearing's BPFO
        b = r[2].strip("()").lower()
        assert float(r[3]) == pytest.approx(int(r[0]) * mult[b]["bpfo"] * 30, abs=0.006)
    d = json.loads(run("spectrum", "--case", str(f), "--speed-hz", "30", "--json").stdout)
    for b in ("de", "nde"):
        assert d["bearing_fault_frequencies_hz"][b]["bpfi"] == pytest.approx(mult[b]["bpfi"] * 30, rel=1e-9)
    assert set(d["line_bearings"]) == {"de", "nde"}
    e = json.loads(run("excitation", "--case", str(f), "--all-bearings", "--json").stdout)
    for b, des in (("de", "6205"), ("nde", "6203")):
        assert e["bearings"][b]["designation"] == des
        assert e["bearings"][b]["bpfo_per_hz"] == pytest.approx(mult[b]["bpfo"], rel=1e-12)
        assert e["bearings"][b]["fault_multipliers_per_shaft_hz"]["bsf"] == pytest.approx(mult[b]["bsf"], rel=1e-12)
    table = run("excitation", "--case", str(f), "--all-bearings").stdout
    assert f"DE bearing 6205, quasi-static" in table and f"BPFO {mult['nde']['bpfo']:.4f} x shaft Hz" in table
