"""Stream bkabem messages to the Rerun viewer or into an ``.rrd`` file (rerun-sdk 0.41).

Entities (units in the series names; all on the ``sample_time`` duration timeline, seconds
since the first stamp the logger saw, :attr:`RerunLogger.t0_ns`):

==========================================  ===========================================
``/<loc>/<quantity>/<channel>``             waveform samples, ``send_columns`` per block
                                            (sample ``i`` at ``header.stamp + i / sample_rate``)
``/<loc>/features/<quantity>_rms``         RMS of each block, one series per channel
``/<loc>/features/<quantity>_peak``        max abs of each block, one series per channel
``/<loc>/features/<name>``                  per-chunk features given to :meth:`log_features`
``/<loc>/spectrum/<quantity>/<channel>``    ``BarChart`` of line amplitudes, abscissa in Hz
``/<loc>/spectrum/<quantity>/bpfo_orders``  ``BarChart`` markers at k x BPFO (k = 1, 2, ...)
``/speed/shaft_hz``                         shaft speed [Hz]
``/fault_frequencies/{ftf,bpfo,bpfi,bsf}_hz`` characteristic frequencies [Hz]
==========================================  ===========================================

``<loc>`` is ``de`` / ``nde``. :func:`blueprint` lays these out: DE and NDE side by side
(waveforms, spectra, features) above a speed / fault-frequency plot.

Nothing here listens on a port: :class:`RerunLogger` either writes a file or connects to a
viewer (default ``rerun+http://127.0.0.1:9876/proxy``, i.e. ``rerun`` started on this machine,
which binds 127.0.0.1 when started as ``rerun --bind 127.0.0.1``).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np

from . import msgs

__all__ = ["DEFAULT_CONNECT_URL", "RerunLogger", "RerunSink", "blueprint", "rerun_binary"]

#: Viewer address used by ``--rerun-connect`` without a URL (the local viewer's gRPC proxy).
DEFAULT_CONNECT_URL = "rerun+http://127.0.0.1:9876/proxy"
TIMELINE = "sample_time"

_CHANNEL_COLORS = {"vertical": (31, 119, 180), "horizontal": (255, 127, 14)}
_FALLBACK_COLORS = [(44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75)]
_MARKER_COLOR = (150, 150, 150, 110)


def rerun_binary() -> str:
    """Path of the real ``rerun`` executable shipped in ``rerun_cli`` (not the Python wrapper,
    whose PID is not the viewer's)."""
    import os  # noqa: PLC0415

    import rerun_cli  # noqa: PLC0415

    return os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")


def blueprint(locations=("de", "nde"), quantities=("acceleration", "displacement"),
              window_s: float = 0.25):
    """Default viewer layout: one column per bearing location (DE left, NDE right), each with
    tabs of waveforms (the last ``window_s`` seconds before the time cursor) per quantity, then
    spectra with BPFO-order markers, then per-block features; below both, speed and fault
    frequencies over the whole run."""
    import rerun.blueprint as rrb  # noqa: PLC0415

    window = rrb.VisibleTimeRange(TIMELINE,
                                  start=rrb.TimeRangeBoundary.cursor_relative(seconds=-window_s),
                                  end=rrb.TimeRangeBoundary.cursor_relative())
    columns = []
    for loc in locations:
        name = loc.upper()
        waves = rrb.Tabs(*[rrb.TimeSeriesView(origin=f"/{loc}/{q}", name=f"{name} {q} [{msgs.SI_UNITS[q]}]",
                                              time_ranges=[window])
                           for q in quantities], name=f"{name} waveforms")
        spectra = rrb.Tabs(*[rrb.BarChartView(origin=f"/{loc}/spectrum/{q}",
                                              name=f"{name} {q} spectrum [{msgs.SI_UNITS[q]}] vs Hz")
                             for q in quantities], name=f"{name} spectra")
        feats = rrb.TimeSeriesView(origin=f"/{loc}/features", name=f"{name} per-block features")
        columns.append(rrb.Vertical(waves, spectra, feats, row_shares=[3, 3, 2], name=name))
    speed = rrb.TimeSeriesView(origin="/", contents=["/speed/**", "/fault_frequencies/bpfo_hz"],
                               name="shaft speed and BPFO [Hz]")
    return rrb.Blueprint(rrb.Vertical(rrb.Horizontal(*columns), speed, row_shares=[4, 1]),
                         collapse_panels=True)


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
        Spectra per second (sample time) logged per location and quantity; the node sends one
        per chunk while the speed changes, and a bar chart costs ~3 ms to log. 0: all.

    Without ``save_path`` and ``connect_url`` the data is kept in memory (tests).
    """

    def __init__(self, app_id: str = "bkabem", recording_id: str | None = None, save_path=None,
                 connect_url: str | None = None, *, with_blueprint: bool = True,
                 max_spectrum_rate_hz: float = 2.0):
        import rerun as rr  # noqa: PLC0415

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
        self._static_done: set[str] = set()
        self._lock = threading.Lock()
        self._bpfo_hz: float | None = None
        self._speed_stream: tuple[str, str] | None = None
        self._last_spectrum: dict[tuple[str, str], int] = {}
        self.max_spectrum_rate_hz = float(max_spectrum_rate_hz)
        self.samples_logged = 0
        self.closed = False

    # ---------------------------------------------------------------- time
    def _rel_ns(self, stamp_ns: int) -> int:
        if self.t0_ns is None:
            self.t0_ns = int(stamp_ns)
        return int(stamp_ns) - self.t0_ns

    def _at(self, stamp_ns: int) -> None:
        self.rec.set_time(TIMELINE, duration=np.timedelta64(self._rel_ns(stamp_ns), "ns"))

    def _series(self, path: str, name, color=None) -> None:
        """Static series style: ``name`` (str or one per series) and colors (one or a list)."""
        if path in self._static_done:
            return
        rr = self._rr
        kwargs = {"names": name}
        if color is not None:
            kwargs["colors"] = color if isinstance(color, list) else [color]
        self.rec.log(path, rr.SeriesLines(**kwargs), static=True)
        self._static_done.add(path)

    def _scalar(self, path: str, name: str, value: float, color=None) -> None:
        self._series(path, name, color)
        self.rec.log(path, self._rr.Scalars(float(value)))

    @staticmethod
    def _color(channel: str, c: int):
        return _CHANNEL_COLORS.get(channel, _FALLBACK_COLORS[c % len(_FALLBACK_COLORS)])

    # ---------------------------------------------------------------- messages
    def log_waveform(self, msg) -> None:
        """``VibrationWaveform``: every sample via ``send_columns`` on ``sample_time``, plus the
        block's RMS and peak per channel and the shaft speed at its first sample."""
        rr = self._rr
        a = msgs.waveform_array(msg)
        n = a.shape[1]
        if n == 0:
            return
        loc, q, unit = msg.location, msg.quantity, msg.unit
        stamp = msgs.stamp_to_ns(msg.header)
        with self._lock:
            rel = self._rel_ns(stamp)
            offs = np.round(np.arange(n, dtype=np.float64) * (1e9 / float(msg.sample_rate))).astype(np.int64)
            times = (rel + offs).astype("timedelta64[ns]")
            self._at(stamp)
            names = list(msg.channel_names) or [f"ch{c}" for c in range(a.shape[0])]
            for c, ch in enumerate(names):
                path = f"/{loc}/{q}/{ch}"
                self._series(path, f"{loc.upper()} {ch} {q} [{unit}]", self._color(ch, c))
                self.rec.send_columns(path, indexes=[rr.TimeColumn(TIMELINE, duration=times)],
                                      columns=rr.Scalars.columns(scalars=a[c].astype(np.float64)))
            # per-block features: one entity per quantity, one series per channel
            x = a.astype(np.float64)
            rms = np.sqrt(np.einsum("ij,ij->i", x, x) / n)
            peak = np.max(np.abs(x), axis=1)
            colors = [self._color(ch, c) for c, ch in enumerate(names)]
            for feat, vals in (("rms", rms), ("peak", peak)):
                path = f"/{loc}/features/{q}_{feat}"
                self._series(path, [f"{feat.upper() if feat == 'rms' else feat} {ch} {q} [{unit}]" for ch in names],
                             colors)
                self.rec.log(path, rr.Scalars(vals))
            self.samples_logged += a.size
            if self._speed_stream is None:
                self._speed_stream = (loc, q)
        if self._speed_stream == (loc, q):   # one stream is enough for the speed trace
            self.log_speed(stamp, float(msg.shaft_speed), source="waveform")

    def log_spectrum(self, msg) -> bool:
        """``VibrationSpectrum``: one bar chart per channel (amplitude vs frequency in Hz) and a
        marker bar chart at the BPFO orders k = 1..max order present. At most
        ``max_spectrum_rate_hz`` per location and quantity (sample time); returns whether logged."""
        rr = self._rr
        f, k, amp, _ph = msgs.spectrum_arrays(msg)
        if f.size == 0:
            return False
        loc, q, unit = msg.location, msg.quantity, msg.unit
        stamp = msgs.stamp_to_ns(msg.header)
        last = self._last_spectrum.get((loc, q))
        if (last is not None and self.max_spectrum_rate_hz > 0
                and 0 <= stamp - last < 1e9 / self.max_spectrum_rate_hz):
            return False
        self._last_spectrum[(loc, q)] = stamp
        nz = k > 0
        bpfo = float(np.median(f[nz] / k[nz])) if np.any(nz) else (self._bpfo_hz or 0.0)
        width = 0.35 * bpfo if bpfo > 0 else None
        names = list(msg.channel_names) or [f"ch{c}" for c in range(amp.shape[0])]
        with self._lock:
            self._at(msgs.stamp_to_ns(msg.header))
            for c, ch in enumerate(names):
                kw = {"abscissa": f, "color": self._color(ch, c)}
                if width:
                    # side by side: channel c shifted by a fraction of the bar width
                    kw["abscissa"] = f + (c - (len(names) - 1) / 2) * width / max(len(names), 1)
                    kw["widths"] = np.full(f.size, width / max(len(names), 1), dtype=np.float32)
                self.rec.log(f"/{loc}/spectrum/{q}/{ch}", rr.BarChart(amp[c], **kw))
            if bpfo > 0:
                kmax = int(round(float(k.max())))
                orders = np.arange(1, kmax + 1, dtype=np.float64)
                top = float(amp[:, nz].max()) if np.any(nz) else float(amp.max())
                self.rec.log(f"/{loc}/spectrum/{q}/bpfo_orders",
                             rr.BarChart(np.full(orders.size, top), abscissa=orders * bpfo,
                                         widths=np.full(orders.size, 0.04 * bpfo, dtype=np.float32),
                                         color=_MARKER_COLOR))
                self.rec.log(f"/{loc}/spectrum/{q}/info", rr.TextDocument(
                    f"{loc.upper()} {q} spectrum [{unit}]: BPFO {bpfo:.3f} Hz, lines at orders "
                    f"{int(k.min())}..{kmax} (grey bars: k x BPFO), shaft "
                    f"{msg.shaft_speed / (2 * math.pi):.3f} Hz"))
        return True

    def log_speed(self, stamp_ns: int, speed_rad_s: float, *, source: str = "speed") -> None:
        """Shaft speed (rad/s, REP 103) as ``/speed/shaft_hz`` [Hz]. Waveforms also carry the
        speed at their first sample; those (of one stream) go to ``/speed/shaft_hz_waveform``."""
        path = "/speed/shaft_hz" if source == "speed" else f"/speed/shaft_hz_{source}"
        label = "shaft speed [Hz]" if source == "speed" else f"shaft speed ({source}) [Hz]"
        with self._lock:
            self._at(stamp_ns)
            self._scalar(path, label, speed_rad_s / (2 * math.pi), (0, 0, 0) if source == "speed" else None)

    def log_fault_frequencies(self, msg) -> None:
        """``BearingFaultFrequencies``: FTF, BPFO, BPFI, BSF as scalars [Hz]."""
        with self._lock:
            self._at(msgs.stamp_to_ns(msg.header))
            for name in ("ftf", "bpfo", "bpfi", "bsf"):
                self._scalar(f"/fault_frequencies/{name}_hz", f"{name.upper()} [Hz]", getattr(msg, name))
            self._bpfo_hz = float(msg.bpfo)

    def log_features(self, location: str, stamp_ns: int, features: Mapping[str, float]) -> None:
        """Per-chunk scalars, e.g. ``{"iso_velocity_rms_mm_s": 1.2, "kurtosis": 3.4}``; put the
        unit in the key (``_mm_s``, ``_m_s2``), it becomes the series name."""
        with self._lock:
            self._at(stamp_ns)
            for name, value in features.items():
                self._scalar(f"/{location}/features/{name}", f"{location.upper()} {name}", value)

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
        """Flush and disconnect (writes the ``.rrd`` footer). Idempotent."""
        if self.closed:
            return
        self.closed = True
        try:
            self.rec.flush()
        finally:
            self.rec.disconnect()


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

                from .mcap_io import message_class  # noqa: PLC0415

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
        """Wait until everything queued so far is logged."""
        if self._thread is not None:
            import time as _time  # noqa: PLC0415

            while not self._queue.empty():
                _time.sleep(0.005)

    def close(self) -> None:
        """Log what is queued, then close the logger (footer of the .rrd). Idempotent."""
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join()
            self._thread = None
        self.logger.close()
