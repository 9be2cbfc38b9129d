"""Synthesis of any set of lines: the lines grouped into families, one wavetable per family and knot.

A BPFO-order set (outer race, healthy bearings) is one family: harmonics of the ball-pass phase, one table (the
synthesiser's original path, :mod:`bkabem_core.synth`). Any other set (:mod:`bkabem_core.lines`: inner-race
sidebands, ball-defect combs, the baseline's 1x, 2x and electrical lines) is split into families

    lines  c = k p + q,   k integer,      x_family(t) = Re(exp(i 2 pi phi_q) G(phi_p)),

``phi_p = p . Phi / 2 pi`` the family's phase in turns, ``G`` a periodic function of it. Without a carrier
(``q = 0``) the family is ``Re sum_{k>=1} Y_k e^{i k 2 pi phi_p}``: one real table, exactly the original path.
With a carrier (sidebands: ``q = n`` shaft orders for an inner race, ``n`` cage orders for a ball), ``k`` runs over
both signs and ``G = Re G + i Im G`` takes two real tables; the sample is ``cos(2 pi phi_q) Re G - sin(2 pi phi_q)
Im G``. Families follow the kinds' own phases (fault_kinds.md):

* ball spin ``p = (0, 0, 1, 0)`` (BSF), carrier the rest (``n`` FTF);
* supply ``p = (0, 0, 0, 1)``, carrier the rest;
* no shaft coefficient: the ball-pass phase ``p = (0, z, 0, 0)`` when the cage coefficient is a multiple of z
  (BPFO orders), else the cage phase ``(0, 1, 0, 0)`` (FTF orders);
* a cage coefficient that is a multiple of z: the inner-race phase ``p = (z, -z, 0, 0)`` (BPFI), carrier the
  remaining shaft orders (``n`` f_r: the load-zone sidebands);
* no cage coefficient: shaft orders ``p = (1, 0, 0, 0)`` (1x, 2x);
* anything else: its own primitive direction.

Every family's phase is an exact function of the knots (speed linear in time between them, as the ball-pass phase
of the original path); random slip moves the cage and the spin only (``kappa``: turns of the family phase per
ball pass of slip; 0 for shaft and supply phases, so inner-race sidebands stay tied to f_r).

Units: phases in turns, frequencies in Hz, amplitudes in the channels' units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import synth_kernel

PASS = float(synth_kernel.PASS_UNITS)


@dataclass
class Family:
    """Lines ``k p + q`` of one table pair (module docstring).

    Attributes
    ----------
    p, q : tuple of int (4,)
        Phase and carrier coefficients on (shaft, cage, spin, line).
    lines : ndarray of int (K,)
        Indices of the family's lines in the model's line set.
    k : ndarray of int (K,)
        Harmonic of each line (``c = k p + q`` with ``sign = +1``, else ``c = -(k p + q)``).
    sign : ndarray (K,)
        +1, or -1 where the family holds the conjugate of the line (its amplitude enters conjugated).
    harmonics : ndarray of int (H,)
        Table harmonics 1..: for a real family the distinct k; for a carrier family the distinct |k| >= 1.
    table_size : int
    basis : QuarterBasis
        Cosines and sines of ``harmonics`` over the padded table rows.
    """

    p: tuple
    q: tuple
    lines: np.ndarray
    k: np.ndarray
    sign: np.ndarray
    harmonics: np.ndarray
    table_size: int
    basis: object
    rate_p: float = 0.0       # turns of phi_p per shaft turn
    fixed_p: float = 0.0      # turns of phi_p per second besides
    rate_q: float = 0.0
    fixed_q: float = 0.0
    kappa_p: float = 0.0      # turns of phi_p per ball pass of slip
    kappa_q: float = 0.0

    @property
    def carrier(self) -> bool:
        return any(self.q)


def _family_of(c, z: int):
    """(p, k, q) with ``c = k p + q`` for the line c (module docstring)."""
    s, cc, b, ln = (int(v) for v in c)
    if b != 0:
        return (0, 0, 1, 0), b, (s, cc, 0, ln)
    if ln != 0:
        return (0, 0, 0, 1), ln, (s, cc, 0, 0)
    if s == 0:
        if cc % z == 0:
            return (0, z, 0, 0), cc // z, (0, 0, 0, 0)
        return (0, 1, 0, 0), cc, (0, 0, 0, 0)
    if cc != 0 and cc % z == 0:
        k = -cc // z
        return (z, -z, 0, 0), k, (s - k * z, 0, 0, 0)
    if cc == 0:
        return (1, 0, 0, 0), s, (0, 0, 0, 0)
    g = math.gcd(abs(s), abs(cc))
    return (s // g, cc // g, 0, 0), g, (0, 0, 0, 0)


def _canonical(q) -> int:
    """+1 if the carrier's first non-zero coefficient is positive (or q = 0), else -1."""
    for v in q:
        if v != 0:
            return 1 if v > 0 else -1
    return 1


