"""The broadband floor (issue 12, ``baseline.broadband_force_n_per_sqrt_hz``): its spectrum is the FE's.

The floor is isolated through the public API: two synthesisers of the healthy machine with the same seed and no
sensor noise, one with ``broadband_floor=False``; their difference is the floor. Oracle: the one-sided PSD
``S_F^2 sum_i |(i w)^p H_ci(w)|^2`` of four independent force pairs (DE/NDE x vertical/horizontal) through the
receptance of the FE's reduced model, solved here directly, ``(K + i w C - w^2 M) q = P``, at every frequency
(the code under test uses a state-space eigen-decomposition), against a Welch PSD (Hann, 4096 points) of 8 s,
averaged in third-octave bands from 200 Hz to 20 kHz.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from bkabem_core.model.case import Case
from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS
from bkabem_core.synth.synthesizer import Synthesizer

FS = 51200.0
SPEED_HZ = 25.0


@pytest.fixture(scope="module")
def healthy(cached_model):
    return cached_model(Case.load("motor_6010_healthy"))


def _run(model, seconds, floor=True, seed=5, chunk_s=0.1):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=chunk_s, seed=seed, features=False, broadband_floor=floor)
    n = int(round(seconds * FS))
    out, done = [], 0
    while done < n:
        c = s.next_chunk(SPEED_HZ, min(s.chunk_samples, n - done))
        out.append(c.samples)
        done += c.samples.shape[1]
    return np.concatenate(out, axis=1).astype(float), s.channel_names


def _fe_psd(model, f, density, channel):
    """One-sided PSD [unit^2/Hz] of a channel (``<bearing>_<direction>_<quantity>``) under the floor's forces."""
    b = model.basis
    bearing, direction, quantity = channel.split("_")
    row = np.zeros(b.outputs.shape[0])
    row[LOCATIONS.index(f"{bearing}_housing") * len(DIRECTIONS) + DIRECTIONS.index(direction)] = 1.0
    if quantity == "displacement":                         # shaft relative to housing
        row *= -1.0
        row[LOCATIONS.index(f"{bearing}_rotor") * len(DIRECTIONS) + DIRECTIONS.index(direction)] = 1.0
    c_out = row @ b.outputs
    psd = np.empty(f.size)
    for i, fi in enumerate(f):
        w = 2 * np.pi * fi
        q = np.linalg.solve(b.K + 1j * w * b.C - w * w * b.M, b.inputs[:, :4])
        h = c_out @ q                                       # (4,) [m/N]
        g = (1j * w) ** 2 if quantity == "acceleration" else 1.0
        psd[i] = density ** 2 * np.sum(np.abs(g * h) ** 2)
    return psd


def test_floor_psd_is_the_fe_transmission_of_the_bearing_forces(healthy):
    density = float(healthy.case.raw["baseline"]["broadband_force_n_per_sqrt_hz"])
    assert density > 0
    with_floor, names = _run(healthy, 8.0)
    without, _ = _run(healthy, 8.0, floor=False)
    x = with_floor - without
    for channel in ("de_vertical_acceleration", "nde_horizontal_acceleration", "de_vertical_displacement"):
        xi = x[names.index(channel)]
        f, pxx = signal.welch(xi, FS, nperseg=4096)
        centres = 200.0 * 2.0 ** (np.arange(0, 26) / 3.0)
        centres = centres[centres * 2 ** (1 / 6) < 20000.0]
        for fc in centres:
            sel = (f >= fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))
            want = np.mean(_fe_psd(healthy, f[sel], density, channel))
            got = np.mean(pxx[sel])
            assert abs(10 * np.log10(got / want)) < 1.0, (channel, fc, got, want)


def test_floor_is_gaussian_seeded_and_chunking_invariant(healthy):
    a, names = _run(healthy, 2.0)
    off, _ = _run(healthy, 2.0, floor=False)
    b, _ = _run(healthy, 2.0, chunk_s=0.037)
    off_b, _ = _run(healthy, 2.0, floor=False, chunk_s=0.037)
    x, xb = a - off, b - off_b
    # any chunking: the same floor (to the float32 rounding of the lines it is added to; streamed knots sit on the
    # chunk borders, so the lines themselves agree to rounding only)
    assert np.max(np.abs(x - xb)) <= 1e-5 * np.max(np.abs(x))
    c, _ = _run(healthy, 2.0, seed=6)
    y = c - off
    i = names.index("de_vertical_acceleration")
    assert np.corrcoef(x[i], y[i])[0, 1] < 0.05              # another seed: another floor
    z = (x[i] - x[i].mean()) / x[i].std()
    assert abs(np.mean(z ** 4) - 3.0) < 0.15                 # Gaussian (kurtosis 3; a sine is 1.5)
    assert abs(np.mean(z ** 3)) < 0.05


