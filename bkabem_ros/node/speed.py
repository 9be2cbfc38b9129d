"""Shaft-speed input: units, validation, speed profiles, the ``bkabem speed`` publisher, and the node's watch
for publishers of the wrong type on its speed topic.

The speed topic carries ``std_msgs/msg/Float64``. REP 103 says rad/s, and that is the default of both
the node (parameter ``speed_unit``) and this publisher (``--publish-unit``). ``hz`` (revolutions per
second) and ``rpm`` are accepted for topics that come from elsewhere.

Profiles (values in ``--unit``, default Hz, the same syntax as ``bkabem synth --profile``):

``constant:V``
    V forever (or for ``--seconds``).
``ramp:A:B:T``
    linear from A to B in T seconds, then B held.
``steps:V1,V2,...:T``
    each value held for T seconds, the last one held.
``FILE.csv``
    two columns ``time_s, speed`` (an optional header line is skipped), linear interpolation between
    rows, the last value held.

Without ``--seconds`` a constant profile runs until interrupted; the others run until their end plus
``--hold`` seconds (default 1 s), so that the last value reaches the node.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from dataclasses import dataclass
from pathlib import Path

TWO_PI = 2.0 * math.pi
#: The type of the speed topic.
SPEED_TYPE = "std_msgs/msg/Float64"
#: The ROS graph's node name for an endpoint whose node it does not know yet (its participant's node list arrives
#: after the endpoint itself), and how many graph checks a publisher of the wrong type may stay that way before it
#: is reported without its name (a plain DDS writer never gets one)
UNKNOWN_NODE_NAME = "_NODE_NAME_UNKNOWN_"
NAME_WAIT_CHECKS = 3

#: The fastest shaft a case may have [Hz] (the upper plausibility bound of operating.max_speed_hz, 120 000 rpm): a
#: profile above it is a unit slip, not a speed any node will take.

#: Accepted speed units and their factor to rad/s.
SPEED_UNITS = {"rad/s": 1.0, "hz": TWO_PI, "rpm": TWO_PI / 60.0}
_UNIT_ALIASES = {"rad/s": "rad/s", "rad_s": "rad/s", "rads": "rad/s", "hz": "hz", "rps": "hz", "rpm": "rpm"}


def normalize_unit(unit: str) -> str:
    """Canonical speed unit name (``"rad/s"``, ``"hz"`` or ``"rpm"``); ValueError otherwise."""
    u = _UNIT_ALIASES.get(str(unit).strip().lower())
    if u is None:
        raise ValueError(f"speed unit {unit!r} is not one of rad/s, hz, rpm")
    return u


def to_rad_s(value: float, unit: str) -> float:
    """Speed ``value`` in ``unit`` -> rad/s (no validation)."""
    return float(value) * SPEED_UNITS[normalize_unit(unit)]


def from_rad_s(value_rad_s: float, unit: str) -> float:
    """Speed in rad/s -> ``unit``."""
    return float(value_rad_s) / SPEED_UNITS[normalize_unit(unit)]


def check_speed(value_rad_s: float, max_rad_s: float, limit: tuple[float, str] | None = None) -> str | None:
    """Why a speed (rad/s) is unusable, or None when it is fine (finite, >= 0, <= the bearings' ``limit``, <= max).

    ``limit``: the fastest shaft the case's bearings allow [rad/s] and which bearing sets it
    (:func:`bkabem_core.model.plausibility.max_speed_bound`), or None.
    """
    if not math.isfinite(value_rad_s):
        return f"not finite ({value_rad_s!r})"
    if value_rad_s < 0.0:
        return f"negative ({value_rad_s:g} rad/s; reverse rotation is not modelled)"
    if limit is not None and value_rad_s > limit[0]:
        return f"above the bearings' limiting speed ({value_rad_s:g} > {limit[0]:g} rad/s: {limit[1]})"
    if value_rad_s > max_rad_s:
        return f"above max_speed ({value_rad_s:g} > {max_rad_s:g} rad/s)"
    return None


def bearing_limit_rad_s(case) -> tuple[float, str] | None:
    """The fastest shaft the bearings of ``case`` allow [rad/s] and which bearing sets it, or None
    (:func:`bkabem_core.model.plausibility.max_speed_bound`: the case's ``[plausibility]`` overrides included)."""
    from bkabem_core.model.plausibility import max_speed_bound  # the case bound; imported when a node runs

    bound = max_speed_bound(case.resolved)
    return None if bound is None else (bound[0] * TWO_PI, bound[1])


def max_speed_refusal(max_rad_s: float, limit: tuple[float, str] | None) -> str | None:
    """Why the node's ``max_speed`` parameter [rad/s] is refused (above the bearings' limiting speed), or None."""
    if limit is None or max_rad_s <= limit[0]:
        return None
    return (f"max_speed: {max_rad_s:g} rad/s is above the bearings' limiting speed {limit[0]:g} rad/s ({limit[1]}); "
            f'if the machine really runs faster, widen it in the case: [plausibility] '
            f'"bearings.*.limiting_speed_ratio" = [low, high]')


# --------------------------------------------------------------------------- profiles
@dataclass
class SpeedProfile:
    """Piecewise-linear speed over time: ``times_s`` (increasing) and ``values`` (in ``unit``).

    Before the first time the first value holds, after the last time the last value holds.
    ``finite`` is False for a constant profile (it has no natural end).
    """

    times_s: list[float]
    values: list[float]
    unit: str = "hz"
    finite: bool = True
    text: str = ""

    @property
    def end_s(self) -> float:
        return self.times_s[-1]

    def at(self, t_s: float) -> float:
        ts, vs = self.times_s, self.values
        if t_s <= ts[0]:
            return vs[0]
        if t_s >= ts[-1]:
            return vs[-1]
        lo, hi = 0, len(ts) - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if ts[mid] <= t_s:
                lo = mid
            else:
                hi = mid
        t0, t1 = ts[lo], ts[hi]
        if t1 == t0:
            return vs[hi]
        return vs[lo] + (vs[hi] - vs[lo]) * (t_s - t0) / (t1 - t0)


def _num(field: str, text: str, *, nonneg: bool = True, positive: bool = False) -> float:
    try:
        if "_" in text:                     # float("1_0") is 10
            raise ValueError(text)
        v = float(text)
    except ValueError:
        raise ValueError(f"{field}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise ValueError(f"{field}: {text!r} must be finite")
    if positive and v <= 0:
        raise ValueError(f"{field}: {text!r} must be > 0")
    if nonneg and v < 0:
        raise ValueError(f"{field}: {text!r} must be >= 0")
    return v


def parse_profile(text: str, unit: str = "hz") -> SpeedProfile:
    """Parse ``constant:V``, ``ramp:A:B:T``, ``steps:V1,V2,...:T`` or a CSV path (see module doc)."""
    unit = normalize_unit(unit)
    s = str(text).strip()
    kind, _, rest = s.partition(":")
    if kind == "constant" and rest:
        v = _num("constant value", rest)
        return SpeedProfile([0.0], [v], unit, finite=False, text=s)
    if kind == "ramp" and rest:
        parts = rest.split(":")
        if len(parts) != 3:
            raise ValueError(f"profile {s!r}: ramp needs ramp:FROM:TO:SECONDS")
        a, b = _num("ramp from", parts[0]), _num("ramp to", parts[1])
        t = _num("ramp seconds", parts[2], positive=True)
        return SpeedProfile([0.0, t], [a, b], unit, text=s)
    if kind == "steps" and rest:
        vals, _, dur = rest.rpartition(":")
        if not vals:
            raise ValueError(f"profile {s!r}: steps needs steps:V1,V2,...:SECONDS")
        t = _num("steps seconds", dur, positive=True)
        vs = [_num("step value", v) for v in vals.split(",")]
        # instantaneous jumps: (i*t, v_i), ((i+1)*t, v_i), ((i+1)*t, v_{i+1}), ...
        times, values = [], []
        for i, v in enumerate(vs):
            times.append(i * t)
            values.append(v)
            times.append((i + 1) * t)
            values.append(v)
        return SpeedProfile(times, values, unit, text=s)
    path = Path(s)
    if s.endswith(".csv") or path.is_file():
        return _csv_profile(path, unit)
    raise ValueError(f"profile {s!r}: expected constant:V, ramp:A:B:SECONDS, steps:V1,V2,...:SECONDS "
                     "or a CSV file")


def _csv_profile(path: Path, unit: str) -> SpeedProfile:
    from bkabem_core.model.files import not_a_file

    why = not_a_file(path)
    if why:
        raise ValueError(f"profile: {why}")
    times, values = [], []
    with path.open(newline="") as fh:
        for lineno, row in enumerate(csv.reader(fh), 1):
            row = [c.strip() for c in row]
            if not row or not row[0] or row[0].startswith("#"):
                continue
            if len(row) < 2:
                raise ValueError(f"{path}:{lineno}: expected two columns time_s, speed")
            try:
                t, v = float(row[0]), float(row[1])
            except ValueError:
                if not times and lineno == 1:
                    continue  # header
                raise ValueError(f"{path}:{lineno}: {row[:2]} are not numbers") from None
            if not (math.isfinite(t) and math.isfinite(v)) or v < 0:
                raise ValueError(f"{path}:{lineno}: time and speed must be finite, speed >= 0")
            if times and t < times[-1]:
                raise ValueError(f"{path}:{lineno}: time {t:g} goes backwards")
            times.append(t)
            values.append(v)
    if not times:
        raise ValueError(f"{path}: no rows")
    return SpeedProfile(times, values, unit, text=str(path))


# --------------------------------------------------------------------------- the publisher
#: ``bkabem speed --help``: what it publishes and the profile syntax.
PROFILE_HELP = """\
Publish a shaft-speed profile on the speed topic (std_msgs/msg/Float64, rad/s by default as REP 103 says;
the node's speed_unit parameter must match --publish-unit).

profiles (values in --unit, default Hz; the same syntax as bkabem synth --profile):
  constant:V             V forever (or for --seconds)
  ramp:A:B:T             linear from A to B in T seconds, then B held
  steps:V1,V2,...:T      each value held for T seconds, the last one held
  FILE.csv               two columns time_s, speed (an optional header line is skipped), linear between rows,
                         the last value held

Without --seconds a constant profile runs until interrupted; the others until their end plus --hold seconds."""


def add_parser(sub, add_case=None):
    """Register ``bkabem speed``."""
    from bkabem_ros.cli.base import finite_float, pos_int

    p = sub.add_parser("speed", help="publish a shaft-speed profile on the speed topic (std_msgs/Float64)",
                       description=PROFILE_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--profile", default="constant:25",
                   help="constant:V | ramp:A:B:SECONDS | steps:V1,V2,...:SECONDS | FILE.csv (default constant:25)")
    p.add_argument("--unit", default="hz", help="unit of the profile values: hz (default), rpm, rad/s")
    p.add_argument("--publish-unit", default="rad/s",
                   help="unit written on the topic; must match the node's speed_unit (default rad/s, REP 103)")
    p.add_argument("--rate", type=finite_float("--rate", 1e-3, maximum=1e5), default=50.0,
                   help="messages per second, 0.001 .. 100000 (default 50)")
    p.add_argument("--seconds", type=finite_float("--seconds", 0.0, strict=True), default=None,
                   help="stop after this long (default: a finite profile's end + --hold; constant: forever)")
    p.add_argument("--hold", type=finite_float("--hold", 0.0), default=1.0,
                   help="keep publishing the last value this long after a finite profile ends (s)")
    p.add_argument("--topic", default="speed", help="topic name (relative names follow --namespace)")
    p.add_argument("--namespace", default="", help="namespace, e.g. /machine_00")
    p.add_argument("--qos", choices=("reliable", "sensor_data"), default="reliable",
                   help="QoS of the speed topic: reliable (default) or sensor_data (best effort)")
    p.add_argument("--wait-subscribers", type=finite_float("--wait-subscribers", 0.0), default=0.0,
                   help="wait up to this long (s) for --subscribers subscribers before starting the profile clock")
    p.add_argument("--subscribers", type=pos_int("--subscribers", 1, 1000), default=1,
                   help="how many subscribers --wait-subscribers waits for (default 1; e.g. 2 for a node and a "
                        "monitor that both subscribe to the speed)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stdout")
    p.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=None,
                   help="everything after this goes to ROS (e.g. -r __ns:=/m1)")
    p.set_defaults(func=main, ros_network=True)
    return p


def main(args) -> int:
    from bkabem_ros.cli.base import fail
    from bkabem_ros.ros_env import check_names

    try:
        unit = normalize_unit(args.unit)
        pub_unit = normalize_unit(args.publish_unit)
        profile = parse_profile(args.profile, unit)
    except ValueError as exc:
        fail("speed", str(exc))
    top = max(profile.values) * SPEED_UNITS[unit]
    from bkabem_core.model.plausibility import BOUNDS  # the case bound; imported when the command runs

    fastest_hz = BOUNDS["operating.max_speed_hz"][1]
    if top > fastest_hz * TWO_PI:
        fail("speed", f"--profile: {max(profile.values):g} {unit} is above {fastest_hz:g} Hz, the fastest "
                      f"shaft any case may have (operating.max_speed_hz; a unit slip? --unit is {unit})")
    check_names([("--namespace", "namespace", args.namespace), ("--topic", "topic", args.topic)])
    duration = args.seconds
    if duration is None and profile.finite:
        duration = profile.end_s + args.hold

    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from std_msgs.msg import Float64

    from bkabem_ros.ros_env import init, until_stopped  # noqa: PLC0415

    init(["bkabem-speed", "--ros-args", *(args.ros_args or [])])   # + the discovery range in force, once
    node = None
    try:
        with until_stopped():
            node = rclpy.create_node("bkabem_speed", namespace=args.namespace or None)
            qos = qos_profile_sensor_data if args.qos == "sensor_data" else QoSProfile(
                depth=10, reliability=ReliabilityPolicy.RELIABLE)
            pub = node.create_publisher(Float64, args.topic, qos)
            if args.wait_subscribers > 0:
                t_end = time.monotonic() + args.wait_subscribers
                while pub.get_subscription_count() < args.subscribers and time.monotonic() < t_end:
                    rclpy.spin_once(node, timeout_sec=0.02)
            factor = SPEED_UNITS[unit] / SPEED_UNITS[pub_unit]
            period = 1.0 / args.rate
            t_start = time.monotonic()
            i = 0
            last_print = -1.0
            if not args.quiet:
                print(f"publishing {profile.text} [{unit}] on {pub.topic_name} in {pub_unit} at {args.rate:g} Hz",
                      flush=True)
            while rclpy.ok():
                # publish every message that is due (a burst when behind), then sleep until the next one;
                # sleeping per message would cap high rates (a 10 kHz flood) at the timer slack
                elapsed = time.monotonic() - t_start
                if duration is not None and i * period > duration + 1e-9:
                    break
                while i * period <= elapsed and (duration is None or i * period <= duration + 1e-9):
                    t = i * period
                    value = profile.at(t) * factor
                    pub.publish(Float64(data=value))
                    if not args.quiet and t - last_print >= 1.0:
                        print(f"t={t:8.2f} s  speed={value:10.4f} {pub_unit}", flush=True)
                        last_print = t
                    i += 1
                delay = t_start + i * period - time.monotonic()
                if delay > 0:
                    time.sleep(max(delay, min(period, 0.001)))   # >= 1 ms: bursts of ~10 at 10 kHz
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


# --------------------------------------------------------------------------- the node's speed topic
class SpeedTypeWatch:
    """Warns once per publisher that offers the node's speed topic with a type other than :data:`SPEED_TYPE`: DDS
    never matches it, so its messages are lost without a word. Looks at the ROS graph every 2 s (steady clock).

    Parameters
    ----------
    node : rclpy.node.Node
    topic : str
        The speed topic's resolved name.
    unit_name : callable () -> str
        The speed unit the node reads now (for the warning).

    Attributes
    ----------
    seen : set of (str, str)
        ``(publisher node, its type)`` warned about.
    unnamed : dict
        Endpoint GID -> the checks for which the graph has not named the node of a publisher of the wrong type
        (reported by name once it is named, or without it after :data:`NAME_WAIT_CHECKS` checks).
    """

    def __init__(self, node, topic: str, unit_name):
        from rclpy.clock import Clock, ClockType

        self.node, self.topic, self.unit_name = node, topic, unit_name
        self.seen: set[tuple[str, str]] = set()
        self.unnamed: dict[bytes, int] = {}
        self.timer = node.create_timer(2.0, self.check, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def check(self) -> None:
        """Warn once per publisher that offers the speed topic with a type other than std_msgs/msg/Float64."""
        try:
            infos = self.node.get_publishers_info_by_topic(self.topic)
        except Exception:  # noqa: BLE001 - graph queries fail during shutdown
            return
        for info in infos:
            if info.topic_type == SPEED_TYPE:
                continue
            if info.node_name == UNKNOWN_NODE_NAME:
                gid = bytes(info.endpoint_gid)
                self.unnamed[gid] = self.unnamed.get(gid, 0) + 1
                if self.unnamed[gid] < NAME_WAIT_CHECKS:
                    continue                     # the graph names it at a later check, as a rule the next one
            who = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
            key = (who, info.topic_type)
            if key not in self.seen:
                self.seen.add(key)
                self.node.get_logger().warning(
                    f"{self.topic}: publisher {who} offers type {info.topic_type}, not {SPEED_TYPE}; "
                    f"its messages never reach this node (publish std_msgs/msg/Float64 in {self.unit_name()})")
