"""Stream bkabem messages to the Rerun viewer or into an ``.rrd`` file (rerun-sdk 0.41).

The messages are SI; the viewer shows engineers' units, named in every series and view
(:data:`bkabem_ros.viewer.blueprint.DISPLAY_UNITS`: m/s², µm, mm/s). Everything is on the
``sample_time`` duration timeline, seconds since the first stamp the logger saw
(:attr:`RerunLogger.t0_ns`). Entities, ``<loc>`` = ``de`` / ``nde``:

=============================================  ================================================
``/<loc>/<quantity>``                          every sample: one row per sample, one float32 per
                                               channel (vertical, horizontal) in the component
                                               ``VibrationWaveform:samples``, min/max aggregation;
                                               ``send_columns`` per 0.5 s
``/<loc>/overview/<quantity>``                 per block: max and min per channel (not for
                                               displacement), the whole-run overview
``/<loc>/overview/<quantity>/rms``             per block: RMS per channel
``/<loc>/trend/displacement``                  per block: peak-to-peak per channel [µm]
``/<loc>/iso_velocity``                        per condition window (1 s): ISO 10816/20816
                                               velocity RMS 10-1000 Hz per channel [mm/s]
``/<loc>/iso_velocity/zones``                  the zone limits A/B, B/C, C/D [mm/s]
``/<loc>/trend/impulsiveness``                 per window: kurtosis and crest factor [-]
``/<loc>/trend/ground_truth/<place>_depth``     per fault-frequency message: the depth [µm] of the defect
                                               at ``<place>`` (its kind's: ``outer_race``, ``inner_race``,
                                               ``ball_3``), series "DE outer race depth [µm]"; a second
                                               defect at the same place adds its name
``/<loc>/trend/ground_truth/no_defect``         0 [µm] while the bearing has had no defect (not an empty plot)
``/<loc>/envelope/<channel>``                  per window: envelope spectrum (``BarChart``, Hz)
``/<loc>/spectrum/<quantity>/<channel>``       order spectrum of the model, lines k >= 1
``/<loc>/{envelope,spectrum/<q>}/markers/<L>`` fault-frequency markers, one entity per line L
``/<loc>/health``                              ``TextDocument``: zone, impulsiveness, envelope
                                               finding, static displacement, ground truth
``/speed/shaft_hz``, ``/speed/shaft_hz_waveform``  shaft speed input / used per chunk [Hz]
``/fault_frequencies``                         1x, FTF, BPFO, BPFI, BSF, 2xBSF [Hz] (of the DE bearing)
``/fault_frequencies/nde``                     the same of the NDE bearing, when it is another bearing
=============================================  ================================================

The condition window (:mod:`bkabem_core.analysis.condition`) collects the acceleration of each bearing
for ``condition_window_s`` and logs its results at the window's end. Markers come from the
defects and fault-frequency lines of the recording (:mod:`bkabem_core.analysis.fault_lines`): each
bearing's panels mark its own bearing's lines (a bearing of its own at each position, bkabem_msgs 0.3.0).

Nothing here listens on a port: :class:`RerunLogger` either writes a file or connects to a
viewer (default ``rerun+http://127.0.0.1:9876/proxy``, i.e. ``rerun`` started on this machine,
which binds 127.0.0.1 when started as ``rerun --bind 127.0.0.1``).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np

from bkabem_core.analysis import condition, fault_lines, health
from bkabem_ros.messages import convert as msgs
from bkabem_ros.viewer.blueprint import DEFAULT_CONNECT_URL, DISPLAY_UNITS, TIMELINE, blueprint
from bkabem_ros.viewer.rrd import optimize_rrd, rerun_binary

__all__ = ["DEFAULT_CONNECT_URL", "TIMELINE", "RerunLogger", "RerunSink", "blueprint", "rerun_binary"]

_CHANNEL_COLORS = {"vertical": (31, 119, 180), "horizontal": (255, 127, 14)}
_LIGHT_COLORS = {"vertical": (150, 200, 240), "horizontal": (255, 200, 140)}
_FALLBACK_COLORS = [(44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75)]
_ZONE_COLORS = [(120, 200, 80), (240, 200, 40), (230, 60, 50)]
_SPEED_COLOR = (255, 190, 90)          # light amber: visible on the dark theme
_SPEED_WAVEFORM_COLOR = (120, 180, 255)
NO_DEFECT_COLOR = _ZONE_COLORS[0]       # the ground-truth trend of a bearing without a defect: zone A's green
#: Order-spectrum lines below this fraction of the largest, past the last one above, are not drawn.
LINE_DISPLAY_FLOOR = 0.01
#: Scalar rows (trends, speed) are sent in column chunks of this much sample time [s].
SCALAR_BATCH_S = 1.0
#: Component holding the waveform samples (float32, one per channel and row).
SAMPLES_COMPONENT = "VibrationWaveform:samples"
#: Waveform samples are sent in column chunks of this much sample time [s] (the live viewer
#: shows them up to that much later; fewer, larger chunks cost less per sample: 0.1 s chunks
#: cost ~25 % more).
WAVEFORM_BATCH_S = 0.5
#: Bars per channel of an envelope spectrum (peak hold over groups of bins beyond that): a bar
#: narrower than a pixel is not drawn.
ENVELOPE_BARS = 200
#: Markers are bars below the zero line (so they never hide a line), this fraction of the
#: spectrum's top deep and this fraction of the shown range wide.
MARKER_DEPTH = 0.12
MARKER_WIDTH = 0.008
#: Marker bars are re-logged when a frequency moves by more than this fraction or the height
#: (the spectrum's top) by more than 15 %: in a steady state they cost nothing.
_MARKER_TOLERANCE = 0.003


def _peak_hold(f: np.ndarray, amp: np.ndarray, bars: int) -> tuple[np.ndarray, np.ndarray, int]:
    """At most ``bars`` bars: groups of adjacent bins, each bar the largest amplitude of its group
    (so no line loses height) at the group's centre. Returns (freq, amp, bins per group)."""
    g = max(1, math.ceil(f.size / bars))
    if g == 1:
        return f, amp, 1
    m = f.size // g * g
    fg = f[:m].reshape(-1, g).mean(axis=1)
    ag = amp[:, :m].reshape(amp.shape[0], -1, g).max(axis=2)
    return fg, ag, g


