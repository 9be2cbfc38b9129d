"""``bkabem_msgs/msg/VibrationWaveform`` straight to its CDR bytes, without a message object.

A fleet host publishes 4 waveform messages per machine and chunk (100 machines: 4 000 a second). Building each as a
Python message object (``msgs.waveform_message``: a Header, a Time, five strings, a list of channel names, an
``array.array`` copy of 20 kB of samples) and serialising it with ``rclpy.serialization.serialize_message`` took
about half of a fleet process's CPU (bench/profile_fleet.py). Most of that message never changes within a stream:
the frame, machine id, location, quantity, unit, channel names and sample rate. :class:`WaveformEncoder` encodes
that part once per stream; each chunk then writes only the stamp, the first sample index, the shaft speed and the
samples (one ``float32`` conversion) behind it, then the chunk's ``ground_truth`` (bkabem_msgs 0.2.0), encoded by
:class:`TruthEncoder` (rclpy's serialiser on a small template, once per chunk for the 4 streams).
``Publisher.publish`` accepts the bytes as they are (rclpy hands them to ``rmw_publish_serialized_message``);
subscribers receive the same message as before.

The layout is the one Fast DDS's ``rmw_fastrtps`` writes for ROS 2 (plain CDR, XCDR version 1, little endian):
a 4-byte encapsulation header ``00 01 00 00``, then the fields in order, each aligned to its own size counted from
the end of that header; strings are a ``uint32`` length that includes the terminating NUL, the bytes, the NUL;
sequences a ``uint32`` count and the elements. ``tests/integration/test_msgs.py`` checks that the bytes equal
``serialize_message`` of the same message for many field values (string lengths that move every alignment), so a
change of the message definition or of the rmw's encoding fails there, not silently on the wire.
"""

from __future__ import annotations

import math
import struct
from typing import Sequence

import numpy as np

#: CDR little endian (XCDR1), options 0: what rmw_fastrtps writes in front of every ROS 2 message.
ENCAPSULATION = b"\x00\x01\x00\x00"


class _Writer:
    """Little-endian CDR writer; positions are counted after the encapsulation header (the CDR origin)."""

    def __init__(self):
        self.buf = bytearray()
        self.padding: list[tuple[int, int]] = []   # (start, end) of every alignment gap

    def align(self, n: int) -> None:
        pad = -len(self.buf) % n
        if pad:
            self.padding.append((len(self.buf), len(self.buf) + pad))
            self.buf += b"\x00" * pad

    def u32(self, v: int) -> None:
        self.align(4)
        self.buf += struct.pack("<I", v)

    def string(self, s: str) -> None:
        b = s.encode("utf-8")
        if b"\x00" in b:
            raise ValueError(f"string {s!r} contains a NUL character")
        self.u32(len(b) + 1)
        self.buf += b + b"\x00"

    def value(self, type_name: str, v) -> None:
        """One field of a ROS message: a primitive, a string, a nested message, or a sequence of those (used to
        find the alignment padding of a message; the bytes on the wire come from rclpy's serialiser)."""
        if type_name.startswith("sequence<"):
            inner = type_name[len("sequence<"):-1]
            if "," in inner:
                raise ValueError(f"bounded sequence {type_name!r} is not supported")
            self.u32(len(v))
            for e in v:
                self.value(inner, e)
        elif type_name == "string":
            self.string(v)
        elif type_name in _PRIMITIVES:
            fmt = _PRIMITIVES[type_name]
            self.align(struct.calcsize(fmt))
            self.buf += struct.pack("<" + fmt, v)
        elif "/" in type_name and "[" not in type_name:
            for name, t in v.get_fields_and_field_types().items():
                self.value(t, getattr(v, name))
        else:
            raise ValueError(f"field type {type_name!r} is not supported")


#: struct formats of the primitive ROS field types bkabem messages use.
_PRIMITIVES = {"boolean": "?", "octet": "B", "uint8": "B", "int8": "b", "uint16": "H", "int16": "h",
               "uint32": "I", "int32": "i", "uint64": "Q", "int64": "q", "float": "f", "double": "d"}


