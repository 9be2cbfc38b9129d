"""The rolling noise follows the load on the balls (:mod:`bkabem_core.synth.rolling`): where a load turns with the
shaft, a bearing's broadband floor swings over the turn as its contacts' stiffness does.

Read as a monitoring pipeline reads it: the housing band (2-3.9 kHz, where the CWRU rig's drive-end floor dominates
and below its interference tones) band-passed (Butterworth, scipy.signal), squared, averaged over the shaft angle in
bins (a synchronous average of the band's power). Oracle, written here from the law and the bearing model's static
equilibrium (not from the module under test): the power of independent Hertzian contacts ~ sum_i Q_i^(2/3), the
ball loads under the static load, the preload and the bearing's turning load at each shaft angle, averaged over the
cage's positions in a ball pitch; its first harmonic over the turn against the signal's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from bkabem_core.model.case import Case
from bkabem_core.synth.rolling import swing_gains
from bkabem_core.synth.synthesizer import Synthesizer

FS = 12000.0
SPEED_HZ = 29.95
BAND_HZ = (2000.0, 3900.0)
BINS = 32
SEEDS = (5, 6, 7)
#: the rig's acquisition without what is not the bearing's floor in the band: the input floor, the tones
QUIET = {"measurement.input_noise_m_s2_per_sqrt_hz": 0.0, "measurement.tone_amplitudes_m_s2": [0.0] * 4}


@pytest.fixture(scope="module")
def rig(cached_model):
    return cached_model(Case.load("cwru_rig").with_overrides(QUIET))


@pytest.fixture(scope="module")
def rig_still(cached_model, rig):
    """The same rig without its coupling's turning load."""
    return cached_model(Case.load("cwru_rig").with_overrides({**QUIET, "baseline.coupling_force_n": 0.0}), like=rig)


def _run(model, seconds, seed=5, chunk_s=0.1):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=chunk_s, seed=seed, features=False,
                    quantities=["acceleration"])
    col = s.channel_names.index("de_vertical_acceleration")
    n, out, done, theta0 = int(round(seconds * FS)), [], 0, None
    while done < n:
        c = s.next_chunk(SPEED_HZ, min(s.chunk_samples, n - done))
        theta0 = c.shaft_angle_rad if theta0 is None else theta0
        out.append(np.asarray(c.samples[col], dtype=float))
        done += c.samples.shape[1]
    return np.concatenate(out), theta0


def _power_over_turn(x, theta0):
    """(bins,) mean band power per shaft-angle bin over its mean."""
    sos = signal.butter(6, BAND_HZ, btype="bandpass", fs=FS, output="sos")
    p = signal.sosfiltfilt(sos, x) ** 2
    turns = (theta0 / (2 * math.pi) + SPEED_HZ * np.arange(x.size) / FS) % 1.0
    k = (turns * BINS).astype(int)
    prof = np.bincount(k, p, BINS) / np.bincount(k, None, BINS)
    return prof / prof.mean()


def _first_harmonic(prof):
    c = np.fft.rfft(prof)[1] * 2 / prof.size
    return abs(c), math.degrees(-np.angle(c)) % 360.0      # amplitude [-], angle of the maximum [deg]


def _oracle(model, n=BINS):
    """The contacts' power over the turn (module docstring), normalised to its mean, at the bins' centres."""
    site = model.machine.sites["de"]
    brg, w, r = site.bearing, site.radial_load_n, complex(site.rotating_load_n)
    z = brg.geometry.n_balls
    out = []
    for th in (np.arange(n) + 0.5) * 2 * math.pi / n:
        t = r * complex(math.cos(th), math.sin(th))
        e = brg.state(w[0] + t.real, w[1] + t.imag, axial_load_n=site.axial_load_n).displacement_m
        out.append(np.mean([np.sum(np.clip(brg.ball_loads_n(e[0], e[1], c, 0.0, with_dent=False, e_z_m=e[2]), 0, None)
                                   ** (2 / 3)) for c in np.arange(16) * 2 * math.pi / z / 16]))
    out = np.array(out)
    return out / out.mean()


def _profile(model, seeds=SEEDS):
    runs = [_run(model, 10.0, seed) for seed in seeds]
    return np.mean([_power_over_turn(x, th) for x, th in runs], axis=0), np.concatenate([x for x, _ in runs])


