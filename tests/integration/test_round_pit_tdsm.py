"""The time-domain reference (TDSM) against BKA-BEM for round pits: the same bridged drop in both models.

A CWRU-sized pit (21 mil, 11 mil deep) in the DE bearing of the fault-library motor, at 30 Hz: outer race at
6 o'clock (BPFO orders: the order comparison of ``validate``, tolerances of tests/integration/test_validation.py) and
inner race (a general line set: the line fit of ``validate_lines``, tolerances of tests/integration/test_hill.py).
"""

from __future__ import annotations

import pytest

from bkabem_core.model.case import Case

pytestmark = pytest.mark.tdsm

PIT = {"defects.0.shape": "round_pit", "defects.0.length_m": 21 * 25.4e-6, "defects.0.depth_m": 11 * 25.4e-6}


def test_tdsm_agrees_with_bkabem_for_a_round_pit_in_the_outer_race():
    """The five largest displacement orders of every location and direction: plain BKA-BEM within 3 dB, the improved
    method within 0.3 dB of the TDSM (displacement and acceleration), the same tolerances as for the slot."""
    from bkabem_core.reference.validation import validate

    case = Case.load("motor_6010_outer").with_overrides(PIT)
    assert case.bearing("de").defects[0].shape == "round_pit"
    r = validate(case, speed_hz=30.0, duration_s=0.05, improvement="hill", progress=False)
    assert r.max_error_db("plain").max() < 3.0, r.max_error_db("plain")
    for q in ("displacement", "acceleration"):
        err = r.max_error_db("hill", q)
        assert err.max() < 0.3, (q, err)


def test_tdsm_agrees_with_the_improved_method_for_a_round_pit_in_the_inner_race():
    """The TDSM record (0.5 s settled, 0.3 s) fitted at the line frequencies: the improved method's five largest
    lines of every location and direction within 0.5 dB, displacement and acceleration (test_hill.py's tolerance)."""
    from bkabem_core.reference.validation import validate_lines
    from bkabem_core.solve.harmonic import BkaBem
    from bkabem_core.solve.improved import HillCorrection

    case = Case.load("motor_6010_inner").with_overrides({**PIT, "excitation.max_order": 50})
    model = BkaBem(case, baseline=False)
    r = validate_lines(case, 30.0, duration_s=0.3, settle_s=0.5, plain=model, improved=HillCorrection(model))
    for q in ("displacement", "acceleration"):
        imp = r.max_error_db(q, "improved")
        assert imp.max() < 0.5, (q, imp, r.max_error_db(q))
    assert r.residual_fraction.max() < 0.05, r.residual_fraction
