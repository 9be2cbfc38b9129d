"""The bkabem ROS 2 node: a digital-twin vibration source for one machine with a faulty ball bearing.

Run it with ``bkabem node`` (``--ros-args ...`` passes through to ROS). Full documentation with the
parameter table: ``docs/ros_node.md``.

Topics (relative names: ``-r __ns:=/machine_07`` or ``--namespace`` puts one machine in a namespace)

=============================  ===================================  ==========================================
topic                          type                                 when
=============================  ===================================  ==========================================
``speed`` (in)                 ``std_msgs/msg/Float64``             shaft speed, rad/s (REP 103) or
                                                                    ``speed_unit`` (hz, rpm)
``vibration/de/acceleration``  ``bkabem_msgs/msg/VibrationWaveform`` every chunk: vertical + horizontal, m/s^2
``vibration/de/displacement``  ``VibrationWaveform``                every chunk, m
``vibration/nde/acceleration`` ``VibrationWaveform``                every chunk, m/s^2
``vibration/nde/displacement`` ``VibrationWaveform``                every chunk, m
``vibration/de/spectrum``      ``bkabem_msgs/msg/VibrationSpectrum`` on speed change and at ``spectrum_rate``;
``vibration/nde/spectrum``                                          one message per quantity (acc., displ.)
``vibration/fault_frequencies`` ``bkabem_msgs/msg/BearingFaultFrequencies`` with the spectra
``/diagnostics``               ``diagnostic_msgs/msg/DiagnosticArray`` once a second: stream on time, model, band
                                                                    limit, ISO zone per bearing (REP 107;
                                                                    :mod:`bkabem_ros.node.diagnostics`)
=============================  ===================================  ==========================================

Timing
------
The node keeps a sample clock: sample ``i`` of the stream is at ``t0 + i / sample_rate`` where ``t0`` is
the node-clock time (ROS time: ``/clock`` with ``use_sim_time``) at which the stream started. A chunk
holds samples ``[j N, (j + 1) N)``; it is *synthesised* when its first sample is due (with the speed
known at that moment: ``shaft_speed`` is the speed at the first sample) and *published* when its last
sample is due, by a timer of period ``N / sample_rate`` on the node clock. The header stamp is computed
from the sample index, never from the time the callback ran; a late timer publishes every chunk that is
due, so ``first_sample_index`` never skips or repeats. A speed change therefore shows in the first
chunk that starts after it arrived (within one chunk of sample time) and is published one chunk later.
Spectra and fault frequencies are stamped with the first sample of the chunk they belong to and are
published together with it.

Sinks (hook for recorders and viewers)
--------------------------------------
``node.add_sink(fn)`` attaches a callable ``fn(topic, type_name, msg, stamp_ns)`` that receives every
incoming speed message and every outgoing message, in the executor thread, right after it was taken or
published: ``topic`` is the fully resolved name (``/machine_07/vibration/de/acceleration``),
``type_name`` is ``"pkg/msg/Type"``, ``msg`` the message object (do not modify it), ``stamp_ns`` the
header stamp in ns (for the speed message, which has no header: the node-clock time of receipt).
Sinks must be quick (they run between publications); an exception in a sink is logged (throttled) and
does not stop the node. ``node.remove_sink(fn)`` detaches it. ``run(..., on_node=f)`` calls ``f(node)``
after construction so a command can attach sinks before the stream starts.
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from bkabem_ros.node.band import BandWatch, carries_to_band, start_note, start_refusal
from bkabem_ros.node.declare import (
    coerce_numeric_overrides,
    declare,
    declare_all,
    refuse_unknown_overrides,
    warn_undeclared,
)
from bkabem_ros.node.diagnostics import NodeDiagnostics
from bkabem_ros.node.params import (  # noqa: F401  (re-exported)
    DEPRECATED_NOISE,
    LIVE_PARAMETERS,
    PARAMETER_SPECS,
    PARAMETERS,
    ParamSpec,
)
from bkabem_ros.node.source import (
    TWO_PI,
    MachineSource,
    parse_labels,
)
from bkabem_ros.node.speed import (
    SPEED_TYPE,
    SPEED_UNITS,
    SpeedTypeWatch,
    bearing_limit_rad_s,
    check_speed,
    max_speed_refusal,
    normalize_unit,
)
from bkabem_ros.node.stream import ChunkStream, stream_qos

Sink = Callable[[str, str, Any, int], None]


# --------------------------------------------------------------------------- helpers
def _percentile(values, q) -> float:
    if not values:
        return float("nan")
    return float(np.percentile(np.asarray(values, dtype=float), q))


# --------------------------------------------------------------------------- the node
def _node_base():
    from rclpy.node import Node

    return Node


class VibrationNode(_node_base()):
    """bkabem digital-twin node (see the module docstring for topics, timing and sinks).

    Parameters
    ----------
    node_name : str
    namespace : str, optional
    context : rclpy.context.Context, optional
    parameter_overrides : list of rclpy.parameter.Parameter, optional
        Win over ``--ros-args -p`` / ``--params-file`` values (used for the CLI shorthand options).
    start : bool
        Start the stream (or the wait for speed / sim time) at once; False leaves it to :meth:`start`.
    """

    def __init__(self, node_name: str = "bkabem", *, namespace: str | None = None, context=None,
                 parameter_overrides=None, start: bool = True):
        super().__init__(node_name, namespace=namespace, context=context,
                         parameter_overrides=list(parameter_overrides or []))
        from bkabem_core.model.case import Case
        from bkabem_core.scenario.timeline import Scenario

        self._sinks: list[Sink] = []
        self._sink_errors = 0
        refuse_unknown_overrides(self)
        coerce_numeric_overrides(self)
        # -- parameters, declared up front (the machine first: two defaults come from it)
        declare(self, "case")
        declare(self, "scenario")
        case_name = self.get_parameter("case").value
        scenario_ref = self.get_parameter("scenario").value
        scenario = Scenario.load(scenario_ref) if scenario_ref else None
        base_case = scenario.case if scenario is not None else Case.load(case_name or None)
        declare_all(self, base_case)
        p = {s.name: self.get_parameter(s.name).value for s in PARAMETERS}
        case = base_case
        if p["defect_depth"] != base_case.defect_depth_m:
            if scenario is not None:
                raise ValueError(f"parameter defect_depth: scenario {scenario.name!r} sets the defects (leave "
                                 f"defect_depth at its default, or run without a scenario)")
            case = base_case.with_defect_depth(float(p["defect_depth"]))
        labels = parse_labels(p["labels"])
        self.machine_id = p["machine_id"] or self.get_namespace().strip("/") or "bkabem"
        self.sample_rate = float(p["sample_rate"])
        self.samples_per_chunk = max(1, int(round(self.sample_rate * float(p["chunk_duration"]))))
        self.chunk_ns = self.samples_per_chunk * 1e9 / self.sample_rate   # float ns (exact stamps use ints)
        self._seed = int(p["seed"])
        self._slip = float(p["slip"])
        self._frame = {"de": p["frame_id.de"], "nde": p["frame_id.nde"]}
        self._wait_for_speed = bool(p["wait_for_speed"])
        self._live = {k: p[k] for k in LIVE_PARAMETERS}
        self._speed_factor = SPEED_UNITS[normalize_unit(p["speed_unit"])]
        self._max_speed = float(p["max_speed"])
        self._limit_case, self._limit = case, bearing_limit_rad_s(case)    # the bearings' limiting speed
        why = max_speed_refusal(self._max_speed, self._limit)
        if why is not None:
            raise ValueError(f"parameter {why}")

        # -- model and synthesiser (BkaBem preparation ~2 s happens here, before any timer)
        self._source = MachineSource(
            base_case if scenario is not None else case, scenario=scenario,
            time_scale=float(p["scenario_time_scale"]), scenario_start_s=float(p["scenario_start"]),
            sample_rate_hz=self.sample_rate, samples_per_chunk=self.samples_per_chunk, seed=self._seed,
            slip=self._slip, machine_id=self.machine_id, frames=self._frame, labels=labels, logger=self.get_logger())
        # -- the sample rate against the lines (bkabem_ros.node.band): refused at start where `bkabem synth` refuses
        # --rate; the taper acting while the stream runs is a warning once per event
        why = start_refusal(self._source.synth, scenario, float(p["scenario_start"]), self._machine_label())
        if why is not None:
            raise ValueError(why)
        self._band = BandWatch(self.get_logger().warning, self.get_logger().info)
        self._apply_noise()
        self._scenario_loaded: dict[str, Scenario] = {}     # parameter callback -> post callback

        # -- publishers and the speed subscription
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Float64

        depth = int(p["qos_depth"])
        self.qos = qos = stream_qos(p["qos"], depth)
        self._stream = ChunkStream(self, qos)          # the publishers and the chunk waiting for its time
        self._diagnostics = NodeDiagnostics(self)        # the node's health on /diagnostics (REP 107), once a second
        # best effort + keep last: matches reliable and best-effort publishers; a flood only overwrites
        speed_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                               reliability=ReliabilityPolicy.BEST_EFFORT)
        from rclpy.event_handler import SubscriptionEventCallbacks

        self._speed_sub = self.create_subscription(      # best effort + volatile: never incompatible, no handlers
            Float64, "speed", self._on_speed, speed_qos,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        self._speed_topic = self._speed_sub.topic_name
        # a publisher of another type on `speed` never matches (DDS drops it silently): look at the graph
        self._speed_types = SpeedTypeWatch(self, self._speed_topic, self._speed_unit_name)

        # -- state
        self._speed_rad_s = 0.0            # last good speed (rad/s)
        self._have_speed = False
        self._speed_count = 0
        self._speed_rejected = 0
        self._started = False
        self._timer = None
        self._poll_timer = None

        self.add_pre_set_parameters_callback(lambda params: warn_undeclared(self, params))
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._after_set_parameters)
        what = f"scenario {scenario.name} (x{float(p['scenario_time_scale']):g})" if scenario is not None else \
            f"case {self._source.case.name}"
        if scenario is not None and scenario.has_speed:
            what += "; shaft speed from the scenario's [speed] profile (the speed topic is counted, not used)"
        self.get_logger().info(
            f"machine {self.machine_id!r}: {what}, {self.sample_rate:g} Hz, "
            f"{self.samples_per_chunk} samples/chunk ({self.chunk_ns / 1e6:g} ms), QoS {p['qos']} depth {depth}, "
            f"speed in {normalize_unit(p['speed_unit'])} on {self._speed_topic}, max {self._max_speed:g} rad/s")
        if scenario is None or not scenario.has_speed or carries_to_band(self._source.model):
            note = start_note(self._source.synth, self._max_speed / TWO_PI, self._machine_label())
            if note is not None:
                self.get_logger().info(note)
        if start:
            self.start()

    def _machine_label(self) -> str:
        """The model in the signal, for people: ``scenario 'x' state 2 (DE outer 0.39 mm x 10 um)`` or ``case ...``."""
        d = self._source.driver
        state = d.applied
        label = "" if state is None else f" ({state.label})"
        if d.scenario.name:
            return f"scenario {d.scenario.name!r} state {'?' if state is None else state.index}{label}"
        return f"case {self._source.case.name}{label}"

    # ------------------------------------------------------------------ parameters
    def _on_set_parameters(self, params):
        """Accept live changes (see LIVE_PARAMETERS); reject the rest with the reason."""
        from rcl_interfaces.msg import SetParametersResult

        for prm in params:
            spec = PARAMETER_SPECS.get(prm.name)
            if spec is None:
                continue  # use_sim_time etc.: rclpy's business
            if not spec.live:
                return SetParametersResult(
                    successful=False,
                    reason=f"{prm.name} is fixed while the node runs (it shapes the stream, the model or the "
                           f"topics); restart the node with the new value")
            if spec.choices:
                v = prm.value
                try:
                    v = normalize_unit(v) if prm.name == "speed_unit" else v
                except ValueError:
                    pass
                if v not in spec.choices:
                    return SetParametersResult(
                        successful=False, reason=f"{prm.name}: {prm.value!r} is not one of {', '.join(spec.choices)}")
            if prm.name == "max_speed" and self._speed_rad_s > float(prm.value):
                return SetParametersResult(
                    successful=False, reason=f"max_speed: {prm.value:g} rad/s is below the current speed "
                                             f"{self._speed_rad_s:g} rad/s")
            if prm.name == "max_speed" and (why := max_speed_refusal(float(prm.value), self._bearing_limit())):
                return SetParametersResult(successful=False, reason=why)
            if prm.name == "scenario":
                why = self._check_scenario(str(prm.value))
                if why is not None:
                    self.get_logger().warning(f"parameter scenario = {prm.value!r} refused, the node goes on with "
                                              f"what it runs: {why}")
                    return SetParametersResult(successful=False, reason=why)
            if prm.name == "defect_depth" and self._source.scenario is not None:
                return SetParametersResult(
                    successful=False, reason=f"defect_depth: scenario {self._source.scenario.name!r} sets the "
                                             f"defects; set scenario to '' first")
        return SetParametersResult(successful=True)

    def _check_scenario(self, ref: str) -> str | None:
        """Load the scenario of a parameter change (kept for the post callback); its one-line error, or None."""
        from bkabem_core.scenario.timeline import Scenario, ScenarioError

        if not ref:
            return None
        try:
            self._scenario_loaded[ref] = Scenario.load(ref)
        except ScenarioError as exc:
            return f"scenario: {exc}"
        return None

    def _after_set_parameters(self, params) -> None:
        for prm in params:
            if prm.name not in LIVE_PARAMETERS:
                continue
            self._live[prm.name] = prm.value
            if prm.name == "speed_unit":
                self._speed_factor = SPEED_UNITS[normalize_unit(prm.value)]
            elif prm.name == "max_speed":
                self._max_speed = float(prm.value)
            elif prm.name.startswith("noise"):
                self._apply_noise()
            elif prm.name == "defect_depth":
                self._request_depth(float(prm.value))
            elif prm.name == "scenario":
                self._source.set_scenario(self._scenario_loaded.pop(prm.value, None) if prm.value else None,
                                          self._next_index(), float(self._live["scenario_time_scale"]),
                                          float(self.get_parameter("scenario_start").value))
                self._scenario_loaded.clear()
            elif prm.name == "scenario_time_scale":
                self._source.set_time_scale(float(prm.value), self._next_index())
            elif prm.name == "spectrum_rate":
                self._stream.next_spectrum_ns = 0 if self._stream.pending is None else self._stream.pending.stamp_ns
            self.get_logger().info(f"parameter {prm.name} = {prm.value!r} (live)")

    # ------------------------------------------------------------------ the machine (bkabem_ros.node.source)
    @property
    def model(self):
        """The BKA-BEM model in the signal now."""
        return self._source.model

    @property
    def source(self) -> MachineSource:
        """The machine: model, synthesiser, scenario, message builders."""
        return self._source

    def _apply_noise(self) -> None:
        """Noise parameters -> the synthesiser (from its next chunk on): the densities ``noise_acc``,
        ``noise_disp``, or the RMS values of earlier versions converted to densities with a warning."""
        live = self._live
        root = math.sqrt(self.sample_rate / 2.0)
        density = {}
        for old, new in DEPRECATED_NOISE.items():
            value, rms = float(live[new]), float(live[old])
            if rms > 0.0:
                if value > 0.0:
                    self.get_logger().warning(f"parameter {old} (deprecated, an RMS) is ignored: {new} is set")
                else:
                    value = rms / root
                    self.get_logger().warning(
                        f"parameter {old} = {rms:g} (an RMS, deprecated) is read as {new} = {value:.4g} "
                        f"(a density: RMS / sqrt(sample_rate / 2)); write {new} instead")
            density[new] = value
        self._source.set_noise(density["noise_acc"], density["noise_disp"], float(live["noise.snr_db"]))

    def _next_index(self) -> int:
        """First sample of the next chunk still to be synthesised (where a change of the machine can begin)."""
        return self._stream.next_index()

    # ------------------------------------------------------------------ sinks
    def add_sink(self, sink: Sink) -> None:
        """Attach ``sink(topic, type_name, msg, stamp_ns)`` (see the module docstring)."""
        if not callable(sink):
            raise TypeError("sink must be callable(topic, type_name, msg, stamp_ns)")
        self._sinks.append(sink)

    def remove_sink(self, sink: Sink) -> None:
        self._sinks.remove(sink)

    def _emit(self, topic: str, type_name: str, msg, stamp_ns: int) -> None:
        for sink in self._sinks:
            try:
                sink(topic, type_name, msg, stamp_ns)
            except Exception as exc:  # noqa: BLE001 - a sink must not stop the stream
                self._sink_errors += 1
                self.get_logger().error(f"sink {sink!r} failed on {topic}: {exc!r}", throttle_duration_sec=5.0)

    # ------------------------------------------------------------------ speed input
    def _on_speed(self, msg) -> None:
        value = msg.data
        self._speed_count += 1
        rad_s = value * self._speed_factor
        why = check_speed(rad_s, self._max_speed, self._bearing_limit())
        if why is None:
            self._speed_rad_s = rad_s
            self._have_speed = True
        else:
            self._speed_rejected += 1
            self.get_logger().warning(
                f"speed {value!r} ignored: {why}; keeping {self._speed_rad_s:g} rad/s "
                f"({self._speed_rejected} rejected so far)", throttle_duration_sec=2.0)
        if self._sinks:
            self._emit(self._speed_topic, SPEED_TYPE, msg, self.get_clock().now().nanoseconds)
        if not self._started and why is None and self._wait_for_speed:
            self._try_start()

    def _bearing_limit(self) -> tuple[float, str] | None:
        """The fastest shaft the bearings of the machine in the signal allow [rad/s], and which bearing sets it."""
        case = self._source.case
        if case is not self._limit_case:                   # another scenario's machine
            self._limit_case, self._limit = case, bearing_limit_rad_s(case)
        return self._limit

    def _speed_unit_name(self) -> str:
        for name, factor in SPEED_UNITS.items():
            if factor == self._speed_factor:
                return name
        return "rad/s"

    @property
    def speed_rad_s(self) -> float:
        """Last good speed [rad/s]."""
        return self._speed_rad_s

    # ------------------------------------------------------------------ stream start
    def start(self) -> None:
        """Start the stream now if the clock is valid (and a speed arrived when wait_for_speed), else
        poll for it on the steady clock."""
        if not self._try_start() and self._poll_timer is None:
            from rclpy.clock import Clock, ClockType

            self._poll_timer = self.create_timer(0.02, self._try_start, clock=Clock(clock_type=ClockType.STEADY_TIME))
            why = "the first speed message" if self._wait_for_speed and not self._have_speed else "/clock (use_sim_time)"
            self.get_logger().info(f"waiting for {why} before streaming")

    def prime(self) -> None:
        """Synthesise and encode chunk 0 now (at the current speed), so that :meth:`start` only stamps it.

        The first chunk of a stream costs several times a later one (first knots, spectra, first calls: 1-4 ms
        against ~0.1-0.3 ms); a fleet process primes all its machines before it starts their streams one after
        the other within one chunk period. No effect once started, or with ``wait_for_speed`` (chunk 0 must
        wait for the speed)."""
        if self._started or self._stream.primed is not None or self._wait_for_speed:
            return
        self._stream.primed = self._stream.prepare(0, 0)

    def _try_start(self) -> bool:
        if self._started:
            return True
        if self._wait_for_speed and not self._have_speed:
            return False
        now = self.get_clock().now().nanoseconds
        if now == 0:   # sim time before the first /clock
            return False
        if self._poll_timer is not None:
            self._poll_timer.cancel()
            self.destroy_timer(self._poll_timer)
            self._poll_timer = None
        self._started = True
        # the timer's phase is its creation time: create it first, then take t0, then synthesise chunk 0
        self._timer = self.create_timer(self.samples_per_chunk / self.sample_rate, self._stream.on_tick)
        now = self.get_clock().now().nanoseconds
        self._stream.begin(now)
        self.get_logger().info(f"streaming from t0 = {now / 1e9:.6f} s at {self._speed_rad_s:g} rad/s")
        return True

    # ------------------------------------------------------------------ live defect depth
    def _request_depth(self, depth_m: float) -> None:
        """The case with its first defect at ``depth_m``, made in the model helper and switched to at a chunk border
        when ready (the stream goes on meanwhile; a newer request replaces an older one still waiting)."""
        case = self._source.base_case.with_defect_depth(depth_m)
        self._source.set_case(case, self._next_index(), f"defect_depth {case.dent().depth_m:g} m")

    # ------------------------------------------------------------------ reporting and shutdown
    def stats(self) -> dict:
        """Counters and publish lateness in ms: ``lateness_*`` = time the chunk's four waveform messages had been
        handed to DDS minus the time its last sample was due (node clock); ``start_lateness_*`` = time the
        publication began minus that due time (the timer's wake-up delay); ``late_chunks`` = chunks handed to DDS a
        whole chunk period or more after they were due, ``lateness_max_chunk`` = the number of the latest one in the
        stream (0 = first)."""
        stream = self._stream
        late = list(stream.lateness_ns)
        start = list(stream.start_lateness_ns)
        return {
            "machine_id": self.machine_id,
            "chunks": stream.published_chunks,
            "next_index": None if stream.pending is None else stream.pending.index,
            "spectra": stream.spectra,
            "speed_messages": self._speed_count,
            "speed_rejected": self._speed_rejected,
            "reanchors": stream.reanchors,
            "sink_errors": self._sink_errors,
            "speed_publishers_wrong_type": len(self._speed_types.seen),
            "lateness_ms_p50": _percentile(late, 50) / 1e6,
            "lateness_ms_p99": _percentile(late, 99) / 1e6,
            "lateness_ms_max": (max(late) / 1e6) if late else float("nan"),
            # where it was: the worst chunk's number (0 = the first published) and how many missed their period
            "lateness_max_chunk": int(np.argmax(late)) if late else None,
            "late_chunks": sum(1 for v in late if v >= self.chunk_ns),
            "start_lateness_ms_p50": _percentile(start, 50) / 1e6,
            "start_lateness_ms_p99": _percentile(start, 99) / 1e6,
            **self._source.stats(),
        }

    def destroy_node(self):
        src = getattr(self, "_source", None)        # not set when __init__ failed (a bad parameter)
        if src is not None:
            src.close()
        return super().destroy_node()
