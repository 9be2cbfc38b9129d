"""Integrity of an MCAP file, and the one bounded reader of its records.

:func:`verify` reads the file once, record by record at the framing level (opcode, length), so that one damaged
record does not hide the ones after it:

- every chunk is decompressed with a bound (:func:`chunk_records`): never more than it declares
  (``uncompressed_size``) and never more than :data:`MAX_RECORD_BYTES`; a chunk whose compressed data gives more
  or less than it declares (a zip bomb, a lying size), whose CRC does not match or whose inner records run past
  its end is damaged;
- after a damaged record (garbage over its opcode or length) the reader looks for the next intact chunk
  (:func:`_resync`), so the chunks after the damage are kept;
- the data section's CRC (``DataEnd``), the footer (its summary offsets point at the summary records, its summary
  CRC matches), the summary's chunk indexes (each points at a chunk that is there) and the end of the file
  (nothing after the closing magic: no second recording appended) are checked, and a cut is located;
- the message count of the footer's statistics is compared with the messages found in intact chunks.

:class:`Integrity` says what is damaged in one line (:meth:`Integrity.summary_line`) and in detail
(:meth:`Integrity.lines`), and keeps the intact chunks, the schemas, channels and metadata, so that
:func:`iter_intact` reads the good part in log-time order with the same bounds. Messages whose payload does not
decode are counted by the ROS layer (:func:`bkabem_ros.recording.mcap_read.check_messages`) into
:attr:`Integrity.bad_messages`: they are damage too.

Only the ``mcap`` package and its compressors are needed (no ROS). Units: bytes, ns.
"""

from __future__ import annotations

import heapq
import io
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, NamedTuple

MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
_CHUNK_HEAD = struct.Struct("<QQQII")            # start, end, uncompressed size, CRC, compression length
#: The largest record this reader loads and the largest chunk it decompresses [bytes]; bkabem's recorder writes
#: chunks of 1 MiB (``bkabem record --chunk-size``, at most this), rosbag2 of 768 kiB.
MAX_RECORD_BYTES = 64 << 20
#: Opcodes of the MCAP specification (0x80 and above: private records, skipped).
_KNOWN_OPCODES = frozenset(range(0x01, 0x10))
_RESYNC_WINDOW = 4 << 20

__all__ = ["DamagedRecording", "Integrity", "MAX_RECORD_BYTES", "chunk_records", "iter_intact", "verify"]


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


class _Bad(Exception):
    """A record that cannot be read as it claims; the message says why."""


class _Exact(io.BytesIO):
    """A record's bytes that refuse to be read past their end (mcap's parsers would silently read less)."""

    def read(self, n=-1):
        data = super().read(n)
        if n is not None and n >= 0 and len(data) != n:
            raise _Bad("a length inside the record runs past its end")
        return data


def _parse(cls, body: bytes, *args):
    """``cls.read`` (an ``mcap.records`` class) of a record's content, strictly."""
    from mcap.data_stream import ReadDataStream

    try:
        return cls.read(ReadDataStream(_Exact(body)), *args)
    except _Bad:
        raise
    except Exception as exc:  # noqa: BLE001 - bad UTF-8, struct errors, mcap's EndOfFile
        raise _Bad(f"unreadable {cls.__name__} record ({type(exc).__name__}: {exc})"[:200]) from None


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
    loose_offsets: list[int] = field(default_factory=list)   # message records outside chunks
    schemas: dict = field(default_factory=dict)              # id -> mcap.records.Schema (chunks, data, summary)
    channels: dict = field(default_factory=dict)             # id -> mcap.records.Channel
    metadata: dict = field(default_factory=dict)             # name -> {key: value}
    attachment_offsets: list[int] = field(default_factory=list)
    profile: str = ""
    library: str = ""
    bad_messages: int = 0                      # messages whose payload does not decode (the ROS layer counts them)
    bad_message_first: str = ""
    messages_checked: bool = False             # whether bad_messages was counted (every message decoded)
    skipped_chunks: int = 0                    # damaged chunks (their messages are lost)

    @property
    def ok(self) -> bool:
        """Nothing damaged, nothing missing, complete, every message decodable (as far as checked)."""
        return self.mcap and self.header and self.footer and not self.damaged and self.cut_at is None \
            and not self.missing and not self.bad_messages

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
        elif not self.header:
            parts.append("no header record after the magic (not an MCAP recording)")
        elif not self.footer:
            parts.append("no footer (the recording did not finish)")
        if self.missing:
            parts.append(f"{self.missing} of {self.expected_messages} messages unreadable")
        if self.bad_messages:
            parts.append(f"{self.bad_messages} message{'s that do' if self.bad_messages != 1 else ' that does'} not "
                         f"decode (first: {self.bad_message_first})")
        parts.append(f"{self.messages - self.bad_messages} readable messages")
        return "; ".join(parts)

    def lines(self) -> list[str]:
        """Every damaged place, one per line (for ``--info``)."""
        out = [f"integrity: {self.summary_line()}"]
        for d in self.damaged[:20]:
            out.append(f"  damaged at byte {d.offset}: {d.what}")
        if len(self.damaged) > 20:
            out.append(f"  ... {len(self.damaged) - 20} more")
        if not self.ok and self.mcap:
            out.append("  (`bkabem record --recover FILE FIXED.mcap` rebuilds the intact part; `bkabem replay "
                       "--allow-damaged` replays it)")
        return out


