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
    (default the usable band ``fs / 2.56``, the 2.56 convention of DAQs: 20 kHz at 51.2 kHz), its analog
    response ``H(s) = 1 / B_n(s / omega_c)`` (magnitude and phase).

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
        Filter order (DAQ anti-alias filters: 4-8 analog poles, or steep digital ones after oversampling).
    """

    cutoff_hz: float
    order: int = 6

    name = "anti_alias"
    measures = None

    def __post_init__(self):
        if not (math.isfinite(self.cutoff_hz) and self.cutoff_hz > 0):
            raise ValueError(f"cutoff_hz: must be > 0 (got {self.cutoff_hz})")
        if not 1 <= int(self.order) <= 16:
            raise ValueError(f"order: must be in 1..16 (got {self.order})")

    @classmethod
    def for_rate(cls, sample_rate_hz: float, order: int = 6) -> "AntiAliasFilter":
        """Cut-off at the usable band ``fs / 2.56``."""
        return cls(float(sample_rate_hz) / 2.56, order)

    def gain(self, frequency_hz) -> np.ndarray:
        """Complex gain at ``frequency_hz`` [Hz] (analog Butterworth, scipy.signal.butter)."""
        from scipy import signal

        b, a = signal.butter(int(self.order), 2 * math.pi * self.cutoff_hz, analog=True)
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
