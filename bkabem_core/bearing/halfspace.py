"""Frictionless normal contact of two elastic bodies, each taken as a half-space, on a rectangular grid.

The bodies touch where their gap closes. With the initial gap ``g0(x, y)`` (the separation of the undeformed
surfaces when they first touch, >= 0; a pit in one of them adds its depth), a rigid approach ``delta`` and the
contact pressure ``p >= 0``, the combined elastic displacement of the two surfaces is the Boussinesq integral

    u(x, y) = 1 / (pi E*) * integral p(x', y') / sqrt((x - x')^2 + (y - y')^2) dx' dy',   1/E* = 2 (1 - nu^2) / E

for equal materials (Johnson, *Contact Mechanics*, 1985, sections 3.2 and 4.2), and the contact conditions are
``g0 + u - delta = 0`` where ``p > 0``, ``>= 0`` where ``p = 0``, with the load ``Q = integral p dA``. The pressure
is piecewise constant on the grid cells (Love's 1929 rectangle solution gives the influence of a cell), the
convolution is evaluated with zero-padded FFTs (the discrete convolution, fast Fourier transform method of Liu,
Wang & Liu, Wear 243, 2000), and the conditions are solved for a given load by the constrained conjugate gradient of
Polonsky & Keer (Wear 231, 1999), which returns the approach ``delta`` with the pressure.

A smooth paraboloid gap on a fine enough grid reproduces Hertz's ellipse and approach (the tests check it); the
grid must hold the whole contact (:class:`ContactDomainError` otherwise).

Units: SI (m, Pa, N).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["HalfSpaceGrid", "ContactSolution", "ContactDomainError", "combined_modulus_pa"]


class ContactDomainError(RuntimeError):
    """The contact reached the edge of the grid: a larger grid is needed."""


def combined_modulus_pa(effective_modulus_pa: float) -> float:
    """Johnson's combined modulus E* [Pa] of two bodies whose Hamrock modulus is ``E' = E / (1 - nu^2)`` (equal
    materials): ``E* = E' / 2``."""
    return 0.5 * float(effective_modulus_pa)


