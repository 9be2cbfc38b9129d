"""``bkabem fleet``: N machines, each a bkabem node in its own namespace, in one or several processes.

Machine ``i`` runs as node ``bkabem`` in namespace ``/<prefix><i:02d>`` (default ``/machine_00``,
``/machine_01``, ...), with ``machine_id`` = that name without the slash, ``seed = --seed + i`` and case
``cases[i % len(cases)]`` (``--case`` is repeatable). ``--defect-depths`` (comma list, m) gives each
machine its own dent depth, cycled like the cases, so that a fleet holds healthy and damaged machines.

``--scenario mixed`` (or any fleet scenario file, or a machine scenario for every machine) assigns each machine
its case or scenario and labels instead (:mod:`bkabem_ros.fleet.plan`, docs/scenarios.md): every message of a
machine carries its ground truth and labels.

Several hosts, one graph: each host runs ``--first-index K --machines N`` for its own disjoint range of
indices (machines ``K .. K+N-1``; seeds, cases and depths follow the index, so the machines are the same as
in one big fleet) with the same ``--index-width`` (digits of the index in the name; default: enough for
this host's last index, at least 2) and opens discovery explicitly (``--discovery-range SUBNET``,
``--discovery-server HOST``: docs/fleet.md). A namespace that shows up twice on the graph (two hosts with
overlapping ranges) is reported.

Nodes of one process share one executor and one BKA-BEM model per case (the ~2 s preparation is paid
once per case and process). ``--processes P`` spreads the machines round-robin over P processes
(default: 1 for up to 4 machines, else the CPU count). The executor is rclpy's EventsExecutor by default
(``--executor events``: timers and callbacks dispatched from C++, no wait set rebuilt over every entity of every
node per callback, which made the cost per machine grow with the machines per process); ``--executor single``
is the SingleThreadedExecutor of ``bkabem node``. Every process makes its nodes and synthesises their first
chunks, then all processes start together (a ready/go handshake with the parent), and the machines of a process
start their streams spread evenly over one chunk period, so that their publications do not all fall due at the
same instant (docs/fleet.md, "100 machines per host"). Each machine's
speed topic is ``/<prefix><i:02d>/speed``; ``bkabem speed --namespace /machine_03`` drives one of them.

``--seconds S`` stops the fleet after S seconds and prints one line of publish statistics per machine
(how late each chunk was published after its last sample was due): the way to measure how many machines
a host sustains (``bench/bench_node.py --fleet`` does it for several N).
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import signal
import subprocess
import sys
import time

#: A host runs tens of machines in real time (BENCHMARKS.md); beyond these the plan itself becomes the problem
#: (the workers' argument lists, thousands of DDS participants).
MAX_MACHINES = 1000
MAX_PROCESSES = 64
#: Highest machine index of a plant (``--first-index`` + ``--machines`` - 1); node seeds stay below 2**31.
MAX_INDEX = 999_999
EXECUTORS = ("events", "single")


def index_width(first: int, n: int, width: int | None = None) -> int:
    """Digits of the machine index in the names: ``width`` when given, else enough for the last index (>= 2)."""
    return width if width is not None else max(2, len(str(first + n - 1)))


def machine_names(n: int, prefix: str = "machine_", first: int = 0, width: int | None = None) -> list[str]:
    w = index_width(first, n, width)
    return [f"{prefix}{i:0{w}d}" for i in range(first, first + n)]


def plan(n: int, cases: list[str], seed: int, prefix: str, depths: list[float] | None, first: int = 0,
         width: int | None = None) -> list[dict]:
    """One dict per machine: index, name, namespace, parameter overrides (seed, case, depth follow the index)."""
    out = []
    for i, name in zip(range(first, first + n), machine_names(n, prefix, first, width)):
        ov = {"machine_id": name, "seed": seed + i}
        if cases:
            ov["case"] = cases[i % len(cases)]
        if depths:
            ov["defect_depth"] = float(depths[i % len(depths)])
        out.append({"index": i, "name": name, "namespace": "/" + name, "overrides": ov})
    return out


def _make_executor(kind: str):
    from rclpy.executors import SingleThreadedExecutor

    if kind == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor()
    return SingleThreadedExecutor()


def _start_spread(nodes) -> None:
    """Start the nodes' streams one after the other, spread evenly over one chunk period (their timers' phases,
    hence their publications, then do not fall due together).

    Every node first synthesises and encodes its chunk 0 (:meth:`VibrationNode.prime`): a stream's first chunk
    costs several times a later one (~1-4 ms), and 50 of them inside the spread, before the executor ran, made
    the first chunks of the first machines up to 300 ms late (100 machines in one process, measured). A start is
    then only its timer and the stamps (~0.2 ms).
    """
    if not nodes:
        return
    for nd in nodes:
        nd.prime()                      # no-op for a node primed already
    period = min(nd.samples_per_chunk / nd.sample_rate for nd in nodes)
    t0 = time.monotonic()
    for k, nd in enumerate(nodes):
        delay = t0 + k * period / len(nodes) - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        nd.start()


class _NamespaceWatch:
    """Warn (once per namespace) when a namespace of this process's machines has more than one ``bkabem`` node on
    the graph: two hosts run overlapping ``--first-index`` ranges and their streams mix on the same topics."""

    def __init__(self, node, namespaces):
        from rclpy.clock import Clock, ClockType

        self.node = node
        self.mine = set(namespaces)
        self.reported: set[str] = set()
        self.timer = node.create_timer(3.0, self.check, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def check(self) -> None:
        from collections import Counter

        try:
            seen = Counter(ns for name, ns in self.node.get_node_names_and_namespaces() if name == "bkabem")
        except Exception:  # noqa: BLE001 - graph queries fail during shutdown
            return
        for ns in sorted(self.mine):
            if seen[ns] > 1 and ns not in self.reported:
                self.reported.add(ns)
                self.node.get_logger().warning(
                    f"namespace {ns} has {seen[ns]} bkabem nodes on the graph: another fleet (host) runs the same "
                    f"machine index; give each host a disjoint --first-index range")


def run_in_process(machines: list[dict], common: dict, ros_args: list[str], seconds: float | None,
                   report=None, executor_kind: str = "events", ready=None) -> int:
    """Run the given machines as nodes of this process; returns the exit code. ``ready(spin)``, when given, is
    called once every node is made and its first chunk primed, and returns when the streams may start (False:
    stop instead); it may call ``spin()`` (one executor step) while it waits."""
    import rclpy
    from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
    from rclpy.parameter import Parameter

    from bkabem_core.model.case import CaseError
    from bkabem_ros.node.run import exit_log, quiet_gc
    from bkabem_ros.node.vibration_node import VibrationNode
    from bkabem_ros.ros_env import init, until_stopped  # noqa: PLC0415

    init(["bkabem-fleet", "--ros-args", *ros_args])   # + the discovery range in force, once
    nodes = []
    try:
        try:
            for m in machines:
                # many nodes share one executor: leave out the ~/get_type_description service (one wait-set
                # entity less per node and cycle)
                ov = {"start_type_description_service": False}
                ov.update(common)
                ov.update(m["overrides"])
                nodes.append(VibrationNode("bkabem", namespace=m["namespace"], start=False,
                                           parameter_overrides=[Parameter(k, value=v) for k, v in ov.items()]))
        except (CaseError, InvalidParameterValueException, InvalidParameterTypeException, ValueError) as exc:
            sys.stderr.write(f"bkabem fleet: error: {exc}\n")
            return 2
        executor = _make_executor(executor_kind)
        for nd in nodes:
            executor.add_node(nd)
        watch = _NamespaceWatch(nodes[0], [m["namespace"] for m in machines]) if nodes else None
        for nd in nodes:
            nd.prime()
        quiet_gc()
        go = ready(lambda: executor.spin_once(timeout_sec=0.05)) if ready is not None else True
        if go:
            _start_spread(nodes)
        t_end = None if seconds is None else time.monotonic() + seconds
        # spin_once in a loop, not spin(): Python runs the SIGTERM handler (and sees the end time) between calls;
        # inside the EventsExecutor's C++ spin() a Python signal handler would never run
        with until_stopped():
            while go and rclpy.ok():
                if t_end is not None and time.monotonic() >= t_end:
                    break
                executor.spin_once(timeout_sec=0.1)
        for nd in nodes:
            st = nd.stats()
            st["namespace_conflicts"] = sorted(watch.reported) if watch is not None else []
            exit_log(nd, st)
            if report is not None:
                report(st)
        return 0
    finally:
        for nd in nodes:
            nd.destroy_node()
        rclpy.try_shutdown()


def _worker_ready(fd: int, spin) -> bool:
    """Worker side of the start handshake: report "ready" on ``fd``, then wait for the parent's go on stdin (EOF,
    a parent gone: start anyway), spinning the executor meanwhile (``spin()``: the speed messages, graph events
    and the executor's first pass over all nodes are dealt with before the streams start, not in their first
    chunk period). False: interrupted (SIGINT) while waiting, do not start."""
    import select

    import rclpy

    try:
        os.write(fd, b"R")
        os.close(fd)
    except OSError:
        return True
    try:
        while rclpy.ok():
            if select.select([sys.stdin], [], [], 0)[0]:
                sys.stdin.buffer.readline()
                return True
            spin()
        return False
    except KeyboardInterrupt:
        return False
    except (OSError, ValueError):
        return True
    except Exception:  # noqa: BLE001 - SIGINT shuts the context down inside spin_once (see ros_env.until_stopped)
        if rclpy.ok():
            raise
        return False


def _start_together(procs, ready_fds) -> None:
    """Let the workers start their streams at the same time, once every one of them has made its nodes and primed
    their first chunks. Without it the first worker streamed while the others still prepared their model and made
    their nodes (seconds of CPU on the same cores, and their endpoints' discovery): its first chunks were published
    up to 0.9 s late (100 machines in 2 processes, measured). A worker that ends before it is ready is not waited
    for."""
    import select

    waiting = dict(zip(ready_fds, procs))
    while waiting:
        r, _, _ = select.select(list(waiting), [], [], 0.5)
        for fd in r:
            os.read(fd, 1)              # b"R", or b"" when the worker ended first
            os.close(fd)
            waiting.pop(fd)
        for fd, p in list(waiting.items()):
            if p.poll() is not None:
                os.close(fd)
                waiting.pop(fd)
    for p in procs:
        try:
            p.stdin.write(b"go\n")
            p.stdin.close()
        except (OSError, ValueError):
            pass


def _print_stats(st: dict) -> None:
    """One line per machine in one write(2): the workers share the parent's stdout, and a line written in pieces
    (unbuffered Python writes text in several calls) could be cut by another worker's line."""
    sys.stdout.flush()
    os.write(sys.stdout.fileno(), ("FLEETSTATS " + json.dumps(st) + "\n").encode())


def add_parser(sub, add_case):
    """Register ``bkabem fleet``."""
    from bkabem_ros.cli.base import finite_float, pos_int

    p = sub.add_parser("fleet", help="start N namespaced bkabem nodes (a fleet of machines)",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--machines", type=pos_int("--machines", 1, MAX_MACHINES), required=True,
                   help=f"number of machines on this host (at most {MAX_MACHINES})")
    p.add_argument("--first-index", type=pos_int("--first-index", 0, MAX_INDEX), default=0, metavar="K",
                   help="index of this host's first machine: machines K .. K+N-1 (other hosts: disjoint ranges)")
    p.add_argument("--index-width", type=pos_int("--index-width", 1, len(str(MAX_INDEX))), default=None,
                   metavar="DIGITS", help="digits of the index in the names (default: enough for the last index, "
                                          "at least 2); give every host of a plant the same width")
    p.add_argument("--processes", type=pos_int("--processes", 1, MAX_PROCESSES), default=None,
                   help="processes to spread the machines over (default: 1 up to 4 machines, else CPU count)")
    p.add_argument("--case", action="append", default=[], metavar="CASE",
                   help="case (embedded name or TOML); repeat to cycle several cases over the machines")
    p.add_argument("--defect-depths", default=None, metavar="M[,M...]",
                   help="dent depths in m, cycled over the machines (e.g. 0,2e-5,5e-5)")
    p.add_argument("--scenario", default=None, metavar="NAME_OR_FILE",
                   help="fleet scenario (e.g. mixed: healthy, outer, inner, ball machines with labels) or a machine "
                        "scenario for every machine (docs/scenarios.md); instead of --case/--defect-depths")
    p.add_argument("--time-scale", type=finite_float("--time-scale", 0.0, strict=True), default=None,
                   help="scenario seconds per second for every scenario machine (default: the entries' own)")
    p.add_argument("--seed", type=pos_int("--seed", 0), default=0, help="seed of machine 0 (machine i: seed+i)")
    p.add_argument("--prefix", default="machine_", help="namespace prefix (default machine_)")
    p.add_argument("--sample-rate", type=finite_float("--sample-rate", 0.0, strict=True), default=None,
                   help="parameter sample_rate of every machine [Hz] (default: each case's "
                        "measurement.sample_rate_hz, else 25600)")
    p.add_argument("--chunk-duration", type=finite_float("--chunk-duration", 0.0, strict=True), default=None,
                   help="parameter chunk_duration of every machine [s] (default 0.1)")
    p.add_argument("--qos", choices=("sensor_data", "reliable"), default=None,
                   help="parameter qos of every machine (default sensor_data)")
    p.add_argument("--params-file", action="append", default=[], metavar="FILE",
                   help="parameter YAML applied to every machine (use /** as the node key)")
    p.add_argument("--executor", choices=EXECUTORS, default="events",
                   help="rclpy executor of each process: events (EventsExecutor, default) or single "
                        "(SingleThreadedExecutor)")
    p.add_argument("--seconds", type=finite_float("--seconds", 0.0, strict=True), default=None,
                   help="stop after this long and print per-machine publish statistics")
    p.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=None,
                   help="everything after this goes to ROS in every process (-p name:=value for every machine)")
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)   # internal: JSON list of machines
    p.add_argument("--ready-fd", type=int, default=None, help=argparse.SUPPRESS)   # internal: start handshake
    p.set_defaults(func=main, ros_network=True)
    return p


