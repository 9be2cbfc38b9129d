"""The command-line layer: one place above both packages (``bkabem_ros.cli.main`` + ``cli_base``).

- ``bkabem_core`` imports nothing above itself (no bkabem_ros, rclpy, mcap, rerun);
- the core commands never import rclpy (checked in a real ``bkabem`` process through ``sys.modules``);
- a command imports the slow parts of scipy (interpolate, optimize, integrate) only where it uses them;
- the error contract: bad input one line + exit 2, an unexpected exception one line with the ``--debug``
  hint + exit 1, ``--debug`` (before or after the command name) shows the traceback.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
ABOVE_CORE = ("bkabem_ros", "rclpy", "mcap", "mcap_ros2", "rerun", "rosbags", "std_msgs", "bkabem_msgs")


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def test_core_imports_nothing_above_itself():
    bad = {}
    for f in sorted((REPO / "bkabem_core").glob("*.py")):
        hits = sorted(m for m in _imports(f) if m.split(".")[0] in ABOVE_CORE)
        if hits:
            bad[f.name] = hits
    assert not bad, f"bkabem_core imports from above itself: {bad}"
    assert not (REPO / "bkabem_core" / "cli.py").exists()


def _probe(watched: tuple[str, ...], packages: bool) -> str:
    """A ``python -c`` program: ``bkabem ARGS`` in it, then ``HEAVY`` and those of ``watched`` it has imported (as
    top-level packages, or as the modules named) on a line of stderr."""
    name = "m.split('.')[0]" if packages else "m"
    return ("import sys\n"
            "from bkabem_ros.cli.main import main\n"
            "try:\n"
            "    rc = main(sys.argv[1:])\n"
            "finally:\n"
            f"    heavy = sorted({{{name} for m in sys.modules}} & {set(watched)!r})\n"
            "    sys.stderr.write('HEAVY ' + ','.join(heavy) + '\\n')\n"
            "sys.exit(rc)\n")


_PROBE = _probe(("rclpy", "rerun", "mcap", "bkabem_msgs", "std_msgs", "rosbags"), packages=True)


@pytest.mark.parametrize("args", [
    ["excitation", "--json"],
    ["spectrum", "--speed-hz", "20", "--json"],
    ["sweep", "--from-hz", "5", "--to-hz", "10", "--steps", "3", "--csv"],
    ["synth", "--profile", "constant:10", "--seconds", "0.05", "--rate", "8000", "--out", "{tmp}/s.npz"],
    ["demo", "--no-ros", "--speeds", "10", "--out", "{tmp}/demo"],
    ["spectrum", "--speed-hz", "-1"],                         # the error path too
    ["excitation", "--case", "{tmp}/missing.toml"],
], ids=lambda a: " ".join(a[:2]))
def test_core_commands_never_import_rclpy(args, tmp_path):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    p = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, timeout=300,
                       cwd=tmp_path)
    heavy = [ln for ln in p.stderr.splitlines() if ln.startswith("HEAVY")]
    assert heavy == ["HEAVY "], (p.returncode, p.stderr[-2000:])
    assert p.returncode in (0, 2)


_SLOW_SCIPY = ("scipy.interpolate", "scipy.integrate", "scipy.optimize")
_PROBE_SCIPY = _probe(_SLOW_SCIPY, packages=False)

_ROUND_PIT = ('[[defects]]\nbearing = "de"\nrace = "outer"\nshape = "round_pit"\nlength_m = 0.000533\n'
              'depth_m = 0.000279\nedge = "ball"\nclock = 6\n\n[case]')      # the keys docs/rigs.md lists


@pytest.mark.parametrize("args, wanted", [
    (["replay", str(REPO / "recordings" / "example_runup.mcap"), "--info"], []),
    (["spectrum", "--speed-hz", "20", "--json"], []),
    (["spectrum", "--speed-hz", "20", "--json", "--case", "{tmp}/pit.toml"], ["scipy.interpolate"]),
], ids=["replay --info", "spectrum", "spectrum of a round pit"])
def test_commands_import_the_slow_parts_of_scipy_only_where_they_use_them(args, wanted, tmp_path):
    """scipy.interpolate (which brings scipy.optimize) and scipy.integrate take about half a second of a process's
    start: only a round pit's contact (its profile table) and the 4-DOF model's integration use them, so a command
    that does neither does not import them. The round pit's case shows that the probe can tell."""
    from case_files import embedded_text

    (tmp_path / "pit.toml").write_text(embedded_text("cwru_rig").replace("defects = []", "", 1)
                                       .replace("[case]", _ROUND_PIT, 1))
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    p = subprocess.run([sys.executable, "-c", _PROBE_SCIPY, *argv], capture_output=True, text=True, timeout=300,
                       cwd=tmp_path)
    loaded = [ln for ln in p.stderr.splitlines() if ln.startswith("HEAVY")]
    assert p.returncode == 0, p.stderr[-2000:]
    assert len(loaded) == 1 and [m for m in wanted if m not in loaded[0]] == [], loaded
    if not wanted:
        assert loaded == ["HEAVY "], loaded


def test_ros_command_module_imports_rclpy_only_when_it_runs():
    """Building the whole parser (all ROS commands registered) must not import rclpy either."""
    code = ("import sys; from bkabem_ros.cli.main import build_parser; build_parser(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'rerun', 'mcap')))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and p.stdout.strip() == "[]", p.stdout + p.stderr


def test_unexpected_exception_is_one_line_with_debug_hint(monkeypatch, capsys):
    from bkabem_ros.cli import core as core_cli
    from bkabem_ros.cli.main import main

    def broken(case, solver="block"):
        raise ZeroDivisionError("a bug somewhere")

    monkeypatch.setattr(core_cli, "_model", broken)
    assert main(["spectrum", "--speed-hz", "5"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ZeroDivisionError" in err[0] and "--debug" in err[0], err
    for argv in (["--debug", "spectrum", "--speed-hz", "5"], ["spectrum", "--speed-hz", "5", "--debug"]):
        assert main(argv) == 1
        err = capsys.readouterr().err
        assert "Traceback (most recent call last)" in err and "a bug somewhere" in err


def test_standalone_modules_keep_the_contract(tmp_path):
    for module, args, fragment in (
            ("bkabem_ros.cli.synth", ["--profile", "constant:10", "--out", str(tmp_path / "x.npz")], "--seconds"),
            ("bkabem_ros.cli.record", ["--recover", str(tmp_path / "no.mcap"), str(tmp_path / "o.mcap")],
             "no such file"),
            ("bkabem_ros.cli.replay", [str(tmp_path / "no.mcap")], "no such file")):
        p = subprocess.run([sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=120)
        lines = p.stderr.strip().splitlines()
        assert p.returncode == 2 and len(lines) == 1 and fragment in lines[0], (module, p.stderr)
