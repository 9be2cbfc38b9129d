"""``bkabem fleet``: N namespaced machines in two processes, each with its own id, seed and defect depth;
plus a check that docs/ros_node.md documents every node parameter. Real processes on loopback DDS."""

from __future__ import annotations

import json
import math
import random
import signal
import time

import pytest
import rclpy  # noqa: F401  (fail, do not skip, when ROS is missing)
from ros_helpers import REPO, Listener, Proc, bkabem_cmd

pytestmark = [pytest.mark.ros, pytest.mark.serial]   # measures time: run alone

DEPTHS = [0.0, 2e-5, 5e-5]


def test_fleet_three_machines_two_processes():
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationWaveform
    from std_msgs.msg import Float64

    prefix = f"fleet{random.SystemRandom().randrange(1 << 24):x}_"
    names = [f"{prefix}{i:02d}" for i in range(3)]
    lis = Listener("fleet_listener")
    fleet = None
    try:
        for n in names:
            lis.subscribe(f"/{n}/vibration/de/acceleration", VibrationWaveform)
            lis.subscribe(f"/{n}/vibration/fault_frequencies", BearingFaultFrequencies)
        fleet = Proc(bkabem_cmd("fleet", "--machines", "3", "--processes", "2", "--prefix", prefix,
                                "--defect-depths", ",".join(map(str, DEPTHS)), "--seed", "7",
                                "--chunk-duration", "0.05", "--sample-rate", "12800"), name="fleet")
        for n in names:
            lis.wait_for(f"/{n}/vibration/de/acceleration", lambda it: len(it) >= 5, timeout=60)
        # each machine has its own speed input
        pub = lis.publisher(f"/{names[1]}/speed", Float64)
        lis.wait_subscribers(pub)
        lis.publish_until(pub, Float64(data=2 * math.pi * 20.0), f"/{names[1]}/vibration/de/acceleration",
                          lambda it: math.isclose(it[-1][1].shaft_speed, 2 * math.pi * 20.0), timeout=10)
        time.sleep(0.3)
        assert lis.get(f"/{names[0]}/vibration/de/acceleration")[-1][1].shaft_speed == 0.0
        for n, depth in zip(names, DEPTHS):
            m = lis.get(f"/{n}/vibration/de/acceleration")[-1][1]
            assert m.machine_id == n and m.sample_rate == 12800.0
            # (published with the first chunk and then at spectrum_rate, 1 Hz: a first one sent before this
            # best-effort subscription matched is lost, the next one comes within a second)
            ff = lis.wait_for(f"/{n}/vibration/fault_frequencies", timeout=30)[-1][1]
            assert ff.machine_id == n and math.isclose(ff.defect_depth, depth, abs_tol=1e-12)
        assert fleet.stop(signal.SIGINT) == 0, fleet.text[-3000:]
        stats = [json.loads(ln.split(" ", 1)[1]) for ln in fleet.lines if ln.startswith("FLEETSTATS ")]
        assert stats == []        # statistics lines only with --seconds
        assert "Traceback" not in fleet.text, fleet.text[-3000:]
        for n in names:
            assert f"/{n}/bkabem ({n}) shutting down" in fleet.text
    finally:
        if fleet is not None:
            fleet.kill()
        lis.close()


