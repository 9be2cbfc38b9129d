"""Integrity of an MCAP file: chunk CRCs, the data-section CRC, truncation, messages missing against the summary.

:func:`verify` reads the file once, record by record at the framing level (opcode, length), so that one damaged
chunk does not hide the chunks after it: every chunk is decompressed and its CRC checked, the data section's CRC
(``DataEnd``) is compared, a cut (no footer, a record longer than the rest of the file) is located, and the
message count of the footer's statistics (when the summary is readable) is compared with the messages found in
intact chunks. :class:`Integrity` says what is damaged in one line (:meth:`Integrity.summary_line`) and in
detail (:meth:`Integrity.lines`), and keeps the intact chunks so that :func:`iter_intact` can read the good
part in log-time order (``bkabem replay --allow-damaged``).

Only the ``mcap`` package is needed (no ROS).
"""

from __future__ import annotations

import heapq
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, NamedTuple

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")

__all__ = ["DamagedRecording", "Integrity", "iter_intact", "verify"]


class DamagedRecording(ValueError):
    """A recording is damaged (bad CRC, cut, unreadable); the message names the file and what is wrong."""


class Damage(NamedTuple):
    """One damaged place: byte offset of the record and what is wrong there."""

    offset: int
    what: str


class _ChunkRef(NamedTuple):
    start_time: int
    offset: int          # of the chunk record's content (after opcode and length)
    length: int


@dataclass
class Integrity:
    """What :func:`verify` found in one file."""

    path: Path
    size: int
    mcap: bool = True                          # starts with the MCAP magic
    header: bool = False
    footer: bool = False                       # footer and closing magic present
    chunks: int = 0
    damaged: list[Damage] = field(default_factory=list)   # damaged chunks and records
    cut_at: int | None = None                  # byte offset where the readable file ends early
    messages: int = 0                          # readable messages (intact chunks + unchunked)
    expected_messages: int | None = None       # from the summary's statistics, when readable
    intact_chunks: list[_ChunkRef] = field(default_factory=list)
    loose_offsets: list[int] = field(default_factory=list)   # schema/channel/message records outside chunks
    #                                                          (the summary's schemas and channels included)

    @property
    def ok(self) -> bool:
        """Nothing damaged, nothing missing, complete."""
        return self.mcap and self.header and self.footer and not self.damaged and self.cut_at is None \
            and not self.missing

    @property
    def missing(self) -> int:
        """Messages counted in the summary but not readable (0 when the summary is unreadable)."""
        if self.expected_messages is None:
            return 0
        return max(0, self.expected_messages - self.messages)

    def summary_line(self) -> str:
        """One line: what is wrong (or ``intact``)."""
        if not self.mcap:
            return "not an MCAP file (no MCAP magic at the start)"
        if self.ok:
            return f"intact ({self.messages} messages in {self.chunks} chunks)"
        parts = []
        if self.damaged:
            n_chunks = sum(1 for d in self.damaged if d.what.startswith("chunk"))
            parts.append(f"{len(self.damaged)} damaged record{'s' * (len(self.damaged) != 1)}"
                         + (f" ({n_chunks} chunk{'s' * (n_chunks != 1)})" if n_chunks else "")
                         + f", first at byte {self.damaged[0].offset}: {self.damaged[0].what}")
        if self.cut_at is not None:
            parts.append(f"cut at byte {self.cut_at} of {self.size}"
                         + ("" if self.header else " (inside the header)"))
        elif not self.footer:
            parts.append("no footer (the recording did not finish)")
        if self.missing:
            parts.append(f"{self.missing} of {self.expected_messages} messages unreadable")
        parts.append(f"{self.messages} readable messages")
        return "; ".join(parts)

    def lines(self) -> list[str]:
        """Every damaged place, one per line (for ``--info``)."""
        out = [f"integrity: {self.summary_line()}"]
        for d in self.damaged[:20]:
            out.append(f"  damaged at byte {d.offset}: {d.what}")
        if len(self.damaged) > 20:
            out.append(f"  ... {len(self.damaged) - 20} more")
        if not self.ok and self.mcap:
            out.append("  (`bkabem record --recover FILE FIXED.mcap` rebuilds a cut file; `bkabem replay "
                       "--allow-damaged` replays the intact part)")
        return out


def _read_exact(fh, n: int) -> bytes:
    data = fh.read(n)
    return data if data is not None else b""


