"""A machine in minutes: the cost of a catalogue machine written in the compact form, from its file to its spectra.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_machine.py --repeat 3
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_machine.py --repeat 1 --json out.json

Each machine is a starting case of ``bkabem case new`` (``bkabem_core.model.starting``: two catalogue bearings, a
rotor mass, a speed range) with a defect, the embedded ``small_motor_6205_outer``, or a rig twin (``mfpt_rig``,
``cwru_rig``) with a round pit in its drive-end bearing; each measurement is a fresh
process. Per machine: ``Case.from_toml`` (the compact form expanded, validated, each bearing linearised for its FE
bearing keys), ``Machine`` (the FE converged up to the band) and ``BkaBem(case)`` (wall and CPU time), the number
of lines, and a new speed, ``model.response([f])`` and ``model.spectrum(f)``, at 200 random speeds of the speed
range (median and 95th percentile). Medians over ``--repeat``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: name -> (DE, NDE, rotor mass [kg], speed range [Hz], defect kind in the DE bearing, max_order), None for the
#: embedded case of that name, or (an embedded rig case, its speed range [Hz], the kind of a 21 mil round pit in its DE
#: bearing)
MACHINES = {
    "small_motor_6205_outer": None,
    "mfpt_rig, DE outer pit": ("mfpt_rig", (5.0, 30.0), "outer"),
    "mfpt_rig, DE inner pit": ("mfpt_rig", (5.0, 30.0), "inner"),
    "cwru_rig, DE inner pit": ("cwru_rig", (5.0, 30.0), "inner"),
    "6205+6203 12 kg, DE outer": ("6205", "6203", 12.0, (5.0, 60.0), "outer", 50),
    "6010+6010 82 kg, DE outer": ("6010", "6010", 82.0, (5.0, 75.0), "outer", 50),
    "6205+6205 12 kg, DE inner": ("6205", "6205", 12.0, (5.0, 60.0), "inner", 50),
    "6205+6205 12 kg, DE ball": ("6205", "6205", 12.0, (5.0, 60.0), "ball", 40),
}

SNIPPET = r"""
import json, time, numpy as np
from bkabem_core.model.case import Case
from bkabem_core.model.starting import starting_case
from bkabem_core.fe.machine import Machine
from bkabem_core.solve.harmonic import BkaBem
spec = {spec!r}
if spec is None:
    from importlib import resources
    text = resources.files("bkabem_core.embedded").joinpath("cases", {name!r} + ".toml").read_text()
    lo, hi = 5.0, 50.0
elif len(spec) == 3:
    from importlib import resources
    rig, (lo, hi), kind = spec
    text = resources.files("bkabem_core.embedded").joinpath("cases", rig + ".toml").read_text()
    text = text.replace("defects = []", "", 1).replace("schema_version = 4\n", "schema_version = 4\n\n[[defects]]\n"
                        "bearing = \"de\"\nrace = \"" + kind + "\"\nlength_m = 5.33e-4\ndepth_m = 2.79e-4\n"
                        "angle_deg = -90.0\nedge = \"ball\"\nshape = \"round_pit\"\nedge_fraction = 0.1\n", 1)
else:
    de, nde, mass, (lo, hi), kind, max_order = spec
    text = starting_case(de, nde, mass, (lo, hi), "bench_machine", slices=24)
    bearing = "de"
    extra = {{"outer": "", "inner": "", "ball": "ball = 1\n"}}[kind]
    length = 1.5e-3 if kind == "ball" else 2.0e-3
    text = text.replace("defects = []", "")
    text = text.replace("schema_version = 4\n", "schema_version = 4\n\n[[defects]]\nbearing = \"" + bearing +
                        "\"\nrace = \"" + kind + "\"\nlength_m = " + repr(length) + "\ndepth_m = 30.0e-6\n"
                        "angle_deg = -90.0\nedge = \"ball\"\nedge_fraction = 0.1\n" + extra, 1)
    text = text.replace("max_order = 50 ", "max_order = " + str(max_order) + " ", 1)
t0 = time.perf_counter(); case = Case.from_toml(text, "bench"); t_case = time.perf_counter() - t0
t0 = time.perf_counter(); machine = Machine(case); t_machine = time.perf_counter() - t0
t0, c0 = time.perf_counter(), time.process_time()
m = BkaBem(case, machine=machine)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
rng = np.random.default_rng(1)
speeds = rng.uniform(lo, hi, 200)
tr, ts = [], []
for f in speeds:
    t = time.perf_counter(); m.response([f]); tr.append(time.perf_counter() - t)
for f in speeds:
    t = time.perf_counter(); m.spectrum(f); ts.append(time.perf_counter() - t)
print(json.dumps({{"case_s": t_case, "machine_s": t_machine, "prep_s": wall, "prep_cpu_s": cpu,
                  "dof": machine.rotor.ndof, "lines": int(len(m.frequency_hz(hi))), "solver": m.solver,
                  "response_ms": 1e3 * float(np.median(tr)), "response_p95_ms": 1e3 * float(np.percentile(tr, 95)),
                  "spectrum_ms": 1e3 * float(np.median(ts)), "spectrum_p95_ms": 1e3 * float(np.percentile(ts, 95))}}))
"""


def run_one(name: str, spec) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", SNIPPET.format(name=name, spec=spec)], env=env, cwd=ROOT,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None, help="write the medians here")
    args = ap.parse_args()
    results = {}
    for name, spec in MACHINES.items():
        runs = [run_one(name, spec) for _ in range(args.repeat)]
        med = {k: statistics.median(r[k] for r in runs) if isinstance(v, float) else v for k, v in runs[0].items()}
        results[name] = med
        print(f"{name:40s} case {med['case_s'] * 1e3:6.1f} ms  machine {med['machine_s'] * 1e3:6.1f} ms  "
              f"BkaBem {med['prep_s']:5.2f} s (cpu {med['prep_cpu_s']:5.2f} s)  {med['dof']} DOF  "
              f"{med['lines']:4d} lines  response {med['response_ms']:.3f} ms (p95 {med['response_p95_ms']:.3f})  "
              f"spectrum {med['spectrum_ms']:.3f} ms (p95 {med['spectrum_p95_ms']:.3f})", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
