"""The ROS 2 environment of every bkabem ROS command: closed to the network unless the user opens it.

:func:`apply_defaults` runs before ``rclpy.init`` (the command line calls it for ``node``, ``fleet``,
``speed``, ``echo``, ``record``, ``replay`` when it publishes, and ``demo``):

- **Discovery.** Unless the user set one of :data:`DISCOVERY_VARIABLES` (``ROS_AUTOMATIC_DISCOVERY_RANGE``,
  ``ROS_STATIC_PEERS``, ``ROS_DISCOVERY_SERVER``) to a non-empty value, the graph stays on this host, bound to
  loopback: ``FASTDDS_DEFAULT_PROFILES_FILE`` points at ``bkabem_ros/fastdds_loopback.xml`` (UDP on 127.0.0.1
  only, shared memory, discovery by unicast to this host's participants, no multicast) and
  ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is ``SYSTEM_DEFAULT`` so that rmw_fastrtps leaves the transports to that
  profile. (rmw's own ``LOCALHOST`` range sends to loopback only but binds its UDP sockets to ``0.0.0.0`` and
  every interface address, where the plant network can reach them.) Nobody on the plant network can publish on
  ``speed`` or even reach a socket. A user's own ``FASTDDS_DEFAULT_PROFILES_FILE`` is kept: then the default is
  rmw's ``LOCALHOST`` range. Whatever the user set
  is kept unchanged (multi-host set-ups are built on exactly these variables). ``ROS_LOCALHOST_ONLY`` is
  deprecated and ignored by Kilted's rmw; it does not count as a choice. :func:`announce`, called by each
  command right before ``rclpy.init`` (not before its arguments are checked: bad input stays one line), says
  on stderr which range is in force, once per process tree (child processes inherit the marker).
- **Security.** ``ROS_SECURITY_ENABLE=true`` is refused with a clear message: the Fast DDS 3.2 of the ROS 2
  Kilted PyPI wheels is built without its DDS Security plugins (no ``builtin.PKI-DH`` authentication,
  ``builtin.Access-Permissions`` access control or ``builtin.AES-GCM-GMAC`` cryptography in ``libfastdds.so``;
  rmw_fastrtps then fails to create any node: "This Fast DDS version doesn't have the security libraries.
  Please compile Fast DDS using the -DSECURITY=ON CMake option"; with the Permissive strategy and no keystore
  rcl would instead run without security, silently). docs/ros_node.md has the details.
- **Checked values.** The discovery variables are checked before rcl sees them (:func:`check_discovery`): rcl
  and Fast DDS take a wrong ``ROS_AUTOMATIC_DISCOVERY_RANGE`` for LOCALHOST with a warning, drop a malformed
  ``ROS_DISCOVERY_SERVER`` locator with a log line and run without the server (nothing discovered, exit 0),
  and fail node creation on an unresolvable ``ROS_STATIC_PEERS`` host; here each is one line naming the
  variable (or the option that set it) and exit code 2.
- **Options.** :func:`add_discovery_options` gives a command ``--discovery-range``, ``--static-peers``,
  ``--discovery-server`` and ``--super-client``; :func:`apply_discovery_options` turns them into the standard
  variables (so worker processes inherit them) before :func:`apply_defaults`. An option is an explicit choice
  like the variable it sets; without one the graph stays on this host.

stdlib only: importing this costs nothing.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import MutableMapping

DISCOVERY_VARIABLES = ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS", "ROS_DISCOVERY_SERVER")
#: Values rmw accepts for ROS_AUTOMATIC_DISCOVERY_RANGE (rcl's discovery_options).
DISCOVERY_RANGES = ("OFF", "LOCALHOST", "SUBNET", "SYSTEM_DEFAULT")
#: Default port of a Fast DDS discovery server (``fastdds discovery``); the one a locator without port gets.
DISCOVERY_SERVER_PORT = 11811
DEFAULT_RANGE = "LOCALHOST"
_NOTED = "_BKABEM_DISCOVERY_NOTED"
_DEFAULTED = "_BKABEM_DISCOVERY_DEFAULTED"          # the range bkabem set (a second call, a child process)
PROFILES_VARIABLE = "FASTDDS_DEFAULT_PROFILES_FILE"


def loopback_profile() -> str:
    """Path of the Fast DDS profile that binds every socket to 127.0.0.1 (``bkabem_ros/fastdds_loopback.xml``)."""
    from importlib import resources

    return str(resources.files("bkabem_ros").joinpath("fastdds_loopback.xml"))


def _drop_our_default(env: MutableMapping[str, str]) -> None:
    """The user chose a discovery setting after bkabem set its default: take bkabem's range and profile back."""
    ours = env.pop(_DEFAULTED, None)
    if ours and env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == ours:
        env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)
    if ours and env.get(PROFILES_VARIABLE) == loopback_profile():
        env.pop(PROFILES_VARIABLE, None)

