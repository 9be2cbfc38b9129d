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
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .speed import SPEED_UNITS, check_speed, normalize_unit

TWO_PI = 2.0 * math.pi
BEARINGS = ("de", "nde")
QUANTITIES = ("acceleration", "displacement")
CHANNELS = ("vertical", "horizontal")
WAVEFORM_TYPE = "bkabem_msgs/msg/VibrationWaveform"
SPECTRUM_TYPE = "bkabem_msgs/msg/VibrationSpectrum"
FAULT_TYPE = "bkabem_msgs/msg/BearingFaultFrequencies"
SPEED_TYPE = "std_msgs/msg/Float64"
N_WAVEFORMS = len(BEARINGS) * len(QUANTITIES)   # waveform messages per chunk (first in a chunk's items)

Sink = Callable[[str, str, Any, int], None]


# --------------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: name, default (None: from the case), unit, description, live, range/choices."""

    name: str
    default: Any
    unit: str
    description: str
    live: bool = False
    range: tuple | None = None
    choices: tuple | None = None


#: Every parameter of the node, declared in this order (docs/ros_node.md has the same table).
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("case", "electric_motor_6010", "",
              "embedded case name or path of a case TOML file"),
    ParamSpec("machine_id", "", "",
              "machine (fleet) id written into every message; empty: the node's namespace without the "
              "leading '/', or 'bkabem' in the root namespace"),
    ParamSpec("sample_rate", 25600.0, "Hz", "samples per second and channel", range=(1000.0, 204800.0)),
    ParamSpec("chunk_duration", 0.1, "s",
              "length of one waveform message; samples per chunk = round(sample_rate * chunk_duration)",
              range=(0.005, 2.0)),
    ParamSpec("seed", 0, "", "seed of the random parts (noise, slip); the same seed gives the same samples",
              range=(0, 2**31 - 1)),
    ParamSpec("noise.acceleration", 0.0, "m/s^2",
              "RMS of white Gaussian sensor noise (0 to sample_rate/2) on the acceleration channels",
              live=True, range=(0.0, 1.0e4)),
    ParamSpec("noise.displacement", 0.0, "m",
              "RMS of white Gaussian sensor noise on the displacement channels", live=True, range=(0.0, 1.0e-2)),
    ParamSpec("noise.snr_db", 0.0, "dB",
              "instead of the two RMS values: noise RMS = each channel's dynamic signal RMS / 10^(snr_db/20); "
              "0 = off (use the RMS values)", live=True, range=(0.0, 200.0)),
    ParamSpec("slip", 0.0, "",
              "random ball slip: standard deviation of the ball-pass interval as a fraction of it (real bearings "
              "0.01-0.02; smears the high orders)", range=(0.0, 0.1)),
    ParamSpec("defect_depth", None, "m",
              "dent depth; default the case's dent.depth_m. A change recomputes the 4-DOF excitation in a "
              "helper process (~2 s) and switches to it at a chunk boundary", live=True, range=(0.0, 1.0e-3)),
    ParamSpec("speed_unit", "rad/s", "",
              "unit of the speed topic: rad/s (REP 103), hz or rpm", live=True, choices=("rad/s", "hz", "rpm")),
    ParamSpec("max_speed", None, "rad/s",
              "speeds above it are rejected; default the case's operating.max_speed_hz (as rad/s)",
              live=True, range=(0.0, 1.0e5)),
    ParamSpec("wait_for_speed", False, "",
              "true: publish nothing until the first valid speed arrives; false: start at once at speed 0 "
              "(the static part of the response)"),
    ParamSpec("spectrum_rate", 1.0, "Hz",
              "spectra and fault frequencies per second besides the ones sent on a speed change; 0: only on "
              "speed change", live=True, range=(0.0, 50.0)),
    ParamSpec("qos", "sensor_data", "",
              "QoS of the outputs: sensor_data (best effort, volatile) or reliable", choices=("sensor_data", "reliable")),
    ParamSpec("qos_depth", 10, "messages", "history depth (keep last) of the outputs", range=(1, 1000)),
    ParamSpec("frame_id.de", "de_bearing", "", "frame_id of the drive-end sensor messages"),
    ParamSpec("frame_id.nde", "nde_bearing", "", "frame_id of the non-drive-end sensor messages"),
)
PARAMETER_SPECS = {p.name: p for p in PARAMETERS}
LIVE_PARAMETERS = frozenset(p.name for p in PARAMETERS if p.live)


