"""Build bkabem_msgs messages from numpy arrays and back; message definitions for MCAP.

No physics here: these helpers only move arrays in and out of the messages defined in
``msg_defs/bkabem_msgs`` (see ``msg_defs/README.md``). All quantities are SI (REP 103):
s, Hz, rad, rad/s, m, m/s, m/s^2.

Speed notes
-----------
Assigning a numpy array to a ``float32[]``/``float64[]`` field makes rosidl check every
element (~0.5 ms per 4096 samples). The builders here hand over an ``array.array`` made from
the array's bytes instead (~2 us), and :func:`waveform_array` / :func:`spectrum_arrays` read
the fields back with ``np.frombuffer`` (no copy when the field is an ``array.array``, as it
is in messages from rclpy).

The ``bkabem_msgs`` / ``std_msgs`` modules are imported on first use, so
:func:`message_definition_text` and :func:`type_hash` work without loading rclpy.
"""

from __future__ import annotations

import array
import functools
import json
import numbers
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from bkabem_core.bearing.defects.registry import KINDS

__all__ = [
    "LOCATIONS",
    "QUANTITIES",
    "SI_UNITS",
    "SpectrumArrays",
    "bearing_kinematics",
    "bearing_kinematics_message",
    "fault_frequencies_message",
    "ground_truth_dict",
    "ground_truth_message",
    "message_definition_text",
    "spectrum_arrays",
    "spectrum_message",
    "stamp_to_ns",
    "time_msg",
    "type_hash",
    "type_name",
    "waveform_array",
    "waveform_message",
]

#: Allowed ``location`` / ``defect_bearing`` values (drive end, non-drive end).
LOCATIONS = ("de", "nde")
#: Allowed ``quantity`` values.
QUANTITIES = ("acceleration", "velocity", "displacement")
#: SI unit string used when ``unit`` is not given, per quantity.
SI_UNITS = {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}
#: Allowed ``defect_race`` / ``Defect.kind`` values: the defect kinds of bkabem_core.
RACES = KINDS

_PRIMITIVES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
})
_DELIMITER = "=" * 80


# --------------------------------------------------------------------------- helpers
def _msgs():
    from bkabem_msgs import msg  # noqa: PLC0415  (lazy: needs the built package)
    return msg


def time_msg(stamp: Any = None):
    """Return a ``builtin_interfaces/Time`` for ``stamp``.

    Parameters
    ----------
    stamp : int, builtin_interfaces.msg.Time, rclpy.time.Time or None
        Integer nanoseconds since the epoch (ROS time), a ``Time`` message (returned as is),
        an object with ``to_msg()`` (``rclpy.time.Time``), or None for time 0.
        Floats are refused: pass ``int(seconds * 1e9)`` to say what you mean.
    """
    from builtin_interfaces.msg import Time  # noqa: PLC0415

    if stamp is None:
        return Time()
    if isinstance(stamp, Time):
        return stamp
    if hasattr(stamp, "to_msg"):
        return stamp.to_msg()
    if isinstance(stamp, numbers.Integral) and not isinstance(stamp, bool):
        ns = int(stamp)
        if ns < 0:
            raise ValueError(f"stamp: {ns} ns is before the epoch")
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
    raise TypeError(f"stamp: expected int nanoseconds, Time or rclpy Time, got {type(stamp).__name__}")


def stamp_to_ns(stamp) -> int:
    """Return a ``builtin_interfaces/Time`` (or a header holding one) as integer ns."""
    stamp = getattr(stamp, "stamp", stamp)
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _header(stamp, frame_id: str):
    from std_msgs.msg import Header  # noqa: PLC0415

    return Header(stamp=time_msg(stamp), frame_id=str(frame_id))


def _f32(a: np.ndarray) -> array.array:
    return array.array("f", np.ascontiguousarray(a, dtype=np.float32).tobytes())


def _f64(a: np.ndarray) -> array.array:
    return array.array("d", np.ascontiguousarray(a, dtype=np.float64).tobytes())


def _choice(name: str, value: str, allowed: Sequence[str]) -> str:
    if value not in allowed:
        raise ValueError(f"{name}: {value!r} is not one of {', '.join(map(repr, allowed))}")
    return str(value)


