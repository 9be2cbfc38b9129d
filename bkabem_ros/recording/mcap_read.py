"""Reading ROS 2-profile MCAP files: stored bytes, decoded messages, channels, summaries, metadata.

Reads files written by :mod:`bkabem_ros.recording.mcap_io` (:class:`~bkabem_ros.recording.mcap_io.McapRecorder`), by rosbag2 / rosbags
(``mcap`` storage) and cut files (read sequentially as far as they are intact). :func:`iter_messages` decodes into
today's message classes, also for recordings made with older ``bkabem_msgs`` definitions
(:mod:`bkabem_ros.messages.compat`: the recorded definitions are compared with the installed ones and upgraded where they
differ); without rclpy, mcap_ros2's decoder built from the embedded schemas gives dynamic objects.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Any, NamedTuple

from bkabem_ros.messages import compat as msg_compat
from bkabem_ros.messages import convert as msgs
from bkabem_ros.messages.compat import message_class  # noqa: F401  (re-exported: mcap_io, record, replay)

__all__ = ["Channels", "Message", "RawMessage", "file_metadata", "iter_messages", "iter_raw", "message_class",
           "scan", "summary"]


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


def _open_reader(fh):
    from mcap.reader import make_reader  # noqa: PLC0415

    return make_reader(fh)


def iter_raw(path, topics: Iterable[str] | None = None, *,
             start_time_ns: int | None = None, integrity=None) -> Iterator[RawMessage]:
    """Yield the stored messages of an MCAP file in log-time order (bytes, not decoded).

    Works for files written by :class:`McapRecorder`, by rosbag2 / rosbags (``mcap`` storage)
    and for truncated files (read sequentially as far as they are intact). With ``integrity``
    (:func:`bkabem_ros.recording.mcap_check.verify` of a damaged file) only the messages of intact chunks
    are yielded, also those after a damaged chunk.
    """
    wanted = set(topics) if topics is not None else None
    if integrity is not None and not integrity.ok:
        from bkabem_ros.recording.mcap_check import iter_intact  # noqa: PLC0415

        for schema, channel, m in iter_intact(integrity, wanted, start_time_ns):
            yield RawMessage(channel.topic, schema.name if schema else "", m.log_time,
                             m.publish_time, m.data, m.sequence, dict(channel.metadata))
        return
    with open(path, "rb") as fh:
        reader = _open_reader(fh)
        try:
            summary_ok = reader.get_summary() is not None
        except Exception:  # noqa: BLE001 - no footer / cut file
            summary_ok = False
        if summary_ok:
            it = reader.iter_messages(topics=list(wanted) if wanted else None,
                                      starting_at=start_time_ns, log_time_order=True)
            for schema, channel, m in it:
                yield RawMessage(channel.topic, schema.name if schema else "", m.log_time,
                                 m.publish_time, m.data, m.sequence, dict(channel.metadata))
            return
    yield from _iter_raw_stream(path, wanted, start_time_ns)


def _iter_raw_stream(path, wanted, start_time_ns) -> Iterator[RawMessage]:
    from mcap.records import Channel, Schema  # noqa: PLC0415
    from mcap.records import Message as McapMessage
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    out: list[RawMessage] = []
    with open(path, "rb") as fh:
        try:
            for rec in StreamReader(fh, record_size_limit=1 << 31).records:
                if isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    channels[rec.id] = rec
                elif isinstance(rec, McapMessage):
                    ch = channels.get(rec.channel_id)
                    if ch is None or (wanted and ch.topic not in wanted):
                        continue
                    if start_time_ns is not None and rec.log_time < start_time_ns:
                        continue
                    s = schemas.get(ch.schema_id)
                    out.append(RawMessage(ch.topic, s.name if s else "", rec.log_time,
                                          rec.publish_time, rec.data, rec.sequence,
                                          dict(ch.metadata)))
        except Exception:  # noqa: BLE001 - stop at the cut
            pass
    out.sort(key=lambda r: r.log_time)
    yield from out


def _decoder(path):
    """Deserializer (type_name, data, schema_text) -> msg: today's rclpy class when the class imports (recordings
    of older definitions upgraded, :class:`bkabem_ros.messages.compat.Reader`), else mcap_ros2's dynamic decoder built
    from the schema in the file."""
    return msg_compat.Reader().decode


def _schema_texts(path) -> dict[str, str]:
    from mcap.records import Schema  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    texts: dict[str, str] = {}
    try:
        with open(path, "rb") as fh:
            reader = _open_reader(fh)
            s = reader.get_summary()
            if s is not None:
                return {x.name: x.data.decode() for x in s.schemas.values()}
    except Exception:  # noqa: BLE001
        pass
    try:
        with open(path, "rb") as fh:
            for rec in StreamReader(fh, record_size_limit=1 << 31).records:
                if isinstance(rec, Schema):
                    texts[rec.name] = rec.data.decode()
    except Exception:  # noqa: BLE001
        pass
    return texts


def iter_messages(path, topics: Iterable[str] | None = None) -> Iterator[Message]:
    """Yield ``(topic, type_name, log_time_ns, msg)`` for every message of an MCAP file, in
    log-time order, deserialized: our bkabem_msgs types, std_msgs, rosgraph_msgs (anything with
    an importable Python package, or else an embedded ``ros2msg`` schema).

    Reads files from :class:`McapRecorder`, rosbag2/rosbags MCAP storage and cut files.
    """
    decode = _decoder(path)
    texts = _schema_texts(path)
    for r in iter_raw(path, topics):
        yield Message(r.topic, msgs.type_name(r.type_name), r.log_time,
                      decode(r.type_name, r.data, texts.get(r.type_name)))


class Channels(NamedTuple):
    """Topics of a file: topic -> (type name, channel metadata); first/last log time (ns)."""

    topics: dict[str, tuple[str, dict]]
    start_ns: int | None
    end_ns: int | None


def scan(path, topics: Iterable[str] | None = None, *, integrity=None) -> Channels:
    """Channels and time range of an MCAP file, from its summary when it has one (cheap), else
    by reading it through (cut files; with ``integrity`` of a damaged file: its intact chunks)."""
    wanted = set(topics) if topics is not None else None
    if integrity is not None and not integrity.ok:
        return _scan_messages(path, wanted, integrity)
    try:
        with open(path, "rb") as fh:
            s = _open_reader(fh).get_summary()
    except Exception:  # noqa: BLE001 - no footer / cut file
        s = None
    if s is not None and s.statistics is not None and s.channels:
        out = {}
        for ch in s.channels.values():
            if wanted is not None and ch.topic not in wanted:
                continue
            if s.statistics.channel_message_counts.get(ch.id, 0) == 0:
                continue
            sc = s.schemas.get(ch.schema_id)
            out[ch.topic] = (sc.name if sc else "", dict(ch.metadata))
        if wanted is None or out:
            st = s.statistics
            return Channels(out, st.message_start_time if st.message_count else None,
                            st.message_end_time if st.message_count else None)
    return _scan_messages(path, wanted, None)


def _scan_messages(path, wanted, integrity) -> Channels:
    out, start, end = {}, None, None
    for r in iter_raw(path, wanted, integrity=integrity):
        out.setdefault(r.topic, (r.type_name, r.metadata))
        start = r.log_time if start is None else min(start, r.log_time)
        end = r.log_time if end is None else max(end, r.log_time)
    return Channels(out, start, end)


def file_metadata(path) -> dict[str, dict[str, str]]:
    """MCAP metadata records of a file, by name (e.g. ``{"bkabem": {"recorded_by": ...}}``)."""
    out: dict[str, dict[str, str]] = {}
    try:
        with open(path, "rb") as fh:
            for m in _open_reader(fh).iter_metadata():
                out[m.name] = dict(m.metadata)
        return out
    except Exception:  # noqa: BLE001 - cut file: read sequentially
        pass
    from mcap.records import Metadata  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    try:
        with open(path, "rb") as fh:
            for rec in StreamReader(fh, record_size_limit=1 << 31).records:
                if isinstance(rec, Metadata):
                    out[rec.name] = dict(rec.metadata)
    except Exception:  # noqa: BLE001
        pass
    return out


def summary(path, *, integrity=None) -> dict[str, Any]:
    """Topics (type, message count), message count, start/end log time (ns) of an MCAP file
    (with ``integrity`` of a damaged file: of its intact chunks)."""
    topics: dict[str, dict[str, Any]] = {}
    start, end, n = None, None, 0
    for r in iter_raw(path, integrity=integrity):
        t = topics.setdefault(r.topic, {"type": r.type_name, "count": 0})
        t["count"] += 1
        n += 1
        start = r.log_time if start is None else min(start, r.log_time)
        end = r.log_time if end is None else max(end, r.log_time)
    return {"path": str(path), "messages": n, "topics": topics,
            "start_ns": start or 0, "end_ns": end or 0,
            "duration_s": ((end or 0) - (start or 0)) / 1e9}