def _slug(text: str) -> str:
    """An entity-path part: letters and digits, the rest as ``_`` ("ball 3" -> "ball_3")."""
    return "".join(ch if ch.isalnum() else "_" for ch in text).strip("_") or "defect"


def _display(quantity: str, unit: str) -> tuple[str, float]:
    """(unit shown, factor) for data in ``unit``: SI is converted, anything else shown as is."""
    if unit == msgs.SI_UNITS.get(quantity) and quantity in DISPLAY_UNITS:
        return DISPLAY_UNITS[quantity]
    return unit, 1.0


class _Window:
    """Acceleration of one bearing collected for the condition window."""

    def __init__(self):
        self.blocks: list[np.ndarray] = []
        self.n = 0
        self.fs = 0.0
        self.next_index: int | None = None
        self.names: list[str] = []
        self.speeds: list[float] = []

    def reset(self) -> None:
        self.blocks, self.n, self.speeds = [], 0, []


def _bar_width(f: np.ndarray, bpfo: float) -> float:
    """Width [Hz] of a line's bar: 0.35 x BPFO for BPFO orders, less where lines are closer (the sidebands of an
    inner race at f_r, of a ball at FTF): 0.7 x the spacing that a tenth of the neighbours are closer than, so that
    bars do not cover their neighbours."""
    if f.size < 2:
        return 0.35 * bpfo if bpfo > 0 else 1.0
    gaps = np.diff(np.sort(f))
    gaps = gaps[gaps > 1e-9 * max(float(f.max()), 1.0)]
    spacing = float(np.percentile(gaps, 10)) if gaps.size else float(f.max())
    return float(min(0.35 * bpfo if bpfo > 0 else np.inf, 0.7 * spacing))


