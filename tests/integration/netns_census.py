"""Run bkabem ROS commands inside a private network namespace and count what leaves on a veth.

Started by ``tests/integration/test_network.py`` as ``unshare -rn python tests/integration/netns_census.py SPEC.json``: a user + network
namespace of its own (only ``lo``), in which this script adds a veth pair ``v0``/``v1`` (10.99.0.1/24 on v0,
IPv6 off so the kernel's own neighbour discovery does not count), runs the commands of SPEC concurrently with
the environment of SPEC (no discovery variables unless SPEC sets them) for SPEC's ``seconds``, then stops the
commands marked ``stop`` with SIGINT and waits for the others to end by themselves, and prints one JSON object:

- ``tx_packets`` / ``tx_bytes``: sent on v0 while the commands ran (``/proc/net/dev`` of the namespace);
- ``groups_v0``: multicast groups joined on v0 (``/proc/net/igmp``; the kernel's 224.0.0.1 left out);
- ``sockets``: every UDP and TCP socket the commands (and their children) had open while they ran, as
  ``[local address, process name, command]`` (``ss -uanpH`` / ``ss -tanpH``, sampled every 0.2 s; the command is
  the one whose process tree holds it, "" if none does);
- per command: exit code and output.

Nothing leaves the namespace: v1 is the other end of the pair, inside it too, and the namespace disappears
with this process.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import time


def sh(*args: str) -> None:
    subprocess.run(args, check=True, capture_output=True)


def setup() -> None:
    sh("ip", "link", "set", "lo", "up")
    sh("ip", "link", "add", "v0", "type", "veth", "peer", "name", "v1")
    for dev in ("v0", "v1"):
        with open(f"/proc/sys/net/ipv6/conf/{dev}/disable_ipv6", "w") as fh:
            fh.write("1")
    sh("ip", "addr", "add", "10.99.0.1/24", "dev", "v0")
    sh("ip", "link", "set", "v0", "up")
    sh("ip", "link", "set", "v1", "up")


def tx(dev: str = "v0") -> tuple[int, int]:
    for line in open("/proc/net/dev").read().splitlines()[2:]:
        name, data = line.split(":", 1)
        if name.strip() == dev:
            f = data.split()
            return int(f[8]), int(f[9])        # tx bytes, tx packets
    raise RuntimeError(f"no device {dev}")


def groups(dev: str = "v0") -> list[str]:
    out, current = [], None
    for line in open("/proc/net/igmp").read().splitlines()[1:]:
        if not line.startswith("\t"):
            current = line.split()[1]
            continue
        if current == dev:
            g = socket.inet_ntoa(struct.pack("<I", int(line.split()[0], 16)))
            if g != "224.0.0.1":
                out.append(g)
    return out


def sockets(roots: dict[int, str]) -> set[tuple[str, str, str]]:
    """(local address, process name, command) of every UDP/TCP socket in this namespace; the command is found by
    walking up from the socket's pid to one of ``roots`` (pid -> command name)."""
    out = set()
    for proto in ("-uanpH", "-tanpH"):
        text = subprocess.run(["ss", proto], capture_output=True, text=True).stdout
        for line in text.splitlines():
            fields = line.split()
            if len(fields) < 6:
                continue
            local = fields[3]
            for name, pid in re.findall(r'\("([^"]*)",pid=(\d+)', line):
                out.add((local, name, _command_of(int(pid), roots)))
    return out


def _command_of(pid: int, roots: dict[int, str]) -> str:
    for _ in range(32):
        if pid in roots:
            return roots[pid]
        try:
            stat = open(f"/proc/{pid}/stat").read()
        except OSError:
            return ""
        pid = int(stat.rsplit(")", 1)[1].split()[1])
        if pid <= 1:
            return ""
    return ""


def main(spec_path: str) -> int:
    spec = json.load(open(spec_path))
    setup()
    time.sleep(0.3)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "_BKABEM"))}
    env.update(spec["env"])
    b0, p0 = tx()
    procs = []
    for cmd in spec["commands"]:
        procs.append(subprocess.Popen(cmd["argv"], env=env, cwd=spec["cwd"], stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True, start_new_session=True))
    t_end = time.monotonic() + spec["seconds"]
    joined: set[str] = set()
    seen: set[tuple[str, str, str]] = set()
    roots = {p.pid: cmd["name"] for cmd, p in zip(spec["commands"], procs)}
    while time.monotonic() < t_end:
        joined |= set(groups())
        seen |= sockets(roots)
        time.sleep(0.2)
    results = []
    for cmd, p in zip(spec["commands"], procs):
        if p.poll() is None and cmd.get("stop"):          # a node runs until stopped; the others end by themselves
            p.send_signal(signal.SIGINT)
        try:
            out, _ = p.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            out, _ = p.communicate()
        results.append({"name": cmd["name"], "rc": p.returncode,
                        "output": out if len(out) < 8000 else out[:3000] + "\n...\n" + out[-5000:]})
    b1, p1 = tx()
    print(json.dumps({"tx_packets": p1 - p0, "tx_bytes": b1 - b0, "groups_v0": sorted(joined),
                      "sockets": sorted(seen), "results": results}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
