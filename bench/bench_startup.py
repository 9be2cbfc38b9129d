"""Start-up time of the command line and of the first results, and the wall time of the fast test tier.

    .venv/bin/python bench/bench_startup.py [--repeat 5] [--unit-tier] [--json FILE]

Each measurement is a fresh process (the interpreter's own start included), wall time, median of ``--repeat``:

help          ``bkabem --help``: what every command pays before it parses its arguments
import        ``python -c "from bkabem_core import Case, BkaBem, Synthesizer"``: the library's main names loaded
excitation    ``bkabem excitation --json``: the embedded case's quasi-static excitation, end to end
spectrum      ``bkabem spectrum --speed-hz 25 --json``: the model prepared and one spectrum, end to end
unit tier     ``--unit-tier``: ``pytest -q -n auto --maxprocesses=4 --dist worksteal tests/unit`` as ``make unit``
              (no processes, no DDS), with its pass / fail counts, twice: with an empty model cache (the tests
              make the fault library and the models they take as input: the run after a change to the physics,
              as on a fresh clone) and then with that cache made (the run after any change above ``solve``)
suite         ``--suite``: the three pytest runs of ``make test`` once (the unit tier, the integration tier but
              its ``serial`` tests on the same workers, then those alone), their wall times summed, with their counts

The commands run from a temporary folder with ``OPENBLAS_NUM_THREADS=1``; their output is checked (exit code 0,
JSON that parses) so that a fast failure is not reported as a fast start.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _bkabem() -> list[str]:
    exe = BIN / "bkabem"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "bkabem_ros"]


def timed(cmd: list[str], cwd: str, check_json: bool = False) -> float:
    """Wall time [s] of one run of ``cmd``; raises if it fails or its JSON does not parse."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()[-400:]}")
    if check_json:
        json.loads(r.stdout)
    return wall


#: The unit tier's workers, as ``make unit`` runs it (pytest-xdist).
UNIT_XDIST = ("-n", "auto", "--maxprocesses=4", "--dist", "worksteal")


def pytest_run(cwd: Path, *paths: str, options: tuple = (), env: dict | None = None) -> dict:
    """One run of pytest over ``paths`` (all tests if none) with ``options`` and the variables ``env`` added:
    wall time and the counts pytest reports."""
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *options, *paths], cwd=cwd,
                       env=dict(os.environ, OPENBLAS_NUM_THREADS="1", **(env or {})), capture_output=True, text=True,
                       timeout=7200)
    wall = time.perf_counter() - t0
    tail = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ""
    counts = {k: int(n) for n, k in re.findall(r"(\d+) (passed|failed|errors?|skipped|deselected)", tail)}
    return {"wall_s": wall, "exit_code": r.returncode, "summary": tail[-200:], **counts}


#: ``make test``: (paths, options) of its pytest runs, in order; the first is ``make unit``.
SUITE_RUNS = ((("tests/unit",), UNIT_XDIST), (("tests/integration",), (*UNIT_XDIST, "-m", "not serial")),
              (("tests/integration",), ("-m", "serial")))


def pytest_runs(cwd: Path, plan) -> dict:
    """The pytest runs of ``plan`` ((paths, options) each) in order: wall times and counts summed, the exit code
    the first non-zero one."""
    runs = [pytest_run(cwd, *paths, options=options) for paths, options in plan]
    out = {"wall_s": sum(r["wall_s"] for r in runs), "exit_code": next((r["exit_code"] for r in runs
                                                                        if r["exit_code"]), 0),
           "summary": "; ".join(r["summary"] for r in runs)[-400:], "runs": runs}     # (a table cell: no "|")
    for key in ("passed", "failed", "error", "errors", "skipped"):
        if any(key in r for r in runs):
            out[key] = sum(r.get(key, 0) for r in runs)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs per command; medians are reported (default 5)")
    ap.add_argument("--unit-tier", action="store_true", help="also run tests/unit once and time it")
    ap.add_argument("--suite", action="store_true", help="also run the whole test suite once and time it")
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args(argv)
    cli = _bkabem()
    cases = {
        "help": (cli + ["--help"], False),
        "import": ([sys.executable, "-c", "from bkabem_core import Case, BkaBem, Synthesizer"], False),
        "excitation": (cli + ["excitation", "--json"], True),
        "spectrum": (cli + ["spectrum", "--speed-hz", "25", "--json"], True),
    }
    res: dict = {"load": [os.getloadavg()[0]]}
    with tempfile.TemporaryDirectory(prefix="bkabem_startup_") as cwd:
        times: dict[str, list[float]] = {k: [] for k in cases}
        for _ in range(args.repeat):                     # interleaved: the machine's load hits every command alike
            for name, (cmd, check) in cases.items():
                times[name].append(timed(cmd, cwd, check))
        for name, ts in ((k, v) for k, v in times.items() if v):
            res[name] = {"median_s": statistics.median(ts), "min_s": min(ts), "runs": len(ts)}
            print(f"{name:11s} median {statistics.median(ts):6.3f} s  (min {min(ts):.3f}, {len(ts)} runs)",
                  flush=True)
    if args.unit_tier:
        paths, options = SUITE_RUNS[0]
        with tempfile.TemporaryDirectory(prefix="bkabem_test_cache_") as cache:
            for key in ("unit_tier_cold", "unit_tier"):           # models made, then taken from the cache
                res[key] = u = pytest_run(ROOT, *paths, options=options, env={"BKABEM_TEST_CACHE": cache})
                print(f"{key:14s} {u['wall_s']:6.1f} s  exit {u['exit_code']}  {u['summary']}", flush=True)
    if args.suite:
        res["suite"] = u = pytest_runs(ROOT, SUITE_RUNS)
        print(f"suite      {u['wall_s']:6.1f} s  exit {u['exit_code']}  {u['summary']}", flush=True)
    res["load"].append(os.getloadavg()[0])
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    failed = [k for k in ("unit_tier_cold", "unit_tier", "suite") if res.get(k, {}).get("exit_code")]
    if failed:                                     # a failing run's time is no record of the tier's speed
        print(f"bench_startup: {', '.join(failed)}: pytest failed; its time is not a measurement", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
