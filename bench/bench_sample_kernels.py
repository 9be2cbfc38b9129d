"""The synthesiser's sample-rate kernels: sensor noise, broadband floor, line-set rows, per 0.1-s chunk.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_sample_kernels.py            # kernels, best of --repeat
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_sample_kernels.py --chunks motor_6010_ball --seconds 20

Kernels (8 channels at 51.2 kHz, 5120 samples = one 0.1-s chunk): ``noise_add`` (x + sigma z of a chunk),
``floor_render`` (the broadband floor of ``motor_6010_healthy``), and the line-set kernel
(``FusedLines.segment``: phases, slip offsets and samples) on one blended 5120-sample segment of the inner race's
and the ball's line sets at 25 Hz with 1 % slip, no noise. ``--chunks CASE``: bench_faults' synthesis loop with
slip 1 % and noise (a new speed every chunk) for one case, us per chunk.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "bench"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import numpy as np  # noqa: E402

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402
from bkabem_core.synth import kernel as sk  # noqa: E402
from bkabem_core.synth.synthesizer import Synthesizer  # noqa: E402

FS, M = 51200.0, 5120
NOISE = {"acceleration": 1e-3, "displacement": 1e-10}


def best_us(fn, calls: int, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for k in range(calls):
            fn(k)
        times.append((time.perf_counter() - t0) / calls * 1e6)
    return min(times)


def blended_segment(case: str):
    """A synthesiser of ``case`` (1 % slip) and the knots of a blended segment of 5120 samples of it."""
    s = Synthesizer(BkaBem(Case.load(case)), sample_rate_hz=FS, chunk_s=0.1, slip=0.01)
    for v in (25.0, 25.3):
        s.next_chunk(v)
    a, b = s._stream.knots[-2:]
    return s, a, b


def kernels(repeat: int) -> None:
    key = 12345
    x, sig = np.zeros((M, 8), np.float32), np.ones(8, np.float32)
    print(f"noise_add         {best_us(lambda k: sk.noise_add(x, key, k * M, sig), 500, repeat):8.1f} us per chunk")
    s = Synthesizer(BkaBem(Case.load("motor_6010_healthy")), sample_rate_hz=FS, chunk_s=0.1, seed=5)
    fl = s.floor
    grains = [fl.grains(k * M, M).copy() for k in range(300)]
    out = np.empty((M, 8), np.float32)

    def floor(k):
        sk.floor_render(k * M, M, fl.half, fl.frames, fl.window, grains[k], out, fl.scale)

    print(f"floor_render      {best_us(floor, 300, repeat):8.1f} us per chunk")
    for case in ("motor_6010_inner", "motor_6010_ball"):
        s, a, b = blended_segment(case)
        lines, walk, off = s._plan.lines_kernel, s._stream.walk, s._plan.dc_off
        acc = sk.new_acc(8)
        us = best_us(lambda k: lines.segment(a, b, a.x, a.x + M, out, acc, off, walk, None), 200, repeat)
        print(f"lines segment     {us:8.1f} us per blended segment of {M} samples, {case}")


def chunks(case: str, seconds: float) -> None:
    from bench_synth import speeds_random_walk

    s = Synthesizer(BkaBem(Case.load(case)), sample_rate_hz=FS, chunk_s=0.1, slip=0.01, noise_density=NOISE)
    s.prepare()
    for v in np.linspace(20.0, 30.0, 41):
        s.next_chunk(float(v))
    s.reset()
    speeds = speeds_random_walk(int(round(seconds / 0.1)), seed=0)
    t0 = time.perf_counter()
    for v in speeds:
        s.next_chunk(v)
    dt = time.perf_counter() - t0
    print(f"{case}: {1e6 * dt / len(speeds):.0f} us per 0.1-s chunk with slip 1 % + noise ({seconds / dt:.0f}x)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--chunks", default=None, metavar="CASE", help="time the synthesis loop of CASE instead")
    ap.add_argument("--seconds", type=float, default=20.0, help="signal seconds for --chunks")
    a = ap.parse_args()
    if not sk.AVAILABLE:
        sys.exit("the C kernels are not built")
    if a.chunks:
        chunks(a.chunks, a.seconds)
    else:
        kernels(a.repeat)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