SECURITY_MESSAGE = (
    "ROS_SECURITY_ENABLE=true: the Fast DDS of these ROS 2 wheels is built without the security plugins "
    "(no PKI-DH authentication, access control or AES-GCM-GMAC encryption), so no secure node can be created; "
    "unset it (bkabem keeps discovery on this host by default) or use a ROS 2 install with Fast DDS built "
    "with -DSECURITY=ON (docs/ros_node.md)")


class SecurityUnavailable(ValueError):
    """``ROS_SECURITY_ENABLE=true`` was asked for and cannot be honoured."""


class DiscoverySettingError(ValueError):
    """A discovery variable or option that rcl / Fast DDS would misread, drop or fail on later."""


class RosArgumentsError(ValueError):
    """rcl refused the ROS arguments (``--ros-args``, ``--params-file``) or a name (namespace, node, topic)."""


def init(args: list[str], context=None, *, announce_now: bool = True) -> None:
    """:func:`announce`, then ``rclpy.init(args=args, context=context)``; rcl's refusal of the arguments (a garbage
    ``--params-file``, a bad remap) becomes one :class:`RosArgumentsError` line instead of a traceback.
    ``announce_now=False``: the caller announces once its own checks passed (a node whose parameters are refused
    says only why)."""
    import rclpy

    if announce_now:
        announce()
    try:
        rclpy.init(args=args, context=context)
    except Exception as exc:  # noqa: BLE001 - rclpy's RCLError lives in its private extension module
        if type(exc).__name__ != "RCLError":
            raise
        text = str(exc).split(", at /")[0].replace("failed to initialize rcl: ", "")
        raise RosArgumentsError(f"--ros-args / --params-file: {text}") from None