def _rectangle_potential(x, y):
    """``x asinh(y / |x|) + y asinh(x / |y|)``: the double antiderivative of ``1 / sqrt(x^2 + y^2)`` (up to terms
    in x or y alone, which the rectangle's four corners cancel); 0 on the axes (its limit)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ax = np.where(x != 0.0, x * np.arcsinh(y / np.where(x != 0.0, np.abs(x), 1.0)), 0.0)
        ay = np.where(y != 0.0, y * np.arcsinh(x / np.where(y != 0.0, np.abs(y), 1.0)), 0.0)
    return ax + ay


@dataclass(frozen=True)
class ContactSolution:
    """A solved contact.

    Attributes
    ----------
    approach_m : float
        Rigid approach ``delta`` of the two bodies [m] (from first touch of the undeformed surfaces).
    pressure_pa : ndarray (nx, ny)
        Contact pressure of each cell [Pa].
    iterations : int
        Conjugate-gradient iterations taken.
    """

    approach_m: float
    pressure_pa: np.ndarray
    iterations: int


class HalfSpaceGrid:
    """A grid of ``nx x ny`` cells of ``dx x dy`` [m] on which contacts are solved (module docstring).

    Parameters
    ----------
    nx, ny : int
        Cells along x and y.
    dx_m, dy_m : float
        Cell size [m].
    combined_modulus_pa : float
        E* [Pa] (:func:`combined_modulus_pa`).
    """

    #: Relative change of the pressure (L1, over the load) below which the iteration has converged.
    TOLERANCE = 1e-8
    MAX_ITERATIONS = 2000

    def __init__(self, nx: int, ny: int, dx_m: float, dy_m: float, combined_modulus_pa: float):
        self.nx, self.ny = int(nx), int(ny)
        self.dx_m, self.dy_m = float(dx_m), float(dy_m)
        self.cell_area_m2 = self.dx_m * self.dy_m
        self._shape = (2 * self.nx, 2 * self.ny)
        # here, not at import: only a round pit's contact needs it
        from scipy import fft

        self._fft = fft
        self._kernel_hat = fft.rfft2(self._influence(combined_modulus_pa))

    def _influence(self, e_star: float) -> np.ndarray:
        """Surface displacement [m/Pa] at cell offsets (i dx, j dy) under a unit pressure on one cell (Love), laid
        out for a circular convolution of twice the grid (negative offsets wrapped)."""
        nx, ny, hx, hy = self.nx, self.ny, 0.5 * self.dx_m, 0.5 * self.dy_m
        ix = np.r_[np.arange(nx), 0, np.arange(-nx + 1, 0)] * self.dx_m          # offsets in wrapped order
        iy = np.r_[np.arange(ny), 0, np.arange(-ny + 1, 0)] * self.dy_m
        x, y = np.meshgrid(ix, iy, indexing="ij")
        f = _rectangle_potential
        k = (f(x + hx, y + hy) - f(x + hx, y - hy) - f(x - hx, y + hy) + f(x - hx, y - hy)) / (math.pi * e_star)
        k[nx, :] = 0.0                                                              # the padding row and column
        k[:, ny] = 0.0
        return k

    def displacement_m(self, pressure_pa: np.ndarray) -> np.ndarray:
        """Combined elastic displacement of the two surfaces [m] at the cell centres under ``pressure_pa``."""
        fft = self._fft
        u = fft.irfft2(fft.rfft2(pressure_pa, self._shape) * self._kernel_hat, self._shape)
        return u[:self.nx, :self.ny]

    def solve(self, gap_m: np.ndarray, load_n: float, pressure_guess_pa: np.ndarray | None = None) -> ContactSolution:
        """The contact of the initial gap ``gap_m`` (nx, ny) [m] under ``load_n`` [N] (> 0).

        Raises
        ------
        ContactDomainError
            The contact touches the edge of the grid.
        RuntimeError
            The iteration did not converge (not seen for gaps of one connected body).
        """
        g0 = np.asarray(gap_m, dtype=float)
        if g0.shape != (self.nx, self.ny):
            raise ValueError(f"gap_m: shape {(self.nx, self.ny)} (got {g0.shape})")
        w = float(load_n)
        if not w > 0.0:
            raise ValueError(f"load_n: must be > 0 (got {w!r})")
        da = self.cell_area_m2
        if pressure_guess_pa is not None and np.any(pressure_guess_pa > 0.0):
            p = np.maximum(np.asarray(pressure_guess_pa, dtype=float), 0.0)
        else:
            p = np.where(g0 <= np.min(g0) + 0.1 * (np.ptp(g0) + 1e-300), 1.0, 0.0)   # start where it is closest
        p *= w / (da * p.sum())
        t = np.zeros_like(p)
        g_norm_old, conjugate = 1.0, 0.0
        for it in range(1, self.MAX_ITERATIONS + 1):
            gap = self.displacement_m(p) + g0
            contact = p > 0.0
            gap -= gap[contact].mean()
            g_norm = float(np.sum(gap[contact] ** 2))
            t = np.where(contact, gap + conjugate * (g_norm / g_norm_old) * t, 0.0)
            g_norm_old = g_norm
            r = self.displacement_m(t)
            r -= r[contact].mean()
            rt = float(np.sum(r[contact] * t[contact]))
            if rt == 0.0:                                       # converged exactly
                break
            tau = float(np.sum(gap[contact] * t[contact])) / rt
            p_old = p
            p = np.maximum(p - tau * t, 0.0)
            overlap = (p == 0.0) & (gap < 0.0)
            if np.any(overlap):
                conjugate = 0.0
                p[overlap] -= tau * gap[overlap]
            else:
                conjugate = 1.0
            p *= w / (da * p.sum())
            if da * float(np.abs(p - p_old).sum()) < self.TOLERANCE * w:
                break
        else:
            raise RuntimeError(f"half-space contact did not converge in {self.MAX_ITERATIONS} iterations")
        if p[0, :].any() or p[-1, :].any() or p[:, 0].any() or p[:, -1].any():
            raise ContactDomainError("the contact reaches the edge of the grid")
        contact = p > 0.0
        approach = float(np.mean((self.displacement_m(p) + g0)[contact]))
        return ContactSolution(approach, p, it)
