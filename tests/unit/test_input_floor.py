"""The acquisition's input floor (``measurement.input_noise_m_s2_per_sqrt_hz``): on each acceleration channel of a
housing an independent white acceleration of density B, after the accelerometer's mount and before the AC coupling
and the anti-alias filter; not on the velocity and the shaft-relative displacement.

Isolated through the public API: a synthesiser of the case with the key and one of the same machine without it,
same seed; their difference is the input floor. Oracle, written here: a white acceleration of one-sided density B
has the PSD B^2 [m^2/s^4/Hz], times |H|^2 of a Butterworth high-pass written here (scipy.signal.butter, analog) where
the case has an AC coupling; against a Welch PSD (Hann, 4096 points) of 8 s in third-octave bands.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from bkabem_core.model.case import Case, CaseError
from bkabem_core.synth.synthesizer import Synthesizer

FS = 25600.0
SPEED_HZ = 25.0
B = 0.02                            # [m/s^2/sqrt(Hz)]
KEY = "measurement.input_noise_m_s2_per_sqrt_hz"


@pytest.fixture(scope="module")
def healthy(cached_model):
    return cached_model(Case.load("motor_6010_healthy"))


MOUNTED = {"measurement.mounting": "magnet", "measurement.mounting_resonance_hz": 3000.0,
           "measurement.high_pass_hz": 200.0, "measurement.high_pass_order": 2}


@pytest.fixture(scope="module")
def pair(cached_model, healthy):
    """(machine with a mount, an AC coupling and the input floor; the same without the input floor)."""
    base = Case.load("motor_6010_healthy").with_overrides(MOUNTED)
    return cached_model(base.with_overrides({KEY: B}), like=healthy), cached_model(base, like=healthy)


def _run(model, seconds, seed=3, quantities=("acceleration", "displacement", "velocity")):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=seed, features=False, quantities=list(quantities))
    n = int(round(seconds * FS))
    out, done = [], 0
    while done < n:
        c = s.next_chunk(SPEED_HZ, min(s.chunk_samples, n - done))
        out.append(c.samples)
        done += c.samples.shape[1]
    return np.concatenate(out, axis=1).astype(float), s.channel_names, s


def _bands(f):
    centres = 100.0 * 2.0 ** (np.arange(0, 24) / 3.0)
    for fc in centres[centres * 2 ** (1 / 6) < 10000.0]:
        yield fc, (f >= fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))


def test_the_input_floor_is_white_after_the_mount_and_only_on_the_accelerations(pair):
    with_it, without = pair
    on, names, s = _run(with_it, 8.0)
    off, _, _ = _run(without, 8.0)
    x = on - off
    assert s.ground_truth()["input_noise_m_s2_per_sqrt_hz"] == B
    b, a = signal.butter(2, 2 * np.pi * 200.0, "highpass", analog=True)
    for ch in ("de_vertical_acceleration", "nde_horizontal_acceleration"):
        f, pxx = signal.welch(x[names.index(ch)], FS, nperseg=4096)
        _, h = signal.freqs(b, a, 2 * np.pi * f)
        for fc, sel in _bands(f):           # flat through the mount's resonance (3 kHz): it enters after the mount
            want = np.mean(B ** 2 * np.abs(h[sel]) ** 2)
            assert abs(10 * np.log10(np.mean(pxx[sel]) / want)) < 1.0, (ch, fc)
    for ch in ("de_vertical_displacement", "nde_horizontal_displacement", "de_vertical_velocity"):
        assert np.max(np.abs(x[names.index(ch)])) == 0.0, ch
    # each housing and direction on its own: uncorrelated
    acc = [x[names.index(f"{b}_{d}_acceleration")] for b in ("de", "nde") for d in ("vertical", "horizontal")]
    r = np.corrcoef(np.array(acc))
    assert np.max(np.abs(r - np.eye(4))) < 0.05, r


def test_the_input_floor_adds_to_the_floor_and_its_periodogram_is_the_psd(cached_model, healthy):
    """With both on: the frames' periodogram is ``psd()`` (floor + input floor) within the spread of 4 x 256
    exponential ordinates, and the input floor is the difference of the two ``psd()``."""
    case = Case.load("motor_6010_healthy").with_overrides({KEY: B})
    model = cached_model(case, like=healthy)
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=11, features=False, quantities=["acceleration"])
    fl = s.floor
    assert fl.density > 0 and fl.input_noise == B
    plain = Synthesizer(healthy, sample_rate_hz=FS, chunk_s=0.1, seed=11, features=False,
                        quantities=["acceleration"]).floor
    np.testing.assert_allclose(fl.psd() - plain.psd(), B ** 2, rtol=1e-5)
    x = fl.frames * fl.scale.astype(np.float64)
    n = fl.frame_length
    spec = np.fft.rfft(x, axis=1)[:, 1:n // 2]
    pxx = (2.0 / (FS * n)) * np.mean(np.abs(spec) ** 2, axis=0)
    nb = (pxx.shape[0] // 256) * 256
    got = pxx[:nb].reshape(-1, 256, pxx.shape[1]).mean(axis=1)
    ref = fl.psd()[:nb].reshape(-1, 256, pxx.shape[1]).mean(axis=1)
    ratio = got / ref
    assert np.all(np.abs(ratio - 1.0) < 0.2), ratio.min()
    assert abs(np.mean(ratio) - 1.0) < 0.02


def test_the_same_seed_the_same_input_floor_another_seed_another(pair):
    with_it, without = pair
    x = [_run(with_it, 1.0, seed=seed, quantities=("acceleration",))[0] for seed in (3, 3, 4)]
    y = [_run(without, 1.0, seed=seed, quantities=("acceleration",))[0] for seed in (3, 4)]
    assert np.array_equal(x[0], x[1])
    a, c = x[0][0] - y[0][0], x[2][0] - y[1][0]
    assert abs(np.corrcoef(a, c)[0, 1]) < 0.05


def test_a_negative_input_floor_is_refused_by_name():
    base = Case.load("motor_6010_healthy")
    for value in (-1e-3, float("nan")):
        with pytest.raises(CaseError) as e:
            base.with_overrides({KEY: value})
        assert "input_noise_m_s2_per_sqrt_hz" in str(e.value)
