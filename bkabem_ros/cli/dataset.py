"""``bkabem dataset``: render a labelled data set from a spec (a grid or a seeded random sample of runs).

    bkabem dataset dataset_example --out out/example                  # embedded spec, every core
    bkabem dataset my_spec.toml --out /data/kinds --workers 2
    bkabem dataset my_spec.toml --out /data/kinds --list              # validate and list the runs only
    bkabem dataset my_spec.toml --out /shared/kinds --engine dask --scheduler tcp://HOST:8786

The spec, the folder layout, the labels and resuming: ``docs/datasets.md`` (:mod:`bkabem_core.dataset.spec`,
:mod:`bkabem_core.dataset.engine`). An interrupted run continues where it stopped when started again with the same spec
and ``--out``. With ``[output] mcap = true`` every run also gets an MCAP recording of the node's waveform messages
(:mod:`bkabem_ros.recording.dataset_sink`).

Bad input (a spec key, an option, an output folder that holds another data set): one line naming it, exit 2.
"""

from __future__ import annotations

import sys
from pathlib import Path

from bkabem_ros.cli.base import UsageError, pos_int, times_real_time


def dataset_main(args) -> int:
    from bkabem_core.dataset.engine import DatasetError, render_dataset
    from bkabem_core.dataset.spec import DatasetSpec, DatasetSpecError

    try:
        spec = DatasetSpec.load(args.spec)
    except DatasetSpecError as exc:
        raise UsageError(str(exc)) from None
    if args.list:
        for r in spec.runs:
            p = r.params
            what = (f"scenario {p['scenario']}" if p["scenario"] is not None else
                    f"{p['fault']}" + (f" {p['bearing']} {p['length_m'] * 1e3:g} mm x {p['depth_m'] * 1e6:g} um"
                                       if p["fault"] != "healthy" else ""))
            speed = p["profile"] or (f"{p['speed_hz']:g} Hz" if p["speed_hz"] is not None else "scenario speed")
            print(f"{r.run_id}  {what}, {speed}, {p['duration_s']:g} s at {p['sample_rate_hz']:g} Hz, "
                  f"seed {p['seed']}")
        print(f"{len(spec.runs)} runs, spec hash {spec.spec_hash}")
        return 0
    if args.out is None:
        raise UsageError("--out: is required (the data set's folder)")
    if args.scheduler is not None and args.engine != "dask":
        raise UsageError("--scheduler: only with --engine dask")
    if args.scheduler is not None:
        _check_scheduler(args.scheduler)
    sinks = ()
    if spec.mcap:
        from bkabem_ros.recording.dataset_sink import SINK  # rclpy only serialises the messages: no ROS graph is joined

        sinks = (SINK,)
    text = None
    if Path(args.spec).is_file():
        text = Path(args.spec).read_text()
    try:
        res = render_dataset(spec, args.out, engine=args.engine, workers=args.workers, scheduler=args.scheduler,
                             progress=not args.no_progress and sys.stderr.isatty(), sinks=sinks, spec_text=text)
    except DatasetError as exc:
        raise UsageError(str(exc)) from None
    rate = res.signal_s / res.wall_s if res.wall_s > 0 else 0.0
    print(f"wrote {res.out_dir}: {res.runs} runs ({res.rendered} rendered, {res.skipped} already there"
          + (f", {len(res.damaged)} damaged files rendered again" if res.damaged else "")
          + f"), labels.parquet + labels.csv ({res.labels_rows} rows); {res.signal_s:g} s of signal in "
          f"{res.wall_s:.1f} s ({times_real_time(rate)} real time; models {res.model_s:.1f} s, synthesis + writing "
          f"{res.render_s:.1f} s of worker time)")
    return 0


def _check_scheduler(address: str) -> None:
    """A Dask scheduler address is ``[tcp|tls|ws|wss|ucx://]HOST:PORT`` (IPv6 in brackets)."""
    import re

    m = re.fullmatch(r"(?:(tcp|tls|ws|wss|ucx)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9.-]*):(\d{1,5})", address.strip())
    if m is None or not 0 < int(m.group(3)) < 65536:
        raise UsageError(f"--scheduler: {address!r} is not a Dask scheduler address like tcp://HOST:8786")


def add_parser(sub):
    """Register ``bkabem dataset`` on an argparse subparsers object."""
    p = sub.add_parser("dataset", help="render a labelled data set (grid or random sample of runs) to Parquet")
    p.add_argument("spec", help="data-set spec: embedded name (dataset_example, dataset_run_to_failure) or TOML file")
    p.add_argument("--out", default=None, help="output folder (created; resumed when it holds this spec's runs)")
    p.add_argument("--engine", default="local", choices=("local", "dask"),
                   help="local: worker processes on this machine (default); dask: a Dask distributed cluster")
    p.add_argument("--workers", default=None, type=pos_int("--workers", 1, 4096),
                   help="worker processes (default: every core; 1 = in this process); dask: local cluster size")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:8786",
                   help="address of a running Dask scheduler (--engine dask; default: a local cluster on 127.0.0.1)")
    p.add_argument("--list", action="store_true", help="validate the spec and list its runs, render nothing")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=dataset_main)
    return p


def main(argv=None) -> int:
    """``python -m bkabem_ros.cli.dataset SPEC --out DIR`` = ``bkabem dataset SPEC --out DIR``."""
    from bkabem_ros.cli.base import subcommand_main

    return subcommand_main("dataset", add_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
