"""The broadband floor: seeded random force pairs across the bearings, transmitted by the machine's receptance.

Every running machine has a broadband vibration floor under its lines: the rolling contacts' surface roughness,
friction and flow excite the structure at all frequencies, and what an accelerometer shows is that excitation
shaped by the transmission path, with the structure's resonances standing out (a measured floor is never white
alone). Model: at each bearing and in each radial direction an independent, stationary, Gaussian force pair
between rotor and housing node (the input patterns of the bearing lines, :class:`~bkabem_core.solve.harmonic.BkaBem`), of
one-sided force spectral density ``S_F`` [N/sqrt(Hz)], flat over the band (case key
``baseline.broadband_force_n_per_sqrt_hz``, 0 = off). Its response at every channel is

    S_y(f) = S_F^2 sum_{inputs i} |G_c(f) H_{c,i}(f)|^2

with ``H`` the receptance of the channel's displacement combination to force pair i of the FE model at standstill
(reduced modal basis, no gyroscopic coupling: the floor's shape is the non-rotating structure's), ``G_c`` the
channel's factor ((i 2 pi f)^2 for acceleration, 10^3 i 2 pi f for velocity in mm/s, 1 for displacement) and the
measurement chain (accelerometer on the housing channels, anti-alias filter on all; :mod:`bkabem_core.synth.sensors`).

**The acquisition's input floor** (case key ``measurement.input_noise_m_s2_per_sqrt_hz``, 0 = off). A recorded
acceleration carries a broadband floor that is neither the bearing's nor the converter's: the CWRU rig's healthy
record is flat within +-5 dB from 100 Hz to its anti-alias filter, through the housing's and the mount's resonances
that shape everything the machine sends, and 50 dB above its converter's floor (docs/rigs.md). So it enters after
the mount and before the AC coupling and the anti-alias filter: pick-up of the signal line, the conditioner, or
vibration that reaches the sensor by a path the mount does not shape. Model: on each acceleration channel of a
housing an independent, stationary, Gaussian acceleration of flat one-sided density ``B`` [m/s^2/sqrt(Hz)], through
the chain without the accelerometer's mount (:meth:`FloorTransfer.input_transfer`). It is drawn into the same
frames as the floor, from its own stream (:func:`input_normals`), so it costs the render nothing.

**A faulty bearing rolls rougher.** A defect's key ``roughness_db`` (every kind; 0 = as the case) raises the force
pairs of its bearing by that many dB over the case's density (the largest of the bearing's defects): a bearing with
a defect rolls rougher than a sound one (:data:`~bkabem_core.bearing.defects.protocol.ROUGHNESS`). Where a case has
no floor (density 0) there is nothing to raise. The CWRU rig's seeded bearings carry 12-40 dB more than its healthy
one in the housing's band where their signal is Gaussian (docs/rigs.md).

**It follows the load.** Where a load turns with the shaft, each bearing's pairs swing over the turn with the
stiffness of its contacts (:mod:`bkabem_core.synth.rolling`, added on top of this stationary floor from the same
seed).

Source of the level: the force of a rolling contact on its roughness is the contact stiffness times the roughness
displacement. Superfinished raceways and balls of deep-groove bearings have RMS roughness of order 0.02-0.1 um
(Harris & Kotzalas, *Essential concepts of bearing technology*, 5th ed., ch. 23 on surface finish; ISO 15242-1
measures the resulting vibration), the bearing's radial stiffness is ~1e8 N/m (the embedded 6010: 1.2e8 N/m
vertical, Table 1 of the paper): ~5e-8 m x 1.2e8 N/m ~ 6 N RMS spread over 0-25 kHz is ~0.04 N/sqrt(Hz). The
fault-library cases use 0.01 N/sqrt(Hz) (a quiet, new bearing; docs/faults.md); it is a level to set per machine,
not a law.

Realisation: ``N_FRAMES`` periodic frames of ``L = 2^FRAME_BITS`` samples, each an exact sample of the process
(complex Gaussian line amplitudes on the FFT grid f_k = k fs / L with E|A_k|^2 = 2 S_F^2 fs / L per input, through
the receptance, one real inverse FFT of the Hermitian half per frame, once per seed: :meth:`BroadbandFloor.reseeded`;
the seed-independent part, state space, receptance, measurement chain, transfer and window, is a
:class:`FloorTransfer` made once per machine structure (the standstill modal basis: every defect model of one
machine has the same) and channel set in the process and shared by every floor of them, so a data set's next run or
defect, a fleet's next machine or a scenario's next state makes its frames only), and the output is an overlap of
*grains*: grain g covers samples [g S, g S + 2 S), S = L / 2, reading frame ``2 (g mod 2) + (h_g mod 2)`` from offset
``h_g / 2 mod L`` (``h_g`` a hash of seed and g) under the sine window ``sin(pi t / 2 S)``. Two grains overlap at
every sample, from different frames (one even, one odd grain), and their windows' squares add to 1, so the floor is
Gaussian with the PSD above (smeared by the window, ~1.5 lines), stationary, not periodic, seeded and a function of
the absolute sample index only (any chunking gives the same samples; continuous: each grain fades in and out from
0). Per sample: two taps of every channel (``kernels/synth_floor.c``), added inside the sample loop with the noise.

Storage: int16 with one scale per channel (max |x| of the frames / 32767: quantisation ~-87 dB below the floor's
RMS, white; >= 53 dB under the floor in every third-octave band from 200 Hz to 20 kHz; float16 would give 46 dB and
loses displacements of ~1e-9 m to underflow): 4 x 2^15 x 8 x 2 B = 2 MB read at two taps a sample, half the bytes
of float32 frames (the render is bound by its memory traffic). Why not shorter frames (in L2): the frames' resolution
would still be enough (fs / 2^13 = 6.25 Hz, against the narrowest half-power bandwidth 2 zeta f of the machine's
in-band modes, 33 Hz for its 23-Hz shaft mode, 83 Hz and more for the ~1.5 % damped modes from 2.2 kHz), but the
frames are the floor's only randomness: its long-run spectrum is the 4 frames' periodograms, N_FRAMES x L / 2
complex amplitudes per input, and a third-octave band holds L / 2^15 as many of them. With 2^13 the 250-Hz band of
nde_horizontal_acceleration came out 1.13 dB off the FE receptance (test_floor: 1 dB; a spread of ~sqrt(2 / lines)
in power), so the frames keep their 2^17 lines.

A seed's frames (:meth:`FloorTransfer.frames`), float32 throughout: the amplitudes' normals come from the sensor
noise's generator (``kernels/synth_noise.c``: 8 a line, the real then the imaginary parts of the four force pairs,
stream :func:`frame_keys`, one per seed and frame), multiplied by the complex64 transfer and summed over the pairs in
one C pass (``kernels/synth_floor.c``), one float32 real inverse FFT (scipy.fft), then the scales and the int16
rounding in one C pass. The normals are standard normal to the generator's 22-bit grid (``kernels/synth_noise.h``),
and float32's rounding of the transfer, product and FFT lies far below the int16 step (3e-5 of the frame's largest
value) the frames are stored at anyway: against a float64 transcription of the definition with the same normals the
stored frames are off by at most 0.504 of a step (0.5 is the rounding; RMS 0.289 = 1/sqrt(12), the quantisation
alone; 4 and 8 channels, 2 seeds). tests/unit/test_floor.py holds them to that transcription (half a step plus
float32 rounding), their periodogram to the PSD, and the floor's third-octave bands to the FE receptance.

Units: forces N, densities N/sqrt(Hz), frequencies Hz, samples in the channels' units.
"""