class TruthEncoder:
    """The CDR bytes of a ``GroundTruth`` message as the last field of a ``VibrationWaveform`` whose ground truth
    starts at byte ``offset`` (counted from the CDR origin, after the encapsulation header).

    The truth changes every chunk (its scenario time, the defects' strike frequencies), so it is encoded once per
    chunk: by rclpy's C serialiser (~50 us), on a small template waveform whose ground truth sits at the same
    alignment, and the bytes from the truth on are taken. The 4 streams of a machine get the same truth object in
    one chunk: the result is kept per alignment for that object (``is``, not ``==``), so a chunk costs one or two
    serialisations, not four (a Python field walk cost ~260 us per message: 1 ms per machine and chunk).

    Parameters
    ----------
    offset : int
        Position of the truth's first byte from the CDR origin; only ``offset % 8`` matters (the largest alignment).
    """

    _last: dict = {}          # offset % 8 -> (truth object, its bytes): shared by all streams of this process

    def __init__(self, offset: int):
        self.offset = int(offset) % 8
        self._template, self._start = _truth_template(self.offset)
        self._truth = None

    def encode(self, truth) -> bytes:
        hit = TruthEncoder._last.get(self.offset)
        if hit is not None and hit[0] is truth:
            self._truth = truth
            return hit[1]
        from rclpy.serialization import serialize_message

        self._template.ground_truth = truth
        raw = serialize_message(self._template)[self._start:]
        TruthEncoder._last[self.offset] = (truth, raw)
        self._truth = truth
        return raw

    @property
    def padding(self) -> list[tuple[int, int]]:
        """(start, end) alignment gaps of the last truth's bytes, relative to their first byte (for comparisons
        with ``serialize_message``, whose padding bytes are not initialised; walks the fields in Python)."""
        if self._truth is None:
            return []
        w = _Writer()
        w.buf += b"\x00" * self.offset
        w.value("message/GroundTruth", self._truth)
        return [(a - self.offset, b - self.offset) for a, b in w.padding]


def _truth_template(offset: int):
    """A ``VibrationWaveform`` (one channel of 0 or 1 samples, empty strings) whose ground truth starts at
    ``offset % 8``, and the index of that byte in its serialised form (encapsulation header included)."""
    from bkabem_msgs.msg import VibrationWaveform

    for n in (0, 1):
        w = _Writer()
        w.buf += b"\x00" * 8                                  # header.stamp
        for _ in range(5):                                    # frame_id, machine_id, location, quantity, unit
            w.string("")
        w.u32(1)
        w.string("c")                                         # channel_names
        w.align(8)
        w.buf += b"\x00" * 24                                 # sample_rate, first_sample_index, shaft_speed
        w.u32(n)                                              # samples_per_channel
        w.u32(n)                                              # data: count, samples
        w.buf += b"\x00" * (4 * n)
        if len(w.buf) % 8 == offset % 8:
            msg = VibrationWaveform(channel_names=["c"], samples_per_channel=n, data=[0.0] * n)
            return msg, len(ENCAPSULATION) + len(w.buf)
    raise ValueError(f"offset: {offset} is not a multiple of 4")


