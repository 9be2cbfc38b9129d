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

The recording's time line and batched rows are :class:`bkabem_ros.viewer.rerun_rows.RecordingRows` (the base of
:class:`RerunLogger`); the condition window and its panels :class:`bkabem_ros.viewer.rerun_condition.ConditionPanels`.

Nothing here listens on a port: :class:`RerunLogger` either writes a file or connects to a
viewer (default ``rerun+http://127.0.0.1:9876/proxy``, i.e. ``rerun`` started on this machine,
which binds 127.0.0.1 when started as ``rerun --bind 127.0.0.1``).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np

from bkabem_core.analysis import condition, fault_lines
from bkabem_ros.messages import convert as msgs
from bkabem_ros.viewer.blueprint import DEFAULT_CONNECT_URL, DISPLAY_UNITS, TIMELINE, blueprint
from bkabem_ros.viewer.rerun_condition import ZONE_COLORS, ConditionPanels
from bkabem_ros.viewer.rerun_rows import SAMPLES_COMPONENT, RecordingRows  # noqa: F401  (SAMPLES_COMPONENT: for readers)
from bkabem_ros.viewer.rrd import optimize_rrd, rerun_binary

__all__ = ["DEFAULT_CONNECT_URL", "TIMELINE", "RerunLogger", "RerunSink", "blueprint", "rerun_binary"]

_CHANNEL_COLORS = {"vertical": (31, 119, 180), "horizontal": (255, 127, 14)}
_LIGHT_COLORS = {"vertical": (150, 200, 240), "horizontal": (255, 200, 140)}
_FALLBACK_COLORS = [(44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75)]
_SPEED_COLOR = (255, 190, 90)          # light amber: visible on the dark theme
_SPEED_WAVEFORM_COLOR = (120, 180, 255)
NO_DEFECT_COLOR = ZONE_COLORS[0]        # the ground-truth trend of a bearing without a defect: zone A's green
#: Order-spectrum lines below this fraction of the largest, past the last one above, are not drawn.
LINE_DISPLAY_FLOOR = 0.01
#: Markers are bars below the zero line (so they never hide a line), this fraction of the
#: spectrum's top deep and this fraction of the shown range wide.
MARKER_DEPTH = 0.12
MARKER_WIDTH = 0.008
#: Marker bars are re-logged when a frequency moves by more than this fraction or the height
#: (the spectrum's top) by more than 15 %: in a steady state they cost nothing.
_MARKER_TOLERANCE = 0.003


def _slug(text: str) -> str:
    """An entity-path part: letters and digits, the rest as ``_`` ("ball 3" -> "ball_3")."""
    return "".join(ch if ch.isalnum() else "_" for ch in text).strip("_") or "defect"


def _display(quantity: str, unit: str) -> tuple[str, float]:
    """(unit shown, factor) for data in ``unit``: SI is converted, anything else shown as is."""
    if unit == msgs.SI_UNITS.get(quantity) and quantity in DISPLAY_UNITS:
        return DISPLAY_UNITS[quantity]
    return unit, 1.0


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