def _finite(name: str, value: float, *, positive: bool = False, nonneg: bool = False) -> float:
    v = float(value)
    if not np.isfinite(v):
        raise ValueError(f"{name}: {value!r} must be finite")
    if positive and v <= 0.0:
        raise ValueError(f"{name}: {value!r} must be > 0")
    if nonneg and v < 0.0:
        raise ValueError(f"{name}: {value!r} must be >= 0")
    return v


def _channels(n: int, channel_names: Sequence[str] | None) -> list[str]:
    if channel_names is None:
        return [f"ch{c}" for c in range(n)]
    names = [str(c) for c in channel_names]
    if len(names) != n:
        raise ValueError(f"channel_names: {len(names)} names for {n} channels")
    return names


def _as_2d(name: str, a) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim == 1:
        a = a[np.newaxis, :]
    if a.ndim != 2:
        raise ValueError(f"{name}: expected shape (channels, n) or (n,), got {a.shape}")
    return a


# --------------------------------------------------------------------------- builders
def waveform_message(
    data,
    *,
    sample_rate: float,
    first_sample_index: int,
    shaft_speed: float,
    machine_id: str,
    location: str,
    quantity: str,
    unit: str | None = None,
    channel_names: Sequence[str] | None = None,
    stamp: Any = None,
    frame_id: str = "",
    ground_truth=None,
):
    """Build a ``bkabem_msgs/VibrationWaveform`` from a block of samples.

    Parameters
    ----------
    data : array_like, shape (channels, samples) or (samples,)
        Samples in ``unit`` (SI: m/s^2, m/s or m); converted to float32. Stored
        channel-major (all samples of channel 0, then channel 1, ...).
    sample_rate : float
        Samples per second and channel (Hz), > 0.
    first_sample_index : int
        Index of ``data[:, 0]`` in the stream (0-based, >= 0). The next block of the same
        stream starts at ``first_sample_index + samples``.
    shaft_speed : float
        Shaft speed at the first sample (rad/s).
    machine_id : str
        Machine (fleet) identifier.
    location : {"de", "nde"}
        Bearing location of the sensor.
    quantity : {"acceleration", "velocity", "displacement"}
        Measured quantity.
    unit : str, optional
        Unit of ``data``; default the SI unit of ``quantity`` ("m/s^2", "m/s", "m").
    channel_names : sequence of str, optional
        One name per channel (e.g. ``["vertical", "horizontal"]``); default "ch0", "ch1", ...
    stamp : int or Time, optional
        Time of the first sample: int ns, ``builtin_interfaces/Time`` or ``rclpy.time.Time``.
    frame_id : str
        Sensor frame.
    ground_truth : bkabem_msgs.msg.GroundTruth, optional
        The machine's ground truth (:func:`ground_truth_message`); default: none stated (``available`` false).

    Returns
    -------
    bkabem_msgs.msg.VibrationWaveform
    """
    a = _as_2d("data", data)
    n_ch, n = a.shape
    if not isinstance(first_sample_index, numbers.Integral) or first_sample_index < 0:
        raise ValueError(f"first_sample_index: {first_sample_index!r} must be an int >= 0")
    quantity = _choice("quantity", quantity, QUANTITIES)
    m = _msgs().VibrationWaveform()
    m.header = _header(stamp, frame_id)
    m.machine_id = str(machine_id)
    m.location = _choice("location", location, LOCATIONS)
    m.quantity = quantity
    m.unit = SI_UNITS[quantity] if unit is None else str(unit)
    m.channel_names = _channels(n_ch, channel_names)
    m.sample_rate = _finite("sample_rate", sample_rate, positive=True)
    m.first_sample_index = int(first_sample_index)
    m.shaft_speed = _finite("shaft_speed", shaft_speed)
    m.samples_per_channel = int(n)
    m.data = _f32(a)
    if ground_truth is not None:
        m.ground_truth = ground_truth
    return m


