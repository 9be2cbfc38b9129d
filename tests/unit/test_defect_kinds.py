"""The defect-kind protocol and its registry: every kind is one module, found by the registry, consistent with the
bearing kinematics, and asked (not named) by the case, scenario, data-set and message code.

Oracles: the textbook kinematics of a deep-groove ball bearing (BPFO = z FTF, BPFI = z (1 - FTF); the CWRU 6205
multipliers), the base phases each kind's torus grid must map back to, and drops recomputed at shifted phases.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import math
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import bkabem_core.bearing.defects as defects_package
from bkabem_core.bearing.deep_groove import Bearing, BearingGeometry, Dent, FaultFrequencies
from bkabem_core.bearing.defects.base import DefectProfile
from bkabem_core.bearing.defects.protocol import DefectKind
from bkabem_core.bearing.defects.registry import KINDS, find, kind, kinds, own_keys

INCH = 25.4e-3
TWO_PI = 2.0 * math.pi


def cwru_6205() -> BearingGeometry:
    return BearingGeometry("6205", 0.3126 * INCH, 1.537 * INCH, 9, diametral_clearance_m=15e-6)


def _dent(k: DefectKind, **kw) -> Dent:
    """A defect of kind ``k``, its own keys at their defaults."""
    own = k.dent_fields({o.name: o.default for o in k.own_keys})
    return Dent(length_m=kw.pop("length_m", 0.8e-3), depth_m=kw.pop("depth_m", 20e-6),
                angle_rad=kw.pop("angle_rad", 0.3), race=k.name, **own, **kw)


# --------------------------------------------------------------------------- the registry
def test_the_registry_holds_every_kind_module_of_the_package_once_in_order():
    found = []
    for info in pkgutil.iter_modules([str(Path(defects_package.__file__).parent)]):
        module = importlib.import_module(f"bkabem_core.bearing.defects.{info.name}")
        found += [obj.name for obj in vars(module).values()
                  if inspect.isclass(obj) and issubclass(obj, DefectKind) and not inspect.isabstract(obj)
                  and obj.__module__ == module.__name__]
    assert sorted(found) == sorted(KINDS) and len(set(found)) == len(found)
    orders = [k.order for k in kinds()]
    assert orders == sorted(orders) and len(set(orders)) == len(orders)
    assert tuple(k.name for k in kinds()) == KINDS
    # the textbook kinds, in the order their drops add (fixed: the samples depend on it bit for bit)
    assert [n for n in KINDS if n in ("outer", "inner", "ball")] == ["outer", "inner", "ball"]


def test_a_name_gives_its_kind_or_a_clear_refusal():
    for k in kinds():
        assert kind(k.name) is k and find(k.name) is k
    assert find("cage") is None
    with pytest.raises(ValueError, match=f"must be one of {', '.join(KINDS)} "):
        kind("cage")
    with pytest.raises(ValueError, match="race"):
        Dent(1e-3, 1e-5, 0.0, race="cage")


# --------------------------------------------------------------------------- the protocol, kind by kind
@pytest.mark.parametrize("name", KINDS)
def test_every_kind_fills_the_protocol(name):
    from bkabem_core.analysis.fault_lines import LINES

    k = kind(name)
    assert k.fault_frequency in {f.name for f in dataclasses.fields(FaultFrequencies)}
    assert k.line in LINES and set(k.envelope_lines) <= set(LINES) and k.envelope_lines[0] == k.line
    assert k.marked_harmonics[0] == 1 and list(k.marked_harmonics) == sorted(set(k.marked_harmonics))
    assert set(k.phases) <= {"shaft", "spin"}
    assert k.contacts and set(k.contacts) <= {"outer", "inner"}
    assert k.periodic == (not k.phases and not k.per_ball)
    assert k.place and k.adjective
    for key in k.own_keys:
        assert key.type in ("int", "float", "str") and key.doc
    if k.periodic:
        with pytest.raises(ValueError):
            k.torus(9, 64, 8)


def test_fault_frequencies_and_surface_rates_are_the_textbook_kinematics():
    """CWRU 6205 multipliers (published), and the rates the strikes come from: a pit on a race is passed by z balls
    per turn of that race relative to the cage (BPFO = z FTF, BPFI = z (1 - FTF)); a pit on a ball meets both races
    once per spin turn (2 x BSF)."""
    fm = Bearing(cwru_6205()).fault_multipliers()
    z = 9
    outer, inner, ball = kind("outer"), kind("inner"), kind("ball")
    assert outer.strike_multiplier(fm) == pytest.approx(3.5848, abs=2e-4)
    assert inner.strike_multiplier(fm) == pytest.approx(5.4152, abs=2e-4)
    assert ball.strike_multiplier(fm) == pytest.approx(2 * 2.3567, abs=4e-4)
    assert z * outer.surface_rate_per_hz(fm) == pytest.approx(fm.bpfo, rel=1e-12)
    assert z * inner.surface_rate_per_hz(fm) == pytest.approx(fm.bpfi, rel=1e-12)
    assert ball.surface_rate_per_hz(fm) == fm.bsf
    assert (outer.line, inner.line, ball.line) == ("BPFO", "BPFI", "2xBSF")
    assert ball.envelope_lines == ("2xBSF", "BSF")


@pytest.mark.parametrize("name", [k.name for k in kinds() if not k.periodic])
def test_a_moving_kinds_torus_grid_maps_back_to_its_own_angles(name):
    """Each grid point's base phases, through the phase map, give back (a, b) = 2 pi (i / n_fast, j / n_slow), and
    its ball-set position is the base table's row ``base_index`` (z theta_cage over one ball pitch)."""
    z, n_fast, n_slow = 9, 96, 12
    g = kind(name).torus(z, n_fast, n_slow)
    phases = np.stack([g.shaft, g.cage, g.spin, np.zeros_like(g.cage)], axis=-1)         # (n_fast, n_slow, 4)
    ab = phases @ g.phase_map.T
    i, j = np.meshgrid(np.arange(n_fast), np.arange(n_slow), indexing="ij")
    want = np.stack([TWO_PI * i / n_fast, TWO_PI * j / n_slow], axis=-1)
    assert np.allclose(np.remainder(ab - want + math.pi, TWO_PI) - math.pi, 0.0, atol=1e-9)
    row = np.remainder(z * g.cage / TWO_PI * n_fast, n_fast)
    assert np.allclose(np.remainder(row - g.base_index + n_fast / 2, n_fast) - n_fast / 2, 0.0, atol=1e-6)
    assert np.array_equal(kind(name).phase_map(z), g.phase_map)