# --------------------------------------------------------------------------- chunks, bounded
def _decompress(compression: str, data: bytes, size: int) -> bytes:
    """The records of a chunk: exactly ``size`` bytes out of ``data``, never more (:data:`MAX_RECORD_BYTES`)."""
    if size > MAX_RECORD_BYTES:
        raise _Bad(f"declares {size} bytes uncompressed, more than the {MAX_RECORD_BYTES >> 20} MiB this reader "
                   f"decompresses")
    if compression == "":
        out = data
    elif compression == "zstd":
        import zstandard

        declared = zstandard.frame_content_size(data) if len(data) >= 4 else -1
        if declared not in (-1, size):
            raise _Bad(f"its zstd frame declares {declared} bytes, the chunk {size}")
        try:
            reader = zstandard.ZstdDecompressor().stream_reader(data)
            parts, got = [], 0
            while got <= size:
                piece = reader.read(size + 1 - got)
                if not piece:
                    break
                parts.append(piece)
                got += len(piece)
            out = b"".join(parts)
        except zstandard.ZstdError as exc:
            raise _Bad(f"corrupted bytes (decompression failed: {exc})"[:200]) from None
    elif compression == "lz4":
        import lz4.frame

        dec = lz4.frame.LZ4FrameDecompressor()
        try:
            out = dec.decompress(data, max_length=size + 1)
        except RuntimeError as exc:
            raise _Bad(f"corrupted bytes (decompression failed: {exc})"[:200]) from None
        if len(out) == size and not dec.eof:
            raise _Bad("corrupted bytes (decompression failed: the lz4 frame does not end)")
    else:
        raise _Bad(f"unknown compression {compression[:40]!r}")
    if len(out) != size:
        what = "more" if len(out) > size else f"{len(out)}"
        raise _Bad(f"its data decompresses to {what} bytes, not the {size} it declares")
    return out


def chunk_records(body: bytes, validate_crc: bool = True):
    """``(message_start_time, records)`` of a chunk record's content: the Schema, Channel and Message records
    (``mcap.records``) inside it, decompressed with the bounds of the module docstring. Raises :class:`_Bad`."""
    from mcap.opcode import Opcode
    from mcap.records import Channel, Message, Schema

    if len(body) < _CHUNK_HEAD.size:
        raise _Bad("shorter than a chunk header")
    start, _end, size, crc, n_comp = _CHUNK_HEAD.unpack_from(body)
    pos = _CHUNK_HEAD.size
    if n_comp > 64 or pos + n_comp + 8 > len(body):
        raise _Bad("its compression name runs past its end")
    try:
        compression = body[pos:pos + n_comp].decode("ascii")
    except UnicodeDecodeError:
        raise _Bad("its compression name is not text") from None
    pos += n_comp
    (n_data,) = struct.unpack_from("<Q", body, pos)
    pos += 8
    if n_data > len(body) - pos:
        raise _Bad("its data runs past its end")
    data = _decompress(compression, body[pos:pos + n_data], size)
    if validate_crc and crc != 0 and zlib.crc32(data) != crc:
        raise _Bad("corrupted bytes (CRC mismatch)")
    records, i = [], 0
    view = memoryview(data)
    while i < len(data):
        if len(data) - i < _RECORD_HEAD.size:
            raise _Bad(f"a record header at byte {i} of its records is cut")
        opcode, length = _RECORD_HEAD.unpack_from(data, i)
        i += _RECORD_HEAD.size
        if length > len(data) - i:
            raise _Bad(f"a record at byte {i - _RECORD_HEAD.size} of its records claims {length} bytes, past its end")
        rec = bytes(view[i:i + length])
        i += length
        if opcode == Opcode.MESSAGE:
            if length < 22:
                raise _Bad("a message record shorter than its header")
            records.append(_parse(Message, rec, length))
        elif opcode == Opcode.SCHEMA:
            records.append(_parse(Schema, rec))
        elif opcode == Opcode.CHANNEL:
            records.append(_parse(Channel, rec))
    return start, records