def spectrum_message(
    frequency,
    bpfo_order,
    amplitude,
    phase,
    *,
    shaft_speed: float,
    machine_id: str,
    location: str,
    quantity: str,
    unit: str | None = None,
    channel_names: Sequence[str] | None = None,
    stamp: Any = None,
    frame_id: str = "",
    ground_truth=None,
):
    """Build a ``bkabem_msgs/VibrationSpectrum`` (lines at BPFO orders).

    Channel ``c`` is ``sum_k amplitude[c, k] * cos(2*pi*frequency[k]*t + phase[c, k])``
    with ``t`` in s from ``stamp``.

    Parameters
    ----------
    frequency : array_like, shape (orders,)
        Line frequencies (Hz).
    bpfo_order : array_like, shape (orders,)
        BPFO order of each line (``frequency = bpfo_order * BPFO``; 0 = static part).
    amplitude : array_like, shape (channels, orders) or (orders,)
        Amplitudes in ``unit`` (>= 0); stored channel-major as float64.
    phase : array_like, same shape as ``amplitude``
        Phases (rad), cosine convention.
    shaft_speed : float
        Shaft speed the spectrum belongs to (rad/s).
    machine_id, location, quantity, unit, channel_names, stamp, frame_id, ground_truth
        As in :func:`waveform_message`.

    Returns
    -------
    bkabem_msgs.msg.VibrationSpectrum
    """
    f = np.asarray(frequency, dtype=np.float64).reshape(-1)
    k = np.asarray(bpfo_order, dtype=np.float64).reshape(-1)
    amp = _as_2d("amplitude", amplitude)
    ph = _as_2d("phase", phase)
    if k.shape != f.shape:
        raise ValueError(f"bpfo_order: {k.size} orders for {f.size} frequencies")
    if amp.shape[1] != f.size:
        raise ValueError(f"amplitude: shape {amp.shape} does not match {f.size} frequencies")
    if ph.shape != amp.shape:
        raise ValueError(f"phase: shape {ph.shape} differs from amplitude's {amp.shape}")
    quantity = _choice("quantity", quantity, QUANTITIES)
    m = _msgs().VibrationSpectrum()
    m.header = _header(stamp, frame_id)
    m.machine_id = str(machine_id)
    m.location = _choice("location", location, LOCATIONS)
    m.quantity = quantity
    m.unit = SI_UNITS[quantity] if unit is None else str(unit)
    m.channel_names = _channels(amp.shape[0], channel_names)
    m.shaft_speed = _finite("shaft_speed", shaft_speed)
    m.frequency = _f64(f)
    m.bpfo_order = _f64(k)
    m.amplitude = _f64(amp)
    m.phase = _f64(ph)
    if ground_truth is not None:
        m.ground_truth = ground_truth
    return m


def fault_frequencies_message(
    *,
    shaft_speed: float,
    ftf: float,
    bpfo: float,
    bpfi: float,
    bsf: float,
    machine_id: str,
    bearing_designation: str,
    defect_bearing: str,
    defect_length: float,
    defect_depth: float,
    defect_angle: float,
    defect_race: str = KINDS[0],
    stamp: Any = None,
    frame_id: str = "",
    ground_truth=None,
    bearings: Sequence[dict] | None = None,
):
    """Build a ``bkabem_msgs/BearingFaultFrequencies``.

    Parameters
    ----------
    shaft_speed : float
        Shaft speed (rad/s).
    ftf, bpfo, bpfi, bsf : float
        Cage, outer-race ball pass, inner-race ball pass and ball spin frequencies of the DE bearing (Hz).
    machine_id : str
        Machine (fleet) identifier.
    bearing_designation : str
        Designation of the DE bearing, e.g. "6205".
    defect_bearing : {"de", "nde"}
        Which bearing has the defect.
    defect_length : float
        Dent length along the raceway (m), >= 0.
    defect_depth : float
        Dent depth (m), >= 0.
    defect_angle : float
        Angular position of the dent centre from +x (horizontal) towards +y (up) (rad).
    defect_race : str
        The defect's kind (:data:`RACES`: ``"outer"``, ``"inner"``, ``"ball"``: a rolling element).
    stamp : int or Time, optional
        Time the shaft speed applies to (see :func:`time_msg`).
    frame_id : str
        Frame of the defective bearing.
    ground_truth : bkabem_msgs.msg.GroundTruth, optional
        Every defect and the rest of the ground truth (:func:`ground_truth_message`); the ``defect_*`` fields are
        the first defect only (the 0.1.0 layout).
    bearings : sequence of dict, optional
        Every bearing of the machine, DE first (:func:`bearing_kinematics_message`: ``bearing``, ``designation``,
        ``n_balls``, ``ball_diameter_m``, ``pitch_diameter_m``, ``contact_angle_rad``, ``ftf``, ``bpfo``,
        ``bpfi``, ``bsf`` [Hz]); the ``bearings`` field of bkabem_msgs 0.3.0.

    Returns
    -------
    bkabem_msgs.msg.BearingFaultFrequencies
    """
    m = _msgs().BearingFaultFrequencies()
    m.header = _header(stamp, frame_id)
    m.machine_id = str(machine_id)
    m.shaft_speed = _finite("shaft_speed", shaft_speed)
    m.ftf = _finite("ftf", ftf, nonneg=True)
    m.bpfo = _finite("bpfo", bpfo, nonneg=True)
    m.bpfi = _finite("bpfi", bpfi, nonneg=True)
    m.bsf = _finite("bsf", bsf, nonneg=True)
    m.bearing_designation = str(bearing_designation)
    m.defect_bearing = _choice("defect_bearing", defect_bearing, LOCATIONS)
    m.defect_race = _choice("defect_race", defect_race, RACES)
    m.defect_length = _finite("defect_length", defect_length, nonneg=True)
    m.defect_depth = _finite("defect_depth", defect_depth, nonneg=True)
    m.defect_angle = _finite("defect_angle", defect_angle)
    if ground_truth is not None:
        m.ground_truth = ground_truth
    if bearings is not None:
        m.bearings = [bearing_kinematics_message(b) for b in bearings]
    return m


