"""What a condition-monitoring pipeline computes from a window of acceleration (numpy only).

Everything here works on one window of samples per channel, shape (channels, n), in SI
(m/s^2 in, the unit of each result named in its function). It is what the Rerun view shows
next to the raw signals, computed from the published waveforms only (so the same numbers come
out of a live node and of any recording):

- :func:`envelope_spectrum`: band-pass (FFT mask) -> analytic signal -> magnitude -> spectrum
  of the envelope (Hann window), the diagnostician's first tool for rolling-element faults;
- :func:`iso_velocity_rms`: ISO 10816 / 20816 vibration severity, RMS velocity in 10-1000 Hz
  from the acceleration spectrum (divide by j*2*pi*f, Parseval), mm/s;
- :func:`iso_zone` with the zone boundaries of :data:`ISO_ZONE_SETS`;
- :func:`kurtosis` and :func:`crest_factor` (impulsiveness).

One FFT of the window serves the envelope band-pass and the velocity integration
(:func:`window_spectrum`). The FFTs run in single precision (the samples are float32).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
import scipy.fft as sfft

__all__ = [
    "DEFAULT_ISO_ZONES",
    "ISO_BAND_HZ",
    "ISO_ZONE_SETS",
    "ZONE_NAMES",
    "crest_factor",
    "default_envelope_band",
    "envelope_spectrum",
    "iso_velocity_rms",
    "iso_velocity_rms_mm_s",
    "iso_zone",
    "kurtosis",
    "window_spectrum",
]

TWO_PI = 2.0 * math.pi

#: ISO 10816-3 / 20816-3 frequency range for machines running above 600 rpm [Hz].
ISO_BAND_HZ = (10.0, 1000.0)

#: Zone boundaries A/B, B/C, C/D of the RMS velocity [mm/s]. ISO 10816-3 (kept by ISO 20816-3)
#: for group 1 (300 kW - 50 MW) and group 2 (15 - 300 kW) machines on rigid or flexible
#: supports; ISO 10816-1 Annex B classes I (small machines up to 15 kW) and II (15-75 kW).
ISO_ZONE_SETS: dict[str, tuple[float, float, float]] = {
    "ISO 10816-3 group 2, rigid": (1.4, 2.8, 4.5),
    "ISO 10816-3 group 2, flexible": (2.3, 4.5, 7.1),
    "ISO 10816-3 group 1, rigid": (2.3, 4.5, 7.1),
    "ISO 10816-3 group 1, flexible": (3.5, 7.1, 11.0),
    "ISO 10816-1 class I": (0.71, 1.8, 4.5),
    "ISO 10816-1 class II": (1.12, 2.8, 7.1),
}
#: An electric motor of 15-300 kW on a rigid foundation (the embedded case's kind of machine).
DEFAULT_ISO_ZONES = "ISO 10816-3 group 2, rigid"
#: What the zones mean (ISO 10816-1 / -3).
ZONE_NAMES = {
    "A": "newly commissioned",
    "B": "unrestricted long-term operation",
    "C": "restricted operation: plan maintenance",
    "D": "damage likely",
}


class WindowSpectrum(NamedTuple):
    """One-sided FFT of a window: ``spectrum`` (channels, n//2+1), ``freq`` [Hz], ``n``, ``fs`` [Hz]."""

    spectrum: np.ndarray
    freq: np.ndarray
    n: int
    fs: float


def window_spectrum(x: np.ndarray, fs: float) -> WindowSpectrum:
    """``rfft`` of each channel of ``x`` (channels, n) after removing its mean, in single
    precision (the samples are float32; twice as fast, errors ~1e-6 of the largest line)."""
    a = np.atleast_2d(np.asarray(x, dtype=np.float32))
    n = a.shape[1]
    spec = sfft.rfft(a - a.mean(axis=1, keepdims=True, dtype=np.float64).astype(np.float32), axis=1)
    return WindowSpectrum(spec, _rfftfreq(n, float(fs)), n, float(fs))


@functools.lru_cache(maxsize=16)
def _rfftfreq(n: int, fs: float) -> np.ndarray:
    return np.fft.rfftfreq(n, 1.0 / fs)


@functools.lru_cache(maxsize=16)
def _hann(n: int) -> np.ndarray:
    return np.hanning(n).astype(np.float32)


def _fast_len(n: int) -> int:
    """Smallest 2^a 3^b 5^c >= n (pocketfft is fastest there)."""
    best = 1 << max(int(n - 1).bit_length(), 0)
    p5 = 1
    while p5 < 2 * n:
        p35 = p5
        while p35 < 2 * n:
            q = p35
            while q < n:
                q *= 2
            best = min(best, q)
            p35 *= 3
        p5 *= 5
    return best


def default_envelope_band(fs: float) -> tuple[float, float]:
    """Envelope band-pass [Hz]: 1 kHz to min(10 kHz, 0.4 fs); for a low sample rate
    (0.4 fs <= 2 kHz) the upper half of the usable range, 0.2 fs to 0.4 fs.

    Dent impacts ring the housing's resonances in the kHz range; below 1 kHz sit the shaft
    orders and the fault lines themselves, which the band must exclude."""
    hi = min(10_000.0, 0.4 * fs)
    lo = 1_000.0 if hi > 2_000.0 else 0.2 * fs
    return lo, hi


def envelope_spectrum(x, fs: float, band_hz: tuple[float, float] | None = None, f_max: float | None = None,
                      ws: WindowSpectrum | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum of the envelope of ``x`` band-passed to ``band_hz``.

    Parameters
    ----------
    x : array_like, shape (channels, n) or (n,)
        Acceleration [m/s^2], one window.
    fs : float
        Sample rate [Hz].
    band_hz : (float, float), optional
        Band-pass [Hz] (default :func:`default_envelope_band`).
    f_max : float, optional
        Return bins up to this frequency [Hz] (default: half the band width, the most the
        envelope of that band can carry).
    ws : WindowSpectrum, optional
        :func:`window_spectrum` of ``x`` if already computed.

    Returns
    -------
    freq : ndarray, shape (bins,)
        [Hz], resolution fs / n, from 0.
    amplitude : ndarray, shape (channels, bins)
        Envelope amplitude [m/s^2] (peak of a sinusoidal envelope modulation; Hann window,
        amplitude-corrected). Bin 0 (the envelope's mean) is zero. The envelope is computed at
        a rate of about twice the band width (see the code), so ``freq`` stops below fs/2.
    """
    ws = ws or window_spectrum(x, fs)
    lo, hi = band_hz or default_envelope_band(fs)
    if not 0.0 <= lo < hi <= fs / 2:
        raise ValueError(f"band_hz: ({lo}, {hi}) must satisfy 0 <= low < high <= fs/2 = {fs / 2}")
    n = ws.n
    band = np.nonzero((ws.freq >= lo) & (ws.freq <= hi))[0]
    # Analytic signal of the band: only bins k0..k0+K-1 are non-zero. Shifted down by k0 (which
    # leaves its magnitude unchanged) it is a K-bin signal, sampled here at m >= 2K points over
    # the window instead of n: the same envelope at a lower rate (3-5x fewer FFT points; the
    # envelope's content above K bins, which would fold back, is negligible).
    kk = int(band.size)
    m = _fast_len(2 * kk)
    z = np.zeros((ws.spectrum.shape[0], m), dtype=np.complex64)
    z[:, :kk] = ws.spectrum[:, band]
    env = np.abs(sfft.ifft(z, axis=1)) * np.float32(2.0 * m / n)
    env -= env.mean(axis=1, keepdims=True)
    w = _hann(m)
    amp = np.abs(sfft.rfft(env * w, axis=1)).astype(np.float64) * (2.0 / float(w.sum(dtype=np.float64)))
    amp[:, 0] = 0.0
    f = _rfftfreq(m, fs * m / n)
    top = (hi - lo) / 2 if f_max is None else min(float(f_max), fs / 2)
    m = f <= top
    return f[m], amp[:, m]


def iso_velocity_rms(x, fs: float, band_hz: tuple[float, float] = ISO_BAND_HZ,
                     ws: WindowSpectrum | None = None) -> np.ndarray:
    """RMS vibration velocity [mm/s] in ``band_hz`` of each channel of an acceleration window
    [m/s^2]: one-sided spectrum, divided by j*2*pi*f, Parseval (mean square =
    2 sum |V_k|^2 / n^2, no DC or Nyquist bin in the band)."""
    ws = ws or window_spectrum(x, fs)
    if ws.n < 8:
        return np.full(ws.spectrum.shape[0], np.nan)
    keep = (ws.freq >= band_hz[0]) & (ws.freq <= band_hz[1]) & (ws.freq > 0)
    v = ws.spectrum[:, keep].astype(np.complex128) / (1j * TWO_PI * ws.freq[keep])
    ms = 2.0 * np.sum(np.abs(v) ** 2, axis=1) / ws.n**2
    return np.sqrt(ms) * 1e3


def iso_velocity_rms_mm_s(acc_m_s2: np.ndarray, sample_rate_hz: float,
                          band_hz: tuple[float, float] = ISO_BAND_HZ) -> float:
    """:func:`iso_velocity_rms` of one channel, as a float (nan for fewer than 8 samples)."""
    return float(iso_velocity_rms(np.asarray(acc_m_s2, dtype=np.float64).reshape(1, -1),
                                  sample_rate_hz, band_hz)[0])


def iso_zone(velocity_mm_s: float, boundaries: tuple[float, float, float]) -> str:
    """Zone "A", "B", "C" or "D" of an RMS velocity [mm/s] for boundaries A/B, B/C, C/D [mm/s]."""
    if not np.isfinite(velocity_mm_s):
        return "?"
    for zone, limit in zip("ABC", boundaries):
        if velocity_mm_s < limit:
            return zone
    return "D"


def kurtosis(x) -> np.ndarray:
    """Pearson kurtosis of each channel (3 for Gaussian noise, 1.5 for a sine; impacts raise it) [-]."""
    a = np.atleast_2d(np.asarray(x))
    a = a if a.dtype in (np.float32, np.float64) else a.astype(np.float64)
    d = a - a.mean(axis=1, keepdims=True, dtype=np.float64).astype(a.dtype)
    d2 = d * d
    m2 = np.mean(d2, axis=1, dtype=np.float64)                  # pairwise sums in float64
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.mean(d2 * d2, axis=1, dtype=np.float64) / (m2 * m2)
    return np.where(m2 > 0, k, np.nan)


def crest_factor(x) -> np.ndarray:
    """Peak (max |x|) over RMS of each channel [-] (1.41 for a sine)."""
    a = np.atleast_2d(np.asarray(x))
    rms = np.sqrt(np.mean(np.square(a, dtype=np.float64) if a.dtype != np.float32 else a * a, axis=1,
                          dtype=np.float64))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(rms > 0, np.max(np.abs(a), axis=1) / rms, np.nan)
