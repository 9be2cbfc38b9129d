"""The check the line-mode tests share: the fast real forms of bkabem_core.fe.linemodes against the complex
eigen-decomposition of each line (tests/integration/test_linemodes_all.py: a sample of lines of the library's
models, and all of one; tests/unit/test_linemodes.py: the fall-back)."""

from __future__ import annotations

import numpy as np

#: Accepted receptance error of the fast forms against the complex decomposition, relative to the receptance's
#: largest entry at each frequency (measured: 1.6e-7 at the highest lines, where the pole sum itself has that
#: conditioning against a direct solve; the improved method and the TDSM comparisons need 1e-4).
TOL = 1e-6


def worst_error(case, nu, fast, ref, lines) -> float:
    """Largest norm-relative receptance difference over the speeds 0..max (200 points plus every in-band
    resonance speed, where the error would peak) of the given lines."""
    worst = 0.0
    f_max = case.max_speed_hz
    for j in lines:
        res = np.abs(ref.poles[j].imag) / (2 * np.pi * nu[j])
        f = np.sort(np.r_[np.linspace(0.0, f_max, 201)[1:], res[(res > 0) & (res <= f_max)]])
        w = 2 * np.pi * nu[j] * f
        h_ref, h = ref.receptance_at(w, j), fast.receptance_at(w, j)
        e = np.abs(h - h_ref).reshape(w.size, -1).max(1) / np.abs(h_ref).reshape(w.size, -1).max(1)
        worst = max(worst, float(e.max()))
    return worst


def hardest_lines(nu, every: int = 10) -> np.ndarray:
    """Indices of the refined lines farthest from their anchors (the two last of each group, where the
    perturbation series converges slowest) and every ``every``-th line."""
    from bkabem_core.fe.linemodes import _groups

    far = []
    for _anchor, members in _groups(1.0 / nu, 0.05, 2e-3):
        far += members[-2:]                                       # members are sorted by distance
    return np.unique(np.r_[np.array(far, dtype=int), np.arange(0, nu.size, every)])
