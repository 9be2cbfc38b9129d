"""The compact machine form ([machine], bkabem_core/model/compact.py): the same model as the hand-written FE of the
embedded motor, the expansion's rules, the FE bearing defaults, and bad input named by the compact keys."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case, CaseError

COMPACT_MOTOR = Path(__file__).resolve().parents[1] / "fixtures" / "electric_motor_6010_compact.toml"
STEEL = 7850.0


def compact_raw() -> dict:
    return tomllib.loads(COMPACT_MOTOR.read_text())


def natural_frequencies_hz(machine: Machine, below_hz: float) -> np.ndarray:
    """Undamped natural frequencies at standstill [Hz], from the assembled matrices (generalised eigenproblem)."""
    import scipy.linalg

    w2 = scipy.linalg.eigh(machine.rotor.K, machine.rotor.M, eigvals_only=True)
    f = np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)
    return f[f < below_hz]


def test_compact_motor_gives_the_hand_written_fe(case, machine):
    compact = Case.load(COMPACT_MOTOR)
    a, b = case.raw, compact.raw
    assert b["rotor"]["node_positions_m"] == a["rotor"]["node_positions_m"]          # the same 14 shaft nodes
    assert b["rotor"]["outer_diameters_m"] == a["rotor"]["outer_diameters_m"]
    assert b["rotor"]["inner_diameters_m"] == a["rotor"]["inner_diameters_m"]
    assert [(d["node"], d["mass_kg"]) for d in b["rotor"]["disks"]] == \
        [(d["node"], pytest.approx(d["mass_kg"], rel=1e-12)) for d in a["rotor"]["disks"]]
    assert b["housings"] == a["housings"]
    for name in ("de", "nde"):
        for key in ("rotor_node", "housing_node", "axial_load_n", "linearisation"):
            assert b["bearings"][name][key] == a["bearings"][name][key]
        assert compact.bearing_geometry(name) == case.bearing_geometry(name)
    assert b["operating"] == a["operating"] and b["excitation"] == a["excitation"] and b["baseline"] == a["baseline"]
    other = Machine(compact)
    assert other.mesh.pieces == machine.mesh.pieces and other.rotor.ndof == machine.rotor.ndof
    f_a = natural_frequencies_hz(machine, case.max_frequency_hz)
    f_b = natural_frequencies_hz(other, case.max_frequency_hz)
    assert len(f_a) == len(f_b) > 40
    elastic = f_a > 1.0
    assert np.max(np.abs(f_b[elastic] / f_a[elastic] - 1.0)) < 0.01


def test_compact_motor_gives_the_hand_written_spectra(case, model, cached_model):
    other = cached_model(Case.load(COMPACT_MOTOR))
    for speed in (25.0, 60.0):
        sa, sb = model.spectrum(speed), other.spectrum(speed)
        np.testing.assert_allclose(sb.frequency_hz, sa.frequency_hz, rtol=1e-12)
        a = np.abs(sa.acceleration[sa.in_band])
        b = np.abs(sb.acceleration[sb.in_band])
        for loc in range(a.shape[1]):
            for d in range(a.shape[2]):
                big = a[:, loc, d] > 1e-3 * a[:, loc, d].max()          # the lines within 60 dB of the largest
                db = 20.0 * np.log10(b[big, loc, d] / a[big, loc, d])
                assert big.sum() >= 10 and np.max(np.abs(db)) < 0.5, (speed, loc, d, np.max(np.abs(db)))


def test_every_number_written_out_is_the_same_case(case):
    """The compact form with the core as the hand-written seven disks and paper Table 1's FE bearing keys: the same
    resolved numbers, hence the same case hash."""
    raw = compact_raw()
    raw["case"]["name"] = case.name
    core = case.raw["rotor"]["disks"][1:]
    z = case.raw["rotor"]["node_positions_m"]
    raw["machine"]["disks"] = raw["machine"]["disks"][:1] + [
        {"name": d["name"], "position_m": z[d["node"] - 1], "mass_kg": d["mass_kg"],
         "polar_inertia_kg_m2": d["polar_inertia_kg_m2"], "diametral_inertia_kg_m2": d["diametral_inertia_kg_m2"]}
        for d in core]
    for name in ("de", "nde"):
        b = case.raw["bearings"][name]
        raw["machine"]["bearings"][name].update({k: v for k, v in b.items() if k.startswith("table_")})
    assert Case.from_dict(raw).case_hash == case.case_hash


def test_stack_keeps_mass_and_inertias_and_every_feature_is_a_node():
    raw = compact_raw()
    raw["baseline"] = {"misalignment_position_m": 0.7, "misalignment_force_n": 10.0}
    raw["machine"]["housings"]["de"] = {"mass_kg": 5.0, "support_stiffness_horizontal_n_m": 2.0e6}
    c = Case.from_dict(raw).raw
    z = c["rotor"]["node_positions_m"]
    assert z == [0.0, 0.04, 0.08, 0.16, 0.19, 0.3, 0.34, 0.38, 0.42, 0.46, 0.5, 0.54, 0.65, 0.7, 0.71]
    assert c["baseline"]["misalignment_node"] == z.index(0.7) + 1 and c["baseline"]["misalignment_force_n"] == 10.0
    stack = [d for d in c["rotor"]["disks"] if d["name"].startswith("core")]
    given = raw["machine"]["disks"][1]
    assert len(stack) == 7
    centre = given["position_m"]
    assert sum(d["mass_kg"] for d in stack) == pytest.approx(given["mass_kg"], rel=1e-12)
    assert sum(d["polar_inertia_kg_m2"] for d in stack) == pytest.approx(given["polar_inertia_kg_m2"], rel=1e-12)
    about_centre = sum(d["diametral_inertia_kg_m2"] + d["mass_kg"] * (z[d["node"] - 1] - centre) ** 2 for d in stack)
    assert about_centre == pytest.approx(given["diametral_inertia_kg_m2"], rel=1e-12)
    # element diameters: the step each element lies in; the NDE shaft end split by the coupling node
    assert c["rotor"]["outer_diameters_m"][-2:] == [0.045, 0.045]
    de, nde = c["housings"]
    assert (de["name"], de["node"], nde["name"], nde["node"]) == ("de", len(z) + 1, "nde", len(z) + 2)
    assert de["mass_kg"] == 5.0 and nde["mass_kg"] == 3.17
    assert de["support_stiffness_horizontal_n_m"] == 2.0e6 and de["support_stiffness_vertical_n_m"] == 1.0e6
    assert c["bearings"]["de"]["rotor_node"] == z.index(0.19) + 1 and c["bearings"]["de"]["housing_node"] == len(z) + 1


def test_defaults_follow_from_the_machine():
    raw = compact_raw()
    del raw["excitation"]
    for t in raw["machine"]["bearings"].values():
        del t["axial_load_n"]
    c = Case.from_dict(raw)
    steps = raw["machine"]["shaft_steps_m"]
    shaft = sum(STEEL * math.pi / 4.0 * d ** 2 * length for length, d in steps)
    rotor = shaft + sum(d["mass_kg"] for d in raw["machine"]["disks"])
    ex = c.raw["excitation"]
    assert ex["rotor_mass_kg"] == pytest.approx(rotor, rel=1e-12) and rotor == pytest.approx(82.0, abs=1e-3)
    assert (ex["housing_mass_kg"], ex["support_stiffness_n_m"], ex["support_damping_n_s_m"]) == (3.17, 1.0e6, 1.0e4)
    assert ex["max_order"] == 50 and ex["method"] == "quasi_static"
    assert c.raw["bearings"]["de"]["axial_load_n"] == 0.0 and c.raw["bearings"]["de"]["linearisation"] == "model"
    assert c.raw["defects"] == raw["defects"] and c.raw["rotor"]["elements_per_wavelength"] == 16.0


def test_fe_bearing_keys_are_the_bearing_models_linearisation():
    """table_* left out: the bearing model at the position's static load; switching to "table" changes nothing."""
    c = Case.load(COMPACT_MOTOR)
    m = Machine(c)
    weight = m.rotor.rotor_mass_kg * c.gravity_m_s2
    loads = {n: -s.radial_load_n[1] for n, s in m.sites.items()}
    assert sum(loads.values()) == pytest.approx(weight, rel=1e-9)
    for name, s in m.sites.items():
        b = c.raw["bearings"][name]
        assert b["table_stiffness_horizontal_n_m"] == pytest.approx(s.stiffness_n_m[0], rel=1e-6)
        assert b["table_stiffness_vertical_n_m"] == pytest.approx(s.stiffness_n_m[1], rel=1e-6)
        assert b["table_damping_vertical_n_s_m"] == 550.0
    table = Machine(c.with_overrides({"bearings.de.linearisation": "table", "bearings.nde.linearisation": "table"}))
    for name in ("de", "nde"):
        np.testing.assert_allclose(table.sites[name].stiffness_n_m, m.sites[name].stiffness_n_m, rtol=1e-6)


