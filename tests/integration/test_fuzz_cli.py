"""A fuzz test over case files, scenario files and arguments, bounded in time.

Generated hostile inputs (``tests/integration/fuzz_cli.py``: mutated case files and scenario files; bad values for
the options of all subcommands, unwritable and full output paths, damaged input files) are run as ``bkabem``
processes (6 GiB address-space limit, 60 s each) and must meet the contract: **exit 0 with finite output, or exit 2
with one line**. A sample of each kind runs within a time budget here, each run forked from one interpreter that has
imported the command line (``fuzz_cli.ForkServer``: half a second of start-up less a run); the first test holds that
to the runs of fresh interpreters. ``python tests/integration/fuzz_cli.py`` runs them all as fresh interpreters.
"""

from __future__ import annotations

import os
import re
import sys

import fuzz_cli
import pytest

pytestmark = pytest.mark.slow

SEED = int(os.environ.get("BKABEM_FUZZ_SEED", "14"))
CLI = [sys.executable, "-m", "bkabem_ros"]


def test_fork_server_runs_are_the_fresh_processes_runs(tmp_path):
    """The same inputs (a few of each kind) give the same exit code, verdict and stderr whether each is a fresh
    ``python -m bkabem_ros`` or a child of the fork server; a run that never ends is cut by its timeout alike; and a
    child whose ``main`` raises ends as the interpreter ends it, with the traceback and exit code 1 (the verdict a
    bug in the command line would get)."""
    inputs = fuzz_cli.case_inputs(4, SEED) + fuzz_cli.scenario_inputs(4, SEED) + fuzz_cli.argument_inputs(6, SEED)
    fresh = fuzz_cli.run_all(inputs, CLI, timeout=60.0, jobs=2)
    forked = fuzz_cli.run_all(inputs, None, timeout=60.0, jobs=2)

    def said(o):            # each run's folder, and a ROS log line's time stamp, named alike
        return re.sub(r"\[\d+\.\d+\]", "[T]", re.sub(r"bkabem_fuzz_[^/]+/fz_[^/\s:]+", "RUN", o.stderr))

    for a, b in zip(fresh, forked, strict=True):
        assert (a.returncode, a.verdict, said(a)) == (b.returncode, b.verdict, said(b)), a.input.label
    forever = [fuzz_cli.Input("speed published forever", ["speed", "--profile", "constant:25", "--quiet"])]
    assert [o.verdict for o in fuzz_cli.run_all(forever, CLI, timeout=4.0)] == ["hang"]
    assert [o.verdict for o in fuzz_cli.run_all(forever, None, timeout=4.0)] == ["hang"]
    server = fuzz_cli.ForkServer(fuzz_cli.fuzz_env(), tmp_path)
    try:
        rc, _, err = server([1], tmp_path, 60.0)          # argparse cannot take an int: an exception nothing catches
    finally:
        server.close()
    assert rc == 1 and "Traceback (most recent call last)" in err and "TypeError" in err, (rc, err)


@pytest.mark.parametrize("kind, n, budget_s", [("case files", 60, 150.0), ("scenario files", 40, 150.0),
                                              ("arguments", 150, 200.0)])
def test_fuzz_exit_0_with_finite_output_or_exit_2_with_one_line(kind, n, budget_s):
    inputs = {"case files": fuzz_cli.case_inputs, "scenario files": fuzz_cli.scenario_inputs,
              "arguments": fuzz_cli.argument_inputs}[kind](n, SEED)
    outcomes = fuzz_cli.run_all(inputs, None, timeout=60.0, jobs=2, budget_s=budget_s)
    assert len(outcomes) >= min(n, 20), f"only {len(outcomes)} runs in {budget_s} s: the machine is too slow"
    bad = [o for o in outcomes if o.verdict not in ("ok0", "ok2")]
    assert not bad, fuzz_cli.report(outcomes, f"{kind} (seed {SEED})")
