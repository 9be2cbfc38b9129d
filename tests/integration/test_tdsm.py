"""Tests of bkabem_core.reference.tdsm: statics, the integrator (energy, exact linear solution, convergence), and the
nonlinear model against an independent stiff ODE solve. Every run is a few BPFO periods (seconds in total)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

from bkabem_core.fe.rotor import rotor_from_case
from bkabem_core.reference.periodic import harmonic_balance
from bkabem_core.reference.tdsm import Tdsm

pytestmark = pytest.mark.tdsm

SPEED = 30.0


@pytest.fixture(scope="module")
def tdsm(case, machine):
    """The TDSM of the embedded case on the same machine as the BKA-BEM fixtures (refined mesh, damped)."""
    return Tdsm(case, SPEED, machine=machine)


def coarse(case, **kw):
    """A TDSM on the case's own 13 elements: the integrator tests do not need the converged mesh."""
    return Tdsm(case, SPEED, mesh=None, **kw)


def _lever_loads(case):
    loads = rotor_from_case(case.raw).static_bearing_loads_n(case.raw["excitation"]["gravity_m_s2"])
    return {b: np.array(loads[b]) for b in ("de", "nde")}


# --------------------------------------------------------------------------- statics
def test_static_equilibrium_equals_bearing_model(case, tdsm):
    """Two bearings: statically determinate. The nonlinear model's static solution must put each bearing at the
    bearing model's own static solution under the lever-rule load of the linear FE and its axial load."""
    st = tdsm.static
    loads = _lever_loads(case)
    for b in ("de", "nde"):
        np.testing.assert_allclose(st.force_n[b], loads[b], rtol=1e-9, atol=1e-9)
        e = case.bearing(b).static_equilibrium_m(-loads[b][0], -loads[b][1], axial_load_n=case.axial_load_n(b))
        np.testing.assert_allclose(st.relative_m[b], e[:2], rtol=0, atol=1e-13)
    # the DE bearing carries ~495 N radially; the 390 N axial preload takes up the play: e_y ~ -3.4 um
    assert st.force_n["de"][1] == pytest.approx(495.0, abs=0.1)
    assert -4e-6 < st.relative_m["de"][1] < -3e-6
    # and the whole model is in equilibrium: K q = F_g + B (f + K_b u), K with the linear bearing springs K_b
    rot = tdsm.rotor
    f = np.concatenate([st.force_n["de"], st.force_n["nde"]])
    u = tdsm.B.T @ st.q_m
    res = rot.K @ st.q_m - rot.gravity_force(tdsm.gravity_m_s2) - tdsm.B @ (f + tdsm._kb @ u)
    assert np.max(np.abs(res)) < 1e-6 * np.max(np.abs(rot.gravity_force(tdsm.gravity_m_s2)))


def test_static_state_is_an_equilibrium_of_the_discrete_model(case):
    """Started in the static equilibrium, the model only moves because the balls move: after two steps the
    deviation is < 0.1 nm; without the dent the DE vertical motion (ball passage only) stays far below the dented
    one."""
    amp = {}
    for name, c in (("healthy", case.with_overrides({"dent.depth_m": 0.0})), ("dented", case)):
        m = Tdsm(c, SPEED, mesh=None)
        r = m.run(3 * m.bpfo_period_s, settle_s=0.0, progress=False)
        dev = r.bearing_relative_m - np.array([[m.static.relative_m["de"][::-1], m.static.relative_m["nde"][::-1]]])
        assert np.max(np.abs(dev[:3])) < 1e-10
        amp[name] = np.max(np.abs(dev[:, 0, 0]))
    assert amp["healthy"] < 0.1 * amp["dented"]
    assert amp["dented"] > 0.5e-6                # the 50 um dent drops the DE rotor by a micron and more


# --------------------------------------------------------------------------- integrator, linear model
def _linear_reference(m):
    """The linear FE with the machine's bearing springs and the TDSM damper, assembled again from the case."""
    c = m.bearing_damping_n_s_m                      # each position's damper
    el = {b: (s.stiffness_n_m[0], s.stiffness_n_m[1], c[b], c[b]) for b, s in m.machine.sites.items()}
    return rotor_from_case(m.case.raw, bearings=el, mesh=m.machine.mesh)


def _initial_displacement(m):
    """A smooth deviation that rings the bearings: the 16 lowest undamped modes of the linear model (up to the
    housing and core-bending modes, ~1.7 kHz) with equal weight, scaled to 1 um at the DE rotor node. Smooth in
    modal space, so both schemes show their asymptotic order at these steps."""
    w2, phi = scipy.linalg.eigh(m.rotor.K, m.rotor.M)
    x0 = phi[:, :16].sum(axis=1)
    return x0 * 1e-6 / np.max(np.abs(x0[m.out_dofs[0]]))