def bearing_kinematics_message(d: dict):
    """A ``bkabem_msgs/BearingKinematics`` from a dict: ``bearing`` ("de"/"nde"), ``designation``, ``n_balls``,
    ``ball_diameter_m``, ``pitch_diameter_m``, ``contact_angle_rad`` (optional, 0 when unknown), ``ftf``, ``bpfo``,
    ``bpfi``, ``bsf`` [Hz]."""
    return _msgs().BearingKinematics(
        bearing=_choice("bearings.bearing", d["bearing"], LOCATIONS), designation=str(d.get("designation", "")),
        n_balls=int(d.get("n_balls", 0)),
        ball_diameter=_finite("bearings.ball_diameter_m", d.get("ball_diameter_m", 0.0), nonneg=True),
        pitch_diameter=_finite("bearings.pitch_diameter_m", d.get("pitch_diameter_m", 0.0), nonneg=True),
        contact_angle=_finite("bearings.contact_angle_rad", d.get("contact_angle_rad", 0.0)),
        **{k: _finite(f"bearings.{k}", d[k], nonneg=True) for k in ("ftf", "bpfo", "bpfi", "bsf")})


def bearing_kinematics(msg) -> dict:
    """Each bearing's kinematics of a ``BearingFaultFrequencies`` message, ``{"de": {...}, "nde": {...}}`` with
    ``designation``, ``n_balls``, ``ball_diameter_m``, ``pitch_diameter_m``, ``contact_angle_rad``, ``ftf``,
    ``bpfo``, ``bpfi``, ``bsf`` [Hz]. A message without the ``bearings`` field (bkabem_msgs 0.1.0, 0.2.0: one
    bearing type at both positions) gives its single fields for both bearings (``n_balls`` = BPFO / FTF, diameters
    0: not stated). Works on rclpy messages and the dynamic objects of mcap_ros2 / rosbags."""
    out = {}
    for b in getattr(msg, "bearings", None) or ():
        out[str(b.bearing)] = {"designation": str(b.designation), "n_balls": int(b.n_balls),
                               "ball_diameter_m": float(b.ball_diameter), "pitch_diameter_m": float(b.pitch_diameter),
                               "contact_angle_rad": float(b.contact_angle), "ftf": float(b.ftf),
                               "bpfo": float(b.bpfo), "bpfi": float(b.bpfi), "bsf": float(b.bsf)}
    if not out:
        ftf, bpfo = float(msg.ftf), float(msg.bpfo)
        shared = {"designation": str(getattr(msg, "bearing_designation", "")),
                  "n_balls": int(round(bpfo / ftf)) if ftf > 0 else 0, "ball_diameter_m": 0.0,
                  "pitch_diameter_m": 0.0, "contact_angle_rad": 0.0, "ftf": ftf, "bpfo": bpfo,
                  "bpfi": float(msg.bpfi), "bsf": float(msg.bsf)}
        out = {b: dict(shared) for b in LOCATIONS}
    return out


