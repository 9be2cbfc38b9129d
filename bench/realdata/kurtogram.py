"""Antoni's fast kurtogram (MSSP 21 (2007) 108-124) and the band a textbook envelope analysis takes from it.

The 1/3-binary tree of his ``Fast_Kurtogram.m``: quasi-analytic generating filters, a 2-band analysis bank
(filter, decimate by 2) for the binary levels 1, 2, ... and a 3-band bank (decimate by 3) on every binary node
for the levels k + log2(3). The kurtosis of a node is that of its complex envelope, E|c|^4 / (E|c|^2)^2 - 2
(0 for a complex Gaussian signal); level 0 is the raw signal, E x^4 / (E x^2)^2 - 3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

LOG2_3 = float(np.log2(3.0))
#: The textbook constraints on the band of the squared-envelope spectrum: at least 1 kHz wide (several times the
#: highest fault frequency with its 1x sidebands, and a floor flat within 3 dB over 0-500 Hz), at least 500 Hz
#: above DC (the shaft and electrical region is not impulsive), at most 5.5 kHz at a 12 kHz sample rate (the CWRU
#: acquisition's anti-alias filter rolls off from 5.4 kHz; narrow bands near Nyquist hold only its residue).
MIN_BANDWIDTH_HZ = 1000.0
MIN_LOW_EDGE_HZ = 500.0
MAX_HIGH_EDGE_12K_HZ = 5500.0


@dataclass(frozen=True)
class Node:
    """One band of the kurtogram: level (0, 1, 1.585, 2, ...), edges [Hz], spectral kurtosis, mean power."""

    level: float
    f_lo: float
    f_hi: float
    kurtosis: float
    power: float

    @property
    def bandwidth(self) -> float:
        return self.f_hi - self.f_lo

    @property
    def centre(self) -> float:
        return 0.5 * (self.f_lo + self.f_hi)


def envelope_kurtosis(c: np.ndarray) -> float:
    """Kurtosis of a band's envelope: E|c|^4 / (E|c|^2)^2 - 2 for a complex band, E x^4 / (E x^2)^2 - 3 for a real
    one (both 0 for Gaussian noise), mean removed."""
    c = c - np.mean(c)
    e2 = float(np.mean(np.abs(c) ** 2))
    if e2 <= 0.0:
        return 0.0
    return float(np.mean(np.abs(c) ** 4) / e2 ** 2 - (2.0 if np.iscomplexobj(c) else 3.0))


def generating_filters():
    """Antoni's filters: ``h`` a 16th-order Hamming low-pass (cut-off 0.4 x Nyquist) shifted to fs/8 (the band
    [0, fs/4]), ``g`` its quadrature mirror (the band [fs/4, fs/2]), and three 24th-order low-passes (cut-off
    0.4 x 2/3 x Nyquist) shifted to fs/12, fs/4 and 5 fs/12 (the thirds of [0, fs/2])."""
    n = np.arange(17)
    h = signal.firwin(17, 0.4) * np.exp(2j * np.pi * n * 0.125)
    m = np.arange(16)
    g = h[(15 - m) % 16] * (-1.0) ** (m + 1)
    n1 = np.arange(25)
    h1 = signal.firwin(25, 2.0 / 3.0 * 0.4) * np.exp(2j * np.pi * n1 / 12.0)
    return h, g, (h1, h1 * np.exp(2j * np.pi * n1 / 6.0), h1 * np.exp(2j * np.pi * n1 / 3.0))


def fast_kurtogram(x: np.ndarray, fs: float, levels: int = 3) -> list[Node]:
    """Every node of the 1/3-binary tree down to binary level ``levels`` (bandwidth fs / 2^(levels + 1)).

    Parameters
    ----------
    x : array
        Real signal (any unit).
    fs : float
        Sample rate [Hz].
    levels : int
        Deepest binary level; the 1/3 levels k + log2(3) <= ``levels`` come with it.

    Each child of the 2-band bank is decimated by 2 and the upper one shifted by (-1)^n, so that every node's
    band occupies [0, fs_node / 2] in increasing order; the first len(h) - 1 samples of a node (the filter's
    transient) are left out of its kurtosis.
    """
    h, g, thirds = generating_filters()
    skip = len(h) - 1
    x = np.asarray(x, dtype=float)
    x = x - x.mean()
    nodes = [Node(0.0, 0.0, fs / 2.0, envelope_kurtosis(x), float(np.mean(x ** 2)))]

    def split3(c, f_lo, f_hi, level):
        if level + LOG2_3 > levels + 1e-9:
            return
        w = (f_hi - f_lo) / 3.0
        for i, hi in enumerate(thirds):
            ci = signal.lfilter(hi, 1.0, c)[2::3][skip:]
            nodes.append(Node(level + LOG2_3, f_lo + i * w, f_lo + (i + 1) * w, envelope_kurtosis(ci),
                              float(np.mean(np.abs(ci) ** 2))))

    def split2(c, f_lo, f_hi, level):
        if level >= levels:
            return
        a = signal.lfilter(h, 1.0, c)[1::2]
        d = signal.lfilter(g, 1.0, c)[1::2]
        d = d * (-1.0) ** np.arange(1, len(d) + 1)
        mid = 0.5 * (f_lo + f_hi)
        for c2, lo, hi in ((a, f_lo, mid), (d, mid, f_hi)):
            c2s = c2[skip:]
            nodes.append(Node(level + 1.0, lo, hi, envelope_kurtosis(c2s), float(np.mean(np.abs(c2s) ** 2))))
            split3(c2, lo, hi, level + 1.0)
            split2(c2, lo, hi, level + 1.0)

    split3(x, 0.0, fs / 2.0, 0.0)
    split2(x, 0.0, fs / 2.0, 0.0)
    return nodes


def pick_band(nodes: list[Node], fs: float, min_bandwidth_hz: float = MIN_BANDWIDTH_HZ,
              min_low_edge_hz: float = MIN_LOW_EDGE_HZ, max_high_edge_hz: float | None = None) -> Node:
    """The node of largest kurtosis among those at least ``min_bandwidth_hz`` wide, above ``min_low_edge_hz`` and
    below ``max_high_edge_hz`` (default 5.5 kHz at 12 kHz, 20 kHz at 48 kHz: under the acquisition's roll-off)."""
    if max_high_edge_hz is None:
        max_high_edge_hz = MAX_HIGH_EDGE_12K_HZ * fs / 12000.0 if fs <= 12000.0 else min(20000.0, 0.45 * fs)
    ok = [n for n in nodes if n.bandwidth >= min_bandwidth_hz - 1e-6 and n.f_lo >= min_low_edge_hz - 1e-6
          and n.f_hi <= max_high_edge_hz + 1e-6]
    if not ok:
        raise ValueError(f"no kurtogram band of >= {min_bandwidth_hz:g} Hz within {min_low_edge_hz:g}-"
                         f"{max_high_edge_hz:g} Hz at fs = {fs:g} Hz")
    return max(ok, key=lambda n: n.kurtosis)
