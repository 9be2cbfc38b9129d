"""Generated hostile inputs for the ``bkabem`` command line, and the contract every run must meet.

The contract (issue 14): **exit 0 with finite output, or exit 2 with one line on stderr** - no traceback, no
other exit code, no hang, no non-finite number in what was written.

Inputs (deterministic for a seed):

- :func:`case_inputs`: mutated copies of the embedded case (every numeric key set to 0, -1, 1e-300, 1e300,
  1e308, nan, inf, a string, ...; keys removed or added; unit slips; binary, non-UTF-8, truncated, deeply
  nested, empty files), run as ``bkabem spectrum --speed-hz 25 --case F --json``;
- :func:`scenario_inputs`: mutated copies of a scenario file (:data:`SCENARIO_TEXT`: every key of the format, issue
  12) the same way, plus wrong types, a fleet file, an impossible timeline, too many states, run as
  ``bkabem synth --scenario F --seconds 0.2 --rate 8000 --out s.npz`` (the npz is checked for finite numbers);
- :func:`argument_inputs`: bad values for the options of all subcommands (non-finite, negative, huge, tiny,
  garbage, unwritable or full output paths, missing or garbage input files).

Used by ``tests/integration/test_fuzz_cli.py`` (a time-bounded sample) and as a script for the full counts::

    python tests/integration/fuzz_cli.py [--n-case 120] [--n-scenario 80] [--n-args 200]
                                         [--cli "python -m bkabem_ros"] [--jobs 2] [--fork-server]

The script starts every run as a fresh interpreter (``--cli``); the test forks each from a :class:`ForkServer`, an
interpreter that has imported the command line once: the same runs as processes of their own, without half a
second of start-up each (``test_fork_server_runs_are_the_fresh_processes_runs`` holds the two to the same
outcomes). Processes run with a 6 GiB address-space limit (a blow-up becomes a MemoryError, not a swapping machine), on
loopback with a random ``ROS_DOMAIN_ID``, and are killed after ``timeout`` seconds (counted as a hang).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import random
import re
import resource
import shlex
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from ros_helpers import random_domain

REPO = Path(__file__).resolve().parents[2]
CASE_TEXT = (REPO / "bkabem_core" / "embedded" / "cases" / "electric_motor_6010.toml").read_text()
MEMORY_LIMIT_BYTES = 6 << 30

BAD_NUMBERS = ["0", "-1", "1e-300", "1e300", "1e308", "nan", "inf", "-inf", '"x"', "true", "[1.0, 2.0]",
               "123456789012345678901234567890", "-1e-300", "1e30"]


@dataclass
class Input:
    """One generated run: argv after ``bkabem``, files to create (name -> bytes), what it is."""

    label: str
    argv: list[str]
    files: dict[str, bytes] = field(default_factory=dict)
    outputs: list[str] = field(default_factory=list)       # files to check for finite numbers after exit 0
    must_fail: bool = False                                 # an unwritable output: exit 0 would be a lie


@dataclass
class Outcome:
    input: Input
    returncode: int | None
    stderr: str
    verdict: str          # "ok0", "ok2", or the failure: "traceback", "exit N", "hang", "non-finite", "multi-line"
    seconds: float


# --------------------------------------------------------------------------- case files
def _numeric_keys(text: str) -> list[tuple[int, str]]:
    out = []
    for i, line in enumerate(text.splitlines()):
        m = re.match(r"^([a-z_0-9]+) = (-?[0-9.][0-9.e+-]*|\[[-0-9., e+]+\])\s*(#.*)?$", line)
        if m:
            out.append((i, m.group(1)))
    return out


def _set_line(text: str, index: int, value: str) -> str:
    lines = text.splitlines()
    key = lines[index].split("=", 1)[0].rstrip()
    lines[index] = f"{key} = {value}"
    return "\n".join(lines) + "\n"


def case_inputs(n: int, seed: int = 14) -> list[Input]:
    """``n`` mutated case files (the first ones are the fixed hard cases, then random key mutations)."""
    rng = random.Random(seed)
    keys = _numeric_keys(CASE_TEXT)
    fixed: list[tuple[str, bytes]] = [
        ("binary", bytes(range(256)) * 4),
        ("latin-1", CASE_TEXT.replace('"6010"', '"6010 \xe9"').encode("latin-1")),
        ("truncated", CASE_TEXT[: len(CASE_TEXT) // 2].encode()),
        ("empty", b""),
        ("nested", ("x = " + "[" * 5000 + "]" * 5000 + "\n" + CASE_TEXT).encode()),
        ("nested-tables", ("x = " + "{a = " * 3000 + "1" + "}" * 3000 + "\n").encode()),
        ("duplicate key", (CASE_TEXT + "\n[operating]\nmax_speed_hz = 10.0\n").encode()),
        ("unknown key", CASE_TEXT.replace("[operating]", "[operating]\nturbo = 1").encode()),
        ("bom", b"\xef\xbb\xbf" + CASE_TEXT.encode()),
        ("nul", CASE_TEXT.replace("[rotor]", "[rotor]\x00").encode()),
    ]
    for key in ("settle_time_s", "record_cage_periods", "samples_per_ball_pass", "gravity_m_s2",
                "density_kg_m3", "mass_kg", "reference_speed_hz", "max_speed_hz", "depth_m",
                "table_stiffness_vertical_n_m", "youngs_modulus_pa", "rotor_mass_kg"):
        idx = next(i for i, k in keys if k == key)
        for v in ({"settle_time_s": ["1e9"], "record_cage_periods": ["1000000"],
                   "samples_per_ball_pass": ["1000000000"], "gravity_m_s2": ["0"], "density_kg_m3": ["1e308"],
                   "mass_kg": ["1e300", "1e-300"], "reference_speed_hz": ["1e-300"],
                   "max_speed_hz": ["1e308"], "depth_m": ["1e300"], "table_stiffness_vertical_n_m": ["1e30"],
                   "youngs_modulus_pa": ["1e-300"], "rotor_mass_kg": ["1e-300"]}[key]):
            fixed.append((f"{key} = {v}", _set_line(CASE_TEXT, idx, v).encode()))
    out = [Input(f"case {label}", ["spectrum", "--speed-hz", "25", "--case", "{dir}/case.toml", "--json"],
                 {"case.toml": data}) for label, data in fixed]
    while len(out) < n:
        text = CASE_TEXT
        labels = []
        for _ in range(rng.choice((1, 1, 1, 2))):
            idx, key = rng.choice(keys)
            kind = rng.random()
            if kind < 0.75:
                v = rng.choice(BAD_NUMBERS)
            elif kind < 0.9:             # unit slips: mm written as m, rpm as Hz, x1000
                line = text.splitlines()[idx]
                v0 = line.split("=", 1)[1].split("#")[0].strip()
                if v0.startswith("["):
                    v = "[" + ", ".join(f"{float(x) * 1000:g}" for x in v0.strip("[]").split(",")) + "]"
                else:
                    v = f"{float(v0) * rng.choice((1000.0, 60.0, 1e-3)):g}"
                    if "." not in v and "e" not in v and not re.match(r"^-?\d+$", v0):
                        v += ".0"
            else:
                lines = text.splitlines()
                del lines[idx]
                text = "\n".join(lines) + "\n"
                labels.append(f"del {key}")
                keys_now = _numeric_keys(text)
                keys = keys_now if keys_now else keys
                continue
            text = _set_line(text, idx, v)
            labels.append(f"{key} = {v}")
        out.append(Input("case " + "; ".join(labels), ["spectrum", "--speed-hz", "25", "--case",
                                                       "{dir}/case.toml", "--json"], {"case.toml": text.encode()}))
        keys = _numeric_keys(CASE_TEXT)
    return out[:n] if n >= len(fixed) else out[:n]


# --------------------------------------------------------------------------- scenario files
#: A scenario with every key of the format (docs/scenarios.md); only its first state (healthy) is rendered in 0.2 s.
SCENARIO_TEXT = """[scenario]
name = "fuzz"
description = "every key"
schema_version = 1
case = "motor_6010_healthy"
duration_h = 12.0
size_step = 0.25

