"""Issue 14, item 3: closed to the network by default; DDS security refused clearly; wrong speed publishers seen.

- Every ROS command (node, speed, echo, record, replay, fleet, discovery-server, demo), run without any discovery
  variable, sends nothing on a non-loopback interface, joins no multicast group there, and binds every socket it
  opens to 127.0.0.1 (issue 25: rmw's LOCALHOST range bound its UDP sockets to 0.0.0.0 and to the veth's
  address, the discovery server to 0.0.0.0:11811 and 0.0.0.0:7411). Measured inside a user + network
  namespace that the test creates (``unshare -rn``) with a veth pair (``tests/integration/netns_census.py``): no packet
  leaves this namespace, and it vanishes with the test. A positive control with the user's own
  ``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`` shows that the census does see discovery traffic (and that the
  user's choice is kept). On main every command but ``demo`` sent SPDP multicast on every interface.
- ``ROS_SECURITY_ENABLE=true``: one line naming it and what the wheels lack, exit 2 (not a dying node, not a
  node silently running without security).
- A publisher of another type on ``speed`` is reported by the node from the graph.
"""

from __future__ import annotations

import json
import random
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from ros_helpers import REPO, Listener, Proc, bkabem_cmd, ros_env, unique_namespace

pytestmark = pytest.mark.ros

CENSUS = Path(__file__).with_name("netns_census.py")
NOTICE = "ROS discovery: LOCALHOST, this host only"


def _census(commands, seconds, extra_env=None, tmp=None):
    tmp = Path(tmp or tempfile.mkdtemp(prefix="bkabem_netns_"))
    env = {"ROS_DOMAIN_ID": str(random.randint(1, 200)), "ROS_LOG_DIR": str(tmp / "log"),
           "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1", "RCUTILS_COLORIZED_OUTPUT": "0"}
    env.update(extra_env or {})
    spec = {"env": env, "cwd": str(REPO), "seconds": seconds,
            "commands": [{"name": n, "argv": [sys.executable, "-m", "bkabem_ros", *a], "stop": a[0] == "node"}
                         for n, a in commands]}
    path = tmp / "spec.json"
    path.write_text(json.dumps(spec))
    p = subprocess.run(["unshare", "-rn", sys.executable, str(CENSUS), str(path)], capture_output=True, text=True,
                       timeout=seconds + 120)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_every_ros_command_stays_on_loopback_by_default(tmp_path):
    rec = tmp_path / "r.mcap"
    commands = [
        ("node", ["node", "--namespace", "/n", "--sample-rate", "5120"]),
        ("speed", ["speed", "--namespace", "/n", "--profile", "constant:20", "--seconds", "9"]),
        ("echo", ["echo", "--namespace", "/n", "--seconds", "9", "vibration/de/acceleration"]),
        ("record", ["record", "--out", str(rec), "--namespace", "/n", "--duration", "9"]),
        ("replay", ["replay", str(REPO / "recordings" / "example_runup.mcap"), "--namespace", "/rp", "--rate", "2"]),
        ("fleet", ["fleet", "--machines", "1", "--seconds", "9", "--prefix", "fm_", "--sample-rate", "5120"]),
        ("discovery-server", ["discovery-server", "--seconds", "12", "--port", "11911"]),
        ("demo", ["demo", "--no-rerun", "--ramp", "2", "--hold", "2", "--sample-rate", "5120", "--speeds", "25",
                  "--out", str(tmp_path / "demo"), "--recordings", str(tmp_path / "rec")]),
    ]
    # long enough for the slowest start to bind its sockets: eight commands starting at once on two cores, in a
    # fresh clone without bytecode, kept the demo from binding within 16 s
    res = _census(commands, seconds=30, tmp=tmp_path)
    out = {r["name"]: r for r in res["results"]}
    for name, r in out.items():
        assert r["rc"] == 0, (name, r["output"][-2000:])
        if name != "discovery-server":
            assert r["output"].count(NOTICE) == 1, (name, r["output"][-2000:])
    # every socket bound to loopback, and the census saw every command's sockets
    wide = [s for s in res["sockets"] if not s[0].startswith(("127.0.0.1:", "[::1]:", "[::ffff:127.0.0.1]:"))]
    assert not wide, f"sockets bound beyond loopback: {wide}"
    owners = {s[2] for s in res["sockets"]}
    assert owners >= {name for name, _ in commands}, (sorted(owners), res["sockets"])
    print(f"{len(res['sockets'])} sockets, all on 127.0.0.1: " + ", ".join(sorted({f'{s[2]}:{s[0]}' for s in
                                                                                  res["sockets"]}))[:3000])
    assert res["tx_packets"] == 0, f"{res['tx_packets']} packets ({res['tx_bytes']} B) left on the veth"
    assert res["groups_v0"] == [], res["groups_v0"]
    # and the graph worked on loopback: echo saw the node's waveforms, record stored them
    assert "/n/vibration/de/acceleration" in out["echo"]["output"], out["echo"]["output"][-2000:]
    assert "recorded 0 messages" not in out["record"]["output"] and rec.exists()


