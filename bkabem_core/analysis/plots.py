"""Matplotlib figures of the core results (PNG files; the Agg backend, no display needed).

Every figure draws each line at its own frequency, names the largest lines by what they are (``BPFO``,
``BPFI - 1 f_r``, ``2 BSF + FTF``, ``1x``: :mod:`bkabem_core.excitation.line_names`) and marks the fault
frequencies of each bearing (dashed: 1x, FTF, BPFO, BPFI, BSF, 2xBSF; the line a defect of that bearing excites
also at 2x and 3x, the colours of :data:`bkabem_core.analysis.fault_lines.LINE_COLORS`). Each function writes the
PNG and returns the figure (closed), so that a test can read what was drawn.
"""

from __future__ import annotations

import numpy as np

from bkabem_core.analysis.fault_lines import LINE_COLORS, Defect, marker_plan
from bkabem_core.bearing.deep_groove import FaultFrequencies
from bkabem_core.excitation.line_names import line_labels
from bkabem_core.excitation.quasi_static import Excitation
from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS
from bkabem_core.solve.harmonic import Spectrum, Sweep

__all__ = ["defects_of_case", "fault_line_hz", "plot_excitation", "plot_spectrum", "plot_sweep"]

#: Lines named in each panel (the largest).
NAMED_LINES = 5
#: The figures show lines down to this fraction of the panel's largest (log scale: 80 dB).
DISPLAY_FLOOR = 1e-4
_DIRECTION_STYLE = {"vertical": {"color": "C0", "marker": "o"}, "horizontal": {"color": "C1", "marker": "x"}}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def defects_of_case(case) -> list[Defect]:
    """The case's defects as :class:`~bkabem_core.analysis.fault_lines.Defect` (kind, bearing, size) for the
    markers."""
    return [Defect(kind=d.race, bearing=d.bearing, length_m=d.length_m, depth_m=d.depth_m, angle_rad=d.angle_rad,
                   ball=d.ball_index + 1 if d.race == "ball" else 0) for d in case.defects()]


def fault_line_hz(ff: FaultFrequencies, speed_hz: float) -> dict[str, float]:
    """{line name: frequency [Hz]} of :data:`~bkabem_core.analysis.fault_lines.LINES` at a shaft speed (``ff``
    at that speed)."""
    return {"1x": float(speed_hz), "FTF": ff.ftf, "BPFO": ff.bpfo, "BPFI": ff.bpfi, "BSF": ff.bsf,
            "2xBSF": 2.0 * ff.bsf}


def _mark_fault_lines(ax, lines: dict[str, float], defects, f_max: float, legend: dict) -> None:
    """Dashed markers of the fault frequencies (and the excited line's harmonics) up to ``f_max``."""
    for m in marker_plan(lines, defects, f_max):
        color = np.array(m.color) / 255.0 * 0.85
        ax.axvline(m.frequency_hz, color=color, ls="--", lw=1.0, alpha=0.9, zorder=0)
        legend.setdefault(m.line, color)


def _name_largest(ax, f, amp, labels, n: int = NAMED_LINES, f_lo: float = 0.0, f_hi: float = np.inf) -> list[int]:
    """Write the names of the ``n`` largest lines in ``[f_lo, f_hi]`` above them, each at least a fifteenth of the
    range away from a line named already (the largest of each group of neighbours); returns their indices."""
    inside = np.flatnonzero((f >= f_lo) & (f <= f_hi))
    if not inside.size:
        return []
    span = (min(f_hi, float(f[inside].max())) - f_lo) or 1.0
    named: list[int] = []
    for i in inside[np.argsort(-amp[inside], kind="stable")]:
        if len(named) == n or not amp[i] > 0:
            break
        if all(abs(f[i] - f[j]) > span / 15 for j in named):
            named.append(int(i))
    for rank, i in enumerate(sorted(named, key=lambda j: f[j])):
        ax.annotate(labels[i], (f[i], amp[i]), xytext=(0, 4 + 10 * (rank % 2)), textcoords="offset points",
                    ha="center", va="bottom", fontsize=7,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "0.6", "lw": 0.5, "alpha": 0.85})
    return named


