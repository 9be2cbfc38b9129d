"""Messages of older ``bkabem_msgs`` versions: recognised by their recorded definitions and read as today's.

Versions (``msg_defs/README.md``, "Versions"; the old ``.msg`` files are kept in ``msg_defs/history/``):

========  ==========================================================================================
0.1.0     VibrationWaveform, VibrationSpectrum, BearingFaultFrequencies (one defect: ``defect_*``)
0.2.0     + Defect, GroundTruth; ``GroundTruth ground_truth`` appended to all three
0.3.0     + BearingKinematics; ``BearingKinematics[] bearings`` appended to BearingFaultFrequencies (each
          bearing's own fault frequencies; the single ``ftf``, ``bpfo``, ... fields are the DE bearing's)
========  ==========================================================================================

A recording keeps the definitions it was written with (its MCAP ``ros2msg`` schemas). :func:`same_as_installed`
compares a recorded definition with the installed one, field by field (names and types of the type and of every
nested type; comments, constants and layout do not count). Where they differ, :class:`Reader` decodes the CDR with
the recorded definition and :func:`upgrade` turns the result into an instance of today's class: each field takes
the recorded value of the same name, a field the recording did not have keeps its default. A 0.1.0
``BearingFaultFrequencies`` also gets its ground truth from its ``defect_*`` fields; 0.1.0 waveforms and spectra had
none (``ground_truth.available`` stays false). A 0.1.0 or 0.2.0 ``BearingFaultFrequencies`` (one bearing type at
both positions) gets ``bearings``: both positions with its single fields. Because every version only appended
fields, a reader built from older definitions still decodes the fields it knows from newer messages.

No ROS graph needed; rclpy only for the message classes and serialisation.
"""

from __future__ import annotations

import array
import functools
import importlib
import re
from typing import Any

import numpy as np

from bkabem_core.bearing.defects.registry import find
from bkabem_core.bearing.defects.registry import kind as defect_kind
from bkabem_ros.messages import convert as msgs

#: rosidl's names of float element types -> (array.array code, numpy dtype)
_PRIMITIVE_ARRAYS = {"float": ("f", np.float32), "double": ("d", np.float64)}


def _fields_of(text: str) -> list[tuple[str, str]]:
    """``(type, name)`` of the fields of one .msg text (constants, comments and blank lines left out)."""
    out = []
    for line in text.splitlines():
        tokens = line.split("#", 1)[0].split()
        if len(tokens) < 2 or "=" in tokens[1] or "=" in tokens[0]:
            continue
        out.append((tokens[0], tokens[1]))
    return out


def _short(type_text: str) -> str:
    """``std_msgs/msg/Header`` / ``std_msgs/Header`` / ``Header`` (within its package) -> ``Header``, arrays kept."""
    base, _, rest = type_text.partition("[")
    return base.rsplit("/", 1)[-1] + (("[" + rest) if rest else "")


@functools.lru_cache(maxsize=256)
def definition_signature(text: str) -> tuple:
    """The fields of a full ``ros2msg`` definition (top type and every ``MSG:`` section), as a comparable value."""
    parts = re.split(r"^=+\s*$", text, flags=re.M)
    sections = []
    for i, part in enumerate(parts):
        body = part.strip("\n")
        name = ""
        if i > 0:
            first, _, body = body.partition("\n")
            name = _short(first.replace("MSG:", "").strip())
        sections.append((name, tuple((_short(t), n) for t, n in _fields_of(body))))
    top, nested = sections[0], sorted(sections[1:])
    return (top, tuple(nested))


@functools.lru_cache(maxsize=64)
def installed_signature(type_name: str) -> tuple | None:
    try:
        return definition_signature(msgs.message_definition_text(type_name))
    except (FileNotFoundError, ValueError):
        return None


def same_as_installed(type_name: str, recorded_text: str | None) -> bool:
    """Whether a recorded definition has the fields of the installed one (None / empty: assumed the same)."""
    if not recorded_text:
        return True
    mine = installed_signature(msgs.type_name(type_name))
    return mine is None or mine == definition_signature(recorded_text)


def version_of(type_name: str, recorded_text: str | None) -> str:
    """``"0.1.0"`` for a bkabem_msgs type recorded without ``ground_truth``, ``"0.2.0"`` for a
    ``BearingFaultFrequencies`` recorded without ``bearings``, else ``"current"``."""
    full = msgs.type_name(type_name)
    if full.startswith("bkabem_msgs/") and recorded_text:
        fields = {n for _, n in definition_signature(recorded_text)[0][1]}
        if "ground_truth" not in fields:
            return "0.1.0"
        if full == "bkabem_msgs/msg/BearingFaultFrequencies" and "bearings" not in fields:
            return "0.2.0"
    return "current"


# --------------------------------------------------------------------------- upgrading
_CLASSES: dict[str, Any] = {}


def message_class(type_name: str):
    """The rclpy message class for ``pkg/msg/Type`` (imports ``pkg.msg``), or None."""
    full = msgs.type_name(type_name)
    if full not in _CLASSES:
        pkg, _, name = full.split("/")
        try:
            _CLASSES[full] = getattr(importlib.import_module(f"{pkg}.msg"), name)
        except (ImportError, AttributeError):
            _CLASSES[full] = None
    return _CLASSES[full]


def _message_class(type_name: str):
    return message_class(type_name)


