"""Every Python and shell block of README.md and docs/*.md that is not a cheap unit-tier block, run as written
(tests/docs_snippets.py): a page's blocks in order in one temporary folder (with the repository's ``config/``, as
from its root), the project's interpreter and console scripts first on ``PATH``, ROS on loopback. Python blocks in
a fresh interpreter; shell blocks with ``bash -e``; a block of servers line by line, each alive after its time (or
ended with exit code 0) and stopped cleanly by SIGINT."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from docs_snippets import REPO, commands, snippets
from ros_helpers import ros_env

pytestmark = [pytest.mark.slow, pytest.mark.ros]

RUN_HOW = ("run", "each-runs-for")
PAGES = sorted({s.page for s in snippets() if s.lang in ("python", "sh", "bash") and s.how in RUN_HOW},
               key=lambda p: p.name)


def _env() -> dict:
    env = ros_env()
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    return env


def _servers(cmds: list[str], seconds: float, cwd: Path, env: dict, what: str) -> None:
    procs = []
    try:
        for i, cmd in enumerate(cmds):
            log = open(cwd / f"server{i}.log", "w")
            procs.append((cmd, subprocess.Popen(["bash", "-c", f"exec {cmd}"], cwd=cwd, env=env, stdout=log,
                                                stderr=subprocess.STDOUT, start_new_session=True), log))
            time.sleep(1.0)
        time.sleep(seconds)
        for cmd, p, _ in procs:
            assert p.poll() in (None, 0), f"{what}: `{cmd}` ended with {p.returncode}: " + \
                (cwd / f"server{procs.index((cmd, p, _))}.log").read_text()[-3000:]
    finally:
        for _, p, _ in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
        for i, (cmd, p, log) in enumerate(procs):
            try:
                rc = p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                rc = "killed"
            log.close()
            text = (cwd / f"server{i}.log").read_text()
            assert rc in (0, 128 + signal.SIGINT), f"{what}: `{cmd}` stopped with {rc}: {text[-3000:]}"
            assert "Traceback" not in text and " error:" not in text, f"{what}: `{cmd}`: {text[-3000:]}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_the_blocks_of_a_page_run_as_written(page, tmp_path):
    (tmp_path / "config").symlink_to(REPO / "config")
    env = _env()
    ran = 0
    for s in snippets([page]):
        if s.lang not in ("python", "sh", "bash") or s.how not in RUN_HOW:
            continue
        if s.lang == "python":
            r = subprocess.run([sys.executable, "-c", s.body], cwd=tmp_path, env=env, capture_output=True, text=True,
                               timeout=900)
        elif s.how == "each-runs-for":
            _servers(commands(s.body), s.value, tmp_path, env, s.id)
            ran += 1
            continue
        else:
            r = subprocess.run(["bash", "-e", "-c", s.body], cwd=tmp_path, env=env, capture_output=True, text=True,
                               timeout=900)
        assert r.returncode == 0, f"{s.id} ({s.lang}) exit {r.returncode}:\n{s.body}\n{r.stdout[-2000:]}\n" \
                                  f"{r.stderr[-3000:]}"
        ran += 1
    assert ran
