"""ROS 2 commands of the ``bkabem`` CLI: ``node``, ``speed``, ``echo``, ``fleet`` (+ ``record``/``replay`` when
their modules exist).

``bkabem_ros.cli.main`` (the ``bkabem`` entry point) calls :func:`add_ros_commands`. Every command accepts ``--ros-args ...`` as its last
option; everything after it goes to ROS unchanged (``-p name:=value``, ``--params-file F``, ``-r __ns:=/m1``,
``--log-level debug``). Bad arguments: one line on stderr, exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util

from bkabem_ros.cli.base import UsageError, check_parameter_ranges, fail, finite_float, output_path, pos_int  # noqa: F401


def _shorthand(p) -> None:
    """Node options that map to parameters (docs/ros_node.md lists them all)."""
    p.add_argument("--name", default="bkabem", help="node name (default bkabem)")
    p.add_argument("--namespace", default=None, help="node namespace, e.g. /machine_00 (topics are relative)")
    p.add_argument("--params-file", action="append", default=[], metavar="FILE",
                   help="ROS parameter YAML file (same as --ros-args --params-file FILE); repeatable")
    p.add_argument("--machine-id", default=None, help="parameter machine_id")
    p.add_argument("--sample-rate", type=finite_float("--sample-rate", 0.0, strict=True), default=None,
                   help="parameter sample_rate [Hz] (default: the case's measurement.sample_rate_hz, else 25600)")
    p.add_argument("--chunk-duration", type=finite_float("--chunk-duration", 0.0, strict=True), default=None,
                   help="parameter chunk_duration [s] (default 0.1)")
    p.add_argument("--seed", type=pos_int("--seed", 0), default=None, help="parameter seed")
    p.add_argument("--noise-acc", type=finite_float("--noise-acc", 0.0), default=None, metavar="DENSITY",
                   help="parameter noise_acc: accelerometer noise density [m/s^2/sqrt(Hz)] (as bkabem synth "
                        "--noise-acc; e.g. 1e-3)")
    p.add_argument("--noise-disp", type=finite_float("--noise-disp", 0.0), default=None, metavar="DENSITY",
                   help="parameter noise_disp: proximity-probe noise density [m/sqrt(Hz)] (e.g. 1e-9)")
    p.add_argument("--qos", choices=("sensor_data", "reliable"), default=None, help="parameter qos")
    p.add_argument("--speed-unit", choices=("rad/s", "hz", "rpm"), default=None,
                   help="parameter speed_unit (default rad/s)")
    p.add_argument("--spectrum-rate", type=finite_float("--spectrum-rate", 0.0), default=None,
                   help="parameter spectrum_rate [Hz]")
    p.add_argument("--wait-for-speed", action="store_true", default=None, help="parameter wait_for_speed=true")
    p.add_argument("--sim-time", action="store_true", help="parameter use_sim_time=true (follow /clock)")
    p.add_argument("--scenario", default=None, metavar="NAME_OR_FILE",
                   help="parameter scenario: embedded scenario or scenario TOML (docs/scenarios.md)")
    p.add_argument("--time-scale", type=finite_float("--time-scale", 0.0, strict=True), default=None,
                   help="parameter scenario_time_scale: scenario seconds per second (e.g. 3600)")
    p.add_argument("--labels", default=None, metavar="K=V[,K=V...]", help="parameter labels of the machine")


def _overrides(args) -> dict:
    m = {"case": args.case, "machine_id": args.machine_id, "sample_rate": args.sample_rate,
         "chunk_duration": args.chunk_duration, "seed": args.seed, "qos": args.qos,
         "noise_acc": getattr(args, "noise_acc", None), "noise_disp": getattr(args, "noise_disp", None),
         "speed_unit": args.speed_unit, "spectrum_rate": args.spectrum_rate, "wait_for_speed": args.wait_for_speed,
         "scenario": getattr(args, "scenario", None), "scenario_time_scale": getattr(args, "time_scale", None),
         "labels": getattr(args, "labels", None)}
    out = {k: v for k, v in m.items() if v is not None}
    if getattr(args, "sim_time", False):
        out["use_sim_time"] = True
    return out


def _ros_args(args) -> list[str]:
    out = []
    from bkabem_core.model.files import not_a_file
    from bkabem_ros.ros_env import params_file_problem

    for f in args.params_file:
        why = not_a_file(f)
        if why:
            fail("node", f"--params-file: {why}")
        why = params_file_problem(f)
        if why:
            fail("node", f"--params-file: {f}: {why}")
        out += ["--params-file", f]
    return out + list(args.ros_args or [])


def check_scenario(option: str, ref: str | None) -> None:
    """A scenario option: loaded (validated) before rclpy starts, so that a bad file is one line and exit 2."""
    if ref is None:
        return
    from bkabem_core.scenario.timeline import Scenario, ScenarioError

    try:
        Scenario.load(ref)
    except ScenarioError as exc:
        raise UsageError(f"{option}: {exc.reason}" if exc.key == "scenario" and not exc.source
                         else f"{option}: {exc}") from None


def cmd_node(args) -> int:
    from bkabem_ros.node.run import run
    from bkabem_ros.ros_env import check_names

    check_names([("--name", "node name", args.name), ("--namespace", "namespace", args.namespace)])
    check_parameter_ranges(_overrides(args))
    check_scenario("--scenario", getattr(args, "scenario", None))
    on_node = None
    attached = []
    if getattr(args, "record", None) or getattr(args, "rerun_save", None) or getattr(args, "rerun_connect", None):
        import os

        from bkabem_ros.recording.record import attach_sinks

        # the Rerun SDK's own warnings would follow a failed start with lines of their own; its errors still show
        os.environ.setdefault("RUST_LOG", "error")

        connect = args.rerun_connect
        if connect == "default":
            from bkabem_ros.viewer.blueprint import DEFAULT_CONNECT_URL

            connect = DEFAULT_CONNECT_URL

        def attach(node):
            sinks = attach_sinks(node, record=args.record, rerun_save=args.rerun_save, rerun_connect=connect,
                                 report_start=False)
            attached.append(sinks)
            if args.record and sinks.mcap is None:
                sinks()
                why = sinks.start_errors.get("--record")
                raise UsageError("--record: the recording could not start" + (f": {why}" if why else ""))
            if (args.rerun_save or connect) and sinks.rerun is None:
                sinks()
                option = "--rerun-save" if args.rerun_save else "--rerun-connect"
                why = sinks.start_errors.get(option)
                raise UsageError(f"{option}: the Rerun output could not start" + (f": {why}" if why else ""))
            return sinks
        on_node = attach

    rc = run(_ros_args(args), _overrides(args), node_name=args.name, namespace=args.namespace, on_node=on_node)
    for sinks in attached:          # a recording that failed while the node ran (disk full ...) is a failure
        for option, sink in (("--record", getattr(sinks, "mcap", None)),
                             ("--rerun-save/--rerun-connect", getattr(sinks, "rerun", None))):
            err = getattr(sink, "error", None)
            if err is not None:
                raise UsageError(f"{option}: {err} (the node streamed on; the recording stopped there)")
    return rc


def add_ros_commands(sub, add_case) -> None:
    """Register ``node``, ``speed``, ``echo``, ``fleet``, ``discovery-server`` and the optional ``record``/``replay``."""
    n = sub.add_parser("node", help="run the ROS 2 vibration-source node (speed in, waveforms out)",
                       description="The bkabem ROS 2 node. Topics, parameters, timing: docs/ros_node.md.")
    add_case(n)
    _shorthand(n)
    if importlib.util.find_spec("bkabem_ros.recording.record") is not None:     # sinks of issue 6 (MCAP, Rerun)
        n.add_argument("--record", default=None, metavar="FILE.mcap", type=output_path("--record", (".mcap",)),
                       help="record everything the node receives and publishes into a ROS 2 MCAP file")
        n.add_argument("--rerun-save", default=None, metavar="FILE.rrd", type=output_path("--rerun-save", (".rrd",)),
                       help="log the streams to a Rerun file")
        n.add_argument("--rerun-connect", nargs="?", const="default", default=None, metavar="URL",
                       help="stream to a running Rerun viewer (default URL of bkabem_ros.viewer.rerun_io)")
    n.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=None,
                   help="everything after this goes to ROS (-p name:=value, --params-file F, -r __ns:=/m1)")
    n.set_defaults(func=cmd_node, ros_network=True)

    from bkabem_ros.fleet import discovery
    from bkabem_ros.fleet import launcher as fleet
    from bkabem_ros.node import echo, speed

    speed.add_parser(sub, add_case)
    echo.add_parser(sub, add_case)
    fleet.add_parser(sub, add_case)
    discovery.add_parser(sub, add_case)
    for name in ("record", "replay"):
        try:
            mod = importlib.import_module(f"bkabem_ros.cli.{name}")
        except ImportError:
            continue
        mod.add_parser(sub, add_case)
