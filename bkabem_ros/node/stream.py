"""The node's stream: its publishers, the sample clock, and each chunk made one ahead and published when due.

Sample ``i`` of the stream is at ``t0 + i / sample_rate`` (node clock). A chunk is synthesised when its first
sample is due and published when its last sample is due (the timing is described in
:mod:`bkabem_ros.node.vibration_node`); :class:`ChunkStream` holds the chunk waiting for its time, stamps it from its
sample index, and publishes the topic groups of a chunk in their order: the four waveforms first (CDR bytes encoded
straight from the samples), then the spectra and fault frequencies when they are due.

No rclpy at import; the node passes itself.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from bkabem_core.model.vocabulary import BEARINGS
from bkabem_ros.node.source import CHANNELS, QUANTITIES, TWO_PI, WAVEFORM_TYPE

__all__ = ["N_WAVEFORMS", "ChunkStream", "stream_qos"]

N_WAVEFORMS = len(BEARINGS) * len(QUANTITIES)   # waveform messages per chunk (first in a chunk's items)


def stream_qos(kind: str, depth: int):
    """The QoS of the published topics: ``"reliable"`` (volatile) or else the sensor-data profile, keep last
    ``depth``."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

    if kind == "reliable":
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.VOLATILE)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=qos_profile_sensor_data.reliability,
                      durability=qos_profile_sensor_data.durability)


@dataclass
class _Prepared:
    """A chunk synthesised ahead of its publication time, with its messages built."""

    index: int
    stamp_ns: int
    due_ns: int
    speed_rad_s: float
    items: list  # (publisher, type_name, msg or None (waveforms: see _message), serialized CDR bytes); waveforms first


def _message(pub, msg, raw: bytes):
    """The message object of a prepared item: ``msg``, or the CDR bytes deserialised (waveforms have no object)."""
    if msg is not None:
        return msg
    from rclpy.serialization import deserialize_message

    return deserialize_message(raw, pub.msg_type)