@pytest.mark.parametrize("name", KINDS)
def test_the_drops_depend_on_the_phases_the_kind_names_and_no_other(name):
    """Shift each base phase the kind does not name: the drops of every ball do not move; shift one it names: they
    do (somewhere)."""
    k = kind(name)
    b = Bearing(cwru_6205(), defects=[_dent(k)])
    rng = np.random.default_rng(4)
    cage, shaft, spin = (rng.uniform(0, TWO_PI, 4000) for _ in range(3))
    beta = b.ball_angles_rad(cage)
    ref = b.defect_set.drop_m(beta, shaft, spin)
    assert ref.max() > 0.0
    shifted = {"shaft": (shaft + 0.7, spin), "spin": (shaft, spin + 0.7)}
    for phase, (sh, sp) in shifted.items():
        moved = b.defect_set.drop_m(beta, sh, sp)
        if phase in k.phases:
            assert np.abs(moved - ref).max() > 0.1 * ref.max(), phase
        else:
            assert np.array_equal(moved, ref), phase


@pytest.mark.parametrize("edge", ["ball", "cubic"])
@pytest.mark.parametrize("name", KINDS)
def test_a_profile_is_deepest_at_the_centre_and_zero_outside_the_pit(name, edge):
    k = kind(name)
    b = Bearing(cwru_6205())
    p = DefectProfile(_dent(k, edge=edge, edge_fraction=0.2), b.contact_geometry)
    a = p.half_angle_rad
    assert a == pytest.approx(0.8e-3 / (2 * k.surface_radius_m(b.contact_geometry)))
    rel = np.linspace(0.0, 2 * a, 401)
    for c in k.contacts:
        prof = p.drop_m(rel, c)
        assert 0.0 < prof[0] <= 20e-6                              # at most the depth
        assert np.all(np.diff(prof) <= 1e-18)                      # falls from the centre towards the edges
        assert np.all(prof[rel >= a] == 0.0)                       # nothing outside the pit
    assert p.depth_eff_m == pytest.approx(max(float(p.drop_m(0.0, c)) for c in k.contacts))
    assert 0.0 < p.entry_ramp_rad() <= a


# --------------------------------------------------------------------------- consumers ask the registry
def test_files_and_messages_take_the_registrys_kinds_and_keys():
    from bkabem_core.dataset.spec import MACHINE_PARAMETERS, PARAMETERS
    from bkabem_core.model.case import SCHEMA
    from bkabem_core.scenario import timeline
    from bkabem_ros.messages.convert import RACES

    assert SCHEMA["defects[]"]["race"][1][1] == set(KINDS)
    assert RACES == KINDS
    for key in own_keys():
        assert SCHEMA["defects[]"][key.name] == key.schema
        assert key.name in PARAMETERS and key.name in MACHINE_PARAMETERS
        assert key.name in timeline._DEFECT_KEYS


def test_words_of_a_kind():
    assert (kind("outer").place_of(), kind("outer").adjective_of(), kind("outer").label_of()) == \
        ("outer race", "outer-race", "outer")
    assert kind("inner").adjective_of({"ball": 3}) == "inner-race"
    assert (kind("ball").place_of({"ball": 3}), kind("ball").label_of({"ball": 3}), kind("ball").place_of()) == \
        ("ball 3", "ball 3", "ball")