from __future__ import annotations

import hashlib
import math
import threading
import weakref
from collections import OrderedDict

import numpy as np
import scipy.fft

from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.sensors import SensorChain
from bkabem_core.synth.splitmix import GOLDEN, MASK64, mix64

FRAME_BITS = 15                 # frame length L = 2^15 samples (0.64 s at 51.2 kHz: 1.56 Hz line spacing)
N_FRAMES = 4
_TAG = 0xF1005
_INPUT_TAG = 0xBAC6


def _state_space(model):
    """(poles (2m,), modal outputs (8, 2m), modal inputs (2m, 4)) of the machine at standstill (the reduced modal
    basis, ``(K + i w C - w^2 M) q = P f``): one eigen-decomposition of its state matrix."""
    basis = model.basis
    m = basis.M.shape[0]
    minv = np.linalg.inv(basis.M)
    a = np.zeros((2 * m, 2 * m))
    a[:m, m:] = np.eye(m)
    a[m:, :m] = -minv @ basis.K
    a[m:, m:] = -minv @ basis.C
    b = np.zeros((2 * m, 4))
    b[m:] = minv @ basis.inputs[:, :4]
    lam, vec = np.linalg.eig(a)
    return lam, basis.outputs @ vec[:m], np.linalg.solve(vec, b)


