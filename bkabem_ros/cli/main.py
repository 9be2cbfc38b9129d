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
:mod:`bkabem_ros.cli.ros` (+ ``speed``,         ``node``, ``speed``, ``echo``, ``fleet``, ``record``, ``replay``
``echo``, ``fleet``, ``record_cli``,
``replay_cli``)
==========================================  =================================================================

The core commands never import rclpy (the ROS modules import it when a ROS command runs). The error contract
(one line naming the argument or case key, exit code 2; an unexpected exception one line with the hint to
re-run with ``--debug``, exit code 1) is :func:`bkabem_ros.cli.base.run_command`.
"""

from __future__ import annotations

import sys

from bkabem_ros.cli import core as core_cli
from bkabem_ros.cli import dataset as dataset_cli
from bkabem_ros.cli import synth as synth_cli
from bkabem_ros.cli.base import Parser, add_debug, add_ros_options, run_command
from bkabem_ros.cli.ros import add_ros_commands

__all__ = ["build_parser", "main"]


def build_parser() -> Parser:
    """The ``bkabem`` parser with every subcommand (and ``--debug`` before or after the command name)."""
    p = Parser(prog="bkabem", description="BKA-BEM digital-twin vibration source for a faulty ball bearing")
    add_debug(p, default=False)
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    core_cli.add_parsers(sub)
    synth_cli.add_parser(sub)
    dataset_cli.add_parser(sub)
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
