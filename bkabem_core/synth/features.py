"""Chunks and their features: the synthesiser's output block, and mean, RMS, peak, peak-to-peak, crest factor and
kurtosis per channel of a sample block.

:func:`waveform_features` is the two-pass numpy computation; :func:`_moment_features` turns running moments into
the same dict (the C kernel's accumulators, :func:`bkabem_core.synth.kernel.features_from_acc`, use it as their
reference). Units: those of the samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bkabem_core.model.vocabulary import DIRECTIONS


@dataclass
class Chunk:
    """One block of samples of every channel.

    Attributes
    ----------
    samples : ndarray (channels, n), float32 or float64
        Signals in ``units`` (a transposed view of a sample-major buffer: rows are strided; use
        ``np.ascontiguousarray`` if a contiguous row is needed).
    first_sample_index : int
        Index of the first sample in the stream (sample i is at ``i / sample_rate_hz`` s).
    t0_s : float
        Time of the first sample [s].
    sample_rate_hz : float
    channel_names, units : tuple of str
    shaft_speed_hz : float
        Shaft speed at the first sample [Hz]; ``shaft_speed_end_hz`` at the first sample of the next chunk.
    cage_angle_rad, shaft_angle_rad : float
        The DE bearing's cage angle and the shaft angle at the first sample [rad], in [0, 2 pi) (0 at t = 0), before
        slip. Order k of the BKA-BEM spectrum has phase ``k z cage_angle`` there (z balls of the DE).
    features : dict
        Per channel (arrays aligned with ``channel_names``): ``mean``, ``rms`` (about the mean), ``peak``
        (largest |x - mean|), ``peak_to_peak``, ``crest_factor`` (peak/rms), ``kurtosis`` (non-excess, 3 for a
        Gaussian); and ``iso10816_velocity_rms_mm_s`` per housing and direction (+ ``overall`` = the larger).
        Constant signals have crest factor and kurtosis 0 (never NaN).
    ground_truth : dict
        Case identity, bearing, defect, fault frequencies at ``shaft_speed_hz``, seed and realism settings.
    cage_angles_rad : dict
        Each bearing's cage angle at the first sample [rad], ``{"de": .., "nde": ..}`` (the same where both bearings
        share their kinematics), before slip; ``cage_angle_rad`` is the DE's.
    """

    samples: np.ndarray
    first_sample_index: int
    t0_s: float
    sample_rate_hz: float
    channel_names: tuple
    units: tuple
    shaft_speed_hz: float
    shaft_speed_end_hz: float
    cage_angle_rad: float
    shaft_angle_rad: float
    features: dict = field(default_factory=dict)
    ground_truth: dict = field(default_factory=dict)
    cage_angles_rad: dict = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[1])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    @property
    def time_s(self) -> np.ndarray:
        """Sample times [s]."""
        return (self.first_sample_index + np.arange(self.n_samples)) / self.sample_rate_hz

    def channel(self, name: str) -> np.ndarray:
        return self.samples[self.channel_names.index(name)]

    def rows(self, bearing: str, quantity: str) -> list[int]:
        """Row indices [vertical, horizontal] of ``bearing`` (de/nde) and ``quantity``."""
        return [self.channel_names.index(f"{bearing}_{d}_{quantity}") for d in DIRECTIONS]

    def to_dict(self) -> dict:
        """Everything except the samples, JSON-ready."""
        feats = {}
        for k, v in self.features.items():
            if isinstance(v, np.ndarray):
                feats[k] = dict(zip(self.channel_names, (float(x) for x in v)))
            else:
                feats[k] = v
        return {"first_sample_index": int(self.first_sample_index), "t0_s": self.t0_s,
                "n_samples": self.n_samples, "sample_rate_hz": self.sample_rate_hz,
                "channel_names": list(self.channel_names), "units": list(self.units),
                "shaft_speed_hz": self.shaft_speed_hz, "shaft_speed_end_hz": self.shaft_speed_end_hz,
                "cage_angle_rad": self.cage_angle_rad, "cage_angles_rad": dict(self.cage_angles_rad),
                "shaft_angle_rad": self.shaft_angle_rad,
                "features": feats, "ground_truth": self.ground_truth}



_FOLD = 64   # numpy is slow on short rows: (n, C) blocks are processed as (n / 64, 64 C)


def _colwise(x: np.ndarray, fn) -> np.ndarray:
    """``fn`` (np.max or np.min) over the rows of a sample-major (n, C) block."""
    n, c = x.shape
    q = n // _FOLD * _FOLD
    r = None
    if q:
        r = fn(fn(x[:q].reshape(-1, _FOLD * c), axis=0).reshape(_FOLD, c), axis=0)
    if q < n:
        t = fn(x[q:], axis=0)
        r = t if r is None else (np.maximum(r, t) if fn is np.max else np.minimum(r, t))
    return r


def waveform_features(x: np.ndarray, offset: np.ndarray | None = None) -> dict:
    """Features of a sample-major block ``x`` (n, C): mean, rms, peak, peak_to_peak, crest_factor, kurtosis.

    ``offset`` (C,), e.g. the known static part, is removed before the mean is taken, so that signals riding on a
    large DC keep their precision in float32; moments are then central (two passes)."""
    n, c = x.shape
    off = np.zeros(c, x.dtype) if offset is None else np.asarray(offset, x.dtype)
    ones = np.ones(n, x.dtype)
    q = n // _FOLD * _FOLD
    xc = np.empty_like(x)

    def sub(v):                                   # xc = x - v (rows folded, see _FOLD)
        if q:
            np.subtract(x[:q].reshape(-1, _FOLD * c), np.tile(v, _FOLD), out=xc[:q].reshape(-1, _FOLD * c))
        if q < n:
            np.subtract(x[q:], v, out=xc[q:])

    sub(off)
    mu = (ones @ xc) / x.dtype.type(n)
    centre = (off + mu).astype(x.dtype)
    sub(centre)
    s1 = (ones @ xc).astype(np.float64) / n               # ~0 (round-off of the centre)
    x2 = xc * xc
    s2 = (ones @ x2).astype(np.float64) / n
    np.multiply(x2, x2, out=x2)
    s4 = (ones @ x2).astype(np.float64) / n
    hi = _colwise(xc, np.max).astype(np.float64)
    lo = _colwise(xc, np.min).astype(np.float64)
    return _moment_features(s1, s2, 0.0 * s1, s4, hi, lo, centre)


def _moment_features(s1, s2, s3, s4, hi, lo, off) -> dict:
    """Features from raw moments s_p = mean((x - off)^p) and the extremes of x - off."""
    m2 = np.maximum(s2 - s1 * s1, 0.0)
    m4 = np.maximum(s4 - 4 * s1 * s3 + 6 * s1 * s1 * s2 - 3 * s1 ** 4, 0.0)
    rms = np.sqrt(m2)
    peak = np.maximum(hi - s1, s1 - lo)
    ok = m2 > 0
    safe = np.where(ok, m2, 1.0)
    return {"mean": s1 + off.astype(np.float64), "rms": rms, "peak": peak, "peak_to_peak": hi - lo,
            "crest_factor": np.where(ok, peak / np.sqrt(safe), 0.0),
            "kurtosis": np.where(ok, m4 / (safe * safe), 0.0)}
