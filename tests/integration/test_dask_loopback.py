"""Dask clusters stay on loopback unless the user opens them: the one-host recipe of docs/datasets.md as written
(its commands read from the page), and the LocalCluster ``bkabem dataset --engine dask`` starts itself. Every
listening socket of every process of the cluster (scheduler, nannies, workers: their comm ports and HTTP ports) is
looked up with psutil and must be bound to 127.0.0.1."""

from __future__ import annotations

import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listening(roots) -> set[tuple[str, int]]:
    """(address, port) of every listening TCP socket of the processes ``roots`` and their children."""
    import psutil

    out = set()
    for root in roots:
        try:
            procs = [root] + root.children(recursive=True)
        except psutil.NoSuchProcess:
            continue
        for p in procs:
            try:
                out |= {(c.laddr.ip, c.laddr.port) for c in p.net_connections(kind="inet")
                        if c.status == psutil.CONN_LISTEN}
            except psutil.NoSuchProcess:
                pass
    return out


def _recipe() -> list[str]:
    """The one-host recipe's commands of docs/datasets.md (the first bash block with ``dask scheduler``)."""
    text = (REPO / "docs" / "datasets.md").read_text()
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        lines = [ln.strip() for ln in block.splitlines() if ln.strip() and not ln.strip().startswith("#")]
        if any(ln.startswith("dask scheduler") for ln in lines):
            return lines
    raise AssertionError("docs/datasets.md has no dask recipe")


def test_the_documented_one_host_recipe_listens_on_loopback_only(tmp_path):
    import psutil

    commands = _recipe()
    assert all("127.0.0.1" in c for c in commands), commands
    port, dash = _free_port(), _free_port()
    procs = []
    try:
        for cmd in commands:
            cmd = cmd.replace("127.0.0.1:8786", f"127.0.0.1:{port}").replace("--port 8786", f"--port {port}")
            cmd = cmd.replace("127.0.0.1:8787", f"127.0.0.1:{dash}").replace("--nworkers auto", "--nworkers 2")
            words = shlex.split(cmd)
            env = dict(os.environ)
            while "=" in words[0]:                              # leading VAR=value assignments
                k, v = words.pop(0).split("=", 1)
                env[k] = v
            words[0] = str(BIN / words[0])
            log = open(tmp_path / f"{len(procs)}.log", "w")
            procs.append(subprocess.Popen(words, env=env, stdout=log, stderr=subprocess.STDOUT,
                                          start_new_session=True))
            time.sleep(0.5)
        roots = [psutil.Process(p.pid) for p in procs]
        t_end = time.monotonic() + 90
        while time.monotonic() < t_end:                          # the scheduler, 2 nannies, 2 workers up
            found = _listening(roots)
            if (("127.0.0.1", port) in found and ("127.0.0.1", dash) in found
                    and len(psutil.Process(procs[1].pid).children(recursive=True)) >= 2 and len(found) >= 8):
                break
            time.sleep(1.0)
        log = "".join((tmp_path / f"{i}.log").read_text() for i in range(len(procs)))
        assert "Register worker" in log or "Starting established connection" in log, log[-3000:]
        found = _listening(roots)
        assert len(found) >= 8, (found, log[-3000:])             # scheduler + its HTTP, 2 x (nanny, worker, HTTP)
        assert {ip for ip, _ in found} == {"127.0.0.1"}, sorted(found)
    finally:
        for p in reversed(procs):
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)


def test_the_commands_own_local_cluster_listens_on_loopback_only(tmp_path, monkeypatch):
    import distributed
    import psutil

    from bkabem_core.dataset.engine import render_dataset
    from bkabem_core.dataset.spec import DatasetSpec

    seen: list[set] = []
    real = distributed.Client

    def client(*a, **kw):
        c = real(*a, **kw)
        seen.append(_listening([psutil.Process()]))            # this process (the scheduler) and its workers
        return c

    monkeypatch.setattr(distributed, "Client", client)
    spec = tmp_path / "spec.toml"
    spec.write_text('[dataset]\nname = "loopback"\nschema_version = 1\nsampling = "grid"\n\n[run]\n'
                    'duration_s = 0.2\n\n[grid]\nfault = ["healthy"]\nspeed_hz = [10.0, 20.0]\n')
    render_dataset(DatasetSpec.load(spec), tmp_path / "out", engine="dask", workers=2, log=lambda line: None)
    assert seen and len(seen[0]) >= 5, seen                      # scheduler, its HTTP port, 2 nannies + workers
    assert {ip for ip, _ in seen[0]} == {"127.0.0.1"}, sorted(seen[0])