# --------------------------------------------------------------------------- model cache and helpers
_MODEL_CACHE: dict[str, Any] = {}
_MODEL_LOCK = threading.Lock()


def prepare_model(case, logger=None):
    """BKA-BEM model of ``case``, shared by all nodes of this process that use the same case (by hash)."""
    from bkabem_core.harmonic import BkaBem

    with _MODEL_LOCK:
        model = _MODEL_CACHE.get(case.case_hash)
        if model is None:
            if logger is not None:
                logger.info(f"preparing the BKA-BEM model of case {case.name} ({case.source}, hash "
                            f"{case.case_hash}): 4-DOF excitation + FE rotor ...")
            t0 = time.perf_counter()
            model = BkaBem(case)
            if logger is not None:
                pt = model.preparation_time_s
                logger.info(f"model prepared in {time.perf_counter() - t0:.2f} s (excitation "
                            f"{pt.get('excitation', 0.0):.2f} s, {model.orders.size} BPFO orders, solver "
                            f"{model.solver})")
            _MODEL_CACHE[case.case_hash] = model
        elif logger is not None:
            logger.info(f"reusing the BKA-BEM model of case {case.name} (hash {case.case_hash})")
        return model


_EXCITATION_CODE = (
    "import json, pickle, sys\n"
    "from bkabem_core.case import Case\n"
    "from bkabem_core.machine import Machine\n"
    "case = Case.from_dict(json.load(sys.stdin))\n"
    "sys.stdout.buffer.write(pickle.dumps(Machine(case, mesh=None).excitations()))\n"
)


