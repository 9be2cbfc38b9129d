"""The bearing excitation and its BPFO orders (bkabem_core.excitation.quasi_static): the quasi-static method (the default)
and the paper's 4-DOF integration, each bearing under its own load."""

import dataclasses

import numpy as np
import pytest
from scipy.optimize import root
from scipy.signal import find_peaks

from bkabem_core.excitation.quasi_static import (
    FourDofModel,
    FourDofParameters,
    compute_excitation,
    quasi_static_excitation,
)


def test_quasi_static_path_is_the_equilibrium_at_every_cage_angle(machine, excitation):
    """Independent check: scipy's root finder on Bearing.forces_n at a few cage angles gives the same e(theta)."""
    site = machine.sites["de"]
    b, e_z = site.bearing, site.state.displacement_m[2]
    w = -site.radial_load_n
    n = excitation.relative_displacement_m.shape[1]
    pitch = 2 * np.pi / b.geometry.n_balls
    for j in (0, n // 7, n // 3, n // 2 + 5, n - 3):
        theta = pitch * j / n
        # unknowns in um, residual in N (scaled for the root finder)
        sol = root(lambda e: np.array(b.forces_n(e[0] * 1e-6, e[1] * 1e-6, theta, e_z_m=e_z)) - w,
                   site.state.displacement_m[:2] * 1e6, method="hybr", tol=1e-14)
        # the root finder's own residual, not its flag: at this tolerance MINPACK may stop with "not making good
        # progress" (numpy / scipy versions differ in the last bits) while standing on the root
        assert np.max(np.abs(sol.fun)) < 1e-6, sol.message
        got = excitation.relative_displacement_m[::-1, j]                   # (horizontal, vertical)
        np.testing.assert_allclose(got, sol.x * 1e-6, rtol=0, atol=2e-11)
        f = np.array(b.forces_n(got[0], got[1], theta, e_z_m=e_z))
        np.testing.assert_allclose(f, w, rtol=0, atol=1e-6)               # the bearing carries the load exactly


def test_one_impulse_per_ball_pass(case, machine):
    """Paper section 5: the 14 balls roll over the dent once each per cage rotation -> 14 impulses, i.e. one per
    ball pass, which is the period the quasi-static excitation is computed over."""
    ex = machine.excitation("de")
    v = ex.relative_displacement_m[0]
    sig = v - np.median(v)
    sig = sig if abs(sig.max()) > abs(sig.min()) else -sig
    peaks, _ = find_peaks(np.r_[sig, sig, sig], prominence=0.5 * np.ptp(sig))
    assert np.all(np.diff(peaks) == v.size)                                  # exactly one per period
    assert ex.off_order_fraction < 1e-4                                      # only the Nyquist bin


def test_orders_are_exact_multiples_of_bpfo(four_dof_excitation):
    # energy outside the BPFO bins of the whole-cage-period FFT of the 4-DOF run is numerically zero
    ex = four_dof_excitation
    assert ex.off_order_fraction < 1e-4
    assert np.all(ex.orders == np.round(ex.orders))
    assert ex.bpfo_per_hz == pytest.approx(6.059846, abs=1e-6)


def test_dent_at_minus_90_deg_is_vertical(excitation):
    """The dent sits in the load zone at the bottom: larger vertical than horizontal response (paper)."""
    assert excitation.peak_to_peak_m["vertical"] > 2 * excitation.peak_to_peak_m["horizontal"]
    a_v = excitation.all_amplitude_m["vertical"]
    a_h = excitation.all_amplitude_m["horizontal"]
    assert np.sqrt(np.sum(a_v**2)) > 2 * np.sqrt(np.sum(a_h**2))
    assert abs(excitation.dc_m["horizontal"]) < 1e-3 * abs(excitation.dc_m["vertical"])
    # with the 390 N axial preload every ball is loaded and the rotor sits close to the centre
    assert excitation.state.loaded_balls == 14
    assert -5e-6 < excitation.dc_m["vertical"] < 0.0


def test_each_bearing_has_its_own_excitation(model):
    """The healthy NDE bearing's ball passage is an excitation too, small next to the dent's."""
    de, nde = model.excitations["de"], model.excitations["nde"]
    assert de.bearing == "de" and nde.bearing == "nde"
    assert de.radial_load_n == pytest.approx(495.0, abs=0.5) and nde.radial_load_n == pytest.approx(309.1, abs=0.5)
    a_de = np.sqrt(np.sum(de.amplitude_m["vertical"] ** 2))
    a_nde = np.sqrt(np.sum(nde.amplitude_m["vertical"] ** 2))
    assert 0 < a_nde < 1e-2 * a_de


def test_quasi_static_excitation_converges_with_the_angle_grid(machine):
    site = machine.sites["de"]
    a = quasi_static_excitation(site.bearing, 495.0, 390.0, 1024)
    b = quasi_static_excitation(site.bearing, 495.0, 390.0, 4096)
    top = b.all_amplitude_m["vertical"].max()
    for d in ("vertical", "horizontal"):
        assert np.max(np.abs(a.all_amplitude_m[d][:200] - b.all_amplitude_m[d][:200])) < 1e-4 * top


def test_quasi_static_limit_of_the_4dof_model(machine):
    """Where the two methods agree and where the 4-DOF model's own dynamics take over (docs/method.md): at 0.1 Hz
    (inertia negligible) the 4-DOF orders are the quasi-static ones up to order 500; at the paper's 1 Hz they agree
    to order 30, then the model's ~1 kHz housing mode (order ~170) lifts orders 100-200 and the mass line above it
    cuts orders 300-500."""
    site = machine.sites["de"]
    w = 495.0
    qs = quasi_static_excitation(site.bearing, w, site.axial_load_n, 4096)
    params = dataclasses.replace(FourDofParameters.from_case(machine.case, "de"), rotor_mass_kg=w / 9.80665,
                                 relative_amplitude_threshold=0.0, max_order=0, samples_per_ball_pass=4096)
    slow = compute_excitation(site.bearing, dataclasses.replace(params, reference_speed_hz=0.1, settle_time_s=0.5),
                              site.axial_load_n)
    fast = compute_excitation(site.bearing, params, site.axial_load_n)
    band = lambda ex, lo, hi: np.sqrt(np.sum(ex.all_amplitude_m["vertical"][lo - 1:hi - 1] ** 2))
    db = lambda ex, lo, hi: 20 * np.log10(band(ex, lo, hi) / band(qs, lo, hi))
    for lo, hi in ((1, 10), (10, 30), (30, 100), (100, 200), (300, 500)):
        assert abs(db(slow, lo, hi)) < 0.6
    assert abs(db(fast, 1, 10)) < 0.2 and abs(db(fast, 10, 30)) < 0.3
    assert db(fast, 100, 150) > 3.0
    assert db(fast, 300, 500) < -6.0


def test_amplitudes_and_phases_stable_to_integration_tolerance(case, four_dof_excitation):
    ex = four_dof_excitation
    w = ex.radial_load_n
    tight = dataclasses.replace(FourDofParameters.from_case(case, "de"), rotor_mass_kg=w / 9.80665, rtol=1e-9, atol_m=1e-14)
    ref = compute_excitation(case.bearing("de"), tight, ex.axial_load_n)
    for d in ("vertical", "horizontal"):
        a, a0 = ex.all_amplitude_m[d][:24], ref.all_amplitude_m[d][:24]
        assert np.max(np.abs(a - a0)) < 1e-5 * a0.max()
        big = a0 > 0.05 * a0.max()
        dphi = np.angle(np.exp(1j * (ex.all_phase_rad[d][:24] - ref.all_phase_rad[d][:24])))
        assert np.max(np.abs(dphi[big])) < 1e-4


def test_paper_order_choice_is_one_setting_away(excitation):
    paper = excitation.with_selection(relative_amplitude_threshold=0.0, max_order=24)
    assert list(paper.orders) == list(range(1, 25))
    assert np.allclose(paper.amplitude_m["vertical"], excitation.all_amplitude_m["vertical"][:24])
    loose = excitation.with_selection(relative_amplitude_threshold=0.1, max_order=0)
    assert 0 < len(loose.orders) < len(excitation.all_orders)
    amp = np.maximum(excitation.all_amplitude_m["vertical"], excitation.all_amplitude_m["horizontal"])
    assert np.all(amp[loose.orders - 1] >= 0.1 * amp.max())


@pytest.mark.parametrize("which", ["quasi_static", "four_dof"])
def test_orders_rebuild_the_recorded_waveform(which, excitation, four_dof_excitation):
    """Sum of all resolved orders (cosine convention, t = 0 at cage angle 0) = the recorded signal."""
    ex = excitation if which == "quasi_static" else four_dof_excitation
    t = ex.time_s
    w = 2 * np.pi * ex.bpfo_per_hz * ex.reference_speed_hz
    for j, d in enumerate(("vertical", "horizontal")):
        rebuilt = ex.dc_m[d] + np.cos(np.outer(t, ex.all_orders * w) + ex.all_phase_rad[d]) @ ex.all_amplitude_m[d]
        err = np.max(np.abs(rebuilt - ex.relative_displacement_m[j]))
        assert err < 1e-5 * np.ptp(ex.relative_displacement_m[j])


def test_housing_resonance_reported(four_dof_excitation, excitation):
    # 3.17 kg on ~1.3e8 N/m: ~1 kHz; the quasi-static method has no dynamics
    assert 900 < four_dof_excitation.housing_resonance_hz < 1150
    assert np.isnan(excitation.housing_resonance_hz)


def test_fast_bearing_path_equals_the_bearing_model(case):
    """The integrator's scalar force path is the same physics as Bearing.forces_n (dent and held axial
    displacement included)."""
    bearing = case.bearing("de")
    model = FourDofModel(bearing, FourDofParameters.from_case(case, "de"), axial_load_n=390.0)
    e_z = model.state.displacement_m[2]
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(3000):
        ex, ey, t = rng.normal(0, 3e-6), -12e-6 + rng.normal(0, 5e-6), rng.uniform(0, 3)
        theta = 2 * np.pi * model.ftf * FourDofParameters.from_case(case, "de").reference_speed_hz * t
        fx, fy, (kxx, kxy, kyy) = bearing.forces_n(ex, ey, theta, with_stiffness=True, e_z_m=e_z)
        got = model._bearing(ex, ey, t)
        assert np.allclose(got, [fx, fy, kxx, kxy, kyy], rtol=1e-9, atol=1e-6)
        hits += bool(np.any(bearing.dent_depth_m(bearing.ball_angles_rad(theta)) > 0))
    assert hits > 10           # the dent was exercised