def test_a_new_seed_after_reset_gives_the_new_seeds_floor(healthy):
    """A reused synthesiser (a data set's worker: ``seed`` set, ``reset()``) renders what a fresh one with that seed
    renders: the floor's frames and grains follow the seed, not the synthesiser's first seed."""
    s = Synthesizer(healthy, sample_rate_hz=FS, chunk_s=0.1, seed=5, features=False, broadband_floor=True)
    for _ in range(3):
        s.next_chunk(SPEED_HZ)
    s.seed = 9
    s.reset()
    reused = np.concatenate([s.next_chunk(SPEED_HZ).samples for _ in range(3)], axis=1).astype(float)
    fresh = _run(healthy, 0.3, seed=9)[0]
    assert np.array_equal(reused, fresh)
    assert not np.array_equal(fresh, _run(healthy, 0.3, seed=5)[0])


def test_int16_frames_and_the_c_render_equal_the_numpy_render(healthy, monkeypatch):
    """The frames are int16 with a scale per channel (half the bytes of float32: the render is bound by memory);
    their quantisation is below 1/32767 of each channel's largest value, and the C render (any split) equals the
    numpy fallback's operations bit for bit."""
    from bkabem_core.synth import kernel as synth_kernel

    s = Synthesizer(healthy, sample_rate_hz=FS, chunk_s=0.1, seed=5, features=False, broadband_floor=True)
    fl = s.floor
    assert fl.frames.dtype == np.int16 and fl.scale.dtype == np.float32
    assert np.abs(fl.frames).max(axis=(0, 1)).min() == 32767        # every channel uses the whole range
    n0, n = 3 * fl.half - 1000, 9000                                 # across grain borders
    c_out = fl.render(n0, n).copy()
    parts = np.concatenate([fl.render(n0, 4001).copy(), fl.render(n0 + 4001, n - 4001).copy()])
    np.testing.assert_array_equal(parts, c_out)
    monkeypatch.setattr(synth_kernel, "AVAILABLE", False)                # the numpy fallback
    ref = np.empty_like(c_out)
    synth_kernel.floor_render(n0, n, fl.half, fl.frames, fl.window, fl.grains(n0, n), ref, fl.scale)
    np.testing.assert_array_equal(c_out, ref)
    rms = c_out.std(axis=0)
    # two grains overlap: |w1 f1 + w2 f2| <= (w1 + w2) max|f| <= sqrt(2) max|f|
    assert np.all(rms > 0) and np.all(np.abs(c_out).max(axis=0) <= 32767 * fl.scale * 1.4143)


