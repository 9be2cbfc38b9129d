"""Textbook vibration diagnostics of one accelerometer signal (Randall & Antoni, MSSP 25 (2011) 485-520).

Everything a monitoring engineer computes without training: RMS, kurtosis, crest factor; the Welch PSD and its
energy by band (broad bands and base-10 third octaves); the squared-envelope spectrum (SES) of a band (a fixed
2-4 kHz band, and the band the fast kurtogram picks), its floor, the level of each bearing line over that floor
(fault frequencies, harmonics, 1x, FTF, sidebands), and the no-training verdict. Signals are in g; frequencies in
Hz; levels in dB (20 log10 of a magnitude ratio, or 10 log10 of an energy in g^2).

Definitions (the same for a measured record and for the twin):

* SES: band-pass (linear-phase FIR, Kaiser beta 8, 401 taps at 12 kHz, delay removed, the filter's transients
  cut), analytic signal by the FFT Hilbert transform, squared modulus, mean removed, Hann window over the whole
  signal, scaled so that a component B cos(2 pi f t) of the squared envelope reads B [g^2].
* Line level: the largest |SES| within +-0.5 % of the target (shaft orders, BPFO and BPFI families and their 1x
  sidebands) or +-1 % (BSF, 2 x BSF, FTF and 2 x BSF +- FTF: ball and cage slip), at least +-2 bins.
* Floor: the median |SES| over 5-500 Hz outside every line window (1x-16x, mains harmonics up to 480 Hz,
  harmonics 1-4 of BPFO, BPFI, BSF, 2 x BSF, FTF, BPFO and BPFI +-1x and +-2x, 2 x BSF +- FTF, of every bearing
  given). On noise alone a line reads ~6 dB over it (the median of the maximum of a few bins).
* Verdict: the fundamentals of BPFO, BPFI and 2 x BSF in dB over the floor; the best one if it reaches the
  threshold (10 dB) and stands 3 dB above the runner-up; ``healthy`` if none reaches it; otherwise
  ``ambiguous(a/b)``.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from realdata.kurtogram import fast_kurtogram, pick_band

#: Standard gravity [m/s^2 per g].
G = 9.80665
#: Broad bands [Hz] of the band-energy table.
BROAD_BANDS = ((0.0, 500.0), (500.0, 1000.0), (1000.0, 2000.0), (2000.0, 3000.0), (3000.0, 4000.0),
               (4000.0, 5000.0), (5000.0, 6000.0))
#: The fixed SES band [Hz]: the structural resonances of the CWRU drive end (2.8, 3.35 kHz) and a textbook
#: default away from the shaft and electrical region.
FIXED_BAND = (2000.0, 4000.0)
TOL_RACE = 0.005
TOL_BALL = 0.01
MIN_BINS = 2
FLOOR_BAND = (5.0, 500.0)
THRESHOLD_DB = 10.0
MARGIN_DB = 3.0
#: The line of each fault kind.
KIND_LINE = {"outer": "BPFO", "inner": "BPFI", "ball": "2BSF"}
VERDICT_OF_LINE = {"BPFO": "outer", "BPFI": "inner", "2BSF": "ball"}


# --------------------------------------------------------------------------- time domain and spectra
def decimate(x: np.ndarray, fs: float, to_hz: float = 12000.0) -> np.ndarray:
    """``x`` resampled from ``fs`` to ``to_hz`` (an integer factor q): polyphase decimation with a linear-phase
    Kaiser FIR (115 q - 1 taps, beta 8.96, cut-off 0.95 x the new Nyquist): for q = 4, flat within 0.001 dB to
    0.9 x the new Nyquist and <= -89 dB from it on, so nothing folds back above -89 dB."""
    q = fs / to_hz
    if abs(q - 1.0) < 1e-12:
        return np.asarray(x, dtype=float)
    if abs(q - round(q)) > 1e-9 or q < 1:
        raise ValueError(f"decimate: {fs:g} Hz -> {to_hz:g} Hz is not an integer factor")
    q = int(round(q))
    b = signal.firwin(115 * q - 1, 0.95 * to_hz / 2.0, fs=fs, window=("kaiser", 8.96))
    return signal.resample_poly(np.asarray(x, dtype=float), 1, q, window=b)


def moments(x: np.ndarray) -> dict:
    """RMS [g], kurtosis E x^4 / E x^2^2 (3 for Gaussian noise), crest factor max|x| / RMS and skewness, about
    the mean."""
    x = np.asarray(x, dtype=float)
    x = x - x.mean()
    m2 = float(np.mean(x ** 2))
    rms = m2 ** 0.5
    return {"rms": rms, "kurtosis": float(np.mean(x ** 4) / m2 ** 2), "crest": float(np.max(np.abs(x)) / rms),
            "skewness": float(np.mean(x ** 3) / m2 ** 1.5)}


def band_spread(x: np.ndarray, fs: float, band: tuple = (2000.0, 4000.0), window_s: float = 0.25) -> float:
    """How steady a signal's band is: the largest over the smallest RMS of ``band`` [Hz] (4th-order Butterworth,
    forward and backward) in consecutive windows of ``window_s`` [s]. About 1 for a stationary signal; a fault that
    comes and goes within the record gives several."""
    sos = signal.butter(4, band, btype="bandpass", fs=fs, output="sos")
    y = signal.sosfiltfilt(sos, np.asarray(x, dtype=float) - float(np.mean(x)))
    w = int(round(window_s * fs))
    n = len(y) // w
    if n < 2:
        return float("nan")
    r = np.sqrt(np.mean(y[:n * w].reshape(n, w) ** 2, axis=1))
    return float(r.max() / r.min()) if r.min() > 0 else float("inf")


def welch_psd(x: np.ndarray, fs: float, resolution_hz: float = 1.0):
    """One-sided Welch PSD [g^2/Hz]: Hann segments of fs / resolution samples (at most half the signal, so that a
    short excerpt still averages three segments), 50 % overlap, mean removed."""
    n = min(int(round(fs / resolution_hz)), len(x) // 2)
    return signal.welch(x, fs, window="hann", nperseg=n, noverlap=n // 2, detrend="constant", scaling="density")


def band_energy_db(f: np.ndarray, psd: np.ndarray, lo: float, hi: float) -> float:
    """Energy of ``psd`` over [lo, hi) [dB re 1 g^2]."""
    m = (f >= lo) & (f < hi)
    e = float(np.sum(psd[m]) * (f[1] - f[0]))
    return 10.0 * np.log10(max(e, 1e-300))


def third_octave_bands(f_max: float) -> list[tuple[str, float, float]]:
    """Base-10 third-octave bands (centres 10^(n/10), 10 Hz to 5 kHz nominal) below ``f_max``: (name, lo, hi);
    a band cut by ``f_max`` is left out."""
    out = []
    for n in range(10, 38):
        fc = 10.0 ** (n / 10.0)
        lo, hi = fc * 10 ** (-1 / 20), fc * 10 ** (1 / 20)
        if hi > f_max:
            break
        nominal = (10, 12.5, 16, 20, 25, 31.5, 40, 50, 63, 80)[n % 10] * 10 ** (n // 10 - 1)
        out.append((f"{nominal:g}", lo, hi))
    return out


def amplitude_spectrum(x: np.ndarray, fs: float, nfft: int | None = None):
    """Amplitude spectrum of the whole signal (Hann, a sinusoid of amplitude A reads A), zero-padded to ``nfft``."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    w = np.hanning(len(x))
    n = nfft or len(x)
    return np.fft.rfftfreq(n, 1.0 / fs), np.abs(np.fft.rfft(x * w, n)) * 2.0 / w.sum()