def _chunk_at(fh, offset: int, length: int):
    fh.seek(offset)
    return chunk_records(fh.read(length))


# --------------------------------------------------------------------------- verify
def verify(path) -> Integrity:
    """Check ``path`` (see the module docstring). Raises only ``OSError`` (unreadable file)."""
    path = Path(path)
    size = path.stat().st_size
    res = Integrity(path=path, size=size)
    with open(path, "rb") as fh:
        if fh.read(len(MAGIC)) != MAGIC:
            res.mcap = False
            return res
        _Scan(fh, res).run()
    if res.expected_messages is not None and res.expected_messages < res.messages:
        res.expected_messages = res.messages       # statistics of a rotated or appended file: not a loss
    return res


class _Scan:
    """One pass over the records of a file (:func:`verify`)."""

    def __init__(self, fh, res: Integrity):
        self.fh, self.res, self.size = fh, res, res.size
        self.crc = zlib.crc32(MAGIC)
        self.data_crc_bad: int | None = None
        self.data_end_next: int | None = None      # first byte after DataEnd: where the summary starts
        self.summary_crc = 0
        self.summary_records: list[tuple[int, int]] = []     # (offset, opcode) of the summary section
        self.chunk_starts: dict[int, int] = {}                # record offset -> record length (head included)
        self.chunk_indexes: list = []

    def damage(self, pos: int, what: str) -> None:
        self.res.damaged.append(Damage(pos, what))

    def run(self) -> None:
        from mcap.opcode import Opcode

        fh, res = self.fh, self.res
        pos = len(MAGIC)
        while True:
            fh.seek(pos)
            head = fh.read(_RECORD_HEAD.size)
            if len(head) == 0:              # ended at a record boundary without a footer: "no footer"
                break
            if len(head) < _RECORD_HEAD.size:
                res.cut_at = pos
                break
            opcode, length = _RECORD_HEAD.unpack(head)
            end = pos + _RECORD_HEAD.size + length
            if opcode not in _KNOWN_OPCODES and opcode < 0x80 or length > self.size - pos - _RECORD_HEAD.size:
                nxt = _resync(fh, pos + 1, self.size)
                if nxt is None:
                    res.cut_at = pos
                    break
                self.damage(pos, f"unreadable bytes up to byte {nxt} (opcode {opcode:#x}, length {length}); "
                                 f"reading on at the next intact chunk")
                self.crc = None
                pos = nxt
                continue
            if opcode == Opcode.FOOTER:
                self.footer(pos, head, length)
                break
            if opcode in (Opcode.ATTACHMENT,):
                if length <= MAX_RECORD_BYTES:
                    res.attachment_offsets.append(pos)
                self.account(opcode, head, pos, length)
                pos = end
                continue
            if length > MAX_RECORD_BYTES:
                nxt = _resync(fh, pos + 1, end)
                self.damage(pos, f"a record of {length} bytes, more than the {MAX_RECORD_BYTES >> 20} MiB this "
                                 f"reader loads")
                self.crc = None
                pos = nxt if nxt is not None else end
                continue
            body = fh.read(length)
            self.account(opcode, head, pos, length, body=body)
            try:
                self.record(opcode, pos, head, body)
            except _Bad as exc:
                prefix = f"chunk {res.chunks}: " if opcode == Opcode.CHUNK else ""
                self.damage(pos, prefix + str(exc))
                if opcode == Opcode.CHUNK:
                    res.skipped_chunks += 1
                    nxt = _resync(fh, pos + 1, end)       # garbage over its length: a real chunk inside it
                    if nxt is not None:
                        pos = nxt
                        continue
            pos = end
        if self.data_crc_bad is not None and not res.damaged:
            self.damage(self.data_crc_bad, "data section CRC mismatch (damage outside the chunks: schemas, channels "
                                           "or unchunked messages)")

    def account(self, opcode: int, head: bytes, pos: int, length: int, body: bytes | None = None) -> None:
        """The running CRCs of the data section (the records before DataEnd) and of the summary section (the
        records after it); ``body`` None: read from the file in blocks (an attachment of any size)."""
        from mcap.opcode import Opcode

        if opcode == Opcode.DATA_END:
            return
        in_summary = self.data_end_next is not None
        if not in_summary and self.crc is None:
            return
        crc = zlib.crc32(head, self.summary_crc if in_summary else self.crc)
        if body is not None:
            crc = zlib.crc32(body, crc)
        else:
            self.fh.seek(pos + _RECORD_HEAD.size)
            left = length
            while left > 0:
                block = self.fh.read(min(left, 1 << 20))
                if not block:
                    break
                crc = zlib.crc32(block, crc)
                left -= len(block)
        if in_summary:
            self.summary_crc = crc
        else:
            self.crc = crc

    def record(self, opcode: int, pos: int, head: bytes, body: bytes) -> None:
        from mcap.opcode import Opcode
        from mcap.records import Channel, ChunkIndex, DataEnd, Header, Metadata, Schema, Statistics

        res = self.res
        in_summary = self.data_end_next is not None
        if in_summary and opcode != Opcode.DATA_END:
            self.summary_records.append((pos, opcode))
        if opcode == Opcode.HEADER:
            h = _parse(Header, body)
            res.header, res.profile, res.library = True, h.profile, h.library
        elif opcode == Opcode.CHUNK:
            res.chunks += 1
            self.chunk_starts[pos] = _RECORD_HEAD.size + len(body)
            start, records = chunk_records(body)
            for r in records:
                if isinstance(r, Schema):
                    res.schemas.setdefault(r.id, r)
                elif isinstance(r, Channel):
                    res.channels.setdefault(r.id, r)
                else:
                    res.messages += 1
            res.intact_chunks.append(_ChunkRef(start, pos + _RECORD_HEAD.size, len(body)))
        elif opcode == Opcode.SCHEMA:
            s = _parse(Schema, body)
            res.schemas.setdefault(s.id, s)
        elif opcode == Opcode.CHANNEL:
            c = _parse(Channel, body)
            res.channels.setdefault(c.id, c)
        elif opcode == Opcode.MESSAGE and not in_summary:
            if len(body) < 22:
                raise _Bad("a message record shorter than its header")
            res.loose_offsets.append(pos)
            res.messages += 1
        elif opcode == Opcode.METADATA and not in_summary:
            m = _parse(Metadata, body)
            res.metadata[m.name] = dict(m.metadata)
        elif opcode == Opcode.DATA_END:
            de = _parse(DataEnd, body)
            if self.crc is not None and de.data_section_crc not in (0, self.crc):
                self.data_crc_bad = pos
            self.data_end_next = pos + _RECORD_HEAD.size + len(body)
        elif opcode == Opcode.STATISTICS:
            res.expected_messages = int(_parse(Statistics, body).message_count)
        elif opcode == Opcode.CHUNK_INDEX:
            ci = _parse(ChunkIndex, body)
            if self.chunk_starts.get(ci.chunk_start_offset) != ci.chunk_length:
                raise _Bad(f"the summary's chunk index points at byte {ci.chunk_start_offset} ({ci.chunk_length} "
                           f"bytes), where no such chunk is")

    def footer(self, pos: int, head: bytes, length: int) -> None:
        from mcap.opcode import Opcode
        from mcap.records import Footer

        res, fh = self.res, self.fh
        body = fh.read(length)
        try:
            f = _parse(Footer, body)
        except _Bad as exc:
            self.damage(pos, f"unreadable footer ({exc})")
            f = None
        tail = fh.read(len(MAGIC))
        if tail != MAGIC:
            res.cut_at = pos + _RECORD_HEAD.size + length
            return
        res.footer = True
        after = pos + _RECORD_HEAD.size + length + len(MAGIC)
        if after < self.size:
            self.damage(after, f"{self.size - after} bytes after the end of the recording (a second recording "
                               f"appended?)")
        if f is None:
            return
        first = self.summary_records[0][0] if self.summary_records else 0
        if f.summary_start != first:
            self.damage(pos, f"the footer's summary offset {f.summary_start} is not where the summary starts "
                             f"({first or 'no summary'})")
        offsets = [p for p, op in self.summary_records if op == Opcode.SUMMARY_OFFSET]
        if f.summary_offset_start not in ((offsets[0] if offsets else 0),):
            self.damage(pos, f"the footer's summary-offset offset {f.summary_offset_start} points at no summary "
                             f"offset record")
        if f.summary_crc != 0 and f.summary_start == first:
            crc = zlib.crc32(body[:16], zlib.crc32(head, self.summary_crc))
            if crc != f.summary_crc:
                self.damage(pos, "summary section CRC mismatch")


