"""The start time of the ``bkabem`` console script: ``--help`` costs a few interpreter starts, not the seconds of
numpy, scipy and the physics (measured as a ratio to ``python -c pass`` on the same machine, in the same run)."""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.serial]   # measures time: run alone

#: ``bkabem --help`` in at most this many bare interpreter starts (about 2-3 measured; 25-35 when the parser
#: imported scipy through the synthesiser).
MAX_RATIO = 8.0


def _median_s(argv, runs: int = 7) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True, timeout=60)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


@pytest.mark.parametrize("command", [[], ["spectrum"], ["node"], ["synth"]], ids=lambda c: " ".join(c) or "bkabem")
def test_help_starts_in_a_few_interpreter_starts(command):
    script = shutil.which("bkabem", path=str(Path(sys.executable).parent))
    assert script, "the bkabem console script is installed beside the interpreter"
    bare = _median_s([sys.executable, "-c", "pass"])
    helped = _median_s([script, *command, "--help"])
    assert helped < MAX_RATIO * bare, f"bkabem {' '.join(command)} --help: {helped:.3f} s, python -c pass: {bare:.3f} s"
