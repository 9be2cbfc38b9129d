"""``bkabem discovery-server``: the Fast DDS discovery server of the ``ros-fastdds`` wheel, started for a fleet.

    bkabem discovery-server [--listen 127.0.0.1] [--port 11811] [--seconds S]

Runs eProsima's ``fastdds discovery`` tool (``<venv>/tools/fastdds/fastdds.py``, which starts the
``fast-discovery-server`` binary of the wheel) with ``-l ADDRESS -p PORT``, in the foreground, and prints the
setting its clients need (``--discovery-server ADDRESS:PORT`` or ``ROS_DISCOVERY_SERVER=ADDRESS:PORT``; a
monitor or a tool that lists the graph adds ``--super-client`` / ``ROS_SUPER_CLIENT=TRUE``). With a discovery
server each participant exchanges discovery data with the server only, and the server forwards to a client only
the endpoints that match its own (Fast DDS discovery server v2), instead of every participant announcing every
endpoint to every other one by multicast. The server's ``ROS_DOMAIN_ID`` does not matter; clients of different
domains still only see their own domain.

Closed by default: the server listens on loopback unless ``--listen`` names an address of a plant network
(``0.0.0.0``: every interface). SIGINT/SIGTERM or ``--seconds`` stop it. docs/fleet.md has the set-ups.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path


def tool_path() -> Path:
    """The ``fastdds`` CLI script of the ros-fastdds wheel in this environment."""
    return Path(sys.prefix) / "tools" / "fastdds" / "fastdds.py"


def add_parser(sub, add_case=None):
    """Register ``bkabem discovery-server``."""
    from bkabem_ros.cli.base import finite_float, pos_int
    from bkabem_ros.ros_env import DISCOVERY_SERVER_PORT

    p = sub.add_parser("discovery-server", help="run a Fast DDS discovery server for fleets across hosts",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--listen", default="127.0.0.1", metavar="ADDRESS",
                   help="IPv4 address to listen on (default 127.0.0.1: this host only; 0.0.0.0: every interface)")
    p.add_argument("--port", type=pos_int("--port", 1, 65535), default=DISCOVERY_SERVER_PORT,
                   help=f"UDP port (default {DISCOVERY_SERVER_PORT}, Fast DDS's)")
    p.add_argument("--seconds", type=finite_float("--seconds", 0.0, strict=True), default=None,
                   help="stop after this long (default: until SIGINT/SIGTERM)")
    p.set_defaults(func=main)
    return p


def main(args) -> int:
    import ipaddress

    from bkabem_ros.cli.base import UsageError

    try:
        ipaddress.IPv4Address(args.listen)
    except ValueError:
        raise UsageError(f"--listen: {args.listen!r} is not an IPv4 address (the server listens on UDPv4)") from None
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((args.listen, 0))
        except OSError as exc:
            raise UsageError(f"--listen: {args.listen} is not an address of this host ({exc.strerror})") from None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((args.listen, args.port))
        except OSError as exc:
            raise UsageError(f"--port: UDP {args.listen}:{args.port}: {exc.strerror} (another server?)") from None
    tool = tool_path()
    if not tool.is_file():
        raise UsageError(f"the Fast DDS discovery tool is not installed here ({tool} is missing: make install)")
    cmd = [sys.executable, str(tool), "discovery", "-l", args.listen, "-p", str(args.port)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
                            start_new_session=True)
    where = f"{args.listen}:{args.port}"
    client = "127.0.0.1" if args.listen == "0.0.0.0" else args.listen
    lines = []
    running = False

    def stop(signum, _frame):
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)

    old = {s: signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)}
    timer = None
    try:
        if args.seconds is not None:
            import threading

            timer = threading.Timer(args.seconds, stop, (signal.SIGINT, None))
            timer.daemon = True
            timer.start()
        for line in proc.stdout:
            lines.append(line.rstrip())
            if not running and "Server started" in line:
                running = True
            if running and "Running on" in line:
                sys.stderr.write(f"bkabem discovery-server: listening on UDPv4 {where}; clients: --discovery-server "
                                 f"{client}:{args.port} (ROS_DISCOVERY_SERVER={client}:{args.port}), monitors "
                                 f"and graph tools also --super-client\n")
                sys.stderr.flush()
        rc = proc.wait()
    finally:
        if timer is not None:
            timer.cancel()
        for s, h in old.items():
            signal.signal(s, h)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    if not running:
        import re

        plain = [re.sub(r"\x1b\[[0-9;]*m", "", ln).strip() for ln in lines]
        tail = " / ".join(ln for ln in plain[-3:] if ln) or f"exit code {rc}"
        raise UsageError(f"--listen/--port: the discovery server did not start on {where}: {tail}")
    return 0
