"""A radial load applied at a bearing (``[bearings.*] applied_radial_load_n``) and the MFPT rig's twin (``mfpt_rig``,
docs/rigs.md) that needs it.

- The test bearing is MFPT's: its fault frequencies at 25 Hz are those MFPT publishes (BPFO 81.125 Hz, BPFI
  118.875 Hz).
- The static loads are the rig's weight and load, found three ways that must agree: by hand here (the lever rule
  on the FE's own masses, plus the load at its bearing), by the FE statics of the machine, and by the time-domain
  reference's nonlinear equilibrium.
- A scenario's load factor and a data set's ``load_factor`` scale the applied load with the weight; a data set's
  ``radial_load_n`` sets it.
- Bad input: each refused with its key.

The envelope analysis at every documented load is in tests/integration/test_mfpt_rig.py (it renders 14 runs).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case, CaseError

LBF_N = 4.4482216152605
#: MFPT's published fault frequencies at its 25 Hz shaft (data set description, E. Bechhoefer 2013) [Hz]; FTF and
#: BSF as the public data-set indexes quote its multipliers (0.406 and 2.555 x the shaft)
MFPT_AT_25_HZ = {"bpfo": 81.125, "bpfi": 118.875, "ftf": 0.406 * 25.0, "bsf": 2.555 * 25.0}


@pytest.fixture(scope="module")
def rig():
    return Case.load("mfpt_rig")


def _with(case: Case, load_n: float | None, **excitation) -> Case:
    raw = copy.deepcopy(case.raw)
    if load_n is None:
        raw["bearings"]["de"].pop("applied_radial_load_n", None)
    else:
        raw["bearings"]["de"]["applied_radial_load_n"] = load_n
    raw["excitation"].update(excitation)
    return Case.from_dict(raw, "test")


def test_the_test_bearing_has_mfpts_fault_frequencies(rig, cached_model):
    mult = cached_model(rig).bearing_multipliers["de"]
    for k, hz in MFPT_AT_25_HZ.items():
        assert abs(25.0 * getattr(mult, k) / hz - 1.0) < 0.005, (k, 25.0 * getattr(mult, k), hz)   # 0.5 %
    assert rig.applied_radial_load_n("de") == pytest.approx(270 * LBF_N, rel=1e-3)      # the baseline records' load


@pytest.mark.parametrize("name", ["mfpt_rig", "cwru_rig"])
def test_the_static_loads_are_the_weight_by_the_lever_rule_plus_the_applied_load(name):
    """By hand: the FE model's masses (its mass matrix's translational part, node by node) and the bearings'
    positions give each bearing's share of the weight; the applied load adds to its bearing alone (mfpt_rig's
    1201 N on the test bearing; cwru_rig has none: its dynamometer's load is a torque)."""
    from bkabem_core.fe.rotor import rotor_from_case

    rig = Case.load(name)
    rot = rotor_from_case(rig.raw, damping={})
    z = dict(zip(rot.shaft_node_labels, rig.raw["rotor"]["node_positions_m"]))
    g = rig.gravity_m_s2
    housings = {int(h["node"]) for h in rig.raw["housings"]}
    moment = weight = 0.0
    for n in rot.node_labels:
        if n in housings:
            continue                                    # the housings stand on their supports, not on the bearings
        i = rot.dof_index(n, "y")
        m = float(rot.M[i, [rot.dof_index(k, "y") for k in rot.node_labels]].sum())   # the row's translational mass
        weight += m * g
        moment += m * g * z[n]
    z_de, z_nde = (z[int(rig.raw["bearings"][b]["rotor_node"])] for b in ("de", "nde"))
    nde_share = (moment - weight * z_de) / (z_nde - z_de)
    expected = {"de": weight - nde_share + rig.applied_radial_load_n("de"), "nde": nde_share}

    machine = Machine(rig)
    from bkabem_core.model.compact import static_loads_n
    from bkabem_core.reference.tdsm import Tdsm

    lever = static_loads_n(rig.raw)
    tdsm = Tdsm(rig, 25.0, machine=machine).static_equilibrium()
    for b in ("de", "nde"):
        assert -machine.sites[b].radial_load_n[1] == pytest.approx(expected[b], rel=1e-6), b
        assert lever[b] == pytest.approx(expected[b], rel=1e-6), b
        assert tdsm.force_n[b][1] == pytest.approx(expected[b], rel=1e-6), b
        assert machine.excitation_load_n(b) == pytest.approx(expected[b], rel=1e-6), b
    if name == "mfpt_rig":
        assert expected["de"] > 1200.0 and 0.0 < expected["nde"] < 10.0
    else:                                       # a 6.1 kg rotor: 31.5 N (DE) and 28.3 N (fan end), docs/rigs.md
        assert expected["de"] + expected["nde"] == pytest.approx(weight) and 25.0 < expected["nde"] < expected["de"]


def test_the_applied_load_loads_the_excitation_and_stiffens_the_bearing(rig):
    light, heavy = Machine(_with(rig, 25 * LBF_N)), Machine(_with(rig, 300 * LBF_N))
    assert heavy.excitation_load_n("de") - light.excitation_load_n("de") == pytest.approx(275 * LBF_N, rel=1e-9)
    assert heavy.excitation_load_n("nde") == pytest.approx(light.excitation_load_n("nde"), rel=1e-12)
    assert heavy.sites["de"].stiffness_n_m[1] > 1.5 * light.sites["de"].stiffness_n_m[1]      # Hertz: k ~ W^(1/3)
    assert Machine.fe_key(_with(rig, 25 * LBF_N)) != Machine.fe_key(_with(rig, 300 * LBF_N))