class RerunLogger:
    """Log bkabem messages into one Rerun recording (a file, a viewer, or both).

    Parameters
    ----------
    app_id : str
        Rerun application id (recordings with the same id share blueprints in the viewer).
    recording_id : str, optional
        Rerun recording id (default: random).
    save_path : str or Path, optional
        Write an ``.rrd`` file (with footer after :meth:`close`, so ``rerun rrd verify`` passes).
    connect_url : str, optional
        Stream to a viewer's gRPC proxy, e.g. :data:`DEFAULT_CONNECT_URL`.
    with_blueprint : bool
        Send :func:`blueprint` as the default layout.
    max_spectrum_rate_hz : float
        Order spectra per second (sample time) logged per location and quantity; the node sends
        one per chunk while the speed changes. 0: all.
    condition_window_s : float
        Length of the acceleration window for ISO velocity, kurtosis, crest factor and the
        envelope spectrum [s] (1 s: 1 Hz envelope resolution).
    envelope_band_hz : (float, float), optional
        Envelope band-pass [Hz]; default :func:`bkabem_core.analysis.condition.default_envelope_band`
        (1 kHz to min(10 kHz, 0.4 fs)).
    iso_zones : str
        Key of :data:`bkabem_core.analysis.condition.ISO_ZONE_SETS` for the zone limits.
    optimize : bool
        After :meth:`close`, compact the ``.rrd``'s chunks (``rerun rrd optimize``: ~7x fewer,
        larger chunks, a few % smaller; ~35 ms of CPU per recorded second at 51.2 kHz x 8
        channels, so off for a long-running node; ``bkabem replay --rerun-save`` and the demo
        turn it on).

    Without ``save_path`` and ``connect_url`` the data is kept in memory (tests).
    """

    def __init__(self, app_id: str = "bkabem", recording_id: str | None = None, save_path=None,
                 connect_url: str | None = None, *, with_blueprint: bool = True,
                 max_spectrum_rate_hz: float = 2.0, condition_window_s: float = 1.0,
                 envelope_band_hz: tuple[float, float] | None = None,
                 iso_zones: str = condition.DEFAULT_ISO_ZONES, optimize: bool = False):
        import rerun as rr  # noqa: PLC0415

        if iso_zones not in condition.ISO_ZONE_SETS:
            raise ValueError(f"iso_zones: {iso_zones!r} is not one of {', '.join(condition.ISO_ZONE_SETS)}")
        if not condition_window_s > 0:
            raise ValueError(f"condition_window_s: {condition_window_s} must be > 0")
        self._rr = rr
        self.rec = rr.RecordingStream(app_id, recording_id=recording_id)
        # one timeline only: the data's own time (log_time would be the conversion's wall clock)
        self.rec.set_log_time_enabled(False)
        self.rec.set_log_tick_enabled(False)
        self.save_path = str(save_path) if save_path is not None else None
        self.connect_url = connect_url
        bp = blueprint() if with_blueprint else None
        sinks = []
        if save_path is not None:
            sinks.append(rr.FileSink(str(save_path)))
        if connect_url is not None:
            sinks.append(rr.GrpcSink(connect_url))
        self.memory = None
        if len(sinks) == 1 and save_path is not None:
            self.rec.save(str(save_path), default_blueprint=bp)
        elif len(sinks) == 1:
            self.rec.connect_grpc(connect_url, default_blueprint=bp)
        elif sinks:
            self.rec.set_sinks(*sinks, default_blueprint=bp)
        else:
            self.memory = self.rec.memory_recording()
            if bp is not None:
                self.rec.send_blueprint(bp)
        self.t0_ns: int | None = None
        self.max_spectrum_rate_hz = float(max_spectrum_rate_hz)
        self.condition_window_s = float(condition_window_s)
        self.envelope_band_hz = envelope_band_hz
        self.iso_zones = iso_zones
        self.optimize = bool(optimize)
        self.optimize_error: str | None = None
        self.samples_logged = 0
        self.closed = False
        self._static_done: set[str] = set()
        self._lock = threading.Lock()
        self._speed_stream: tuple[str, str] | None = None
        self._last_spectrum: dict[tuple[str, str], int] = {}
        self._markers: dict[str, tuple[tuple[float, ...], float]] = {}
        self._windows: dict[str, _Window] = {}
        # the run's fault-frequency lines at the speed `_lines_speed` [rad/s] (the DE bearing's, and each bearing's),
        # and its defects
        self._lines: dict[str, float] = {}
        self._bearing_lines: dict[str, dict[str, float]] = {}
        self._lines_speed = 0.0
        self._defects: list[fault_lines.Defect] = []
        self._truth: fault_lines.Truth | None = None
        self._truth_paths: dict[str, fault_lines.Defect] = {}     # ground-truth trend: path -> defect, once seen
        self._truth_keys: dict[tuple, str] = {}                   # (bearing, kind, ball, name) -> its trend path
        self._truth_names: dict[str, str] = {}                    # trend path -> series name
        self._health: dict[str, dict] = {}
        self._rows: dict[str, tuple[list[int], list[np.ndarray]]] = {}
        self._waves: dict[str, dict] = {}
        self._offsets: dict[tuple[int, float], np.ndarray] = {}
        self._bar_keys: dict[str, tuple] = {}

    # ---------------------------------------------------------------- time and style
    def _rel_ns(self, stamp_ns: int) -> int:
        if self.t0_ns is None:
            self.t0_ns = int(stamp_ns)
        return int(stamp_ns) - self.t0_ns

    def _at(self, stamp_ns: int) -> None:
        self.rec.set_time(TIMELINE, duration=np.timedelta64(self._rel_ns(stamp_ns), "ns"))

    def _series(self, path: str, names, colors, *, minmax: bool = False, widths=None) -> None:
        """Static series style of ``path``: one name and colour per scalar of its rows."""
        if path in self._static_done:
            return
        kwargs = {"names": list(names), "colors": list(colors)}
        if minmax:
            kwargs["aggregation_policy"] = "minmax"
        if widths is not None:
            kwargs["widths"] = list(widths)
        self.rec.log(path, self._rr.SeriesLines(**kwargs), static=True)
        self._static_done.add(path)

    def _scalars(self, path: str, values, stamp_ns: int, *, batch: bool = True) -> None:
        """One row of scalars at ``stamp_ns``. With ``batch`` (streams of 10-50 rows per second:
        block trends, speed) rows are collected per entity and sent as one column chunk per
        ``SCALAR_BATCH_S`` of sample time (one ``rr.log`` per row costs ~0.1 ms; the viewer sees
        those trends that much later); rare rows are logged at once."""
        if not batch:
            self._at(stamp_ns)
            self.rec.log(path, self._rr.Scalars(np.asarray(values, dtype=np.float64)))
            return
        rel = self._rel_ns(stamp_ns)
        buf = self._rows.get(path)
        if buf is None:
            buf = self._rows[path] = ([], [])
        buf[0].append(rel)
        buf[1].append(np.asarray(values, dtype=np.float64).reshape(-1))
        if rel - buf[0][0] >= SCALAR_BATCH_S * 1e9:
            self._send_rows(path)

    def _send_rows(self, path: str) -> None:
        times, rows = self._rows.pop(path, ([], []))
        if not times:
            return
        rr = self._rr
        self.rec.send_columns(path, indexes=[rr.TimeColumn(TIMELINE, duration=np.asarray(times, dtype="timedelta64[ns]"))],
                              columns=rr.Scalars.columns(scalars=np.vstack(rows)))

    def _samples(self, path: str, times_ns: np.ndarray, x: np.ndarray, fs: float) -> None:
        """Waveform rows (one per sample, one float32 per channel) of ``path``, collected while
        they follow each other and sent as one column chunk per ``WAVEFORM_BATCH_S``."""
        buf = self._waves.get(path)
        if buf is not None and (buf["next"] != times_ns[0] or buf["x"][0].shape[1] != x.shape[1]):
            self._send_samples(path)                    # a gap or another layout: send what is there
            buf = None
        if buf is None:
            buf = self._waves[path] = {"t": [], "x": [], "n": 0}
        buf["t"].append(times_ns)
        buf["x"].append(x)
        buf["n"] += x.shape[0]
        buf["next"] = int(times_ns[-1]) + int(round(1e9 / fs))
        if buf["n"] >= WAVEFORM_BATCH_S * fs:
            self._send_samples(path)

    def _send_samples(self, path: str) -> None:
        buf = self._waves.pop(path, None)
        if not buf or not buf["n"]:
            return
        import pyarrow as pa  # noqa: PLC0415  (comes with rerun-sdk)

        rr = self._rr
        t = np.concatenate(buf["t"]) if len(buf["t"]) > 1 else buf["t"][0]
        x = np.concatenate(buf["x"]) if len(buf["x"]) > 1 else buf["x"][0]
        # float32, the message's own precision, in a component of our own (Rerun's Scalars are
        # float64 by definition; the time-series view plots any numeric component and applies
        # the entity's SeriesLines): 8 instead of 16 bytes per row for two channels, a third
        # less CPU in the file encoder
        col = rr.ComponentColumn(SAMPLES_COMPONENT, rr.AnyBatchValue(SAMPLES_COMPONENT, pa.array(x.reshape(-1))),
                                 lengths=np.full(x.shape[0], x.shape[1], dtype=np.int32))
        self.rec.send_columns(path, indexes=[rr.TimeColumn(TIMELINE, duration=t.view("timedelta64[ns]"))],
                              columns=[col])

    def flush_rows(self) -> None:
        """Send every collected waveform sample and scalar row now (done by :meth:`close`)."""
        with self._lock:
            for path in list(self._waves):
                self._send_samples(path)
            for path in list(self._rows):
                self._send_rows(path)

    def _bars(self, path: str, values, abscissa, widths, color) -> None:
        """Log a bar chart at the current time: nothing if it is the one logged last, and
        abscissa, widths and colour only when they changed (latest-at keeps them; converting
        each costs ~0.3-0.5 ms)."""
        rr = self._rr
        abscissa = np.asarray(abscissa, dtype=np.float64)
        widths = np.asarray(widths, dtype=np.float32)
        values = np.asarray(values, dtype=np.float64)
        old = self._bar_keys.get(path)
        if old is not None and old[2] == color and np.array_equal(old[0], abscissa) and np.array_equal(old[1], widths):
            if not np.array_equal(old[3], values):    # the same chart again (steady speed): nothing to log
                self.rec.log(path, rr.BarChart.from_fields(values=values))
                self._bar_keys[path] = (abscissa, widths, color, values)
            return
        self._bar_keys[path] = (abscissa, widths, color, values)
        self.rec.log(path, rr.BarChart(values, abscissa=abscissa, widths=widths, color=color))

    @staticmethod
    def _color(channel: str, c: int, light: bool = False):
        table = _LIGHT_COLORS if light else _CHANNEL_COLORS
        return table.get(channel, _FALLBACK_COLORS[c % len(_FALLBACK_COLORS)])

    def _lines_at(self, speed_rad_s: float, loc: str) -> dict[str, float]:
        """The fault-frequency lines of bearing ``loc`` scaled to ``speed_rad_s`` (they are kinematic:
        proportional to the shaft speed), from the last fault-frequency message."""
        lines = self._bearing_lines.get(loc, self._lines)
        if not lines or not self._lines_speed > 0:
            return dict(lines)
        r = speed_rad_s / self._lines_speed
        return {k: v * r for k, v in lines.items()}

    def _defects_with_lines_of(self, loc: str) -> list:
        return fault_lines.defects_with_lines_of(self._defects, self._bearing_lines, loc)

    # ---------------------------------------------------------------- waveforms
    def log_waveform(self, msg) -> None:
        """``VibrationWaveform``: every sample via ``send_columns`` (one row per sample, one
        scalar per channel), the block's min/max and RMS (displacement: peak-to-peak), and
        the shaft speed at its first sample. Acceleration also feeds the condition window."""
        rr = self._rr
        a = msgs.waveform_array(msg)
        n = a.shape[1]
        if n == 0:
            return
        loc, q = msg.location, msg.quantity
        unit, factor = _display(q, msg.unit)
        stamp = msgs.stamp_to_ns(msg.header)
        names = list(msg.channel_names) or [f"ch{c}" for c in range(a.shape[0])]
        colors = [self._color(ch, c) for c, ch in enumerate(names)]
        L = loc.upper()
        with self._lock:
            rel = self._rel_ns(stamp)
            key = (n, float(msg.sample_rate))
            offs = self._offsets.get(key)
            if offs is None:
                offs = self._offsets[key] = np.round(np.arange(n) * (1e9 / key[1])).astype(np.int64)
            # (n, channels) float32 in the display unit: the message's own precision
            x = np.ascontiguousarray(a.T) if factor == 1.0 else np.ascontiguousarray(a.T * np.float32(factor))
            path = f"/{loc}/{q}"
            self._series(path, [f"{L} {ch} [{unit}]" for ch in names], colors, minmax=True)
            self._samples(path, rel + offs, x, float(msg.sample_rate))
            hi = a.max(axis=1).astype(np.float64) * factor
            lo = a.min(axis=1).astype(np.float64) * factor
            if q == "displacement":
                tr = f"/{loc}/trend/{q}"
                self._series(tr, [f"{ch} peak-to-peak [{unit}]" for ch in names], colors)
                self._scalars(tr, hi - lo, stamp)
            else:                       # the whole-run overview: block min/max and RMS
                ov = f"/{loc}/overview/{q}"
                # a channel's max and min share one name: the viewer gives them one legend entry (6 entries did not
                # fit the row's height, the last ones were cut)
                self._series(ov, [f"{ch} min/max [{unit}]" for ch in names for _m in ("max", "min")],
                             [self._color(ch, c, light=True) for c, ch in enumerate(names) for _ in range(2)],
                             widths=[1.0] * 2 * len(names))
                self._scalars(ov, np.column_stack([hi, lo]).reshape(-1), stamp)
                self._series(f"{ov}/rms", [f"{ch} RMS [{unit}]" for ch in names], colors, widths=[2.5] * len(names))
                self._scalars(f"{ov}/rms", np.sqrt(np.einsum("ij,ij->i", a, a, dtype=np.float64) / n) * factor, stamp)
            self.samples_logged += a.size
            if self._speed_stream is None:
                self._speed_stream = (loc, q)
            if q == "acceleration" and msg.unit == msgs.SI_UNITS[q]:
                self._collect(msg, a, names, stamp)
        if self._speed_stream == (loc, q):   # one stream is enough for the speed trace
            self.log_speed(stamp, float(msg.shaft_speed), source="waveform")

    def _collect(self, msg, a: np.ndarray, names: list[str], stamp: int) -> None:
        """Add a block of acceleration to its bearing's window; at a full window, log the
        condition results at the time of the window's last sample."""
        w = self._windows.setdefault(msg.location, _Window())
        fs = float(msg.sample_rate)
        first = int(msg.first_sample_index)
        if w.fs != fs or w.next_index != first or w.names != names:
            w.reset()                                        # new stream, gap or other layout
            w.fs, w.names = fs, names
        w.next_index = first + a.shape[1]
        w.blocks.append(a)                  # float32 view of the message; the window is float64
        w.n += a.shape[1]
        w.speeds.append(float(msg.shaft_speed))
        need = max(int(round(self.condition_window_s * fs)), 16)
        if w.n < need:
            return
        x = np.concatenate(w.blocks, axis=1)                # float32, SI
        rest = x[:, need:]
        x = x[:, :need]
        speed = float(np.mean(w.speeds))
        w.blocks = [rest] if rest.shape[1] else []
        w.n = rest.shape[1]
        w.speeds = [w.speeds[-1]] if rest.shape[1] else []
        end = stamp + int(round((a.shape[1] - rest.shape[1] - 1) * 1e9 / fs))
        self._log_condition(msg.location, x, fs, names, end, speed)

    def _log_condition(self, loc: str, x: np.ndarray, fs: float, names: list[str], stamp: int,
                       speed_rad_s: float) -> None:
        rr = self._rr
        L = loc.upper()
        colors = [self._color(ch, c) for c, ch in enumerate(names)]
        ws = condition.window_spectrum(x, fs)
        iso = condition.iso_velocity_rms(x, fs, ws=ws)
        kurt = condition.kurtosis(x)
        crest = condition.crest_factor(x)
        band = self.envelope_band_hz or condition.default_envelope_band(fs)
        lines = self._lines_at(speed_rad_s, loc)
        f_top = self._envelope_range(lines, band, loc)
        f, env = condition.envelope_spectrum(x, fs, band, f_top, ws=ws)
        limits = condition.ISO_ZONE_SETS[self.iso_zones]
        self._at(stamp)
        p = f"/{loc}/iso_velocity"
        self._series(p, [f"{L} {ch} [mm/s]" for ch in names], colors, widths=[2.0] * len(names))
        self._scalars(p, iso, stamp, batch=False)
        self._series(f"{p}/zones", [f"zone {z} limit {v:g} mm/s" for z, v in zip(("A/B", "B/C", "C/D"), limits)],
                     _ZONE_COLORS, widths=[1.0] * 3)
        self._scalars(f"{p}/zones", limits, stamp, batch=False)
        p = f"/{loc}/trend/impulsiveness"
        self._series(p, [f"kurtosis {ch}" for ch in names] + [f"crest factor {ch}" for ch in names],
                     colors + [self._color(ch, c, light=True) for c, ch in enumerate(names)])
        self._scalars(p, np.concatenate([kurt, crest]), stamp, batch=False)
        fg, eg, group = _peak_hold(f, env, ENVELOPE_BARS)
        dfg = fg[1] - fg[0] if fg.size > 1 else 1.0
        nch = max(len(names), 1)
        for c, ch in enumerate(names):
            self._bars(f"/{loc}/envelope/{ch}", eg[c], fg + (c - (nch - 1) / 2) * dfg / nch,
                       np.full(fg.size, 0.9 * dfg / nch, dtype=np.float32), colors[c])
        top = float(env.max()) if env.size else 0.0
        self._log_markers(f"/{loc}/envelope/markers", lines, f_top, top, loc)
        h = self._health.setdefault(loc, {})
        h.update(iso=iso, zone=[condition.iso_zone(v, limits) for v in iso], kurt=kurt, crest=crest,
                 rms=np.sqrt(np.mean(x * x, axis=1, dtype=np.float64)), peak=np.max(np.abs(x), axis=1).astype(np.float64),
                 names=names,
                 band=band, window_s=x.shape[1] / fs, env_df=(f[1] - f[0]) if f.size > 1 else 0.0, env_group=group,
                 finding=health.envelope_finding(f, env, lines, names, loc, self._defects,
                                                 {b: self._lines_at(speed_rad_s, b) for b in self._bearing_lines}),
                 speed_hz=speed_rad_s / (2 * math.pi), lines=lines)
        text = health.health_text(loc, self._health.get(loc, {}), self._defects,
                                  self._bearing_lines.get(loc, self._lines), self.iso_zones, self.condition_window_s,
                                  self._truth, marked=self._defects_with_lines_of(loc))
        self.rec.log(f"/{loc}/health", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))

    def _envelope_range(self, lines: dict[str, float], band: tuple[float, float], loc: str) -> float:
        """Envelope spectrum shown up to 3.5x the highest line a defect excites and past every
        fundamental, at most half the band width [Hz]; 500 Hz while no lines are known."""
        cap = (band[1] - band[0]) / 2
        if not lines or not max(lines.values()) > 0:
            return min(500.0, cap)
        excited = [lines[d.line] for d in self._defects_with_lines_of(loc) if d.line in lines] or \
            [lines.get("BPFO", 0.0)]
        want = max(3.5 * max(excited), 1.15 * max(lines.values()))
        return float(min(cap, 50.0 * math.ceil(want / 50.0)))

    # ---------------------------------------------------------------- spectra and markers
    def log_spectrum(self, msg) -> bool:
        """``VibrationSpectrum``: order spectrum bars per channel (lines k >= 1, amplitude in
        display units vs frequency in Hz; the static part k = 0 goes to the health panel) and
        the fault-frequency markers. At most ``max_spectrum_rate_hz`` per location and quantity
        (sample time); returns whether logged."""
        rr = self._rr
        f, k, amp, _ph = msgs.spectrum_arrays(msg)
        if f.size == 0:
            return False
        loc, q = msg.location, msg.quantity
        unit, factor = _display(q, msg.unit)
        stamp = msgs.stamp_to_ns(msg.header)
        last = self._last_spectrum.get((loc, q))
        if (last is not None and self.max_spectrum_rate_hz > 0
                and 0 <= stamp - last < 1e9 / self.max_spectrum_rate_hz):
            return False
        self._last_spectrum[(loc, q)] = stamp
        names = list(msg.channel_names) or [f"ch{c}" for c in range(amp.shape[0])]
        nz = k > 0
        bpfo = float(np.median(f[nz] / k[nz])) if np.any(nz) else 0.0
        lines = self._lines_at(float(msg.shaft_speed), loc) or ({"BPFO": bpfo} if bpfo > 0 else {})
        static = amp[:, ~nz].sum(axis=1) * factor if np.any(~nz) else np.zeros(amp.shape[0])
        fl, al = f[nz], amp[:, nz] * factor
        if al.size:
            big = np.nonzero(al.max(axis=0) >= LINE_DISPLAY_FLOOR * al.max())[0]
            keep = slice(0, int(big[-1]) + 1) if big.size else slice(0, 0)
            fl, al = fl[keep], al[:, keep]
        width = _bar_width(fl, bpfo)
        with self._lock:
            self._at(stamp)
            for c, ch in enumerate(names):
                # every line at its own frequency; the channels' bars nested (each next one narrower), so that
                # each shows and none is drawn off its line
                self._bars(f"/{loc}/spectrum/{q}/{ch}", al[c], fl,
                           np.full(fl.size, width / (1 + c), dtype=np.float32), self._color(ch, c))
            f_top = float(fl[-1]) + width if fl.size else 0.0
            self._log_markers(f"/{loc}/spectrum/{q}/markers", lines, f_top, float(al.max()) if al.size else 0.0,
                              loc)
            h = self._health.setdefault(loc, {})
            h.setdefault("spectra", {})[q] = {
                "unit": unit, "static": static, "names": names, "bpfo": bpfo,
                "orders": (int(k[nz].min()), int(k[nz].max())) if np.any(nz) else (0, 0),
                "shown_to_hz": float(fl[-1]) if fl.size else 0.0,
                "shaft_hz": float(msg.shaft_speed) / (2 * math.pi)}
        return True

    def _log_markers(self, prefix: str, lines: dict[str, float], f_max: float, top: float, loc: str) -> None:
        """One bar-chart entity per fault-frequency line of bearing ``loc`` under ``prefix``: bars at the
        marked harmonics up to ``f_max`` [Hz] (the harmonics of the lines the defects of bearings with
        these lines excite), below the zero line (``MARKER_DEPTH`` x ``top`` deep, so they never cover
        the spectrum's lines)."""
        rr = self._rr
        defects = self._defects_with_lines_of(loc)
        plan = fault_lines.marker_plan(lines, defects, f_max) if f_max > 0 and top > 0 else []
        by_line: dict[str, list[float]] = {}
        for m in plan:
            by_line.setdefault(m.line, []).append(m.frequency_hz)
        width = np.float32(max(MARKER_WIDTH * f_max, 1e-3))
        for name in fault_lines.LINES:
            path = f"{prefix}/{name}"
            freqs = tuple(by_line.get(name, ()))
            height = -MARKER_DEPTH * top
            old = self._markers.get(path)
            if old is not None and len(old[0]) == len(freqs) and (
                    not freqs or (np.all(np.abs(np.subtract(old[0], freqs)) <= _MARKER_TOLERANCE * np.asarray(freqs))
                                  and 0.85 <= height / old[1] <= 1.18)):
                continue
            if old is None and not freqs:
                continue
            self._markers[path] = (freqs, height if freqs else -1.0)
            self._bars(path, np.full(len(freqs), height), np.asarray(freqs, dtype=np.float64),
                       np.full(len(freqs), width, dtype=np.float32), fault_lines.LINE_COLORS[name])

    # ---------------------------------------------------------------- speed, faults, health
    def log_speed(self, stamp_ns: int, speed_rad_s: float, *, source: str = "speed") -> None:
        """Shaft speed (rad/s, REP 103) as ``/speed/shaft_hz`` [Hz]. Waveforms also carry the
        speed at their first sample; those (of one stream) go to ``/speed/shaft_hz_waveform``."""
        path = "/speed/shaft_hz" if source == "speed" else f"/speed/shaft_hz_{source}"
        label = "shaft speed [Hz]" if source == "speed" else f"shaft speed used by the {source}s [Hz]"
        with self._lock:
            self._series(path, [label], [_SPEED_COLOR if source == "speed" else _SPEED_WAVEFORM_COLOR],
                         widths=[2.0 if source == "speed" else 1.0])
            self._scalars(path, [speed_rad_s / (2 * math.pi)], stamp_ns)

    def log_fault_frequencies(self, msg) -> None:
        """``BearingFaultFrequencies``: the lines (1x, FTF, BPFO, BPFI, BSF, 2xBSF [Hz]) in the
        marker colours, and the run's ground truth (every defect, the machine's state) for
        markers, health panels and the ground-truth trend (defect depths over the run)."""
        per = fault_lines.bearing_line_frequencies(msg)
        lines = per["de"]
        truth = fault_lines.truth_from_message(msg)
        stamp = msgs.stamp_to_ns(msg.header)
        with self._lock:
            self._series("/fault_frequencies", [f"{name} [Hz]" for name in fault_lines.LINES],
                         [fault_lines.LINE_COLORS[name] for name in fault_lines.LINES])
            self._scalars("/fault_frequencies", [lines[name] for name in fault_lines.LINES], stamp, batch=False)
            if per.get("nde", lines) != lines:            # another bearing at the NDE: its own lines
                self._series("/fault_frequencies/nde", [f"NDE {name} [Hz]" for name in fault_lines.LINES],
                             [fault_lines.LINE_COLORS[name] for name in fault_lines.LINES], widths=[1.0] * 6)
                self._scalars("/fault_frequencies/nde", [per["nde"][name] for name in fault_lines.LINES], stamp,
                              batch=False)
            self._lines, self._lines_speed = lines, float(msg.shaft_speed)
            self._bearing_lines = per
            self._defects = list(truth.defects)
            self._truth = truth
            self._log_truth_trend(truth, stamp)

    def _log_truth_trend(self, truth: "fault_lines.Truth", stamp: int) -> None:
        """``/<loc>/trend/ground_truth/<place>_depth``: the depth [µm] of every defect of the run (from
        the fault-frequency messages; a defect that disappears is logged as 0)."""
        if not truth.available:
            return
        seen = self._truth_paths
        now = {}
        for d in truth.defects:
            now[self._truth_path(d)] = d
        for path, d in now.items():
            seen.setdefault(path, d)
        for path, d in seen.items():
            cur = now.get(path)
            self._series(path, [self._truth_names[path]],
                         [fault_lines.LINE_COLORS[d.line]], widths=[2.0])
            self._scalars(path, [cur.depth_m * 1e6 if cur is not None else 0.0], stamp)
        for loc in ("de", "nde"):           # a bearing without a defect (yet): a 0 line says so, not an empty plot
            if any(path.startswith(f"/{loc}/trend/ground_truth/") for path in seen):
                continue
            path = f"/{loc}/trend/ground_truth/no_defect"
            self._series(path, ["no defect in this bearing [µm]"], [NO_DEFECT_COLOR], widths=[2.0])
            self._scalars(path, [0.0], stamp)

    def _truth_path(self, d: "fault_lines.Defect") -> str:
        """The ground-truth trend entity of a defect, fixed for the run at its first sight: named by bearing and place
        (``/de/trend/ground_truth/outer_race_depth``, series "DE outer race depth [µm]"); a second defect at the same
        place of the same bearing adds its scenario name (``..._<name>_depth``, "DE outer race (spall 2) depth
        [µm]"; square brackets are for units: a case's "defects[1]" shows as "defects 1")."""
        key = (d.bearing, d.kind, d.ball, d.name)
        path = self._truth_keys.get(key)
        if path is not None:
            return path
        place = fault_lines.defect_place(d)
        path = f"/{d.bearing}/trend/ground_truth/{_slug(place)}_depth"
        name = f"{d.bearing.upper()} {place} depth [µm]"
        if path in self._truth_names:
            label = (d.name or d.kind).replace("[", " ").replace("]", "").strip()
            path = f"/{d.bearing}/trend/ground_truth/{_slug(place)}_{_slug(label)}_depth"
            name = f"{d.bearing.upper()} {place} ({label}) depth [µm]"
        self._truth_keys[key] = path
        self._truth_names[path] = name
        return path

    def log_features(self, location: str, stamp_ns: int, features: Mapping[str, float]) -> None:
        """Extra per-chunk scalars, e.g. ``{"oil_temperature_C": 61.0}``, under
        ``/<location>/features/<name>``; put the unit in the key, it becomes the series name."""
        with self._lock:
            for name, value in features.items():
                path = f"/{location}/features/{name}"
                self._series(path, [f"{location.upper()} {name}"], [_FALLBACK_COLORS[0]])
                self._scalars(path, [float(value)], stamp_ns, batch=False)

    def log_message(self, topic: str, type_name, msg, stamp_ns: int | None = None) -> bool:
        """Dispatch by type: waveform, spectrum, fault frequencies; ``std_msgs/Float64`` on a
        topic ending in ``speed`` is the shaft speed (rad/s) at ``stamp_ns``. Returns whether
        the message was logged."""
        name = msgs.type_name(type_name).rsplit("/", 1)[-1]
        if name == "VibrationWaveform":
            self.log_waveform(msg)
        elif name == "VibrationSpectrum":
            self.log_spectrum(msg)
        elif name == "BearingFaultFrequencies":
            self.log_fault_frequencies(msg)
        elif name == "Float64" and topic.rstrip("/").endswith("speed") and stamp_ns is not None:
            self.log_speed(stamp_ns, float(msg.data))
        else:
            return False
        return True

    def close(self) -> None:
        """Flush and disconnect (writes the ``.rrd`` footer); then, for a file with ``optimize``,
        compact its chunks (:func:`optimize_rrd`). Idempotent."""
        if self.closed:
            return
        self.closed = True
        try:
            self.flush_rows()
            self.rec.flush()
        finally:
            self.rec.disconnect()
        if self.save_path is not None and self.optimize:
            self.optimize_error = optimize_rrd(self.save_path)


