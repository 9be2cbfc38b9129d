"""Line-set path (issue 12): what a chunk and a knot cost besides the samples.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_line_knots.py --repeat 7

Per case, the synthesiser of bench_faults (8 channels at 51.2 kHz, float32, slip 1 % + accelerometer and probe
noise, features on, after ``prepare()`` and one pass over 20-30 Hz):

chunk overhead  ``next_chunk(v, n_samples=64)`` with a new speed every call (bench_synth's random walk in 20-30 Hz,
                400 calls): everything a 0.1-s chunk costs but its samples (the speed check, the knot with its
                spectrum and tables, the segment's phases and slip window, the features and ISO velocity, the
                chunk's metadata) plus 64 samples; median of ``--repeat`` [us per call]
knot            ``_amplitudes`` of a new speed: speed cells -> channel amplitudes -> tables [us]
ctypes tables   for comparison, the families' tables alone by ``synth_kernel.family_tables`` from the same
                amplitudes (the path before the one-call knot) [us]

Times are CPU time of this process (``time.process_time``: steadier than wall time on shared cores).
``electric_motor_6010`` (the order path) is the in-run reference.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "bench"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import numpy as np  # noqa: E402
from bench_synth import speeds_random_walk  # noqa: E402

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402
from bkabem_core.synth import kernel as synth_kernel  # noqa: E402
from bkabem_core.synth.synthesizer import Synthesizer  # noqa: E402

CASES = ("electric_motor_6010", "motor_6010_healthy", "motor_6010_outer", "motor_6010_inner", "motor_6010_ball")
NOISE = {"acceleration": 1e-3, "displacement": 1e-10}


def _per_call(fn, args, repeat: int) -> float:
    """Median over ``repeat`` passes of the CPU time per call of fn over ``args`` [us]."""
    out = []
    for _ in range(repeat):
        t0 = time.process_time()
        for a in args:
            fn(a)
        out.append((time.process_time() - t0) / len(args) * 1e6)
    return statistics.median(out)


def bench_case(name: str, repeat: int) -> dict:
    model = BkaBem(Case.load(name))
    s = Synthesizer(model, sample_rate_hz=51200.0, chunk_s=0.1, slip=0.01, noise_density=NOISE)
    s.prepare()
    for v in np.linspace(20.0, 30.0, 41):
        s.next_chunk(float(v))
    speeds = speeds_random_walk(400, seed=1)

    def stream(_):
        s.reset()
        for v in speeds:
            s.next_chunk(v, n_samples=64)

    out = {"case": name, "chunk_overhead_us": _per_call(stream, [0], repeat) / len(speeds)}
    if s._general:
        f = np.random.default_rng(2).uniform(20.0, 30.0, 200).tolist()
        out["knot_us"] = _per_call(s._line_amplitudes, f, repeat)
        amp = s._line_amplitudes(24.3)
        plan = s._families.plan
        buf = np.empty(plan["rows"] * amp.y_emphasised.shape[1], dtype=np.float32)
        work = np.empty(2 * plan["max_n"] * amp.y_emphasised.shape[1])
        out["ctypes_tables_us"] = _per_call(lambda _: synth_kernel.family_tables(amp.y_emphasised, plan, buf, work),
                                            range(200), repeat)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--cases", default=",".join(CASES))
    args = ap.parse_args(argv)
    rows = [bench_case(c, args.repeat) for c in args.cases.split(",")]
    print(f"load {os.getloadavg()[0]:.1f}")
    print("| case | chunk overhead [us] | knot [us] | tables by ctypes family_tables [us] |")
    print("|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r['case']} | {r['chunk_overhead_us']:.0f} | {r.get('knot_us', float('nan')):.0f} | "
              f"{r.get('ctypes_tables_us', float('nan')):.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
