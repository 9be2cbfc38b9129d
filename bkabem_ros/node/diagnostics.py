"""The node's health on ``/diagnostics`` (REP 107): a ``diagnostic_msgs/msg/DiagnosticArray`` once a second.

Standard ROS tools read it as they read any driver's (``rqt_runtime_monitor``, the ``diagnostic_aggregator``,
Foxglove's diagnostics panel); the node's sinks get it too, so ``--record`` and ``bkabem record`` put it into the
MCAP with the rest. Each status is named ``<node>: <part>`` (the node's fully qualified name) with the machine id
as ``hardware_id``, and carries its numbers as ``KeyValue`` pairs (units in the keys):

``stream``
    The chunks on time: OK when no chunk of the last report period was handed to DDS a chunk period or more after
    its last sample was due; WARN when some were (how many, the worst lateness). Before the first speed arrives
    (``wait_for_speed``) OK, saying so.
``model``
    The machine in the signal: case and hash, the scenario and its state, lines; WARN when a scenario state came
    late or a switch to the next model has waited longer than :data:`SWITCH_WAIT_S`.
``band limit``
    The sample rate against the lines at the current speed (:func:`bkabem_ros.node.band.band_status`): OK, or WARN
    when a case that caps its lines loses some of them to the sample rate.
``DE bearing``, ``NDE bearing``
    ISO 10816/20816 velocity RMS (10-1000 Hz, mm/s) of the published housing acceleration over the last second,
    vertical and horizontal, and the zone of the larger (:data:`bkabem_core.analysis.condition.DEFAULT_ISO_ZONES`):
    zones A and B OK, C WARN (unsatisfactory for long-term operation), D ERROR (vibration that causes damage).

No rclpy at import; the node passes itself. Units: SI except where a key names another (mm/s, ms, Hz).
"""

from __future__ import annotations

import math
import time
from collections import deque

import numpy as np

from bkabem_core.analysis.condition import DEFAULT_ISO_ZONES, ISO_ZONE_SETS, iso_velocity_rms_mm_s, iso_zone
from bkabem_core.model.vocabulary import BEARINGS
from bkabem_ros.node.band import band_status

__all__ = ["DIAGNOSTICS_TOPIC", "DIAGNOSTICS_TYPE", "PERIOD_S", "NodeDiagnostics"]

DIAGNOSTICS_TOPIC = "/diagnostics"
DIAGNOSTICS_TYPE = "diagnostic_msgs/msg/DiagnosticArray"
#: Seconds between reports (the ``diagnostic_updater`` default) and of acceleration the ISO velocity is taken over.
PERIOD_S = 1.0
#: A switch to the next model that waits longer than this is reported (WARN) [s].
SWITCH_WAIT_S = 10.0
_LEVEL = {"OK": 0, "WARN": 1, "ERROR": 2, "STALE": 3}
_ZONE_LEVEL = {"A": "OK", "B": "OK", "C": "WARN", "D": "ERROR", "?": "OK"}