class RerunSink:
    """Node sink ``callable(topic, msg_type_name, msg, stamp_ns)`` feeding a :class:`RerunLogger`.

    ``speed_scale``: factor from the speed topic's unit to rad/s (1 for rad/s, 2*pi for Hz,
    2*pi/60 for rpm), or a callable returning it (the node's live ``speed_unit``). With
    ``threaded`` (default) the logging runs in a worker thread, so the node's executor only
    queues the message (the node does not modify messages after publishing them); at most
    ``max_queue`` messages wait, more are dropped and counted in :attr:`dropped`. Errors in the
    logger are reported once through ``log_error`` and switch the sink off.
    """

    def __init__(self, logger: RerunLogger, *, speed_scale=1.0, log_error=None, threaded: bool = True,
                 max_queue: int = 5000):
        import queue  # noqa: PLC0415

        self.logger = logger
        self.speed_scale = speed_scale
        self.log_error = log_error
        self.error: Exception | None = None
        self.dropped = 0
        self._queue = queue.Queue(maxsize=max_queue) if threaded else None
        self._thread = None
        if threaded:
            self._thread = threading.Thread(target=self._worker, name="rerun-sink", daemon=True)
            self._thread.start()

    def __call__(self, topic: str, msg_type_name, msg, stamp_ns: int | None = None) -> None:
        if self.error is not None:
            return
        scale = None
        if str(msg_type_name).endswith("Float64"):
            scale = self.speed_scale() if callable(self.speed_scale) else self.speed_scale
        item = (topic, msg_type_name, msg, stamp_ns, scale)
        if self._queue is None:
            self._log(item)
            return
        try:
            self._queue.put_nowait(item)
        except Exception:  # noqa: BLE001 - queue.Full: the viewer/file does not keep up
            self.dropped += 1

    def _worker(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self.error is None:
                self._log(item)

    def _log(self, item) -> None:
        topic, msg_type_name, msg, stamp_ns, scale = item
        try:
            if isinstance(msg, (bytes, bytearray, memoryview)):
                from rclpy.serialization import deserialize_message  # noqa: PLC0415

                from bkabem_ros.recording.mcap_io import message_class  # noqa: PLC0415

                msg = deserialize_message(bytes(msg), message_class(msg_type_name))
            name = msgs.type_name(msg_type_name)
            if name == "std_msgs/msg/Float64" and stamp_ns is not None:
                if topic.rstrip("/").endswith("speed"):
                    self.logger.log_speed(stamp_ns, float(msg.data) * float(1.0 if scale is None else scale))
                return
            self.logger.log_message(topic, name, msg, stamp_ns)
        except Exception as exc:  # noqa: BLE001 - never break the node's publishing
            self.error = exc
            if self.log_error is not None:
                self.log_error(f"Rerun logging stopped: {type(exc).__name__}: {exc}")

    def flush(self) -> None:
        """Wait until everything queued so far is logged, and send what the logger collects."""
        if self._thread is not None:
            import time as _time  # noqa: PLC0415

            while not self._queue.empty():
                _time.sleep(0.005)
        self.logger.flush_rows()

    def close(self) -> None:
        """Log what is queued, then close the logger (footer of the .rrd). Idempotent."""
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join()
            self._thread = None
        self.logger.close()