def _key(fig, legend: dict, extra=()) -> None:
    from matplotlib.lines import Line2D

    handles = list(extra) + [Line2D([], [], color=c, ls="--", lw=1.2, label=name) for name, c in legend.items()]
    if handles:
        fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 9), fontsize=8, frameon=False)


def _stems(ax, f, amp, direction: str, floor: float) -> None:
    style = _DIRECTION_STYLE[direction]
    keep = amp >= floor
    ax.vlines(f[keep], floor, amp[keep], color=style["color"], lw=0.8, alpha=0.75)
    ax.plot(f[keep], amp[keep], ls="none", ms=3.5, mfc="none" if style["marker"] == "o" else style["color"],
            **style, label=direction)


def _zoom_hz(fault: dict[str, float], defects, f: np.ndarray) -> float:
    """Upper end of the zoomed view [Hz]: 4.5 x the highest line a defect excites (BPFO without one), where the
    fault-frequency markers and the sidebands can be read."""
    excited = [fault[d.line] for d in defects if d.depth_m > 0 and d.line in fault] or [fault["BPFO"]]
    top = float(f.max()) if f.size else 1.0
    return float(min(top * 1.04, 4.5 * max(excited))) if max(excited) > 0 else top * 1.04



def plot_spectrum(sp: Spectrum, png_path: str, quantity: str = "acceleration", defects=(),
                  title: str = "") -> "object":
    """Line spectra at one speed for the four locations, vertical and horizontal at each line's frequency: the
    whole band (left) and a zoom to 4.5 x the highest excited fault frequency (right).

    Parameters
    ----------
    sp : Spectrum
    png_path : str
    quantity : {"acceleration", "displacement"}
    defects : sequence of Defect
        The machine's defects (:func:`defects_of_case`): their lines are also marked at 2x and 3x, in the panels
        of their bearing.
    title : str
        First words of the figure's title (e.g. the case).

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _pyplot()
    x = sp.acceleration if quantity == "acceleration" else sp.displacement
    unit = "m/s²" if quantity == "acceleration" else "m"
    labels = list(sp.labels) if sp.labels is not None else [f"{int(k)} BPFO" for k in sp.orders]
    ff = sp.fault_frequencies_hz
    fault = fault_line_hz(ff, sp.speed_hz)
    f = np.asarray(sp.frequency_hz, dtype=float)
    f_max = min(float(f.max()) * 1.04, sp.band_hz) if f.size else 1.0       # lines beyond the model's band: not drawn
    f_zoom = _zoom_hz(fault, defects, f)
    views = (f_max, f_zoom) if f_zoom < 0.8 * f_max else (f_max,)   # no zoom when the band is narrow already
    fig, ax = plt.subplots(len(LOCATIONS), len(views), figsize=(14 if len(views) == 2 else 11, 14), squeeze=False,
                           gridspec_kw={"width_ratios": (1.4, 1)[:len(views)]})
    legend: dict = {}
    for li, loc in enumerate(LOCATIONS):
        amp = np.abs(x[:, li, :])                                    # (K, 2)
        bearing = loc.split("_")[0]
        mine = [dd for dd in defects if dd.bearing == bearing]
        for col, hi in enumerate(views):
            a = ax[li, col]
            inside = f <= hi
            top = float(amp[inside].max()) if np.any(inside) else 0.0
            floor = top * DISPLAY_FLOOR if top > 0 else 1e-30
            for di, d in enumerate(DIRECTIONS):
                _stems(a, f[inside], amp[inside, di], d, floor)
            _mark_fault_lines(a, fault, mine, hi, legend)
            _name_largest(a, f, amp.max(axis=1), labels, f_hi=hi)
            a.set_yscale("log")
            a.set_ylim(floor, top * 8 if top > 0 else 1.0)
            a.set_xlim(0, hi)
            a.set_title(f"{loc.replace('_', ' ')} {quantity}" + (", zoom" if col else ""), fontsize=10)
            a.set_ylabel(f"amplitude [{unit}]")
            a.grid(alpha=0.3)
            if li == len(LOCATIONS) - 1:
                a.set_xlabel("frequency [Hz]")
            if li == 0 and col == 0:
                a.legend(fontsize=8, loc="upper right")
    head = f"{title}: " if title else ""
    fig.suptitle(f"{head}{len(f)} lines at {sp.speed_hz:g} Hz shaft speed ({sp.speed_hz * 60:.0f} rpm), the largest "
                 f"named\ndashed: fault frequencies FTF {ff.ftf:.1f}, BPFO {ff.bpfo:.1f}, BPFI {ff.bpfi:.1f}, "
                 f"BSF {ff.bsf:.1f} Hz (a defect's line also at 2x and 3x, in its bearing's panels)", fontsize=10)
    _key(fig, legend)
    fig.tight_layout(rect=(0, 0.025, 1, 0.965))
    fig.savefig(png_path, dpi=100)
    plt.close(fig)
    return fig


def plot_sweep(sw: Sweep, png_path: str, location: str = "de_housing", direction: str = "vertical",
               defects=(), fault_multipliers: FaultFrequencies | None = None, title: str = "") -> "object":
    """Speed sweep: line map (frequency x speed, colour = amplitude) and the overall RMS per location.

    ``fault_multipliers`` (per shaft Hz) draws the fault frequencies of ``defects`` (or BPFO, BPFI, 2xBSF, 1x
    when none is given) as dashed rays through the origin of the line map.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _pyplot()
    li, di = LOCATIONS.index(location), DIRECTIONS.index(direction)
    acc = np.abs(sw.acceleration[:, :, li, di])
    fig, ax = plt.subplots(1, 2, figsize=(14, 6))
    f = sw.frequency_hz
    s = np.repeat(sw.speeds_hz[:, None], f.shape[1], axis=1)
    db = 20 * np.log10(np.maximum(acc, 1e-12))
    keep = db >= db.max() - 80
    order = np.argsort(db[keep])                                      # the strongest on top
    sc = ax[0].scatter(f[keep][order], s[keep][order], c=db[keep][order], s=3, cmap="viridis", vmin=db.max() - 80,
                       vmax=db.max(), linewidths=0)
    fig.colorbar(sc, ax=ax[0], label="acceleration [dB re 1 m/s²]")
    legend: dict = {}
    if fault_multipliers is not None and sw.speeds_hz.size:
        top_speed = float(sw.speeds_hz.max())
        excited = {d.line for d in defects if d.depth_m > 0} or {"BPFO", "BPFI", "2xBSF", "1x"}
        for name, mult in fault_line_hz(fault_multipliers, 1.0).items():
            if name in excited:
                color = np.array(LINE_COLORS[name]) / 255.0 * 0.85
                ax[0].plot([0, mult * top_speed], [0, top_speed], ls="--", lw=1.0, color=color)
                legend[name] = color
    ax[0].set_xlim(0, float(f.max()) * 1.02 if f.size else 1.0)
    ax[0].set_ylim(float(sw.speeds_hz.min()) if sw.speeds_hz.size else 0, float(sw.speeds_hz.max()) * 1.01
                   if sw.speeds_hz.size else 1)
    ax[0].set(title=f"{location.replace('_', ' ')} {direction}: {f.shape[1]} lines vs speed (top 80 dB)",
              xlabel="frequency [Hz]", ylabel="shaft speed [Hz]")
    rms = sw.rms("acceleration")
    for lj, loc in enumerate(LOCATIONS):
        for dj, d in enumerate(DIRECTIONS):
            ax[1].semilogy(sw.speeds_hz, rms[:, lj, dj], ls="-" if dj == 0 else "--", color=f"C{lj}",
                           label=f"{loc.replace('_', ' ')} {d}")
    ax[1].set(title=f"overall RMS acceleration of the {f.shape[1]} lines", xlabel="shaft speed [Hz]",
              ylabel="RMS [m/s²]")
    ax[1].grid(alpha=0.3, which="both")
    ax[1].legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    _key(fig, legend)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97 if title else 1))
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
    return fig


