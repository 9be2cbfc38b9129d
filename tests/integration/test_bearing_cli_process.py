"""``bkabem bearing`` as a process: the JSON document on stdout, bad input one line on stderr with exit code 2."""

import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow

CLI = [sys.executable, "-m", "bkabem_ros"]


def run(*args):
    return subprocess.run(CLI + list(args), capture_output=True, text=True, timeout=120)


def test_bearing_json_as_a_process():
    p = run("bearing", "6203-2RS JEM", "--json")
    assert p.returncode == 0, p.stderr
    m = json.loads(p.stdout)["fault_multipliers_per_shaft_hz"]
    # CWRU bearing information page, fan-end 6203-2RS JEM
    for k, published in {"bpfi": 4.9469, "bpfo": 3.0530, "ftf": 0.3817, "bsf": 1.9944}.items():
        assert m[k] == pytest.approx(published, rel=0.005), k


@pytest.mark.parametrize("argv, argument", [(["62055"], "DESIGNATION"), (["6205", "--clearance", "C9"], "--clearance")])
def test_bad_input_exits_2_with_one_line(argv, argument):
    p = run("bearing", *argv)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.count("\n") == 1 and p.stderr.startswith(f"bkabem bearing: error: {argument}: "), p.stderr


def test_help_lists_the_command():
    p = run("--help")
    assert p.returncode == 0 and "bearing" in p.stdout
