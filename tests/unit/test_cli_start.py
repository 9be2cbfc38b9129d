"""A fast start: parsing the command line (``--help`` of ``bkabem`` and of every subcommand) imports argparse and
the option tables only; numpy, scipy, matplotlib, rclpy and the physics are imported when a command runs."""

from __future__ import annotations

import json
import subprocess
import sys

#: Top-level packages that parsing must not import (each costs 0.1-1 s of start-up).
HEAVY = ("numpy", "scipy", "matplotlib", "rclpy", "rerun", "mcap", "pyarrow", "pandas", "dask", "threadpoolctl")

_PROBE = """
import json, sys
from bkabem_ros.cli.main import build_parser, main

commands = [[]] + [[name] for name in build_parser()._subparsers._group_actions[0].choices]
found = {}
for argv in commands:
    try:
        main(argv + ["--help"])
    except SystemExit:
        pass
    heavy = sorted({m.split(".")[0] for m in sys.modules} & set(sys.argv[1:]))
    physics = sorted(m for m in sys.modules if m.startswith("bkabem_core."))
    found[" ".join(argv) or "bkabem"] = heavy + physics
print(json.dumps(found))
"""


def test_help_of_every_command_imports_no_numerical_library_or_physics():
    out = subprocess.run([sys.executable, "-c", _PROBE, *HEAVY], capture_output=True, text=True, timeout=120,
                         check=True).stdout
    found = json.loads(out.splitlines()[-1])
    assert len(found) > 10, found                     # bkabem and every subcommand were asked
    assert {k: v for k, v in found.items() if v} == {}