def _frames_by_the_definition(fl):
    """The floor's frames as the module docstring defines them, in float64 by the first implementation's
    operations: per frame the complex amplitudes of the four force pairs (the frame's normals, taken from the
    sensor noise's generator here: the sample loop's normals of ``frame_keys``, 8 a line), through the transfer
    (einsum), the one-sided spectrum's complex inverse FFT (real part). Returns (N_FRAMES, L, C) float64."""
    from bkabem_core.synth import kernel as synth_kernel
    from bkabem_core.synth.floor import N_FRAMES, frame_keys

    n, fs = fl.frame_length, fl.sample_rate_hz
    t = fl.transfer.astype(np.complex128)
    frames = np.empty((N_FRAMES, n, t.shape[1]))
    for i in range(N_FRAMES):
        z = np.empty((t.shape[0], 8), np.float32)                      # a zero table, sigma 1: the normals
        synth_kernel.segment(0, 1 << 40, 0, None, np.zeros((67, 8), np.float32), None, 0.0, 0.0, z,
                             noise=(frame_keys(fl.seed)[i], 0, np.ones(8, np.float32), None))
        z = z.astype(np.float64)
        a = fl.density * np.sqrt(fs / n) * (z[:, :4] + 1j * z[:, 4:])
        spec = np.zeros((n, t.shape[1]), complex)
        spec[1:n // 2] = np.einsum("fci,fi->fc", t, a)
        frames[i] = np.fft.ifft(spec, axis=0).real * n
    return frames


def _assert_frames_are_the_definitions(fl):
    """The int16 frames times their scales are the float64 definition's frames to the int16 step (half a step of
    rounding) plus the float32 arithmetic of the C pass and the FFT (~1e-6 of the largest value); every channel
    uses the whole int16 range."""
    ref = _frames_by_the_definition(fl)
    top = np.abs(ref).max(axis=(0, 1))
    np.testing.assert_allclose(fl.scale, top / 32767.0, rtol=1e-5)
    err = np.abs(fl.frames * fl.scale.astype(np.float64) - ref).max(axis=(0, 1))
    assert np.all(err <= 0.5 * fl.scale + 2e-6 * top), (err / fl.scale)
    assert np.all(np.abs(fl.frames).max(axis=(0, 1)) == 32767)


def test_a_new_seed_makes_only_the_frames_and_they_are_the_definitions(healthy):
    """A new seed (``reset()``) reuses the seed-independent part: the transfer and window of the first floor, and
    of any other synthesiser of that model and channel set (one per process); the frames, made in float32 by the C
    pass and scipy's real inverse FFT of the Hermitian half, are those of the float64 definition to the int16 step
    and float32 rounding, and the same bits whether the synthesiser is new or reused. Another rate is another
    transfer."""
    s = Synthesizer(healthy, sample_rate_hz=FS, chunk_s=0.1, seed=5, features=False, broadband_floor=True)
    first = s.floor
    s.seed = 9
    s.reset()
    again = s.floor
    assert again is not first and again.seed == 9 and again.path is first.path
    other = Synthesizer(healthy, sample_rate_hz=FS, chunk_s=0.1, seed=9, features=False, broadband_floor=True)
    fresh = other.floor
    assert fresh.path is first.path                        # shared by the process's synthesisers of the model
    np.testing.assert_array_equal(again.frames, fresh.frames)
    np.testing.assert_array_equal(again.scale, fresh.scale)
    assert not np.array_equal(again.frames, first.frames)
    for fl in (first, again):
        _assert_frames_are_the_definitions(fl)
    slow = Synthesizer(healthy, sample_rate_hz=25600.0, chunk_s=0.1, seed=9, features=False, broadband_floor=True,
                       quantities=["acceleration"])
    fl = slow.floor
    assert fl.path is not first.path and fl.frames.shape[2] == 4
    _assert_frames_are_the_definitions(fl)


def test_the_frames_periodogram_is_the_transfer(healthy):
    """The frames are samples of the process: their periodogram, averaged over the four frames and bands of 256
    lines, is the floor's PSD (``psd()``: S_F^2 sum |transfer|^2) within the spread of 4 x 256 exponential
    ordinates (~3 %; 6 sigma: 20 %)."""
    s = Synthesizer(healthy, sample_rate_hz=25600.0, chunk_s=0.1, seed=11, features=False, broadband_floor=True,
                    quantities=["acceleration"])
    fl = s.floor
    x = fl.frames * fl.scale.astype(np.float64)
    n, fs = fl.frame_length, fl.sample_rate_hz
    spec = np.fft.rfft(x, axis=1)[:, 1:n // 2]                          # (N_FRAMES, F, C)
    pxx = (2.0 / (fs * n)) * np.mean(np.abs(spec) ** 2, axis=0)          # one-sided [unit^2/Hz]
    want = fl.psd()
    nb = (pxx.shape[0] // 256) * 256
    got = pxx[:nb].reshape(-1, 256, pxx.shape[1]).mean(axis=1)
    ref = want[:nb].reshape(-1, 256, want.shape[1]).mean(axis=1)
    live = ref > 1e-6 * ref.max(axis=0)                                 # above the quantisation floor (~-87 dB)
    ratio = got[live] / ref[live]
    assert np.all(np.abs(ratio - 1.0) < 0.2), ratio.min()
    assert abs(np.mean(ratio) - 1.0) < 0.02


def test_the_frames_kernels_equal_their_numpy_fallbacks(healthy, monkeypatch):
    """The C pass of a frame's spectrum (normals and transfer product) gives the numpy fallback's normals (bit for
    bit: the scalar and the AVX2 generator too) and its products to float32 rounding; the int16 pass equals its
    fallback bit for bit (a channel without floor: scale 1, zeros)."""
    from bkabem_core.synth import kernel as synth_kernel

    s = Synthesizer(healthy, sample_rate_hz=25600.0, chunk_s=0.1, seed=3, features=False, broadband_floor=True,
                    quantities=["acceleration"])
    by_input = s.floor.path.by_input[:, :700]
    by_input = np.ascontiguousarray(by_input)
    c_out = np.empty(by_input.shape[1:], np.complex64)
    scalar = np.empty_like(c_out)
    synth_kernel.floor_spectrum(12345, by_input, 0.25, c_out)
    synth_kernel.floor_spectrum(12345, by_input, 0.25, scalar, avx2=False)
    np.testing.assert_array_equal(c_out, scalar)
    x = np.random.default_rng(0).standard_normal((2, 4096, 3)).astype(np.float32)
    x[0, 7, 1] = 0.0
    x[:, :, 2] = 0.0                                                    # a channel without floor: scale 1
    q, scale = synth_kernel.floor_quantise(x)
    monkeypatch.setattr(synth_kernel, "AVAILABLE", False)                # the numpy fallbacks
    ref = np.empty_like(c_out)
    synth_kernel.floor_spectrum(12345, by_input, 0.25, ref)
    np.testing.assert_allclose(c_out, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    q_ref, scale_ref = synth_kernel.floor_quantise(x)
    np.testing.assert_array_equal(scale, scale_ref)
    np.testing.assert_array_equal(q, q_ref)
    assert scale[2] == 1.0 and not q[:, :, 2].any() and np.abs(q[:, :, :2]).max() == 32767


def test_the_shared_transfer_serves_a_machines_models_and_goes_with_the_last(monkeypatch, cached_model):
    """The floor transfer (4-8 MB, ~80-150 ms) depends on the machine's standstill structure, not on its defects:
    the healthy and the inner-race model of one machine get the very same transfer (the second one makes none), a
    machine of another structure its own; the process keeps a structure's transfers only while one of its models
    lives (a fleet or a data set that moves on to other machines does not hold the old ones)."""
    import gc

    from bkabem_core.synth.floor import FloorTransfer

    kw = dict(sample_rate_hz=20480.0, chunk_s=0.1, seed=3, features=False, broadband_floor=True,
              quantities=["acceleration"])                  # a rate no other test's transfer has
    healthy, inner = cached_model(Case.load("motor_6010_healthy")), cached_model(Case.load("motor_6010_inner"))
    machine = Case.load("electric_motor_6010").with_overrides({"baseline.broadband_force_n_per_sqrt_hz": 0.01})
    other, other2 = cached_model(machine), cached_model(machine)        # two objects of one structure
    key, okey = FloorTransfer.structure_key(healthy), FloorTransfer.structure_key(other)
    assert FloorTransfer.structure_key(inner) == key != okey == FloorTransfer.structure_key(other2)
    made = []
    real_init = FloorTransfer.__init__

    def counting(self, *a, **k):
        made.append(1)
        real_init(self, *a, **k)
    monkeypatch.setattr(FloorTransfer, "__init__", counting)
    s1 = Synthesizer(healthy, **kw)                         # the plan makes its floor
    assert len(made) == 1
    s2 = Synthesizer(inner, **kw)
    assert len(made) == 1                                   # the inner-race model makes none
    s3, s4 = Synthesizer(other, **kw), Synthesizer(other2, **kw)
    assert len(made) == 2                                   # the other structure one, for both its models
    assert s1.floor.path is s2.floor.path is not s3.floor.path
    assert s3.floor.path is s4.floor.path
    assert s1.floor.path in FloorTransfer._shared[key].values()
    del s3, other
    gc.collect()
    assert okey in FloorTransfer._shared                    # its second model still uses it
    del s4, other2
    gc.collect()
    assert okey not in FloorTransfer._shared and okey not in FloorTransfer._users
