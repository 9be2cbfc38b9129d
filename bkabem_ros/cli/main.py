"""The ``bkabem`` command: one parser over every subcommand module, run under one error contract.

    bkabem [--debug] <command> ...       (console script; also ``python -m bkabem_ros``)

The command line stands above both packages: ``bkabem_core`` (physics, no ROS) imports nothing from here.
Subcommand modules, each registering its commands with ``add_parser(s)`` and only parsing and calling:

==========================================  =================================================================
module                                      commands
==========================================  =================================================================
:mod:`bkabem_ros.cli.core`                  ``excitation``, ``spectrum``, ``sweep``, ``validate``, ``demo``
:mod:`bkabem_ros.cli.synth`                 ``synth``
:mod:`bkabem_ros.cli.dataset`               ``dataset``
:mod:`bkabem_ros.cli.bearing`               ``bearing``
:mod:`bkabem_ros.cli.case`                  ``case new``, ``case check``
:mod:`bkabem_ros.cli.ros` (+ ``speed``,         ``node``, ``speed``, ``echo``, ``fleet``, ``record``, ``replay``
``echo``, ``fleet``, ``record_cli``,
``replay_cli``)
==========================================  =================================================================

The core commands never import rclpy (the ROS modules import it when a ROS command runs). The error contract
(one line naming the argument or case key, exit code 2; an unexpected exception one line with the hint to
re-run with ``--debug``, exit code 1) is :func:`bkabem_ros.cli.base.run_command`.
"""

from __future__ import annotations

import argparse
import sys

from bkabem_ros.cli import bearing as bearing_cli
from bkabem_ros.cli import case as case_cli
from bkabem_ros.cli import core as core_cli
from bkabem_ros.cli import dataset as dataset_cli
from bkabem_ros.cli import listing as listing_cli
from bkabem_ros.cli import synth as synth_cli
from bkabem_ros.cli.base import Parser, add_debug, add_ros_options, run_command
from bkabem_ros.cli.ros import add_ros_commands

__all__ = ["build_parser", "main"]


#: The top-level help's way in: what to run first, in the order a new user meets it.
START_HERE = """\
start here:
  bkabem list                                   what ships with bkabem: cases, scenarios, data-set specs
  bkabem demo --no-ros                          the embedded case: excitation and spectrum tables, figures in
                                                out/demo (a few seconds)
  bkabem spectrum --case motor_6010_inner --speed-hz 25 --png inner.png
                                                one machine at one speed: every line named, largest first
  bkabem synth --case motor_6010_ball --profile constant:25 --seconds 2 --out ball.npz --png ball.png
                                                sensor waveforms (npz or csv) with the ground truth
  bkabem demo                                   the same, then the ROS 2 node through a run-up, recorded to
                                                recordings/demo.mcap and demo.rrd
  bkabem COMMAND --help                         every option of a command, with its unit and default

docs: README.md, docs/*.md; bad input: one line naming the option, exit code 2"""


def build_parser() -> Parser:
    """The ``bkabem`` parser with every subcommand (and ``--debug`` before or after the command name)."""
    p = Parser(prog="bkabem", description="BKA-BEM digital-twin vibration source for rotating machines with faulty "
                                          "ball bearings", epilog=START_HERE,
               formatter_class=argparse.RawDescriptionHelpFormatter)
    add_debug(p, default=False)
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    listing_cli.add_parser(sub)
    core_cli.add_parsers(sub)
    synth_cli.add_parser(sub)
    dataset_cli.add_parser(sub)
    bearing_cli.add_parser(sub)
    case_cli.add_parser(sub)
    add_ros_commands(sub, core_cli.add_case)
    for sp in sub.choices.values():
        add_debug(sp)
        add_ros_options(sp)
    return p


def main(argv=None) -> int:
    """Entry point of the ``bkabem`` console script; returns the exit code.

    BLAS runs on one thread: the matrices are small (at most the FE model's few hundred DOF), where a multi-threaded
    OpenBLAS costs more than it gains and, beside the two eigen-decomposition workers, oversubscribes a 2-core
    machine (model preparation 4-25 s instead of 1.7 s, measured). Parsing imports no numerical library (the
    command modules import theirs when the command runs): ``bkabem --help`` starts in a fraction of a second.
    """
    args = build_parser().parse_args(argv)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return run_command(args)


if __name__ == "__main__":
    sys.exit(main())
