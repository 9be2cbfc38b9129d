"""Replay an MCAP recording: republish on ROS 2 with the original timing, and/or convert to Rerun.

:func:`replay` reads the stored CDR bytes (:func:`bkabem_ros.recording.mcap_io.iter_raw`), so nothing is
deserialized for publishing: ``Publisher.publish(bytes)`` sends them as recorded (messages recorded with
older ``bkabem_msgs`` definitions are decoded with those and republished as today's messages:
:mod:`bkabem_ros.messages.compat`, "Versions" in msg_defs/README.md). The spacing of
the messages is the spacing of their log times divided by ``rate``; headers keep their original
stamps. With ``clock`` the playback time (the log time of the recording) is published on
``/clock`` (``rosgraph_msgs/Clock``) before every message and at ``clock_hz`` in between, so
nodes with ``use_sim_time`` follow the recording. Looping restarts the file: the clock jumps
back (as with ``ros2 bag play --loop``).

Without ``publish`` (``bkabem replay FILE --rerun-save OUT.rrd`` with no ``--publish``) rclpy
is not loaded for publishing: the file is converted as fast as it can be read, with the
stamps of the messages as the viewer's time.

Works for files written by :mod:`bkabem_ros.recording.mcap_io` and by rosbag2 / rosbags with our types.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from bkabem_ros.messages import compat as msg_compat
from bkabem_ros.messages import convert as msgs
from bkabem_ros.recording import mcap_check, mcap_io

#: After --wait-subscribers sees every publisher matched: time for the readers to match back [s].
DISCOVERY_SETTLE_S = 0.25

__all__ = ["ReplayStats", "parse_remaps", "replay", "to_rerun"]


@dataclass
class ReplayStats:
    """What a replay did: messages published / logged per topic, loops, wall time (s)."""

    published: dict[str, int] = field(default_factory=dict)
    logged: int = 0
    clock_messages: int = 0
    loops: int = 0
    wall_s: float = 0.0
    first_log_time_ns: int = 0
    last_log_time_ns: int = 0
    damage: str | None = None      # what was skipped in a damaged file (allow_damaged), None when intact
    bad_messages: int = 0          # messages skipped because their payload does not decode (allow_damaged)

    @property
    def messages(self) -> int:
        return sum(self.published.values())


def parse_remaps(items: Iterable[str] | None) -> dict[str, str]:
    """``["old:=new", ...]`` -> {old: new}; names without a leading ``/`` get one."""
    out: dict[str, str] = {}
    for item in items or []:
        old, sep, new = str(item).partition(":=")
        if not sep or not old.strip() or not new.strip():
            raise ValueError(f"--remap {item!r}: expected OLD:=NEW")
        out[_abs(old.strip())] = _abs(new.strip())
    return out


def _abs(topic: str) -> str:
    return topic if topic.startswith("/") else "/" + topic


def _qos_from_metadata(meta: Mapping[str, str]):
    """Publisher QoS from a channel's ``offered_qos_profiles`` (first profile); rclpy default
    (reliable, keep last 10, volatile) when absent."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: PLC0415

    profiles = []
    try:
        profiles = mcap_io.parse_qos_yaml(meta.get("offered_qos_profiles", ""))
    except Exception:  # noqa: BLE001 - bad metadata: use the default
        profiles = []
    if not profiles:
        return QoSProfile(depth=10)
    p = profiles[0]
    rel = (ReliabilityPolicy.BEST_EFFORT if str(p.get("reliability")) == "best_effort"
           else ReliabilityPolicy.RELIABLE)
    dur = (DurabilityPolicy.TRANSIENT_LOCAL if str(p.get("durability")) == "transient_local"
           else DurabilityPolicy.VOLATILE)
    hist = HistoryPolicy.KEEP_ALL if str(p.get("history")) == "keep_all" else HistoryPolicy.KEEP_LAST
    depth = int(p.get("depth") or 10) or 10
    return QoSProfile(history=hist, depth=max(depth, 1), reliability=rel, durability=dur)


def _linger(pubs, linger_s: float) -> None:
    from rclpy.duration import Duration  # noqa: PLC0415
    from rclpy.qos import ReliabilityPolicy  # noqa: PLC0415

    t0 = time.monotonic()
    for p in pubs:
        try:
            if p.qos_profile.reliability == ReliabilityPolicy.RELIABLE:
                p.wait_for_all_acked(Duration(seconds=1))
        except Exception:  # noqa: BLE001 - best effort only
            pass
    rest = linger_s - (time.monotonic() - t0)
    if rest > 0:
        time.sleep(rest)