def squared_envelope(x: np.ndarray, fs: float, lo: float, hi: float) -> np.ndarray:
    """Squared envelope of the band [lo, hi] Hz (definition in the module's docstring)."""
    taps = int(round(401 * fs / 12000.0)) | 1
    lo, hi = max(lo, 1.0), min(hi, fs / 2.0 - 1.0)
    b = signal.firwin(taps, [lo, hi], pass_zero=False, fs=fs, window=("kaiser", 8.0))
    y = signal.fftconvolve(np.asarray(x, dtype=float) - np.mean(x), b, mode="same")[taps:-taps]
    return np.abs(signal.hilbert(y)) ** 2


# --------------------------------------------------------------------------- bearing lines
def line_targets(fr: float, mult: dict) -> dict:
    """Name -> (frequency [Hz], relative window) of the lines read in the SES, for shaft speed ``fr`` [Hz] and
    the fault multipliers ``mult`` (``bpfo``, ``bpfi``, ``ftf``, ``bsf`` per shaft Hz)."""
    bpfo, bpfi, ftf, bsf2 = mult["bpfo"] * fr, mult["bpfi"] * fr, mult["ftf"] * fr, 2.0 * mult["bsf"] * fr
    t = {}
    for name, f0, tol in (("BPFO", bpfo, TOL_RACE), ("BPFI", bpfi, TOL_RACE), ("2BSF", bsf2, TOL_BALL)):
        t[name] = (f0, tol)
        for h in (2, 3):
            t[f"{name}_h{h}"] = (h * f0, tol)
    t["BSF"] = (mult["bsf"] * fr, TOL_BALL)
    t["FTF"] = (ftf, TOL_BALL)
    for k in (1, 2, 3):
        t[f"{k}x"] = (k * fr, TOL_RACE)
    for name, f0 in (("BPFO", bpfo), ("BPFI", bpfi)):
        t[f"{name}-1x"] = (f0 - fr, TOL_RACE)
        t[f"{name}+1x"] = (f0 + fr, TOL_RACE)
    t["2BSF-FTF"] = (bsf2 - ftf, TOL_BALL)
    t["2BSF+FTF"] = (bsf2 + ftf, TOL_BALL)
    return t