def ground_truth_message(gt: dict, labels: dict | None = None):
    """Build a ``bkabem_msgs/GroundTruth`` from a ground-truth dict of bkabem_core.

    Parameters
    ----------
    gt : dict
        :meth:`bkabem_core.scenario.timeline.Scenario.ground_truth` (a plain case: ``Scenario.of_case(case)``):
        ``defects`` (each with ``name``, ``race``, ``bearing``, ``length_m``, ``depth_m``, ``angle_rad``, ``edge``,
        ``fault_frequency``, ``fault_multiplier``, ``strike_multiplier``, optional ``ball``,
        ``bearing_designation`` (its own bearing's) and ``strike_frequency_hz``), ``bearing_designation``,
        ``healthy``, ``baseline`` (case ``[baseline]`` keys),
        ``case``, ``case_hash``, ``scenario``, ``scenario_hash``, ``state_index``, ``state_label``,
        ``state_start_s``, ``scenario_time_s``, ``time_scale``, ``load_factor``, ``labels``.
    labels : dict, optional
        More labels (the node's ``labels`` parameter); they win over ``gt["labels"]`` of the same key.

    Returns
    -------
    bkabem_msgs.msg.GroundTruth
        SI throughout: the balance grade in m/s (G 2.5 mm/s -> 0.0025), angles in rad.
    """
    M = _msgs()
    defects = []
    designation = str(gt.get("bearing_designation", ""))            # the DE bearing's (a ground truth of 0.2.0)
    for d in gt.get("defects", []):
        defects.append(M.Defect(
            name=str(d.get("name", "")), kind=_choice("defects.race", d["race"], RACES),
            bearing=_choice("defects.bearing", d["bearing"], LOCATIONS),
            bearing_designation=str(d.get("bearing_designation", designation)),
            ball=int(d.get("ball", 0) or 0), length=_finite("defects.length_m", d["length_m"], nonneg=True),
            depth=_finite("defects.depth_m", d["depth_m"], nonneg=True),
            angle=_finite("defects.angle_rad", d["angle_rad"]), edge=str(d.get("edge", "")),
            fault_frequency=str(d["fault_frequency"]),
            fault_multiplier=_finite("defects.fault_multiplier", d["fault_multiplier"], nonneg=True),
            strike_multiplier=_finite("defects.strike_multiplier", d["strike_multiplier"], nonneg=True),
            strike_frequency=_finite("defects.strike_frequency_hz", d.get("strike_frequency_hz") or 0.0,
                                     nonneg=True)))
    base = gt.get("baseline", {})
    lab = dict(gt.get("labels") or {})
    lab.update(labels or {})
    scale = gt.get("time_scale")
    return M.GroundTruth(
        available=True, healthy=bool(gt.get("healthy", not defects)), defects=defects,
        unbalance_grade=_finite("baseline.unbalance_grade_mm_s", base.get("unbalance_grade_mm_s", 0.0)) * 1e-3,
        unbalance_phase=_finite("baseline.unbalance_phase_deg", base.get("unbalance_phase_deg", 0.0)) * np.pi / 180,
        misalignment_force=_finite("baseline.misalignment_force_n", base.get("misalignment_force_n", 0.0)),
        electrical_force=_finite("baseline.electrical_force_n", base.get("electrical_force_n", 0.0)),
        line_frequency=_finite("baseline.line_frequency_hz", base.get("line_frequency_hz", 0.0)),
        load_factor=_finite("load_factor", gt.get("load_factor", 1.0)),
        case_name=str(gt.get("case", "")), case_hash=str(gt.get("case_hash", "")),
        scenario=str(gt.get("scenario", "") or ""), scenario_hash=str(gt.get("scenario_hash", "") or ""),
        state_index=int(gt.get("state_index", 0)), state_label=str(gt.get("state_label", "")),
        state_start_time=_finite("state_start_s", gt.get("state_start_s", 0.0)),
        scenario_time=_finite("scenario_time_s", gt.get("scenario_time_s", 0.0)),
        time_scale=_finite("time_scale", 1.0 if scale is None else scale),
        label_keys=[str(k) for k in lab], label_values=[str(v) for v in lab.values()])


