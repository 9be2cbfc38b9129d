"""Matplotlib figures of the core results (PNG files; the Agg backend, no display needed)."""

from __future__ import annotations

import numpy as np

from bkabem_core.excitation.quasi_static import Excitation
from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS
from bkabem_core.solve.harmonic import Spectrum, Sweep


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_excitation(ex: Excitation, png_path: str) -> None:
    """Relative displacement over the recorded cage period(s) and its BPFO orders (paper Figs. 4 and 5)."""
    plt = _pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(12, 7), constrained_layout=True)
    for j, d in enumerate(DIRECTIONS):
        ax[0, j].plot(ex.time_s, ex.relative_displacement_m[j] * 1e6, lw=0.8)
        what = "4-DOF" if ex.method == "four_dof" else "quasi-static"
        ax[0, j].set(title=f"{ex.bearing.upper()} {what} relative displacement, {d}",
                     xlabel=f"time at {ex.reference_speed_hz:g} Hz shaft speed [s]", ylabel="rotor - housing [µm]")
        ax[0, j].grid(alpha=0.3)
        k = ex.all_orders[:80]
        a = ex.all_amplitude_m[d][:80] * 1e6
        kept = np.isin(k, ex.orders)
        ax[1, j].bar(k[kept], a[kept], color="C0", label="kept")
        ax[1, j].bar(k[~kept], a[~kept], color="0.7", label="dropped")
        ax[1, j].set(title=f"BPFO orders at {ex.reference_speed_hz:g} Hz, {d}", xlabel="BPFO order k",
                     ylabel="A_k [µm]")
        ax[1, j].legend()
        ax[1, j].grid(alpha=0.3)
    fig.savefig(png_path, dpi=110)
    plt.close(fig)


def plot_spectrum(sp: Spectrum, png_path: str, quantity: str = "acceleration") -> None:
    """Order spectra at one speed for the four locations, vertical and horizontal."""
    plt = _pyplot()
    x = sp.acceleration if quantity == "acceleration" else sp.displacement
    unit = "m/s²" if quantity == "acceleration" else "m"
    fig, ax = plt.subplots(2, 2, figsize=(12, 7), constrained_layout=True, sharex=True)
    for li, loc in enumerate(LOCATIONS):
        a = ax.flat[li]
        for di, d in enumerate(DIRECTIONS):
            a.stem(sp.frequency_hz + (di - 0.5) * 0.15 * sp.fault_frequencies_hz.bpfo, np.abs(x[:, li, di]),
                   linefmt=f"C{di}-", markerfmt=f"C{di}.", basefmt=" ", label=d)
        a.set_yscale("log")
        a.set(title=f"{loc} {quantity} at {sp.speed_hz:g} Hz (BPFO {sp.fault_frequencies_hz.bpfo:.1f} Hz)",
              xlabel="frequency [Hz]", ylabel=f"amplitude [{unit}]")
        a.grid(alpha=0.3)
        a.legend()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)


def plot_sweep(sw: Sweep, png_path: str, location: str = "de_housing", direction: str = "vertical") -> None:
    """Speed sweep: order-amplitude map (speed x frequency) and overall RMS per location."""
    plt = _pyplot()
    li, di = LOCATIONS.index(location), DIRECTIONS.index(direction)
    acc = np.abs(sw.acceleration[:, :, li, di])
    fig, ax = plt.subplots(1, 2, figsize=(13, 5.5), constrained_layout=True)
    f = sw.frequency_hz
    s = np.repeat(sw.speeds_hz[:, None], f.shape[1], axis=1)
    db = 20 * np.log10(np.maximum(acc, 1e-12))
    sc = ax[0].scatter(f.ravel(), s.ravel(), c=db.ravel(), s=2, cmap="viridis", vmin=db.max() - 80, vmax=db.max())
    fig.colorbar(sc, ax=ax[0], label="acceleration [dB re 1 m/s²]")
    ax[0].set(title=f"{location} {direction}: BPFO orders vs speed", xlabel="frequency [Hz]",
              ylabel="shaft speed [Hz]")
    rms = sw.rms("acceleration")
    for lj, loc in enumerate(LOCATIONS):
        for dj, d in enumerate(DIRECTIONS):
            ax[1].semilogy(sw.speeds_hz, rms[:, lj, dj], ls="-" if dj == 0 else "--", color=f"C{lj}",
                           label=f"{loc} {d}")
    ax[1].set(title="overall RMS acceleration (kept orders)", xlabel="shaft speed [Hz]", ylabel="RMS [m/s²]")
    ax[1].grid(alpha=0.3, which="both")
    ax[1].legend(fontsize=8)
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