class ChunkStream:
    """The publishers of one node and the chunk that waits for its publication time.

    Parameters
    ----------
    node : VibrationNode
        The node (its clock, logger, parameters, machine source, speed, band watch, diagnostics and sinks).
    qos : rclpy.qos.QoSProfile
        The QoS of every published topic.

    Attributes
    ----------
    pending : _Prepared or None
        The chunk synthesised and waiting to be published (None before the start).
    t0_ns : int or None
        Node-clock time of sample 0 [ns].
    next_spectrum_ns : int
        Stamp from which the next spectra are due at ``spectrum_rate`` [ns].
    lateness_ns, start_lateness_ns : deque of int
        Per published chunk: waveforms handed to DDS minus due, publication started minus due [ns].
    """

    def __init__(self, node, qos):
        from bkabem_msgs.msg import BearingFaultFrequencies, VibrationSpectrum, VibrationWaveform

        self.node = node
        # rclpy gives every publisher two QoS event handlers (incompatible QoS / type warnings) that each executor
        # cycle adds to its wait set; with many nodes in one executor that is most of the CPU. Only the first
        # waveform publisher keeps them (subscribers report incompatibilities on their side as well).
        from rclpy.event_handler import PublisherEventCallbacks

        quiet = PublisherEventCallbacks(use_default_callbacks=False)

        def pub(msg_type, name):
            return node.create_publisher(msg_type, name, qos, event_callbacks=None if not self._wave_pub else quiet)

        self._wave_pub = {}
        for b in BEARINGS:
            for q in QUANTITIES:
                self._wave_pub[(b, q)] = pub(VibrationWaveform, f"vibration/{b}/{q}")
        from bkabem_ros.messages.cdr import WaveformEncoder
        from bkabem_ros.messages.convert import SI_UNITS

        self._wave_cdr = {(b, q): WaveformEncoder(machine_id=node.machine_id, location=b, quantity=q,
                                                  unit=SI_UNITS[q], channel_names=CHANNELS,
                                                  sample_rate=node.sample_rate,
                                                  samples_per_channel=node.samples_per_chunk, frame_id=node._frame[b])
                          for b in BEARINGS for q in QUANTITIES}
        self._spec_pub = {b: pub(VibrationSpectrum, f"vibration/{b}/spectrum") for b in BEARINGS}
        self._ff_pub = pub(BearingFaultFrequencies, "vibration/fault_frequencies")

        self.t0_ns: int | None = None
        self.pending: _Prepared | None = None
        self.primed: _Prepared | None = None   # chunk 0 made ahead by prime(), stamped from t0 = 0
        self._last_spectrum_speed: float | None = None
        self.next_spectrum_ns = 0
        self.spectra = 0
        self.lateness_ns: deque[int] = deque(maxlen=100_000)        # waveforms handed to DDS - due
        self.start_lateness_ns: deque[int] = deque(maxlen=100_000)  # publication started - due
        self.published_chunks = 0
        self.reanchors = 0
        self._last_now_ns = 0

    def next_index(self) -> int:
        """First sample of the next chunk still to be synthesised (where a change of the machine can begin)."""
        return 0 if self.pending is None else self.pending.index + self.node.samples_per_chunk

    def begin(self, now: int) -> None:
        """Start at node-clock time ``now`` [ns]: chunk 0 synthesised now, or the primed one moved to t0 = now."""
        self._last_now_ns = now
        primed, self.primed = self.primed, None
        if primed is None:
            self.pending = self.prepare(0, now)
        else:                                   # chunk 0 made by prime() with t0 = 0: move it to t0 = now
            self.t0_ns = now
            self._restamp(primed)
            self.next_spectrum_ns += now
            self.pending = primed

    # ------------------------------------------------------------------ production
    def prepare(self, index: int, t0_ns: int | None = None) -> _Prepared:
        """Synthesise the chunk that starts at sample ``index`` and build its messages.

        Called when the chunk's first sample is due (one chunk ahead of its publication). The last good speed
        becomes the speed at the *end* of this chunk; the synthesiser ramps linearly to it from the previous
        chunk's end speed (angle and speed continuous), so ``shaft_speed`` (first sample) is that previous speed.
        A scenario with a speed profile gives that speed instead. A change of the machine (a scenario state, a new
        scenario, defect_depth) takes effect here, at this chunk's first sample, when its model is ready.
        """
        node = self.node
        if t0_ns is not None:
            self.t0_ns = t0_ns
        n = node.samples_per_chunk
        stamp = self.t0_ns + int(round(index * 1e9 / node.sample_rate))
        due = self.t0_ns + int(round((index + n) * 1e9 / node.sample_rate))
        src = node.source
        chunk, truth = src.next_chunk(index, node.speed_rad_s / TWO_PI)
        if int(chunk.first_sample_index) != index:
            raise RuntimeError(f"synth produced index {chunk.first_sample_index}, expected {index}")
        node._band.check(src.synth, src.model, max(float(chunk.shaft_speed_hz), float(chunk.shaft_speed_end_hz)),
                         node._machine_label)
        node._diagnostics.add_chunk(chunk)
        speed = float(chunk.shaft_speed_hz) * TWO_PI          # at the first sample
        # the waveforms straight to CDR (waveform_cdr: the constant part of each stream encoded once); message
        # objects only for sinks (recorders, viewers), made from the same bytes when one asks for them
        items = []
        for b in BEARINGS:
            for q in QUANTITIES:
                raw = self._wave_cdr[(b, q)].encode(chunk.samples[chunk.rows(b, q)], first_sample_index=index,
                                                    shaft_speed=speed, stamp_ns=stamp,
                                                    ground_truth=truth)
                items.append((self._wave_pub[(b, q)], WAVEFORM_TYPE, None, raw))
        rate = float(node._live["spectrum_rate"])
        if (src.changed or self._last_spectrum_speed is None or speed != self._last_spectrum_speed
                or (rate > 0 and stamp >= self.next_spectrum_ns)):
            # spectra and fault frequencies (at most spectrum_rate + speed changes per second): message objects,
            # serialised now, off the publication path
            from rclpy.serialization import serialize_message

            for bearing, type_name, msg in src.spectrum_messages(chunk, stamp, truth):
                pub = self._ff_pub if bearing is None else self._spec_pub[bearing]
                items.append((pub, type_name, msg, serialize_message(msg)))
            self.spectra += 1
            self._last_spectrum_speed = speed
            if rate > 0:
                self.next_spectrum_ns = stamp + int(1e9 / rate)
        return _Prepared(index=index, stamp_ns=stamp, due_ns=due, speed_rad_s=speed, items=items)

    # ------------------------------------------------------------------ publication
    def on_tick(self) -> None:
        """The chunk timer: publish every chunk that is due (a late timer catches up), synthesise the next."""
        node = self.node
        now = node.get_clock().now().nanoseconds
        pend = self.pending
        period = node.chunk_ns
        if now < self._last_now_ns - period:      # ROS time jumped back (sim time loop): re-anchor
            self._reanchor(now)
            pend = self.pending
        self._last_now_ns = now
        behind = (now - pend.due_ns) / period
        if behind > 50:                            # paused or a big jump forward: do not synthesise a backlog
            self._reanchor(now)
            pend = self.pending
        half = period / 2
        while pend.due_ns <= now + half:
            self.start_lateness_ns.append(node.get_clock().now().nanoseconds - pend.due_ns)
            items = pend.items
            for pub, _type_name, _msg, raw in items[:N_WAVEFORMS]:
                pub.publish(raw)
            self.lateness_ns.append(node.get_clock().now().nanoseconds - pend.due_ns)
            for pub, _type_name, _msg, raw in items[N_WAVEFORMS:]:      # spectra, fault frequencies
                pub.publish(raw)
            self.published_chunks += 1
            if node._sinks:
                for pub, type_name, msg, raw in items:
                    node._emit(pub.topic_name, type_name, _message(pub, msg, raw), pend.stamp_ns)
            pend = self.pending = self.prepare(pend.index + node.samples_per_chunk)
            now = node.get_clock().now().nanoseconds

    def _reanchor(self, now: int) -> None:
        """Keep the index, move t0 so that the pending chunk starts now (after a clock jump or stall)."""
        pend = self.pending
        old = pend.stamp_ns
        self.t0_ns = now - int(round(pend.index * 1e9 / self.node.sample_rate))
        self._restamp(pend)
        self.next_spectrum_ns = now
        self.reanchors += 1
        self.node.get_logger().warning(f"clock jumped from {old / 1e9:.6f} s to {now / 1e9:.6f} s: stamps "
                                       f"re-anchored at sample {pend.index} (indices stay continuous)")

    def _restamp(self, pend: _Prepared) -> None:
        """Stamp and due time of a prepared chunk (and its messages) from the current ``t0_ns``: the stamp is
        written into the CDR bytes in place of the old one (every message starts with its header), and into the
        message object where there is one."""
        from bkabem_ros.messages.cdr import with_stamp
        from bkabem_ros.messages.convert import time_msg

        rate = self.node.sample_rate
        pend.stamp_ns = self.t0_ns + int(round(pend.index * 1e9 / rate))
        pend.due_ns = self.t0_ns + int(round((pend.index + self.node.samples_per_chunk) * 1e9 / rate))
        items = []
        for pub, type_name, msg, raw in pend.items:
            if msg is not None:
                msg.header.stamp = time_msg(pend.stamp_ns)
            items.append((pub, type_name, msg, with_stamp(raw, pend.stamp_ns)))
        pend.items = items
