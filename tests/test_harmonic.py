"""BKA-BEM harmonic solve (bkabem_core.harmonic) against independent solutions."""

import numpy as np
import pytest
import scipy.linalg as sla

from bkabem_core.harmonic import LOCATIONS, BkaBem, ShaftSolver


def test_block_solver_matches_direct_solve_over_a_sweep(case, excitation, model):
    direct = BkaBem(case, excitation=excitation, solver="direct")
    speeds = np.linspace(0.0, case.max_speed_hz, 301)
    a = model.sweep(speeds).displacement
    b = direct.sweep(speeds).displacement
    scale = np.abs(b).max(axis=(1, 2, 3), keepdims=True)
    assert np.max(np.abs(a - b) / scale) < 1e-8


def test_block_solver_rejects_other_topologies(model):
    rotor = model.rotor
    assert ShaftSolver(rotor).n_nodes == len(rotor.shaft_node_labels)


def _newmark_steady_state(m, c, k, f_amp, omega, dt, t_end):
    """Average-acceleration Newmark integration of M q'' + C q' + K q = Re(f e^{i w t}); returns q(t)."""
    n = m.shape[0]
    q = np.zeros(n)
    v = np.zeros(n)
    a = np.linalg.solve(m, f_amp.real - c @ v - k @ q)
    keff = k + 2.0 / dt * c + 4.0 / dt**2 * m
    lu = sla.lu_factor(keff)
    steps = int(round(t_end / dt))
    out = np.empty((steps + 1, n))
    out[0] = q
    for i in range(1, steps + 1):
        t = i * dt
        f = (f_amp * np.exp(1j * omega * t)).real
        rhs = f + m @ (4.0 / dt**2 * q + 4.0 / dt * v + a) + c @ (2.0 / dt * q + v)
        qn = sla.lu_solve(lu, rhs)
        vn = 2.0 / dt * (qn - q) - v
        a = 4.0 / dt**2 * (qn - q) - 4.0 / dt * v - a
        q, v = qn, vn
        out[i] = q
    return out


def test_harmonic_solve_matches_time_integration_of_the_linear_model(model):
    """One harmonic force pair at the DE bearing, integrated in time until steady state (Newmark),
    gives the amplitude and phase the frequency-domain solve predicts (Eq. 8 in complex form)."""
    rot = model.rotor
    speed_hz, freq_hz = 30.0, 180.0
    big_w, w = 2 * np.pi * speed_hz, 2 * np.pi * freq_hz
    f = np.zeros(rot.ndof, dtype=complex)
    f[rot.dof_index(5, "y")] = 100.0
    f[rot.dof_index(15, "y")] = -100.0
    f[rot.dof_index(5, "x")] = 40.0j
    x_freq = ShaftSolver(rot).solve(np.array([w]), np.array([big_w]), f[None])[0]
    dt = 1.0 / freq_hz / 256
    q = _newmark_steady_state(rot.M, rot.C + big_w * rot.G, rot.K, f, w, dt, t_end=1.2)
    # least-squares fit of a cos + b sin over the last 20 periods
    n = int(round(20 / freq_hz / dt))
    t = np.arange(q.shape[0])[-n:] * dt
    basis = np.column_stack([np.cos(w * t), -np.sin(w * t)])
    for node, d in ((5, "y"), (5, "x"), (13, "y"), (15, "y"), (16, "x")):
        i = rot.dof_index(node, d)
        coef, *_ = np.linalg.lstsq(basis, q[-n:, i], rcond=None)
        x_time = coef[0] + 1j * coef[1]
        # Newmark's period error at 256 steps per period is ~(w dt)^2/12 = 5e-5 (x resonance amplification)
        assert abs(x_time - x_freq[i]) < 2e-3 * abs(x_freq[i]), (node, d)


def test_dc_relative_displacement_equals_excitation_dc(model, excitation):
    """A static force pair k_b A_0 across the DE bearing: the rotor pivots about the NDE bearing node
    (no other element is loaded), so rotor - housing at the DE bearing is exactly A_0."""
    dc = model.dc_m
    li_r, li_h = LOCATIONS.index("de_rotor"), LOCATIONS.index("de_housing")
    rel = dc[li_r] - dc[li_h]
    assert rel[0] == pytest.approx(excitation.dc_m["vertical"], rel=1e-9)
    assert rel[1] == pytest.approx(excitation.dc_m["horizontal"], rel=1e-6, abs=1e-15)


def test_spectrum_fields_and_units(model):
    sp = model.spectrum(25.0)
    k = sp.orders
    assert np.allclose(sp.frequency_hz, k * model.bpfo_per_hz * 25.0)
    assert sp.displacement.shape == (k.size, 4, 2)
    assert np.allclose(sp.acceleration, -(2 * np.pi * sp.frequency_hz[:, None, None]) ** 2 * sp.displacement)
    assert sp.fault_frequencies_hz.bpfo == pytest.approx(6.059846 * 25.0)
    d = sp.to_dict()
    for loc in LOCATIONS:
        for direction in ("vertical", "horizontal"):
            entry = d[loc][direction]
            assert set(entry) >= {"frequency_hz", "displacement_m", "acceleration_m_s2", "phase_rad"}
            assert len(entry["displacement_m"]) == k.size
    assert set(d["fault_frequencies_hz"]) == {"ftf", "bpfo", "bpfi", "bsf"}


def test_response_scales_with_dent_depth(case):
    """Halving the dent depth lowers the DE response (sanity of the whole chain)."""
    shallow = BkaBem(case.with_overrides({"dent.depth_m": 10e-6}))
    deep = BkaBem(case)
    a = np.abs(shallow.spectrum(25.0).displacement[:, 0, 0]).max()
    b = np.abs(deep.spectrum(25.0).displacement[:, 0, 0]).max()
    assert a < 0.7 * b


def test_bad_speed_is_rejected(model):
    with pytest.raises(ValueError, match="speed_hz"):
        model.spectrum(float("nan"))
    with pytest.raises(ValueError, match="speed_hz"):
        model.response([-1.0])


def test_compiled_kernel_is_built_and_used(model):
    """The C kernel is part of the install (setup.py); without it the solver silently gets 6x slower."""
    from bkabem_core import harmonic

    assert harmonic._KERNEL is not None
    model.spectrum(20.0)
    assert model.solver == "block" and model._block.last_fallbacks == 0


def test_order_modal_form_c_kernel_matches_numpy(model):
    """The pole-residue sum in C (_modalsum.c: mode-acceleration form, float32 residues) is part of the install and
    agrees with the numpy sum (plain form, double) within 2e-6 of each output's largest order, for 8 outputs and
    for fewer (zero-padded to the kernel's 8), from near the static limit up."""
    from bkabem_core import harmonic

    assert harmonic._MODAL_KERNEL is not None
    rng = np.random.default_rng(3)
    for comb in (None, rng.standard_normal((3, 8))):
        form = model.order_modal_form(comb)
        assert form._c is not None
        for f in (0.05, 0.3, 17.0, 49.5):
            got, ref = form(f), form.evaluate_numpy(f)
            assert got.shape == ref.shape == (model.orders.size, 8 if comb is None else 3)
            err = (np.abs(got - ref).max(axis=0) / np.abs(ref).max(axis=0)).max()
            assert 0 < err <= 2e-6, err                     # > 0: the float32 kernel really ran
    np.testing.assert_allclose(form.static, form.evaluate_numpy(0.0), rtol=1e-9, atol=1e-9 * np.abs(form.static).max())