def test_no_applied_load_is_the_key_left_out(rig):
    a, b = _with(rig, None), _with(rig, 0.0)
    assert a.applied_radial_load_n("de") == 0.0
    assert Machine(a).excitation_load_n("de") == pytest.approx(Machine(b).excitation_load_n("de"), rel=1e-12)


def test_a_light_load_on_one_ball_has_an_equilibrium(rig):
    """Without the loader the test bearing carries ~8 N: one ball at the bottom, stiff along its own line only. The
    static solution and the quasi-static path follow the load's direction there (an inner-race pit passing it)."""
    from bkabem_core.excitation.path import quasi_static_path_m

    case = _with(rig, 0.0)
    m = Machine(case)
    site = m.sites["de"]
    assert 0.0 < -site.radial_load_n[1] < 10.0
    raw = copy.deepcopy(case.raw)
    raw["defects"] = [{"bearing": "de", "race": "inner", "length_m": 0.5e-3, "depth_m": 0.28e-3, "angle_deg": -90.0,
                       "edge": "ball", "shape": "round_pit", "edge_fraction": 0.1}]
    pitted = Case.from_dict(raw, "pit")
    bearing = Machine(pitted).sites["de"].bearing
    theta = np.linspace(0.0, 2 * np.pi / 8, 64)
    path, _, _ = quasi_static_path_m(bearing, site.radial_load_n, 0.0, theta, shaft_angles_rad=-theta * 1.5)
    assert np.all(np.isfinite(path)) and np.all(path[:, 1] < 0.0)


@pytest.mark.parametrize("load_factor", [0.5, 2.0])
def test_a_scenario_load_factor_scales_the_applied_load_with_the_weight(rig, load_factor):
    from scenario_files import scenario_toml

    from bkabem_core.scenario.timeline import Scenario

    text = scenario_toml("load", duration_s=4.0, case="mfpt_rig", speed=([0.0], [25.0]))
    text += f"\n[load]\ntime_s = [0.0, 2.0]\nload_factor = [1.0, {load_factor}]\n"
    sc = Scenario.from_toml(text, "load.toml")
    before, after = sc.state_at(1.0).case, sc.state_at(3.0).case
    assert after.applied_radial_load_n("de") == pytest.approx(load_factor * before.applied_radial_load_n("de"))
    assert after.gravity_m_s2 == pytest.approx(load_factor * before.gravity_m_s2)
    load_before, load_after = (Machine(c).excitation_load_n("de") for c in (before, after))
    assert load_after == pytest.approx(load_factor * load_before)


def _spec(run: str, grid: str = "", case: str = "mfpt_rig"):
    from bkabem_core.dataset.spec import DatasetSpec

    text = (f'[dataset]\nname = "m"\nschema_version = 1\ncase = "{case}"\nsampling = "grid"\n\n[run]\n'
            f'speed_hz = 25.0\n{run}\n' + (f"\n[grid]\n{grid}\n" if grid else ""))
    return DatasetSpec.from_toml(text, "m.toml")


def test_a_data_set_sets_the_rigs_radial_load_per_run():
    lbf = [0, 25, 50, 100, 150, 200, 250, 300]
    spec = _spec('fault = "inner"\nshape = "round_pit"\nedge = "ball"\nlength_m = 5e-4\ndepth_m = 2.8e-4',
                 f"radial_load_n = {[x * LBF_N for x in lbf]}")
    loads = [r.case_raw["bearings"]["de"]["applied_radial_load_n"] for r in spec.runs]
    assert loads == pytest.approx([x * LBF_N for x in lbf])
    assert [r.params["radial_load_n"] for r in spec.runs] == pytest.approx(loads)
    assert all(r.case_raw["bearings"]["nde"].get("applied_radial_load_n", 0.0) == 0.0 for r in spec.runs)
    scaled = _spec("load_factor = 2.0").runs[0].case_raw["bearings"]["de"]["applied_radial_load_n"]
    assert scaled == pytest.approx(2 * 270 * LBF_N, rel=1e-3)


@pytest.mark.parametrize("run, case, key, words", [
    ("radial_load_n = 500.0", "cwru_rig", "run.radial_load_n", "none of cwru_rig's bearings"),
    ("radial_load_n = 500.0\nload_factor = 2.0", "mfpt_rig", "run.radial_load_n", "not both"),
    ("radial_load_n = -1.0", "mfpt_rig", "run.radial_load_n", ">= 0"),
    ("radial_load_n = 5000.0", "mfpt_rig", "run.radial_load_n", "static load rating"),
])
def test_a_bad_radial_load_in_a_data_set_is_refused_with_its_key(run, case, key, words):
    from bkabem_core.dataset.spec import DatasetSpecError

    with pytest.raises(DatasetSpecError) as exc:
        _spec(run, case=case)
    assert key in str(exc.value) and words in str(exc.value), str(exc.value)


@pytest.mark.parametrize("value, excitation, key, words", [
    (-5.0, {}, "bearings.de.applied_radial_load_n", ">= 0"),
    ("heavy", {}, "bearings.de.applied_radial_load_n", "number"),
    (5000.0, {}, "bearings.de.applied_radial_load_n", "static load rating"),
    (100.0, {"load": "rotor_weight"}, "bearings.de.applied_radial_load_n", "fe_share"),
])
def test_a_bad_applied_load_in_a_case_is_refused_with_its_key(rig, value, excitation, key, words):
    raw = copy.deepcopy(rig.raw)
    raw["bearings"]["de"]["applied_radial_load_n"] = value
    raw["excitation"].update(excitation)
    with pytest.raises(CaseError) as exc:
        Case.from_dict(raw, "bad")
    assert exc.value.key == key and words in str(exc.value), str(exc.value)