def _edit(path: str, value):
    """A change of the compact motor: ``path`` dotted (integers pick array items); value None deletes."""
    def apply(raw):
        *parts, last = path.split(".")
        node = raw
        for p in parts:
            node = node[int(p)] if p.isdigit() else node.setdefault(p, {})
        if value is None:
            del node[int(last) if last.isdigit() else last]
        else:
            node[int(last) if last.isdigit() else last] = value
        return raw
    return apply


BAD = [
    (_edit("machine.bearings.de.designation", "6299X"), "machine.bearings.de.designation", "unknown designation"),
    (lambda r: _edit("machine.bearings.nde.clearance_class", "C7")(_edit("machine.bearings.nde.diametral_clearance_m",
                                                                        None)(r)),
     "machine.bearings.nde.clearance_class", "must be one of"),
    (_edit("machine.bearings.nde", None), "machine.bearings.nde", "missing"),
    (_edit("machine.bearings", None), "machine.bearings", "missing"),
    (_edit("machine.shaft_steps_m", [[0.3, 0.05]]), "machine.bearings.nde.position_m", "beyond the shaft"),
    (_edit("machine.disks.0.mass_kg", -9.79), "machine.disks[0].mass_kg", "must be > 0"),
    (_edit("machine.disks.0.position_m", 0.9), "machine.disks[0].position_m", "not on the shaft"),
    (_edit("machine.shaft_steps_m.6", [0.060, 45.0]), "machine.shaft_steps_m", "a unit slip"),
    (_edit("machine.shaft_steps_m.6", [0.060, 0.045, 0.05]), "machine.shaft_steps_m[6]", "inner diameter"),
    (_edit("machine.bearings.nde.position_m", 0.19), "machine.bearings.nde.position_m", "both at 0.19 m"),
    (_edit("machine.disks.1.diametral_inertia_kg_m2", 0.1), "machine.disks[1].diametral_inertia_kg_m2",
     "less than the 7 slices"),
    (_edit("machine.disks.1.slices", None), "machine.disks[1].slices", "both length_m and slices"),
    (_edit("machine.speed_range_hz", [75.0, 5.0]), "machine.speed_range_hz", "below the highest"),
    (_edit("machine.rpm", 3000), "machine.rpm", "unknown key"),
    (_edit("machine.housings.support_stiffness_n_m", None), "machine.housings.support_stiffness_n_m", "missing"),
    (_edit("machine.bearings.de.damping_n_s_m", None), "machine.bearings.de.damping_n_s_m", "missing"),
    (_edit("machine.bearings.de.rotor_node", 5), "machine.bearings.de.rotor_node", "position_m"),
    (_edit("machine.bearings.de.linearisation", "table"), "machine.bearings.de.table_stiffness_horizontal_n_m",
     "missing"),
    (_edit("machine.bearings.de.n_balls", 40), "machine.bearings.de.n_balls", "do not fit"),
    (_edit("operating.max_speed_hz", 75.0), "operating", "give one of them"),
    (_edit("rotor.node_positions_m", [0.0, 1.0]), "rotor.node_positions_m", "machine.shaft_steps_m"),
    (_edit("baseline.misalignment_node", 3), "baseline.misalignment_node", "misalignment_position_m"),
    (_edit("case.schema_version", 3), "case.schema_version", "schema 4"),
]