def test_the_floor_swings_over_the_turn_as_the_contacts_stiffness_does(rig, rig_still):
    prof, x = _profile(rig)
    got_amp, got_deg = _first_harmonic(prof)
    want_amp, want_deg = _first_harmonic(_oracle(rig))
    assert 0.05 < want_amp < 0.1, want_amp                 # the rig's drive end: 1.17 : 1 over the turn
    # a seed's floor holds ~11 s of independent samples at 12 kHz (4 frames of 2^15): over 3 seeds the first
    # harmonic of 32 bins' mean power scatters by ~0.01
    assert got_amp == pytest.approx(want_amp, abs=0.025), (got_amp, want_amp)
    assert abs((got_deg - want_deg + 180.0) % 360.0 - 180.0) < 25.0, (got_deg, want_deg)
    still, y = _profile(rig_still)
    assert _first_harmonic(still)[0] < 0.025               # no load turns: a stationary floor
    # the same seeds, the same floor on average: the swing moves the power over the turn, it adds none
    sos = signal.butter(6, BAND_HZ, btype="bandpass", fs=FS, output="sos")
    ratio = np.mean(signal.sosfiltfilt(sos, x) ** 2) / np.mean(signal.sosfiltfilt(sos, y) ** 2)
    assert ratio == pytest.approx(1.0, abs=0.02), ratio


def test_the_swing_is_a_function_of_the_sample_index_whatever_the_chunks(rig):
    a, _ = _run(rig, 1.0, chunk_s=0.1)
    b, _ = _run(rig, 1.0, chunk_s=0.037)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6 * np.max(np.abs(a)))


def test_gains_keep_the_mean_power_and_only_where_a_load_turns(rig, cached_model):
    g = swing_gains(rig)
    assert set(g) == {"de", "nde"}                         # the coupling's load: both bearings carry a share
    for v in g.values():
        assert np.mean(v ** 2) == pytest.approx(1.0, rel=1e-12)
    # the overhung coupling loads the far bearing against the near one: their swings are opposite
    assert abs((np.argmax(g["de"]) - np.argmax(g["nde"])) % g["de"].size - g["de"].size // 2) <= 1
    assert swing_gains(cached_model(Case.load("motor_6010_healthy"))) == {}


def test_the_ground_truth_says_how_much_the_floor_swings(rig, cached_model):
    truth = Synthesizer(rig, sample_rate_hz=FS, seed=1, features=False).ground_truth()["floor_swing"]
    g = swing_gains(rig)
    assert truth["bearings"]["de"]["power_swing"] == pytest.approx(np.max(g["de"] ** 2) / np.min(g["de"] ** 2))
    assert 1.1 < truth["bearings"]["de"]["power_swing"] < 1.3 and truth["bearings"]["nde"]["power_swing"] < 1.1
    healthy = cached_model(Case.load("motor_6010_healthy"))
    assert "floor_swing" not in Synthesizer(healthy, sample_rate_hz=25600.0, seed=1, features=False).ground_truth()


def test_a_bearings_part_of_the_floor_is_its_share_of_the_same_noise(rig):
    """The parts the swing multiplies are the stationary floor's own noise split by bearing: the same seed, normals
    and grains, so the DE part plus the NDE part is the floor (the rig without its input floor), to the int16 steps
    each is stored at."""
    floor = Synthesizer(rig, sample_rate_hz=FS, seed=4, features=False, quantities=["acceleration"])._plan.floor
    de, nde = floor.pairs_only([1, 1, 0, 0]), floor.pairs_only([0, 0, 1, 1])
    whole = floor.render(1000, 6000).copy()
    parts = de.render(1000, 6000).copy() + nde.render(1000, 6000)
    steps = floor.scale + de.scale + nde.scale                     # one rounding each, per channel
    assert np.all(np.abs(whole - parts) <= steps[None, :]), np.max(np.abs(whole - parts) / steps[None, :])
    assert np.std(de.render(0, 6000)) > 0.1 * np.std(whole) and np.std(nde.render(0, 6000)) > 0.0
    assert not np.allclose(de.render(0, 6000), nde.render(0, 6000))