class _ExcitationJob:
    """The 4-DOF integration of a changed case in a helper process (it holds the GIL for ~2 s: in a thread
    of the node it would delay the publications). A thread only waits for the process's output."""

    def __init__(self, case):
        import json
        import subprocess
        import sys

        self.case = case
        self.t_start = time.perf_counter()
        self._result = None
        self._error = None
        self._proc = subprocess.Popen([sys.executable, "-c", _EXCITATION_CODE], stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self._payload = json.dumps(case.raw).encode()
        self._thread = threading.Thread(target=self._wait, daemon=True, name="bkabem-excitation")
        self._thread.start()

    def _wait(self) -> None:
        import pickle

        try:
            out, err = self._proc.communicate(self._payload)
            if self._proc.returncode != 0:
                lines = err.decode(errors="replace").strip().splitlines()
                self._error = RuntimeError(lines[-1] if lines else f"exit code {self._proc.returncode}")
            else:
                self._result = pickle.loads(out)
        except Exception as exc:  # noqa: BLE001
            self._error = exc

    def done(self) -> bool:
        return not self._thread.is_alive()

    def result(self):
        if self._error is not None:
            raise self._error
        return self._result

    def cancel(self) -> None:
        if self._proc.poll() is None:
            self._proc.kill()


def _percentile(values, q) -> float:
    if not values:
        return float("nan")
    return float(np.percentile(np.asarray(values, dtype=float), q))


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
        from bkabem_core.case import Case

        self._sinks: list[Sink] = []
        self._sink_errors = 0
        self._coerce_numeric_overrides()
        # -- parameters, declared up front (the case first: two defaults come from it)
        self._declare("case")
        case_name = self.get_parameter("case").value
        self._base_case = Case.load(case_name or None)
        self._declare_all(self._base_case)
        p = {s.name: self.get_parameter(s.name).value for s in PARAMETERS}
        self._case = self._base_case
        if p["defect_depth"] != self._base_case.defect_depth_m:
            self._case = self._base_case.with_defect_depth(float(p["defect_depth"]))
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

        # -- model and synthesiser (BkaBem preparation ~2 s happens here, before any timer)
        self.model = prepare_model(self._case, self.get_logger())
        self._source = self._make_source(self.model)
        self._bpfo_per_hz = float(self.model.bpfo_per_hz)

        # -- publishers and the speed subscription
        from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy,
                               qos_profile_sensor_data)
        from std_msgs.msg import Float64

        from bkabem_msgs.msg import BearingFaultFrequencies, VibrationSpectrum, VibrationWaveform

        depth = int(p["qos_depth"])
        if p["qos"] == "reliable":
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.VOLATILE)
        else:
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                             reliability=qos_profile_sensor_data.reliability,
                             durability=qos_profile_sensor_data.durability)
        self.qos = qos
        # rclpy gives every publisher two QoS event handlers (incompatible QoS / type warnings) that each executor
        # cycle adds to its wait set; with many nodes in one executor that is most of the CPU. Only the first
        # waveform publisher keeps them (subscribers report incompatibilities on their side as well).
        from rclpy.event_handler import PublisherEventCallbacks

        quiet = PublisherEventCallbacks(use_default_callbacks=False)

        def pub(msg_type, name):
            return self.create_publisher(msg_type, name, qos, event_callbacks=None if not self._wave_pub else quiet)

        self._wave_pub = {}
        for b in BEARINGS:
            for q in QUANTITIES:
                self._wave_pub[(b, q)] = pub(VibrationWaveform, f"vibration/{b}/{q}")
        from .msgs import SI_UNITS
        from .waveform_cdr import WaveformEncoder

        self._wave_cdr = {(b, q): WaveformEncoder(machine_id=self.machine_id, location=b, quantity=q,
                                                  unit=SI_UNITS[q], channel_names=CHANNELS,
                                                  sample_rate=self.sample_rate,
                                                  samples_per_channel=self.samples_per_chunk, frame_id=self._frame[b])
                          for b in BEARINGS for q in QUANTITIES}
        self._spec_pub = {b: pub(VibrationSpectrum, f"vibration/{b}/spectrum") for b in BEARINGS}
        self._ff_pub = pub(BearingFaultFrequencies, "vibration/fault_frequencies")
        # best effort + keep last: matches reliable and best-effort publishers; a flood only overwrites
        speed_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                               reliability=ReliabilityPolicy.BEST_EFFORT)
        from rclpy.event_handler import SubscriptionEventCallbacks

        self._speed_sub = self.create_subscription(      # best effort + volatile: never incompatible, no handlers
            Float64, "speed", self._on_speed, speed_qos,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        self._speed_topic = self._speed_sub.topic_name
        # a publisher of another type on `speed` never matches (DDS drops it silently): look at the graph
        from rclpy.clock import Clock, ClockType

        self._wrong_speed_publishers: set[tuple[str, str]] = set()
        self._graph_timer = self.create_timer(2.0, self._check_speed_publishers,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))

        # -- state
        self._speed_rad_s = 0.0            # last good speed (rad/s)
        self._have_speed = False
        self._speed_count = 0
        self._speed_rejected = 0
        self._started = False
        self._t0_ns: int | None = None
        self._pending: _Prepared | None = None
        self._primed: _Prepared | None = None   # chunk 0 made ahead by prime(), stamped from t0 = 0
        self._timer = None
        self._poll_timer = None
        self._last_spectrum_speed: float | None = None
        self._next_spectrum_ns = 0
        self._spectra = 0
        self._lateness_ns: deque[int] = deque(maxlen=100_000)        # waveforms handed to DDS - due
        self._start_lateness_ns: deque[int] = deque(maxlen=100_000)  # publication started - due
        self._published_chunks = 0
        self._reanchors = 0
        self._depth_job: _ExcitationJob | None = None
        self._depth_pending: float | None = None
        self._last_now_ns = 0

        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._after_set_parameters)
        self.get_logger().info(
            f"machine {self.machine_id!r}: case {self._case.name}, {self.sample_rate:g} Hz, "
            f"{self.samples_per_chunk} samples/chunk ({self.chunk_ns / 1e6:g} ms), QoS {p['qos']} depth {depth}, "
            f"speed in {normalize_unit(p['speed_unit'])} on {self._speed_topic}, max {self._max_speed:g} rad/s")
        if start:
            self.start()

    # ------------------------------------------------------------------ parameters
    def _coerce_numeric_overrides(self) -> None:
        """YAML ``sample_rate: 51200`` is an integer: accept it for a double parameter (and 2.0 for ints)."""
        from rclpy.parameter import Parameter

        ov = self._parameter_overrides
        for spec in PARAMETERS:
            prm = ov.get(spec.name)
            if prm is None:
                continue
            want_float = isinstance(spec.default, float) or (spec.default is None)
            if want_float and prm.type_ == Parameter.Type.INTEGER:
                ov[spec.name] = Parameter(spec.name, Parameter.Type.DOUBLE, float(prm.value))
            elif isinstance(spec.default, int) and not isinstance(spec.default, bool) and \
                    prm.type_ == Parameter.Type.DOUBLE and float(prm.value).is_integer():
                ov[spec.name] = Parameter(spec.name, Parameter.Type.INTEGER, int(prm.value))

    def _descriptor(self, spec: ParamSpec, value):
        from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

        text = spec.description
        if spec.unit:
            text += f" [{spec.unit}]"
        if spec.choices:
            text += f" (one of: {', '.join(spec.choices)})"
        text += "; changeable at run time" if spec.live else "; fixed while the node runs"
        d = ParameterDescriptor(description=text, read_only=False)
        if spec.range is not None:
            lo, hi = spec.range
            if isinstance(value, float):
                d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
            else:
                d.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=1)]
        if spec.choices:
            d.additional_constraints = f"one of: {', '.join(spec.choices)}"
        return d

    def _declare(self, name: str, default=None) -> None:
        spec = PARAMETER_SPECS[name]
        value = spec.default if default is None else default
        self.declare_parameter(name, value, self._descriptor(spec, value))
        if spec.choices:
            v = self.get_parameter(name).value
            if name == "speed_unit":
                try:
                    v = normalize_unit(v)
                except ValueError:
                    pass
            if v not in spec.choices:
                raise ValueError(f"parameter {name}: {v!r} is not one of {', '.join(spec.choices)}")

    def _declare_all(self, case) -> None:
        derived = {"defect_depth": float(case.defect_depth_m),
                   "max_speed": float(case.max_speed_hz) * TWO_PI}
        for spec in PARAMETERS:
            if spec.name != "case":
                self._declare(spec.name, derived.get(spec.name))

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
        return SetParametersResult(successful=True)

    def _after_set_parameters(self, params) -> None:
        for prm in params:
            if prm.name not in LIVE_PARAMETERS:
                continue
            self._live[prm.name] = prm.value
            if prm.name == "speed_unit":
                self._speed_factor = SPEED_UNITS[normalize_unit(prm.value)]
            elif prm.name == "max_speed":
                self._max_speed = float(prm.value)
            elif prm.name.startswith("noise."):
                self._apply_noise()
            elif prm.name == "defect_depth":
                self._request_depth(float(prm.value))
            elif prm.name == "spectrum_rate":
                self._next_spectrum_ns = 0 if self._pending is None else self._pending.stamp_ns
            self.get_logger().info(f"parameter {prm.name} = {prm.value!r} (live)")

    # ------------------------------------------------------------------ synthesiser adapter
    def _make_source(self, model):
        """The waveform synthesiser (bkabem_core.synth): all physics of the samples lives there."""
        from bkabem_core.synth import Synthesizer

        # spectrum="exact": the model's own response at each new speed (a pole sum of the reduced model, ~0.1 ms),
        # no speed cells to build inside the timer when a defect-depth change swaps the model
        synth = Synthesizer(model, sample_rate_hz=self.sample_rate, chunk_s=self.samples_per_chunk / self.sample_rate,
                            seed=self._seed, slip=self._slip, band_limit="taper", features=False, spectrum="exact")
        if synth.chunk_samples != self.samples_per_chunk:
            raise RuntimeError(f"synth chunk of {synth.chunk_samples} samples, node expects {self.samples_per_chunk}")
        self._synth = synth
        synth.max_knots_per_step = max(4, int(0.4 * (self.samples_per_chunk / self.sample_rate) / self.KNOT_COST_S))
        self._apply_noise()
        return synth

    def _apply_noise(self) -> None:
        """Noise parameters -> the synthesiser (from its next chunk on). RMS over 0..fs/2 -> one-sided density."""
        live = self._live
        if float(live["noise.snr_db"]) > 0.0:
            self._synth.set_noise(snr_db=float(live["noise.snr_db"]))
            return
        root = math.sqrt(self.sample_rate / 2.0)
        dens = {q: float(live[f"noise.{q}"]) / root for q in QUANTITIES if float(live[f"noise.{q}"]) > 0.0}
        self._synth.set_noise(noise_density=dens or None)

    #: Seconds of synthesis per amplitude knot assumed when limiting the knots of a fast speed change.
    KNOT_COST_S = 0.0025

    def _next_chunk(self, end_speed_hz: float):
        """``synth.next_chunk`` with a bounded cost. The synthesiser places amplitude knots at most
        ``max_speed_step_hz`` (0.5 Hz) apart, and 2 % apart in speed where orders cross the Nyquist taper; a jump
        of tens of Hz within one chunk would need dozens of knots (~0.5-2 ms each) and could make the next
        publication late. ``synth.max_knots_per_step`` (set in :meth:`_make_source`) caps the knots of one chunk
        so that they take at most ~40 % of a chunk period, whatever the jump (to or from 0 included); phase and
        speed stay exact, only the amplitude interpolation through the (already non-stationary) transient is
        coarser."""
        return self._synth.next_chunk(end_speed_hz)

    def _line_spectrum(self, speed_hz: float):
        """Complex channel amplitudes (orders, channels) and static part (channels,) of the synthesiser at a speed:
        exactly the lines its waveform holds (quantity, sensor point, Nyquist taper, low-speed fade), with the
        phase origin at cage angle 0."""
        ls = self._synth.line_spectrum(speed_hz)
        return np.asarray(ls["amplitude"]), np.asarray(ls["dc"])

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
        why = check_speed(rad_s, self._max_speed)
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

    def _check_speed_publishers(self) -> None:
        """Warn once per publisher that offers the speed topic with a type other than std_msgs/msg/Float64."""
        try:
            infos = self.get_publishers_info_by_topic(self._speed_topic)
        except Exception:  # noqa: BLE001 - graph queries fail during shutdown
            return
        for info in infos:
            if info.topic_type == SPEED_TYPE:
                continue
            who = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
            key = (who, info.topic_type)
            if key not in self._wrong_speed_publishers:
                self._wrong_speed_publishers.add(key)
                self.get_logger().warning(
                    f"{self._speed_topic}: publisher {who} offers type {info.topic_type}, not {SPEED_TYPE}; "
                    f"its messages never reach this node (publish std_msgs/msg/Float64 in {self._speed_unit_name()})")

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
        if self._started or self._primed is not None or self._wait_for_speed:
            return
        self._primed = self._prepare(0, 0)

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
        self._timer = self.create_timer(self.samples_per_chunk / self.sample_rate, self._on_tick)
        now = self.get_clock().now().nanoseconds
        self._last_now_ns = now
        primed, self._primed = self._primed, None
        if primed is None:
            self._pending = self._prepare(0, now)
        else:                                   # chunk 0 made by prime() with t0 = 0: move it to t0 = now
            self._t0_ns = now
            self._restamp(primed)
            self._next_spectrum_ns += now
            self._pending = primed
        self.get_logger().info(f"streaming from t0 = {now / 1e9:.6f} s at {self._speed_rad_s:g} rad/s")
        return True

    # ------------------------------------------------------------------ production
    def _prepare(self, index: int, t0_ns: int | None = None) -> _Prepared:
        """Synthesise the chunk that starts at sample ``index`` and build its messages.

        Called when the chunk's first sample is due (one chunk ahead of its publication). The last good speed
        becomes the speed at the *end* of this chunk; the synthesiser ramps linearly to it from the previous
        chunk's end speed (angle and speed continuous), so ``shaft_speed`` (first sample) is that previous speed.
        """
        if t0_ns is not None:
            self._t0_ns = t0_ns
        self._poll_depth_job()
        n = self.samples_per_chunk
        stamp = self._t0_ns + int(round(index * 1e9 / self.sample_rate))
        due = self._t0_ns + int(round((index + n) * 1e9 / self.sample_rate))
        chunk = self._next_chunk(self._speed_rad_s / TWO_PI)
        if int(chunk.first_sample_index) != index:
            raise RuntimeError(f"synth produced index {chunk.first_sample_index}, expected {index}")
        speed = float(chunk.shaft_speed_hz) * TWO_PI          # at the first sample
        # the waveforms straight to CDR (waveform_cdr: the constant part of each stream encoded once); message
        # objects only for sinks (recorders, viewers), made from the same bytes when one asks for them
        items = []
        for b in BEARINGS:
            for q in QUANTITIES:
                raw = self._wave_cdr[(b, q)].encode(chunk.samples[chunk.rows(b, q)], first_sample_index=index,
                                                    shaft_speed=speed, stamp_ns=stamp)
                items.append((self._wave_pub[(b, q)], WAVEFORM_TYPE, None, raw))
        rate = float(self._live["spectrum_rate"])
        if (self._last_spectrum_speed is None or speed != self._last_spectrum_speed
                or (rate > 0 and stamp >= self._next_spectrum_ns)):
            # spectra and fault frequencies (at most spectrum_rate + speed changes per second): message objects,
            # serialised now, off the publication path
            from rclpy.serialization import serialize_message

            items += [(pub, type_name, msg, serialize_message(msg))
                      for pub, type_name, msg in self._spectrum_items(chunk, stamp)]
            self._last_spectrum_speed = speed
            if rate > 0:
                self._next_spectrum_ns = stamp + int(1e9 / rate)
        return _Prepared(index=index, stamp_ns=stamp, due_ns=due, speed_rad_s=speed, items=items)

    def _spectrum_items(self, chunk, stamp: int) -> list:
        """Spectra (per bearing and quantity) and fault frequencies at the chunk's first-sample speed, with the
        phase origin at the chunk's first sample (order k turned by k z cage_angle there)."""
        from .msgs import fault_frequencies_message, spectrum_message

        speed_hz = float(chunk.shaft_speed_hz)
        speed_rad_s = speed_hz * TWO_PI
        y, dc = self._line_spectrum(speed_hz)                       # (K, C), (C,)
        orders = self._synth.line_orders()                              # BPFO orders (any line: nu / BPFO)
        y = y * np.exp(1j * self._synth.line_phases_rad(chunk))[:, None]
        freq = np.concatenate([[0.0], self._synth.frequency_hz(speed_hz)])
        k_all = np.concatenate([[0.0], orders])
        items = []
        for b in BEARINGS:
            for q in QUANTITIES:
                rows = chunk.rows(b, q)
                yy = y[:, rows].T                                      # (2, K)
                d = np.asarray(dc[rows], dtype=float)
                amp = np.concatenate([np.abs(d)[:, None], np.abs(yy)], axis=1)
                ph = np.concatenate([np.where(d < 0, np.pi, 0.0)[:, None], np.angle(yy)], axis=1)
                msg = spectrum_message(freq, k_all, amp, ph, shaft_speed=speed_rad_s, machine_id=self.machine_id,
                                       location=b, quantity=q, channel_names=CHANNELS, stamp=stamp,
                                       frame_id=self._frame[b])
                items.append((self._spec_pub[b], SPECTRUM_TYPE, msg))
        ff = self.model.fault_multipliers.at_speed(speed_hz)
        dent = self._case.dent()
        msg = fault_frequencies_message(
            shaft_speed=speed_rad_s, ftf=ff.ftf, bpfo=ff.bpfo, bpfi=ff.bpfi, bsf=ff.bsf, machine_id=self.machine_id,
            bearing_designation=self._case.bearing_geometry().designation, defect_bearing=dent.bearing,
            defect_race=dent.race, defect_length=dent.length_m, defect_depth=dent.depth_m,
            defect_angle=dent.angle_rad, stamp=stamp, frame_id=self._frame[dent.bearing])
        items.append((self._ff_pub, FAULT_TYPE, msg))
        self._spectra += 1
        return items

    # ------------------------------------------------------------------ publication
    def _on_tick(self) -> None:
        now = self.get_clock().now().nanoseconds
        pend = self._pending
        period = self.chunk_ns
        if now < self._last_now_ns - period:      # ROS time jumped back (sim time loop): re-anchor
            self._reanchor(now)
            pend = self._pending
        self._last_now_ns = now
        behind = (now - pend.due_ns) / period
        if behind > 50:                            # paused or a big jump forward: do not synthesise a backlog
            self._reanchor(now)
            pend = self._pending
        half = period / 2
        while pend.due_ns <= now + half:
            self._start_lateness_ns.append(self.get_clock().now().nanoseconds - pend.due_ns)
            items = pend.items
            for pub, _type_name, _msg, raw in items[:N_WAVEFORMS]:
                pub.publish(raw)
            self._lateness_ns.append(self.get_clock().now().nanoseconds - pend.due_ns)
            for pub, _type_name, _msg, raw in items[N_WAVEFORMS:]:      # spectra, fault frequencies
                pub.publish(raw)
            self._published_chunks += 1
            if self._sinks:
                for pub, type_name, msg, raw in items:
                    self._emit(pub.topic_name, type_name, _message(pub, msg, raw), pend.stamp_ns)
            pend = self._pending = self._prepare(pend.index + self.samples_per_chunk)
            now = self.get_clock().now().nanoseconds

    def _reanchor(self, now: int) -> None:
        """Keep the index, move t0 so that the pending chunk starts now (after a clock jump or stall)."""
        pend = self._pending
        old = pend.stamp_ns
        self._t0_ns = now - int(round(pend.index * 1e9 / self.sample_rate))
        self._restamp(pend)
        self._next_spectrum_ns = now
        self._reanchors += 1
        self.get_logger().warning(f"clock jumped from {old / 1e9:.6f} s to {now / 1e9:.6f} s: stamps re-anchored "
                                  f"at sample {pend.index} (indices stay continuous)")

    def _restamp(self, pend: _Prepared) -> None:
        """Stamp and due time of a prepared chunk (and its messages) from the current ``_t0_ns``: the stamp is
        written into the CDR bytes in place of the old one (every message starts with its header), and into the
        message object where there is one."""
        from .msgs import time_msg
        from .waveform_cdr import with_stamp

        pend.stamp_ns = self._t0_ns + int(round(pend.index * 1e9 / self.sample_rate))
        pend.due_ns = self._t0_ns + int(round((pend.index + self.samples_per_chunk) * 1e9 / self.sample_rate))
        items = []
        for pub, type_name, msg, raw in pend.items:
            if msg is not None:
                msg.header.stamp = time_msg(pend.stamp_ns)
            items.append((pub, type_name, msg, with_stamp(raw, pend.stamp_ns)))
        pend.items = items

    # ------------------------------------------------------------------ live defect depth
    def _request_depth(self, depth_m: float) -> None:
        if self._depth_job is not None and not self._depth_job.done():
            self._depth_pending = depth_m
            return
        self.get_logger().info(f"defect_depth {depth_m:g} m: recomputing the bearing excitations in a helper process")
        self._depth_job = _ExcitationJob(self._base_case.with_defect_depth(depth_m))
        self._depth_pending = None

    def _poll_depth_job(self) -> None:
        job = self._depth_job
        if job is None or not job.done():
            return
        self._depth_job = None
        try:
            ex = job.result()
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(f"defect_depth change failed: {exc!r}; keeping the current model")
        else:
            from bkabem_core.harmonic import BkaBem

            model = BkaBem(job.case, excitation=ex, like=self.model)
            self._case = job.case
            self.model = model
            self._swap_model(model)
            self._last_spectrum_speed = None  # a new spectrum with the next chunk
            self.get_logger().info(f"defect_depth {job.case.dent().depth_m:g} m in effect from the next chunk "
                                   f"(excitation took {time.perf_counter() - job.t_start:.2f} s)")
        if self._depth_pending is not None:
            self._request_depth(self._depth_pending)

    def _swap_model(self, model) -> None:
        self._synth.set_model(model)      # from the next knot (chunk border) on, phase continuous

    # ------------------------------------------------------------------ reporting and shutdown
    def stats(self) -> dict:
        """Counters and publish lateness in ms: ``lateness_*`` = time the chunk's four waveform messages had been
        handed to DDS minus the time its last sample was due (node clock); ``start_lateness_*`` = time the
        publication began minus that due time (the timer's wake-up delay); ``late_chunks`` = chunks handed to DDS a
        whole chunk period or more after they were due, ``lateness_max_chunk`` = the number of the latest one in the
        stream (0 = first)."""
        late = list(self._lateness_ns)
        start = list(self._start_lateness_ns)
        return {
            "machine_id": self.machine_id,
            "chunks": self._published_chunks,
            "next_index": None if self._pending is None else self._pending.index,
            "spectra": self._spectra,
            "speed_messages": self._speed_count,
            "speed_rejected": self._speed_rejected,
            "reanchors": self._reanchors,
            "sink_errors": self._sink_errors,
            "speed_publishers_wrong_type": len(self._wrong_speed_publishers),
            "lateness_ms_p50": _percentile(late, 50) / 1e6,
            "lateness_ms_p99": _percentile(late, 99) / 1e6,
            "lateness_ms_max": (max(late) / 1e6) if late else float("nan"),
            # where it was: the worst chunk's number (0 = the first published) and how many missed their period
            "lateness_max_chunk": int(np.argmax(late)) if late else None,
            "late_chunks": sum(1 for v in late if v >= self.chunk_ns),
            "start_lateness_ms_p50": _percentile(start, 50) / 1e6,
            "start_lateness_ms_p99": _percentile(start, 99) / 1e6,
        }

    def destroy_node(self):
        job = getattr(self, "_depth_job", None)      # not set when __init__ failed (a bad parameter)
        if job is not None:
            job.cancel()
        return super().destroy_node()