@pytest.mark.parametrize("change,key,reason", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_bad_compact_input_names_the_compact_key(change, key, reason):
    with pytest.raises(CaseError) as info:
        Case.from_dict(change(compact_raw()), "motor.toml")
    assert info.value.key == key and reason in info.value.reason, (info.value.key, info.value.reason)
    assert str(info.value).startswith("motor.toml: ") and "\n" not in str(info.value)


def test_a_light_rotor_in_loose_bearings_rests_on_its_lowest_ball():
    """A 0.6 kg shaft in two 6203s with CN clearance and no preload: each bearing carries ~3 N on the one ball at
    its bottom, stiff along that ball's line only. The bearing model finds that equilibrium (Newton along the load
    where the tangent has no horizontal stiffness) and linearises it over the ball pitch: softer horizontally than
    vertically, both finite; a preload stiffens both."""
    raw = compact_raw()
    raw["machine"]["shaft_steps_m"] = [[0.02, 0.015], [0.012, 0.017], [0.2, 0.02], [0.012, 0.017]]
    raw["machine"]["disks"] = []
    raw["excitation"] = {}
    for name, z in (("de", 0.026), ("nde", 0.238)):
        raw["machine"]["bearings"][name] = {"position_m": z, "designation": "6203", "damping_n_s_m": 550.0}
    loose = Case.from_dict(raw, "light.toml")
    assert loose.raw["rotor"]["node_positions_m"][-1] == 0.244
    raw["machine"]["bearings"]["de"]["axial_load_n"] = raw["machine"]["bearings"]["nde"]["axial_load_n"] = 50.0
    preloaded = Case.from_dict(raw)
    for name in ("de", "nde"):
        kv, kh = (loose.raw["bearings"][name][f"table_stiffness_{d}_n_m"] for d in ("vertical", "horizontal"))
        assert np.isfinite(kv) and np.isfinite(kh) and 0.0 < kh < kv, (name, kv, kh)
        assert preloaded.raw["bearings"][name]["table_stiffness_horizontal_n_m"] > kh


def test_a_fleet_mixes_machines_each_with_its_own_truth(tmp_path):
    """A fleet scenario of three machines: the fault library's motor, the small motor on 6205s and a compact case
    file next to the fleet file; each machine of the plan runs its own, with its own bearings and fault lines."""
    from bkabem_core.scenario.fleet import FleetScenario
    from bkabem_ros.fleet import plan as fleet_plan
    from bkabem_ros.fleet.launcher import plan

    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "motor_compact.toml").write_text(COMPACT_MOTOR.read_text())
    (tmp_path / "mixed.toml").write_text("""
[fleet]
name = "machines"
schema_version = 1

[[fleet.machines]]
case = "motor_6010_outer"
labels = { machine = "motor_82kg" }

[[fleet.machines]]
case = "small_motor_6205_outer"
labels = { machine = "motor_6kg" }

[[fleet.machines]]
case = "cases/motor_compact.toml"
labels = { machine = "motor_compact" }
""")
    fleet = FleetScenario.load(tmp_path / "mixed.toml")
    machines = fleet_plan.apply(plan(6, [], 0, "machine_", None), fleet)
    cases = [Case.load(m["overrides"]["case"]) for m in machines]
    assert [c.name for c in cases] == ["motor_6010_outer", "small_motor_6205_outer",
                                       "electric_motor_6010_compact"] * 2
    assert [m["overrides"]["labels"].split(",")[1] for m in machines[:3]] == \
        ["machine=motor_82kg", "machine=motor_6kg", "machine=motor_compact"]
    truth = [c.ground_truth() for c in cases[:3]]
    assert [t["bearings"]["de"]["designation"] for t in truth] == ["6010", "6205", "6010"]
    assert [t["defects"][0]["bearing_designation"] for t in truth] == ["6010", "6205", "6010"]
    for c, t in zip(cases[:3], truth):
        g = c.bearing_geometry("de")
        bpfo = g.n_balls / 2.0 * (1.0 - g.ball_diameter_m / g.pitch_diameter_m)      # textbook, contact angle 0
        assert t["defects"][0]["fault_multiplier"] == pytest.approx(bpfo, rel=1e-12)
        assert c.kinematics(20.0)["de"]["bpfo"] == pytest.approx(20.0 * bpfo, rel=1e-12)
    assert truth[0]["fault_multipliers"]["bpfo"] != pytest.approx(truth[1]["fault_multipliers"]["bpfo"], rel=1e-3)
    assert cases[0].max_speed_hz == 75.0 and cases[1].max_speed_hz == 50.0