class NodeDiagnostics:
    """Publishes the node's :class:`DiagnosticArray` every :data:`PERIOD_S` (module docstring).

    Parameters
    ----------
    node : VibrationNode
        The node (its clock, logger, publishers, stats, source and sinks).
    """

    def __init__(self, node):
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.clock import Clock, ClockType
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        self.node = node
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
        self.pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, qos)
        self.name = node.get_fully_qualified_name().lstrip("/") or node.get_name()
        self._acc: dict[str, deque] = {b: deque() for b in BEARINGS}
        self._acc_n = {b: 0 for b in BEARINGS}
        self._late_seen = 0
        self._chunks_seen = 0
        self._states_late_seen = 0
        self._switch_since: float | None = None
        self.reports = 0
        self.timer = node.create_timer(PERIOD_S, self.publish, clock=Clock(clock_type=ClockType.STEADY_TIME))

    # ------------------------------------------------------------------ input
    def add_chunk(self, chunk) -> None:
        """The acceleration of a published chunk (DE and NDE housing, vertical and horizontal), for the ISO
        velocity of the last second."""
        keep = int(round(PERIOD_S * self.node.sample_rate))
        for b in BEARINGS:
            x = np.asarray(chunk.samples[chunk.rows(b, "acceleration")], dtype=np.float64)
            buf = self._acc[b]
            buf.append(x)
            self._acc_n[b] += x.shape[1]
            while buf and self._acc_n[b] - buf[0].shape[1] >= keep:
                self._acc_n[b] -= buf.popleft().shape[1]

    # ------------------------------------------------------------------ the statuses
    def _stream(self) -> tuple[str, str, dict]:
        node = self.node
        st = node.stats()
        late = list(node._stream.lateness_ns)
        new = late[self._late_seen:] if len(late) >= self._late_seen else late
        self._late_seen = len(late)
        period_ns = node.chunk_ns
        late_now = sum(1 for v in new if v >= period_ns)
        chunks_now = st["chunks"] - self._chunks_seen
        self._chunks_seen = st["chunks"]
        values = {"chunks": st["chunks"], "chunks_in_period": chunks_now, "late_chunks": st["late_chunks"],
                  "late_chunks_in_period": late_now,
                  "lateness_ms_max_in_period": (max(new) / 1e6) if new else float("nan"),
                  "lateness_ms_p99": st["lateness_ms_p99"], "chunk_duration_s": period_ns / 1e9,
                  "sample_rate_hz": node.sample_rate, "shaft_speed_hz": node.speed_rad_s / (2 * math.pi),
                  "speed_messages": st["speed_messages"], "speed_rejected": st["speed_rejected"],
                  "sink_errors": st["sink_errors"]}
        if not node._started:
            return "OK", "waiting for the first speed (wait_for_speed)", values
        if late_now:
            return "WARN", (f"{late_now} of {chunks_now} chunks a period or more late in the last {PERIOD_S:g} s "
                            f"(worst {values['lateness_ms_max_in_period']:.1f} ms)"), values
        return "OK", f"{chunks_now} chunks on time in the last {PERIOD_S:g} s", values

    def _model(self) -> tuple[str, str, dict]:
        src = self.node.source
        st = src.stats()
        model = src.model
        values = {"case": model.case.name, "case_hash": model.case.case_hash, "lines": len(model.lines),
                  "scenario": st["scenario"] or "", "scenario_state": "" if st["scenario_state"] is None
                  else st["scenario_state"], "machine_switches": st["machine_switches"],
                  "scenario_states_late": st["scenario_states_late"], "switch_pending": st["switch_pending"]}
        what = f"case {model.case.name}" + (f", scenario {st['scenario']} state {st['scenario_state']}"
                                            if st["scenario"] else "")
        now = time.monotonic()
        if st["switch_pending"]:
            self._switch_since = self._switch_since or now
        else:
            self._switch_since = None
        waited = 0.0 if self._switch_since is None else now - self._switch_since
        values["switch_waiting_s"] = waited
        if st["scenario_states_late"] > self._states_late_seen:
            self._states_late_seen = st["scenario_states_late"]
            return "WARN", f"{what}: a scenario state came late (its model was not ready at its start)", values
        if waited > SWITCH_WAIT_S:
            return "WARN", f"{what}: the next model has been preparing for {waited:.0f} s", values
        return "OK", what + (" (next model preparing)" if st["switch_pending"] else ""), values

    def _band(self) -> tuple[str, str, dict]:
        src = self.node.source
        return band_status(src.synth, src.model, self.node.speed_rad_s / (2 * math.pi))

    def _bearing(self, b: str) -> tuple[str, str, dict]:
        limits = ISO_ZONE_SETS[DEFAULT_ISO_ZONES]
        values = {"iso_zones": DEFAULT_ISO_ZONES, "zone_limits_mm_s": ", ".join(f"{v:g}" for v in limits)}
        buf = self._acc[b]
        if not buf or self._acc_n[b] < 8:
            values["window_s"] = 0.0
            return "OK", "no samples yet", values
        x = np.concatenate(list(buf), axis=1)
        fs = self.node.sample_rate
        v = [iso_velocity_rms_mm_s(x[c], fs) for c in range(x.shape[0])]
        top = max(v)
        zone = iso_zone(top, limits)
        values.update({"velocity_rms_vertical_mm_s": v[0], "velocity_rms_horizontal_mm_s": v[1],
                       "velocity_rms_mm_s": top, "zone": zone, "window_s": x.shape[1] / fs})
        return _ZONE_LEVEL[zone], f"ISO zone {zone}: {top:.2f} mm/s RMS (10-1000 Hz, last {x.shape[1] / fs:.2g} s)", \
            values

    # ------------------------------------------------------------------ the message
    def message(self):
        """The :class:`DiagnosticArray` of now (the node's clock)."""
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        parts = [("stream", self._stream()), ("model", self._model()), ("band limit", self._band())]
        parts += [(f"{b.upper()} bearing", self._bearing(b)) for b in BEARINGS]
        msg = DiagnosticArray()
        msg.header.stamp = self.node.get_clock().now().to_msg()
        for part, (level, text, values) in parts:
            s = DiagnosticStatus()
            s.level = bytes([_LEVEL[level]])
            s.name = f"{self.name}: {part}"
            s.message = text
            s.hardware_id = self.node.machine_id
            s.values = [KeyValue(key=k, value=_text(v)) for k, v in values.items()]
            msg.status.append(s)
        return msg

    def publish(self) -> None:
        """Timer callback: build, publish and hand to the node's sinks (a failure is logged, never raised)."""
        try:
            msg = self.message()
        except Exception as exc:  # noqa: BLE001 - the health report must never stop the stream
            self.node.get_logger().error(f"diagnostics: {exc!r}", throttle_duration_sec=10.0)
            return
        self.pub.publish(msg)
        self.reports += 1
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.node._emit(self.pub.topic_name, DIAGNOSTICS_TYPE, msg, stamp)


def _text(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)
