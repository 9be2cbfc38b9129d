"""The default Rerun layout of a bkabem recording, and the units the viewer shows (rerun-sdk 0.41).

The recording on ROS 2 / MCAP is SI. The viewer shows engineers' units, named in every view and
series: acceleration m/s², displacement µm (as a proximity probe is read), velocity mm/s
(:data:`DISPLAY_UNITS`). :mod:`bkabem_ros.viewer.rerun_io` scales on logging.

Layout (:func:`blueprint`), DE left, NDE right, each column (at most :data:`MAX_TABS` tabs per
row, so that every tab title shows in full and the title in white is the plot below it):

1. waveforms (tabs per quantity): the last ``window_s`` (1 s) before the time cursor, every
   sample, min/max aggregated when zoomed out, so impact peaks keep their height;
2. spectra (tabs; abscissa in Hz): envelope spectrum of the band-passed acceleration, the
   model's line spectra (orders of BPFO: acceleration, displacement), fault-frequency markers;
3. condition trends over the whole run (tabs): ISO velocity RMS with the zone limits, kurtosis
   and crest factor;
4. ground truth and levels over the whole run (tabs): the ground truth's defect depths (first:
   a scenario's growing defects; a 0 "no defect" line for a healthy bearing), the acceleration
   per block (min/max envelope and RMS: the overview that loads fast, ten points per second),
   displacement peak-to-peak;
and across the bottom, in three equal parts: the DE and NDE health panels (ISO zone, the ground
truth of this bearing, what the envelope spectrum shows and whose line it is, the other bearing's
defects, the machine) and the machine's tabs: fault frequencies (1x, FTF, BPFO, BPFI, BSF, 2xBSF:
the marker key) and shaft speed over the whole run. The bottom row is as tall as the fault-frequency
legend's six entries need at 1600 x 900 (every legend entry of every view shows whole at 1920 x 1080
and 1600 x 900: ``HeadlessViewer.legend_problems``, tests/integration/test_rerun_viewer.py). The recording opens
following its latest data (the end of a file), paused there once the user scrubs, so every view has
data from the start.
"""

from __future__ import annotations

__all__ = ["DEFAULT_CONNECT_URL", "DISPLAY_UNITS", "MAX_TABS", "TAB_BAR_END_PX", "TIMELINE", "blueprint", "legend_views", "tab_row_width_px",
           "tab_rows", "view_names"]

TIMELINE = "sample_time"
#: A viewer on this machine (``rerun --bind 127.0.0.1``): its gRPC proxy.
DEFAULT_CONNECT_URL = "rerun+http://127.0.0.1:9876/proxy"

#: quantity -> (unit shown, factor from SI).
DISPLAY_UNITS = {
    "acceleration": ("m/s²", 1.0),
    "velocity": ("mm/s", 1e3),
    "displacement": ("µm", 1e6),
}

_WAVEFORM_WINDOW_S = 1.0

#: The tab rows of a bearing's column, top to bottom (its health panel goes to the bottom row).
_TAB_GROUPS = ("waveforms", "spectra", "condition", "levels")
#: Heights of the column's rows (the condition row tall enough for the ISO legend's five entries, the levels row for
#: the four of the acceleration per block, at 900 px).
_ROW_SHARES = (1.9, 2.0, 3.4, 3.0)
#: Height of the bottom row (health panels, fault frequencies: the legend's six entries) against the columns' rows.
_BOTTOM_SHARE = 4.2
#: The machine's views (bottom right, tabs): fault frequencies first (its legend is the marker key), shaft speed.
MACHINE_VIEWS = (("fault frequencies [Hz]", "/fault_frequencies"), ("shaft speed [Hz]", "/speed"))
#: At most this many views share a tab row: with the titles of :func:`_views`, every title of a row is
#: visible in a bearing's column at the screenshot window size (1920 x 1080: half the window per column) and
#: down to a 1600 px wide window. Spectra have their abscissa in Hz, trends in time.
MAX_TABS = 3
#: Width of a tab title in the viewer at 1 pixel per point (rerun 0.41, Inter 12.5 pt), measured on
#: the screenshots: ~6.2 px per character (6.6 with margin), a 14-px icon and 6 px before the text, 18 px
#: between tabs; the help, visibility and maximise icons and the overflow arrow take the last 110 px.
TITLE_PX_PER_CHAR = 6.6
TAB_ICON_PX, TAB_GAP_PX, TAB_BAR_END_PX = 20, 18, 110


