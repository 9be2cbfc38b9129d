"""The measurement chain (bkabem_core.synth.sensors): mounted accelerometer and anti-alias filter as line gains."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from bkabem_core.synth.sensors import MOUNTING_RESONANCE_HZ, Accelerometer, AntiAliasFilter
from bkabem_core.synth.synthesizer import SynthError, Synthesizer


def test_accelerometer_is_a_base_excited_oscillator():
    acc = Accelerometer.mounted("magnet", damping_ratio=0.05)
    assert acc.resonance_hz == MOUNTING_RESONANCE_HZ["magnet"]
    assert abs(acc.gain(0.0)) == pytest.approx(1.0)
    assert abs(acc.gain(acc.resonance_hz)) == pytest.approx(1 / (2 * 0.05))
    # independent: the transfer function of m x'' + c x' + k x = -m a_base, output -k x / m over a_base
    wn, z = 2 * np.pi * acc.resonance_hz, 0.05
    _, h = signal.freqs([wn ** 2], [1, 2 * z * wn, wn ** 2], worN=2 * np.pi * np.array([1e3, 5e3, 2e4]))
    assert np.allclose(acc.gain([1e3, 5e3, 2e4]), h, rtol=1e-12)
    with pytest.raises(ValueError, match="damping_ratio"):
        Accelerometer(damping_ratio=0.0)


def test_anti_alias_filter_is_butterworth():
    aa = AntiAliasFilter.for_rate(51200.0)
    assert aa.cutoff_hz == pytest.approx(20000.0)
    assert abs(aa.gain(20000.0)) == pytest.approx(2 ** -0.5, rel=1e-9)
    assert abs(aa.gain(40000.0)) == pytest.approx(1 / np.sqrt(1 + 2.0 ** 12), rel=1e-9)     # order 6


def test_chain_applies_to_the_lines_of_the_right_channels(model):
    """Acceleration lines get the accelerometer and the filter, displacement (the probe) the filter only."""
    acc, aa = Accelerometer.mounted("magnet"), AntiAliasFilter(5000.0, 4)
    plain = Synthesizer(model, 51200.0, features=False)
    chain = Synthesizer(model, 51200.0, features=False, accelerometer=acc, anti_alias=aa)
    a, b = plain.line_spectrum(25.0), chain.line_spectrum(25.0)
    f = a["frequency_hz"]
    for name in ("de_vertical_acceleration", "de_vertical_displacement"):
        i = a["channel_names"].index(name)
        want = a["amplitude"][:, i] * aa.gain(f) * (acc.gain(f) if name.endswith("acceleration") else 1.0)
        assert np.allclose(b["amplitude"][:, i], want, rtol=1e-12, atol=1e-15 * np.abs(want).max())
    assert chain.info()["case_hash"] == plain.info()["case_hash"]
    assert chain.ground_truth()["accelerometer"]["mounting"] == "magnet"
    with pytest.raises(SynthError, match="accelerometer"):
        Synthesizer(model, 51200.0, accelerometer="stud")
