"""The line modes (bkabem_core.fe.linemodes): the real plane-rotated form and the anchored refinement against the
complex eigen-decomposition of every line (the fault library's inner-race and ball line sets against it:
tests/integration/test_linemodes_all.py)."""

import numpy as np
from linemodes_check import TOL, worst_error

from bkabem_core.fe.linemodes import LineModes
from bkabem_core.fe.modal import ModalBasis, plane_mask


def test_the_fe_separates_into_two_planes_and_the_plane_basis_spans_the_same_model(model):
    """Bearing elements have no cross stiffness: K, M, C do not couple (x, beta) with (y, alpha), G couples only
    them. The basis made plane by plane gives the receptances of the mixed one (direct solves) to round-off."""
    rotor = model.rotor
    ym = plane_mask(rotor)
    assert ym is not None and ym.sum() == rotor.ndof // 2
    b = model.basis
    assert b.planes is not None and 0 < b.planes.sum() < b.size
    for a in (b.K, b.M, b.C):
        assert np.abs(a[np.ix_(b.planes, ~b.planes)]).max() <= 1e-12 * np.abs(a).max()
    assert np.abs(b.G[np.ix_(b.planes, b.planes)]).max() <= 1e-12 * np.abs(b.G).max()

    class Mixed:                                  # the same FE, without DOF names: the mixed basis of before
        M, K, C, G = rotor.M, rotor.K, rotor.C, rotor.G

    mixed = ModalBasis(Mixed, model._p, model._out_dofs.reshape(-1), b.cutoff_hz)
    assert mixed.planes is None and mixed.size == b.size
    for f, nu in ((3.0, 6.06), (40.0, 60.6), (75.0, 303.0)):
        w, big = np.array([2 * np.pi * nu * f]), np.array([2 * np.pi * f])
        h1, h2 = b.solve_unit(w, big), mixed.solve_unit(w, big)
        assert np.abs(h1 - h2).max() <= 1e-8 * np.abs(h2).max()


def test_a_refinement_too_far_from_its_anchor_falls_back_to_the_exact_decomposition(fault_library):
    """Groups 20 times too wide: some lines do not converge from their anchor; they are decomposed exactly and
    become the next anchors, and every line is still right."""
    m = fault_library["inner"]
    nu = np.sort(m.multipliers[m.speed_locked_index])[::12]
    fast = LineModes(m.basis, nu, group_width=1.0, group_width_abs=0.04, max_sweeps=6)
    assert fast.stats["fallbacks"] > 0 and fast.stats["refined"] > 0
    ref = LineModes(m.basis, nu, method="complex")
    assert worst_error(m.case, nu, fast, ref, range(nu.size)) <= TOL


def test_a_basis_without_planes_takes_the_complex_form(model):
    class Mixed:
        M, K, C, G = model.rotor.M, model.rotor.K, model.rotor.C, model.rotor.G

    mixed = ModalBasis(Mixed, model._p, model._out_dofs.reshape(-1), model.basis.cutoff_hz)
    lm = LineModes(mixed, model.multipliers[:5])
    assert lm.stats["method"] == "complex"
    ref = model.line_modes.subset(np.arange(5))
    for f in (10.0, 60.0):
        a, b = lm.receptance(f), ref.receptance(f)
        assert np.abs(a - b).max() <= 1e-8 * np.abs(b).max()


def test_a_model_made_like_another_with_a_supply_line_reuses_the_speed_locked_line_modes(cached_model):
    """A supply line (``electrical_harmonics``) has a fixed frequency and no line mode; a model made like one whose
    line modes exist takes the speed-locked lines only, and its spectrum is the one of a model made from scratch."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem

    extra = {"baseline.electrical_harmonics": [6.0], "baseline.electrical_harmonic_forces_n": [5.0]}
    healthy = cached_model(Case.load("motor_6010_healthy").with_overrides(extra))
    assert healthy.line_modes.multipliers.size < len(healthy.multipliers)      # the supply line has none
    faulty = Case.load("motor_6010_inner").with_overrides(extra)
    like = BkaBem(faulty, like=healthy)
    fresh = cached_model(faulty)
    a, b = like.spectrum(20.0), fresh.spectrum(20.0)
    np.testing.assert_allclose(a.frequency_hz, b.frequency_hz)
    scale = np.max(np.abs(b.displacement))
    assert np.max(np.abs(a.displacement - b.displacement)) <= 1e-6 * scale