@pytest.mark.parametrize("scheme", ["exponential", "newmark"])
def test_linear_model_matches_exact_solution_second_order(case, scheme):
    """Linear bearings: the TDSM must give the exact solution expm(A t) y0 of the FE: to round-off with the
    exponential scheme (the linear springs are part of its exact linear step), at second order with Newmark."""
    errs = []
    for n_per in (128, 256, 512):
        m = coarse(case, max_step_s=(1.0 / (6.059846 * SPEED)) / n_per * 1.0001, bearing_model="linear",
                   scheme=scheme)
        assert m.steps_per_bpfo == n_per
        n = m.ndof
        x0 = _initial_displacement(m)
        rot = m.rotor
        if scheme == "exponential":
            z0 = np.r_[x0, np.zeros(n)]
        else:
            a0 = np.linalg.solve(rot.M, -rot.K @ x0)
            z0 = np.r_[x0, np.zeros(n), a0]
        r = m.run(m.bpfo_period_s, settle_s=0.0, progress=False, initial_state=z0, record_state=True)
        ref_rot = _linear_reference(m)
        a = rot_state_matrix(ref_rot, TWO_PI_SPEED())
        stride = n_per // 16
        phi = scipy.linalg.expm(a * m.h * stride)
        y = np.r_[x0, np.zeros(n)]
        y_exact = []
        for _ in range(r.time_s[::stride].size):
            y_exact.append(y)
            y = phi @ y
        od = m.out_dofs.ravel()                                   # bearing and housing x, y
        err = np.max(np.abs(r.state[::stride][:, od] - np.array(y_exact)[:, od])) / np.max(np.abs(x0[od]))
        errs.append(err)
    if scheme == "exponential":
        # the linear bearing springs are inside the exactly discretised linear part: exact at every step
        assert max(errs) < 1e-8, errs
        return
    assert errs[-1] < 1e-2
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 1.8), (errs, orders)


def TWO_PI_SPEED():
    return 2.0 * math.pi * SPEED


def rot_state_matrix(rot, omega):
    n = rot.ndof
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    a[n:, :n] = -np.linalg.solve(rot.M, rot.K)
    a[n:, n:] = -np.linalg.solve(rot.M, rot.C + omega * rot.G)
    return a


def test_newmark_energy_balance_linear(case):
    """Average acceleration, linear bearings: the discrete energy balance holds to round-off,
    E_{n+1} - E_n = -h vbar^T C vbar (the gyroscopic term does no work)."""
    m = coarse(case, bearing_model="linear", scheme="newmark")
    rot, n = m.rotor, m.ndof
    k = rot.K
    x0 = _initial_displacement(m)
    z0 = np.r_[x0, np.zeros(n), np.linalg.solve(rot.M, -k @ x0)]
    r = m.run(m.bpfo_period_s, settle_s=0.0, progress=False, initial_state=z0, record_state=True)
    x, v = r.state[:, :n], r.state[:, n:2 * n]
    e = 0.5 * np.einsum("ti,ij,tj->t", v, rot.M, v) + 0.5 * np.einsum("ti,ij,tj->t", x, k, x)
    vb = 0.5 * (v[1:] + v[:-1])
    diss = m.h * np.einsum("ti,ij,tj->t", vb, rot.C, vb)
    balance = (e[1:] - e[:-1]) + diss
    assert e[0] > 0 and diss.sum() > 1e-3 * e[0]           # the dampers really work
    assert np.max(np.abs(balance)) < 1e-9 * e[0]


def test_exponential_energy_balance_linear(case):
    """Exact linear part: the energy lost over one BPFO period equals the damper work (trapezoidal quadrature
    of the recorded velocities) to the quadrature's accuracy."""
    m = coarse(case, max_step_s=2.5e-6, bearing_model="linear")
    rot, n = m.rotor, m.ndof
    k = rot.K
    x0 = _initial_displacement(m)
    r = m.run(m.bpfo_period_s, settle_s=0.0, progress=False, initial_state=np.r_[x0, np.zeros(n)],
              record_state=True)
    x, v = r.state[:, :n], r.state[:, n:]
    e = 0.5 * np.einsum("ti,ij,tj->t", v, rot.M, v) + 0.5 * np.einsum("ti,ij,tj->t", x, k, x)
    p = np.einsum("ti,ij,tj->t", v, rot.C, v)
    lost = e[0] - e[-1]
    assert lost > 0.01 * e[0]
    assert abs(lost - np.trapezoid(p, dx=m.h)) < 2e-3 * lost


