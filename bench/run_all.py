"""Regenerate BENCHMARKS.md: run each area's benchmark scripts with short settings, read their JSON, write the tables.

    .venv/bin/python bench/run_all.py                        # every default area (~7 min on 2 quiet cores, 10-20 busy)
    .venv/bin/python bench/run_all.py --areas core,synthesis # re-measure these areas, keep the others' records
    .venv/bin/python bench/run_all.py --list                 # the areas, their steps and commands
    .venv/bin/python bench/run_all.py --render               # rewrite BENCHMARKS.md from bench/records.json only
    .venv/bin/python bench/run_all.py --areas realism --data-dir DIR   # the twin against measured CWRU records
    make bench [AREAS=core,synthesis]

A *step* is one benchmark command (a script of ``bench/`` or a ``bkabem`` command) with the settings below, run as
its own process with ``OPENBLAS_NUM_THREADS=1``, ROS 2 on loopback and its output in ``bench/results/`` (the raw JSON
and the log of every step; not kept in git). Its JSON becomes rows (case, quantity, value, target) by the step's
reader (bench/bench_tables.py). The rows of every step, with the command, the machine (CPU model and cores from
/proc/cpuinfo), the load average, the date and the code's commit, are kept in ``bench/records.json`` (in git), so
that re-measuring some areas leaves the others' rows as they were. BENCHMARKS.md is
``bench/BENCHMARKS.template.md`` with each ``{{area:NAME}}`` replaced by that area's table.

A step that fails is recorded as failed (its rows are dropped, the table says so, the exit code is 1); the run
goes on with the next step. Targets are the ones the project's issues set; "met" compares the value with it.

The realism area needs measured records the project does not keep (CWRU's drive-end records as NumPy files):
``--data-dir DIR`` or ``$BKABEM_CWRU_DIR``; without one its steps are not run, and a measurement made before keeps
its rows.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from bench_tables import (  # bench/: the script's folder
    read_core,
    read_dataset,
    read_dataset_synth,
    read_faults,
    read_fleet,
    read_floor,
    read_machine,
    read_model_switch,
    read_node,
    read_preparation,
    read_record,
    read_rerun,
    read_scenario,
    read_sim2real,
    read_speed_jumps,
    read_startup,
    read_suite,
    read_synth,
    read_tdsm,
    read_validate,
    read_validate_real,
    shown,
)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
RECORDS = HERE / "records.json"
TEMPLATE = HERE / "BENCHMARKS.template.md"
OUTPUT = ROOT / "BENCHMARKS.md"


# --------------------------------------------------------------------------- steps and areas
PY = "{python}"
BK = "{bkabem}"
DATA = "{data}"
#: The folder of measured CWRU records for the realism area (or ``--data-dir``); the project keeps no copy.
DATA_ENV = "BKABEM_CWRU_DIR"


@dataclass
class Step:
    """One benchmark command. ``argv`` items ``{python}``, ``{json}`` and ``{data}`` (the measured-data folder) are
    filled in; ``output`` says where its JSON comes from: "file" (the ``{json}`` path), "stdout" (the whole output)
    or "stdouts" (several commands). A step that ``needs_data`` runs only when a data folder is given."""

    name: str
    argv: list | list[list]
    read: Callable
    estimate_s: float
    output: str = "file"
    areas: tuple = ()
    needs_data: bool = False


STEPS = [
    Step("core", [PY, "bench/bench_core.py", "--repeats", "3", "--json", "{json}"], read_core, 15),
    Step("preparation", [PY, "bench/bench_preparation.py", "--repeat", "1", "--improved", "--json", "{json}"],
         read_preparation, 60),
    Step("tdsm", [PY, "bench/bench_tdsm.py", "--steps", "3000", "--repeats", "3", "--json", "{json}"], read_tdsm,
         50),
    Step("validate", [[BK, "validate", "--speed-hz", str(f), "--duration", "0.2", "--json"]
                      for f in (15, 30, 50)], read_validate, 50, output="stdouts"),
    Step("synth", [PY, "bench/bench_synth.py", "--seconds", "10", "--repeat", "3", "--json", "{json}"], read_synth,
         30),
    Step("faults", [PY, "bench/bench_faults.py", "--repeat", "3", "--seconds", "5", "--json", "{json}"],
         read_faults, 120),
    Step("dataset", [PY, "bench/bench_dataset.py", "--repeat", "3", "--runs", "5", "--seconds", "10", "--json",
                     "{json}"], read_dataset, 45),
    Step("floor", [PY, "bench/bench_floor.py", "--repeat", "7", "--machines", "12", "--json", "{json}"],
         read_floor, 10),
    Step("node", [PY, "bench/bench_node.py", "--seconds", "20", "--rates", "25600,51200", "--json", "{json}"],
         read_node, 70),
    Step("fleet", [PY, "bench/bench_fleet.py", "--machines", "32,100", "--variants", "after", "--repeats", "1",
                   "--seconds", "10", "--json", "{json}"], read_fleet, 150),
    Step("speed_jumps", [PY, "bench/bench_speed_jumps.py", "--repeats", "1", "--json", "{json}"], read_speed_jumps,
         45),
    Step("record", [PY, "bench/bench_record.py", "--seconds", "10", "--node-seconds", "10", "--repeats", "1",
                    "--json", "{json}"], read_record, 70),
    Step("rerun", [PY, "bench/bench_rerun.py", "--seconds", "10", "--repeats", "3", "--json", "{json}"], read_rerun,
         40),
    Step("model_switch", [PY, "bench/bench_model_switch.py", "--repeat", "1", "--json", "{json}"],
         read_model_switch, 25),
    Step("scenario", [PY, "bench/bench_scenario.py", "--repeat", "1", "--json", "{json}"], read_scenario, 30),
    Step("machine", [PY, "bench/bench_machine.py", "--repeat", "3", "--json", "{json}"], read_machine, 60),
    Step("startup", [PY, "bench/bench_startup.py", "--repeat", "5", "--unit-tier", "--json", "{json}"],
         read_startup, 200),
    Step("suite", [PY, "bench/bench_startup.py", "--repeat", "0", "--suite", "--json", "{json}"], read_suite, 900),
    # the rig's twin with the seeds of docs/validation_real.md (the scripts' default, 2), so the page and this table
    # give the same numbers
    Step("validate_real", [PY, "bench/validate_real.py", DATA, "--seeds", "2", "--out", "bench/results/realism",
                           "--json", "{json}"], read_validate_real, 60, needs_data=True),
    Step("sim2real", [PY, "bench/sim2real.py", DATA, "--seeds", "2", "--out", "bench/results/realism", "--json",
                      "{json}"], read_sim2real, 330, needs_data=True),
    # the fault library's machine (not the rig's) as the twin: what a pipeline trained on the product's default
    # machine alone makes of the rig's records
    Step("sim2real_library", [PY, "bench/sim2real.py", DATA, "--twin", "motor_6010", "--seeds", "1", "--out",
                              "bench/results/realism_library", "--json", "{json}"], read_sim2real, 300,
         needs_data=True),
]

#: area -> (title, steps whose rows it shows, in this order). Areas marked optional run only when named.
AREAS = {
    "core": ("Core: preparation and spectrum speed", ["core"]),
    "excitation": ("Excitation and preparation per defect kind", ["preparation"]),
    "tdsm": ("TDSM and validation", ["tdsm", "validate"]),
    "synthesis": ("Synthesis per kind and channel count", ["synth", "faults", "dataset:synth"]),
    "dataset": ("Data-set path", ["dataset", "floor"]),
    "node": ("Node and fleet", ["node", "fleet", "speed_jumps"]),
    "recording": ("Recording and Rerun", ["record", "rerun"]),
    "switches": ("Model switches and scenarios", ["model_switch", "scenario"]),
    "machine": ("Any machine: catalogue machines in the compact form", ["machine"]),
    "startup": ("Start-up time and the fast test tier", ["startup"]),
    "realism": ("Realism: the twin against measured CWRU records (only with a data folder)",
                ["validate_real", "sim2real", "sim2real_library"]),
    "suite": ("The whole test suite (optional: only with --areas suite)", ["suite"]),
}
OPTIONAL = {"suite"}
READERS = {"dataset:synth": read_dataset_synth}


def step_by_name(name: str) -> Step:
    return next(s for s in STEPS if s.name == name)


def steps_of(areas) -> list[Step]:
    names = []
    for a in areas:
        for ref in AREAS[a][1]:
            n = ref.split(":")[0]
            if n not in names:
                names.append(n)
    return [s for s in STEPS if s.name in names]


# --------------------------------------------------------------------------- the machine
def machine() -> dict:
    info = {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "python": platform.python_version()}
    try:
        text = Path("/proc/cpuinfo").read_text()
        for line in text.splitlines():
            if line.startswith("model name"):
                info["cpu"] = line.split(":", 1)[1].strip()
                break
        flags = next((ln.split(":", 1)[1].split() for ln in text.splitlines() if ln.startswith("flags")), [])
        info["simd"] = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "SSE"
        mem = next(ln for ln in Path("/proc/meminfo").read_text().splitlines() if ln.startswith("MemTotal"))
        info["memory_gb"] = round(int(mem.split()[1]) / 2 ** 20)
    except (OSError, StopIteration):
        pass
    try:
        import numpy

        info["numpy"] = numpy.__version__
    except ImportError:
        pass
    return info


def commit() -> str:
    """The code's commit, ``-dirty`` if tracked files differ from it (the run's own outputs left aside)."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                             timeout=10).stdout.strip()
        changed = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".",
                                  ":!BENCHMARKS.md", ":!bench/records.json"], cwd=ROOT, capture_output=True,
                                 text=True, timeout=10).stdout.strip()
        return (rev or "unknown") + ("-dirty" if changed else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def shown_command(argv: list) -> str:
    """The command as a user types it from the repository (``.venv/bin/python``, ``F.json`` for the output)."""
    def one(a):
        parts = []
        for x in a:
            if x == PY:
                parts.append(".venv/bin/python")
            elif x == BK:
                parts.append(".venv/bin/bkabem")
            elif x == "{json}":
                parts.append("F.json")
            elif x == DATA:
                parts.append("DATA_DIR")
            else:
                parts.append(x)
        return shlex.join(parts)
    if argv and isinstance(argv[0], list):
        return "; ".join(one(a) for a in argv)
    return one(argv)


# --------------------------------------------------------------------------- running
def run_step(step: Step, bar, env: dict, data_dir: str | None = None) -> dict:
    """Run one step; returns its record (rows, command, machine, load, time, commit, or the error)."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "logs").mkdir(exist_ok=True)
    jpath = RESULTS / f"{step.name}.json"
    jpath.unlink(missing_ok=True)
    log = RESULTS / "logs" / f"{step.name}.log"
    cmds = step.argv if isinstance(step.argv[0], list) else [step.argv]
    rec = {"step": step.name, "command": shown_command(step.argv), "machine": machine(), "commit": commit(),
           "date": _dt.date.today().isoformat(), "load": [round(os.getloadavg()[0], 2)]}
    t_start = time.monotonic()
    done = 0.0
    outputs = []
    error = None
    with open(log, "w") as lf:
        for cmd in cmds:
            fill = {PY: sys.executable, BK: str(Path(sys.executable).parent / "bkabem"), "{json}": str(jpath),
                    DATA: str(data_dir)}
            argv = [fill.get(x, x) for x in cmd]
            lf.write(f"$ {shlex.join(argv)}\n")
            lf.flush()
            out = tempfile.TemporaryFile(mode="w+")
            p = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=out if step.output != "file" else lf,
                                 stderr=lf, text=True)
            while p.poll() is None:
                time.sleep(0.5)
                elapsed = time.monotonic() - t_start
                want = min(elapsed, step.estimate_s * 0.98)
                if want > done:
                    bar.update(want - done)
                    done = want
            if step.output != "file":
                out.seek(0)
                text = out.read()
                lf.write(text)
                outputs.append(text)
            out.close()
            if p.returncode != 0:
                error = f"exit {p.returncode}"
                break
    bar.update(step.estimate_s - done)
    rec["duration_s"] = round(time.monotonic() - t_start, 1)
    rec["load"].append(round(os.getloadavg()[0], 2))
    if error is None:
        try:
            if step.output == "file":
                data = json.loads(jpath.read_text())
            else:
                data = [json.loads(t) for t in outputs]
                if step.output == "stdout":
                    data = data[0]
                jpath.write_text(json.dumps(data, indent=1))
            rec["data_file"] = str(jpath.relative_to(ROOT))
            rec["rows"] = {}
            for area, (_title, refs) in AREAS.items():
                for ref in refs:
                    if ref.split(":")[0] == step.name:
                        rec["rows"][ref] = READERS.get(ref, step.read)(data, None)
        except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError, StopIteration) as exc:
            error = f"its output could not be read: {type(exc).__name__}: {exc}"
    if error is not None:
        tail = [ln for ln in log.read_text(errors="replace").splitlines() if ln.strip()][-3:]
        rec["error"] = error + (f"; last lines of {log.relative_to(ROOT)}: " + " | ".join(t[:200] for t in tail)
                                if tail else "")
        rec.pop("rows", None)
    return rec


def environment() -> dict:
    env = dict(os.environ)
    env.update({"OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                "ROS_LOG_DIR": tempfile.mkdtemp(prefix="bkabem_bench_ros_log_")})
    env.pop("PYTHONPATH", None)
    return env


# --------------------------------------------------------------------------- rendering
def render_area(area: str, records: dict) -> str:
    title, refs = AREAS[area]
    rows, notes, tags = [], [], {}
    for ref in refs:
        name = ref.split(":")[0]
        rec = records.get(name)
        if rec is None:
            notes.append(f"- `{name}`: not measured yet (`.venv/bin/python bench/run_all.py --areas {area}`).")
            continue
        tag = tags.setdefault(name, f"[{len(tags) + 1}]")
        if "error" in rec:
            rows.append({"case": f"step `{name}`", "quantity": "failed", "value": None, "fmt": "", "note": rec["error"],
                         "by": tag})
        elif "not_run" in rec:
            rows.append({"case": f"step `{name}`", "quantity": rec["not_run"], "value": None, "fmt": "", "by": tag})
        else:
            rows += [dict(r, by=tag) for r in rec["rows"].get(ref, [])]
    for name, tag in tags.items():
        rec = records[name]
        if "not_run" in rec:
            notes.append(f"- {tag} `{rec['command']}`: {rec['not_run']}")
            continue
        m = rec["machine"]
        mach = f"{m.get('cpu')}, {m.get('cores')} cores" + (f" ({m['simd']})" if m.get("simd") else "") + \
               (f", {m['memory_gb']} GB" if m.get("memory_gb") else "")
        soft = f"Python {m.get('python')}" + (f", numpy {m['numpy']}" if m.get("numpy") else "")
        notes.append(f"- {tag} `{rec['command']}` — {mach}; {soft}; load average {rec['load'][0]:.1f} → "
                     f"{rec['load'][-1]:.1f}; {rec['date']}, code {rec['commit']}, {rec['duration_s']:.0f} s")
    out = ["| case | quantity | value | target | met | by |", "|---|---|---|---|---|---|"]
    for r in rows:
        met = {True: "yes", False: "**no**", None: ""}[r.get("met")] if "target" in r else ""
        cells = [r["case"], r["quantity"], shown(r), r.get("target", ""), met, r["by"]]
        out.append("| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |")    # "|" inside a cell
    return "\n".join(out) + "\n\n" + "\n".join(notes)


def render(records: dict) -> str:
    text = TEMPLATE.read_text()
    for area in AREAS:
        key = "{{area:%s}}" % area
        if key in text:
            text = text.replace(key, render_area(area, records))
    return text


def load_records() -> dict:
    return json.loads(RECORDS.read_text()) if RECORDS.exists() else {}


def save_records(records: dict) -> None:
    RECORDS.write_text(json.dumps({k: records[k] for k in sorted(records)}, indent=1, ensure_ascii=False) + "\n")


# --------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--areas", default=None,
                    help=f"comma-separated areas to measure (default: all but {', '.join(sorted(OPTIONAL))}); "
                         f"one of {', '.join(AREAS)}")
    ap.add_argument("--list", action="store_true", help="list the areas, steps and commands, and stop")
    ap.add_argument("--render", action="store_true", help="only rewrite BENCHMARKS.md from bench/records.json")
    ap.add_argument("--data-dir", default=os.environ.get(DATA_ENV) or None,
                    help=f"folder of measured CWRU records for the realism area (default: ${DATA_ENV}); without "
                         "one its steps are not run")
    args = ap.parse_args(argv)
    if args.data_dir and not Path(args.data_dir).is_dir():
        print(f"run_all: --data-dir: {args.data_dir}: not a folder", file=sys.stderr)
        return 2
    areas = [a for a in AREAS if a not in OPTIONAL] if args.areas is None else \
        [a.strip() for a in args.areas.split(",") if a.strip()]
    unknown = [a for a in areas if a not in AREAS]
    if unknown:
        print(f"run_all: --areas: unknown area {unknown[0]!r}; the areas are {', '.join(AREAS)}", file=sys.stderr)
        return 2
    steps = steps_of(areas)
    if args.list:
        for a, (title, refs) in AREAS.items():
            print(f"{a:11s} {title}" + ("  [optional]" if a in OPTIONAL else ""))
            for ref in refs:
                s = step_by_name(ref.split(":")[0])
                print(f"    {s.name:13s} ~{s.estimate_s:4.0f} s  {shown_command(s.argv)}")
        return 0
    records = load_records()
    failed = []
    if not args.render:
        from tqdm import tqdm

        if not args.data_dir:
            for s in [s for s in steps if s.needs_data]:
                steps.remove(s)
                if s.name not in records or "not_run" in records[s.name]:   # a measurement made before stays
                    records[s.name] = {"step": s.name, "command": shown_command(s.argv),
                                       "not_run": f"not run: no data folder (--data-dir or ${DATA_ENV})"}
                print(f"{s.name}: not run: no data folder (--data-dir or ${DATA_ENV})")
        total = sum(s.estimate_s for s in steps)
        print(f"bench/run_all.py: {len(steps)} steps of {', '.join(areas)}, about {total / 60:.0f} min on 2 cores; "
              f"logs and raw JSON in {RESULTS.relative_to(ROOT)}/", flush=True)
        env = environment()
        with tqdm(total=total, unit="s", bar_format="{desc:<13} {percentage:3.0f}%|{bar}| {elapsed} < ~{remaining}",
                  dynamic_ncols=True) as bar:
            for s in steps:
                bar.set_description_str(s.name)
                rec = run_step(s, bar, env, args.data_dir)
                records[s.name] = rec
                save_records(records)                 # a step's record is kept even if a later one hangs
                if "error" in rec:
                    failed.append(s.name)
                    tqdm.write(f"{s.name}: FAILED: {rec['error']}")
                else:
                    tqdm.write(f"{s.name}: {sum(len(r) for r in rec['rows'].values())} rows in "
                               f"{rec['duration_s']:.0f} s")
    OUTPUT.write_text(render(records))
    print(f"wrote {OUTPUT.relative_to(ROOT)}" + (f"; failed steps: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