def replay(path, *, rate: float = 1.0, loop: bool = False, start_offset_s: float = 0.0,
           remap: Mapping[str, str] | None = None, topics: Iterable[str] | None = None,
           clock: bool = False, clock_hz: float = 100.0, publish: bool = True,
           rerun_logger=None, node=None, namespace: str = "",
           wait_for_subscribers_s: float = 0.0, subscribers: int = 1, stop: threading.Event | None = None,
           progress: Callable[[str], None] | None = None, ros_args: list[str] | None = None,
           linger_s: float = 0.3, allow_damaged: bool = False, integrity=None) -> ReplayStats:
    """Replay ``path`` on ROS 2 (``publish``) and/or into a :class:`~bkabem_ros.viewer.rerun_io.RerunLogger`.

    Parameters
    ----------
    path : str or Path
        MCAP file.
    rate : float
        Playback speed factor (2 = twice as fast). Ignored without ``publish`` (as fast as possible).
    loop : bool
        Start again at the end, until ``stop`` is set (or interrupted).
    start_offset_s : float
        Skip the first seconds of the recording (log time).
    remap : mapping old -> new topic
        Publish ``old`` under ``new`` (full names; see :func:`parse_remaps`).
    topics : iterable of str, optional
        Only these (recorded) topics.
    clock, clock_hz
        Publish ``/clock`` (playback time = recorded log time) before each message and at
        ``clock_hz`` while waiting.
    publish : bool
        Publish on ROS 2 (creates an rclpy node unless ``node`` is given).
    rerun_logger : RerunLogger, optional
        Also log every message (deserialized) to Rerun.
    namespace : str
        Prefix for recorded topic names (after remapping), e.g. ``/replayed``.
    wait_for_subscribers_s : float
        Before starting, wait up to this long until every publisher has ``subscribers`` subscribers.
    subscribers : int
        How many subscribers each topic waits for (default 1; more when several readers must see the
        first message: a reliable reader that matches after a message was sent never gets it).
    stop : threading.Event, optional
        Set it to end the replay early.
    linger_s : float
        After the last message, wait for reliable subscribers to acknowledge (at most 1 s) and at
        least this long, so the end of the file is delivered before the publishers are destroyed.
    allow_damaged : bool
        Replay the intact chunks of a damaged file (bad CRC, cut) instead of raising
        :class:`~bkabem_ros.recording.mcap_check.DamagedRecording`; what was skipped is in ``stats.damage``.
    integrity : mcap_check.Integrity, optional
        The file's :func:`~bkabem_ros.recording.mcap_check.verify` result, when the caller already has it.
    """
    if not rate > 0:
        raise ValueError(f"rate: {rate} must be > 0")
    if start_offset_s < 0:
        raise ValueError(f"start_offset: {start_offset_s} must be >= 0")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    integrity = integrity if integrity is not None else mcap_check.verify(path)
    if integrity.mcap and not integrity.messages_checked:
        mcap_io.check_messages(path, integrity)            # a message that does not decode is damage too
    if not integrity.ok and not allow_damaged:
        raise mcap_check.DamagedRecording(f"{path}: {integrity.summary_line()}")
    remap = dict(remap or {})
    ns = namespace.rstrip("/")
    stats = ReplayStats()
    stats.damage = None if integrity.ok else integrity.summary_line()
    stop = stop or threading.Event()
    wanted = [t for t in topics] if topics is not None else None

    own_context = False
    pubs: dict[str, object] = {}
    clock_pub = None
    reader = msg_compat.Reader()            # recordings of older bkabem_msgs definitions: decoded and upgraded
    decode = reader.decode
    schema_texts = mcap_io._schema_texts(path, integrity)
    speed_scale = 1.0          # speed topic unit -> rad/s, from the node's recording metadata
    if rerun_logger is not None:
        from bkabem_ros.node.speed import SPEED_UNITS, normalize_unit  # noqa: PLC0415

        try:
            speed_scale = SPEED_UNITS[normalize_unit(
                mcap_io.file_metadata(path, integrity=integrity).get("bkabem", {}).get("speed_unit", "rad/s"))]
        except ValueError:
            speed_scale = 1.0
    if publish:
        import rclpy  # noqa: PLC0415

        if node is None:
            if not rclpy.ok():
                from bkabem_ros.ros_env import init  # noqa: PLC0415

                init(["bkabem-replay", "--ros-args", *(ros_args or [])])   # + the discovery range in force, once
                own_context = True
            node = rclpy.create_node("bkabem_replay")
            own_node = True
        else:
            own_node = False
        if clock:
            from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: PLC0415
            from rosgraph_msgs.msg import Clock  # noqa: PLC0415

            clock_pub = node.create_publisher(
                Clock, "/clock", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
            clock_cls = Clock

    def out_topic(topic: str) -> str:
        t = remap.get(topic, topic)
        return f"{ns}{t}" if ns else t

    # publishers for every channel up front (so subscribers can match before the first message)
    info = mcap_io.scan(path, wanted, integrity=integrity)
    channels, first, last = info.topics, info.start_ns, info.end_ns
    if first is None:
        if publish and own_node:
            node.destroy_node()
        if own_context:
            import rclpy  # noqa: PLC0415

            rclpy.shutdown()
        return stats
    stats.first_log_time_ns, stats.last_log_time_ns = first, last
    if publish:
        for topic, (type_name, meta) in channels.items():
            cls = mcap_io.message_class(type_name)
            if cls is None:
                if progress:
                    progress(f"skipping {topic}: type {type_name} is not importable here")
                continue
            pubs[topic] = node.create_publisher(cls, out_topic(topic), _qos_from_metadata(meta))
        if wait_for_subscribers_s > 0:   # matching happens in the middleware: no spinning needed
            t_end = time.monotonic() + wait_for_subscribers_s
            while (time.monotonic() < t_end and not stop.is_set()
                   and any(p.get_subscription_count() < subscribers for p in pubs.values())):
                time.sleep(0.02)
            # The writer seeing the reader does not mean the reader has matched the writer yet; a
            # best-effort reader drops what arrives before that (seen in CI: the first message lost).
            time.sleep(DISCOVERY_SETTLE_S)

    start_ns = first + int(start_offset_s * 1e9)
    wall0 = time.monotonic()
    clock_period = 1.0 / clock_hz if clock_hz > 0 else None

    def publish_clock(t_ns: int) -> None:
        m = clock_cls()
        m.clock.sec, m.clock.nanosec = t_ns // 1_000_000_000, t_ns % 1_000_000_000
        clock_pub.publish(m)
        stats.clock_messages += 1

    try:
        while not stop.is_set():
            loop_wall0 = time.monotonic()
            for r in mcap_io.iter_raw(path, wanted, start_time_ns=start_ns, integrity=integrity):
                if stop.is_set():
                    break
                if integrity.bad_messages:
                    with mcap_io.quiet_stderr():
                        problem = mcap_io.message_problem(reader, r, schema_texts.get(r.type_name))
                    if problem:
                        stats.bad_messages += 1         # skipped (allow_damaged): never published or logged
                        continue
                if publish:
                    due = loop_wall0 + (r.log_time - start_ns) / 1e9 / rate
                    while True:
                        now = time.monotonic()
                        wait = due - now
                        if wait <= 0 or stop.is_set():
                            break
                        if clock_pub is not None and clock_period is not None:
                            step = min(wait, clock_period)
                            time.sleep(step)
                            played = start_ns + int((time.monotonic() - loop_wall0) * rate * 1e9)
                            publish_clock(min(played, r.log_time))
                        else:
                            time.sleep(min(wait, 0.5))
                    if clock_pub is not None:
                        publish_clock(r.log_time)
                    pub = pubs.get(r.topic)
                    if pub is not None:
                        # as recorded, unless recorded with older definitions: then upgraded to today's, which the
                        # subscribers (and the publisher's type) have
                        pub.publish(reader.to_current_cdr(r.type_name, r.data, schema_texts.get(r.type_name)))
                        t = out_topic(r.topic)
                        stats.published[t] = stats.published.get(t, 0) + 1
                if rerun_logger is not None:
                    msg = decode(r.type_name, r.data, schema_texts.get(r.type_name))
                    # publish_time: the node sink stores the node-clock stamp there (sim time too)
                    if r.type_name.endswith("Float64") and r.topic.rstrip("/").endswith("speed"):
                        rerun_logger.log_speed(r.publish_time, float(msg.data) * speed_scale)
                        stats.logged += 1
                    elif rerun_logger.log_message(r.topic, r.type_name, msg, r.publish_time):
                        stats.logged += 1
            stats.loops += 1
            if not loop:
                break
            if progress:
                progress(f"loop {stats.loops} done, restarting")
    except KeyboardInterrupt:
        pass
    finally:
        stats.wall_s = time.monotonic() - wall0
        if publish:
            # let the last messages reach the subscribers before the publishers go away
            _linger(pubs.values(), linger_s)
            for p in pubs.values():
                node.destroy_publisher(p)
            if clock_pub is not None:
                node.destroy_publisher(clock_pub)
            if own_node:
                node.destroy_node()
            if own_context:
                import rclpy  # noqa: PLC0415

                if rclpy.ok():
                    rclpy.shutdown()
    return stats


def to_rerun(path, logger, *, topics: Iterable[str] | None = None, start_offset_s: float = 0.0) -> ReplayStats:
    """Convert a recording into a :class:`~bkabem_ros.viewer.rerun_io.RerunLogger` without ROS
    (no rclpy publishing; deserialization uses the message classes when importable, else the
    embedded schemas). The caller closes the logger."""
    return replay(path, publish=False, rerun_logger=logger, topics=topics,
                  start_offset_s=start_offset_s)


def describe(path, integrity=None, summary: dict | None = None) -> str:
    """A few lines about a recording: duration, topics with type and count, its longest gap between messages,
    and its integrity (with the damaged places when it is damaged; every message is decoded for it unless
    ``summary``, a :func:`bkabem_ros.recording.mcap_read.summary` with ``decode=True``, is given)."""
    integrity = integrity if integrity is not None else mcap_check.verify(path)
    s = summary if summary is not None else mcap_io.summary(path, integrity=integrity, decode=True)
    lines = [f"{s['path']}: {s['messages']} messages, {s['duration_s']:.2f} s"
             + (f" (longest gap between messages {s['max_gap_ns'] / 1e9:.3g} s)" if s["max_gap_ns"] > 1e9 else "")]
    for topic, t in sorted(s["topics"].items()):
        lines.append(f"  {topic:40s} {msgs.type_name(t['type']) if t['type'] else '?':40s} {t['count']}")
    lines += integrity.lines()
    return "\n".join(lines)
