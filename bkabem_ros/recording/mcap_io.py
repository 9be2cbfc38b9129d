"""ROS 2-profile MCAP recording and recovery (plain ``mcap`` writer, rclpy CDR); reading is :mod:`bkabem_ros.recording.mcap_read`
(re-exported here).

What a file written here holds (the rosbag2 ``mcap`` storage layout):

* header profile ``ros2``; one ``ros2msg`` schema per type with the full definition text
  (nested types after ``====`` / ``MSG:`` lines, :func:`bkabem_ros.messages.convert.message_definition_text`);
* one ``cdr`` channel per topic with metadata ``offered_qos_profiles`` (YAML list, rosbag2 v9
  style) and ``topic_type_hash`` (``RIHS01_...``);
* messages with ``log_time`` (when the recorder got it, ns) and ``publish_time`` (when it was
  published, ns), zstd-compressed chunks, message and chunk indexes, statistics.

A chunk is written (and the file flushed to the OS) when it reaches ``chunk_size_bytes`` or
when its oldest message is ``chunk_duration_s`` old, whichever comes first, also while no
messages arrive (a background thread). A ``kill -9`` therefore loses at most the last
``chunk_duration_s`` (1 s by default) of data; :func:`recover` turns the truncated file into a
complete one.

Errors writing the file (unwritable path, disk full: any ``OSError``) become one
:class:`RecorderError`; the recorder stops and the caller keeps going.

Nothing here needs a running ROS graph. rclpy is used only to serialize message objects and to
deserialize for :func:`iter_messages`; without it, reading falls back to ``mcap_ros2``'s
decoder built from the embedded schemas.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording.mcap_read import (  # noqa: F401
    Channels,
    Message,
    RawMessage,
    _decoder,
    _schema_texts,
    check_messages,
    file_metadata,
    iter_messages,
    iter_raw,
    message_class,
    message_problem,
    quiet_stderr,
    scan,
    summary,
)

__all__ = [
    "DEFAULT_QOS",
    "McapRecorder",
    "McapSink",
    "Message",
    "RawMessage",
    "RecorderError",
    "RecoverResult",
    "iter_messages",
    "file_metadata",
    "iter_raw",
    "qos_dict",
    "qos_yaml",
    "recover",
    "summary",
]

LIBRARY = "bkabem mcap_io"
#: rmw's "infinite" duration as rosbag2 writes it into offered_qos_profiles.
_INFINITE = {"sec": 9223372036, "nsec": 854775807}
_INFINITE_NS = 9223372036854775807

#: QoS assumed for a topic when the caller gives none: reliable, keep last 10, volatile
#: (rclpy's default publisher profile).
DEFAULT_QOS: dict[str, Any] = {
    "history": "keep_last",
    "depth": 10,
    "reliability": "reliable",
    "durability": "volatile",
    "deadline": dict(_INFINITE),
    "lifespan": dict(_INFINITE),
    "liveliness": "automatic",
    "liveliness_lease_duration": dict(_INFINITE),
    "avoid_ros_namespace_conventions": False,
}


class RecorderError(RuntimeError):
    """Recording failed (path not writable, disk full, ...). The recorder has stopped;
    everything written before the failure stays readable after :func:`recover`."""


# --------------------------------------------------------------------------- QoS metadata
def _duration(value) -> dict[str, int]:
    """rclpy Duration / ns int / {'sec','nsec'} dict -> {'sec','nsec'}; 0 (= rmw default) and
    anything >= the rmw maximum count as infinite, as rosbag2 writes them."""
    if isinstance(value, Mapping):
        return {"sec": int(value["sec"]), "nsec": int(value["nsec"])}
    ns = int(getattr(value, "nanoseconds", value))
    if ns <= 0 or ns >= _INFINITE_NS:
        return dict(_INFINITE)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _policy(value, default: str) -> str:
    if value is None:
        return default
    name = getattr(value, "name", value)  # rclpy enums: QoSReliabilityPolicy.RELIABLE
    return str(name).lower()


def qos_dict(qos=None) -> dict[str, Any]:
    """QoS as a rosbag2 v9 ``offered_qos_profiles`` entry.

    ``qos``: an rclpy ``QoSProfile``, a dict with (some of) the keys of :data:`DEFAULT_QOS`,
    an int (keep-last depth) or None (:data:`DEFAULT_QOS`).
    """
    d = dict(DEFAULT_QOS)
    if qos is None:
        return d
    if isinstance(qos, int) and not isinstance(qos, bool):
        d["depth"] = int(qos)
        return d
    if isinstance(qos, Mapping):
        get = qos.get
    else:
        def get(key, default=None):
            return getattr(qos, key, default)
    d["history"] = _policy(get("history"), d["history"])
    d["depth"] = int(get("depth", d["depth"]) or 0)
    d["reliability"] = _policy(get("reliability"), d["reliability"])
    d["durability"] = _policy(get("durability"), d["durability"])
    d["liveliness"] = _policy(get("liveliness"), d["liveliness"])
    for key in ("deadline", "lifespan", "liveliness_lease_duration"):
        v = get(key)
        d[key] = _duration(v) if v is not None else dict(_INFINITE)
    d["avoid_ros_namespace_conventions"] = bool(get("avoid_ros_namespace_conventions", False))
    return d


def qos_yaml(profiles=None) -> str:
    """``offered_qos_profiles`` text: a YAML list of :func:`qos_dict` entries (rosbag2 v9 layout).

    ``profiles``: one QoS (see :func:`qos_dict`), a list of them, or None (one default entry).
    """
    if profiles is None or not isinstance(profiles, (list, tuple)):
        profiles = [profiles]
    out = []
    for p in profiles:
        d = qos_dict(p)
        lines = [f"- history: {d['history']}", f"  depth: {d['depth']}",
                 f"  reliability: {d['reliability']}", f"  durability: {d['durability']}"]
        for key in ("deadline", "lifespan"):
            lines += [f"  {key}:", f"    sec: {d[key]['sec']}", f"    nsec: {d[key]['nsec']}"]
        lines.append(f"  liveliness: {d['liveliness']}")
        key = "liveliness_lease_duration"
        lines += [f"  {key}:", f"    sec: {d[key]['sec']}", f"    nsec: {d[key]['nsec']}"]
        lines.append(f"  avoid_ros_namespace_conventions: "
                     f"{'true' if d['avoid_ros_namespace_conventions'] else 'false'}")
        out.append("\n".join(lines))
    return "\n".join(out) + "\n"


def parse_qos_yaml(text: str) -> list[dict[str, Any]]:
    """Parse an ``offered_qos_profiles`` value (rosbag2 v8 numeric or v9 named enums) to dicts."""
    if not text or not text.strip():
        return []
    try:
        from ruamel.yaml import YAML  # noqa: PLC0415  (ships with rosbags)

        items = YAML(typ="safe").load(text)
    except ImportError:  # pragma: no cover - ruamel.yaml comes with rosbags
        import yaml  # noqa: PLC0415

        items = yaml.safe_load(text)
    names = {"history": {1: "keep_last", 2: "keep_all"},
             "reliability": {1: "reliable", 2: "best_effort"},
             "durability": {1: "transient_local", 2: "volatile"},
             "liveliness": {1: "automatic", 3: "manual_by_topic"}}
    out = []
    for item in items or []:
        d = qos_dict(None)
        for key, value in item.items():
            if key in names and isinstance(value, int):
                value = names[key].get(value, "system_default")
            d[key] = value
        out.append(d)
    return out


# --------------------------------------------------------------------------- recorder
def _definition(type_name: str) -> tuple[str, str]:
    """(ros2msg definition text, RIHS01 hash) of a type; ValueError if this environment lacks it."""
    try:
        return msgs.message_definition_text(type_name), msgs.type_hash(type_name)
    except (OSError, KeyError) as exc:
        raise ValueError(f"no message definition for {type_name}: {exc}") from None


class McapRecorder:
    """Write ROS 2 messages into ros2-profile MCAP files, with crash-bounded chunks and rotation.

    Parameters
    ----------
    path : str or Path
        Output file. With rotation, files are ``<stem>_0.mcap``, ``<stem>_1.mcap``, ... next
        to ``path`` (rosbag2's naming); :attr:`paths` lists them.
    chunk_size_bytes : int
        Uncompressed chunk size (bytes) at which a chunk is written. Default 1 MiB
        (~0.6 s of 51.2 kHz x 8 float32 channels).
    chunk_duration_s : float
        A chunk is written at the latest when its oldest message is this old (s, wall clock),
        also when no further message arrives. A ``kill -9`` loses at most this much data.
    rotate_size_bytes : int, optional
        Start a new file once the current one reaches this size (bytes on disk).
    rotate_duration_s : float, optional
        Start a new file after this much recorded time (s of log time).
    compression : {"zstd", "lz4", "none"}
        Chunk compression.
    metadata : mapping, optional
        Key/value strings stored once per file as an MCAP metadata record named ``bkabem``.
    background_flush : bool
        Run the thread that writes an idle chunk once it is ``chunk_duration_s`` old.

    Raises
    ------
    RecorderError
        The file cannot be created (bad directory, no permission, ...).
    """

    def __init__(self, path, *, chunk_size_bytes: int = 1 << 20, chunk_duration_s: float = 1.0,
                 rotate_size_bytes: int | None = None, rotate_duration_s: float | None = None,
                 compression: str = "zstd", metadata: Mapping[str, str] | None = None,
                 background_flush: bool = True):
        if chunk_size_bytes <= 0:
            raise ValueError(f"chunk_size_bytes: {chunk_size_bytes} must be > 0")
        if not chunk_duration_s > 0:
            raise ValueError(f"chunk_duration_s: {chunk_duration_s} must be > 0")
        if rotate_size_bytes is not None and rotate_size_bytes <= 0:
            raise ValueError(f"rotate_size_bytes: {rotate_size_bytes} must be > 0")
        if rotate_duration_s is not None and not rotate_duration_s > 0:
            raise ValueError(f"rotate_duration_s: {rotate_duration_s} must be > 0")
        if compression not in ("zstd", "lz4", "none"):
            raise ValueError(f"compression: {compression!r} is not 'zstd', 'lz4' or 'none'")
        self.path = Path(path)
        self.chunk_size_bytes = int(chunk_size_bytes)
        self.chunk_duration_s = float(chunk_duration_s)
        self.rotate_size_bytes = rotate_size_bytes
        self.rotate_duration_s = rotate_duration_s
        self.compression = compression
        self.metadata = {str(k): str(v) for k, v in (metadata or {}).items()}
        self.paths: list[Path] = []
        self.error: RecorderError | None = None
        self._error_raised = False
        self.message_count = 0
        self.bytes_in = 0
        self._lock = threading.RLock()
        self._topics: dict[str, tuple[str, str]] = {}   # topic -> (type, qos yaml)
        self._writer = None
        self._fh = None
        self._closed = False
        self._open_next()
        # Written chunks must not be older than chunk_duration_s: flush at 80 % of it, checked
        # on every add and by the thread every 20 %, so the worst case is chunk_duration_s.
        self._flush_age_s = 0.8 * self.chunk_duration_s
        self._stop = threading.Event()
        self._thread = None
        if background_flush:
            self._thread = threading.Thread(target=self._flusher, name="mcap-flush", daemon=True)
            self._thread.start()

    # ---------------------------------------------------------------- files
    def _file_path(self, index: int) -> Path:
        if self.rotate_size_bytes is None and self.rotate_duration_s is None:
            return self.path
        return self.path.with_name(f"{self.path.stem}_{index}{self.path.suffix or '.mcap'}")

    def _open_next(self) -> None:
        from mcap.writer import CompressionType, Writer  # noqa: PLC0415

        path = self._file_path(len(self.paths))
        try:
            fh = open(path, "wb")  # noqa: SIM115 - closed in _finish_file
        except OSError as exc:
            raise self._fail(exc, path, opening=True) from exc
        self._fh = fh
        self.paths.append(path)
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}[self.compression]
        # chunk_size is handled here (the writer's own check runs after each add anyway)
        self._writer = Writer(fh, chunk_size=self.chunk_size_bytes, compression=comp)
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._seq: dict[str, int] = {}
        self._chunk_t0: float | None = None       # monotonic time of the oldest unwritten message
        self._file_t0: int | None = None           # first log time in this file (ns)
        try:
            self._writer.start(profile="ros2", library=LIBRARY)
            if self.metadata:
                self._writer.add_metadata("bkabem", self.metadata)
            fh.flush()
        except OSError as exc:
            raise self._fail(exc, path) from exc
        for topic, (type_name, qos) in self._topics.items():   # each file stands alone
            self._channel(topic, type_name, qos)

    def _finish_file(self) -> None:
        w, fh = self._writer, self._fh
        self._writer = self._fh = None
        if w is not None:
            w.finish()
        if fh is not None:
            fh.close()

    def _fail(self, exc: OSError, path=None, opening: bool = False) -> RecorderError:
        path = path or (self.paths[-1] if self.paths else self.path)
        reason = (exc.strerror or str(exc)) + (f" [errno {exc.errno}]" if exc.errno else "")
        err = RecorderError(f"cannot record to {path}: {reason}" if opening
                            else f"recording to {path} stopped: {reason}")
        self.error = err
        self._closed = True
        fh, self._fh, self._writer = self._fh, None, None
        if fh is not None:
            try:
                fh.close()
            except OSError:
                pass
        return err

    # ---------------------------------------------------------------- channels
    def _channel(self, topic: str, type_name: str, qos: str) -> int:
        w = self._writer
        sid = self._schemas.get(type_name)
        text, rihs = _definition(type_name)
        if sid is None:
            sid = w.register_schema(name=type_name, encoding="ros2msg", data=text.encode())
            self._schemas[type_name] = sid
        cid = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid,
                                 metadata={"offered_qos_profiles": qos, "topic_type_hash": rihs})
        self._channels[topic] = cid
        self._seq[topic] = 0
        self._topics[topic] = (type_name, qos)
        return cid

    # ---------------------------------------------------------------- writing
    @property
    def closed(self) -> bool:
        return self._closed

    def add(self, topic: str, type_name, data, log_time_ns: int | None = None,
            publish_time_ns: int | None = None, qos=None) -> bool:
        """Record one message.

        Parameters
        ----------
        topic : str
            Full topic name (``/ns/vibration/de/acceleration``).
        type_name : str or message class
            ``pkg/msg/Type`` (also ``pkg/Type`` or the class).
        data : bytes or message
            CDR bytes (e.g. from a raw subscription) or a message object (serialized here
            with rclpy).
        log_time_ns, publish_time_ns : int, optional
            Receive and publish time (ns since the epoch, or sim time). Default now / log time.
        qos : optional
            Offered QoS of the topic, used when the topic is first seen (see :func:`qos_yaml`;
            a ready YAML string is taken as is).

        Returns
        -------
        bool
            True if recorded; False if the recorder is closed or stopped after an error.

        Raises
        ------
        RecorderError
            Writing failed just now (disk full, ...). Later calls return False.
        ValueError
            No message definition for ``type_name`` here (the recording goes on).
        """
        if self._closed:
            if self.error is not None and not self._error_raised:   # the flusher thread failed
                self._error_raised = True
                raise self.error
            return False
        if not isinstance(data, (bytes, bytearray, memoryview)):
            from rclpy.serialization import serialize_message  # noqa: PLC0415

            data = serialize_message(data)
        if log_time_ns is None:
            log_time_ns = time.time_ns()
        if publish_time_ns is None:
            publish_time_ns = log_time_ns
        with self._lock:
            if self._closed:
                return False
            try:
                cid = self._channels.get(topic)
                if cid is None:
                    name = msgs.type_name(type_name)
                    _definition(name)     # a missing .msg is the caller's problem, not the file's
                    q = qos if isinstance(qos, str) else qos_yaml(qos)
                    cid = self._channel(topic, name, q)
                if self._maybe_rotate(log_time_ns):
                    cid = self._channels[topic]
                seq = self._seq[topic]
                self._seq[topic] = seq + 1
                self._writer.add_message(channel_id=cid, log_time=int(log_time_ns),
                                         publish_time=int(publish_time_ns), sequence=seq & 0xFFFFFFFF,
                                         data=bytes(data))
                self.message_count += 1
                self.bytes_in += len(data)
                now = time.monotonic()
                if self._chunk_t0 is None:
                    self._chunk_t0 = now
                if self._file_t0 is None:
                    self._file_t0 = int(log_time_ns)
                if now - self._chunk_t0 >= self._flush_age_s:
                    self._flush_locked()
            except OSError as exc:
                self._error_raised = True
                raise self._fail(exc) from exc
        return True

    def _maybe_rotate(self, log_time_ns: int) -> bool:
        rotate = False
        if self.rotate_size_bytes is not None and self._fh.tell() >= self.rotate_size_bytes:
            rotate = True
        if (self.rotate_duration_s is not None and self._file_t0 is not None
                and (log_time_ns - self._file_t0) >= self.rotate_duration_s * 1e9):
            rotate = True
        if rotate:
            self._finish_file()
            self._open_next()
        return rotate

    def _flush_locked(self) -> None:
        self._writer.flush()      # ends the chunk in progress, writes it, flushes the stream
        self._chunk_t0 = None

    def flush(self) -> None:
        """Write the chunk in progress now (it is then safe from a crash)."""
        with self._lock:
            if self._closed:
                return
            try:
                self._flush_locked()
            except OSError as exc:
                raise self._fail(exc) from exc

    def _flusher(self) -> None:
        period = 0.2 * self.chunk_duration_s
        while not self._stop.wait(period):
            with self._lock:
                if self._closed:
                    return
                if self._chunk_t0 is not None and time.monotonic() - self._chunk_t0 >= self._flush_age_s:
                    try:
                        self._flush_locked()
                    except OSError as exc:
                        self._fail(exc)
                        return

    def close(self) -> None:
        """Finish the file (summary, indexes, footer). Idempotent; never raises for a recorder
        that already failed (see :attr:`error`)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self._finish_file()
            except OSError as exc:
                self._closed = False
                raise self._fail(exc) from exc

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# --------------------------------------------------------------------------- node sink
class McapSink:
    """Node sink ``callable(topic, msg_type_name, msg, stamp_ns)`` that records into MCAP.

    The message is serialized in the caller's thread (~6 us per 4096 samples); writing,
    compression and file I/O happen in a writer thread, so the node's executor never waits for
    the disk. Never raises into the node: a failure (unwritable path, disk full) is reported once
    through ``log_error`` (default: stderr), recording stops, the node keeps publishing.
    ``log_time`` is the wall clock at the call (ns); ``publish_time`` is ``stamp_ns``.

    Parameters
    ----------
    path : str or Path
        Output file (see :class:`McapRecorder`).
    qos : mapping topic -> QoS, or one QoS for all, optional
        Offered QoS written into ``offered_qos_profiles``.
    log_error : callable(str), optional
        Where the one error line goes (e.g. ``node.get_logger().error``).
    threaded : bool
        Use the writer thread (default). False writes in the caller's thread.
    max_queue : int
        Messages waiting for the writer thread before new ones are dropped (counted in
        :attr:`dropped`).
    **recorder_options
        Passed to :class:`McapRecorder`.
    """

    def __init__(self, path, *, qos=None, log_error=None, threaded: bool = True,
                 max_queue: int = 20000, **recorder_options):
        import queue  # noqa: PLC0415

        self.log_error = log_error or _stderr
        self.qos = qos
        self.recorder: McapRecorder | None = None
        self.error: RecorderError | None = None
        self.dropped = 0
        self.bad_topics: dict[str, str] = {}
        self._queue = None
        self._thread = None
        try:
            self.recorder = McapRecorder(path, **recorder_options)
        except RecorderError as exc:
            self._report(exc)
            return
        if threaded:
            self._queue = queue.Queue(maxsize=max_queue)
            self._thread = threading.Thread(target=self._writer_loop, name="mcap-sink", daemon=True)
            self._thread.start()

    def _report(self, exc: RecorderError) -> None:
        if self.error is None:
            self.error = exc
            self.log_error(f"{exc}; publishing continues without recording")

    def _qos_for(self, topic: str):
        if isinstance(self.qos, Mapping) and not ({"history", "depth", "reliability"} & set(self.qos)):
            return self.qos.get(topic)
        return self.qos

    def _write(self, item) -> None:
        topic, type_name, data, log_t, pub_t = item
        if topic in self.bad_topics:
            return
        try:
            self.recorder.add(topic, type_name, data, log_time_ns=log_t, publish_time_ns=pub_t,
                              qos=self._qos_for(topic))
        except RecorderError as exc:
            self._report(exc)
        except Exception as exc:  # noqa: BLE001 - e.g. no .msg definition for the type: skip the topic
            self.bad_topics[topic] = f"{type(exc).__name__}: {exc}"
            self.log_error(f"not recording {topic} ({type_name}): {exc}")

    def _writer_loop(self) -> None:
        q = self._queue
        while True:
            item = q.get()
            if item is None:
                return
            if self.error is None:
                self._write(item)

    def __call__(self, topic: str, msg_type_name, msg, stamp_ns: int | None = None) -> None:
        rec = self.recorder
        if rec is None or self.error is not None or rec.closed:
            if rec is not None and rec.error is not None and self.error is None:
                self._report(rec.error)      # the background flush failed (disk full): say so, once
            return
        if not isinstance(msg, (bytes, bytearray, memoryview)):
            from rclpy.serialization import serialize_message  # noqa: PLC0415

            msg = serialize_message(msg)
        now = time.time_ns()
        item = (topic, msg_type_name, msg, now, now if stamp_ns is None else int(stamp_ns))
        if self._queue is None:
            self._write(item)
            return
        try:
            self._queue.put_nowait(item)
        except Exception:  # noqa: BLE001 - queue.Full: the disk does not keep up
            self.dropped += 1

    def close(self) -> None:
        """Write what is queued, finish the file. Idempotent."""
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join()
            self._thread = None
        if self.recorder is not None:
            try:
                self.recorder.close()
            except RecorderError as exc:
                self._report(exc)
            if self.recorder.error is not None and self.error is None:
                self._report(self.recorder.error)

    @property
    def paths(self) -> list[Path]:
        return self.recorder.paths if self.recorder is not None else []


def _stderr(text: str) -> None:
    import sys  # noqa: PLC0415

    sys.stderr.write(text + "\n")


# --------------------------------------------------------------------------- recovery
class RecoverResult(NamedTuple):
    """What :func:`recover` wrote: messages, channels, whether the source was cut or damaged (``truncated``), the
    last log time [ns], what was wrong with the source (``error``, "" when intact), the damaged chunks skipped and
    the messages the source's summary counts (None without a readable summary)."""

    messages: int
    channels: int
    truncated: bool
    last_log_time_ns: int
    error: str
    skipped_chunks: int = 0
    expected_messages: int | None = None
    damaged_records: int = 0


def recover(src, dst, *, compression: str = "zstd") -> RecoverResult:
    """Rebuild a complete MCAP from a file cut short (``kill -9``, power loss, disk full) or damaged.

    Reads ``src`` with the bounded reader of :mod:`bkabem_ros.recording.mcap_check`: every intact chunk is kept,
    also those after a damaged one (garbage, a bad CRC, a chunk that lies about its size); the damaged ones are
    counted (``skipped_chunks``). Writes ``dst`` with the same header, schemas, channels (metadata), messages
    (times, sequence numbers, in log-time order), metadata and attachments, plus the summary and footer a reader
    needs. Also works on an intact file (a copy). Raises ``ValueError`` for a file that is not an MCAP recording
    (no magic, or no header record after it).
    """
    from mcap.writer import CompressionType, Writer  # noqa: PLC0415

    from bkabem_ros.recording.mcap_check import iter_intact, read_attachment, verify  # noqa: PLC0415

    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise ValueError("recover: dst must differ from src")
    comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
            "none": CompressionType.NONE}[compression]
    info = verify(src)
    if not info.mcap:
        raise ValueError(f"{src} is not an MCAP file (no MCAP magic at the start)")
    if not info.header:
        raise ValueError(f"{src} is not an MCAP recording (no header record after the magic"
                         + (f"; {info.summary_line()})" if info.cut_at is not None else ")"))
    n_msgs, last = 0, 0
    with open(dst, "wb") as fout:
        w = Writer(fout, compression=comp)
        w.start(profile=info.profile or "ros2", library=info.library or LIBRARY)
        schema_map = {sid: w.register_schema(s.name, s.encoding, s.data)
                      for sid, s in sorted(info.schemas.items()) if sid != 0}
        channel_map = {cid: w.register_channel(c.topic, c.message_encoding, schema_map.get(c.schema_id, 0),
                                               dict(c.metadata))
                       for cid, c in sorted(info.channels.items())}
        for _schema, channel, m in iter_intact(info):
            w.add_message(channel_id=channel_map[channel.id], log_time=m.log_time, data=m.data,
                          publish_time=m.publish_time, sequence=m.sequence)
            n_msgs += 1
            last = max(last, m.log_time)
        for name, meta in info.metadata.items():
            w.add_metadata(name, dict(meta))
        for off in info.attachment_offsets:
            a = read_attachment(info, off)
            if a is not None:
                w.add_attachment(a.create_time, a.log_time, a.name, a.media_type, a.data)
        w.finish()
    return RecoverResult(n_msgs, len(channel_map), not info.ok, last, "" if info.ok else info.summary_line(),
                         info.skipped_chunks, info.expected_messages, len(info.damaged))