[labels]
condition = "fuzz"

[speed]
time_h = [0.0, 6.0, 12.0]
speed_hz = [24.0, 30.0, 20.0]

[load]
time_h = [0.0, 3.0]
load_factor = [1.0, 1.5]

[[defects]]
name = "de_outer"
bearing = "de"
race = "outer"
angle_deg = -90.0
edge = "ball"
edge_fraction = 0.1
growth = "exponential"
time_h = [2.0, 6.0, 12.0]
length_m = [0.2e-3, 0.6e-3, 4.0e-3]
depth_m = [5.0e-6, 15.0e-6, 100.0e-6]

[[defects]]
name = "nde_ball"
bearing = "nde"
race = "ball"
ball = 2
time_h = [8.0]
length_m = [1.0e-3]
depth_m = [20.0e-6]
"""
_SCENARIO_ARGV = ["synth", "--scenario", "{dir}/scenario.toml", "--seconds", "0.2", "--rate", "8000", "--out",
                  "{dir}/s.npz"]
_BAD_SCENARIO_VALUES = BAD_NUMBERS + ['""', '"outer"', "[]", '["a"]', "{}", "-90"]


def scenario_inputs(n: int, seed: int = 12) -> list[Input]:
    """``n`` mutated scenario files (fixed hard cases first, then random mutations of :data:`SCENARIO_TEXT`)."""
    rng = random.Random(seed)
    text0 = SCENARIO_TEXT
    lines0 = text0.splitlines()
    keyed = [(i, ln.split("=", 1)[0].strip()) for i, ln in enumerate(lines0) if re.match(r"^[a-z_]+ = ", ln)]
    fixed: list[tuple[str, str | bytes]] = [
        ("binary", bytes(range(256)) * 4),
        ("empty", b""),
        ("truncated", text0[: len(text0) // 2]),
        ("latin-1", text0.replace('"every key"', '"every k\xe9y"').encode("latin-1")),
        ("nested", "x = " + "[" * 5000 + "]" * 5000 + "\n" + text0),
        ("fleet file", '[fleet]\nname = "f"\nschema_version = 1\n[[fleet.machines]]\ncase = "motor_6010_healthy"\n'),
        ("no scenario table", text0.split("[labels]")[1]),
        ("too many states", text0.replace("size_step = 0.25", "size_step = 1e-5")),
        ("defect after the end", text0.replace("time_h = [8.0]", "time_h = [80.0]")),
        ("times not increasing", text0.replace("time_h = [2.0, 6.0, 12.0]", "time_h = [2.0, 6.0, 5.0]")),
        ("duplicate defect name", text0.replace('name = "nde_ball"', 'name = "de_outer"')),
        ("both time keys", text0.replace("time_h = [8.0]", "time_h = [8.0]\ntime_s = [8.0]")),
        ("unknown key", text0.replace("[load]", "[load]\nramp = true")),
        ("duplicate key", text0 + '\n[scenario]\nname = "again"\n'),
        ("case missing", text0.replace('case = "motor_6010_healthy"', 'case = "no_such_case"')),
        ("case path missing", text0.replace('case = "motor_6010_healthy"', 'case = "missing/case.toml"')),
        ("a dent at the start", text0.replace("time_h = [2.0, 6.0, 12.0]", "time_h = [0.0, 6.0, 12.0]")),
        ("speed above the case's", text0.replace("[24.0, 30.0, 20.0]", "[24.0, 3000.0, 20.0]")),
        ("exponential from 0", text0.replace("depth_m = [5.0e-6,", "depth_m = [0.0,")),
        ("ball of an outer dent", text0.replace('race = "outer"', 'race = "outer"\nball = 1')),
    ]
    out = [Input(f"scenario {label}", list(_SCENARIO_ARGV),
                 {"scenario.toml": data if isinstance(data, bytes) else data.encode()}, outputs=["{dir}/s.npz"])
           for label, data in fixed]
    while len(out) < n:
        lines = list(lines0)
        labels = []
        for _ in range(rng.choice((1, 1, 2))):
            idx, key = rng.choice(keyed)
            v0 = lines[idx].split("=", 1)[1].strip()
            kind = rng.random()
            if kind < 0.6:
                v = rng.choice(_BAD_SCENARIO_VALUES)
                if v0.startswith("[") and rng.random() < 0.5:          # one element of an array
                    items = [x.strip() for x in v0.strip("[]").split(",")]
                    items[rng.randrange(len(items))] = v
                    v = "[" + ", ".join(items) + "]"
            elif kind < 0.8 and re.match(r"^\[?[-0-9.e, ]+\]?$", v0):     # unit slips: mm as m, h as s, x1000
                f = rng.choice((1000.0, 3600.0, 1e-3))
                nums = [f"{float(x) * f:g}" for x in v0.strip("[]").split(",")]
                nums = [x if ("." in x or "e" in x) else x + ".0" for x in nums]
                v = "[" + ", ".join(nums) + "]" if v0.startswith("[") else nums[0]
            else:
                del lines[idx]
                labels.append(f"del {key}")
                break
            lines[idx] = f"{key} = {v}"
            labels.append(f"{key} = {v}")
        out.append(Input("scenario " + "; ".join(labels), list(_SCENARIO_ARGV),
                         {"scenario.toml": ("\n".join(lines) + "\n").encode()}, outputs=["{dir}/s.npz"]))
    return out[:n]


# --------------------------------------------------------------------------- arguments
_BAD = ["nan", "inf", "-1", "0", "1e308", "1e-300", "x", "", "1e6", "-inf", "1e9"]


UNWRITABLE: set[str] = set()


def _unwritable(suffix: str) -> list[str]:
    """Output paths that cannot be written: the full device, /proc, a read-only folder, and a file name with the
    right suffix that is a link to /dev/full (a full disk); plus a missing folder (some commands create it)."""
    out = ["/dev/full", f"/proc/bkabem{suffix}", f"{{ro}}/out{suffix}", f"{{dir}}/full{suffix}"]
    UNWRITABLE.update(out)
    return out + [f"{{dir}}/missing/out{suffix}"]


def argument_inputs(n: int, seed: int = 14) -> list[Input]:
    """``n`` bad argument sets over all subcommands (fixed hard ones first, then random single-option values)."""
    rng = random.Random(seed)
    specs: list[tuple[str, list[str], dict[str, list[str]], list[str]]] = [
        # command, valid base argv, option -> bad values, outputs of the base run
        ("excitation", ["excitation", "--json"], {"--png": _unwritable(".png")}, []),
        ("spectrum", ["spectrum", "--speed-hz", "25", "--json"],
         {"--speed-hz": _BAD + ["1e30"], "--png": _unwritable(".png")}, []),
        ("sweep", ["sweep", "--from-hz", "5", "--to-hz", "20", "--steps", "3", "--json"],
         {"--from-hz": _BAD, "--to-hz": _BAD, "--steps": ["0", "-1", "1e9", "1000000000", "x", "2.5"],
          "--png": _unwritable(".png")}, []),
        ("validate", ["validate", "--speed-hz", "25", "--duration", "0.05", "--json"],
         {"--speed-hz": _BAD, "--duration": _BAD, "--png": _unwritable(".png")}, []),
        ("synth", ["synth", "--profile", "constant:10", "--seconds", "0.2", "--rate", "8000", "--out",
                   "{dir}/s.npz"],
         {"--profile": ["constant:nan", "ramp:0:1e308:1", "steps::1", "x", "constant:-5", "ramp:0:50:0",
                        "{dir}/missing.csv", "{dir}/garbage.csv", "constant:1e300"],
          "--seconds": _BAD, "--rate": _BAD + ["1"], "--chunk": _BAD, "--snr-db": ["-1000", "1e308", "nan"],
          "--noise-acc": ["1e300", "1e308", "-1", "nan"], "--noise-disp": ["1e300"], "--noise-vel": ["1e300"],
          "--slip": ["1e300", "-1", "nan", "100"], "--max-order": ["0", "-1", "1e9", "x"],
          "--out": _unwritable(".npz") + _unwritable(".csv") + ["{dir}/x.txt"],
          "--png": _unwritable(".png")}, ["{dir}/s.npz"]),
        ("synth-scenario", ["synth", "--scenario", "de_outer_run_to_failure", "--seconds", "0.2", "--rate", "8000",
                            "--out", "{dir}/s.npz"],
         {"--time-scale": ["nan", "inf", "-1", "0", "1e308", "1e-300", "x", ""],
          "--scenario-start": ["nan", "-inf", "-1", "1e308", "x"],
          "--scenario": ["{dir}/missing.toml", "{dir}/garbage.yaml", "{dir}/binary.yaml", "no_such_scenario",
                         "mixed", "", "{dir}"],
          "--profile": ["constant:10"], "--case": ["motor_6010_outer"]}, ["{dir}/s.npz"]),
        ("demo", ["demo", "--no-ros", "--speeds", "10", "--out", "{dir}/demo"],
         {"--speeds": ["nan", "-1", "1e308", "1e30"], "--out": ["/dev/full", "/proc/bkabem", "{ro}/demo"],
          "--top-hz": ["nan", "0", "-1"], "--sample-rate": ["nan", "0", "-1"]}, []),
        ("demo-ros", ["demo", "--speeds", "10", "--out", "{dir}/demo", "--ramp", "0.5", "--hold", "0.5"],
         {"--top-hz": ["1e9", "1e308"], "--sample-rate": ["1", "1e9"], "--recordings": ["{ro}", "/proc/bkabem"]},
         []),
        ("node", ["node"],
         {"--sample-rate": ["nan", "0", "-1", "1", "1e9"], "--chunk-duration": ["nan", "0", "1e9"],
          "--seed": ["-1", "x"], "--namespace": ["bad ns", "/1x", "//", "/a b"], "--name": ["bad name", "1x", ""],
          "--params-file": ["{dir}/garbage.yaml", "{dir}/missing.yaml", "{dir}/binary.yaml"],
          "--record": ["{ro}/x.mcap", "{dir}/missing/x.mcap", "/dev/full", "{dir}/full.mcap"],
          "--case": ["{dir}/missing.toml"],
          "--spectrum-rate": ["nan", "-1", "1e9"],
          "--scenario": ["{dir}/missing.toml", "{dir}/garbage.yaml", "{dir}/binary.yaml", "no_such_scenario", "mixed",
                         "{dir}"],
          "--time-scale": ["nan", "0", "-1", "1e308", "x"], "--labels": ["x", "=v", "a=1,b"]}, []),
        ("speed", ["speed", "--seconds", "0.3", "--quiet"],
         {"--profile": ["constant:nan", "x", "ramp:0:1:0", "{dir}/missing.csv", "{dir}/garbage.csv"],
          "--rate": _BAD, "--seconds": ["nan", "-1", "0"], "--unit": ["furlongs"], "--topic": ["bad topic", "1x"],
          "--namespace": ["bad ns", "/1x"], "--hold": ["nan", "-1"]}, []),
        ("echo", ["echo", "--seconds", "0.3"],
         {"--count": ["0", "-1", "x"], "--seconds": ["nan", "-1", "0"], "--namespace": ["bad ns"],
          "topics": ["bad topic", "1x"]}, []),
        ("fleet", ["fleet", "--machines", "1", "--seconds", "1"],
         {"--machines": ["0", "-1", "1e6", "1000000", "x"], "--processes": ["0", "-1", "100000"],
          "--sample-rate": ["nan", "0"], "--defect-depths": ["x", "nan", "-1", "1e300"],
          "--prefix": ["bad prefix", "1"], "--seconds": ["nan", "-1"],
          "--first-index": ["-1", "x", "1e6", "999999", "2.5"], "--index-width": ["0", "1x", "99"],
          "--executor": ["threads", ""], "--discovery-range": ["subnet1", "", "nan"],
          "--discovery-server": ["10.0.0.300", "h:99999", ";", "[::1", "a b", "UDPv6:::1"],
          "--static-peers": [";", "foo..bar", "256.1.1.1"],
          "--scenario": ["{dir}/missing.toml", "{dir}/garbage.yaml", "no_such_scenario"]}, []),
        ("discovery-server", ["discovery-server", "--seconds", "1"],
         {"--listen": ["10.0.0.300", "x y", "::1", "192.0.2.7", ""], "--port": ["0", "-1", "65536", "x"],
          "--seconds": ["nan", "-1", "0"]}, []),
        ("record", ["record", "--out", "{dir}/r.mcap", "--duration", "0.5", "--quiet"],
         {"--out": _unwritable(".mcap"),
          "--duration": ["nan", "-1", "0"], "--chunk-size": ["0", "-1", "x", "1e30"],
          "--namespace": ["bad ns"], "--topics": ["bad topic"]}, []),
        ("recover", ["record", "--recover", "{dir}/ok.mcap", "{dir}/fixed.mcap"],
         {"DST": ["{dir}/missing/f.mcap", "/dev/full", "{ro}/f.mcap"],
          "SRC": ["{dir}/missing.mcap", "{dir}/garbage.mcap", "{dir}/binary.yaml"]}, []),
        ("replay", ["replay", "{dir}/ok.mcap", "--rerun-save", "{dir}/o.rrd"],
         {"FILE": ["{dir}/missing.mcap", "{dir}/garbage.mcap", "{dir}/half.mcap", "{dir}/header.mcap"],
          "--rerun-save": _unwritable(".rrd"), "--rate": _BAD,
          "--start-offset": ["nan", "-1", "1e308"], "--remap": ["x", ":=", "a:=bad topic"]}, []),
    ]
    inputs: list[Input] = []
    for cmd, base, options, outputs in specs:
        for opt, values in options.items():
            for v in values:
                inputs.append(_arg_input(cmd, base, opt, v, outputs))
    rng.shuffle(inputs)
    # every command at least once, then fill: the first inputs cover all 12+ commands
    by_cmd: dict[str, list[Input]] = {}
    for i in inputs:
        by_cmd.setdefault(i.label.split()[0], []).append(i)
    ordered = []
    while any(by_cmd.values()):
        for k in list(by_cmd):
            if by_cmd[k]:
                ordered.append(by_cmd[k].pop())
    return ordered[:n]


def _arg_input(cmd: str, base: list[str], opt: str, value: str, outputs: list[str]) -> Input:
    argv = list(base)
    suffix_value = value
    if opt in ("SRC", "DST"):
        i = {"SRC": 2, "DST": 3}[opt]
        argv[i] = suffix_value
    elif opt == "FILE":
        argv[1] = suffix_value
    elif opt == "topics":
        argv.append(suffix_value)
    elif opt in argv:
        argv[argv.index(opt) + 1] = suffix_value
    else:
        argv += [opt, suffix_value]
    return Input(f"{cmd} {opt} {value!r}", argv, outputs=[] if value in outputs else list(outputs),
                 must_fail=value in UNWRITABLE)


# --------------------------------------------------------------------------- running and judging
def _fixture_files(d: Path, ro: Path, recordings: bool = True) -> None:
    (d / "garbage.csv").write_text("time_s,speed_hz\n0,x\n1,\n")
    (d / "garbage.yaml").write_text("/**:\n  ros__parameters: [unclosed\n")
    (d / "binary.yaml").write_bytes(bytes(range(256)))
    (d / "garbage.mcap").write_bytes(b"\x89MCAP0\r\n" + os.urandom(300))
    ok = REPO / "recordings" / "example_runup.mcap"
    if recordings and ok.exists():                  # 3 MB of copies: only for the inputs that name a recording
        data = ok.read_bytes()
        (d / "ok.mcap").write_bytes(data)
        (d / "half.mcap").write_bytes(data[: len(data) // 2])
        (d / "header.mcap").write_bytes(data[:40])
    for suffix in (".png", ".npz", ".csv", ".rrd", ".mcap"):
        p = d / f"full{suffix}"
        if not p.is_symlink():
            p.symlink_to("/dev/full")
    ro.mkdir(exist_ok=True)
    os.chmod(ro, 0o555)


def read_only_dir(d: Path) -> Path:
    """A folder this process cannot create files in: a 0555 folder, or for root (who ignores modes) /sys/fs."""
    return Path("/sys/fs") if os.geteuid() == 0 else d / "ro"


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def _finite_json(text: str) -> bool:
    bad = []

    def walk(o):
        if isinstance(o, float) and not math.isfinite(o):
            bad.append(o)
        elif isinstance(o, dict):
            for v in o.values():
                walk(v)
        elif isinstance(o, list):
            for v in o:
                walk(v)

    for chunk in _json_documents(text):
        walk(chunk)
    return not bad


def _json_documents(text: str):
    text = text.strip()
    if not text:
        return
    try:
        yield json.loads(text)
        return
    except json.JSONDecodeError:
        pass
    for line in text.splitlines():                  # JSON lines
        line = line.strip()
        if line.startswith(("{", "[")):
            try:
                yield json.loads(line)
            except json.JSONDecodeError:
                pass


def _finite_file(path: Path) -> bool:
    if not path.exists():
        return True
    if path.suffix == ".npz":
        import numpy as np

        with np.load(path) as z:
            for k in z.files:
                a = z[k]
                if a.dtype.kind in "fc" and not np.all(np.isfinite(a)):
                    return False
        return True
    if path.suffix == ".csv":
        return not re.search(r"(?i)\b(nan|inf)\b", path.read_text(errors="replace"))
    return True


def judge(inp: Input, rc: int | None, stdout: str, stderr: str, workdir: Path) -> str:
    if rc is None:
        return "hang"
    if "Traceback (most recent call last)" in stderr:
        return "traceback"
    lines = [ln for ln in stderr.strip().splitlines() if ln.strip()]
    if rc == 2:
        errors = [ln for ln in lines if ": error: " in ln or ln.startswith("usage:")]
        return "ok2" if len(errors) == 1 and len([ln for ln in lines if ln.startswith("bkabem") or
                                                  ln.startswith("usage:")]) <= 2 else "multi-line"
    if rc != 0:
        return f"exit {rc}"
    if inp.must_fail:
        return "exit 0 after failure"
    if re.search(r"(?i)\b(nan|inf)\b", stdout) and not _finite_json(stdout):
        return "non-finite"
    for o in inp.outputs:
        if not _finite_file(workdir / o.replace("{dir}/", "")):
            return "non-finite"
    return "ok0"


def run_one(inp: Input, run, timeout: float, base_dir: Path) -> Outcome:
    """Run one input in a folder of its own with the fixture files; ``run(argv, cwd, timeout)`` is a
    :class:`FreshProcesses` or a :class:`ForkServer` and returns ``(exit code or None for a hang, stdout, stderr)``."""
    d = Path(tempfile.mkdtemp(prefix="fz_", dir=base_dir))
    _fixture_files(d, d / "ro", recordings=any(".mcap" in a for a in inp.argv))
    ro = read_only_dir(d)
    for name, data in inp.files.items():
        (d / name).write_bytes(data)
    argv = [a.replace("{dir}", str(d)).replace("{ro}", str(ro)) for a in inp.argv]
    t0 = time.monotonic()
    rc, out, err = run(argv, d, timeout)
    verdict = judge(inp, rc, out, err, d)
    os.chmod(d / "ro", 0o755)
    return Outcome(inp, rc, err, verdict, time.monotonic() - t0)


class FreshProcesses:
    """Each run a new interpreter, ``cli + argv`` (``python -m bkabem_ros`` or the console script), as a user runs
    it."""

    def __init__(self, cli: list[str], env: dict):
        self.cli, self.env = cli, env

    def __call__(self, argv: list[str], cwd: Path, timeout: float) -> tuple[int | None, str, str]:
        p = subprocess.Popen(self.cli + argv, cwd=cwd, env=self.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, errors="replace", preexec_fn=_limit_memory, start_new_session=True)
        try:
            out, err = p.communicate(timeout=timeout)
            return p.returncode, out, err
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, 9)
            out, err = p.communicate()
            return None, out, err

    def close(self) -> None:
        pass


# --------------------------------------------------------------------------- the fork server
#: The fork server's program. It imports what a ``bkabem`` command imports when it runs, says ``ready``, then reads
#: one JSON request per line on stdin: ``{"id", "argv", "cwd", "stdout", "stderr", "memory"}``. For each it forks a
#: child that starts a session of its own (so that a hang is killed with its helpers), limits its address space,
#: takes the request's files as its stdout and stderr and /dev/null as its stdin, and runs the command line's
#: ``main`` at this program's top level: an exception no handler caught ends it the way it ends ``python -m
#: bkabem_ros`` (the interpreter's traceback, exit code 1) and ``sys.exit`` as it does there (atexit handlers and
#: all). The server answers ``ID started PID`` at once and ``ID exited CODE`` when it has reaped the child (CODE as
#: :attr:`subprocess.Popen.returncode` gives it: negative for a signal).
ZYGOTE = r"""
import json, os, resource, select, sys

