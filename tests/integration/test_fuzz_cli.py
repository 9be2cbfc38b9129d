"""Issue 14: a fuzz test over case files and arguments, bounded in time.

Generated hostile inputs (``tests/integration/fuzz_cli.py``: mutated case files and scenario files; bad values for the options of all
subcommands, unwritable and full output paths, damaged input files) are run as real ``bkabem`` processes (6 GiB
address-space limit, 60 s each) and must meet the contract: **exit 0 with finite output, or exit 2 with one
line**. A sample of each kind runs within a time budget here; ``python tests/integration/fuzz_cli.py`` runs them all (the
counts before and after issue 14 are in its closing note and in BENCHMARKS.md).
"""

from __future__ import annotations

import os
import sys

import fuzz_cli
import pytest

pytestmark = pytest.mark.slow

SEED = int(os.environ.get("BKABEM_FUZZ_SEED", "14"))
CLI = [sys.executable, "-m", "bkabem_ros"]


@pytest.mark.parametrize("kind, n, budget_s", [("case files", 60, 150.0), ("scenario files", 40, 150.0),
                                              ("arguments", 150, 200.0)])
def test_fuzz_exit_0_with_finite_output_or_exit_2_with_one_line(kind, n, budget_s):
    inputs = {"case files": fuzz_cli.case_inputs, "scenario files": fuzz_cli.scenario_inputs,
              "arguments": fuzz_cli.argument_inputs}[kind](n, SEED)
    outcomes = fuzz_cli.run_all(inputs, CLI, timeout=60.0, jobs=2, budget_s=budget_s)
    assert len(outcomes) >= min(n, 20), f"only {len(outcomes)} runs in {budget_s} s: the machine is too slow"
    bad = [o for o in outcomes if o.verdict not in ("ok0", "ok2")]
    assert not bad, fuzz_cli.report(outcomes, f"{kind} (seed {SEED})")