def tab_row_width_px(names) -> float:
    """Estimated width [px] of a tab row holding the views ``names`` (see :data:`TITLE_PX_PER_CHAR`)."""
    return sum(TAB_ICON_PX + TITLE_PX_PER_CHAR * len(n) for n in names) + TAB_GAP_PX * (len(names) - 1)


def _views(loc: str, quantities):
    """(group, name, kind, origin) of one bearing's views, in layout order. Each group is one row of the
    bearing's column: a tab row (:data:`MAX_TABS` at most) or, for the health panel, a single view."""
    L = loc.upper()
    out = []
    for q in quantities:
        unit = DISPLAY_UNITS[q][0]
        out.append(("waveforms", f"{L} {q} [{unit}]", "wave", f"/{loc}/{q}"))
    out.append(("spectra", f"{L} envelope spectrum [m/s²]", "bars", f"/{loc}/envelope"))
    for q in quantities:
        unit = DISPLAY_UNITS[q][0]
        out.append(("spectra", f"{L} spectrum: {q} [{unit}]", "bars", f"/{loc}/spectrum/{q}"))
    out.append(("condition", f"{L} ISO velocity RMS 10-1000 Hz [mm/s]", "trend", f"/{loc}/iso_velocity"))
    out.append(("condition", f"{L} kurtosis and crest factor [-]", "trend", f"/{loc}/trend/impulsiveness"))
    out.append(("levels", f"{L} ground truth: depth [µm]", "trend", f"/{loc}/trend/ground_truth"))
    out.append(("levels", f"{L} acceleration per block [m/s²]", "trend", f"/{loc}/overview/acceleration"))
    if "displacement" in quantities:
        out.append(("levels", f"{L} displacement p-p [µm]", "trend", f"/{loc}/trend/displacement"))
    out.append(("health", f"{L} health", "text", f"/{loc}/health"))
    return out


def tab_rows(locations=("de", "nde"), quantities=("acceleration", "displacement")) -> list[list[str]]:
    """The view names of every tab row of :func:`blueprint`, in layout order (tests check that each fits)."""
    rows = []
    for loc in locations:
        groups: dict[str, list[str]] = {}
        for group, name, _kind, _origin in _views(loc, quantities):
            groups.setdefault(group, []).append(name)
        rows += [names for group, names in groups.items() if group in _TAB_GROUPS]
    return rows + [[name for name, _origin in MACHINE_VIEWS]]


def view_names(locations=("de", "nde"), quantities=("acceleration", "displacement")) -> list[str]:
    """Names of every view :func:`blueprint` makes (tests check the viewer shows each)."""
    names = [v[1] for loc in locations for v in _views(loc, quantities)]
    return names + [name for name, _origin in MACHINE_VIEWS]


def legend_views(locations=("de", "nde"), quantities=("acceleration", "displacement")) -> dict[str, str]:
    """{view name: origin} of every view of :func:`blueprint` that shows a plot legend (the time series views;
    the bar charts have none): tests check that every entry of each legend is visible."""
    out = {name: origin for loc in locations for _g, name, kind, origin in _views(loc, quantities)
           if kind in ("wave", "trend")}
    return {**out, **dict(MACHINE_VIEWS)}


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

    columns, panels = [], []
    for loc in locations:
        groups: dict[str, list] = {}
        for group, name, kind, origin in _views(loc, quantities):
            groups.setdefault(group, []).append(make(kind, name, origin))
        L = loc.upper()
        columns.append(rrb.Vertical(*[rrb.Tabs(*groups[g], name=f"{L} {g}") for g in _TAB_GROUPS],
                                    row_shares=list(_ROW_SHARES), name=L))
        panels.append(groups["health"][0])
    legends = {"/fault_frequencies": legend, "/speed": trend_legend}
    machine = rrb.Tabs(*[rrb.TimeSeriesView(origin=origin, name=name, plot_legend=legends[origin])
                         for name, origin in MACHINE_VIEWS], name="machine")
    return rrb.Blueprint(
        rrb.Vertical(rrb.Horizontal(*columns), rrb.Horizontal(*panels, machine, name="health and machine"),
                     row_shares=[sum(_ROW_SHARES), _BOTTOM_SHARE]),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE, play_state="following"),
        collapse_panels=True)