class LineFamilies:
    """The families of a line set and their per-knot tables (module docstring).

    Parameters
    ----------
    coefficients : ndarray of int (L, 4)
    rates_per_hz : ndarray (4,)
        (1, FTF, BSF, 0).
    line_hz : float
        Supply frequency [Hz].
    n_balls : int
    bpfo_per_hz : float
    table_size : int or None
        Fixed table size (power of 2), or None: max(64, 8 x the family's highest harmonic) each.
    """

    def __init__(self, coefficients, rates_per_hz, line_hz: float, n_balls: int, bpfo_per_hz: float,
                 table_size: int | None = None):
        coef = np.asarray(coefficients, dtype=np.int64)
        rates = np.asarray(rates_per_hz, dtype=float)
        z = int(n_balls)
        spin_per_cage = rates[2] / rates[1]
        groups: dict = {}
        for j, c in enumerate(coef):
            p, k, q = _family_of(c, z)
            sign = _canonical(q)
            if not any(q) and k < 0:
                sign = -1
            if sign < 0:
                k, q = -k, tuple(-v for v in q)
            groups.setdefault((p, q), []).append((j, k, sign))
        self.families: list[Family] = []
        for (p, q), members in groups.items():
            lines = np.array([m[0] for m in members], dtype=np.int64)
            k = np.array([m[1] for m in members], dtype=np.int64)
            sign = np.array([m[2] for m in members], dtype=float)
            harmonics = np.unique(np.abs(k[k != 0])) if any(q) else np.unique(k)
            if harmonics.size == 0:
                harmonics = np.array([1], dtype=np.int64)           # a carrier alone: tables of DC only
            n = table_size or max(64, 1 << int(math.ceil(math.log2(8 * int(harmonics.max())))))
            if n < 4 * int(harmonics.max()) or n > synth_kernel.MAX_TABLE:
                raise ValueError(f"table size {n} cannot hold harmonic {int(harmonics.max())} of family {p}")
            fam = Family(p=p, q=q, lines=lines, k=k, sign=sign, harmonics=harmonics, table_size=n,
                         basis=synth_kernel.quarter_basis(harmonics, n))
            fam.rate_p = float(np.dot(p[:3], rates[:3]))
            fam.fixed_p = p[3] * float(line_hz)
            fam.rate_q = float(np.dot(q[:3], rates[:3]))
            fam.fixed_q = q[3] * float(line_hz)
            fam.kappa_p = (p[1] + p[2] * spin_per_cage) / z
            fam.kappa_q = (q[1] + q[2] * spin_per_cage) / z
            self.families.append(fam)
        self.bpfo_per_hz = float(bpfo_per_hz)
        # the families' emphasis (cubic B-spline droop) per line, for the amplitudes handed to the tables
        self.emphasis = [1.0 / np.sinc(f.harmonics / f.table_size) ** 4 for f in self.families]

    def __len__(self) -> int:
        return len(self.families)

    def tables(self, y: np.ndarray, dtype) -> list:
        """Per family its padded spline table(s) (N + 3, C) for channel amplitudes ``y`` (L, C) complex: one for a
        real family, (Re G, Im G) for a carrier family; no DC (added once by the caller)."""
        out = []
        for fam, emph in zip(self.families, self.emphasis):
            yl = y[fam.lines]
            yl = np.where(fam.sign[:, None] > 0, yl, np.conj(yl))                    # amplitudes of k p + q
            cos, sin = fam.basis.full()
            h = fam.harmonics
            if not fam.carrier:
                a = np.zeros((h.size, y.shape[1]), complex)
                np.add.at(a, np.searchsorted(h, fam.k), yl)
                a *= emph[:, None]
                out.append(((cos @ a.real - sin @ a.imag).astype(dtype),))
                continue
            pos = np.zeros((h.size, y.shape[1]), complex)
            neg = np.zeros_like(pos)
            dc = np.zeros(y.shape[1], complex)
            for kk, v in zip(fam.k, yl):
                if kk > 0:
                    pos[np.searchsorted(h, kk)] += v
                elif kk < 0:
                    neg[np.searchsorted(h, -kk)] += v
                else:
                    dc += v
            re_a = (pos + np.conj(neg)) * emph[:, None]
            im_a = -1j * (pos - np.conj(neg)) * emph[:, None]
            re_t = dc.real[None, :] + cos @ re_a.real - sin @ re_a.imag
            im_t = dc.imag[None, :] + cos @ im_a.real - sin @ im_a.imag
            out.append((re_t.astype(dtype), im_t.astype(dtype)))
        return out

    @staticmethod
    def turns(fam_rate: float, fam_fixed: float, u_passes: float, x_samples: int, bpfo_per_hz: float,
              sample_rate_hz: float) -> float:
        """Fractional turns of a family phase at ``u_passes`` ball passes (BPFO phase) and sample ``x_samples``."""
        t = (fam_rate / bpfo_per_hz) * u_passes + fam_fixed * (x_samples / sample_rate_hz)
        return t - math.floor(t)
