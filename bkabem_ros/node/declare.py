"""Declaring the node's parameters: the table of :mod:`bkabem_ros.node.params` with descriptors (unit, range,
choices, live or fixed), the overrides given at start checked against it, and numeric overrides of the wrong type
accepted (YAML ``51200`` for a double).

Functions of the node (:class:`bkabem_ros.node.vibration_node.VibrationNode`), called while it is constructed; the
live changes are the node's own callbacks. No rclpy at import.
"""

from __future__ import annotations

from bkabem_ros.node.params import PARAMETER_SPECS, PARAMETERS, ParamSpec
from bkabem_ros.node.source import TWO_PI
from bkabem_ros.node.speed import normalize_unit

__all__ = ["RCLPY_PARAMETERS", "coerce_numeric_overrides", "declare", "declare_all", "descriptor",
           "refuse_unknown_overrides", "warn_undeclared"]

#: Parameters rclpy declares on every node (besides the table of bkabem_ros.node.params).
RCLPY_PARAMETERS = ("use_sim_time", "start_type_description_service")


def _known(name: str) -> bool:
    return name in PARAMETER_SPECS or name in RCLPY_PARAMETERS or name.startswith("qos_overrides.")


def refuse_unknown_overrides(node) -> None:
    """A parameter given for this node (``-p``, ``--params-file``) that it does not have is a typo that would be
    ignored: refused, with the nearest name."""
    import difflib

    unknown = sorted(n for n in node._parameter_overrides if not _known(n))
    if unknown:
        near = difflib.get_close_matches(unknown[0], list(PARAMETER_SPECS), n=1)
        raise ValueError(f"parameter {unknown[0]}: the node has no such parameter"
                         + (f" (did you mean {near[0]}?)" if near else "")
                         + (f"; also unknown: {', '.join(unknown[1:])}" if len(unknown) > 1 else "")
                         + " (docs/ros_node.md lists them)")


def warn_undeclared(node, params):
    """A live set of a parameter the node does not have: rclpy refuses it to the caller; the node says so too."""
    for prm in params:
        if not node.has_parameter(prm.name):
            node.get_logger().warning(f"parameter {prm.name}: the node has no such parameter; the set is refused "
                                      f"(docs/ros_node.md lists them)")
    return params


def coerce_numeric_overrides(node) -> None:
    """YAML ``sample_rate: 51200`` is an integer: accept it for a double parameter (and 2.0 for ints)."""
    from rclpy.parameter import Parameter

    ov = node._parameter_overrides
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


def descriptor(spec: ParamSpec, value):
    """The ``ParameterDescriptor`` of a parameter: description with unit and choices, range, live or fixed."""
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


def declare(node, name: str, default=None) -> None:
    """Declare one parameter of the table (``default``: instead of the table's); a value not among its choices is
    refused."""
    spec = PARAMETER_SPECS[name]
    value = spec.default if default is None else default
    node.declare_parameter(name, value, descriptor(spec, value))
    if spec.choices:
        v = node.get_parameter(name).value
        if name == "speed_unit":
            try:
                v = normalize_unit(v)
            except ValueError:
                pass
        if v not in spec.choices:
            raise ValueError(f"parameter {name}: {v!r} is not one of {', '.join(spec.choices)}")


def declare_all(node, case) -> None:
    """Declare the rest of the table (``case`` and ``scenario`` come first), four defaults from the machine: its
    defect's depth, its highest speed, and its acquisition's rate and ball-pass jitter (a rig case's ``[measurement]``
    section, so that a node on a rig twin streams what the rig's acquisition recorded)."""
    from bkabem_core.synth.measurement import Measurement  # noqa: PLC0415

    m = Measurement.of_case(case)
    derived = {"defect_depth": float(case.defect_depth_m),
               "max_speed": float(case.max_speed_hz) * TWO_PI,
               "slip": float(m.slip) if m.slip is not None else None,
               "sample_rate": float(m.sample_rate_hz) if m.sample_rate_hz is not None else None}
    for spec in PARAMETERS:
        if spec.name not in ("case", "scenario"):
            declare(node, spec.name, derived.get(spec.name))
