"""Every line of the fault library's inner-race machine against the complex eigen-decomposition (the unit tier
checks the hardest lines and every tenth: tests/unit/test_linemodes.py)."""

import pytest
from linemodes_check import TOL, worst_error

from bkabem_core.fe.linemodes import LineModes
from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem

pytestmark = pytest.mark.slow


def test_line_modes_of_every_inner_race_line_match_the_complex_decomposition():
    """All 893 lines of the inner-race machine (multipliers 1-931), receptances within TOL at every speed up to
    the maximum."""
    m = BkaBem(Case.load("motor_6010_inner"), solver="block")
    nu = m.multipliers[m._locked_idx]
    fast = LineModes(m.basis, nu)
    assert fast.stats["method"] == "real+anchors" and fast.stats["refined"] > 0.6 * nu.size
    ref = LineModes(m.basis, nu, method="complex")
    assert worst_error(m.case, nu, fast, ref, range(nu.size)) <= TOL