def verify(path) -> Integrity:
    """Check ``path`` (see the module docstring). Raises only ``OSError`` (unreadable file)."""
    from io import BytesIO

    from mcap.data_stream import ReadDataStream
    from mcap.opcode import Opcode
    from mcap.records import Chunk, DataEnd, Footer, Statistics
    from mcap.stream_reader import breakup_chunk

    path = Path(path)
    size = path.stat().st_size
    res = Integrity(path=path, size=size)
    in_summary = False
    data_crc_bad = None
    with open(path, "rb") as fh:
        magic = _read_exact(fh, len(MAGIC))
        if magic != MAGIC:
            res.mcap = False
            return res
        crc = zlib.crc32(magic)
        pos = len(MAGIC)
        while True:
            head = _read_exact(fh, _RECORD_HEAD.size)
            if len(head) == 0:          # ended at a record boundary without a footer: "no footer"
                break
            if len(head) < _RECORD_HEAD.size:
                res.cut_at = pos
                break
            opcode, length = _RECORD_HEAD.unpack(head)
            if length > size - pos - _RECORD_HEAD.size:
                res.cut_at = pos
                break
            body = _read_exact(fh, length)
            content_offset = pos + _RECORD_HEAD.size
            if opcode == Opcode.DATA_END:
                try:
                    de = DataEnd.read(ReadDataStream(BytesIO(body)))
                    if de.data_section_crc not in (0, crc):
                        data_crc_bad = pos
                except Exception as exc:  # noqa: BLE001
                    res.damaged.append(Damage(pos, f"unreadable DataEnd record ({exc})"))
                in_summary = True
            elif not in_summary:
                crc = zlib.crc32(head, crc)
                crc = zlib.crc32(body, crc)
            if opcode == Opcode.HEADER:
                res.header = True
            elif opcode == Opcode.CHUNK:
                res.chunks += 1
                try:
                    ch = Chunk.read(ReadDataStream(BytesIO(body)))
                    n = sum(1 for r in breakup_chunk(ch, validate_crc=True) if type(r).__name__ == "Message")
                except Exception as exc:  # noqa: BLE001 - CRC mismatch, bad compression, garbage lengths
                    res.damaged.append(Damage(pos, f"chunk {res.chunks}: {_reason(exc)}"))
                else:
                    res.messages += n
                    res.intact_chunks.append(_ChunkRef(ch.message_start_time, content_offset, length))
            elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL) or (opcode == Opcode.MESSAGE and not in_summary):
                res.loose_offsets.append(pos)      # summary schemas/channels too: they define the topics of
                if opcode == Opcode.MESSAGE:       # intact chunks whose first message sat in a damaged one
                    res.messages += 1
            elif opcode == Opcode.STATISTICS:
                try:
                    res.expected_messages = int(Statistics.read(ReadDataStream(BytesIO(body))).message_count)
                except Exception as exc:  # noqa: BLE001
                    res.damaged.append(Damage(pos, f"unreadable statistics record ({exc})"))
            elif opcode == Opcode.FOOTER:
                try:
                    Footer.read(ReadDataStream(BytesIO(body)))
                except Exception as exc:  # noqa: BLE001
                    res.damaged.append(Damage(pos, f"unreadable footer ({exc})"))
                tail = _read_exact(fh, len(MAGIC))
                if tail == MAGIC:
                    res.footer = True
                else:
                    res.cut_at = pos + _RECORD_HEAD.size + length
                break
            pos += _RECORD_HEAD.size + length
    if data_crc_bad is not None and not res.damaged:
        res.damaged.append(Damage(data_crc_bad, "data section CRC mismatch (damage outside the chunks: schemas, "
                                                "channels or unchunked messages)"))
    if res.expected_messages is not None and res.expected_messages < res.messages:
        res.expected_messages = res.messages       # statistics of a rotated or appended file: not a loss
    return res


def _reason(exc: Exception) -> str:
    name = type(exc).__name__
    if name == "CRCValidationError":
        return "corrupted bytes (CRC mismatch)"
    if name in ("ZstdError", "LZ4FrameError", "RuntimeError") or "compress" in str(exc):
        return f"corrupted bytes (decompression failed: {exc})"[:200]
    return f"unreadable ({name}: {exc})"[:200]


def iter_intact(integrity: Integrity, wanted: set[str] | None = None,
                start_time_ns: int | None = None) -> Iterator[tuple]:
    """Yield ``(schema, channel, message)`` (``mcap.records``) from the intact chunks and loose records of a
    verified file, in log-time order (a merge over the chunks by start time; memory bounded by the chunks that
    overlap in time)."""
    from io import BytesIO

    from mcap.data_stream import ReadDataStream
    from mcap.opcode import Opcode
    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import breakup_chunk

    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    heap: list = []
    seq = 0
    with open(integrity.path, "rb") as fh:
        loose: list = []
        for off in integrity.loose_offsets:
            fh.seek(off)
            opcode, length = _RECORD_HEAD.unpack(fh.read(_RECORD_HEAD.size))
            stream = ReadDataStream(BytesIO(fh.read(length)))
            try:
                loose.append(Schema.read(stream) if opcode == Opcode.SCHEMA else Channel.read(stream)
                             if opcode == Opcode.CHANNEL else Message.read(stream, length))
            except Exception:  # noqa: BLE001 - a damaged loose record: the data-section CRC reported it
                continue
        for rec in loose:
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                channels[rec.id] = rec
        for rec in loose:
            if isinstance(rec, Message):
                heapq.heappush(heap, (rec.log_time, seq, rec))
                seq += 1
        refs = sorted(integrity.intact_chunks)
        for i, ref in enumerate(refs):
            fh.seek(ref.offset)
            ch = Chunk.read(ReadDataStream(BytesIO(fh.read(ref.length))))
            for rec in breakup_chunk(ch, validate_crc=True):
                if isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    channels[rec.id] = rec
                elif isinstance(rec, Message):
                    heapq.heappush(heap, (rec.log_time, seq, rec))
                    seq += 1
            horizon = refs[i + 1].start_time if i + 1 < len(refs) else None
            while heap and (horizon is None or heap[0][0] < horizon):
                _, _, m = heapq.heappop(heap)
                out = _resolve(m, schemas, channels, wanted, start_time_ns)
                if out is not None:
                    yield out
        while heap:
            _, _, m = heapq.heappop(heap)
            out = _resolve(m, schemas, channels, wanted, start_time_ns)
            if out is not None:
                yield out


def _resolve(m, schemas, channels, wanted, start_time_ns):
    ch = channels.get(m.channel_id)
    if ch is None or (wanted and ch.topic not in wanted):
        return None
    if start_time_ns is not None and m.log_time < start_time_ns:
        return None
    return schemas.get(ch.schema_id), ch, m
