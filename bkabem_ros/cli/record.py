"""``bkabem record``: record the node's topics from the graph into MCAP, or recover a cut file.

    bkabem record --out run.mcap [--namespace /m1] [--topics speed vibration/de/acceleration ...]
                  [--duration S] [--chunk-size BYTES] [--chunk-duration S]
                  [--rotate-size BYTES] [--rotate-duration S]
    bkabem record --recover CUT.mcap FIXED.mcap
"""

from __future__ import annotations

import argparse
import os
import sys

__all__ = ["add_parser", "main"]

DEFAULT_OUT = "recordings/record.mcap"


def _size(text: str) -> int:
    """Bytes with an optional k/M/G suffix (powers of 1024)."""
    t = text.strip().upper().removesuffix("B")
    mult = 1
    for suffix, m in (("K", 1 << 10), ("M", 1 << 20), ("G", 1 << 30)):
        if t.endswith(suffix):
            t, mult = t[:-1], m
            break
    try:
        if "_" in t:
            raise ValueError(t)
        v = int(float(t) * mult)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a size like 1048576, 512k, 64M (got {text!r})") from None
    if v <= 0:
        raise argparse.ArgumentTypeError(f"size must be > 0 (got {text!r})")
    return v


#: --chunk-size at most: the largest chunk the reader decompresses (bkabem_ros.recording.mcap_check.MAX_RECORD_BYTES,
#: not imported here: this module parses arguments without mcap), less a message or two of slack.
MAX_CHUNK_BYTES = 48 << 20


def _size_at_most(limit: int):
    def conv(text: str) -> int:
        v = _size(text)
        if v > limit:
            raise argparse.ArgumentTypeError(f"at most {limit >> 20}M (got {text!r})")
        return v

    return conv


def add_parser(sub, add_case=None):
    """Register ``bkabem record`` on an argparse subparsers object."""
    from bkabem_ros.cli.base import finite_float, output_path

    p = sub.add_parser("record", help="record the node's topics into a ROS 2 MCAP file (or --recover one)",
                       description=__doc__)
    p.add_argument("--out", default=None, type=output_path("--out", (".mcap",), make_parents=True),
                   help=f"output MCAP file (default {DEFAULT_OUT})")
    p.add_argument("--topics", nargs="+", default=None, metavar="TOPIC",
                   help="topics to record (relative names follow --namespace); default: speed and every "
                        "bkabem_msgs topic")
    p.add_argument("--namespace", default="", help="namespace of the node, e.g. /machine_00")
    p.add_argument("--duration", type=finite_float("--duration", 0.0, strict=True), default=None,
                   help="stop after this many seconds (default: until Ctrl-C)")
    p.add_argument("--chunk-size", type=_size_at_most(MAX_CHUNK_BYTES), default=1 << 20,
                   help=f"uncompressed chunk size that triggers a write (default 1M, at most "
                        f"{MAX_CHUNK_BYTES >> 20}M: the largest chunk replay reads)")
    p.add_argument("--chunk-duration", type=finite_float("--chunk-duration", 0.0, strict=True), default=1.0,
                   help="write a chunk at the latest after this many seconds; a crash loses at most this "
                        "(default 1)")
    p.add_argument("--rotate-size", type=_size, default=None,
                   help="start a new file (<stem>_N.mcap) at this size")
    p.add_argument("--rotate-duration", type=finite_float("--rotate-duration", 0.0, strict=True), default=None,
                   help="start a new file after this many seconds of recording")
    p.add_argument("--recover", nargs=2, metavar=("SRC", "DST"), default=None,
                   help="rebuild a cut recording SRC (kill -9, power loss) into a complete DST, and exit")
    p.add_argument("--quiet", action="store_true", help="no progress or summary lines (errors still go to stderr)")
    p.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=None,
                   help="everything after this goes to ROS")
    p.set_defaults(func=main, ros_network=lambda a: a.recover is None)
    return p


def main(args) -> int:
    from bkabem_ros.cli.base import UsageError, output_path
    from bkabem_ros.recording import mcap_io

    say = (lambda text: None) if args.quiet else (lambda text: print(text, flush=True))
    if args.recover:
        import argparse as _argparse

        from bkabem_ros.cli.base import check_output

        src, dst = args.recover
        from bkabem_core.model.files import not_a_file

        why = not_a_file(src, missing="{path}: no such file")
        if why:
            raise UsageError(f"--recover SRC: {why}")
        try:
            check_output("--recover DST", dst)
        except _argparse.ArgumentTypeError as exc:
            raise UsageError(str(exc)) from None
        try:
            res = mcap_io.recover(src, dst)
        except FileNotFoundError as exc:
            which = "SRC" if exc.filename == src else "DST"
            raise UsageError(f"--recover {which}: {exc.filename}: no such file or directory") from None
        except ValueError as exc:
            raise UsageError(f"--recover: {exc}") from None
        except OSError as exc:
            which = "SRC" if exc.filename == src else "DST"
            raise UsageError(f"--recover {which}: {exc.filename or dst}: {exc.strerror}") from None
        if res.truncated and res.messages == 0 and (res.expected_messages or res.skipped_chunks):
            os.unlink(dst)
            raise UsageError(f"--recover SRC: nothing in {src} is recoverable: {res.error}")
        state = "was complete" if not res.truncated else \
            f"was {'damaged' if res.damaged_records or res.skipped_chunks else 'cut'} ({res.error})"
        skipped = f"; skipped {res.skipped_chunks} damaged chunk{'s' * (res.skipped_chunks != 1)}" \
            if res.skipped_chunks else ""
        lost = f" of the {res.expected_messages} its summary counts" \
            if res.expected_messages is not None and res.expected_messages != res.messages else ""
        say(f"{src} {state}; wrote {dst}: {res.messages} messages{lost} on {res.channels} channels, "
            f"last log time {res.last_log_time_ns} ns{skipped}")
        return 0

    from bkabem_ros.recording.record import record
    from bkabem_ros.ros_env import check_names

    if args.out is None:
        args.out = output_path("--out", (".mcap",), make_parents=True)(DEFAULT_OUT)
    check_names([("--namespace", "namespace", args.namespace)] + [("--topics", "topic", t) for t in args.topics or []])
    try:
        stats = record(args.out, topics=args.topics, namespace=args.namespace,
                       duration_s=args.duration, chunk_size_bytes=args.chunk_size,
                       chunk_duration_s=args.chunk_duration, rotate_size_bytes=args.rotate_size,
                       rotate_duration_s=args.rotate_duration, progress=say,
                       ros_args=args.ros_args)
    except mcap_io.RecorderError as exc:
        raise UsageError(f"--out: {exc}") from None
    files = ", ".join(str(p) for p in stats.paths)
    say(f"recorded {stats.messages} messages on {len(stats.counts)} topics into {files}")
    for topic, n in sorted(stats.counts.items()):
        say(f"  {topic:40s} {n}")
    if stats.error:
        raise UsageError(f"--out: {stats.error}")
    return 0


def standalone(argv=None) -> int:
    """``python -m bkabem_ros.cli.record ARGS`` = ``bkabem record ARGS`` (same errors and exit codes)."""
    from bkabem_ros.cli.base import subcommand_main

    return subcommand_main("record", add_parser, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(standalone())