def ground_truth_dict(msg) -> dict:
    """The ``ground_truth`` of a message (or a ``GroundTruth`` itself) as a plain dict, SI units in the key names
    (``length_m``, ``strike_frequency_hz``, ...); ``{"available": False}`` for a message without one (bkabem_msgs
    0.1.0). Works on rclpy messages and on the dynamic objects of mcap_ros2 / rosbags."""
    g = getattr(msg, "ground_truth", msg)
    if g is None or not hasattr(g, "available") or not bool(g.available):
        return {"available": False}
    defects = [{"name": str(d.name), "kind": str(d.kind), "race": str(d.kind), "bearing": str(d.bearing),
                "bearing_designation": str(d.bearing_designation), "ball": int(d.ball),
                "length_m": float(d.length), "depth_m": float(d.depth), "angle_rad": float(d.angle),
                "edge": str(d.edge), "fault_frequency": str(d.fault_frequency),
                "fault_multiplier": float(d.fault_multiplier), "strike_multiplier": float(d.strike_multiplier),
                "strike_frequency_hz": float(d.strike_frequency)} for d in g.defects]
    return {"available": True, "healthy": bool(g.healthy), "defects": defects,
            "baseline": {"unbalance_grade_m_s": float(g.unbalance_grade), "unbalance_phase_rad": float(g.unbalance_phase),
                         "misalignment_force_n": float(g.misalignment_force),
                         "electrical_force_n": float(g.electrical_force), "line_frequency_hz": float(g.line_frequency)},
            "load_factor": float(g.load_factor), "case": str(g.case_name), "case_hash": str(g.case_hash),
            "scenario": str(g.scenario), "scenario_hash": str(g.scenario_hash), "state_index": int(g.state_index),
            "state_label": str(g.state_label), "state_start_s": float(g.state_start_time),
            "scenario_time_s": float(g.scenario_time), "time_scale": float(g.time_scale),
            "labels": dict(zip((str(k) for k in g.label_keys), (str(v) for v in g.label_values)))}


# --------------------------------------------------------------------------- readers
def _view(field, dtype) -> np.ndarray:
    """Field as a 1-D numpy array; zero-copy for array.array (rclpy) and ndarray (rosbags)."""
    if isinstance(field, array.array) and field.itemsize == np.dtype(dtype).itemsize:
        return np.frombuffer(field, dtype=dtype)
    return np.asarray(field, dtype=dtype)  # no copy for an ndarray of that dtype; lists copy


