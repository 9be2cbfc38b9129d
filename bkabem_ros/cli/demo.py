"""The main job: the node on the embedded case through a run-up, recorded to MCAP and Rerun.

    python -m bkabem_ros.cli.demo [--out recordings] [--ramp 20] [--hold 10] [--top-hz 50]
                              [--sample-rate 25600] [--rerun-connect [URL]] [--no-rerun]
    python -m bkabem_ros.cli.demo --example      # recordings/example_runup.mcap (small, for the repo)

What :func:`run_demo` does, in one process (no DDS discovery needed, but the topics are on the
ROS 2 graph, so ``bkabem echo`` / ``bkabem record`` in another shell see them):

1. builds the bkabem node (:class:`bkabem_ros.node.vibration_node.VibrationNode`) on the embedded case;
2. attaches the MCAP recorder (``<out>/demo.mcap``) and the Rerun logger (``<out>/demo.rrd``)
   as node sinks (:func:`bkabem_ros.recording.record.attach_sinks`);
3. drives the shaft speed with a second node publishing ``speed`` (rad/s) at 50 Hz: a linear
   run-up from 0 to ``top_hz`` in ``ramp_s``, then ``hold_s`` at ``top_hz``;
4. prints progress every 2 s and a summary: shaft speed, BPFO, and per bearing (DE, NDE) the RMS
   acceleration of the last chunk and the ISO 10816/20816 velocity RMS (10-1000 Hz, mm/s) of the
   last second, computed from the published waveforms (the Rerun logger computes the same per
   second from the waveforms it logs, with the zone limits and the envelope spectrum);
5. ends with the command that opens the result in the viewer.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:                   # numpy is imported when the demo runs, not to parse its options
    import numpy as np

__all__ = ["DemoResult", "main", "run_demo"]

TWO_PI = 2.0 * math.pi


class _Summary:
    """Node sink that keeps the numbers for the progress lines and the summary."""

    def __init__(self, window_s: float = 1.0):
        self.window_s = window_s
        self.speed_rad_s = 0.0
        self.shaft_speed_rad_s = 0.0
        self.bpfo_hz = float("nan")
        self.counts: dict[str, int] = {}
        self.rms: dict[str, np.ndarray] = {}
        self.acc: dict[str, deque] = {}
        self.sample_rate = 0.0
        self.last_stamp = 0

    def __call__(self, topic, type_name, msg, stamp_ns):
        self.counts[topic] = self.counts.get(topic, 0) + 1
        if type_name.endswith("/Float64"):
            self.speed_rad_s = float(msg.data)
        elif type_name.endswith("/BearingFaultFrequencies"):
            self.bpfo_hz = float(msg.bpfo)
        elif type_name.endswith("/VibrationWaveform") and msg.quantity == "acceleration":
            import numpy as np

            from bkabem_ros.messages.convert import waveform_array

            a = waveform_array(msg).astype(np.float64)
            loc = msg.location
            self.sample_rate = float(msg.sample_rate)
            self.shaft_speed_rad_s = float(msg.shaft_speed)
            self.rms[loc] = np.sqrt(np.mean(a * a, axis=1))
            buf = self.acc.setdefault(loc, deque())
            buf.append(a)
            keep = max(1, int(round(self.window_s * self.sample_rate / max(a.shape[1], 1))))
            while len(buf) > keep:
                buf.popleft()
            self.last_stamp = stamp_ns

    def iso(self, loc: str) -> list[float]:
        buf = self.acc.get(loc)
        if not buf:
            return []
        import numpy as np

        from bkabem_core.analysis.condition import iso_velocity_rms_mm_s

        x = np.concatenate(list(buf), axis=1)
        return [iso_velocity_rms_mm_s(x[c], self.sample_rate) for c in range(x.shape[0])]

    def line(self, t: float) -> str:
        parts = [f"t={t:5.1f} s  speed {self.shaft_speed_rad_s / TWO_PI:6.2f} Hz  BPFO {self.bpfo_hz:7.2f} Hz"]
        for loc in ("de", "nde"):
            if loc in self.rms:
                r = self.rms[loc]
                iso = self.iso(loc)
                parts.append(f"{loc.upper()} RMS v/h {r[0]:.3g}/{r[1]:.3g} m/s^2, ISO vel v/h "
                             f"{iso[0]:.3g}/{iso[1]:.3g} mm/s")
        return "  ".join(parts)


@dataclass
class DemoResult:
    """Outcome of :func:`run_demo`: files, message counts per topic, final numbers."""

    mcap: Path | None
    rrd: Path | None
    wall_s: float
    counts: dict[str, int] = field(default_factory=dict)
    speed_hz: float = 0.0
    bpfo_hz: float = float("nan")
    rms_m_s2: dict[str, list[float]] = field(default_factory=dict)
    iso_velocity_mm_s: dict[str, list[float]] = field(default_factory=dict)
    node_stats: dict = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)


def run_demo(out_dir="recordings", *, ramp_s: float = 20.0, hold_s: float = 10.0, top_hz: float = 50.0,
             sample_rate: float = 25600.0, case: str | None = None, record: bool = True, rerun: bool = True,
             rerun_connect: str | None = None, mcap_name: str = "demo.mcap", rrd_name: str = "demo.rrd",
             noise_acceleration: float = 0.05, quiet: bool = False, progress_every_s: float = 2.0) -> DemoResult:
    """Run the node through a run-up with recording; see the module docstring.

    Parameters
    ----------
    out_dir : str or Path
        Folder for ``demo.mcap`` / ``demo.rrd`` (created).
    ramp_s, hold_s, top_hz
        Speed profile: 0 -> ``top_hz`` (shaft Hz) linearly in ``ramp_s`` seconds, then ``hold_s``.
    sample_rate : float
        Node parameter ``sample_rate`` (Hz).
    case : str, optional
        Case name or TOML (default: the embedded case).
    record, rerun
        Write the MCAP / the ``.rrd``.
    rerun_connect : str, optional
        Also stream to a running viewer (e.g. ``rerun+http://127.0.0.1:9876/proxy``).
    noise_acceleration : float
        RMS of the accelerometer noise (0 to sample_rate/2) [m/s^2]: the node's ``noise_acc`` density is this
        / sqrt(sample_rate / 2).
    """
    from bkabem_ros.ros_env import apply_defaults

    apply_defaults()              # this host only, unless the user chose a discovery range or peers
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from std_msgs.msg import Float64

    from bkabem_ros.node.vibration_node import VibrationNode
    from bkabem_ros.recording.record import attach_sinks

    say = (lambda text: None) if quiet else (lambda text: print(text, flush=True))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    mcap = out / mcap_name if record else None
    rrd = out / rrd_name if rerun else None
    duration = ramp_s + hold_s
    t_wall0 = time.perf_counter()
    ctx = rclpy.Context()
    from bkabem_ros.ros_env import init, until_stopped  # noqa: PLC0415

    init(["bkabem-demo"], context=ctx)   # + the discovery range in force, once
    node = speed_node = attached = None
    result = DemoResult(mcap, rrd, 0.0)
    try:
        overrides = [Parameter("sample_rate", value=float(sample_rate)),
                     Parameter("noise_acc", value=float(noise_acceleration) / math.sqrt(sample_rate / 2.0))]
        if case:
            overrides.append(Parameter("case", value=str(case)))
        say(f"bkabem demo: run-up 0 -> {top_hz:g} Hz in {ramp_s:g} s, hold {hold_s:g} s, "
            f"{sample_rate:g} Hz sampling, ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}")
        node = VibrationNode("bkabem", context=ctx, parameter_overrides=overrides, start=False)
        summary = _Summary()
        node.add_sink(summary)
        attached = attach_sinks(node, record=mcap, rerun_save=rrd, rerun_connect=rerun_connect,
                                recording_id="bkabem-demo", rerun_optimize=True)
        speed_node = rclpy.create_node("bkabem_demo_speed", context=ctx)
        pub = speed_node.create_publisher(Float64, "speed", 10)
        t_start = [None]

        def speed_at(t: float) -> float:
            return top_hz * min(max(t / ramp_s, 0.0), 1.0) if ramp_s > 0 else top_hz

        def tick():
            now = time.monotonic()
            if t_start[0] is None:
                t_start[0] = now
            pub.publish(Float64(data=TWO_PI * speed_at(now - t_start[0])))

        speed_node.create_timer(0.02, tick)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.add_node(speed_node)
        say(f"node ready in {time.perf_counter() - t_wall0:.1f} s; streaming"
            + (f", recording {mcap}" if mcap else "") + (f", Rerun {rrd}" if rrd else ""))
        node.start()
        t0 = time.monotonic()
        next_print = t0 + progress_every_s
        with until_stopped(ctx, interrupt=True):     # Ctrl-C: the CLI's "interrupted", never a finished demo
            while True:
                now = time.monotonic()
                if now - t0 >= duration + 0.25:
                    break
                executor.spin_once(timeout_sec=0.05)
                if now >= next_print:
                    say(summary.line(now - t0))
                    next_print += progress_every_s
        result.node_stats = node.stats()
    finally:
        if attached is not None:
            attached()
            for s in (attached.mcap, attached.rerun):
                err = getattr(s, "error", None)
                if err is not None:
                    result.errors.append(str(err))
            if attached.rerun is not None and attached.rerun.logger.optimize_error:
                say(f"warning: {rrd} left as written: {attached.rerun.logger.optimize_error}")
        if speed_node is not None:
            speed_node.destroy_node()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=ctx)
    result.wall_s = time.perf_counter() - t_wall0
    result.counts = dict(summary.counts)
    result.speed_hz = summary.shaft_speed_rad_s / TWO_PI
    result.bpfo_hz = summary.bpfo_hz
    result.rms_m_s2 = {k: [float(x) for x in v] for k, v in summary.rms.items()}
    result.iso_velocity_mm_s = {k: summary.iso(k) for k in summary.acc}
    _print_summary(result, say)
    return result


def _print_summary(r: DemoResult, say) -> None:
    say("")
    say(f"summary after {r.wall_s:.1f} s: shaft speed {r.speed_hz:.2f} Hz ({r.speed_hz * 60:.0f} rpm), "
        f"BPFO {r.bpfo_hz:.2f} Hz")
    for loc in ("de", "nde"):
        if loc in r.rms_m_s2:
            rms, iso = r.rms_m_s2[loc], r.iso_velocity_mm_s.get(loc, [float("nan")] * 2)
            say(f"  {loc.upper():3s} acceleration RMS vertical {rms[0]:.4g} m/s^2, horizontal {rms[1]:.4g} m/s^2; "
                f"ISO velocity RMS (10-1000 Hz) vertical {iso[0]:.4g} mm/s, horizontal {iso[1]:.4g} mm/s")
    st = r.node_stats
    if st:
        say(f"  node: {st.get('chunks')} chunks, {st.get('spectra')} spectra, {st.get('speed_messages')} speed "
            f"messages, publish lateness p99 {st.get('lateness_ms_p99', float('nan')):.2f} ms")
    for topic, n in sorted(r.counts.items()):
        say(f"  {topic:36s} {n:6d} messages")
    if r.mcap is not None and r.mcap.exists():
        say(f"  MCAP  {r.mcap} ({r.mcap.stat().st_size / 1e6:.1f} MB) - replay: bkabem replay {r.mcap}")
    if r.rrd is not None and r.rrd.exists():
        say(f"  Rerun {r.rrd} ({r.rrd.stat().st_size / 1e6:.1f} MB)")
    for e in r.errors:
        say(f"  error: {e}")
    if r.rrd is not None and r.rrd.exists():
        say("")
        say(f"open it in the viewer:  .venv/bin/rerun {r.rrd}")


def add_run_up_arguments(p) -> None:
    """The run-up options shared by ``bkabem demo-run`` and ``bkabem demo``."""
    from bkabem_ros.cli.base import finite_float

    p.add_argument("--ramp", type=finite_float("--ramp", 0.0), default=20.0, help="run-up time [s] (default 20)")
    p.add_argument("--hold", type=finite_float("--hold", 0.0), default=10.0, help="hold time [s] (default 10)")
    p.add_argument("--top-hz", type=finite_float("--top-hz", 0.0, strict=True), default=50.0,
                   help="final shaft speed [Hz] (default 50)")
    p.add_argument("--sample-rate", type=finite_float("--sample-rate", 1000.0, maximum=204800.0), default=25600.0,
                   help="samples per second and channel, 1000 .. 204800 (the node's range; default 25600)")
    p.add_argument("--no-rerun", action="store_true", help="no .rrd")


def add_parser(sub, add_case=None):
    """Register ``bkabem demo-run`` (the ROS part of the main job)."""
    p = sub.add_parser("demo-run", help="node + run-up + MCAP + Rerun on the embedded case (the main job)",
                       description=__doc__.split("\n\n")[0])
    if add_case is not None:
        add_case(p)
    else:
        p.add_argument("--case", default=None)
    p.add_argument("--out", default="recordings", help="folder for demo.mcap and demo.rrd (default recordings)")
    add_run_up_arguments(p)
    p.add_argument("--rerun-connect", nargs="?", const="rerun+http://127.0.0.1:9876/proxy", default=None,
                   metavar="URL", help="also stream to a running viewer")
    p.add_argument("--example", action="store_true",
                   help="write the small example recording recordings/example_runup.mcap instead")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=main, ros_network=True)
    return p


def main(args) -> int:
    from bkabem_core.model.case import Case
    from bkabem_ros.cli.base import UsageError, check_output_dir

    top = Case.load(args.case).max_speed_hz
    if args.top_hz > top:
        raise UsageError(f"--top-hz: {args.top_hz:g} Hz is above the case's operating.max_speed_hz ({top:g} Hz): the "
                         f"node would reject every speed of the run-up")
    check_output_dir("--out", args.out)
    if args.example:
        make_example(Path(args.out), quiet=args.quiet)
        return 0
    r = run_demo(args.out, ramp_s=args.ramp, hold_s=args.hold, top_hz=args.top_hz, sample_rate=args.sample_rate,
                 case=args.case, rerun=not args.no_rerun, rerun_connect=args.rerun_connect, quiet=args.quiet)
    if r.errors:
        raise UsageError(f"--out: {r.errors[0]}")
    return 0


EXAMPLE = {"ramp_s": 8.0, "hold_s": 2.0, "top_hz": 50.0, "sample_rate": 5120.0}


def make_example(out_dir=Path("recordings"), quiet: bool = False) -> Path:
    """``recordings/example_runup.mcap``: a short run-up at a modest sample rate (see README there)."""
    r = run_demo(out_dir, rerun=False, mcap_name="example_runup.mcap", quiet=quiet, **EXAMPLE)
    return r.mcap


def standalone(argv=None) -> int:
    """``python -m bkabem_ros.cli.demo ARGS`` = ``bkabem demo-run ARGS`` (same errors and exit codes)."""
    from bkabem_ros.cli.base import subcommand_main

    return subcommand_main("demo-run", add_parser, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(standalone())
