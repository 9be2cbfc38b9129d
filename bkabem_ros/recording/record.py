"""``bkabem record``: record our topics from the ROS 2 graph into MCAP with raw subscriptions.

The recorder node looks at the graph every ``discovery_period_s`` and subscribes (raw CDR, no
deserialization) to every wanted topic once it has a publisher: by default the node's outputs
(every topic with a ``bkabem_msgs`` type) and the speed input, under ``namespace``. Types and
offered QoS come from the graph (``get_publishers_info_by_topic``); the subscription is reliable
unless a publisher is best effort. ``log_time`` is the receive time (wall clock, ns),
``publish_time`` the publisher's source timestamp from the message info.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from bkabem_ros.recording import mcap_io

__all__ = ["DEFAULT_TOPICS", "AttachedSinks", "RecordStats", "TopicRecorder", "attach_sinks", "record"]

#: Topics of the bkabem node (relative; resolved under the namespace). Any other topic with a
#: bkabem_msgs type is recorded too unless an explicit topic list is given.
DEFAULT_TOPICS = (
    "speed",
    "vibration/de/acceleration", "vibration/de/displacement", "vibration/de/velocity",
    "vibration/de/spectrum",
    "vibration/nde/acceleration", "vibration/nde/displacement", "vibration/nde/velocity",
    "vibration/nde/spectrum",
    "vibration/fault_frequencies",
    "/diagnostics",                 # the node's health (diagnostic_msgs/DiagnosticArray, REP 107)
)
OUR_PACKAGES = ("bkabem_msgs/",)


def _resolve(topic: str, namespace: str) -> str:
    if topic.startswith("/"):
        return topic
    ns = namespace.strip("/")
    return f"/{ns}/{topic}" if ns else f"/{topic}"


@dataclass
class RecordStats:
    """Messages recorded per topic, files written, error (if recording stopped)."""

    counts: dict[str, int] = field(default_factory=dict)
    paths: list = field(default_factory=list)
    error: str = ""

    @property
    def messages(self) -> int:
        return sum(self.counts.values())


class TopicRecorder:
    """Raw subscriptions on an rclpy node feeding a :class:`~bkabem_ros.recording.mcap_io.McapRecorder`.

    Parameters
    ----------
    node : rclpy Node
        Node to create subscriptions on.
    recorder : McapRecorder
        Where messages go.
    topics : iterable of str, optional
        Topics to record (relative names resolve under ``namespace``). Default
        :data:`DEFAULT_TOPICS` plus any topic with a ``bkabem_msgs`` type.
    namespace : str
        Namespace of the bkabem node (``/machine_00``).
    log_error : callable(str)
        Where the one-line error goes if recording stops.
    """

    def __init__(self, node, recorder: mcap_io.McapRecorder, topics: Iterable[str] | None = None,
                 namespace: str = "", log_error: Callable[[str], None] | None = None):
        self.node = node
        self.recorder = recorder
        self.explicit = topics is not None
        self.wanted = {_resolve(t, namespace) for t in (topics if topics is not None else DEFAULT_TOPICS)}
        self.namespace = namespace
        self.subs: dict[str, object] = {}
        self.counts: dict[str, int] = {}
        self.log_error = log_error or mcap_io._stderr
        self.error: mcap_io.RecorderError | None = None

    def _wants(self, topic: str, types: list[str]) -> bool:
        if topic in self.wanted:
            return True
        if self.explicit:
            return False
        ns = "/" + self.namespace.strip("/") if self.namespace.strip("/") else ""
        in_ns = not ns or topic.startswith(ns + "/")
        return in_ns and any(t.startswith(OUR_PACKAGES) for t in types)

    def discover(self) -> list[str]:
        """Subscribe to wanted topics that appeared; returns the new ones."""
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: PLC0415

        new = []
        for topic, types in self.node.get_topic_names_and_types():
            if topic in self.subs or not types or not self._wants(topic, types):
                continue
            type_name = types[0]
            cls = mcap_io.message_class(type_name)
            if cls is None:
                continue
            infos = self.node.get_publishers_info_by_topic(topic)
            if not infos:
                continue
            offered = [i.qos_profile for i in infos]
            best_effort = any(q.reliability == ReliabilityPolicy.BEST_EFFORT for q in offered)
            transient = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
            qos = QoSProfile(
                depth=100,
                reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
                durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE)
            qos_text = mcap_io.qos_yaml(offered)
            self.counts.setdefault(topic, 0)
            self.subs[topic] = self.node.create_subscription(
                cls, topic, self._callback(topic, type_name, qos_text), qos, raw=True)
            new.append(topic)
        return new

    def _callback(self, topic: str, type_name: str, qos_text: str):
        rec = self.recorder

        def cb(data, info):  # two parameters: rclpy passes the MessageInfo
            if self.error is not None:
                return
            now = time.time_ns()
            pub_t = int(info["source_timestamp"]) if info and info.get("source_timestamp") else now
            try:
                if rec.add(topic, type_name, data, now, pub_t, qos=qos_text):
                    self.counts[topic] += 1
            except mcap_io.RecorderError as exc:
                self.error = exc
                self.log_error(str(exc))
            except Exception as exc:  # noqa: BLE001 - e.g. no .msg definition: drop this topic only
                self.log_error(f"not recording {topic} ({type_name}): {exc}")
                self.node.destroy_subscription(self.subs.pop(topic))

        return cb


def record(out, *, topics: Iterable[str] | None = None, namespace: str = "",
           duration_s: float | None = None, chunk_size_bytes: int = 1 << 20,
           chunk_duration_s: float = 1.0, rotate_size_bytes: int | None = None,
           rotate_duration_s: float | None = None, discovery_period_s: float = 0.5,
           stop: threading.Event | None = None, progress: Callable[[str], None] | None = None,
           ros_args: list[str] | None = None) -> RecordStats:
    """Record until ``duration_s`` has passed, ``stop`` is set, or Ctrl-C. Returns the stats.

    Raises :class:`~bkabem_ros.recording.mcap_io.RecorderError` if the file cannot be created; a later
    write error ends the recording (the stats carry the error) and the file stays recoverable.
    """
    import rclpy  # noqa: PLC0415
    from rclpy.executors import SingleThreadedExecutor  # noqa: PLC0415

    from bkabem_ros.ros_env import init, until_stopped  # noqa: PLC0415

    stop = stop or threading.Event()
    recorder = mcap_io.McapRecorder(out, chunk_size_bytes=chunk_size_bytes,
                                    chunk_duration_s=chunk_duration_s,
                                    rotate_size_bytes=rotate_size_bytes,
                                    rotate_duration_s=rotate_duration_s,
                                    metadata={"recorded_by": "bkabem record",
                                              "namespace": namespace or "/"})
    own_context = not rclpy.ok()
    if own_context:
        init(["bkabem-record", "--ros-args", *(ros_args or [])])   # + the discovery range in force, once
    node = rclpy.create_node("bkabem_record")
    tr = TopicRecorder(node, recorder, topics, namespace,
                       log_error=lambda text: node.get_logger().error(text))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stats = RecordStats()
    t_end = None if duration_s is None else time.monotonic() + duration_s
    next_discovery = 0.0
    next_progress = time.monotonic() + 1.0
    try:
        with until_stopped():
            while not stop.is_set() and rclpy.ok() and tr.error is None:
                now = time.monotonic()
                if t_end is not None and now >= t_end:
                    break
                if now >= next_discovery:
                    for topic in tr.discover():
                        if progress:
                            progress(f"recording {topic}")
                    next_discovery = now + discovery_period_s
                if progress and now >= next_progress:
                    progress(f"{sum(tr.counts.values())} messages on {len(tr.subs)} topics")
                    next_progress = now + 1.0
                executor.spin_once(timeout_sec=0.05)
    finally:
        for s in tr.subs.values():
            node.destroy_subscription(s)
        executor.remove_node(node)
        node.destroy_node()
        if own_context and rclpy.ok():
            rclpy.shutdown()
        try:
            recorder.close()
        except mcap_io.RecorderError as exc:
            tr.error = tr.error or exc
    stats.counts = dict(tr.counts)
    stats.paths = list(recorder.paths)
    stats.error = str(tr.error) if tr.error else ""
    return stats


# --------------------------------------------------------------------------- node sinks
def _speed_unit(node) -> str:
    try:
        return str(node.get_parameter("speed_unit").value)
    except Exception:  # noqa: BLE001 - no such parameter: REP 103
        return "rad/s"


def attach_sinks(node, *, record=None, rerun_save=None, rerun_connect=None,
                 chunk_size_bytes: int = 1 << 20, chunk_duration_s: float = 1.0,
                 rotate_size_bytes: int | None = None, rotate_duration_s: float | None = None,
                 recording_id: str | None = None, rerun_optimize: bool = False,
                 report_start: bool = True) -> AttachedSinks:
    """Attach an MCAP recorder and/or a Rerun logger to a running bkabem node.

    ``node`` is a :class:`bkabem_ros.node.vibration_node.VibrationNode` (anything with ``add_sink`` /
    ``remove_sink``, ``publishers`` and ``get_logger``). The offered QoS of each output topic is
    taken from the node's publishers. Returns a cleanup function that detaches the sinks and
    finishes the files (call it after the node stopped spinning); use it as the node's
    ``run(..., on_node=lambda n: attach_sinks(n, record=...))``.

    A recording error (unwritable path, disk full) is logged once by the node's logger; the node
    keeps publishing. ``rerun_optimize``: compact the ``.rrd``'s chunks when detaching (see
    :class:`~bkabem_ros.viewer.rerun_io.RerunLogger`). ``report_start=False``: a sink that cannot start is not
    logged but left in ``start_errors`` (option -> reason) for the caller to report (the command line's one line).

    Returns
    -------
    AttachedSinks
        Call it to detach and close; ``.mcap`` (:class:`~bkabem_ros.recording.mcap_io.McapSink`) and
        ``.rerun`` (:class:`~bkabem_ros.viewer.rerun_io.RerunSink`) are the sinks (None if not asked or
        not started).
    """
    sinks = []
    attached = AttachedSinks(node, sinks)
    log = node.get_logger()
    started = False

    def report(option: str, text: str) -> None:
        if report_start or started:
            log.error(text)
        else:
            attached.start_errors.setdefault(option, text)

    if record:
        qos = {}
        for pub in getattr(node, "publishers", []):
            qos[pub.topic_name] = pub.qos_profile
        sink = mcap_io.McapSink(record, qos=qos, log_error=lambda text: report("--record", text),
                                chunk_size_bytes=chunk_size_bytes, chunk_duration_s=chunk_duration_s,
                                rotate_size_bytes=rotate_size_bytes, rotate_duration_s=rotate_duration_s,
                                metadata={"recorded_by": "bkabem node",
                                          "node": node.get_fully_qualified_name(),
                                          "speed_unit": _speed_unit(node)})
        if sink.error is not None and not report_start:
            attached.start_errors["--record"] = str(sink.error)      # the recorder's own words, not the sink's
        if sink.error is None:
            node.add_sink(sink)
            sinks.append(sink)
            attached.mcap = sink
            log.info(f"recording to {record} (chunks <= {chunk_duration_s:g} s)")
    if rerun_save or rerun_connect:
        from bkabem_ros.viewer import rerun_io  # noqa: PLC0415

        def speed_scale():
            try:
                from bkabem_ros.node.speed import SPEED_UNITS, normalize_unit  # noqa: PLC0415

                return SPEED_UNITS[normalize_unit(node.get_parameter("speed_unit").value)]
            except Exception:  # noqa: BLE001 - no such parameter: REP 103
                return 1.0

        try:
            logger = rerun_io.RerunLogger("bkabem", recording_id=recording_id, save_path=rerun_save,
                                          connect_url=rerun_connect, optimize=rerun_optimize)
        except Exception as exc:  # noqa: BLE001 - bad path/URL: keep publishing
            report("--rerun-save" if rerun_save else "--rerun-connect",
                   f"Rerun output not started: {type(exc).__name__}: {exc}")
        else:
            sink = rerun_io.RerunSink(logger, speed_scale=speed_scale, log_error=log.error)
            node.add_sink(sink)
            sinks.append(sink)
            attached.rerun = sink
            log.info(f"Rerun: {'saving ' + str(rerun_save) if rerun_save else ''}"
                     f"{' and ' if rerun_save and rerun_connect else ''}"
                     f"{'streaming to ' + rerun_connect if rerun_connect else ''}")
    started = True
    return attached


class AttachedSinks:
    """What :func:`attach_sinks` attached; calling it detaches the sinks and closes the files."""

    def __init__(self, node, sinks: list):
        self.node = node
        self.sinks = sinks
        self.mcap = None
        self.rerun = None
        self.start_errors: dict[str, str] = {}       # option -> why it did not start (report_start=False)

    def __call__(self) -> None:
        for s in self.sinks:
            try:
                self.node.remove_sink(s)
            except ValueError:
                pass
            try:
                s.close()
            except Exception as exc:  # noqa: BLE001 - a full disk at the footer: report it, close the rest
                if getattr(s, "error", None) is None:
                    s.error = exc
        self.sinks.clear()