def floor_exclusions(fr: float, mults: list[dict], mains_hz: float) -> list[tuple[float, float]]:
    """(frequency, relative window) of every line kept out of the SES floor."""
    ex = [(k * fr, TOL_RACE) for k in range(1, 17)]
    ex += [(n * mains_hz, TOL_RACE) for n in range(1, int(480.0 // mains_hz) + 1)]
    for m in mults:
        bsf2 = 2.0 * m["bsf"]
        for key, mm, tol in (("bpfo", m["bpfo"], TOL_RACE), ("bpfi", m["bpfi"], TOL_RACE), ("bsf", m["bsf"], TOL_BALL),
                             ("2bsf", bsf2, TOL_BALL), ("ftf", m["ftf"], TOL_BALL)):
            ex += [(h * mm * fr, tol) for h in range(1, 5)]
        for mm in (m["bpfo"], m["bpfi"]):
            ex += [((mm + s) * fr, TOL_RACE) for s in (-2, -1, 1, 2)]
        ex += [((bsf2 + s * m["ftf"]) * fr, TOL_BALL) for s in (-1, 1)]
    return ex


def _window(f0: float, df: float, tol: float) -> float:
    return max(tol * f0, MIN_BINS * df)


def line_level(f: np.ndarray, S: np.ndarray, f0: float, tol: float) -> tuple[float, float]:
    """(largest |SES| within the line's window, its frequency [Hz])."""
    df = f[1] - f[0]
    w = _window(f0, df, tol)
    idx = np.flatnonzero((f >= f0 - w) & (f <= f0 + w))
    i = idx[np.argmax(S[idx])]
    return float(S[i]), float(f[i])


def ses_floor(f: np.ndarray, S: np.ndarray, exclusions) -> float:
    """Median |SES| over 5-500 Hz outside the excluded line windows."""
    df = f[1] - f[0]
    keep = (f >= FLOOR_BAND[0]) & (f <= FLOOR_BAND[1])
    for f0, tol in exclusions:
        w = _window(f0, df, tol)
        keep &= ~((f >= f0 - w) & (f <= f0 + w))
    return float(np.median(S[keep]))


def envelope_analysis(x: np.ndarray, fs: float, band: tuple, fr: float, mult: dict, extra_mults=(),
                      mains_hz: float = 60.0, keep_spectrum: bool = False) -> dict:
    """The SES of ``band`` and every line of :func:`line_targets` in dB over its floor.

    Returns ``{"band": [lo, hi], "floor": g^2, "levels": {name: dB}, "frequencies": {name: Hz}, "verdict": ...}``,
    plus ``"f"``, ``"S"`` (the spectrum) when ``keep_spectrum``.
    """
    e = squared_envelope(x, fs, band[0], band[1])
    f, S = amplitude_spectrum(e, fs)
    floor = ses_floor(f, S, floor_exclusions(fr, [mult, *extra_mults], mains_hz))
    levels, freqs = {}, {}
    for name, (f0, tol) in line_targets(fr, mult).items():
        v, fp = line_level(f, S, f0, tol)
        levels[name] = 20.0 * np.log10(v / floor)
        freqs[name] = fp
    out = {"band": [float(band[0]), float(band[1])], "floor": floor, "levels": levels, "frequencies": freqs,
           "verdict": verdict(levels)}
    if keep_spectrum:
        out["f"], out["S"] = f, S
    return out


def null_levels(f: np.ndarray, S: np.ndarray, floor: float, fr: float, mults, mains_hz: float, n: int = 300,
                seed: int = 0) -> np.ndarray:
    """The line measure at ``n`` random frequencies in 20-480 Hz at least 2 % from every excluded line (the
    false-alarm distribution of a line level), with the +-0.5 % window [dB over the floor]."""
    rng = np.random.default_rng(seed)
    ex = np.array([e[0] for e in floor_exclusions(fr, list(mults), mains_hz)])
    out = []
    while len(out) < n:
        f0 = rng.uniform(20.0, 480.0)
        if np.any(np.abs(ex - f0) <= 0.02 * np.maximum(ex, f0)):
            continue
        out.append(20.0 * np.log10(line_level(f, S, f0, TOL_RACE)[0] / floor))
    return np.array(out)


def verdict(levels: dict, threshold_db: float = THRESHOLD_DB, margin_db: float = MARGIN_DB) -> str:
    """The no-training verdict from the fundamentals' levels [dB over floor] (module docstring)."""
    order = sorted(VERDICT_OF_LINE, key=lambda k: -levels[k])
    best, second = order[0], order[1]
    if levels[best] < threshold_db:
        return "healthy"
    if levels[best] - levels[second] < margin_db:
        return f"ambiguous({VERDICT_OF_LINE[best]}/{VERDICT_OF_LINE[second]})"
    return VERDICT_OF_LINE[best]


# --------------------------------------------------------------------------- speed
def _peak(f, X, lo, hi):
    idx = np.flatnonzero((f >= lo) & (f <= hi))
    i = idx[np.argmax(X[idx])]
    a, b, c = (np.log(X[j] + 1e-300) for j in (i - 1, i, i + 1))
    d = a - 2 * b + c
    p = 0.5 * (a - c) / d if d != 0 else 0.0
    near = (f > lo - 3.0) & (f < hi + 3.0)
    return f[i] + p * (f[1] - f[0]), 20.0 * np.log10(X[i] / np.median(X[near]))


def estimate_speed(channels: dict, fs: float, nominal_hz: float, cap_hz: float | None = 30.0) -> tuple[float, int]:
    """Shaft speed [Hz] without a tachometer, and the number of candidates it rests on.

    Candidates per channel: the 1x peak of the raw amplitude spectrum, the 3x peak / 3, the 1x peak of the SES
    of 1-5 kHz (Hann over the whole signal, zero-padded to 2^22 points, parabolic interpolation on the log
    magnitude), searched in [0.985, 1.01] x nominal (capped at ``cap_hz``, the synchronous speed of a 4-pole
    60 Hz motor: 2x and 4x are not used, they sit next to the mains lines). The estimate is the median of the
    candidates standing >= 15 dB over the median of their +-3 Hz, or the most prominent one if none does.
    """
    lo = 0.985 * nominal_hz
    hi = 1.01 * nominal_hz if cap_hz is None else min(1.01 * nominal_hz, cap_hz)
    cands = []
    nfft = 1 << 22
    for x in channels.values():
        f, X = amplitude_spectrum(x, fs, nfft)
        cands.append(_peak(f, X, lo, hi))
        f3, p3 = _peak(f, X, 3 * lo, 3 * hi)
        cands.append((f3 / 3.0, p3))
        fe, E = amplitude_spectrum(squared_envelope(x, fs, 1000.0, min(5000.0, 0.45 * fs)), fs, nfft)
        cands.append(_peak(fe, E, lo, hi))
    good = [c for c in cands if c[1] >= 15.0] or [max(cands, key=lambda c: c[1])]
    return float(np.median([c[0] for c in good])), len(good)


# --------------------------------------------------------------------------- one signal, everything
def diagnose(x: np.ndarray, fs: float, fr: float, mult: dict, extra_mults=(), mains_hz: float = 60.0,
             keep_spectra: bool = False, kurtogram_levels: int = 3) -> dict:
    """Every diagnostic of one signal [g] at ``fs`` [Hz] (12 kHz in this bench), shaft speed ``fr`` [Hz].

    Returns a dict: ``rms``, ``kurtosis``, ``crest``, ``skewness``; ``bands_db`` (energy of each of
    :data:`BROAD_BANDS` [dB re g^2]); ``band_spread`` (:func:`band_spread` of the 2-4 kHz band, 0.25 s windows);
    ``third_octaves_db`` (name -> dB re g^2); ``kurtogram`` (the picked band: edges, level, kurtosis); ``ses``
    with ``"fixed"`` (2-4 kHz) and ``"kurtogram"`` (the picked band), each as
    :func:`envelope_analysis`; with ``keep_spectra`` also ``psd_f``, ``psd`` and the SES arrays.
    """
    x = np.asarray(x, dtype=float)
    out = moments(x)
    f, P = welch_psd(x, fs)
    out["bands_db"] = [band_energy_db(f, P, lo, hi) for lo, hi in BROAD_BANDS if hi <= fs / 2.0 + 1e-9]
    out["band_spread"] = band_spread(x, fs, FIXED_BAND)
    out["third_octaves_db"] = {name: band_energy_db(f, P, lo, hi) for name, lo, hi in third_octave_bands(fs / 2.0)}
    node = pick_band(fast_kurtogram(x, fs, kurtogram_levels), fs)
    out["kurtogram"] = {"f_lo": node.f_lo, "f_hi": node.f_hi, "level": node.level, "kurtosis": node.kurtosis}
    kw = dict(fr=fr, mult=mult, extra_mults=extra_mults, mains_hz=mains_hz, keep_spectrum=keep_spectra)
    out["ses"] = {"fixed": envelope_analysis(x, fs, FIXED_BAND, **kw),
                  "kurtogram": envelope_analysis(x, fs, (node.f_lo, node.f_hi), **kw)}
    if keep_spectra:
        out["psd_f"], out["psd"] = f, P
    return out
