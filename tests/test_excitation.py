"""The 4-DOF quasi-static excitation model and its BPFO orders (bkabem_core.excitation)."""

import dataclasses

import numpy as np
import pytest
from scipy.signal import find_peaks

from bkabem_core.excitation import compute_excitation


def test_fourteen_impulses_per_cage_period(excitation):
    """Paper section 5: the 14 balls roll over the dent once each per cage rotation -> 14 impulses."""
    v = excitation.relative_displacement_m[0]
    # one full cage period is recorded; the dent lifts the rotor relative to the housing (less deformation)
    dev = v - np.median(v)
    sig = dev if abs(dev.max()) > abs(dev.min()) else -dev
    peaks, _ = find_peaks(np.r_[sig, sig[:10]], prominence=0.5 * np.ptp(sig), distance=len(v) // 28)
    peaks = peaks[peaks < len(v)]
    assert len(peaks) == 14
    spacing = np.diff(peaks)
    assert np.all(np.abs(spacing - len(v) / 14) <= 2)      # equally spaced: one ball pass each


def test_orders_are_exact_multiples_of_bpfo(excitation):
    # energy outside the BPFO bins of the whole-cage-period FFT is numerically zero
    assert excitation.off_order_fraction < 1e-4
    assert np.all(excitation.orders == np.round(excitation.orders))
    assert excitation.bpfo_per_hz == pytest.approx(6.059846, abs=1e-6)


def test_dent_at_minus_90_deg_is_vertical(excitation):
    """The dent sits in the load zone at the bottom: larger vertical than horizontal response (paper)."""
    assert excitation.peak_to_peak_m["vertical"] > 2 * excitation.peak_to_peak_m["horizontal"]
    a_v = excitation.all_amplitude_m["vertical"]
    a_h = excitation.all_amplitude_m["horizontal"]
    assert np.sqrt(np.sum(a_v**2)) > 2 * np.sqrt(np.sum(a_h**2))
    # DC: gravity pushes the rotor down past the radial play; horizontal DC is ~0
    assert excitation.dc_m["vertical"] < -0.5 * excitation.clearance_m
    assert abs(excitation.dc_m["horizontal"]) < 1e-3 * abs(excitation.dc_m["vertical"])


def test_amplitudes_and_phases_stable_to_integration_tolerance(case, excitation):
    tight = dataclasses.replace(case.four_dof_parameters(), rtol=1e-9, atol_m=1e-14)
    ref = compute_excitation(case.bearing(), tight)
    for d in ("vertical", "horizontal"):
        a, a0 = excitation.all_amplitude_m[d][:24], ref.all_amplitude_m[d][:24]
        assert np.max(np.abs(a - a0)) < 1e-5 * a0.max()
        big = a0 > 0.05 * a0.max()
        dphi = np.angle(np.exp(1j * (excitation.all_phase_rad[d][:24] - ref.all_phase_rad[d][:24])))
        assert np.max(np.abs(dphi[big])) < 1e-4


def test_paper_order_choice_is_one_setting_away(excitation):
    paper = excitation.with_selection(relative_amplitude_threshold=0.0, max_order=24)
    assert list(paper.orders) == list(range(1, 25))
    assert np.allclose(paper.amplitude_m["vertical"], excitation.all_amplitude_m["vertical"][:24])
    loose = excitation.with_selection(relative_amplitude_threshold=0.1, max_order=0)
    assert 0 < len(loose.orders) < len(excitation.all_orders)
    amp = np.maximum(excitation.all_amplitude_m["vertical"], excitation.all_amplitude_m["horizontal"])
    assert np.all(amp[loose.orders - 1] >= 0.1 * amp.max())


def test_orders_rebuild_the_recorded_waveform(excitation):
    """Sum of all resolved orders (cosine convention, t = 0 at cage angle 0) = the recorded signal."""
    t = excitation.time_s
    w = 2 * np.pi * excitation.bpfo_per_hz * excitation.reference_speed_hz
    for j, d in enumerate(("vertical", "horizontal")):
        rebuilt = excitation.dc_m[d] + np.cos(np.outer(t, excitation.all_orders * w)
                                             + excitation.all_phase_rad[d]) @ excitation.all_amplitude_m[d]
        err = np.max(np.abs(rebuilt - excitation.relative_displacement_m[j]))
        assert err < 1e-5 * np.ptp(excitation.relative_displacement_m[j])


def test_housing_resonance_reported(excitation):
    # 3.17 kg on ~1.25e8 N/m: ~1 kHz; the default max_order keeps orders below a third of it at 1 Hz
    assert 900 < excitation.housing_resonance_hz < 1100
    assert excitation.orders.max() * excitation.bpfo_per_hz * excitation.reference_speed_hz < \
        excitation.housing_resonance_hz / 3


def test_fast_bearing_path_equals_the_bearing_model(case):
    """The integrator's scalar force path is the same physics as Bearing.forces_n (dent included)."""
    from bkabem_core.excitation import FourDofModel

    bearing = case.bearing()
    model = FourDofModel(bearing, case.four_dof_parameters())
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(3000):
        ex, ey, t = rng.normal(0, 3e-6), -42e-6 + rng.normal(0, 5e-6), rng.uniform(0, 3)
        theta = 2 * np.pi * model.ftf * case.four_dof_parameters().reference_speed_hz * t
        fx, fy, (kxx, kxy, kyy) = bearing.forces_n(ex, ey, theta, with_stiffness=True)
        got = model._bearing(ex, ey, t)
        assert np.allclose(got, [fx, fy, kxx, kxy, kyy], rtol=1e-9, atol=1e-6)
        hits += bool(np.any(bearing.dent_depth_m(bearing.ball_angles_rad(theta)) > 0))
    assert hits > 10           # the dent was exercised