# --------------------------------------------------------------------------- running
def _stats_line(st: dict) -> str:
    return (f"stats: {st['chunks']} chunks (next index {st['next_index']}), {st['spectra']} spectra, "
            f"{st['speed_messages']} speed messages ({st['speed_rejected']} rejected), publish lateness "
            f"p50 {st['lateness_ms_p50']:.3f} ms p99 {st['lateness_ms_p99']:.3f} ms max {st['lateness_ms_max']:.3f} ms "
            f"(start p50 {st['start_lateness_ms_p50']:.3f} ms p99 {st['start_lateness_ms_p99']:.3f} ms)")


def _quiet_gc() -> None:
    """After start-up: move everything allocated so far (model, modules) out of the collector's view, so that
    a full collection during streaming scans only what the stream allocates (shorter pauses, less jitter)."""
    import gc

    gc.collect()
    gc.freeze()


def _exit_log(node, st: dict | None = None) -> None:
    """Final stats line. Not through the node's logger: after SIGINT/SIGTERM rclpy has already shut the
    context down, and a node logger would try (and fail) to publish on /rosout."""
    import rclpy.logging

    st = node.stats() if st is None else st
    rclpy.logging.get_logger("bkabem_exit").info(
        f"{node.get_fully_qualified_name()} ({st['machine_id']}) shutting down: {_stats_line(st)}")


def run(ros_args=None, overrides: dict | None = None, *, node_name: str = "bkabem", namespace: str | None = None,
        on_node: Callable | None = None) -> int:
    """Run one node until SIGINT/SIGTERM; returns the exit code (2 for bad parameters or case)."""
    import sys

    import rclpy
    from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from bkabem_core.case import CaseError

    from .ros_env import init  # noqa: PLC0415

    init(["bkabem-node", "--ros-args", *(ros_args or [])])   # + the discovery range in force, once
    node = None
    cleanup = None
    try:
        try:
            node = VibrationNode(node_name, namespace=namespace,
                                 parameter_overrides=[Parameter(k, value=v) for k, v in (overrides or {}).items()],
                                 start=False)
        except (CaseError, InvalidParameterValueException, InvalidParameterTypeException, ValueError) as exc:
            sys.stderr.write(f"bkabem node: error: {exc}\n")
            return 2
        if on_node is not None:
            cleanup = on_node(node)
        _quiet_gc()
        node.start()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        try:
            executor.spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        _exit_log(node)
        return 0
    finally:
        if cleanup is not None:
            cleanup()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
