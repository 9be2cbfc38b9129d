"""The Rerun recording's time line and its rows, as the :class:`bkabem_ros.viewer.rerun_io.RerunLogger` sends them.

Everything is on the ``sample_time`` duration timeline (:data:`bkabem_ros.viewer.blueprint.TIMELINE`), seconds
since the first stamp seen (:attr:`RecordingRows.t0_ns`). Waveform samples and frequent scalar rows are collected
per entity and sent as column chunks (``send_columns``); a series' style is sent once, statically; a bar chart only
when it changed.
"""

from __future__ import annotations

import threading

import numpy as np

from bkabem_ros.viewer.blueprint import TIMELINE

__all__ = ["SAMPLES_COMPONENT", "SCALAR_BATCH_S", "WAVEFORM_BATCH_S", "RecordingRows"]

#: Scalar rows (trends, speed) are sent in column chunks of this much sample time [s].
SCALAR_BATCH_S = 1.0
#: Component holding the waveform samples (float32, one per channel and row).
SAMPLES_COMPONENT = "VibrationWaveform:samples"
#: Waveform samples are sent in column chunks of this much sample time [s] (the live viewer
#: shows them up to that much later; fewer, larger chunks cost less per sample: 0.1 s chunks
#: cost ~25 % more).
WAVEFORM_BATCH_S = 0.5


class RecordingRows:
    """A Rerun recording stream with its time line, series styles, batched rows and bar charts.

    Parameters
    ----------
    rec : rerun.RecordingStream
    rr : module
        The ``rerun`` module (imported by the caller: no rerun at import here).

    Attributes
    ----------
    rec : rerun.RecordingStream
    rr : module
        The ``rerun`` module, for the archetypes a caller logs itself.
    t0_ns : int or None
        The first stamp seen [ns]: time 0 of the timeline.
    """

    def __init__(self, rec, rr):
        self.rr = rr
        self.rec = rec
        self.t0_ns: int | None = None
        self._static_done: set[str] = set()
        self._lock = threading.Lock()
        self._rows: dict[str, tuple[list[int], list[np.ndarray]]] = {}
        self._waves: dict[str, dict] = {}
        self._bar_keys: dict[str, tuple] = {}

    def _rel_ns(self, stamp_ns: int) -> int:
        if self.t0_ns is None:
            self.t0_ns = int(stamp_ns)
        return int(stamp_ns) - self.t0_ns

    def at(self, stamp_ns: int) -> None:
        """Set the recording's time to ``stamp_ns`` [ns] (on the timeline: since :attr:`t0_ns`) for what is logged
        next."""
        self.rec.set_time(TIMELINE, duration=np.timedelta64(self._rel_ns(stamp_ns), "ns"))

    def series(self, path: str, names, colors, *, minmax: bool = False, widths=None) -> None:
        """Static series style of ``path``: one name and colour per scalar of its rows."""
        if path in self._static_done:
            return
        kwargs = {"names": list(names), "colors": list(colors)}
        if minmax:
            kwargs["aggregation_policy"] = "minmax"
        if widths is not None:
            kwargs["widths"] = list(widths)
        self.rec.log(path, self.rr.SeriesLines(**kwargs), static=True)
        self._static_done.add(path)

    def scalars(self, path: str, values, stamp_ns: int, *, batch: bool = True) -> None:
        """One row of scalars at ``stamp_ns``. With ``batch`` (streams of 10-50 rows per second:
        block trends, speed) rows are collected per entity and sent as one column chunk per
        ``SCALAR_BATCH_S`` of sample time (one ``rr.log`` per row costs ~0.1 ms; the viewer sees
        those trends that much later); rare rows are logged at once."""
        if not batch:
            self.at(stamp_ns)
            self.rec.log(path, self.rr.Scalars(np.asarray(values, dtype=np.float64)))
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
        rr = self.rr
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

        rr = self.rr
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

    def bars(self, path: str, values, abscissa, widths, color) -> None:
        """Log a bar chart at the current time: nothing if it is the one logged last, and
        abscissa, widths and colour only when they changed (latest-at keeps them; converting
        each costs ~0.3-0.5 ms)."""
        rr = self.rr
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