def waveform_array(msg) -> np.ndarray:
    """Samples of a ``VibrationWaveform`` as an array of shape (channels, samples).

    Zero-copy view of ``msg.data`` when it is an ``array.array`` (rclpy) or a float32
    ndarray (rosbags); a copy when it is a list (mcap_ros2). Works on any object with
    the message's fields. Units: ``msg.unit``; sample ``i`` is at
    ``header.stamp + i / sample_rate``.
    """
    a = _view(msg.data, np.float32)
    n = int(msg.samples_per_channel)
    n_ch = len(msg.channel_names) if len(msg.channel_names) else (a.size // n if n else 0)
    if a.size != n_ch * n:
        raise ValueError(f"data: {a.size} values, expected {n_ch} channels x {n} samples")
    return a.reshape(n_ch, n)


class SpectrumArrays(NamedTuple):
    """Arrays of a ``VibrationSpectrum``: frequency (Hz), bpfo_order (-) of shape (orders,),
    amplitude (``unit``) and phase (rad) of shape (channels, orders)."""

    frequency: np.ndarray
    bpfo_order: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray


def spectrum_arrays(msg) -> SpectrumArrays:
    """Arrays of a ``VibrationSpectrum`` (zero-copy where the fields allow it)."""
    f = _view(msg.frequency, np.float64)
    k = _view(msg.bpfo_order, np.float64)
    amp = _view(msg.amplitude, np.float64)
    ph = _view(msg.phase, np.float64)
    n_ch = len(msg.channel_names) if len(msg.channel_names) else (amp.size // f.size if f.size else 0)
    if amp.size != n_ch * f.size or ph.size != amp.size or k.size != f.size:
        raise ValueError(f"spectrum: {amp.size} amplitudes / {ph.size} phases / {k.size} orders "
                         f"for {n_ch} channels x {f.size} frequencies")
    return SpectrumArrays(f, k, amp.reshape(n_ch, f.size), ph.reshape(n_ch, f.size))


# --------------------------------------------------------------------------- definitions
def type_name(t) -> str:
    """Normalise a message type to ``pkg/msg/Type``.

    Accepts ``"pkg/msg/Type"``, ``"pkg/Type"``, a message class or a message instance.
    """
    if not isinstance(t, str):
        cls = t if isinstance(t, type) else type(t)
        return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"
    parts = t.split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 3 and parts[1] == "msg":
        return t
    raise ValueError(f"type_name: {t!r} is not 'pkg/msg/Type' or 'pkg/Type'")


def _share_dirs() -> list[Path]:
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    prefixes.append(sys.prefix)
    return [Path(p) / "share" for p in dict.fromkeys(prefixes)]


def _interface_file(full_name: str, suffix: str) -> Path:
    pkg, _, name = full_name.split("/")
    for share in _share_dirs():
        p = share / pkg / "msg" / f"{name}{suffix}"
        if p.is_file():
            return p
    raise FileNotFoundError(
        f"{pkg}/msg/{name}{suffix} not found under {', '.join(map(str, _share_dirs()))} "
        "(is the package built into this environment? tools/setup_ros.sh)")


def _dependencies(text: str, pkg: str) -> list[str]:
    """Non-primitive field types of a .msg text, as written ('pkg/Type'), sorted."""
    deps = set()
    for line in text.splitlines():
        tokens = line.split("#", 1)[0].split()
        if len(tokens) < 2 or "=" in tokens[0]:
            continue
        t = tokens[0].split("[", 1)[0].split("<=", 1)[0]
        if t in _PRIMITIVES:
            continue
        deps.add(t if "/" in t else f"{pkg}/{t}")
    return sorted(deps)


@functools.lru_cache(maxsize=None)
def message_definition_text(t) -> str:
    """Full ``ros2msg`` definition of a message type, as rosbag2 writes it into MCAP schemas.

    The type's own ``.msg`` text, then for every nested type once (depth first, sorted):
    a line of 80 ``=``, a line ``MSG: pkg/Type``, and that type's ``.msg`` text. Read from
    ``<prefix>/share/<pkg>/msg/<Type>.msg`` for the prefixes in ``AMENT_PREFIX_PATH`` and
    ``sys.prefix``.

    Parameters
    ----------
    t : str or message class
        ``"bkabem_msgs/msg/VibrationWaveform"``, ``"bkabem_msgs/VibrationWaveform"`` or the class.

    Returns
    -------
    str
        Schema data for an MCAP schema with encoding ``ros2msg``.
    """
    seen: set[str] = set()

    def text_of(full: str) -> str:
        pkg = full.split("/", 1)[0]
        text = _interface_file(full, ".msg").read_text(encoding="utf-8")
        out = text
        for dep in _dependencies(text, pkg):
            if dep not in seen:
                seen.add(dep)
                out += f"\n{_DELIMITER}\nMSG: {dep}\n" + text_of(type_name(dep))
        return out

    return text_of(type_name(t))


@functools.lru_cache(maxsize=None)
def type_hash(t) -> str:
    """RIHS01 type hash (``"RIHS01_<64 hex>"``) of a message type, from the ``<Type>.json``
    that rosidl installs next to the ``.msg`` (the value for MCAP's ``topic_type_hash``)."""
    full = type_name(t)
    doc = json.loads(_interface_file(full, ".json").read_text(encoding="utf-8"))
    for entry in doc.get("type_hashes", []):
        if entry.get("type_name") == full:
            return str(entry["hash_string"])
    raise KeyError(f"no type hash for {full} in its .json")
