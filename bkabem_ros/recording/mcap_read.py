"""Reading ROS 2-profile MCAP files: stored bytes, decoded messages, channels, summaries, metadata.

Reads files written by :mod:`bkabem_ros.recording.mcap_io` (:class:`~bkabem_ros.recording.mcap_io.McapRecorder`), by rosbag2 / rosbags
(``mcap`` storage), cut and damaged files: every read goes through the bounded reader of
:mod:`bkabem_ros.recording.mcap_check` (no chunk is decompressed beyond what it declares), which keeps the intact
chunks after a damaged one. :func:`check_messages` deserializes every message and counts those that do not decode. :func:`iter_messages` decodes into
today's message classes, also for recordings made with older ``bkabem_msgs`` definitions
(:mod:`bkabem_ros.messages.compat`: the recorded definitions are compared with the installed ones and upgraded where they
differ); without rclpy, mcap_ros2's decoder built from the embedded schemas gives dynamic objects.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Iterator
from typing import Any, NamedTuple

from bkabem_ros.messages import compat as msg_compat
from bkabem_ros.messages import convert as msgs
from bkabem_ros.messages.compat import message_class  # noqa: F401  (re-exported: mcap_io, record, replay)

__all__ = ["Channels", "Message", "RawMessage", "check_messages", "file_metadata", "iter_messages", "iter_raw",
           "message_class", "message_problem", "scan", "summary"]


class RawMessage(NamedTuple):
    """One recorded message as stored: CDR ``data``, times in ns, the channel's metadata."""

    topic: str
    type_name: str
    log_time: int
    publish_time: int
    data: bytes
    sequence: int
    metadata: dict


class Message(NamedTuple):
    """One recorded message, deserialized (``msg`` is an rclpy message when the type's Python
    package is importable, else a dynamic ``mcap_ros2`` object with the same fields)."""

    topic: str
    type_name: str
    log_time: int
    msg: Any


def _integrity(path, integrity):
    from bkabem_ros.recording.mcap_check import verify  # noqa: PLC0415

    return integrity if integrity is not None else verify(path)


def iter_raw(path, topics: Iterable[str] | None = None, *,
             start_time_ns: int | None = None, integrity=None) -> Iterator[RawMessage]:
    """Yield the stored messages of an MCAP file in log-time order (bytes, not decoded).

    Works for files written by :class:`McapRecorder`, by rosbag2 / rosbags (``mcap`` storage), for truncated
    and for damaged files: everything is read through :func:`bkabem_ros.recording.mcap_check.verify` (given as
    ``integrity``, or made here) and its bounded reader, so only the messages of intact chunks are yielded, also
    those after a damaged chunk, and no chunk is decompressed beyond what it declares.
    """
    from bkabem_ros.recording.mcap_check import iter_intact  # noqa: PLC0415

    wanted = set(topics) if topics is not None else None
    for schema, channel, m in iter_intact(_integrity(path, integrity), wanted, start_time_ns):
        yield RawMessage(channel.topic, schema.name if schema else "", m.log_time,
                         m.publish_time, m.data, m.sequence, dict(channel.metadata))


def _decoder(path):
    """Deserializer (type_name, data, schema_text) -> msg: today's rclpy class when the class imports (recordings
    of older definitions upgraded, :class:`bkabem_ros.messages.compat.Reader`), else mcap_ros2's dynamic decoder built
    from the schema in the file."""
    return msg_compat.Reader().decode


def _schema_texts(path, integrity=None) -> dict[str, str]:
    """Recorded definition of every schema of the file, by type name (undecodable text: left out)."""
    texts: dict[str, str] = {}
    for x in _integrity(path, integrity).schemas.values():
        # garbage bytes stay garbage (and then fail to parse), not a missing schema that the installed one replaces
        texts.setdefault(x.name, x.data.decode("utf-8", errors="replace"))
    return texts


def iter_messages(path, topics: Iterable[str] | None = None) -> Iterator[Message]:
    """Yield ``(topic, type_name, log_time_ns, msg)`` for every message of an MCAP file, in
    log-time order, deserialized: our bkabem_msgs types, std_msgs, rosgraph_msgs (anything with
    an importable Python package, or else an embedded ``ros2msg`` schema).

    Reads files from :class:`McapRecorder`, rosbag2/rosbags MCAP storage and cut files.
    """
    decode = _decoder(path)
    integrity = _integrity(path, None)
    texts = _schema_texts(path, integrity)
    for r in iter_raw(path, topics, integrity=integrity):
        yield Message(r.topic, msgs.type_name(r.type_name), r.log_time,
                      decode(r.type_name, r.data, texts.get(r.type_name)))


class Channels(NamedTuple):
    """Topics of a file: topic -> (type name, channel metadata); first/last log time (ns)."""

    topics: dict[str, tuple[str, dict]]
    start_ns: int | None
    end_ns: int | None