def _line_waveform(ex: Excitation, n: int = 8192):
    """(t [s], (2, n) relative displacement [m]) of an excitation's lines over one cage revolution at its reference
    speed (the sum of its lines: a moving defect's signal, which one ball pitch does not hold; the cage turns the
    balls through the load zone once in it)."""
    ls = ex.line_set()
    ftf = float(ls.rates_per_hz[1])
    t = np.linspace(0.0, 1.0 / (ftf * ex.reference_speed_hz), n, endpoint=False)
    f = ls.frequency_hz(ex.reference_speed_hz)
    phase = np.exp(2j * np.pi * np.outer(t, f))                                       # (n, L)
    x = (phase @ ls.amplitude).real.T + np.asarray(ls.dc)[:, None]                   # (2, n)
    return t, x


def plot_excitation(ex: Excitation, png_path: str) -> "object":
    """Relative displacement and the excitation's lines (paper Figs. 4 and 5 for BPFO orders).

    BPFO orders (outer race, healthy): the recorded ball pass and the amplitude per order (kept and dropped).
    Line sets (inner race, ball): the sum of the lines over one cage revolution and the lines against their
    frequency at the reference speed, the largest named.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(12.5, 7.5))
    what = "4-DOF" if ex.method == "four_dof" else "quasi-static"
    ls = ex.line_set()
    for j, d in enumerate(DIRECTIONS):
        if ex.lines is None:
            ax[0, j].plot(ex.time_s, ex.relative_displacement_m[j] * 1e6, lw=0.8)
            ax[0, j].set(title=f"{ex.bearing.upper()} {what} relative displacement, {d}",
                         xlabel=f"time at {ex.reference_speed_hz:g} Hz shaft speed [s]", ylabel="rotor - housing [µm]")
            k = ex.all_orders[:80]
            a = ex.all_amplitude_m[d][:80] * 1e6
            kept = np.isin(k, ex.orders)
            ax[1, j].bar(k[kept], a[kept], color="C0", label="kept")
            ax[1, j].bar(k[~kept], a[~kept], color="0.7", label="dropped")
            ax[1, j].set(title=f"BPFO orders at {ex.reference_speed_hz:g} Hz, {d}", xlabel="BPFO order k",
                         ylabel="A_k [µm]")
            ax[1, j].legend()
        else:
            t, x = _line_waveform(ex)
            ax[0, j].plot(t, x[j] * 1e6, lw=0.8)
            ax[0, j].set(title=f"{ex.bearing.upper()} {what} relative displacement, {d} ({len(ls)} lines)",
                         xlabel=f"time at {ex.reference_speed_hz:g} Hz shaft speed [s]", ylabel="rotor - housing [µm]")
            f = ls.frequency_hz(ex.reference_speed_hz)
            amp = np.abs(ls.amplitude[:, j]) * 1e6
            top = float(amp.max()) if amp.size else 1.0
            floor = top * DISPLAY_FLOOR if top > 0 else 1e-30
            _stems(ax[1, j], f, amp, d, floor)
            _name_largest(ax[1, j], f, amp, line_labels(ls.coefficients, ex.n_balls))
            ax[1, j].set_yscale("log")
            ax[1, j].set_ylim(floor, top * 6 if top > 0 else 1.0)
            ax[1, j].set(title=f"lines at {ex.reference_speed_hz:g} Hz, {d} (the {NAMED_LINES} largest named)",
                         xlabel="frequency [Hz]", ylabel="amplitude [µm]")
        ax[0, j].grid(alpha=0.3)
        ax[1, j].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
    return fig