def _resync(fh, start: int, stop: int) -> int | None:
    """Offset of the first intact chunk record (or DataEnd) in ``[start, stop)`` of the file, or None: where
    reading goes on after garbage over a record's opcode or length."""
    from mcap.opcode import Opcode

    pos = start
    while pos < stop:
        fh.seek(pos)
        window = fh.read(min(_RESYNC_WINDOW, stop - pos) + _RECORD_HEAD.size + _CHUNK_HEAD.size)
        i = 0
        limit = min(_RESYNC_WINDOW, stop - pos)
        while i < limit:
            hits = [j for j in (window.find(bytes([Opcode.CHUNK]), i), window.find(bytes([Opcode.DATA_END]), i))
                    if 0 <= j < limit]
            if not hits:
                break
            j = min(hits)
            if _plausible(fh, pos + j, window[j:j + _RECORD_HEAD.size]):
                return pos + j
            i = j + 1
        pos += limit
    return None


def _plausible(fh, at: int, head: bytes) -> bool:
    from mcap.opcode import Opcode

    if len(head) < _RECORD_HEAD.size:
        return False
    opcode, length = _RECORD_HEAD.unpack(head)
    size = fh.seek(0, io.SEEK_END)
    if opcode == Opcode.DATA_END:
        return length == 4 and at + _RECORD_HEAD.size + 4 < size
    if not _CHUNK_HEAD.size < length <= min(MAX_RECORD_BYTES, size - at - _RECORD_HEAD.size):
        return False
    try:
        _chunk_at(fh, at + _RECORD_HEAD.size, length)
    except _Bad:
        return False
    return True


