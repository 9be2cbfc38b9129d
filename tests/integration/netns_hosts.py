"""Several "hosts" on one machine for multi-host tests: Linux network namespaces joined by a bridge.

:class:`Hosts` creates, with ``ip netns``, one switch namespace holding a bridge ``br0`` (multicast snooping off,
like a plain plant switch) and ``n`` host namespaces, each with an ``eth0`` (veth) plugged into the bridge and a
private address ``10.<net>.0.<10+k>/24`` (``lo`` up, a multicast route on eth0, IPv6 off). Everything lives inside
these namespaces: the machine's own namespace gets no interface, route or address, so no test traffic can
leave the machine. :meth:`Hosts.cmd` prefixes a command with ``ip netns exec``; :meth:`Hosts.port_bytes`
reads the bridge port counters (what went over the "network" to and from a host).

Names start with :data:`PREFIX` and the creating process id; :meth:`Hosts.close` (called from the test
fixture's finalizer, also after a failure) kills whatever still runs inside and deletes the namespaces, and
:func:`cleanup_leftovers` removes namespaces of a crashed earlier run (its process no longer exists).
:func:`unavailable` says why namespaces cannot be made here (not root, no ``ip``, no privilege), or None.
"""

from __future__ import annotations

import os
import random
import re
import shutil
import signal
import subprocess

PREFIX = "bkfleet"


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], check=check, capture_output=True, text=True, timeout=30)


def _names() -> list[str]:
    out = _ip("netns", "list", check=False).stdout
    return [ln.split()[0] for ln in out.splitlines() if ln.startswith(PREFIX)]


def _remove(name: str) -> None:
    pids = _ip("netns", "pids", name, check=False).stdout.split()
    for p in pids:
        try:
            os.kill(int(p), signal.SIGKILL)
        except (OSError, ValueError):
            pass
    _ip("netns", "del", name, check=False)


def cleanup_leftovers() -> list[str]:
    """Delete namespaces of earlier runs whose creating process is gone; returns their names."""
    gone = []
    for name in _names():
        m = re.match(rf"{PREFIX}(\d+)_", name)
        if m and not os.path.exists(f"/proc/{m.group(1)}"):
            _remove(name)
            gone.append(name)
    return gone


def unavailable() -> str | None:
    """Why network namespaces cannot be created here, or None (tried: one is created and deleted)."""
    if shutil.which("ip") is None:
        return "the 'ip' command (iproute2) is missing"
    if os.geteuid() != 0:
        return "not running as root (ip netns needs CAP_SYS_ADMIN and CAP_NET_ADMIN)"
    probe = f"{PREFIX}{os.getpid()}_probe{random.randrange(1 << 20):x}"
    r = _ip("netns", "add", probe, check=False)
    if r.returncode != 0:
        return f"'ip netns add' failed: {r.stderr.strip()[:200]}"
    try:
        r = _ip("netns", "exec", probe, "ip", "link", "add", "t0", "type", "veth", "peer", "name", "t1", check=False)
        if r.returncode != 0:
            return f"veth pairs cannot be created in a namespace: {r.stderr.strip()[:200]}"
    finally:
        _remove(probe)
    return None


class Hosts:
    """``n`` host namespaces on one bridge (see the module docstring)."""

    def __init__(self, n: int):
        self.tag = f"{PREFIX}{os.getpid()}_{random.randrange(1 << 16):x}"
        self.net = random.randrange(64, 250)
        self.switch = f"{self.tag}sw"
        self.names = [f"{self.tag}h{k}" for k in range(1, n + 1)]
        self.addresses = [f"10.{self.net}.0.{10 + k}" for k in range(1, n + 1)]
        self._made: list[str] = []
        try:
            self._build()
        except BaseException:
            self.close()
            raise

    def _build(self) -> None:
        sw = self.switch
        _ip("netns", "add", sw)
        self._made.append(sw)
        self._in(sw, "ip", "link", "set", "lo", "up")
        self._in(sw, "ip", "link", "add", "br0", "type", "bridge", "mcast_snooping", "0")
        self._in(sw, "ip", "link", "set", "br0", "up")
        for k, (name, addr) in enumerate(zip(self.names, self.addresses), start=1):
            _ip("netns", "add", name)
            self._made.append(name)
            self._in(name, "sysctl", "-q", "-w", "net.ipv6.conf.all.disable_ipv6=1")
            self._in(sw, "ip", "link", "add", f"p{k}", "type", "veth", "peer", "name", "eth0", "netns", name)
            self._in(sw, "ip", "link", "set", f"p{k}", "master", "br0", "up")
            self._in(name, "ip", "link", "set", "lo", "up")
            self._in(name, "ip", "addr", "add", f"{addr}/24", "dev", "eth0")
            self._in(name, "ip", "link", "set", "eth0", "up")
            self._in(name, "ip", "route", "add", "224.0.0.0/4", "dev", "eth0")

    @staticmethod
    def _in(ns: str, *args: str) -> None:
        _ip("netns", "exec", ns, *args)

    def cmd(self, k: int, argv: list[str]) -> list[str]:
        """``argv`` run in host ``k`` (1-based)."""
        return ["ip", "netns", "exec", self.names[k - 1], *argv]

    def port_bytes(self, k: int) -> dict:
        """Bytes the bridge port of host ``k`` carried: ``to_host`` (bridge -> host) and ``from_host``."""
        out = subprocess.run(["ip", "netns", "exec", self.switch, "cat", f"/sys/class/net/p{k}/statistics/tx_bytes",
                              f"/sys/class/net/p{k}/statistics/rx_bytes"], capture_output=True, text=True,
                             check=True).stdout.split()
        return {"to_host": int(out[0]), "from_host": int(out[1])}

    def igmp_groups(self, k: int) -> list[str]:
        """IPv4 multicast groups joined on host ``k``'s eth0 (the kernel's 224.0.0.1 left out)."""
        import socket
        import struct

        text = subprocess.run(["ip", "netns", "exec", self.names[k - 1], "cat", "/proc/net/igmp"],
                              capture_output=True, text=True, check=True).stdout
        out, current = [], None
        for line in text.splitlines()[1:]:
            if not line.startswith("\t"):
                current = line.split()[1]
                continue
            if current == "eth0":
                g = socket.inet_ntoa(struct.pack("<I", int(line.split()[0], 16)))
                if g != "224.0.0.1":
                    out.append(g)
        return sorted(set(out))

    def close(self) -> None:
        for name in reversed(self._made):
            _remove(name)
        self._made = []
