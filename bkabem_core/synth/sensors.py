"""The measurement chain: what stands between the machine's motion and the samples, as a chain of sensors.

A monitoring pipeline never sees the housing's acceleration itself but what a mounted accelerometer and a data
acquisition make of it. Every element of the chain is linear and time-invariant, so on a sum of lines it is an
exact complex gain per line frequency, applied where the synthesiser evaluates its amplitudes (every knot) and on
the broadband floor's transfer (:mod:`bkabem_core.synth.floor`).

A sensor is an object with

* ``name``: its key in the ground truth and metadata (``"accelerometer"``, ``"anti_alias"``, ...);
* ``measures``: the motion it acts on, ``"housing"`` (the housing's own motion: the acceleration and velocity
  channels) or None (every channel);
* ``gain(frequency_hz)``: its complex frequency response (output / input);
* ``to_dict()``: its parameters, JSON-ready.

:class:`SensorChain` applies the sensors in order. Adding a sensor (a housing transmission path, a charge
amplifier's high-pass, ...) is one class here with these four members, and its entry in :data:`SENSOR_KINDS`
(which names the ground truth always carries, None when absent).

``Accelerometer``
    The sensor on its mount is a base-excited single-degree-of-freedom system (ISO 5348, *Mechanical mounting of
    accelerometers*): output / true acceleration ``H(f) = 1 / (1 - (f/f_n)^2 + 2 i zeta f/f_n)``, +6 dB at
    ``f_n / 2 zeta``... e.g. stud mounting 25-30 kHz, adhesive ~20 kHz, magnet 7-10 kHz (flat magnet on a flat
    spot), hand probe ~2 kHz, with light damping (zeta ~0.02-0.05). Its noise floor is the
    synthesiser's ``noise_density`` (e.g. 100 mV/g ICP sensors: ~5e-5 m/s^2/sqrt(Hz) above 1 kHz); its
    sensitivity [mV/g] is recorded with the data (the samples stay in m/s^2).
``AntiAliasFilter``
    The acquisition's low-pass before sampling: Butterworth of ``order`` with its -3 dB point at ``cutoff_hz``
    (default the usable band ``fs / 2.56``, the 2.56 convention of DAQs: 20 kHz at 51.2 kHz). ``phase =
    "analog"``: the analog response ``H(s) = 1 / B_n(s / omega_c)`` (magnitude and phase, order <= 16).
    ``phase = "linear"``: a digital decimation filter (a linear-phase FIR after oversampling, as in DAT recorders
    and sigma-delta ADCs), the Butterworth magnitude ``1 / sqrt(1 + (f / f_c)^(2 n))`` of any steepness (order <=
    128) with zero phase: such a filter delays every frequency alike, which shifts the whole record in time and
    is left out. E.g. the 12 kHz records of the CWRU rig fall to -3 dB at 5.46 kHz and -40 dB at 5.87 kHz: order 64.
``HighPassFilter``
    The acquisition's AC coupling (the ICP conditioner's or the input's high-pass): analog Butterworth
    ``H(s) = (s / omega_c)^n / B_n(s / omega_c)`` on the housing channels (a proximity probe is DC-coupled).

The acquisition's *output stage* is not linear: it acts on the samples after the lines, the broadband floor and
the sensor noise are summed (:class:`OutputStage`, in this order):

``InterferenceTones``
    Fixed-frequency tones of the acquisition's environment (electromagnetic pick-up of drives and power
    electronics in the cables and the recorder), added to the acceleration channels as recorded: they do not
    follow the speed. A rig property (the CWRU records carry lines at 4025, 4144, 4264 and 4384 Hz of 10-140 mg
    that do not move with the speed; Smith & Randall 2015 report electromagnetic interference at harmonics of about
    4.2 kHz).
``Quantiser``
    The analog-to-digital converter: every acceleration sample rounded to a multiple of its step ``q`` [m/s^2]
    (mid-tread), a white error of RMS ``q / sqrt(12)`` below a few steps of signal, a staircase above.

Frequencies in Hz.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

#: Typical mounting resonances [Hz] (ISO 5348; manufacturers' mounting guides).
MOUNTING_RESONANCE_HZ = {"stud": 28000.0, "adhesive": 20000.0, "magnet": 8500.0, "probe": 2000.0}


@dataclass(frozen=True)
class Accelerometer:
    """A mounted accelerometer (module docstring).

    Attributes
    ----------
    resonance_hz : float
        Mounted resonance f_n [Hz] (:data:`MOUNTING_RESONANCE_HZ`).
    damping_ratio : float
        zeta of the mounted resonance [-], in (0, 1).
    sensitivity_mv_per_g : float
        Recorded with the data [mV/g] (the samples stay in m/s^2).
    mounting : str
        What it stands for (``"stud"``, ``"magnet"``, ...), for the metadata.
    """

    resonance_hz: float = MOUNTING_RESONANCE_HZ["stud"]
    damping_ratio: float = 0.03
    sensitivity_mv_per_g: float = 100.0
    mounting: str = "stud"

    name = "accelerometer"
    measures = "housing"

    def __post_init__(self):
        if not (math.isfinite(self.resonance_hz) and self.resonance_hz > 0):
            raise ValueError(f"resonance_hz: must be > 0 (got {self.resonance_hz})")
        if not 0.0 < self.damping_ratio < 1.0:
            raise ValueError(f"damping_ratio: must be in (0, 1) (got {self.damping_ratio})")

    @classmethod
    def mounted(cls, mounting: str, damping_ratio: float = 0.03) -> "Accelerometer":
        if mounting not in MOUNTING_RESONANCE_HZ:
            raise ValueError(f"mounting: one of {', '.join(MOUNTING_RESONANCE_HZ)} (got {mounting!r})")
        return cls(MOUNTING_RESONANCE_HZ[mounting], damping_ratio, mounting=mounting)

    def gain(self, frequency_hz) -> np.ndarray:
        """Complex output / true acceleration at ``frequency_hz`` [Hz]."""
        r = np.asarray(frequency_hz, dtype=float) / self.resonance_hz
        return 1.0 / (1.0 - r * r + 2j * self.damping_ratio * r)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class AntiAliasFilter:
    """Butterworth low-pass of the acquisition (module docstring).

    Attributes
    ----------
    cutoff_hz : float
        -3 dB frequency [Hz].
    order : int
        Filter order (analog DAQ anti-alias filters: 4-8 poles; the magnitude of steep digital ones after
        oversampling: 30-128).
    phase : {"analog", "linear"}
        The analog filter's response (magnitude and phase, order <= 16), or the Butterworth magnitude with zero
        phase of a linear-phase digital filter (order <= 128; its constant delay left out).
    """

    cutoff_hz: float
    order: int = 6
    phase: str = "analog"

    name = "anti_alias"
    measures = None

    #: highest order of each phase (an analog Butterworth's transfer polynomial is ill-conditioned beyond 16)
    MAX_ORDER = {"analog": 16, "linear": 128}

    def __post_init__(self):
        if not (math.isfinite(self.cutoff_hz) and self.cutoff_hz > 0):
            raise ValueError(f"cutoff_hz: must be > 0 (got {self.cutoff_hz})")
        if self.phase not in self.MAX_ORDER:
            raise ValueError(f"phase: must be 'analog' or 'linear' (got {self.phase!r})")
        top = self.MAX_ORDER[self.phase]
        if isinstance(self.order, bool) or int(self.order) != self.order or not 1 <= int(self.order) <= top:
            raise ValueError(f"order: must be an integer in 1..{top} for phase {self.phase!r} (got {self.order})")

    @classmethod
    def for_rate(cls, sample_rate_hz: float, order: int = 6) -> "AntiAliasFilter":
        """Cut-off at the usable band ``fs / 2.56``."""
        return cls(float(sample_rate_hz) / 2.56, order)

    def gain(self, frequency_hz) -> np.ndarray:
        """Complex gain at ``frequency_hz`` [Hz] (analog Butterworth, scipy.signal.butter; or its magnitude)."""
        f = np.asarray(frequency_hz, dtype=float)
        if self.phase == "linear":
            r = np.abs(f) / self.cutoff_hz
            with np.errstate(over="ignore"):
                return (1.0 / np.sqrt(1.0 + r ** (2 * int(self.order)))).astype(complex)
        from scipy import signal

        b, a = signal.butter(int(self.order), 2 * math.pi * self.cutoff_hz, analog=True)
        _, h = signal.freqs(b, a, worN=2 * math.pi * np.atleast_1d(f))
        return h.reshape(np.shape(frequency_hz))

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class HighPassFilter:
    """The acquisition's AC coupling: analog Butterworth high-pass on the housing channels (module docstring).

    Attributes
    ----------
    cutoff_hz : float
        -3 dB frequency [Hz].
    order : int
        Filter order, 1..8 (an ICP conditioner's coupling capacitor: 1; a DAQ's input high-pass: 1-4).
    """

    cutoff_hz: float
    order: int = 1

    name = "high_pass"
    measures = "housing"

    def __post_init__(self):
        if not (math.isfinite(self.cutoff_hz) and self.cutoff_hz > 0):
            raise ValueError(f"cutoff_hz: must be > 0 (got {self.cutoff_hz})")
        if isinstance(self.order, bool) or int(self.order) != self.order or not 1 <= int(self.order) <= 8:
            raise ValueError(f"order: must be an integer in 1..8 (got {self.order})")

    def gain(self, frequency_hz) -> np.ndarray:
        """Complex gain at ``frequency_hz`` [Hz] (scipy.signal.butter, ``btype="highpass"``, analog)."""
        from scipy import signal

        b, a = signal.butter(int(self.order), 2 * math.pi * self.cutoff_hz, btype="highpass", analog=True)
        _, h = signal.freqs(b, a, worN=2 * math.pi * np.atleast_1d(np.asarray(frequency_hz, dtype=float)))
        return h.reshape(np.shape(frequency_hz))

    def to_dict(self) -> dict:
        return asdict(self)


#: The sensor kinds the ground truth always names (None where a chain has none of that kind).
SENSOR_KINDS = (Accelerometer, AntiAliasFilter)


@dataclass(frozen=True)
class SensorChain:
    """The sensors between the machine and the samples, applied in order (module docstring).

    Attributes
    ----------
    sensors : tuple
        Sensor objects (``name``, ``measures``, ``gain``, ``to_dict``), at most one of each name.
    """

    sensors: tuple = ()

    def __post_init__(self):
        names = [s.name for s in self.sensors]
        if len(set(names)) != len(names):
            raise ValueError(f"sensors: one of each kind (got {', '.join(names)})")

    def __bool__(self) -> bool:
        return bool(self.sensors)

    def get(self, name: str):
        """The sensor of this name, or None."""
        return next((s for s in self.sensors if s.name == name), None)

    def gains(self, frequency_hz: np.ndarray, housing_columns: np.ndarray, n_columns: int) -> np.ndarray | None:
        """(K, U) complex gains of the chain on ``n_columns`` displacement combinations at ``frequency_hz`` (K,)
        [Hz]: a sensor that measures the housing's motion acts on ``housing_columns``, any other on every column;
        None for an empty chain (a gain of 1)."""
        if not self.sensors:
            return None
        f = np.asarray(frequency_hz, dtype=float)
        g = np.ones((f.size, n_columns), complex)
        for s in self.sensors:
            if s.measures == "housing":
                g[:, housing_columns] *= s.gain(f)[:, None]
            else:
                g *= s.gain(f)[:, None]
        return g

    def metadata(self) -> dict:
        """{name: parameters} of every kind in :data:`SENSOR_KINDS` (None where absent) and of any other sensor."""
        out = {kind.name: None for kind in SENSOR_KINDS}
        out.update({s.name: s.to_dict() for s in self.sensors})
        return out


# =========================================================================== the acquisition's output stage
def _columns(channels, quantity: str) -> np.ndarray:
    """Indices of the channels of ``quantity``."""
    return np.array([i for i, c in enumerate(channels) if c.quantity == quantity], dtype=np.intp)


@dataclass(frozen=True)
class InterferenceTones:
    """Fixed-frequency interference of the acquisition's environment on the acceleration channels (module
    docstring): ``sum_k A_k cos(2 pi f_k t + phi_kc)``, t = n / fs from sample 0, each tone's phase on each channel
    from the run's seed.

    Attributes
    ----------
    frequencies_hz : tuple of float
        Tone frequencies [Hz], each > 0.
    amplitudes_m_s2 : tuple of float
        0-peak amplitude of each tone as recorded [m/s^2], each >= 0.
    """

    frequencies_hz: tuple
    amplitudes_m_s2: tuple

    name = "interference_tones"
    quantity = "acceleration"
    #: tag of the phases' seed sequence
    _TAG = 0x70E5

    def __post_init__(self):
        f, a = tuple(float(v) for v in self.frequencies_hz), tuple(float(v) for v in self.amplitudes_m_s2)
        if len(f) != len(a) or not f:
            raise ValueError(f"amplitudes_m_s2: needs one amplitude per frequency ({len(f)}, got {len(a)})")
        if not all(math.isfinite(v) and v > 0 for v in f):
            raise ValueError(f"frequencies_hz: must be finite and > 0 (got {list(f)})")
        if not all(math.isfinite(v) and v >= 0 for v in a):
            raise ValueError(f"amplitudes_m_s2: must be finite and >= 0 (got {list(a)})")
        object.__setattr__(self, "frequencies_hz", f)
        object.__setattr__(self, "amplitudes_m_s2", a)

    def check_rate(self, sample_rate_hz: float) -> str | None:
        """Why the tones cannot be recorded at ``sample_rate_hz`` [Hz] (a tone at or above Nyquist), or None."""
        top = max(self.frequencies_hz)
        if top >= 0.5 * sample_rate_hz:
            return (f"a tone at {top:g} Hz is at or above the Nyquist frequency of {sample_rate_hz:g} Hz (the record "
                    f"could not hold it: a higher rate, or leave the tones out)")
        return None

    def bind(self, channels, sample_rate_hz: float, seed: int) -> "_BoundTones":
        cols = _columns(channels, self.quantity)
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), self._TAG]))
        phases = rng.uniform(0.0, 2.0 * math.pi, (len(self.frequencies_hz), max(cols.size, 1)))[:, :cols.size]
        return _BoundTones(cols, np.array(self.frequencies_hz) / float(sample_rate_hz),
                           np.array(self.amplitudes_m_s2), phases)

    def to_dict(self) -> dict:
        return {"frequencies_hz": list(self.frequencies_hz), "amplitudes_m_s2": list(self.amplitudes_m_s2)}


@dataclass(frozen=True)
class _BoundTones:
    cols: np.ndarray            # the acceleration channels
    cycles: np.ndarray          # (K,) tone frequency / sample rate [cycles per sample]
    amp: np.ndarray             # (K,) [m/s^2]
    phase: np.ndarray           # (K, len(cols)) [rad]

    def apply(self, out: np.ndarray, n0: int) -> None:
        """Add the tones to the samples ``out`` (n, C) of [n0, n0 + n): a function of the absolute sample alone."""
        if not self.cols.size:
            return
        n = np.arange(n0, n0 + out.shape[0], dtype=np.float64)
        # exact per sample: n is an integer < 2^53; each tone's cos and sin once, the channels' phases by the angle
        # sum, cos(a + p) = cos a cos p - sin a sin p: one (n, 2K) x (2K, C) product
        a = 2.0 * math.pi * np.mod(np.outer(n, self.cycles), 1.0)
        weights = np.concatenate([self.amp[:, None] * np.cos(self.phase), -self.amp[:, None] * np.sin(self.phase)])
        tone = np.concatenate([np.cos(a), np.sin(a)], axis=1) @ weights
        out[:, self.cols] += tone.astype(out.dtype)


@dataclass(frozen=True)
class Quantiser:
    """The analog-to-digital converter's rounding of the acceleration samples (module docstring).

    Attributes
    ----------
    step_m_s2 : float
        One least-significant bit [m/s^2] (range / 2^bits; the CWRU records: 0.04-0.8 mg).
    """

    step_m_s2: float

    name = "quantisation"
    quantity = "acceleration"

    def __post_init__(self):
        if not (math.isfinite(self.step_m_s2) and self.step_m_s2 > 0):
            raise ValueError(f"step_m_s2: must be > 0 (got {self.step_m_s2})")

    def bind(self, channels, sample_rate_hz: float, seed: int) -> "_BoundQuantiser":
        return _BoundQuantiser(_columns(channels, self.quantity), float(self.step_m_s2))

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class _BoundQuantiser:
    cols: np.ndarray
    step: float

    def apply(self, out: np.ndarray, n0: int) -> None:
        """Round the samples of the channels to multiples of the step (half-way: to even, as numpy's rint)."""
        if self.cols.size:
            x = out[:, self.cols].astype(np.float64)
            out[:, self.cols] = (np.rint(x / self.step) * self.step).astype(out.dtype)


#: Output-stage kinds in the order the acquisition applies them: pick-up before the converter.
OUTPUT_ORDER = (InterferenceTones, Quantiser)


@dataclass(frozen=True)
class OutputStage:
    """The acquisition's non-linear stages on the summed samples, in the order of :data:`OUTPUT_ORDER`.

    Attributes
    ----------
    stages : tuple
        Stage objects (``name``, ``bind(channels, sample_rate_hz, seed)`` -> an object with ``apply(out, n0)``,
        ``to_dict()``), at most one of each kind.
    """

    stages: tuple = ()

    def __post_init__(self):
        names = [s.name for s in self.stages]
        if len(set(names)) != len(names):
            raise ValueError(f"one of each kind (got {', '.join(names)})")
        rank = {k: i for i, k in enumerate(OUTPUT_ORDER)}
        object.__setattr__(self, "stages", tuple(sorted(self.stages, key=lambda s: rank.get(type(s), len(rank)))))

    def __bool__(self) -> bool:
        return bool(self.stages)

    def get(self, name: str):
        return next((s for s in self.stages if s.name == name), None)

    def bind(self, channels, sample_rate_hz: float, seed: int) -> tuple:
        """The stages bound to the channels, rate and seed of a run (each with ``apply(out, n0)``)."""
        return tuple(s.bind(channels, sample_rate_hz, seed) for s in self.stages)

    def metadata(self) -> dict:
        """{name: parameters} of the stages (empty without any)."""
        return {s.name: s.to_dict() for s in self.stages}