def receptance(model, frequency_hz: np.ndarray, state_space=None) -> np.ndarray:
    """(F, 8, 4) complex receptance [m/N] of the output displacements (LOCATIONS x DIRECTIONS of
    :mod:`bkabem_core.solve.harmonic`) to a unit force pair across each bearing and direction (de vertical, de horizontal,
    nde vertical, nde horizontal: +1 N on the rotor node, -1 N on the housing node) at ``frequency_hz`` [Hz], of the
    machine at standstill: a pole-residue sum at every frequency (``state_space``: :func:`_state_space`, made if
    not given)."""
    lam, left, right = _state_space(model) if state_space is None else state_space
    m2 = lam.size
    s = 2j * np.pi * np.asarray(frequency_hz, dtype=float)
    g = 1.0 / (s[:, None] - lam[None, :])                           # (F, 2m)
    res = (left[:, :, None] * right[None, :, :]).transpose(1, 0, 2).reshape(m2, -1)   # (2m, 8 x 4)
    return (g @ res).reshape(s.size, 8, 4)


class FloorTransfer:
    """The seed-independent part of a floor: each channel's transfer from the four force pairs on the frames' FFT
    grid ``f_k = k fs / L``, k = 1 .. L/2 - 1 (receptance of the standstill state space, measurement chain,
    channel factor), and the grains' window. Made once per machine structure and channel set (:meth:`shared`) and
    shared, read only, by every :class:`BroadbandFloor` of them, whatever its defects, seed or level: a data set's
    runs (one seed each), a fleet's machines and a scenario's states pay only their own frames (:meth:`frames`;
    a sixth of the whole floor's work).
    Memory: (4, F, C) complex64, 2 MB at 4 channels, once per process instead of once per synthesiser.

    Parameters: those of :class:`BroadbandFloor` without the density and seed.
    """

    #: structure digest -> LRU {key: FloorTransfer}: the models of one machine (its defects, kinds, sizes: the
    #: same standstill structure) share them; an entry goes with the last live model of its structure
    _shared: dict[bytes, OrderedDict] = {}
    #: structure digest -> ids of the live models that use it (weakref.finalize removes each)
    _users: dict[bytes, set] = {}
    #: transfers kept per structure (one per channel set, rate and chain: 2-8 MB each)
    CACHE = 4
    _lock = threading.Lock()

    def __init__(self, model, combination, cindex, power, scale, housing_cols, sample_rate_hz: float,
                 sensors: SensorChain = SensorChain()):
        self.sample_rate_hz = fs = float(sample_rate_hz)
        n = 1 << FRAME_BITS
        self.frame_length = n
        self.half = n // 2
        f = np.arange(1, n // 2) * fs / n
        h = np.einsum("uo,foi->fui", combination, receptance(model, f))       # (F, U, 4) [m/N]
        gains = sensors.gains(f, housing_cols, combination.shape[0])
        if gains is not None:
            h = h * gains[:, :, None]
        iw = 2j * np.pi * f
        fac = np.stack([np.ones_like(iw), iw, iw * iw])[np.asarray(power, dtype=int)].T * np.asarray(scale)[None, :]
        transfer = h[:, np.asarray(cindex)] * fac[:, :, None]                  # (F, C, 4) channel per N
        #: (4, F, C) complex64: per force pair, the transfer to every channel, contiguous (the frames' C pass;
        #: float32 as the frames: its rounding, ~6e-8 relative, is far below the frames' own spread)
        self.by_input = np.ascontiguousarray(transfer.transpose(2, 0, 1), dtype=np.complex64)
        self.frequency_hz = f
        #: (F, C) complex64: the chain without the mount on each housing acceleration channel (0 elsewhere)
        self.by_input_noise = self.input_transfer(f, cindex, power, housing_cols, combination.shape[0], sensors)
        t = np.arange(2 * self.half)
        self.window = np.sin(np.pi * t / (2 * self.half)).astype(np.float32)
        for a in (self.by_input, self.by_input_noise, self.frequency_hz, self.window):
            a.flags.writeable = False

    @staticmethod
    def input_transfer(f, cindex, power, housing_cols, n_columns: int, sensors: SensorChain) -> np.ndarray:
        """(F, C) complex64 gain of the acquisition's input floor (module docstring) at ``f`` [Hz] on each channel:
        the chain without the accelerometer's mount on the acceleration channels of a housing, 0 on the others."""
        chain = SensorChain(tuple(s for s in sensors.sensors if s.name != "accelerometer"))
        gains = chain.gains(f, housing_cols, n_columns)
        housing = {int(u) for u in np.asarray(housing_cols).ravel()}
        out = np.zeros((f.size, len(cindex)), complex)
        for c, (u, p) in enumerate(zip(np.asarray(cindex, dtype=int), np.asarray(power, dtype=int))):
            if u in housing and p == 2:
                out[:, c] = 1.0 if gains is None else gains[:, u]
        return out.astype(np.complex64)

    @property
    def transfer(self) -> np.ndarray:
        """(F, C, 4) complex transfer [channel unit / N] at :attr:`frequency_hz` (a read-only view)."""
        return self.by_input.transpose(1, 2, 0)

    @staticmethod
    def structure_key(model) -> bytes:
        """Digest of what the transfer takes of the model: its standstill structure, the reduced modal basis (M, K,
        C, the force pairs' inputs, the outputs). The defects of a machine excite it but do not change it, so the
        models of one machine (a scenario's states, a fleet's or a data set's defect kinds and sizes) have one key
        (a digest instead of the transfer)."""
        b = model.basis
        h = hashlib.blake2b(digest_size=20)
        for a in (b.M, b.K, b.C, b.inputs[:, :4], b.outputs):
            a = np.ascontiguousarray(a, dtype=float)
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
        return h.digest()

    @classmethod
    def shared(cls, model, combination, cindex, power, scale, housing_cols, sample_rate_hz: float,
               sensors: SensorChain = SensorChain()) -> "FloorTransfer":
        """The transfer of these arguments, made once per machine structure (:meth:`structure_key`) and arguments
        in the process (an LRU of :attr:`CACHE` per structure) and kept while a model of that structure lives: the
        same arrays for every floor of them, whichever of the machine's models asks."""
        def key_of(a):
            a = np.ascontiguousarray(a)
            return a.shape, a.dtype.str, a.tobytes()
        key = (key_of(combination), key_of(cindex), key_of(power), key_of(scale), key_of(housing_cols),
               float(sample_rate_hz), sensors)
        structure = cls.structure_key(model)
        with cls._lock:                     # a fleet's machines may bind from several threads: one making each
            users = cls._users.setdefault(structure, set())
            if id(model) not in users:
                users.add(id(model))
                weakref.finalize(model, cls._release, structure, id(model))
            lru = cls._shared.setdefault(structure, OrderedDict())
            made = lru.get(key)
            if made is None:
                made = lru[key] = cls(model, combination, cindex, power, scale, housing_cols, sample_rate_hz,
                                      sensors)
                while len(lru) > cls.CACHE:
                    lru.popitem(last=False)
            else:
                lru.move_to_end(key)
            return made

    @classmethod
    def _release(cls, structure: bytes, model_id: int) -> None:
        """A model of ``structure`` is gone: the structure's transfers go with the last one."""
        with cls._lock:
            users = cls._users.get(structure)
            if users is None:
                return
            users.discard(model_id)
            if not users:
                cls._users.pop(structure, None)
                cls._shared.pop(structure, None)

    def frames(self, density: float, seed: int, input_noise: float = 0.0, by_input=None) -> tuple:
        """(int16 frames (N_FRAMES, L, C), float32 scale per channel) of a floor of ``density`` [N/sqrt(Hz)], the
        acquisition's ``input_noise`` [m/s^2/sqrt(Hz)] and ``seed`` (module docstring). Per frame i: the complex amplitudes of
        the four force pairs from the stream :func:`frame_keys` ``(seed)[i]`` of the sensor noise's ziggurat, times
        the transfer and summed over the pairs in one C pass into the Hermitian half of the spectrum
        (:func:`synth_kernel.floor_spectrum`, complex64); the input floor's amplitudes from :func:`input_normals`
        ``(seed, i)`` times its transfer added to it; one float32 real inverse FFT;
        then one scale per channel and the int16 rounding in one C pass (:func:`synth_kernel.floor_quantise`).
        ``by_input``: the force pairs' transfer scaled per pair (a faulty bearing's roughness), else :attr:`by_input`."""
        n, fs = self.frame_length, self.sample_rate_hz
        by_input = self.by_input if by_input is None else by_input
        c = by_input.shape[2]
        # E|A|^2 = 2 S^2 df: (g1 + i g2) sqrt(S^2 df); the factor 1/2 (exact) makes the unnormalised real inverse
        # FFT of the half spectrum, X_0 + 2 Re sum_k X_k e^(i 2 pi k t / L), the real part of the one-sided sum
        scale_a = 0.5 * (float(density) * math.sqrt(fs / n))
        scale_b = 0.5 * (float(input_noise) * math.sqrt(fs / n))
        frames = np.empty((N_FRAMES, n, c), dtype=np.float32)
        half = np.zeros((n // 2 + 1, c), np.complex64)
        for i, key in enumerate(frame_keys(seed)):
            if density > 0.0:                       # the C pass writes the half spectrum (no sum into it)
                synth_kernel.floor_spectrum(key, by_input, scale_a, half[1:n // 2])
            else:
                half[:] = 0.0
            if input_noise > 0.0:
                half[1:n // 2] += input_normals(seed, i, self.by_input_noise.shape) * np.float32(scale_b) \
                    * self.by_input_noise
            frames[i] = scipy.fft.irfft(half, n, axis=0, norm="forward")
        return synth_kernel.floor_quantise(frames)


def frame_keys(seed: int) -> list:
    """The 64-bit keys of the normals of the ``N_FRAMES`` frames of a floor of ``seed`` (the sensor noise's
    generator, ``kernels/synth_noise.c``): one ``SeedSequence([seed, _TAG])``, its first N_FRAMES words (another tag than
    the sensor noise's :func:`~bkabem_core.synth.randomness.noise_key`, so the streams are independent; one sequence
    and not one per frame)."""
    return [int(k) for k in np.random.SeedSequence([int(seed), _TAG]).generate_state(N_FRAMES, np.uint64)]


def input_normals(seed: int, frame: int, shape: tuple) -> np.ndarray:
    """Complex64 array of ``shape`` (lines, channels) with independent standard normal real and imaginary parts: the
    input floor's amplitudes in frame ``frame`` of a floor of ``seed`` (numpy's PCG64 on
    ``SeedSequence([seed, _INPUT_TAG, frame])``: a stream of its own, independent of the floor's)."""
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), _INPUT_TAG, int(frame)])))
    g = rng.standard_normal((*shape, 2), dtype=np.float32)
    return g[..., 0] + 1j * g[..., 1]


class BroadbandFloor:
    """The floor of one synthesiser's channels (module docstring).

    Parameters
    ----------
    model : BkaBem
    density_n_rthz : float
        One-sided force spectral density of every force pair [N/sqrt(Hz)] (>= 0).
    combination, cindex, power, scale : ndarray
        The synthesiser's displacement combinations (U, 8), each channel's row, power of (i omega) and unit scale
        (:class:`bkabem_core.synth.channels.ChannelMap`).
    housing_cols : ndarray of int
        Combinations that are housing displacements (the accelerometer acts there).
    sample_rate_hz : float
    seed : int
    sensors : SensorChain
        The measurement chain (:mod:`bkabem_core.synth.sensors`).
    input_noise_m_s2_rthz : float
        One-sided density of the acquisition's input floor on each housing acceleration channel [m/s^2/sqrt(Hz)]
        (>= 0; with ``density_n_rthz``, not both 0).
    pair_gains : sequence of 4 float or None
        Amplitude factor of each force pair (de vertical, de horizontal, nde vertical, nde horizontal) over
        ``density_n_rthz``: a faulty bearing's roughness (None: 1 each).

    The seed-independent part is the process's :meth:`FloorTransfer.shared` one; a floor of another seed is
    :meth:`reseeded` (its frames only).
    """

    def __init__(self, model, density_n_rthz: float, combination, cindex, power, scale, housing_cols,
                 sample_rate_hz: float, seed: int, sensors: SensorChain = SensorChain(),
                 input_noise_m_s2_rthz: float = 0.0, pair_gains=None):
        path = FloorTransfer.shared(model, combination, cindex, power, scale, housing_cols, sample_rate_hz, sensors)
        gains = np.ones(4) if pair_gains is None else np.asarray(pair_gains, dtype=float)
        #: the force pairs' transfer with their gains (:attr:`FloorTransfer.by_input` itself where all are 1)
        self.by_input = path.by_input if np.all(gains == 1.0) else np.ascontiguousarray(
            path.by_input * gains[:, None, None].astype(np.float32))
        self.pair_gains = gains
        self._seeded(path, density_n_rthz, seed, input_noise_m_s2_rthz)

    def _seeded(self, path: FloorTransfer, density_n_rthz: float, seed: int, input_noise_m_s2_rthz: float) -> None:
        self.path = path
        self.density = float(density_n_rthz)
        self.input_noise = float(input_noise_m_s2_rthz)
        self.sample_rate_hz = path.sample_rate_hz
        self.frame_length = path.frame_length
        self.half = path.half
        self.frequency_hz = path.frequency_hz
        self.window = path.window
        self.seed = int(seed)
        #: (N_FRAMES, L, C) int16; per channel: frames = scale * the int16 frames (max |x| -> 32767; 1 for a
        #: channel without floor)
        self.frames, self.scale = path.frames(self.density, self.seed, self.input_noise, self.by_input)
        self._key = mix64(self.seed ^ _TAG)
        self._buf = np.empty((0, self.frames.shape[2]), dtype=np.float32)
        self._rows: dict = {}
        self._last_grains = None

    def reseeded(self, seed: int) -> "BroadbandFloor":
        """The floor of these channels and level with another seed: this one's transfer and window (shared), new
        frames; the same samples as a floor made from scratch with that seed."""
        floor = BroadbandFloor.__new__(BroadbandFloor)
        floor.by_input, floor.pair_gains = self.by_input, self.pair_gains
        floor._seeded(self.path, self.density, seed, self.input_noise)
        return floor

    def pairs_only(self, mask) -> "BroadbandFloor":
        """The part of this floor that force pairs ``mask`` (4 factors: 1 keeps a pair, 0 drops it) make: the same seed,
        normals and grains, the other pairs and the input floor left out (:mod:`bkabem_core.synth.rolling` swings a
        bearing's part)."""
        m = np.asarray(mask, dtype=float)
        floor = BroadbandFloor.__new__(BroadbandFloor)
        floor.by_input = np.ascontiguousarray(self.by_input * m[:, None, None].astype(np.float32))
        floor.pair_gains = self.pair_gains * m
        floor._seeded(self.path, self.density, self.seed, 0.0)
        return floor

    @property
    def transfer(self) -> np.ndarray:
        """(F, C, 4) complex transfer [channel unit / N] at :attr:`frequency_hz`, each pair with its gain."""
        return self.by_input.transpose(1, 2, 0)

    def psd(self) -> np.ndarray:
        """(F, C) one-sided PSD of the floor and the input floor at :attr:`frequency_hz` [channel unit^2 / Hz]."""
        return (self.density ** 2 * np.sum(np.abs(self.transfer) ** 2, axis=2)
                + self.input_noise ** 2 * np.abs(self.path.by_input_noise) ** 2)

    def _grain(self, g: int) -> tuple:
        """(grain, frame, offset) of grain g (remembered: a grain spans ~3 chunks)."""
        row = self._rows.get(g)
        if row is None:
            h = mix64((self._key + (g & MASK64) * GOLDEN) & MASK64)
            row = self._rows[g] = (g, 2 * (g & 1) + (h & 1), (h >> 1) % self.frame_length)
            if len(self._rows) > 64:
                del self._rows[next(iter(self._rows))]
        return row

    def grains(self, n0: int, n: int) -> np.ndarray:
        """(G, 3) int64 (grain, frame, offset) of the grains over samples [n0, n0 + n) (not to be modified: the last
        range's array is kept and returned again, a grain spans ~3 chunks, so consecutive segments mostly ask for the
        same grains)."""
        s = self.half
        g0, g1 = n0 // s - 1, (n0 + n - 1) // s + 1
        last = self._last_grains
        if last is not None and last[0] == g0 and last[1] == g1:
            return last[2]
        arr = np.array([self._grain(g) for g in range(g0, g1)], dtype=np.int64)
        self._last_grains = (g0, g1, arr)
        return arr

    def source(self, n0: int, n: int) -> tuple:
        """What the line-set kernel needs to render samples [n0, n0 + n) itself (:meth:`~bkabem_core.synth.render.FusedLines.segment`):
        (frames, window, grains, half, scale)."""
        return self.frames, self.window, self.grains(n0, n), self.half, self.scale

    def render(self, n0: int, n: int) -> np.ndarray:
        """(n, C) float32 floor at absolute samples n0 .. n0 + n - 1 (a view of a buffer reused by the next call)."""
        if self._buf.shape[0] < n:
            self._buf = np.empty((n, self.frames.shape[2]), dtype=np.float32)
        out = self._buf[:n]
        synth_kernel.floor_render(n0, n, self.half, self.frames, self.window, self.grains(n0, n), out, self.scale)
        return out
