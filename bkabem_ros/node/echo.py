"""``bkabem echo``: one line per message on bkabem's topics (the ros2 CLI is not available as wheels).

Each line: topic, header stamp (s), first sample index, RMS per channel, shaft speed (rad/s), the ground truth
(``truth="..."``: the machine's state, its scenario and scenario time; ``n/a`` for a message recorded without it,
bkabem_msgs 0.1.0) and the machine's labels. Without
topics it follows every bkabem topic of ``--namespace``: the four waveforms, the two spectra, the fault
frequencies and the speed input. ``--json`` prints one JSON object per line instead.

Waveform RMS is over the samples of the chunk (mean included); spectrum RMS is over its lines
(``sqrt(dc^2 + sum_k A_k^2 / 2)``).
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import sys
import time

DEFAULT_TOPICS = (
    "speed",
    "vibration/de/acceleration", "vibration/de/displacement",
    "vibration/nde/acceleration", "vibration/nde/displacement",
    "vibration/de/spectrum", "vibration/nde/spectrum",
    "vibration/fault_frequencies",
)
KNOWN_TYPES = {
    "bkabem_msgs/msg/VibrationWaveform": ("bkabem_msgs.msg", "VibrationWaveform"),
    "bkabem_msgs/msg/VibrationSpectrum": ("bkabem_msgs.msg", "VibrationSpectrum"),
    "bkabem_msgs/msg/BearingFaultFrequencies": ("bkabem_msgs.msg", "BearingFaultFrequencies"),
    "std_msgs/msg/Float64": ("std_msgs.msg", "Float64"),
}


def type_for_topic(topic: str) -> str | None:
    """Message type of a bkabem topic, from its last name component (None: unknown)."""
    last = topic.rstrip("/").rsplit("/", 1)[-1]
    if last in ("acceleration", "displacement", "velocity"):
        return "bkabem_msgs/msg/VibrationWaveform"
    if last == "spectrum":
        return "bkabem_msgs/msg/VibrationSpectrum"
    if last == "fault_frequencies":
        return "bkabem_msgs/msg/BearingFaultFrequencies"
    if last == "speed":
        return "std_msgs/msg/Float64"
    return None


def summarize(topic: str, type_name: str, msg, receive_ns: int | None = None) -> dict:
    """The fields ``bkabem echo`` prints, as a dict (also used by tests and benchmarks)."""
    import numpy as np

    from bkabem_ros.messages.convert import spectrum_arrays, stamp_to_ns, waveform_array

    out = {"topic": topic, "type": type_name.rsplit("/", 1)[-1]}
    if type_name.endswith("VibrationWaveform"):
        a = waveform_array(msg).astype(np.float64)
        out.update(stamp_ns=stamp_to_ns(msg.header), index=int(msg.first_sample_index),
                   channels=list(msg.channel_names), samples=int(msg.samples_per_channel),
                   rms=[float(v) for v in np.sqrt(np.mean(a * a, axis=1))] if a.size else [],
                   unit=msg.unit, speed_rad_s=float(msg.shaft_speed), machine_id=msg.machine_id)
    elif type_name.endswith("VibrationSpectrum"):
        sa = spectrum_arrays(msg)
        dc = np.where(sa.bpfo_order == 0, 1.0, 0.5)
        rms = np.sqrt((sa.amplitude ** 2 * dc[None, :]).sum(axis=1)) if sa.amplitude.size else np.zeros(0)
        out.update(stamp_ns=stamp_to_ns(msg.header), index=None, quantity=msg.quantity, lines=int(sa.frequency.size),
                   rms=[float(v) for v in rms], unit=msg.unit, speed_rad_s=float(msg.shaft_speed),
                   machine_id=msg.machine_id)
    elif type_name.endswith("BearingFaultFrequencies"):
        from bkabem_ros.messages.convert import bearing_kinematics

        out.update(stamp_ns=stamp_to_ns(msg.header), index=None, speed_rad_s=float(msg.shaft_speed),
                   ftf_hz=msg.ftf, bpfo_hz=msg.bpfo, bpfi_hz=msg.bpfi, bsf_hz=msg.bsf,
                   defect_depth_m=msg.defect_depth, machine_id=msg.machine_id,
                   bearings=bearing_kinematics(msg))       # each bearing's own; the single fields: the DE's
    elif type_name.endswith("Float64"):
        out.update(stamp_ns=receive_ns, index=None, value=float(msg.data))
    else:
        out.update(stamp_ns=None, index=None)
    if type_name.startswith("bkabem_msgs/"):
        from bkabem_ros.messages.convert import ground_truth_dict

        out["ground_truth"] = ground_truth_dict(msg)
    return out


def _truth_text(gt: dict | None) -> str | None:
    """``truth=...`` of a line: the state of the machine the message states (n/a: recorded without it)."""
    if gt is None:
        return None
    if not gt.get("available"):
        return "truth=n/a"
    text = gt["state_label"] or ("healthy" if gt["healthy"] else "faulty")
    if gt["scenario"]:
        text = f"{gt['scenario']}[{gt['state_index']}] {text} @{gt['scenario_time_s']:.6g}s"
    labels = ",".join(f"{k}={v}" for k, v in gt.get("labels", {}).items())
    return f"truth=\"{text}\"" + (f" labels={labels}" if labels else "")


def format_line(d: dict) -> str:
    st = d.get("stamp_ns")
    stamp = "-" if st is None else f"{st // 1_000_000_000}.{st % 1_000_000_000:09d}"
    parts = [d["topic"], f"stamp={stamp}"]
    if d["type"] == "VibrationWaveform":
        rms = ",".join(f"{v:.4g}" for v in d["rms"])
        parts += [f"index={d['index']}", f"n={len(d['channels'])}x{d['samples']}", f"rms=[{rms}] {d['unit']}",
                  f"speed={d['speed_rad_s']:.4f} rad/s"]
    elif d["type"] == "VibrationSpectrum":
        rms = ",".join(f"{v:.4g}" for v in d["rms"])
        parts += ["index=-", f"{d['quantity']} lines={d['lines']}", f"rms=[{rms}] {d['unit']}",
                  f"speed={d['speed_rad_s']:.4f} rad/s"]
    elif d["type"] == "BearingFaultFrequencies":
        parts += ["index=-", f"ftf={d['ftf_hz']:.4f} bpfo={d['bpfo_hz']:.4f} bpfi={d['bpfi_hz']:.4f} "
                  f"bsf={d['bsf_hz']:.4f} Hz", f"speed={d['speed_rad_s']:.4f} rad/s"]
        nde = d.get("bearings", {}).get("nde")
        if nde is not None and nde["bpfo"] != d["bpfo_hz"]:         # another bearing at the NDE: its own too
            parts.insert(-1, f"nde {nde['designation']}: ftf={nde['ftf']:.4f} bpfo={nde['bpfo']:.4f} "
                             f"bpfi={nde['bpfi']:.4f} bsf={nde['bsf']:.4f} Hz")
    elif d["type"] == "Float64":
        parts += ["index=-", f"value={d['value']:.6g}"]
    truth = _truth_text(d.get("ground_truth"))
    if truth:
        parts.append(truth)
    return "  ".join(parts)


def _json_default(o):
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return str(o)


def add_parser(sub, add_case=None):
    """Register ``bkabem echo``."""
    from bkabem_ros.cli.base import finite_float, pos_int

    p = sub.add_parser("echo", help="print one line per message on bkabem topics",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("topics", nargs="*", help="topics (relative to --namespace); default: all bkabem topics")
    p.add_argument("--namespace", default="", help="namespace of the machine, e.g. /machine_00")
    p.add_argument("--count", type=pos_int("--count", 1), default=None, help="exit after this many messages")
    p.add_argument("--seconds", type=finite_float("--seconds", 0.0, strict=True), default=None,
                   help="exit after this long")
    p.add_argument("--qos", choices=("sensor_data", "reliable"), default="sensor_data",
                   help="subscription QoS; sensor_data (best effort) receives from both kinds of publisher")
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=None,
                   help="everything after this goes to ROS")
    p.set_defaults(func=main, ros_network=True)
    return p


def main(args) -> int:
    import importlib

    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from bkabem_ros.cli.base import fail

    topics = list(args.topics) or list(DEFAULT_TOPICS)
    from bkabem_ros.ros_env import check_names, init, until_stopped  # noqa: PLC0415

    check_names([("--namespace", "namespace", args.namespace)] + [("TOPIC", "topic", t) for t in topics])

    init(["bkabem-echo", "--ros-args", *(args.ros_args or [])])   # + the discovery range in force, once
    node = None
    state = {"n": 0}
    try:
        node = rclpy.create_node("bkabem_echo", namespace=args.namespace or None)
        rel = ReliabilityPolicy.RELIABLE if args.qos == "reliable" else ReliabilityPolicy.BEST_EFFORT
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=rel)
        subs = []

        def on_msg(topic_name, type_name, msg):
            d = summarize(topic_name, type_name, msg, node.get_clock().now().nanoseconds)
            sys.stdout.write((json.dumps(d, default=_json_default) if args.json else format_line(d)) + "\n")
            sys.stdout.flush()
            state["n"] += 1

        for topic in topics:
            type_name = type_for_topic(topic)
            if type_name is None:
                type_name = _discover_type(node, topic)
            if type_name not in KNOWN_TYPES:
                fail("echo", f"topic {topic!r}: unknown message type {type_name!r} (known: {', '.join(KNOWN_TYPES)})")
            mod, cls = KNOWN_TYPES[type_name]
            msg_type = getattr(importlib.import_module(mod), cls)

            full = node.resolve_topic_name(topic)
            sub = node.create_subscription(msg_type, topic, functools.partial(on_msg, full, type_name), qos)
            subs.append(sub)
        t_end = None if args.seconds is None else time.monotonic() + args.seconds
        with until_stopped():
            while rclpy.ok():
                if args.count is not None and state["n"] >= args.count:
                    break
                if t_end is not None and time.monotonic() >= t_end:
                    break
                rclpy.spin_once(node, timeout_sec=0.05)
    except (KeyboardInterrupt, ExternalShutdownException, BrokenPipeError):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def _discover_type(node, topic: str, timeout_s: float = 2.0) -> str | None:
    import rclpy

    full = node.resolve_topic_name(topic)
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        for name, types in node.get_topic_names_and_types():
            if name == full and types:
                return types[0]
        rclpy.spin_once(node, timeout_sec=0.1)
    return None