def main(args) -> int:
    import math

    from bkabem_ros.cli.base import fail
    from bkabem_ros.ros_env import check_names

    depths = None
    if args.defect_depths:
        try:
            depths = [float(v) for v in args.defect_depths.split(",")]
        except ValueError:
            fail("fleet", f"--defect-depths: {args.defect_depths!r} is not a comma list of numbers")
        bad = [d for d in depths if not (math.isfinite(d) and 0.0 <= d <= 1e-3)]
        if bad:
            fail("fleet", f"--defect-depths: {bad[0]!r} m is not a dent depth in [0, 0.001] m")
    last = args.first_index + args.machines - 1
    if last > MAX_INDEX:
        fail("fleet", f"--first-index: {args.first_index} + {args.machines} machines ends at index {last}, above "
                      f"{MAX_INDEX}")
    if args.index_width is not None and len(str(last)) > args.index_width:
        fail("fleet", f"--index-width: {args.index_width} digits cannot hold machine index {last}")
    check_names([("--prefix", "namespace", "/" + machine_names(1, args.prefix, last, args.index_width)[0])])
    if args.scenario is not None and args.worker is None:
        if args.case or depths:
            fail("fleet", "--scenario: give --scenario or --case/--defect-depths, not both (the scenario assigns "
                          "the machines' cases)")
        from bkabem_core.scenario.timeline import ScenarioError
        from bkabem_ros.fleet import plan as fleet_plan

        try:
            fleet_plan.load(args.scenario)
        except ScenarioError as exc:
            fail("fleet", f"--scenario: {exc.reason}" if exc.key == "scenario" and not exc.source
                 else f"--scenario: {exc}")
    elif args.time_scale is not None and args.worker is None:
        fail("fleet", "--time-scale: only with --scenario")
    from bkabem_ros.cli.base import check_parameter_ranges

    check_parameter_ranges({k: v for k, v in {"sample_rate": args.sample_rate,
                                              "chunk_duration": args.chunk_duration}.items() if v is not None})
    common = {k: v for k, v in {"sample_rate": args.sample_rate, "chunk_duration": args.chunk_duration,
                                "qos": args.qos}.items() if v is not None}
    ros_args = []
    from bkabem_core.model.files import not_a_file
    from bkabem_ros.ros_env import params_file_problem

    for f in args.params_file:
        why = not_a_file(f)
        if why:
            fail("fleet", f"--params-file: {why}")
        why = params_file_problem(f)
        if why:
            fail("fleet", f"--params-file: {f}: {why}")
        ros_args += ["--params-file", f]
    ros_args += list(args.ros_args or [])
    report = _print_stats if args.seconds is not None else None

    if args.worker is not None:   # child process of a multi-process fleet
        ready = None if args.ready_fd is None else functools.partial(_worker_ready, args.ready_fd)
        return run_in_process(json.loads(args.worker), common, ros_args, args.seconds, report, args.executor,
                              ready)

    machines = plan(args.machines, args.case, args.seed, args.prefix, depths, args.first_index, args.index_width)
    if args.scenario is not None:                   # per-machine case or scenario, and labels (fleet_plan.py)
        from bkabem_ros.fleet import plan as fleet_plan

        fleet_plan.apply(machines, fleet_plan.load(args.scenario), args.time_scale)
    n_proc = args.processes or (1 if args.machines <= 4 else (os.cpu_count() or 1))
    n_proc = min(n_proc, args.machines)
    if n_proc == 1:
        return run_in_process(machines, common, ros_args, args.seconds, report, args.executor)

    from bkabem_ros.ros_env import announce

    announce()                      # here, not in every worker (they inherit the marker)
    groups = [machines[i::n_proc] for i in range(n_proc)]
    base = [sys.executable, "-m", "bkabem_ros", "fleet", "--machines", str(args.machines),
            "--executor", args.executor]
    for flag, val in (("--sample-rate", args.sample_rate), ("--chunk-duration", args.chunk_duration),
                      ("--qos", args.qos), ("--seconds", args.seconds)):
        if val is not None:
            base += [flag, str(val)]
    for f in args.params_file:
        base += ["--params-file", f]
    procs, ready_fds = [], []
    for g in groups:
        r, w = os.pipe()
        cmd = base + ["--worker", json.dumps(g), "--ready-fd", str(w)]
        if args.ros_args:
            cmd += ["--ros-args", *args.ros_args]
        # own session: a terminal's Ctrl-C reaches only this parent, which forwards it once to each worker
        procs.append(subprocess.Popen(cmd, start_new_session=True, stdin=subprocess.PIPE, pass_fds=(w,)))
        os.close(w)
        ready_fds.append(r)
    sys.stderr.write(f"bkabem fleet: {args.machines} machines in {n_proc} processes "
                     f"(pids {', '.join(str(p.pid) for p in procs)})\n")

    def forward(signum, _frame):
        for p in procs:
            if p.poll() is None:
                p.send_signal(signum)

    old = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        _start_together(procs, ready_fds)
        codes = [p.wait() for p in procs]
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    bad = [c for c in codes if c not in (0, -signal.SIGINT, -signal.SIGTERM)]
    return bad[0] if bad else 0
