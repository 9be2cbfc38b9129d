"""Issue 15: the plant options of ``bkabem fleet`` and the discovery settings, without starting a fleet.

- the plan of a host's index range (names, seeds, cases, depths follow the plant index; widths agree across hosts);
- bad values of the new options and of the discovery variables: one line naming the option or variable, exit 2
  (rcl / Fast DDS would otherwise fall back to LOCALHOST, drop the server and find nothing, or crash);
- ``bkabem discovery-server`` refuses what it cannot listen on;
- the security finding: the wheels' Fast DDS has no DDS Security plugins (if a later wheel has them, this test
  fails, and the refusal of ``ROS_SECURITY_ENABLE`` should give way to real SROS2 support).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from ros_helpers import bkabem_cmd, ros_env

pytestmark = pytest.mark.ros


def test_plan_follows_the_plant_index():
    from bkabem_ros.fleet.launcher import machine_names, plan

    one = plan(6, ["a", "b", "c"], 10, "m_", [0.0, 1e-5], first=0, width=3)
    host2 = plan(3, ["a", "b", "c"], 10, "m_", [0.0, 1e-5], first=3, width=3)
    assert one[3:] == host2                       # host 2 runs exactly machines 3..5 of the one big fleet
    assert [m["name"] for m in host2] == ["m_003", "m_004", "m_005"]
    assert [m["overrides"]["seed"] for m in host2] == [13, 14, 15]
    assert [m["overrides"]["case"] for m in host2] == ["a", "b", "c"]
    assert [m["overrides"]["defect_depth"] for m in host2] == [1e-5, 0.0, 1e-5]
    assert machine_names(2) == ["machine_00", "machine_01"]          # unchanged default names
    assert machine_names(3, first=98) == ["machine_098", "machine_099", "machine_100"]


@pytest.mark.parametrize("args, needle", [
    (["fleet", "--machines", "2", "--first-index", "-1"], "--first-index"),
    (["fleet", "--machines", "3", "--first-index", "999999"], "--first-index"),
    (["fleet", "--machines", "3", "--first-index", "8", "--index-width", "1"], "--index-width"),
    (["fleet", "--machines", "1", "--executor", "threads"], "--executor"),
    (["fleet", "--machines", "1", "--discovery-range", "subnet1"], "--discovery-range"),
    (["fleet", "--machines", "1", "--discovery-server", "10.0.0.300:11811"], "--discovery-server"),
    (["fleet", "--machines", "1", "--discovery-server", "10.0.0.1:99999"], "--discovery-server"),
    (["fleet", "--machines", "1", "--discovery-server", "UDPv6:::1"], "--discovery-server"),
    (["fleet", "--machines", "1", "--static-peers", ";"], "--static-peers"),
    (["echo", "--seconds", "1", "--super-client"], "--super-client"),
    (["discovery-server", "--listen", "10.0.0.300"], "--listen"),
    (["discovery-server", "--listen", "192.0.2.7"], "--listen"),          # TEST-NET-1: not an address of this host
    (["discovery-server", "--port", "0"], "--port"),
])
def test_bad_plant_options_give_one_line_and_exit_2(args, needle):
    p = subprocess.run(bkabem_cmd(*args), env=ros_env(), capture_output=True, text=True, timeout=60)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, (args, p.returncode, p.stderr[-2000:])
    assert needle in lines[0], lines[0]


@pytest.mark.parametrize("var, value", [
    ("ROS_AUTOMATIC_DISCOVERY_RANGE", "subnet"),           # rcl: "Invalid value ... assuming localhost only"
    ("ROS_DISCOVERY_SERVER", "10.0.0.300:11811"),          # Fast DDS: logs, drops it, runs without a server
    ("ROS_DISCOVERY_SERVER", "not:an:addr:xx"),
    ("ROS_STATIC_PEERS", "foo..bar"),                      # rmw: "Unable to resolve peer" -> node creation fails
    ("ROS_SUPER_CLIENT", "yes"),
])
def test_bad_discovery_variables_give_one_line_and_exit_2(var, value):
    env = ros_env({var: value})
    if var != "ROS_AUTOMATIC_DISCOVERY_RANGE":
        env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE")
    p = subprocess.run(bkabem_cmd("speed", "--seconds", "1"), env=env, capture_output=True, text=True, timeout=60)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, (var, value, p.returncode, p.stderr[-2000:])
    assert lines[0].startswith(f"bkabem speed: error: {var}: "), lines[0]


def test_discovery_values_fast_dds_accepts_pass():
    from bkabem_ros import ros_env as re_

    for server in ("10.0.0.1", "10.0.0.1:11811", "[::1]:11811", "UDPv4:10.0.0.1:11811", "TCPv4:10.0.0.1:42100",
                   "UDPv6:[fe80::1]:11811", ";10.0.0.2:11811", "localhost:11812"):
        re_.check_discovery({"ROS_DISCOVERY_SERVER": server})
    for rng in re_.DISCOVERY_RANGES:
        re_.check_discovery({"ROS_AUTOMATIC_DISCOVERY_RANGE": rng})
    re_.check_discovery({"ROS_STATIC_PEERS": "10.0.0.1;localhost;fe80::1"})
    env = {}

    class Args:
        discovery_range, static_peers, discovery_server, super_client = "SUBNET", "10.0.0.1,10.0.0.2", None, False

    re_.apply_discovery_options(Args(), env)
    assert env == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "ROS_STATIC_PEERS": "10.0.0.1;10.0.0.2"}


def test_discovery_options_are_on_every_ros_command_only():
    from bkabem_ros.cli.main import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name, sp in sub.choices.items():
        has = any(a.dest == "discovery_server" for a in sp._actions)
        assert has == bool(sp.get_default("ros_network")), name
    assert not any(a.dest == "discovery_server" for a in sub.choices["excitation"]._actions)
    assert any(a.dest == "discovery_server" for a in sub.choices["fleet"]._actions)


def test_the_wheels_fast_dds_has_no_security_plugins():
    lib = Path(sys.prefix) / "lib" / "libfastdds.so"
    data = lib.read_bytes()
    for plugin in (b"builtin.PKI-DH", b"builtin.Access-Permissions", b"builtin.AES-GCM-GMAC"):
        assert plugin not in data, f"{lib} now has {plugin!r}: DDS Security may be possible, revisit ros_env"
    assert b"process_data_message_without_security" in data     # the build's HAVE_SECURITY=0 receive path