class RerunLogger(RecordingRows):
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

    Attributes
    ----------
    defects : list of bkabem_core.analysis.fault_lines.Defect
        The run's defects, from the last fault-frequency message.
    truth : bkabem_core.analysis.fault_lines.Truth or None
        That message's ground truth.
    bearing_lines : dict
        ``location -> {line name: frequency [Hz]}`` from that message, at its shaft speed (:meth:`lines_at` scales
        them to another).
    health : dict
        ``location -> facts`` the health panel shows (the last spectrum's, the last condition window's), filled by
        the spectra here and by :class:`~bkabem_ros.viewer.rerun_condition.ConditionPanels`.
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
        super().__init__(rr.RecordingStream(app_id, recording_id=recording_id), rr)
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
        self.max_spectrum_rate_hz = float(max_spectrum_rate_hz)
        self.condition_window_s = float(condition_window_s)
        self.envelope_band_hz = envelope_band_hz
        self.iso_zones = iso_zones
        self.optimize = bool(optimize)
        self.optimize_error: str | None = None
        self.samples_logged = 0
        self.closed = False
        self._speed_stream: tuple[str, str] | None = None
        self._last_spectrum: dict[tuple[str, str], int] = {}
        self._markers: dict[str, tuple[tuple[float, ...], float]] = {}
        # the run's fault-frequency lines at the speed `_lines_speed` [rad/s] (the DE bearing's, and each bearing's),
        # and its defects
        self._lines: dict[str, float] = {}
        self.bearing_lines: dict[str, dict[str, float]] = {}
        self._lines_speed = 0.0
        self.defects: list[fault_lines.Defect] = []
        self.truth: fault_lines.Truth | None = None
        self._truth_paths: dict[str, fault_lines.Defect] = {}     # ground-truth trend: path -> defect, once seen
        self._truth_keys: dict[tuple, str] = {}                   # (bearing, kind, ball, name) -> its trend path
        self._truth_names: dict[str, str] = {}                    # trend path -> series name
        self.health: dict[str, dict] = {}
        self._offsets: dict[tuple[int, float], np.ndarray] = {}
        self._condition = ConditionPanels(self)      # the condition window and its panels, per bearing

    # ---------------------------------------------------------------- style and the run's lines
    @staticmethod
    def color(channel: str, c: int, light: bool = False):
        table = _LIGHT_COLORS if light else _CHANNEL_COLORS
        return table.get(channel, _FALLBACK_COLORS[c % len(_FALLBACK_COLORS)])

    def lines_at(self, speed_rad_s: float, loc: str) -> dict[str, float]:
        """The fault-frequency lines of bearing ``loc`` scaled to ``speed_rad_s`` (they are kinematic:
        proportional to the shaft speed), from the last fault-frequency message."""
        lines = self.lines_of(loc)
        if not lines or not self._lines_speed > 0:
            return dict(lines)
        r = speed_rad_s / self._lines_speed
        return {k: v * r for k, v in lines.items()}

    def lines_of(self, loc: str) -> dict[str, float]:
        """The fault-frequency lines of bearing ``loc`` [Hz] as the last fault-frequency message gave them (the DE
        bearing's where the message names no bearing of its own)."""
        return self.bearing_lines.get(loc, self._lines)

    def defects_with_lines_of(self, loc: str) -> list:
        """The run's defects whose lines are marked in bearing ``loc``'s panels."""
        return fault_lines.defects_with_lines_of(self.defects, self.bearing_lines, loc)

    # ---------------------------------------------------------------- waveforms
    def log_waveform(self, msg) -> None:
        """``VibrationWaveform``: every sample via ``send_columns`` (one row per sample, one
        scalar per channel), the block's min/max and RMS (displacement: peak-to-peak), and
        the shaft speed at its first sample. Acceleration also feeds the condition window."""
        a = msgs.waveform_array(msg)
        n = a.shape[1]
        if n == 0:
            return
        loc, q = msg.location, msg.quantity
        unit, factor = _display(q, msg.unit)
        stamp = msgs.stamp_to_ns(msg.header)
        names = list(msg.channel_names) or [f"ch{c}" for c in range(a.shape[0])]
        colors = [self.color(ch, c) for c, ch in enumerate(names)]
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
            self.series(path, [f"{L} {ch} [{unit}]" for ch in names], colors, minmax=True)
            self._samples(path, rel + offs, x, float(msg.sample_rate))
            hi = a.max(axis=1).astype(np.float64) * factor
            lo = a.min(axis=1).astype(np.float64) * factor
            if q == "displacement":
                tr = f"/{loc}/trend/{q}"
                self.series(tr, [f"{ch} peak-to-peak [{unit}]" for ch in names], colors)
                self.scalars(tr, hi - lo, stamp)
            else:                       # the whole-run overview: block min/max and RMS
                ov = f"/{loc}/overview/{q}"
                # a channel's max and min share one name: the viewer gives them one legend entry (6 entries did not
                # fit the row's height, the last ones were cut)
                self.series(ov, [f"{ch} min/max [{unit}]" for ch in names for _m in ("max", "min")],
                            [self.color(ch, c, light=True) for c, ch in enumerate(names) for _ in range(2)],
                            widths=[1.0] * 2 * len(names))
                self.scalars(ov, np.column_stack([hi, lo]).reshape(-1), stamp)
                self.series(f"{ov}/rms", [f"{ch} RMS [{unit}]" for ch in names], colors, widths=[2.5] * len(names))
                self.scalars(f"{ov}/rms", np.sqrt(np.einsum("ij,ij->i", a, a, dtype=np.float64) / n) * factor, stamp)
            self.samples_logged += a.size
            if self._speed_stream is None:
                self._speed_stream = (loc, q)
            if q == "acceleration" and msg.unit == msgs.SI_UNITS[q]:
                self._condition.collect(msg, a, names, stamp)
        if self._speed_stream == (loc, q):   # one stream is enough for the speed trace
            self.log_speed(stamp, float(msg.shaft_speed), source="waveform")

    # ---------------------------------------------------------------- spectra and markers
    def log_spectrum(self, msg) -> bool:
        """``VibrationSpectrum``: order spectrum bars per channel (lines k >= 1, amplitude in
        display units vs frequency in Hz; the static part k = 0 goes to the health panel) and
        the fault-frequency markers. At most ``max_spectrum_rate_hz`` per location and quantity
        (sample time); returns whether logged."""
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
        lines = self.lines_at(float(msg.shaft_speed), loc) or ({"BPFO": bpfo} if bpfo > 0 else {})
        static = amp[:, ~nz].sum(axis=1) * factor if np.any(~nz) else np.zeros(amp.shape[0])
        fl, al = f[nz], amp[:, nz] * factor
        if al.size:
            big = np.nonzero(al.max(axis=0) >= LINE_DISPLAY_FLOOR * al.max())[0]
            keep = slice(0, int(big[-1]) + 1) if big.size else slice(0, 0)
            fl, al = fl[keep], al[:, keep]
        width = _bar_width(fl, bpfo)
        with self._lock:
            self.at(stamp)
            for c, ch in enumerate(names):
                # every line at its own frequency; the channels' bars nested (each next one narrower), so that
                # each shows and none is drawn off its line
                self.bars(f"/{loc}/spectrum/{q}/{ch}", al[c], fl,
                          np.full(fl.size, width / (1 + c), dtype=np.float32), self.color(ch, c))
            f_top = float(fl[-1]) + width if fl.size else 0.0
            self.log_markers(f"/{loc}/spectrum/{q}/markers", lines, f_top, float(al.max()) if al.size else 0.0,
                             loc)
            h = self.health.setdefault(loc, {})
            h.setdefault("spectra", {})[q] = {
                "unit": unit, "static": static, "names": names, "bpfo": bpfo,
                "orders": (int(k[nz].min()), int(k[nz].max())) if np.any(nz) else (0, 0),
                "shown_to_hz": float(fl[-1]) if fl.size else 0.0,
                "shaft_hz": float(msg.shaft_speed) / (2 * math.pi)}
        return True

    def log_markers(self, prefix: str, lines: dict[str, float], f_max: float, top: float, loc: str) -> None:
        """One bar-chart entity per fault-frequency line of bearing ``loc`` under ``prefix``: bars at the
        marked harmonics up to ``f_max`` [Hz] (the harmonics of the lines the defects of bearings with
        these lines excite), below the zero line (``MARKER_DEPTH`` x ``top`` deep, so they never cover
        the spectrum's lines)."""
        defects = self.defects_with_lines_of(loc)
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
            self.bars(path, np.full(len(freqs), height), np.asarray(freqs, dtype=np.float64),
                      np.full(len(freqs), width, dtype=np.float32), fault_lines.LINE_COLORS[name])

    # ---------------------------------------------------------------- speed, faults, health
    def log_speed(self, stamp_ns: int, speed_rad_s: float, *, source: str = "speed") -> None:
        """Shaft speed (rad/s, REP 103) as ``/speed/shaft_hz`` [Hz]. Waveforms also carry the
        speed at their first sample; those (of one stream) go to ``/speed/shaft_hz_waveform``."""
        path = "/speed/shaft_hz" if source == "speed" else f"/speed/shaft_hz_{source}"
        label = "shaft speed [Hz]" if source == "speed" else f"shaft speed used by the {source}s [Hz]"
        with self._lock:
            self.series(path, [label], [_SPEED_COLOR if source == "speed" else _SPEED_WAVEFORM_COLOR],
                        widths=[2.0 if source == "speed" else 1.0])
            self.scalars(path, [speed_rad_s / (2 * math.pi)], stamp_ns)

    def log_fault_frequencies(self, msg) -> None:
        """``BearingFaultFrequencies``: the lines (1x, FTF, BPFO, BPFI, BSF, 2xBSF [Hz]) in the
        marker colours, and the run's ground truth (every defect, the machine's state) for
        markers, health panels and the ground-truth trend (defect depths over the run)."""
        per = fault_lines.bearing_line_frequencies(msg)
        lines = per["de"]
        truth = fault_lines.truth_from_message(msg)
        stamp = msgs.stamp_to_ns(msg.header)
        with self._lock:
            self.series("/fault_frequencies", [f"{name} [Hz]" for name in fault_lines.LINES],
                        [fault_lines.LINE_COLORS[name] for name in fault_lines.LINES])
            self.scalars("/fault_frequencies", [lines[name] for name in fault_lines.LINES], stamp, batch=False)
            if per.get("nde", lines) != lines:            # another bearing at the NDE: its own lines
                self.series("/fault_frequencies/nde", [f"NDE {name} [Hz]" for name in fault_lines.LINES],
                            [fault_lines.LINE_COLORS[name] for name in fault_lines.LINES], widths=[1.0] * 6)
                self.scalars("/fault_frequencies/nde", [per["nde"][name] for name in fault_lines.LINES], stamp,
                             batch=False)
            self._lines, self._lines_speed = lines, float(msg.shaft_speed)
            self.bearing_lines = per
            self.defects = list(truth.defects)
            self.truth = truth
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
            self.series(path, [self._truth_names[path]],
                        [fault_lines.LINE_COLORS[d.line]], widths=[2.0])
            self.scalars(path, [cur.depth_m * 1e6 if cur is not None else 0.0], stamp)
        for loc in ("de", "nde"):           # a bearing without a defect (yet): a 0 line says so, not an empty plot
            if any(path.startswith(f"/{loc}/trend/ground_truth/") for path in seen):
                continue
            path = f"/{loc}/trend/ground_truth/no_defect"
            self.series(path, ["no defect in this bearing [µm]"], [NO_DEFECT_COLOR], widths=[2.0])
            self.scalars(path, [0.0], stamp)

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
                self.series(path, [f"{location.upper()} {name}"], [_FALLBACK_COLORS[0]])
                self.scalars(path, [float(value)], stamp_ns, batch=False)

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