# --------------------------------------------------------------------------- integrator, nonlinear model
def test_step_size_convergence_nonlinear(case):
    """The dented nonlinear model, through a dent crossing: halving the step shrinks the change of the bearing
    displacement at second order on average (the ball profile's kink where the ball reaches the dent bottom makes
    single halvings irregular, 2.8x to 4.7x)."""
    runs = []
    for n_per in (256, 512, 1024, 2048, 4096):
        m = coarse(case, max_step_s=(1.0 / (6.059846 * SPEED)) / n_per * 1.0001)
        assert m.steps_per_bpfo == n_per
        r = m.run(2 * m.bpfo_period_s, settle_s=m.bpfo_period_s, progress=False)
        runs.append(r.bearing_relative_m[:: n_per // 256])          # common instants
    d = np.array([np.max(np.abs(runs[i] - runs[i + 1])) for i in range(4)])
    assert np.all(d[:-1] / d[1:] > 2.5), d
    assert np.log2(d[0] / d[-1]) / 3 > 1.8, d
    assert d[-1] < 1e-10                                              # 1.3 us vs 0.7 us steps: < 0.1 nm


def test_newton_tolerance_does_not_change_the_result(case):
    a = coarse(case).run(0.02, settle_s=0.01, progress=False)
    b = coarse(case, newton_tol_m=1e-13).run(0.02, settle_s=0.01, progress=False)
    assert b.newton_iterations_mean > a.newton_iterations_mean
    np.testing.assert_allclose(a.displacement_m, b.displacement_m, rtol=0, atol=1e-13)


def test_reproducible(case, tdsm):
    a = tdsm.run(0.01, settle_s=0.0, progress=False)
    b = tdsm.run(0.01, settle_s=0.0, progress=False)
    np.testing.assert_array_equal(a.displacement_m, b.displacement_m)
    assert a.settings == b.settings and a.settings["case_hash"] == case.case_hash


def test_against_independent_stiff_ode_solver(case):
    """The full nonlinear model written independently (Bearing.forces_n at the exact cage angle, the linear FE
    with the damper) and integrated by scipy's LSODA, over the first dent crossing (2.7-3.4 ms at 30 Hz).
    (Radau and BDF agree with LSODA; at a 2.5 us step the TDSM is within 1e-4 of them.)"""
    m = coarse(case, max_step_s=5e-6)
    r = m.run(3.7e-3, settle_s=0.0, progress=False)
    n = m.ndof
    rot = m.rotor
    minv = np.linalg.inv(rot.M)
    cw = rot.C + 2 * math.pi * SPEED * rot.G
    u_s = np.concatenate([m.static.relative_m["de"], m.static.relative_m["nde"]])
    f_s = np.concatenate([m.static.force_n["de"], m.static.force_n["nde"]])
    de, nde = case.bearing("de"), case.bearing("nde")
    ez = [m.machine.sites[b].state.displacement_m[2] for b in ("de", "nde")]
    w_c = m.cage_speed_rad_s
    # the FE without its linear bearing springs: the ball forces alone act across the bearings
    k_free = rot.K - m.B @ m._kb @ m.B.T

    def rhs(t, y):
        x, v = y[:n], y[n:]
        u = u_s + m.B.T @ x
        fx0, fy0 = de.forces_n(u[0], u[1], w_c * t, e_z_m=ez[0])
        fx1, fy1 = nde.forces_n(u[2], u[3], w_c * t, e_z_m=ez[1])
        f = np.array([fx0, fy0, fx1, fy1]) - f_s
        return np.r_[v, minv @ (-cw @ v - k_free @ x + m.B @ f)]

    def jac(t, y):
        u = u_s + m.B.T @ y[:n]
        kt = np.zeros((4, 4))
        for i, b in enumerate((de, nde)):
            _, _, (kxx, kxy, kyy) = b.forces_n(u[2 * i], u[2 * i + 1], w_c * t, with_stiffness=True, e_z_m=ez[i])
            kt[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[kxx, kxy], [kxy, kyy]]
        j = np.zeros((2 * n, 2 * n))
        j[:n, n:] = np.eye(n)
        j[n:, :n] = -minv @ (k_free + m.B @ kt @ m.B.T)
        j[n:, n:] = -minv @ cw
        return j

    t_eval = r.time_s[r.time_s <= 3.6e-3][::10]
    sol = solve_ivp(rhs, (0, t_eval[-1]), np.zeros(2 * n), method="LSODA", t_eval=t_eval, jac=jac, rtol=1e-7,
                    atol=1e-13, max_step=2e-5)
    assert sol.success
    u_ref = np.stack([sol.y[m.out_dofs[0, 0]] - sol.y[m.out_dofs[1, 0]],
                      sol.y[m.out_dofs[0, 1]] - sol.y[m.out_dofs[1, 1]]], axis=1)     # DE (vertical, horizontal)
    u_tdsm = r.bearing_relative_m[r.time_s <= 3.6e-3][::10, 0, :] - m.static.relative_m["de"][::-1]
    scale = np.max(np.abs(u_ref), axis=0)
    assert scale[0] > 0.3e-6                                   # the dent crossing really happened
    assert np.max(np.abs(u_tdsm - u_ref) / scale) < 1e-3


@pytest.mark.parametrize("nde_race", ["outer", "inner"])
def test_two_different_bearings_against_independent_stiff_ode_solver(nde_race):
    """A 6205 at the DE and a 6203 at the NDE, an outer-race dent in the DE and an outer- or inner-race dent in the
    NDE: each bearing's balls turn at its own cage speed and spin at its own rate (the TDSM takes each bearing's
    ball angles and defect drops from its own clock at every step). The same independent LSODA model as above, each
    bearing's Bearing.forces_n at its own cage angle 2 pi FTF_b f t (shaft angle 2 pi f t, spin 2 pi BSF_b f t), over
    the first 7.6 ms (the NDE's first outer-race dent crossing from t = 0, the DE's at about 7 ms at 30 Hz)."""
    from case_files import two_bearing_text

    from bkabem_core.model.case import Case

    case = Case.from_toml(two_bearing_text().replace('bearing = "nde"\nrace = "outer"',
                                                     f'bearing = "nde"\nrace = "{nde_race}"'), "two.toml")
    assert case.defects("nde")[0].race == nde_race
    m = coarse(case, max_step_s=5e-6)
    assert not m.one_ball_set and m.forces.split and not m.forces.periodic
    w = [2 * math.pi * case.fault_multipliers(b).ftf * SPEED for b in ("de", "nde")]
    spin = [2 * math.pi * case.fault_multipliers(b).bsf * SPEED for b in ("de", "nde")]
    assert m.cage_speeds_rad_s == pytest.approx(w, rel=1e-15) and w[0] != w[1]
    t_end = 7.6e-3
    r = m.run(t_end, settle_s=0.0, progress=False)
    n = m.ndof
    rot = m.rotor
    minv = np.linalg.inv(rot.M)
    cw = rot.C + 2 * math.pi * SPEED * rot.G
    u_s = np.concatenate([m.static.relative_m["de"], m.static.relative_m["nde"]])
    f_s = np.concatenate([m.static.force_n["de"], m.static.force_n["nde"]])
    bearings = (case.bearing("de"), case.bearing("nde"))
    ez = [m.machine.sites[b].state.displacement_m[2] for b in ("de", "nde")]
    k_free = rot.K - m.B @ m._kb @ m.B.T

    def rhs(t, y):
        x, v = y[:n], y[n:]
        u = u_s + m.B.T @ x
        f = np.array([c for i, b in enumerate(bearings)
                      for c in b.forces_n(u[2 * i], u[2 * i + 1], w[i] * t, e_z_m=ez[i],
                                          shaft_angle_rad=2 * math.pi * SPEED * t, spin_angle_rad=spin[i] * t)]) - f_s
        return np.r_[v, minv @ (-cw @ v - k_free @ x + m.B @ f)]

    def jac(t, y):
        u = u_s + m.B.T @ y[:n]
        kt = np.zeros((4, 4))
        for i, b in enumerate(bearings):
            _, _, (kxx, kxy, kyy) = b.forces_n(u[2 * i], u[2 * i + 1], w[i] * t, with_stiffness=True, e_z_m=ez[i],
                                               shaft_angle_rad=2 * math.pi * SPEED * t, spin_angle_rad=spin[i] * t)
            kt[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[kxx, kxy], [kxy, kyy]]
        j = np.zeros((2 * n, 2 * n))
        j[:n, n:] = np.eye(n)
        j[n:, :n] = -minv @ (k_free + m.B @ kt @ m.B.T)
        j[n:, n:] = -minv @ cw
        return j

    keep = r.time_s <= t_end - 1e-4
    t_eval = r.time_s[keep][::10]
    sol = solve_ivp(rhs, (0, t_eval[-1]), np.zeros(2 * n), method="LSODA", t_eval=t_eval, jac=jac, rtol=1e-7,
                    atol=1e-13, max_step=2e-5)
    assert sol.success
    for i, b in enumerate(("de", "nde")):
        rotor, housing = m.out_dofs[2 * i], m.out_dofs[2 * i + 1]
        u_ref = np.stack([sol.y[rotor[0]] - sol.y[housing[0]], sol.y[rotor[1]] - sol.y[housing[1]]], axis=1)
        u_tdsm = r.bearing_relative_m[keep][::10, i, :] - m.static.relative_m[b][::-1]
        scale = np.max(np.abs(u_ref), axis=0)
        assert scale[0] > 0.1e-6, b                            # each bearing's dent crossing really happened
        assert np.max(np.abs(u_tdsm - u_ref) / scale) < 1e-3, b


def test_harmonic_balance_needs_one_ball_set():
    from case_files import two_bearing_text

    from bkabem_core.model.case import Case

    m = coarse(Case.from_toml(two_bearing_text(), "two.toml"))
    with pytest.raises(ValueError, match="two ball-pass periods"):
        harmonic_balance(m, n_orders=5)


def test_harmonic_balance_and_time_integration_agree(case, tdsm):
    """Two independent solvers of the same nonlinear model: the periodic steady state found in the frequency
    domain (harmonic balance, alternating frequency-time) and the time integration after its start transient.
    Complex amplitudes (phase included, same time origin) of the five largest orders agree within 1 %.
    (Smaller orders next to a nearly undamped shaft mode need seconds of settling, docs/validation.md.)"""
    hb = harmonic_balance(tdsm, n_orders=50)
    assert hb.converged and hb.iterations < 10
    r = tdsm.run(0.03, settle_s=0.4, progress=False)
    orders, x, dc = r.order_spectrum(50)
    for li in range(4):
        for di in range(2):
            a = x[:, li, di]
            big = np.argsort(np.abs(a))[::-1][:5]
            err = np.abs(hb.complex_amplitude[big, li, di] - a[big]) / np.abs(a[big])
            assert np.max(err) < 0.01, (li, di, err)
    np.testing.assert_allclose(hb.dc_m, dc, rtol=0, atol=2e-9)
    # and the linear time-periodic model (one Newton step) is within ~1.5 dB of both
    lin = harmonic_balance(tdsm, n_orders=50, linearised=True)
    big = np.argsort(np.abs(x[:, 0, 0]))[::-1][:5]
    assert np.max(np.abs(20 * np.log10(np.abs(lin.complex_amplitude[big, 0, 0]) / np.abs(x[big, 0, 0])))) < 1.5


def test_adaptive_settle_stops_when_the_orders_are_steady(case, tdsm):
    r = tdsm.run(2 * tdsm.bpfo_period_s, progress=False)
    assert r.settled and r.settings["settle"] == "adaptive"
    assert 0.1 <= r.settle_s < 1.0
    assert r.settle_log[-1][1] <= 0.02


def test_interrupt_keeps_what_was_computed(case, monkeypatch):
    m = coarse(case)
    calls = {"n": 0}
    real = m.forces.evaluate

    def flaky(u, j):
        calls["n"] += 1
        if calls["n"] == 3000:
            raise KeyboardInterrupt
        return real(u, j)

    monkeypatch.setattr(m.forces, "evaluate", flaky)
    r = m.run(0.1, settle_s=m.bpfo_period_s, progress=False)
    assert r.interrupted
    assert 0 < r.steps < 3000
    assert r.time_s.size == r.displacement_m.shape[0] == r.steps - m.steps_per_bpfo + 1
    assert np.all(np.isfinite(r.displacement_m))
    assert r.whole_periods >= 1


def test_cost_per_step_is_small(case, tdsm):
    """<= 0.1 ms/step is the target on this machine; the test allows 3x for a loaded CI machine."""
    r = tdsm.run(0.05, settle_s=0.0, progress=False)
    assert r.ms_per_step < 0.3
    assert r.newton_iterations_mean < 1.2


def test_bad_input(case):
    with pytest.raises(ValueError, match="speed_hz"):
        Tdsm(case, 0.0)
    with pytest.raises(ValueError, match="scheme"):
        Tdsm(case, 10.0, scheme="rk4")
    with pytest.raises(ValueError, match="hht_alpha"):
        Tdsm(case, 10.0, hht_alpha=0.5)