def test_the_users_discovery_choice_is_kept_and_seen(tmp_path):
    """Positive control: with the user's SUBNET the census sees the multicast discovery (inside the namespace)."""
    res = _census([("speed", ["speed", "--profile", "constant:5", "--seconds", "3"])], seconds=5,
                  extra_env={"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}, tmp=tmp_path)
    r = res["results"][0]
    assert r["rc"] == 0 and "ROS discovery: range SUBNET (set in the environment)" in r["output"], r["output"]
    assert res["tx_packets"] > 0 and "239.255.0.1" in res["groups_v0"], res


def test_security_enable_is_refused_with_one_line():
    for args in (["node"], ["speed", "--seconds", "1"], ["echo", "--seconds", "1"], ["record", "--duration", "1"]):
        p = subprocess.run(bkabem_cmd(*args), env=ros_env({"ROS_SECURITY_ENABLE": "true"}), capture_output=True,
                           text=True, timeout=60)
        lines = p.stderr.strip().splitlines()
        assert p.returncode == 2 and len(lines) == 1, (args, p.returncode, p.stderr[-2000:])
        assert "ROS_SECURITY_ENABLE=true" in lines[0] and "security plugins" in lines[0], lines[0]


def test_wrong_type_publisher_on_speed_is_reported():
    from std_msgs.msg import String

    ns = unique_namespace("wrongtype")
    lis = Listener("wrong_type_publisher")
    node = Proc(bkabem_cmd("node", "--namespace", ns, "--sample-rate", "5120"), name="node")
    try:
        node.wait_for(r"streaming from t0", timeout=90)
        pub = lis.publisher(f"{ns}/speed", String)
        pub.publish(String(data="50"))
        m = node.wait_for(r"publisher (\S+) offers type std_msgs/msg/String, not std_msgs/msg/Float64", timeout=40)
        assert m.group(1).endswith("wrong_type_publisher")
        assert node.stop(signal.SIGINT) == 0, node.text[-3000:]
    finally:
        node.kill()
        lis.close()


def test_discovery_defaults_keep_the_users_choice():
    from bkabem_ros import ros_env

    env = {}
    line = ros_env.apply_defaults(env)
    # this host only, bound to loopback: bkabem's Fast DDS profile, which rmw's own LOCALHOST range would undo
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT" and "bkabem's default" in line
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == ros_env.loopback_profile()
    assert 'name="127.0.0.1"' in Path(ros_env.loopback_profile()).read_text()
    assert "bkabem's default" in ros_env.apply_defaults(env)        # a second call (run_demo) still says so
    env = {"FASTDDS_DEFAULT_PROFILES_FILE": "/etc/my_profile.xml"}    # the user's own profile stays theirs
    ros_env.apply_defaults(env)
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == "/etc/my_profile.xml"
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    for name, value in (("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET"), ("ROS_STATIC_PEERS", "10.1.2.3"),
                        ("ROS_DISCOVERY_SERVER", "10.1.2.3:11811")):
        env = {name: value}
        line = ros_env.apply_defaults(env)
        assert env[name] == value                                    # kept as the user set it
        assert "ROS_AUTOMATIC_DISCOVERY_RANGE" not in env or name == "ROS_AUTOMATIC_DISCOVERY_RANGE"
        assert value in line and "set in the environment" in line
    env = {"ROS_LOCALHOST_ONLY": "0"}                                 # deprecated, ignored by Kilted: no choice
    ros_env.apply_defaults(env)
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == ros_env.loopback_profile()
    with pytest.raises(ros_env.SecurityUnavailable, match="security plugins"):
        ros_env.apply_defaults({"ROS_SECURITY_ENABLE": "true"})