def scan(path, topics: Iterable[str] | None = None, *, integrity=None) -> Channels:
    """Channels and time range of an MCAP file (of its intact part when it is damaged), from its messages."""
    wanted = set(topics) if topics is not None else None
    return _scan_messages(path, wanted, _integrity(path, integrity))


def _scan_messages(path, wanted, integrity) -> Channels:
    out, start, end = {}, None, None
    for r in iter_raw(path, wanted, integrity=integrity):
        out.setdefault(r.topic, (r.type_name, r.metadata))
        start = r.log_time if start is None else min(start, r.log_time)
        end = r.log_time if end is None else max(end, r.log_time)
    return Channels(out, start, end)


def file_metadata(path, *, integrity=None) -> dict[str, dict[str, str]]:
    """MCAP metadata records of a file, by name (e.g. ``{"bkabem": {"recorded_by": ...}}``)."""
    return {k: dict(v) for k, v in _integrity(path, integrity).metadata.items()}


def summary(path, *, integrity=None, decode: bool = False) -> dict[str, Any]:
    """Topics (type, message count), message count, start/end log time (ns), the longest gap between two
    messages' log times (``max_gap_ns``, after ``max_gap_at_ns``) of an MCAP file (of its intact part when it is
    damaged). With ``decode``, every message is also deserialized (:func:`check_messages`): those that fail are
    counted into ``integrity.bad_messages`` (and ``bad_messages`` here)."""
    integrity = _integrity(path, integrity)
    topics: dict[str, dict[str, Any]] = {}
    start, end, n, prev, gap, gap_at = None, None, 0, None, 0, None
    check = _MessageCheck(path, integrity) if decode else None
    with quiet_stderr() if decode else contextlib.nullcontext():
        for r in iter_raw(path, integrity=integrity):
            t = topics.setdefault(r.topic, {"type": r.type_name, "count": 0})
            t["count"] += 1
            n += 1
            start = r.log_time if start is None else min(start, r.log_time)
            end = r.log_time if end is None else max(end, r.log_time)
            if prev is not None and r.log_time - prev > gap:
                gap, gap_at = r.log_time - prev, prev
            prev = r.log_time
            if check is not None:
                check(r)
    if check is not None:
        check.finish()
    return {"path": str(path), "messages": n, "topics": topics,
            "start_ns": start or 0, "end_ns": end or 0,
            "duration_s": ((end or 0) - (start or 0)) / 1e9, "max_gap_ns": gap, "max_gap_at_ns": gap_at,
            "bad_messages": integrity.bad_messages}


def check_messages(path, integrity=None):
    """Deserialize every message of ``path`` (:class:`bkabem_ros.messages.compat.Reader`); those whose payload
    does not decode (garbage, cut, empty, a sequence longer than the message, a schema that does not parse) are
    counted into ``integrity.bad_messages`` (first one named in ``bad_message_first``). Returns the integrity."""
    integrity = _integrity(path, integrity)
    check = _MessageCheck(path, integrity)
    with quiet_stderr():
        for r in iter_raw(path, integrity=integrity):
            check(r)
    check.finish()
    return integrity


class quiet_stderr:
    """File descriptor 2 to /dev/null while bad payloads are decoded: Fast CDR and the message parsers print their
    own lines there ("sequence size exceeds remaining buffer"); the exception carries what went wrong."""

    def __enter__(self):
        import os
        import sys

        try:
            sys.stderr.flush()
            self._saved = os.dup(2)
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 2)
            os.close(devnull)
        except (OSError, ValueError):
            self._saved = None
        return self

    def __exit__(self, *exc):
        import os

        if self._saved is not None:
            os.dup2(self._saved, 2)
            os.close(self._saved)
        return False


class _MessageCheck:
    """Decode messages one by one and count those that fail (see :func:`check_messages`)."""

    def __init__(self, path, integrity):
        self.integrity = integrity
        self.reader = msg_compat.Reader()
        self.texts = _schema_texts(path, integrity)
        self.bad, self.first = 0, ""

    def __call__(self, r: RawMessage) -> bool:
        """Whether ``r`` decodes (a failure is counted)."""
        problem = message_problem(self.reader, r, self.texts.get(r.type_name))
        if problem is None:
            return True
        self.bad += 1
        if not self.first:
            self.first = f"{r.topic} at log time {r.log_time} ns: {problem}"
        return False

    def finish(self) -> None:
        self.integrity.bad_messages, self.integrity.bad_message_first = self.bad, self.first
        self.integrity.messages_checked = True


def message_problem(reader, r: RawMessage, schema_text: str | None) -> str | None:
    """Why the recorded message ``r`` does not decode (one line), or None."""
    if not r.type_name:
        return "its channel has no schema"
    try:
        reader.decode(r.type_name, r.data, schema_text)
    except Exception as exc:  # noqa: BLE001 - rclpy's RMWError, mcap_ros2's struct / UnicodeDecodeError ...
        return f"{type(exc).__name__}: {' '.join(str(exc).split())[:120]}"
    return None
