"""``bkabem replay FILE.mcap``: republish a recording on ROS 2 and/or convert it for Rerun.

    bkabem replay run.mcap [--rate 2] [--loop] [--start-offset S] [--remap /speed:=/speed_in]
                           [--clock [HZ]] [--namespace /replayed] [--topics T ...]
    bkabem replay run.mcap --rerun-save run.rrd          # no ROS needed, as fast as possible
    bkabem replay run.mcap --rerun-connect [URL]         # to a running viewer (rerun --bind 127.0.0.1)
    bkabem replay run.mcap --rerun-save run.rrd --publish   # both, with the original timing
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["add_parser", "main"]


def add_parser(sub, add_case=None):
    """Register ``bkabem replay`` on an argparse subparsers object."""
    from bkabem_ros.cli.base import finite_float, output_path, pos_int
    from bkabem_ros.viewer.blueprint import DEFAULT_CONNECT_URL

    p = sub.add_parser("replay", help="republish an MCAP recording on ROS 2 and/or convert it for Rerun",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE.mcap", help="recording (bkabem or rosbag2 MCAP)")
    p.add_argument("--rate", type=finite_float("--rate", 1e-3, maximum=1e4), default=1.0,
                   help="playback speed factor, 0.001 .. 10000 (default 1)")
    p.add_argument("--loop", action="store_true", help="start again at the end (until Ctrl-C)")
    p.add_argument("--start-offset", type=finite_float("--start-offset", 0.0, maximum=1e9), default=0.0,
                   help="skip the first seconds of the recording")
    p.add_argument("--remap", action="append", default=[], metavar="OLD:=NEW",
                   help="publish recorded topic OLD as NEW (repeatable)")
    p.add_argument("--topics", nargs="+", default=None, metavar="TOPIC", help="only these recorded topics")
    p.add_argument("--namespace", default="", help="prefix for the published topic names")
    p.add_argument("--clock", nargs="?", type=finite_float("--clock", 0.0, strict=True), const=100.0,
                   default=None, metavar="HZ",
                   help="publish /clock (the recording's time) at HZ (default 100) for use_sim_time")
    p.add_argument("--max-gap", type=finite_float("--max-gap", 0.0, strict=True), default=600.0, metavar="S",
                   help="refuse to publish a recording with a pause between two messages that would take longer than "
                        "this to replay (default 600 s: a clock jump is not waited out)")
    p.add_argument("--wait-subscribers", type=finite_float("--wait-subscribers", 0.0), default=0.0,
                   help="wait up to this long (s) until every topic has --subscribers subscribers")
    p.add_argument("--subscribers", type=pos_int("--subscribers", 1, 1000), default=1,
                   help="how many subscribers each topic waits for with --wait-subscribers (default 1)")
    p.add_argument("--rerun-save", metavar="OUT.rrd", default=None, type=output_path("--rerun-save", (".rrd",)),
                   help="write the recording as a Rerun file")
    p.add_argument("--rerun-connect", nargs="?", const=DEFAULT_CONNECT_URL, default=None, metavar="URL",
                   help=f"stream to a Rerun viewer (default {DEFAULT_CONNECT_URL})")
    p.add_argument("--publish", action="store_true",
                   help="with --rerun-save/--rerun-connect: also publish on ROS 2 (original timing)")
    p.add_argument("--info", action="store_true",
                   help="print the topics, counts and integrity of FILE and exit (exit code 2 when damaged)")
    p.add_argument("--allow-damaged", action="store_true",
                   help="replay the intact chunks of a damaged file (bad CRC, cut) and say what was skipped, "
                        "instead of refusing it (exit code 2)")
    p.add_argument("--quiet", action="store_true", help="no progress or summary lines (errors still go to stderr)")
    p.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=None,
                   help="everything after this goes to ROS")
    p.set_defaults(func=main, ros_network=lambda a: not a.info and (a.publish or (a.rerun_save is None
                                                                                 and a.rerun_connect is None)))
    return p


def main(args) -> int:
    from pathlib import Path

    from bkabem_ros.cli.base import UsageError
    from bkabem_ros.recording import mcap_check, mcap_io
    from bkabem_ros.recording import replay as rp

    say = (lambda text: None) if args.quiet else (lambda text: print(text, flush=True))
    path = Path(args.file)
    from bkabem_core.model.files import not_a_file

    why = not_a_file(path, missing="{path}: no such file")
    if why:
        raise UsageError(f"FILE: {why}")
    try:
        remap = rp.parse_remaps(args.remap)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    from bkabem_ros.ros_env import check_names

    check_names([("--namespace", "namespace", args.namespace)]
                + [("--remap", "topic", t) for pair in remap.items() for t in pair]
                + [("--topics", "topic", t) for t in args.topics or []])
    try:
        integrity = mcap_check.verify(path)
    except OSError as exc:
        raise UsageError(f"FILE: {path}: {exc.strerror}") from None
    if not integrity.mcap:
        raise UsageError(f"FILE: {path}: not a readable MCAP file (no MCAP magic at the start)")
    summary = mcap_io.summary(path, integrity=integrity, decode=True)     # every message decoded: damage too
    say(rp.describe(path, integrity, summary))
    if not integrity.ok:
        if not args.allow_damaged:
            raise UsageError(f"FILE: {path} is damaged: {integrity.summary_line()} (--allow-damaged replays the "
                             f"intact part)")
        sys.stderr.write(f"bkabem replay: warning: {path} is damaged, replaying only its intact part: "
                         f"{integrity.summary_line()}\n")
    recorded = sorted(summary["topics"])
    for option, names in (("--topics", args.topics or []), ("--remap", list(remap))):
        for t in names:
            if t not in summary["topics"] and "/" + t.lstrip("/") not in summary["topics"]:
                raise UsageError(f"{option}: {t} is not a topic of {path} (it has {len(recorded)}: "
                                 f"{', '.join(recorded[:8])}{' ...' if len(recorded) > 8 else ''})")
    if args.info:
        return 0
    if args.start_offset > 0:
        span = (summary["end_ns"] - summary["start_ns"]) / 1e9
        if summary["messages"] and args.start_offset > span:
            raise UsageError(f"--start-offset: {args.start_offset:g} s is after the end of the recording "
                             f"({span:.2f} s long)")
    publish_now = args.publish or (args.rerun_save is None and args.rerun_connect is None)
    wait_s = summary["max_gap_ns"] / 1e9 / args.rate
    if publish_now and wait_s > args.max_gap:
        raise UsageError(f"FILE: {path} has a gap of {summary['max_gap_ns'] / 1e9:.6g} s between two messages "
                         f"(after log time {summary['max_gap_at_ns']} ns: a clock jump?), which replay at --rate "
                         f"{args.rate:g} would wait {wait_s:.4g} s for, more than --max-gap {args.max_gap:g} s "
                         f"(raise --max-gap to replay it as recorded)")

    to_rerun = args.rerun_save is not None or args.rerun_connect is not None
    publish = args.publish or not to_rerun
    logger = None
    if to_rerun:
        from bkabem_ros.viewer.rerun_io import RerunLogger

        with _rerun_errors(args):
            logger = RerunLogger("bkabem", recording_id=path.stem, save_path=args.rerun_save,
                                 connect_url=args.rerun_connect, optimize=True)
    with _rerun_errors(args):
        try:
            stats = rp.replay(path, rate=args.rate, loop=args.loop, start_offset_s=args.start_offset,
                              remap=remap, topics=args.topics, clock=args.clock is not None,
                              clock_hz=args.clock or 100.0, publish=publish, rerun_logger=logger,
                              namespace=args.namespace, wait_for_subscribers_s=args.wait_subscribers,
                              subscribers=args.subscribers,
                              progress=say, ros_args=args.ros_args, allow_damaged=args.allow_damaged,
                              integrity=integrity)
        finally:
            if logger is not None:
                logger.close()
    if publish:
        say(f"published {stats.messages} messages on {len(stats.published)} topics in {stats.wall_s:.2f} s"
            + (f", {stats.clock_messages} /clock" if args.clock is not None else ""))
    if logger is not None:
        where = args.rerun_save or args.rerun_connect
        say(f"logged {stats.logged} messages ({logger.samples_logged} waveform samples) to {where}")
        if getattr(logger, "optimize_error", None):
            print(f"bkabem replay: warning: {args.rerun_save} left as written: {logger.optimize_error}", file=sys.stderr)
        if args.rerun_save:
            say(f"open it with: .venv/bin/rerun {args.rerun_save}")
    if stats.damage:
        sys.stderr.write(f"bkabem replay: warning: skipped the damaged part of {path}: {stats.damage}"
                         + (f"; left out {stats.bad_messages} message{'s' * (stats.bad_messages != 1)} that did not decode"
                            if stats.bad_messages
                            else "") + "\n")
    return 0


class _rerun_errors:
    """A failure inside the Rerun SDK (file not creatable, disk full, viewer gone) -> one line naming the option."""

    def __init__(self, args):
        self.option = ("--rerun-save", args.rerun_save) if args.rerun_save else ("--rerun-connect", args.rerun_connect)

    def __enter__(self):
        return self

    def __exit__(self, et, exc, tb):
        if exc is None or not isinstance(exc, Exception) or isinstance(exc, OSError):
            return False
        while tb is not None:
            if "/rerun" in tb.tb_frame.f_code.co_filename.replace("\\", "/"):
                from bkabem_ros.cli.base import UsageError

                raise UsageError(f"{self.option[0]}: {self.option[1]}: {exc}") from None
            tb = tb.tb_next
        return False


def standalone(argv=None) -> int:
    """``python -m bkabem_ros.cli.replay ARGS`` = ``bkabem replay ARGS`` (same errors and exit codes)."""
    from bkabem_ros.cli.base import subcommand_main

    return subcommand_main("replay", add_parser, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(standalone())
