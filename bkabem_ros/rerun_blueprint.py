"""The default Rerun layout of a bkabem recording, and the units the viewer shows (rerun-sdk 0.41).

The recording on ROS 2 / MCAP is SI. The viewer shows engineers' units, named in every view and
series: acceleration m/s², displacement µm (as a proximity probe is read), velocity mm/s
(:data:`DISPLAY_UNITS`). :mod:`bkabem_ros.rerun_io` scales on logging.

Layout (:func:`blueprint`), DE left, NDE right, each column:

1. waveforms (tabs per quantity): the last ``window_s`` (1 s) before the time cursor, every
   sample, min/max aggregated when zoomed out, so impact peaks keep their height;
2. spectra (tabs): envelope spectrum of the band-passed acceleration, order spectra of the
   model (acceleration, displacement), fault-frequency markers;
3. trends over the whole run (tabs): ISO velocity RMS with the zone limits, the acceleration per
   block (min/max envelope and RMS: the overview that loads fast, ten points per second),
   displacement peak-to-peak, kurtosis and crest factor, the ground truth's defect depths (a
   scenario's growing defects; a 0 "no defect" line for a healthy bearing);
4. the health panel: ISO zone, impulsiveness, what the envelope spectrum shows, the ground truth;

and across the bottom shaft speed and fault frequencies over the whole run, each on its own
axis. The recording opens following its latest data (the end of a file), paused there once
the user scrubs, so every view has data from the start.
"""

from __future__ import annotations

__all__ = ["DISPLAY_UNITS", "TIMELINE", "blueprint", "view_names"]

TIMELINE = "sample_time"

#: quantity -> (unit shown, factor from SI).
DISPLAY_UNITS = {
    "acceleration": ("m/s²", 1.0),
    "velocity": ("mm/s", 1e3),
    "displacement": ("µm", 1e6),
}

_WAVEFORM_WINDOW_S = 1.0


def _views(loc: str, quantities):
    """(group, name, kind, origin, extra) of one bearing's views, in layout order."""
    L = loc.upper()
    out = []
    for q in quantities:
        unit = DISPLAY_UNITS[q][0]
        out.append(("waveforms", f"{L} {q} [{unit}]", "wave", f"/{loc}/{q}"))
    out.append(("spectra", f"{L} envelope spectrum [m/s²] vs frequency [Hz]", "bars", f"/{loc}/envelope"))
    for q in quantities:
        unit = DISPLAY_UNITS[q][0]
        out.append(("spectra", f"{L} order spectrum, {q} [{unit}] vs frequency [Hz]", "bars",
                    f"/{loc}/spectrum/{q}"))
    out.append(("trends", f"{L} ISO velocity RMS 10-1000 Hz [mm/s], zone limits", "trend", f"/{loc}/iso_velocity"))
    out.append(("trends", f"{L} acceleration per block: min/max and RMS [m/s²]", "trend",
                f"/{loc}/overview/acceleration"))
    if "displacement" in quantities:
        out.append(("trends", f"{L} displacement peak-to-peak [µm]", "trend", f"/{loc}/trend/displacement"))
    out.append(("trends", f"{L} kurtosis and crest factor [-]", "trend", f"/{loc}/trend/impulsiveness"))
    out.append(("trends", f"{L} ground truth: defect depth [µm]", "trend", f"/{loc}/trend/ground_truth"))
    out.append(("health", f"{L} health", "text", f"/{loc}/health"))
    return out


def view_names(locations=("de", "nde"), quantities=("acceleration", "displacement")) -> list[str]:
    """Names of every view :func:`blueprint` makes (tests check the viewer shows each)."""
    names = [v[1] for loc in locations for v in _views(loc, quantities)]
    return names + ["shaft speed [Hz]", "fault frequencies [Hz]"]


def blueprint(locations=("de", "nde"), quantities=("acceleration", "displacement"),
              window_s: float = _WAVEFORM_WINDOW_S):
    """The layout described in the module docstring; ``window_s``: seconds of waveform shown
    before the time cursor."""
    import rerun.blueprint as rrb  # noqa: PLC0415

    last = rrb.VisibleTimeRange(TIMELINE, start=rrb.TimeRangeBoundary.cursor_relative(seconds=-window_s),
                                end=rrb.TimeRangeBoundary.cursor_relative())
    legend = rrb.PlotLegend(corner=rrb.Corner2D.LeftTop, visible=True)
    # trends rise during a run-up: their legend goes where the early, small values are not
    trend_legend = rrb.PlotLegend(corner=rrb.Corner2D.RightBottom, visible=True)
    no_legend = rrb.PlotLegend(visible=False)

    def make(kind, name, origin):
        if kind == "wave":
            return rrb.TimeSeriesView(origin=origin, name=name, time_ranges=[last], plot_legend=legend)
        if kind == "bars":
            return rrb.BarChartView(origin=origin, name=name, plot_legend=no_legend)
        if kind == "trend":
            return rrb.TimeSeriesView(origin=origin, name=name, plot_legend=trend_legend)
        return rrb.TextDocumentView(origin=origin, name=name)

    columns = []
    for loc in locations:
        groups: dict[str, list] = {}
        for group, name, kind, origin in _views(loc, quantities):
            groups.setdefault(group, []).append(make(kind, name, origin))
        L = loc.upper()
        parts = [rrb.Tabs(*groups["waveforms"], name=f"{L} waveforms"),
                 rrb.Tabs(*groups["spectra"], name=f"{L} spectra"),
                 rrb.Tabs(*groups["trends"], name=f"{L} trends"),
                 groups["health"][0]]
        columns.append(rrb.Vertical(*parts, row_shares=[3, 3.2, 3.6, 2], name=L))
    machine = rrb.Horizontal(
        rrb.TimeSeriesView(origin="/speed", name="shaft speed [Hz]", plot_legend=trend_legend),
        rrb.TimeSeriesView(origin="/fault_frequencies", name="fault frequencies [Hz]", plot_legend=legend),
        name="machine")
    return rrb.Blueprint(
        rrb.Vertical(rrb.Horizontal(*columns), machine, row_shares=[10.8, 3.2]),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state="following"),
        collapse_panels=True)