import numpy, scipy.linalg, scipy.signal, scipy.integrate, scipy.interpolate  # noqa: E401,F401
import matplotlib.pyplot  # noqa: F401
import bkabem_core, bkabem_core.model, bkabem_core.fe, bkabem_core.solve, bkabem_core.excitation  # noqa: E401,F401
import bkabem_core.synth, bkabem_core.scenario, bkabem_core.dataset, bkabem_core.analysis  # noqa: E401,F401
import bkabem_ros.cli.main  # noqa: F401

reply = os.dup(1)
os.write(reply, b"ready\n")
running, pending, child = {}, b"", None
while child is None:
    while running:                                      # reap what has ended
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            break
        if pid == 0:
            break
        os.write(reply, f"{running.pop(pid)} exited {os.waitstatus_to_exitcode(status)}\n".encode())
    if not select.select([0], [], [], 0.02)[0]:
        continue
    data = os.read(0, 1 << 16)
    if not data:                                        # stdin closed: the test is done with the server
        sys.exit(0)
    pending += data
    while child is None and b"\n" in pending:
        line, pending = pending.split(b"\n", 1)
        req = json.loads(line)
        pid = os.fork()
        if pid == 0:
            child = req
        else:
            running[pid] = req["id"]
            os.write(reply, f"{req['id']} started {pid}\n".encode())