class WaveformEncoder:
    """The CDR bytes of the ``VibrationWaveform`` messages of one stream (fixed strings, rate and channels).

    Parameters
    ----------
    machine_id, location, quantity, unit, frame_id : str
        The message's constant strings (the same values :func:`bkabem_ros.messages.convert.waveform_message` writes).
    channel_names : sequence of str
        One name per channel.
    sample_rate : float
        Samples per second and channel [Hz], > 0 and finite.
    samples_per_channel : int
        Samples of each channel in every message of the stream.
    """

    def __init__(self, *, machine_id: str, location: str, quantity: str, unit: str, channel_names: Sequence[str],
                 sample_rate: float, samples_per_channel: int, frame_id: str):
        sample_rate = float(sample_rate)
        if not (math.isfinite(sample_rate) and sample_rate > 0.0):
            raise ValueError(f"sample_rate: {sample_rate!r} must be finite and > 0")
        n = int(samples_per_channel)
        if n < 0:
            raise ValueError(f"samples_per_channel: {n} must be >= 0")
        names = [str(c) for c in channel_names]
        w = _Writer()
        w.buf += b"\x00" * 8                      # header.stamp: sec (int32), nanosec (uint32), per message
        w.string(str(frame_id))
        for s in (machine_id, location, quantity, unit):
            w.string(str(s))
        w.u32(len(names))
        for c in names:
            w.string(c)
        w.align(8)
        w.buf += struct.pack("<d", sample_rate)
        self._tail_at = len(w.buf)                # first_sample_index (u64), shaft_speed (f64): per message
        w.buf += b"\x00" * 16
        w.u32(n)
        w.u32(len(names) * n)                     # data: count, then the float32 samples (aligned 4 already)
        self._head = bytes(w.buf[:self._tail_at])
        self._after = bytes(w.buf[self._tail_at + 16:])
        self._padding = [(a + len(ENCAPSULATION), b + len(ENCAPSULATION)) for a, b in w.padding]
        self.channels = len(names)
        self.samples_per_channel = n
        self._truth_at = len(ENCAPSULATION) + len(w.buf) + 4 * len(names) * n
        self._truth = TruthEncoder(self._truth_at - len(ENCAPSULATION))
        self.size = len(ENCAPSULATION) + len(w.buf) + 4 * len(names) * n + len(self._truth.encode(_empty_truth()))

    @property
    def padding(self) -> list[tuple[int, int]]:
        """(start, end) byte ranges of the last encoded message that are alignment padding (zeros here; Fast CDR
        leaves whatever its buffer held there, so a byte comparison with ``serialize_message`` must skip them)."""
        return self._padding + [(self._truth_at + a, self._truth_at + b) for a, b in self._truth.padding]

    def encode(self, data, *, first_sample_index: int, shaft_speed: float, stamp_ns: int, ground_truth=None) -> bytes:
        """CDR bytes of one message.

        Parameters
        ----------
        data : array_like, shape (channels, samples_per_channel)
            Samples in the stream's unit, channel-major; converted to float32 like ``waveform_message``.
        first_sample_index : int
            Index of the first sample in the stream, >= 0.
        shaft_speed : float
            Shaft speed at the first sample [rad/s], finite.
        stamp_ns : int
            Time of the first sample [ns since the epoch, ROS time], >= 0.
        ground_truth : bkabem_msgs.msg.GroundTruth, optional
            The machine's ground truth at the first sample (default: an empty one, ``available`` false).
        """
        a = np.asarray(data)
        if a.shape != (self.channels, self.samples_per_channel):
            raise ValueError(f"data: shape {a.shape}, the stream has {(self.channels, self.samples_per_channel)}")
        idx = int(first_sample_index)
        if idx < 0 or idx != first_sample_index:
            raise ValueError(f"first_sample_index: {first_sample_index!r} must be an int >= 0")
        speed = float(shaft_speed)
        if not math.isfinite(speed):
            raise ValueError(f"shaft_speed: {shaft_speed!r} must be finite")
        ns = int(stamp_ns)
        if ns < 0:
            raise ValueError(f"stamp: {ns} ns is before the epoch")
        sec, nsec = divmod(ns, 1_000_000_000)
        return b"".join((ENCAPSULATION, struct.pack("<iI", sec, nsec), self._head[8:],
                         struct.pack("<Qd", idx, speed), self._after,
                         np.ascontiguousarray(a, dtype="<f4").tobytes(),
                         self._truth.encode(_empty_truth() if ground_truth is None else ground_truth)))


def _empty_truth():
    from bkabem_msgs.msg import GroundTruth

    return GroundTruth()


def with_stamp(raw: bytes, stamp_ns: int) -> bytes:
    """The CDR bytes ``raw`` of a message whose first field is a ``std_msgs/Header`` (every bkabem message), with
    ``header.stamp`` set to ``stamp_ns`` [ns since the epoch, >= 0]: the stamp is bytes 4..12 (``int32 sec``,
    ``uint32 nanosec`` right after the encapsulation header), so nothing else is decoded or re-encoded."""
    if raw[:4] != ENCAPSULATION or len(raw) < 12:
        raise ValueError("not a little-endian CDR message with a header first")
    ns = int(stamp_ns)
    if ns < 0:
        raise ValueError(f"stamp: {ns} ns is before the epoch")
    sec, nsec = divmod(ns, 1_000_000_000)
    return b"".join((raw[:4], struct.pack("<iI", sec, nsec), raw[12:]))
