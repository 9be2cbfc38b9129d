"""Preparation and new-speed cost of BKA-BEM per defect kind, this checkout against a baseline checkout, same run.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_preparation.py --baseline DIR --repeat 5
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_preparation.py --repeat 1 --improved --json out.json

Each measurement is a fresh process (``python -c`` with ``PYTHONPATH`` set to the checkout, the compiled kernels
of this checkout's build copied in if the baseline has none), the two checkouts alternating, so that both see the
same machine load. Per case: ``BkaBem(case)`` wall and CPU time (process time: both worker threads), its stages
(``preparation_time_s``), the line-mode statistics, and ``model.response([f])`` at 200 random speeds in 5-75 Hz
(median). Medians over ``--repeat``; the ratio baseline / this checkout (without ``--baseline``: this checkout
only). ``inner+ball``: two moving defects at
once (``validate_kinds.kind_case``: the inner-race case with the ball defect in the NDE bearing). ``--improved``
also times, in this checkout, ``HillCorrection`` of the model without baseline (preparation, spectrum at 5 speeds
in 15-50 Hz, median).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = ("electric_motor_6010", "motor_6010_healthy", "motor_6010_outer", "motor_6010_inner", "motor_6010_ball",
         "inner+ball")

SNIPPET = r"""
import json, time, numpy as np
from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem
if "+" in {name!r}:                        # several defects: built by this checkout's bench/validate_kinds.py
    import sys
    sys.path.insert(0, {bench!r})
    from validate_kinds import kind_case
    case = kind_case({name!r})
else:
    case = Case.load({name!r})
t0, c0 = time.perf_counter(), time.process_time()
m = BkaBem(case)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
rng = np.random.default_rng(1)
ts = []
for f in rng.uniform(5.0, 75.0, 200):
    t = time.perf_counter(); m.response([f]); ts.append(time.perf_counter() - t)
lm = m._line_modes
hill = None
if {improved!r}:
    try:
        from bkabem_core.solve.improved import HillCorrection
        plain = BkaBem(case, baseline=False, like=m)      # the same machine and line modes, no baseline lines
        t = time.perf_counter(); h = HillCorrection(plain); hp = time.perf_counter() - t
        hs = []
        for f in (15.0, 22.0, 30.0, 41.0, 50.0):
            t = time.perf_counter(); h.spectrum(f); hs.append(time.perf_counter() - t)
        hill = {{"preparation_s": hp, "spectrum_ms": 1e3 * float(np.median(hs)), "method": h.method}}
    except (ValueError, TypeError) as exc:
        hill = {{"error": str(exc)[:80]}}
print(json.dumps({{"wall_s": wall, "cpu_s": cpu, "parts": m.preparation_time_s, "lines": len(m.lines),
                  "new_speed_us": 1e6 * float(np.median(ts)),
                  "stats": getattr(lm, "stats", None), "hill": hill}}))
"""


def run(tree: Path, name: str, improved: bool = False) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    code = SNIPPET.format(name=name, improved=improved, bench=str(ROOT / "bench"))
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=str(tree), capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, default=None, help="another checkout (e.g. git archive of main)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--improved", action="store_true",
                    help="also time the improved method (HillCorrection of the model without baseline), this checkout")
    args = ap.parse_args(argv)
    base = args.baseline.resolve() if args.baseline else None
    for so in (ROOT / "bkabem_core").rglob("*.so") if base else ():     # the same compiled kernels in both
        dst = base / so.relative_to(ROOT)
        if dst.parent.is_dir() and not dst.exists():
            shutil.copy2(so, dst)
    trees = ((("baseline", base),) if base else ()) + (("this", ROOT),)
    results = {}
    for name in args.cases.split(","):
        runs = {label: [] for label, _ in trees}
        for _ in range(args.repeat):
            for label, tree in trees:
                runs[label].append(run(tree, name, args.improved and label == "this"))
        results[name] = runs
        med = {k: {q: statistics.median(r[q] for r in v) for q in ("wall_s", "cpu_s", "new_speed_us")}
               for k, v in runs.items()}
        st = runs["this"][-1]["stats"] or {}
        part = {k: {q: statistics.median(r["parts"].get(q, 0.0) for r in v) for q in ("excitation", "solver_setup")}
                for k, v in runs.items()}
        hills = [r["hill"] for r in runs["this"] if r.get("hill") and "preparation_s" in r["hill"]]
        hill_txt = (f" | improved ({hills[0]['method']}): preparation "
                    f"{statistics.median(h['preparation_s'] for h in hills):.2f} s, spectrum "
                    f"{statistics.median(h['spectrum_ms'] for h in hills):.1f} ms" if hills else "")
        b = med.get("baseline", med["this"])                     # without a baseline: "x -> x", ratio 1
        pb = part.get("baseline", part["this"])
        print(f"{name}: {runs['this'][0]['lines']} lines | preparation wall {b['wall_s']:.2f} -> "
              f"{med['this']['wall_s']:.2f} s ({b['wall_s'] / med['this']['wall_s']:.2f}x), cpu "
              f"{b['cpu_s']:.2f} -> {med['this']['cpu_s']:.2f} s | excitation / solver set-up "
              f"{pb['excitation']:.2f} / {pb['solver_setup']:.2f} -> "
              f"{part['this']['excitation']:.2f} / {part['this']['solver_setup']:.2f} s | new speed "
              f"{b['new_speed_us']:.0f} -> {med['this']['new_speed_us']:.0f} us | "
              f"line modes: {st.get('exact')} exact, {st.get('refined')} refined, "
              f"{st.get('sweeps_mean', 0):.1f} sweeps{hill_txt}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