# --------------------------------------------------------------------------- reading the intact part
def iter_intact(integrity: Integrity, wanted: set[str] | None = None,
                start_time_ns: int | None = None) -> Iterator[tuple]:
    """Yield ``(schema, channel, message)`` (``mcap.records``) from the intact chunks and loose records of a
    verified file, in log-time order (a merge over the chunks by start time; memory bounded by the chunks that
    overlap in time)."""
    from mcap.records import Channel, Message, Schema

    schemas: dict[int, Schema] = dict(integrity.schemas)
    channels: dict[int, Channel] = dict(integrity.channels)
    heap: list = []
    seq = 0
    with open(integrity.path, "rb") as fh:
        for off in integrity.loose_offsets:
            fh.seek(off)
            _opcode, length = _RECORD_HEAD.unpack(fh.read(_RECORD_HEAD.size))
            try:
                rec = _parse(Message, fh.read(length), length)
            except _Bad:
                continue
            heapq.heappush(heap, (rec.log_time, seq, rec))
            seq += 1
        refs = sorted(integrity.intact_chunks)
        for i, ref in enumerate(refs):
            try:
                _, records = _chunk_at(fh, ref.offset, ref.length)
            except _Bad:                       # changed since verify: nothing more from this chunk
                continue
            for rec in records:
                if isinstance(rec, Message):
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


def read_attachment(integrity: Integrity, offset: int):
    """The ``mcap.records.Attachment`` at ``offset`` (one of :attr:`Integrity.attachment_offsets`), or None."""
    from mcap.records import Attachment

    with open(integrity.path, "rb") as fh:
        fh.seek(offset)
        _opcode, length = _RECORD_HEAD.unpack(fh.read(_RECORD_HEAD.size))
        try:
            return _parse(Attachment, fh.read(length))
        except _Bad:
            return None


def _resolve(m, schemas, channels, wanted, start_time_ns):
    ch = channels.get(m.channel_id)
    if ch is None or (wanted and ch.topic not in wanted):
        return None
    if start_time_ns is not None and m.log_time < start_time_ns:
        return None
    return schemas.get(ch.schema_id), ch, m