os.setsid()
os.close(reply)
resource.setrlimit(resource.RLIMIT_AS, (child["memory"], child["memory"]))
os.chdir(child["cwd"])
os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
os.dup2(os.open(child["stdout"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644), 1)
os.dup2(os.open(child["stderr"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644), 2)
sys.argv = ["bkabem", *child["argv"]]
del json, resource, select, running, pending, reply
from bkabem_ros.cli.main import main
sys.exit(main(child["argv"]))
"""


class ForkServer:
    """Each run a process forked from one interpreter that has imported what the command line imports
    (:data:`ZYGOTE`). A process of its own all the same: its own pid and session, the memory limit, its exit code,
    stdout and stderr, killed with its helpers after ``timeout``. What it skips is the interpreter's start-up and
    imports (about half a second a run), which the other command-line tests pay and ``test_cli_start_time``
    measures."""

    def __init__(self, env: dict, base_dir: Path):
        self._log = open(base_dir / "fork_server.log", "w+")
        self._p = subprocess.Popen([sys.executable, "-c", ZYGOTE], env=env, cwd=base_dir, stdin=subprocess.PIPE,
                                   stdout=subprocess.PIPE, stderr=self._log, text=True)
        self._lock, self._ids, self._runs = threading.Lock(), itertools.count(), {}
        if self._p.stdout.readline().strip() != "ready":
            self._p.kill()
            self._log.seek(0)
            raise RuntimeError(f"the fork server did not start: {self._log.read()[-3000:]}")
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self._p.stdout:
            rid, what, value = line.split()
            run = self._runs.get(int(rid))
            if run is None:                                 # a run given up on (its kill was not reaped in time)
                continue
            if what == "started":
                run["pid"] = int(value)
                run["started"].set()
            else:
                run["code"] = int(value)
                run["exited"].set()

    def __call__(self, argv: list[str], cwd: Path, timeout: float) -> tuple[int | None, str, str]:
        rid = next(self._ids)
        run = self._runs[rid] = {"started": threading.Event(), "exited": threading.Event()}
        out, err = cwd / ".stdout", cwd / ".stderr"
        req = {"id": rid, "argv": argv, "cwd": str(cwd), "stdout": str(out), "stderr": str(err),
               "memory": MEMORY_LIMIT_BYTES}
        with self._lock:
            self._p.stdin.write(json.dumps(req) + "\n")
            self._p.stdin.flush()
        if not run["started"].wait(60):
            raise RuntimeError(f"the fork server does not answer (exit code {self._p.poll()})")
        code = run["code"] if run["exited"].wait(timeout) else None
        if code is None:                                    # a hang: the run and whatever it started
            try:
                os.killpg(run["pid"], 9)
            except ProcessLookupError:                      # killed before it had its own session
                os.kill(run["pid"], 9)
            run["exited"].wait(60)
        del self._runs[rid]
        text = [p.read_text(errors="replace") if p.exists() else "" for p in (out, err)]
        out.unlink(missing_ok=True), err.unlink(missing_ok=True)
        return code, text[0], text[1]

    def close(self) -> None:
        self._p.stdin.close()
        self._p.wait(60)
        self._log.close()


def fuzz_env() -> dict:
    env = dict(os.environ)
    env.update({"ROS_DOMAIN_ID": str(random_domain()),
                "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "OPENBLAS_NUM_THREADS": "1",
                "ROS_LOG_DIR": tempfile.mkdtemp(prefix="fz_roslog_"), "PYTHONUNBUFFERED": "1"})
    return env


def run_all(inputs: list[Input], cli: list[str] | None = None, timeout: float = 60.0, jobs: int = 2,
            budget_s: float | None = None) -> list[Outcome]:
    """Run ``inputs``, ``jobs`` at a time, until ``budget_s`` (if given) is spent: each in a fresh interpreter
    ``cli + argv`` if ``cli`` is given, else forked from a :class:`ForkServer`."""
    env = fuzz_env()
    base = Path(tempfile.mkdtemp(prefix="bkabem_fuzz_"))
    t_end = None if budget_s is None else time.monotonic() + budget_s
    out: list[Outcome] = []
    run = FreshProcesses(cli, env) if cli else ForkServer(env, base)

    def job(inp):
        if t_end is not None and time.monotonic() > t_end:
            return None
        return run_one(inp, run, timeout, base)

    try:
        with ThreadPoolExecutor(max_workers=jobs) as ex:
            for r in ex.map(job, inputs):
                if r is not None:
                    out.append(r)
    finally:
        run.close()
    return out


def report(outcomes: list[Outcome], title: str) -> str:
    from collections import Counter

    c = Counter(o.verdict for o in outcomes)
    lines = [f"{title}: {len(outcomes)} runs: " + ", ".join(f"{k} {v}" for k, v in sorted(c.items()))]
    for o in outcomes:
        if o.verdict not in ("ok0", "ok2"):
            last = (o.stderr.strip().splitlines() or [""])[-1][:160]
            lines.append(f"  {o.verdict:10s} {o.input.label[:70]:70s} | {last}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n-case", type=int, default=120)
    ap.add_argument("--n-scenario", type=int, default=80)
    ap.add_argument("--n-args", type=int, default=200)
    ap.add_argument("--cli", default=f"{sys.executable} -m bkabem_ros")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--fork-server", action="store_true",
                    help="fork each run from one interpreter that has imported the command line (as the test does) "
                         "instead of starting --cli afresh")
    a = ap.parse_args(argv)
    cli = None if a.fork_server else shlex.split(a.cli)
    t0 = time.monotonic()
    rc = 0
    for title, inputs in (("case files", case_inputs(a.n_case)), ("scenario files", scenario_inputs(a.n_scenario)),
                          ("arguments", argument_inputs(a.n_args))):
        outs = run_all(inputs, cli, a.timeout, a.jobs)
        print(report(outs, title), flush=True)
        rc |= any(o.verdict not in ("ok0", "ok2") for o in outs)
    print(f"{time.monotonic() - t0:.0f} s")
    return int(rc)


if __name__ == "__main__":
    sys.exit(main())
