"""The line modes of the fault library's inner-race and ball machines against the complex eigen-decomposition:
every inner-race line of a fresh model, and the hardest lines and every tenth of the library's own (the unit tier,
tests/unit/test_linemodes.py, checks the form on the embedded machine and the fall-back)."""

import pytest
from linemodes_check import TOL, hardest_lines, worst_error

from bkabem_core.fe.linemodes import LineModes
from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem

pytestmark = pytest.mark.slow


def test_line_modes_of_every_inner_race_line_match_the_complex_decomposition():
    """All 893 lines of the inner-race machine (multipliers 1-931), receptances within TOL at every speed up to
    the maximum."""
    m = BkaBem(Case.load("motor_6010_inner"), solver="block")
    nu = m.multipliers[m.speed_locked_index]
    fast = LineModes(m.basis, nu)
    assert fast.stats["method"] == "real+anchors" and fast.stats["refined"] > 0.6 * nu.size
    ref = LineModes(m.basis, nu, method="complex")
    assert worst_error(m.case, nu, fast, ref, range(nu.size)) <= TOL


def test_line_modes_of_the_inner_race_lines_match_the_complex_decomposition(fault_library):
    """The inner-race machine's 893 lines (multipliers 1-931): the real form with anchors and refinement against
    the complex state matrix of each line, receptances within TOL at every speed up to the maximum, on the refined
    lines farthest from their anchors and every tenth line (all lines of a fresh model: the test above)."""
    m = fault_library["inner"]
    nu = m.multipliers[m.speed_locked_index]
    fast = LineModes(m.basis, nu)              # afresh: the library model's own was extended from another's
    assert fast.stats["method"] == "real+anchors"
    assert fast.stats["refined"] > 0.6 * nu.size                 # the refinement is what is being tested
    pick = hardest_lines(nu)
    ref = LineModes(m.basis, nu[pick], method="complex")
    assert worst_error(m.case, nu[pick], fast.subset(pick), ref, range(pick.size)) <= TOL


def test_line_modes_of_the_ball_lines_match_the_complex_decomposition(fault_library):
    """The ball machine's 1813 lines (FTF-spaced sidebands: groups of up to 60 lines per anchor): the refined
    lines farthest from their anchors and every tenth line, within TOL."""
    m = fault_library["ball"]
    nu = m.multipliers[m.speed_locked_index]
    fast = LineModes(m.basis, nu)
    pick = hardest_lines(nu)
    ref = LineModes(m.basis, nu[pick], method="complex")
    assert worst_error(m.case, nu[pick], fast.subset(pick), ref, range(pick.size)) <= TOL