@contextlib.contextmanager
def until_stopped(context=None, *, interrupt: bool = False):
    """Run a spin loop inside this; a stop asked for (Ctrl-C, SIGTERM, an external shutdown) ends it quietly.

    rclpy's SIGINT handler shuts the context down before Python raises KeyboardInterrupt in the main thread; in that
    moment whatever the executor is doing fails with an error of its own ("publisher's context is invalid", "failed to
    initialize wait set", pybind11's "Unable to convert call argument"). An error raised while the context is no
    longer valid is therefore the stop, not a failure; with the context still valid it is real and propagates.

    Parameters
    ----------
    context : rclpy.context.Context, optional
        The context the loop spins in (default: the global one).
    interrupt : bool
        False: the stop ends the block and the caller goes on (a node or a recorder that finishes its files).
        True: the stop surfaces as KeyboardInterrupt, whatever form it took (a command whose interrupted run must
        not look like a finished one).
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException

    try:
        yield
    except KeyboardInterrupt:
        if interrupt:
            raise
    except ExternalShutdownException:
        if interrupt:
            raise KeyboardInterrupt from None
    except Exception:
        if rclpy.ok(context=context):
            raise
        if interrupt:
            raise KeyboardInterrupt from None


def params_file_problem(path: str) -> str | None:
    """Why ``path`` is not a ROS 2 parameter file (YAML: ``<node or /**>: {ros__parameters: {...}}``), or None.
    Checked before rcl reads it, so that a garbage file gives one line (rcl also logs its own error line)."""
    import yaml

    try:
        with open(path, "rb") as fh:
            data = yaml.safe_load(fh)
    except OSError as exc:
        return exc.strerror or str(exc)
    except (yaml.YAMLError, UnicodeDecodeError, ValueError) as exc:
        return "not valid YAML (" + " ".join(str(exc).split())[:160] + ")"

    def has_parameters(node, depth=0) -> bool:
        if not isinstance(node, dict) or depth > 8:
            return False
        if isinstance(node.get("ros__parameters"), dict):
            return True
        return any(has_parameters(v, depth + 1) for v in node.values())

    if not has_parameters(data):
        return "no '<node name or /**>: ros__parameters: {...}' table in it"
    return None


def name_problem(kind: str, value: str) -> str | None:
    """Why ``value`` is not a valid ROS ``kind`` ("namespace", "node name", "topic"), or None (rcl's own rules)."""
    from rclpy.validate_namespace import validate_namespace
    from rclpy.validate_node_name import validate_node_name
    from rclpy.validate_topic_name import validate_topic_name

    check = {"namespace": validate_namespace, "node name": validate_node_name, "topic": validate_topic_name}[kind]
    try:
        check(value if kind != "namespace" or value.startswith("/") else "/" + value)
    except Exception as exc:  # noqa: BLE001 - rclpy's Invalid*Exception
        return str(exc).splitlines()[0].split(": ", 1)[-1].rstrip(":")
    return None


def check_names(pairs) -> None:
    """``[(option, kind, value), ...]`` -> :class:`RosArgumentsError` naming the first invalid one."""
    for option, kind, value in pairs:
        if value is None or (kind == "namespace" and value in ("", "/")):
            continue
        why = name_problem(kind, value)
        if why:
            raise RosArgumentsError(f"{option}: {value!r} is not a valid ROS {kind}: {why}")


def _set(environ: MutableMapping[str, str], name: str) -> str | None:
    v = environ.get(name, "").strip()
    return v or None


def discovery_in_force(environ: MutableMapping[str, str] | None = None) -> str:
    """One line: the discovery range and peers this process will use, and where they come from."""
    env = os.environ if environ is None else environ
    parts = []
    rng = _set(env, "ROS_AUTOMATIC_DISCOVERY_RANGE")
    if rng is not None:
        parts.append(f"range {rng}")
    peers = _set(env, "ROS_STATIC_PEERS")
    if peers is not None:
        parts.append(f"static peers {peers}")
    server = _set(env, "ROS_DISCOVERY_SERVER")
    if server is not None:
        parts.append(f"discovery server {server}")
    return ", ".join(parts) if parts else "Fast DDS defaults (every interface)"


def _host_problem(host: str) -> str | None:
    """Why ``host`` is not an IPv4 address, a bracket-free IPv6 address or a resolvable host name, or None."""
    import ipaddress
    import re
    import socket

    if not host:
        return "empty address"
    if re.fullmatch(r"[0-9.]+", host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            return f"{host!r} is not an IPv4 address"
        return None
    if ":" in host:
        try:
            ipaddress.IPv6Address(host)
        except ValueError:
            return f"{host!r} is not an IPv6 address"
        return None
    label = r"(?!-)[A-Za-z0-9-]{1,63}(?<!-)"
    if len(host) > 253 or not re.fullmatch(rf"{label}(\.{label})*\.?", host):
        return f"{host!r} is not an address or host name"
    try:
        socket.getaddrinfo(host, None)
    except (OSError, UnicodeError):
        return f"host name {host!r} does not resolve"
    return None


def server_locator_problem(entry: str) -> str | None:
    """Why one ``ROS_DISCOVERY_SERVER`` entry (``[UDPv4:|UDPv6:|TCPv4:|TCPv6:]host[:port]``, IPv6 in brackets:
    ``[::1]:11811``) is wrong, or None (Fast DDS's own syntax, its default port 11811)."""
    import re

    text = entry.strip()
    m = re.fullmatch(r"(?:(UDPv4|UDPv6|TCPv4|TCPv6):)?(\[[^\]]*\]|[^:\[\]]*)(?::([^:]*))?", text)
    if m is None:
        return f"{entry!r} is not host[:port] (IPv6: [addr]:port)"
    kind, host, port = m.groups()
    if host.startswith("["):
        host = host[1:-1]
        if ":" not in host:
            return f"{entry!r}: brackets are for IPv6 addresses"
    elif kind and kind.endswith("v6"):
        return f"{entry!r}: an IPv6 address goes in brackets, [addr]:port"
    why = _host_problem(host)
    if why:
        return f"{entry!r}: {why}"
    if port is not None:
        if not port.isdigit() or not 0 < int(port) < 65536:
            return f"{entry!r}: port {port!r} is not in 1..65535"
    return None


def check_discovery(environ: MutableMapping[str, str] | None = None, names: dict | None = None) -> None:
    """Raise :class:`DiscoverySettingError` for a discovery variable that rcl / Fast DDS would misread (see the
    module docstring). ``names`` maps a variable to the option that set it (the message names that option)."""
    env = os.environ if environ is None else environ
    names = names or {}

    def fail(var, why):
        raise DiscoverySettingError(f"{names.get(var, var)}: {why}")

    rng = _set(env, "ROS_AUTOMATIC_DISCOVERY_RANGE")
    if rng is not None and rng not in DISCOVERY_RANGES:
        fail("ROS_AUTOMATIC_DISCOVERY_RANGE", f"{rng!r} is not one of {', '.join(DISCOVERY_RANGES)} (rcl would "
                                              f"fall back to LOCALHOST with a warning)")
    peers = _set(env, "ROS_STATIC_PEERS")
    if peers is not None:
        for p in (x.strip() for x in peers.split(";")):
            why = _host_problem(p[1:-1] if p.startswith("[") and p.endswith("]") else p) if p else None
            if why:
                fail("ROS_STATIC_PEERS", why)
    server = _set(env, "ROS_DISCOVERY_SERVER")
    if server is not None:
        entries = [e for e in server.split(";") if e.strip()]
        if not entries:
            fail("ROS_DISCOVERY_SERVER", f"{server!r} names no server (host[:port];...)")
        for e in entries:
            why = server_locator_problem(e)
            if why:
                fail("ROS_DISCOVERY_SERVER", why + " (Fast DDS would drop it and run without the server)")
    sc = env.get("ROS_SUPER_CLIENT", "").strip()
    if sc and sc not in ("TRUE", "true", "True", "1", "FALSE", "false", "False", "0"):
        fail("ROS_SUPER_CLIENT", f"{sc!r} is not TRUE or FALSE")


_OPTION_OF = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "--discovery-range", "ROS_STATIC_PEERS": "--static-peers",
              "ROS_DISCOVERY_SERVER": "--discovery-server", "ROS_SUPER_CLIENT": "--super-client"}


def add_discovery_options(p) -> None:
    """``--discovery-range``, ``--static-peers``, ``--discovery-server``, ``--super-client`` on a ROS command's
    parser (main.build_parser adds them to every command that joins the graph)."""
    g = p.add_argument_group("discovery (default: this host only; docs/fleet.md)")
    g.add_argument("--discovery-range", default=None, metavar="RANGE", type=str.upper,
                   help="sets ROS_AUTOMATIC_DISCOVERY_RANGE: LOCALHOST, SUBNET (multicast on the subnet), "
                        "SYSTEM_DEFAULT or OFF")
    g.add_argument("--static-peers", default=None, metavar="HOST[;HOST...]",
                   help="sets ROS_STATIC_PEERS: hosts to discover by unicast (with --discovery-range LOCALHOST: "
                        "only these)")
    g.add_argument("--discovery-server", default=None, metavar="HOST[:PORT][;...]",
                   help=f"sets ROS_DISCOVERY_SERVER: Fast DDS discovery server(s) (bkabem discovery-server; "
                        f"port {DISCOVERY_SERVER_PORT} when left out)")
    g.add_argument("--super-client", action="store_true", default=False,
                   help="sets ROS_SUPER_CLIENT=TRUE: with a discovery server, learn the whole graph (monitors, "
                        "tools listing topics), not only the matching endpoints")


def apply_discovery_options(args, environ: MutableMapping[str, str] | None = None) -> None:
    """Set the variables of :func:`add_discovery_options`'s options that were given, then check all of them."""
    env = os.environ if environ is None else environ
    given = {}
    rng = getattr(args, "discovery_range", None)
    if rng is not None:
        given["ROS_AUTOMATIC_DISCOVERY_RANGE"] = rng
    peers = getattr(args, "static_peers", None)
    if peers is not None:
        given["ROS_STATIC_PEERS"] = ";".join(x.strip() for x in peers.replace(",", ";").split(";"))
        if not given["ROS_STATIC_PEERS"].strip(";"):
            raise DiscoverySettingError(f"--static-peers: {peers!r} names no host")
    server = getattr(args, "discovery_server", None)
    if server is not None:
        given["ROS_DISCOVERY_SERVER"] = server.strip()
    if getattr(args, "super_client", False):
        given["ROS_SUPER_CLIENT"] = "TRUE"
        if "ROS_DISCOVERY_SERVER" not in given and _set(env, "ROS_DISCOVERY_SERVER") is None:
            raise DiscoverySettingError("--super-client: needs --discovery-server (or ROS_DISCOVERY_SERVER)")
    probe = dict(env)
    probe.update(given)
    check_discovery(probe, {k: _OPTION_OF[k] for k in given})
    if any(k in given for k in DISCOVERY_VARIABLES):
        _drop_our_default(env)           # the user's setting now, not bkabem's default
    env.update(given)


_pending: dict = {}


def announce() -> None:
    """Write the line of :func:`apply_defaults` (if it was given ``say``), once per process tree."""
    say, line = _pending.pop("say", None), _pending.pop("line", None)
    env = os.environ
    if say is not None and line and not env.get(_NOTED):
        say(line)
    env[_NOTED] = "1"


def apply_defaults(environ: MutableMapping[str, str] | None = None, *, say=None) -> str:
    """Set loopback-only discovery unless the user chose, refuse DDS security (see the module docstring).

    Returns the line that describes what is in force; :func:`announce` later passes it to ``say`` (once per
    process tree). Raises :class:`SecurityUnavailable` for ``ROS_SECURITY_ENABLE=true``.
    """
    env = os.environ if environ is None else environ
    if env.get("ROS_SECURITY_ENABLE", "").strip().lower() == "true":
        raise SecurityUnavailable(SECURITY_MESSAGE)
    check_discovery(env)
    ours = bool(env.get(_DEFAULTED)) and env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == env.get(_DEFAULTED)
    chosen = [name for name in DISCOVERY_VARIABLES if _set(env, name) is not None
              and not (ours and name == "ROS_AUTOMATIC_DISCOVERY_RANGE")]
    if chosen:
        line = f"ROS discovery: {discovery_in_force(env)} (set in the environment)"
    else:
        own_profile = _set(env, PROFILES_VARIABLE) not in (None, loopback_profile())
        if own_profile:                 # the user's Fast DDS profile: rmw's LOCALHOST range on top of it
            env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = DEFAULT_RANGE
            how = f"rmw's LOCALHOST range with your {PROFILES_VARIABLE}"
        else:
            env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
            env[PROFILES_VARIABLE] = loopback_profile()
            how = "sockets bound to 127.0.0.1"
        env[_DEFAULTED] = env["ROS_AUTOMATIC_DISCOVERY_RANGE"]     # set by bkabem, not by the user
        line = (f"ROS discovery: LOCALHOST, this host only (bkabem's default, {how}; to reach other hosts set "
                "ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET, ROS_STATIC_PEERS or ROS_DISCOVERY_SERVER: docs/ros_node.md)")
    _pending["line"] = line
    if say is not None:                 # a library call (run_demo) keeps the command line's writer
        _pending["say"] = say
    return line
