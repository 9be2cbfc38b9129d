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
(``0.0.0.0``: every interface), and every socket of the server is bound to that address (a Fast DDS profile,
:func:`server_profile`, with an interfaces allowlist: the tool alone binds its ports on ``0.0.0.0`` whatever
``-l`` says). SIGINT/SIGTERM or ``--seconds`` stop it. docs/fleet.md has the set-ups.
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


def server_profile(address: str, port: int) -> str:
    """A Fast DDS XML profile for ``fastdds discovery -x``: a discovery server on UDPv4 ``address:port``.

    Loopback (the default): the transport is allowed that interface only, so every socket is bound to 127.0.0.1.
    Another address: the discovery and data locators (what clients are told) are on that address, but Fast DDS
    binds the sockets on every interface: an interfaces allowlist of a non-loopback address stops the server from
    answering clients on other hosts (measured with Fast DDS 3.2, by address and by interface name), so it is not
    used there. ``0.0.0.0``: every interface."""
    import ipaddress

    loopback = ipaddress.IPv4Address(address).is_loopback
    allow = (f'<interfaces><allowlist><interface name="{address}" netmask_filter="OFF"/></allowlist></interfaces>'
             if loopback else "")
    data = ("" if address == "0.0.0.0" else
            f"<defaultUnicastLocatorList><locator><udpv4><address>{address}</address></udpv4></locator>"
            f"</defaultUnicastLocatorList>")
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>bkabem_discovery_udp</transport_id>
        <type>UDPv4</type>
        {allow}
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="bkabem_discovery_server" is_default_profile="true">
      <rtps>
        {data}
        <builtin>
          <discovery_config><discoveryProtocol>SERVER</discoveryProtocol></discovery_config>
          <metatrafficUnicastLocatorList>
            <locator><udpv4><address>{address}</address><port>{port}</port></udpv4></locator>
          </metatrafficUnicastLocatorList>
        </builtin>
        <userTransports><transport_id>bkabem_discovery_udp</transport_id></userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
      </rtps>
    </participant>
  </profiles>
</dds>
"""


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
    import tempfile

    profile_dir = tempfile.TemporaryDirectory(prefix="bkabem_discovery_")
    profile = Path(profile_dir.name) / "server.xml"
    profile.write_text(server_profile(args.listen, args.port))
    cmd = [sys.executable, str(tool), "discovery", "-l", args.listen, "-p", str(args.port), "-x", str(profile)]
    env = {k: v for k, v in os.environ.items() if k != "FASTDDS_DEFAULT_PROFILES_FILE"}    # the server's own
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
                            start_new_session=True, env=env)
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
                bound = "" if ipaddress.IPv4Address(args.listen).is_loopback or args.listen == "0.0.0.0" else \
                    " (Fast DDS binds the server's sockets on every interface of this host)"
                sys.stderr.write(f"bkabem discovery-server: listening on UDPv4 {where}{bound}; clients: "
                                 f"--discovery-server "
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
        profile_dir.cleanup()
    if not running:
        import re

        plain = [re.sub(r"\x1b\[[0-9;]*m", "", ln).strip() for ln in lines]
        tail = " / ".join(ln for ln in plain[-3:] if ln) or f"exit code {rc}"
        raise UsageError(f"--listen/--port: the discovery server did not start on {where}: {tail}")
    return 0
