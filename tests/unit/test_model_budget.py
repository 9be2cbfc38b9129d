"""The model's size and cost from the case, refused before anything is allocated (issue 25, items 1, 6 and 7).

In-bounds case values that asked for an FE model nobody can compute: ``operating.max_sample_rate_hz = 1e6`` (the
bounds allow it) prepared for minutes at several GB, ``excitation.max_order = 1e9`` grew RSS by 85 MB/s, a density
of 1e308 admitted by ``[plausibility]`` ended in a 47-line traceback. Now each is one :class:`CaseError` naming the
key, in well under 2 s and without allocating the model; so are cases whose numbers are each fine but which
together have no answer (a stiffness of 1e30 that leaves the FE singular, a race covered with pits) and values
that used to be clamped or merged without a word.
"""

from __future__ import annotations

import copy
import resource
import time

import pytest

from bkabem_core.fe.budget import check_mesh, mesh_elements
from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case, CaseError

BASE = Case.load().raw


def _case(edit, plausibility=None) -> Case:
    raw = copy.deepcopy(BASE)
    edit(raw)
    if plausibility:
        raw["plausibility"] = plausibility
    return Case.from_dict(raw, "hostile.toml")


def _set(section, key, value):
    return lambda raw: raw[section].__setitem__(key, value)


def _refused(make, key: str, *fragments: str):
    """``make()`` raises CaseError naming ``key`` within 2 s and without growing the process by 200 MB."""
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    with pytest.raises(CaseError) as ei:
        make()
    elapsed = time.perf_counter() - t0
    grew_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
    assert ei.value.key == key, str(ei.value)
    text = str(ei.value)
    assert "\n" not in text and all(f in text for f in fragments), text
    assert elapsed < 2.0, f"refused after {elapsed:.2f} s"
    assert grew_mb < 200, f"grew by {grew_mb:.0f} MB before refusing"
    return text


def test_sample_rate_in_bounds_whose_mesh_is_too_big_is_refused_before_the_mesh():
    case = _case(_set("operating", "max_sample_rate_hz", 1.0e6))        # inside its bound [100, 1e6]
    text = _refused(lambda: Machine(case), "operating.max_sample_rate_hz", "1902 elements", "rotor.fe_elements")
    assert "more than 256" in text


def test_max_order_beyond_the_resolved_orders_is_refused_at_load():
    _refused(lambda: _case(_set("excitation", "max_order", 1_000_000_000)), "excitation.max_order",
             "1024 orders", "samples_per_ball_pass")


def test_high_max_order_within_resolution_names_max_order_for_the_mesh():
    case = _case(lambda raw: (raw["excitation"].update(max_order=1000),
                              raw["operating"].update(max_speed_hz=180.0)))   # the 6010s allow 183 Hz
    _refused(lambda: Machine(case), "excitation.max_order", "BPFO", "operating.max_speed_hz")


def test_absurd_density_admitted_by_an_override_is_counted_not_allocated():
    case = _case(_set("rotor", "density_kg_m3", 1e308), {"rotor.density_kg_m3": [1.0, 1e308]})
    assert mesh_elements(case.raw, case.max_frequency_hz, 16.0) > 1e100
    _refused(lambda: Machine(case), "rotor.density_kg_m3", "elements")


def test_the_mesh_bound_can_be_widened_and_the_default_case_is_within_it():
    assert mesh_elements(BASE, Case.load().max_frequency_hz, 16.0) == Machine(Case.load()).mesh.n_elements == 105
    case = _case(_set("operating", "max_sample_rate_hz", 1.45e5), {"rotor.fe_elements": [1, 300]})
    assert 256 < mesh_elements(case.raw, case.max_frequency_hz, 16.0) <= 300
    check_mesh(case)
    with pytest.raises(CaseError, match="rotor.fe_elements"):
        check_mesh(_case(_set("operating", "max_sample_rate_hz", 1.45e5)))


def test_torus_of_an_inner_race_defect_is_bounded():
    inner = Case.load("motor_6010_inner").raw

    def make():
        raw = copy.deepcopy(inner)
        raw["excitation"]["samples_per_ball_pass"] = 65536                # inside its bound [64, 65536]
        return Case.from_dict(raw, "inner.toml")

    _refused(make, "excitation.samples_per_ball_pass", "65536 x 64", "excitation.torus_samples")


def test_line_modes_cost_is_refused_before_the_decompositions(monkeypatch):
    from bkabem_core.fe import linemodes
    from bkabem_core.solve.harmonic import BkaBem

    def never(*a, **k):
        raise AssertionError("the line modes were started")

    monkeypatch.setattr(linemodes.LineModes, "__init__", never)
    case = _case(lambda raw: None, {"model.line_modes": [0.0, 1e6]})        # 50 lines x 64^3 = 1.3e7 > 1e6
    with pytest.raises(CaseError) as ei:
        BkaBem(case)
    assert "lines x modes^3" in str(ei.value) and "model.line_modes" in str(ei.value)


def test_support_stiffness_that_makes_the_fe_singular_is_named():
    def edit(raw):
        raw["housings"][0]["support_stiffness_vertical_n_m"] = 1e30

    case = _case(edit, {"housings[].support_stiffness_vertical_n_m": [1e3, 1e31]})
    _refused(lambda: Machine(case), "housings[0].support_stiffness_vertical_n_m", "numerically singular")


def _ring(n: int, length_m: float) -> list[dict]:
    d = dict(BASE["defects"][0])
    return [dict(d, length_m=length_m, angle_deg=-180.0 + i * 360.0 / n) for i in range(n)]


def test_overlapping_and_repeated_defects_are_refused():
    with pytest.raises(CaseError, match="the same defect as defects\\[0\\]") as ei:
        _case(lambda raw: raw.__setitem__("defects", [dict(BASE["defects"][0])] * 2000))
    assert ei.value.key == "defects[1]"
    with pytest.raises(CaseError, match="overlaps defects\\[0\\]"):
        _case(lambda raw: raw.__setitem__("defects", _ring(16, 15e-3)))


def test_defects_that_leave_no_equilibrium_are_the_cases_fault():
    case = _case(lambda raw: raw.__setitem__("defects", _ring(16, 14e-3)))   # each valid, none overlapping
    with pytest.raises(CaseError) as ei:
        Machine(case, mesh=None).excitation("de")
    assert ei.value.key == "defects" and "no static equilibrium" in str(ei.value)


def test_values_that_were_clamped_or_accepted_silently():
    with pytest.raises(CaseError) as ei:
        _case(_set("excitation", "rtol", 1e-300))
    assert ei.value.key == "excitation.rtol"
    with pytest.raises(CaseError) as ei:
        _case(_set("case", "name", "  "))
    assert ei.value.key == "case.name"