def test_fleet_of_mixed_machines():
    """Two machines of two cases with different bearings and rotors (the fault library's motor on 6010s, the small
    motor on 6205s, a compact case): each publishes its own bearings, fault frequencies and ground truth."""
    from bkabem_msgs.msg import BearingFaultFrequencies, VibrationWaveform
    from std_msgs.msg import Float64

    from bkabem_core.model.case import Case

    cases = ["motor_6010_outer", "small_motor_6205_outer"]
    prefix = f"mixed{random.SystemRandom().randrange(1 << 24):x}_"
    names = [f"{prefix}{i:02d}" for i in range(2)]
    lis = Listener("mixed_fleet_listener")
    fleet = None
    try:
        for n in names:
            lis.subscribe(f"/{n}/vibration/de/acceleration", VibrationWaveform)
            lis.subscribe(f"/{n}/vibration/fault_frequencies", BearingFaultFrequencies)
        fleet = Proc(bkabem_cmd("fleet", "--machines", "2", "--processes", "2", "--prefix", prefix,
                                *[a for c in cases for a in ("--case", c)], "--chunk-duration", "0.05",
                                "--sample-rate", "12800"), name="mixed fleet")
        for n, case_name in zip(names, cases):
            case = Case.load(case_name)
            g = case.bearing_geometry("de")
            bpfo = g.n_balls / 2.0 * (1.0 - g.ball_diameter_m / g.pitch_diameter_m)        # textbook, angle 0
            lis.wait_for(f"/{n}/vibration/de/acceleration", lambda it: len(it) >= 3, timeout=90)
            pub = lis.publisher(f"/{n}/speed", Float64)
            lis.wait_subscribers(pub)
            lis.publish_until(pub, Float64(data=2 * math.pi * 20.0), f"/{n}/vibration/fault_frequencies",
                              lambda it: it and math.isclose(it[-1][1].shaft_speed, 2 * math.pi * 20.0), timeout=30)
            ff = lis.get(f"/{n}/vibration/fault_frequencies")[-1][1]
            assert ff.machine_id == n and ff.bearing_designation == g.designation
            assert math.isclose(ff.bpfo, 20.0 * bpfo, rel_tol=1e-9), (ff.bpfo, 20.0 * bpfo)
            assert {b.bearing: b.designation for b in ff.bearings} == {"de": g.designation, "nde": g.designation}
            gt = lis.get(f"/{n}/vibration/de/acceleration")[-1][1].ground_truth
            assert (gt.case_name, gt.case_hash) == (case.name, case.case_hash)
            d = gt.defects[0]
            assert (d.kind, d.bearing_designation) == ("outer", g.designation)
            assert math.isclose(d.depth, case.defects("de")[0].depth_m) and math.isclose(d.fault_multiplier, bpfo)
        assert fleet.stop(signal.SIGINT) == 0, fleet.text[-3000:]
        assert "Traceback" not in fleet.text, fleet.text[-3000:]
    finally:
        if fleet is not None:
            try:
                fleet.stop(signal.SIGINT)      # forwarded to the workers (a SIGKILL of the parent orphans them)
            finally:
                fleet.kill()
        lis.close()


def test_fleet_seconds_prints_statistics():
    prefix = f"fleetstats{random.SystemRandom().randrange(1 << 24):x}_"
    p = Proc(bkabem_cmd("fleet", "--machines", "2", "--processes", "1", "--prefix", prefix, "--seconds", "3",
                        "--chunk-duration", "0.05"), name="fleet stats")
    assert p.p.wait(90) == 0, p.text[-3000:]
    p.stop()
    stats = [json.loads(ln.split(" ", 1)[1]) for ln in p.lines if ln.startswith("FLEETSTATS ")]
    assert sorted(s["machine_id"] for s in stats) == [f"{prefix}00", f"{prefix}01"]
    for s in stats:
        assert s["chunks"] >= 40 and s["lateness_ms_max"] < 50.0, s


def test_docs_list_every_parameter():
    from bkabem_ros.node.vibration_node import PARAMETERS

    text = (REPO / "docs" / "ros_node.md").read_text()
    missing = [p.name for p in PARAMETERS if f"`{p.name}`" not in text]
    assert not missing, f"docs/ros_node.md does not document {missing}"
    cfg = (REPO / "config" / "bkabem_node.yaml").read_text()
    for p in PARAMETERS:
        assert p.name.split(".")[-1] + ":" in cfg, f"config/bkabem_node.yaml lacks {p.name}"
