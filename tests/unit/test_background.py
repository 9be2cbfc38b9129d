"""The rig's background (``baseline.background_acceleration_m_s2_per_sqrt_hz``): each housing and radial direction
moves with an independent white acceleration of density B, read by the housing channels and not by the
shaft-relative displacement.

Isolated through the public API as the floor is (tests/unit/test_floor.py): a synthesiser with the background and
one with ``broadband_floor=False``, same seed, no sensor noise; their difference is the background. Oracle, written
here: a white acceleration of one-sided density B has the PSD B^2 [m^2/s^4/Hz]; its velocity (mm/s) the PSD
(1e3 B / (2 pi f))^2; against a Welch PSD (Hann, 4096 points) of 8 s in third-octave bands.
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
KEY = "baseline.background_acceleration_m_s2_per_sqrt_hz"


@pytest.fixture(scope="module")
def healthy(cached_model):
    return cached_model(Case.load("motor_6010_healthy"))


@pytest.fixture(scope="module")
def background_only(cached_model, healthy):
    case = Case.load("motor_6010_healthy").with_overrides({"baseline.broadband_force_n_per_sqrt_hz": 0.0, KEY: B})
    return cached_model(case, like=healthy)


def _run(model, seconds, floor=True, seed=3, quantities=("acceleration", "displacement", "velocity")):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=seed, features=False, broadband_floor=floor,
                    quantities=list(quantities))
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


def test_the_background_is_white_housing_acceleration_and_not_in_the_shaft_probe(background_only):
    on, names, s = _run(background_only, 8.0)
    off, _, _ = _run(background_only, 8.0, floor=False)
    x = on - off
    assert s.ground_truth()["background_acceleration_m_s2_per_sqrt_hz"] == B
    assert s.ground_truth()["broadband_force_n_per_sqrt_hz"] == 0.0
    for ch in ("de_vertical_acceleration", "nde_horizontal_acceleration"):
        f, pxx = signal.welch(x[names.index(ch)], FS, nperseg=4096)
        for fc, sel in _bands(f):
            assert abs(10 * np.log10(np.mean(pxx[sel]) / B ** 2)) < 1.0, (ch, fc)
    f, pxx = signal.welch(x[names.index("de_horizontal_velocity")], FS, nperseg=4096)
    for fc, sel in _bands(f):
        want = np.mean((1e3 * B / (2 * np.pi * f[sel])) ** 2)
        assert abs(10 * np.log10(np.mean(pxx[sel]) / want)) < 1.0, ("velocity", fc)
    # the shaft follows its housing: a proximity probe does not read the rig's background
    for ch in ("de_vertical_displacement", "nde_horizontal_displacement"):
        assert np.max(np.abs(x[names.index(ch)])) == 0.0, ch
    # each housing and direction on its own: uncorrelated
    acc = [x[names.index(f"{b}_{d}_acceleration")] for b in ("de", "nde") for d in ("vertical", "horizontal")]
    r = np.corrcoef(np.array(acc))
    assert np.max(np.abs(r - np.eye(4))) < 0.05, r


def test_the_background_adds_to_the_floor_and_its_periodogram_is_the_psd(cached_model, healthy):
    """With both on: the frames' periodogram is ``psd()`` (floor + background) within the spread of 4 x 256
    exponential ordinates, and the background is the difference of the two ``psd()``."""
    case = Case.load("motor_6010_healthy").with_overrides({KEY: B})
    model = cached_model(case, like=healthy)
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=11, features=False, quantities=["acceleration"])
    fl = s.floor
    assert fl.density > 0 and fl.background == B
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


def test_the_same_seed_the_same_background_another_seed_another(background_only):
    a, names, _ = _run(background_only, 1.0, quantities=("acceleration",))
    b, _, _ = _run(background_only, 1.0, quantities=("acceleration",))
    c, _, _ = _run(background_only, 1.0, seed=4, quantities=("acceleration",))
    assert np.array_equal(a, b)
    i = names.index("de_vertical_acceleration")
    assert abs(np.corrcoef(a[i], c[i])[0, 1]) < 0.05


def test_a_negative_or_implausible_background_is_refused_by_name():
    base = Case.load("motor_6010_healthy")
    for value in (-1e-3, 50.0):
        with pytest.raises(CaseError) as e:
            base.with_overrides({KEY: value})
        assert "background_acceleration_m_s2_per_sqrt_hz" in str(e.value)
