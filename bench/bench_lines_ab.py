"""A/B of the line-set kernel (``lines_render``) in one process, for a machine too noisy for separate runs.

    flock /work/notes/bench.lock .venv/bin/python bench/bench_lines_ab.py --code /tmp/main_checkout
    .venv/bin/python bench/bench_lines_ab.py --code DIR --kinds inner --passes 9

A run's ``lines_render`` calls are recorded (this checkout's extension, its arguments copied), then replayed
alternately through this checkout's extension (A) and the one built in ``--code DIR`` (B; loaded side by side under
the same module name from its own file), CPU time summed per pass, the order of A and B swapped every pass; the
outputs of A and B are compared bit for bit. Cases per kind (``motor_6010_<kind>``, slip 1 % + sensor noise +
broadband floor): ``C4`` the data set's acc4 (4 accelerations at 25.6 kHz, 1-s chunks, constant speed 25 Hz, no
features) and ``C8`` the streaming benchmark's (8 channels at 51.2 kHz, 0.1-s chunks, a new speed every chunk:
the knots' blend, features on). The Python side (phases, knots) is this checkout's for both: only the C kernel is
compared. Prints ns per sample (all channels) of A and B, median (min) over the passes, and A / B.
"""

from __future__ import annotations

import argparse
import glob
import importlib.machinery
import importlib.util
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
from bkabem_core.synth import lineknots as synth_lineknots
from bkabem_core.synth.synthesizer import Synthesizer  # noqa: E402


def load_extension(code: str):
    """The ``_synthloop`` extension built in checkout ``code``, as a module object of its own."""
    so = sorted(glob.glob(str(Path(code) / "bkabem_core" / "_synthloop*.so")))
    if not so:
        sys.exit(f"--code: no built _synthloop extension in {code}/bkabem_core")
    loader = importlib.machinery.ExtensionFileLoader("bkabem_core.kernels._synthloop", so[0])
    spec = importlib.util.spec_from_file_location("bkabem_core.kernels._synthloop", so[0], loader=loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


def _copy(x):
    if isinstance(x, np.ndarray):
        return x.copy()
    if isinstance(x, tuple):
        return tuple(_copy(y) for y in x)
    return x


class _Recorder:
    """Stands in for the extension in synth_lineknots: renders as it, and keeps a copy of every lines_render call."""

    def __init__(self, ext):
        self.ext, self.calls = ext, []

    def __getattr__(self, name):
        return getattr(self.ext, name)

    def lines_render(self, *args):
        self.ext.lines_render(*args)
        self.calls.append(tuple(_copy(a) for a in args))


def record(model, case: str, rec: _Recorder) -> list:
    rec.calls = []
    if case == "C4":
        s = Synthesizer(model, sample_rate_hz=25600.0, chunk_s=1.0, slip=0.01, seed=5, features=False,
                        quantities=("acceleration",), noise_density={"acceleration": 5e-4}, band_limit="taper")
        for _ in range(4):
            s.next_chunk(25.0)
    else:
        s = Synthesizer(model, sample_rate_hz=51200.0, chunk_s=0.1, slip=0.01, seed=5,
                        noise_density={"acceleration": 5e-4, "displacement": 1e-10})
        for v in speeds_random_walk(20, seed=1):
            s.next_chunk(v)
    return rec.calls


def replay(calls: list, a, b, passes: int):
    """(ns per sample of a per pass, of b, outputs equal)."""
    n = sum(c[1] for c in calls)
    ta, tb, same = [], [], True
    for p in range(passes):
        acc = {"a": 0.0, "b": 0.0}
        for c in calls:
            outs = {}
            for name, mod in ((("a", a), ("b", b)) if p % 2 == 0 else (("b", b), ("a", a))):
                args = list(c)
                args[17] = c[17].copy()                          # out
                if args[18] is not None:
                    args[18] = c[18].copy()                      # feature accumulators
                t0 = time.process_time()
                mod.lines_render(*args)
                acc[name] += time.process_time() - t0
                outs[name] = args[17]
            same &= np.array_equal(outs["a"].view(np.uint32), outs["b"].view(np.uint32))
        ta.append(acc["a"] / n * 1e9)
        tb.append(acc["b"] / n * 1e9)
    return ta, tb, same


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--code", required=True, help="checkout whose built extension is B")
    ap.add_argument("--kinds", default="inner,ball")
    ap.add_argument("--cases", default="C4,C8")
    ap.add_argument("--passes", type=int, default=7)
    args = ap.parse_args()
    if not synth_lineknots.AVAILABLE:
        sys.exit("the C line-set kernel is not built here")
    a, b = synth_kernel._EXT, load_extension(args.code)
    print(f"# A {a.__file__}\n# B {b.__file__}\n# load {os.getloadavg()[0]:.2f}")
    rec = _Recorder(a)
    synth_lineknots._EXT = rec
    try:
        for kind in args.kinds.split(","):
            model = BkaBem(Case.load(f"motor_6010_{kind}"))
            for case in args.cases.split(","):
                calls = record(model, case, rec)
                ta, tb, same = replay(calls, a, b, args.passes)
                ma, mb = statistics.median(ta), statistics.median(tb)
                print(f"{kind} {case}: A {ma:.1f} ({min(ta):.1f}) B {mb:.1f} ({min(tb):.1f}) ns/sample, A/B "
                      f"{ma / mb:.3f}, outputs {'equal' if same else 'DIFFER'} ({len(calls)} calls)", flush=True)
    finally:
        synth_lineknots._EXT = a
    print(f"# load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
