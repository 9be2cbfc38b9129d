"""Data-set specs: bad specs named by key with one line, hostile values, the embedded specs."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from bkabem_core.dataset.spec import DatasetSpec
from bkabem_core.model.case import Case


def _spec(tmp_path: Path, text: str, name: str = "spec.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# --------------------------------------------------------------------------- bad specs
BAD = [
    ("[dataset]\nname='x'\nschema_version=1\nbogus=1\n", "dataset.bogus", "unknown key"),
    ("[dataset]\nname='x'\nschema_version=2\n", "dataset.schema_version", "must be 1"),
    ("[dataset]\nschema_version=1\n", "dataset.name", "missing"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nspeed_hz=[10.0, -5.0]\n", "grid.speed_hz[1]", "> 0"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nspeed_hz=[500.0]\n", "grid.speed_hz[0]", "max_speed_hz"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nfault=['outer', 'crack']\n", "grid.fault[1]", "outer, inner"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nfault='outer'\ndepth_m=nan\n", "run.depth_m", "finite"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nfault='inner'\nlength_m=0.015\n", "run.length_m", "ball pitch"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nslip=0.5\n", "run.slip", "<= 0.1"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nquantities=['acceleration','pressure']\n", "run.quantities",
     "unknown quantity"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nspeed_hz=20.0\nprofile='ramp:0:30:1'\n", "run.profile",
     "not both"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nprofile='ramp:0:30'\n", "run.profile", "three values"),
    ("[dataset]\nname='x'\nschema_version=1\n[random]\nslip=[0.0]\n", "random", "only with dataset.sampling"),
    ("[dataset]\nname='x'\nschema_version=1\nsampling='random'\n", "dataset.runs", "missing"),
    ("[dataset]\nname='x'\nschema_version=1\nsampling='random'\nruns=3\n[random]\nslip={min=0.02, max=0.01}\n",
     "random.slip.max", ">= min"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nscenario='de_outer_run_to_failure'\nfault='outer'\n",
     "run.fault", "not with a scenario"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nscenario='nope'\n", "run.scenario", "no embedded scenario"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\ntime_scale=10.0\n", "run.time_scale", "only with a scenario"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nfault='ball'\nball=15\n", "run.ball", "1..14"),
    ("[dataset]\nname='x'\nschema_version=1\n[grid]\nslip=0.01\n", "grid.slip", "non-empty list"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nload_factor=0.01\n", "run.load_factor", ">= 0.1"),
    ("[dataset]\nname='x'\nschema_version=1\ncase='no_such_case'\n", "dataset.case", "no embedded case"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nload_hp=1.0\n", "run.load_hp", "no load table"),
    ("[dataset]\nname='x'\nschema_version=1\ncase='cwru_rig'\n[grid]\nload_hp=[0.0, 3.5]\n", "grid.load_hp[1]",
     "outside the case's load table (0 .. 3 hp)"),
    ("[dataset]\nname='x'\nschema_version=1\ncase='cwru_rig'\n[run]\nload_hp=-1.0\n", "run.load_hp", ">= 0"),
    ("[dataset]\nname='x'\nschema_version=1\n[run]\nscenario='de_outer_run_to_failure'\nload_hp=1.0\n",
     "run.load_hp", "not with a scenario"),
    ("[dataset\nname='x'\n", "toml", "not valid TOML"),
]


def _main(argv, capsys) -> tuple[int, str, str]:
    from bkabem_ros.cli.main import main

    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


@pytest.mark.parametrize("text,key,reason", BAD, ids=[b[1] for b in BAD])
def test_bad_spec_exit_2_one_line_naming_the_key(tmp_path, capsys, text, key, reason):
    p = _spec(tmp_path, text)
    rc, out, err = _main(["dataset", str(p), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert err.startswith("bkabem dataset: error: ") and f"{key}:" in err and reason in err, err
    assert not (tmp_path / "o").exists()                                 # nothing written


HOSTILE = [0, -1, 1e300, float("nan"), float("inf"), "x", "", True, [], {}, [1, "a"], {"min": "a"}]


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if math.isinf(v) else repr(v))
    if isinstance(v, str):
        return repr(v).replace("'", '"')
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return str(v)


def test_fuzz_every_key_with_hostile_values_exit_0_or_2_with_one_line(tmp_path, capsys):
    """Every key of the embedded example spec (and of a random-sampling variant) set to each hostile value:
    ``--list`` (the whole validation, no rendering) exits 0 or 2 with one line naming the key, never 1."""
    from bkabem_core.dataset.spec import PARAMETERS

    sections = {"dataset": {"name": '"f"', "schema_version": "1", "seed": "1"},
                "run": {k: None for k in ("duration_s", "slip", "noise_acc", "depth_m", "quantities", "ball",
                                          "anti_alias", "accelerometer", "profile", "edge")},
                "grid": {"fault": None, "speed_hz": None, "load_factor": None}}
    n = rc2 = 0
    for sec, keys in sections.items():
        for key in keys:
            for v in HOSTILE:
                lines = {s: {} for s in sections}
                lines["grid"]["fault"] = '["outer"]'
                lines["dataset"].update(sections["dataset"])
                if sec == "grid":
                    lines[sec][key] = _toml_value([v])
                else:
                    lines[sec][key] = _toml_value(v)
                text = "\n".join(f"[{s}]\n" + "\n".join(f"{k} = {x}" for k, x in kv.items())
                                 for s, kv in lines.items())
                p = _spec(tmp_path, text)
                rc, out, err = _main(["dataset", str(p), "--list"], capsys)
                n += 1
                assert rc in (0, 2), (text, err)
                if rc == 2:
                    rc2 += 1
                    assert len(err.strip().splitlines()) == 1 and f"{sec}.{key}" in err, (text, err)
                else:
                    assert "runs, spec hash" in out
    assert n > 150 and rc2 > 0.8 * n
    assert set(sections["run"]) <= set(PARAMETERS)


# --------------------------------------------------------------------------- scenarios and MCAP


def test_embedded_specs_load_and_list(capsys):
    from bkabem_core.dataset.spec import embedded_specs

    assert {"dataset_example", "dataset_run_to_failure"} <= set(embedded_specs())
    ex = DatasetSpec.load("dataset_example")
    assert len(ex.runs) == 8 and sum(r.params["duration_s"] for r in ex.runs) == 8.0
    assert [r.params["fault"] for r in ex.runs[::2]] == ["healthy", "outer", "inner", "ball"]
    # the faulty runs' bearing rolls as rough as the fault library's cases say; a healthy run has no defect to carry it
    library = {k: Case.load(f"motor_6010_{k}").raw["defects"][0]["roughness_db"] for k in ("outer", "inner", "ball")}
    for r in ex.runs:
        d = r.case_raw["defects"]
        assert (d == []) if r.params["fault"] == "healthy" else (d[0]["roughness_db"] == library[r.params["fault"]])
    rtf = DatasetSpec.load("dataset_run_to_failure")
    assert len(rtf.runs) == 3 and len({r.params["seed"] for r in rtf.runs}) == 3 and rtf.runs[0].is_scenario
    mfpt = DatasetSpec.load("mfpt_rig_loads")                  # MFPT's loads, 0-300 lbf, on the test bearing
    loads_lbf = sorted({round(r.case_raw["bearings"]["de"]["applied_radial_load_n"] / 4.4482216) for r in mfpt.runs})
    assert len(mfpt.runs) == 27 and loads_lbf == [0, 25, 50, 100, 150, 200, 250, 270, 300]
    assert {r.params["sample_rate_hz"] for r in mfpt.runs} == {48828.125}              # the case's acquisition
    rc, out, err = _main(["dataset", "dataset_example", "--list"], capsys)
    assert rc == 0 and out.strip().splitlines()[-1] == f"8 runs, spec hash {ex.spec_hash}"


def test_a_rigs_load_sets_the_speed_of_its_table():
    """cwru_rig's dynamometer: 0-3 hp at the documented 1797, 1772, 1750, 1730 r/min, linear between them; the
    label carries the load. Without load_hp the runs keep their speed; with both, the speed given is the speed."""
    text = ("[dataset]\nname='loads'\nschema_version=1\ncase='cwru_rig'\n[run]\nfault='outer'\n"
            "length_m=0.1778e-3\ndepth_m=0.2794e-3\nshape='round_pit'\nedge='ball'\n"
            "[grid]\nload_hp=[0.0, 1.0, 2.0, 3.0, 0.5]\n")
    spec = DatasetSpec.from_toml(text, "loads.toml")
    rpm = [r.params["speed_hz"] * 60.0 for r in spec.runs]
    assert [r.params["load_hp"] for r in spec.runs] == [0.0, 1.0, 2.0, 3.0, 0.5]
    assert rpm == pytest.approx([1797.0, 1772.0, 1750.0, 1730.0, 1784.5], abs=1e-3)
    assert len({r.run_hash for r in spec.runs}) == 5
    plain = DatasetSpec.from_toml("[dataset]\nname='s'\nschema_version=1\ncase='cwru_rig'\n[run]\nspeed_hz=29.0\n")
    assert plain.runs[0].params["load_hp"] is None and plain.runs[0].params["speed_hz"] == 29.0
    # a record's measured speed at its load: the speed given, the load its label (still within the table)
    measured = DatasetSpec.from_toml("[dataset]\nname='m'\nschema_version=1\ncase='cwru_rig'\n[run]\n"
                                     "speed_hz=29.6\nload_hp=1.0\n")
    assert measured.runs[0].params["speed_hz"] == 29.6 and measured.runs[0].params["load_hp"] == 1.0