def upgrade(type_name: str, old: Any, cls=None):
    """An instance of today's class of ``type_name`` with the fields of ``old`` (any object with attributes, e.g.
    an mcap_ros2 dynamic message) that exist in both; the rest at their defaults (module docstring)."""
    cls = _message_class(type_name) if cls is None else cls
    new = cls()
    for name, ftype in cls.get_fields_and_field_types().items():
        if not hasattr(old, name):
            continue
        value = getattr(old, name)
        base = ftype.split("<", 1)[0]
        if base.startswith("sequence") or ftype.endswith("]"):
            inner = ftype[ftype.index("<") + 1:ftype.rindex(">")] if "<" in ftype else ftype[:ftype.index("[")]
            inner = inner.split(",", 1)[0]
            if inner in _PRIMITIVE_ARRAYS:
                code, dtype = _PRIMITIVE_ARRAYS[inner]
                value = array.array(code, np.asarray(value, dtype=dtype).tobytes())
            elif "/" in inner:
                sub = _class_of(inner)
                value = [upgrade(_full(inner), v, sub) for v in value]
            else:
                value = list(value)
        elif "/" in ftype:
            value = upgrade(_full(ftype), value, _class_of(ftype))
        setattr(new, name, value)
    if msgs.type_name(type_name) == "bkabem_msgs/msg/BearingFaultFrequencies":
        if not hasattr(old, "ground_truth"):
            _truth_from_defect_fields(new)
        if not hasattr(old, "bearings"):                     # one bearing type at both positions (0.1.0, 0.2.0)
            new.bearings = [msgs.bearing_kinematics_message({"bearing": b, **k})
                            for b, k in msgs.bearing_kinematics(new).items()]
    return new


def _full(rosidl_type: str) -> str:
    pkg, name = rosidl_type.split("/")
    return f"{pkg}/msg/{name}"


def _class_of(rosidl_type: str):
    return _message_class(_full(rosidl_type))


def _truth_from_defect_fields(m) -> None:
    """Ground truth of a 0.1.0 fault-frequency message: its one defect (an outer-race dent then)."""
    from bkabem_msgs.msg import Defect, GroundTruth  # noqa: PLC0415

    speed_hz = float(m.shaft_speed) / (2 * np.pi)
    kind = find(m.defect_race) or defect_kind("outer")        # 0.1.0 wrote outer-race dents only
    name = kind.fault_frequency
    multiplier = float(getattr(m, name)) / speed_hz if speed_hz > 0 else 0.0
    strike = kind.strikes * multiplier
    d = Defect(name="defects[0]", kind=m.defect_race or kind.name, bearing=m.defect_bearing or "de",
               bearing_designation=m.bearing_designation, length=float(m.defect_length),
               depth=float(m.defect_depth), angle=float(m.defect_angle), fault_frequency=name,
               fault_multiplier=multiplier, strike_multiplier=strike, strike_frequency=strike * speed_hz)
    m.ground_truth = GroundTruth(available=True, healthy=not float(m.defect_depth) > 0, defects=[d], load_factor=1.0,
                                 time_scale=1.0, state_label="recorded with bkabem_msgs 0.1.0 (one defect)")


class _Undecodable:
    """The decoder of a recorded definition that does not parse: raises its reason for every message."""

    def __init__(self, reason: str):
        self.reason = reason

    def __call__(self, data: bytes):
        raise ValueError(self.reason)


class Reader:
    """Decode recorded CDR (type name, bytes, recorded definition) into today's message classes.

    Recorded with the installed definitions (or no definition known): rclpy's deserialiser. Otherwise the recorded
    definition's decoder (mcap_ros2, built once per definition), then :func:`upgrade`. A type without an importable
    class stays the decoder's dynamic object.
    """

    def __init__(self):
        self._dynamic: dict[tuple, Any] = {}
        self.upgraded = 0

    def decode(self, type_name: str, data: bytes, schema_text: str | None):
        full = msgs.type_name(type_name)
        cls = _message_class(full)
        if cls is not None and same_as_installed(full, schema_text):
            try:
                from rclpy.serialization import deserialize_message  # noqa: PLC0415

                return deserialize_message(data, cls)
            except ImportError:
                pass
        msg = self._dynamic_decode(full, data, schema_text)
        if cls is not None:
            self.upgraded += 1
            return upgrade(full, msg, cls)
        return msg

    def _dynamic_decode(self, full: str, data: bytes, schema_text: str | None):
        text = schema_text if schema_text else msgs.message_definition_text(full)
        key = (full, text)
        fn = self._dynamic.get(key)
        if fn is None:
            from mcap_ros2._dynamic import generate_dynamic  # noqa: PLC0415

            try:
                fn = generate_dynamic(full, text)[full]
            except Exception as exc:  # noqa: BLE001 - a definition that does not parse: every message fails alike
                fn = _Undecodable(f"the recorded definition of {full} does not parse ({type(exc).__name__}: "
                                  f"{' '.join(str(exc).split())[:120]})")
            self._dynamic[key] = fn
        return fn(data)

    def to_current_cdr(self, type_name: str, data: bytes, schema_text: str | None) -> bytes:
        """The bytes to publish for a recorded message: as recorded when the definitions agree, else upgraded and
        serialised with today's class (subscribers use today's definitions)."""
        full = msgs.type_name(type_name)
        if same_as_installed(full, schema_text) or _message_class(full) is None:
            return data
        from rclpy.serialization import serialize_message  # noqa: PLC0415

        return serialize_message(self.decode(full, data, schema_text))
