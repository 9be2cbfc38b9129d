"""Issue 14, item 8: physical plausibility bounds per case key catch unit slips (main accepted them all and
computed plausible-looking nonsense); an explicit ``[plausibility]`` table widens a bound; bounds of keys a case
does not have are skipped."""

from __future__ import annotations

import copy
import re

import pytest

from bkabem_core.model import plausibility
from bkabem_core.model.case import Case, CaseError

BASE = Case.load().raw


def _with(path: str, value, raw=None):
    raw = copy.deepcopy(BASE if raw is None else raw)
    node = raw
    parts = re.findall(r"[^.\[\]]+|\[\d+\]", path)
    for p in parts[:-1]:
        node = node[int(p[1:-1])] if p.startswith("[") else node[p]
    last = parts[-1]
    if isinstance(value, str) and value.startswith("*"):        # "*1000": scale the existing value
        f = float(value[1:])
        old = node[last]
        value = [v * f for v in old] if isinstance(old, list) else type(old)(old * f)
    node[last] = value
    return raw


@pytest.mark.parametrize("path, value, named", [
    ("bearings.de.ball_diameter_m", "*1000", "bearings.de."),          # mm written as m (a cross-check or bound)
    ("bearings.nde.n_balls", 1000, "bearings.nde.n_balls"),             # each position's bearing has its bounds
    ("rotor.outer_diameters_m", "*1000", "rotor.outer_diameters_m"),
    ("rotor.node_positions_m", "*1000", "rotor.node_positions_m"),
    ("operating.max_speed_hz", "*60", "operating.max_speed_hz"),        # rpm written as Hz
    ("bearings.de.table_stiffness_vertical_n_m", 1e30, "bearings.de.table_stiffness_vertical_n_m"),
    ("bearings.nde.axial_load_n", "*1000", "bearings.nde.axial_load_n"),                # kN written as N
    ("operating.max_sample_rate_hz", 1e30, "operating.max_sample_rate_hz"),
    ("housings.[1].support_stiffness_horizontal_n_m", 1e30, "housings[1].support_stiffness_horizontal_n_m"),
    ("defects.[0].depth_m", 1e300, "defects[0].depth_m"),
    ("defects.[0].depth_m", "*1000", "defects[0].depth_m"),            # 50 mm deep
    ("defects.[0].length_m", "*1000", "defects[0].length_m"),          # 2 m long
    ("baseline.unbalance_grade_mm_s", 1e6, "baseline.unbalance_grade_mm_s"),
    ("baseline.line_frequency_hz", "*1000", "baseline.line_frequency_hz"),
    ("rotor.density_kg_m3", 1e308, "rotor.density_kg_m3"),
    ("rotor.disks.[3].mass_kg", 1e300, "rotor.disks[3].mass_kg"),
    ("excitation.gravity_m_s2", 0.0, "excitation.gravity_m_s2"),
    ("excitation.rotor_mass_kg", 1e-300, "excitation.rotor_mass_kg"),
    ("excitation.reference_speed_hz", 1e-300, "excitation.reference_speed_hz"),
    ("bearings.de.youngs_modulus_pa", "*1e-9", "bearings.de.youngs_modulus_pa"),   # GPa written as Pa
    ("excitation.settle_time_s", 1e9, "excitation.settle_time_s"),
    ("excitation.record_cage_periods", 1_000_000, "excitation.record_cage_periods"),
    ("excitation.samples_per_ball_pass", 1_000_000_000, "excitation.samples_per_ball_pass"),
])
def test_unit_slips_and_absurd_values_are_named(path, value, named):
    with pytest.raises(CaseError) as ei:
        Case.from_dict(_with(path.replace(".[", "["), value), "slip.toml")
    assert ei.value.key.startswith(named), (ei.value.key, str(ei.value))


def test_the_cost_limits_catch_combinations():
    # each value inside its own bound, the product too large: 64 periods x 14 balls x 65536 samples
    raw = _with("excitation.record_cage_periods", 64)
    raw = _with("excitation.samples_per_ball_pass", 65536, raw)
    with pytest.raises(CaseError, match="recorded samples"):
        Case.from_dict(raw)
    raw = _with("excitation.settle_time_s", 60.0, _with("excitation.reference_speed_hz", 50.0))
    with pytest.raises(CaseError, match="ball passes to integrate"):
        Case.from_dict(raw)


def test_embedded_case_and_an_explicit_override_pass():
    Case.load()
    raw = _with("rotor.density_kg_m3", 30000.0)
    with pytest.raises(CaseError, match="rotor.density_kg_m3"):
        Case.from_dict(raw)
    raw[plausibility.SECTION] = {"rotor.density_kg_m3": [500.0, 40000.0]}
    case = Case.from_dict(raw)
    assert case.raw["rotor"]["density_kg_m3"] == 30000.0
    # the override travels with the case (with_overrides re-validates)
    assert case.with_overrides({"dent.depth_m": 1e-5}).raw["rotor"]["density_kg_m3"] == 30000.0
    raw = _with("excitation.settle_time_s", 60.0, _with("excitation.reference_speed_hz", 50.0))
    raw[plausibility.SECTION] = {"excitation.ball_passes": [0, 1e6]}
    Case.from_dict(raw)


@pytest.mark.parametrize("override, fragment", [
    ({"rotor.densty_kg_m3": [1, 2]}, "no plausibility bound of that name"),
    ({"rotor.density_kg_m3": [2, 1]}, "low <= high"),
    ({"rotor.density_kg_m3": "off"}, "[low, high]"),
    ("all", "must be a table"),
])
def test_bad_overrides_are_errors(override, fragment):
    raw = copy.deepcopy(BASE)
    raw[plausibility.SECTION] = override
    with pytest.raises(CaseError, match=re.escape(fragment)):
        Case.from_dict(raw)


def test_bounds_of_missing_keys_are_skipped():
    raw = copy.deepcopy(BASE)
    del raw["rotor"]["density_kg_m3"]
    del raw["excitation"]
    raw["rotor"]["disks"] = []
    assert plausibility.problem(raw) is None
    assert plausibility.cost_problem(raw) is None


def test_toml_override_in_a_case_file(tmp_path):
    from importlib import resources

    text = resources.files("bkabem_core.embedded").joinpath("cases", "electric_motor_6010.toml").read_text()
    text = text.replace("density_kg_m3 = 7850.0", "density_kg_m3 = 30000.0")
    with pytest.raises(CaseError, match="rotor.density_kg_m3"):
        Case.from_toml(text)
    Case.from_toml(text + '\n[plausibility]\n"rotor.density_kg_m3" = [500.0, 40000.0]\n')
