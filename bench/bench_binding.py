"""Call overhead of the two ways to bind a C kernel to Python: a CPython extension function (the arrays by the
buffer protocol, checked in C) and ctypes (the arrays' addresses as integers), for the same C function.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_binding.py [--calls 20000] [--repeat 7]

The kernel is the modal form's pole-residue sum (``bkabem_core/kernels/modalsum.c``, ``modal_sum8``: 9 arrays and
2 sizes) on one order of two poles, so that the call is nearly all binding. The extension is the built module
``bkabem_core.kernels._modalsum``; for ctypes the same source is compiled here into a plain shared library (needs a
C compiler). ctypes is timed as its best case (argtypes set, addresses taken once before the loop, as a caller
that keeps its arrays can do) and as a caller whose arrays are new per call (addresses taken per call). Also the
speed-cell evaluation (``cell_sum8``: a cell and an output array) both ways. Medians of ``--repeat`` passes [us per
call].
"""

from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bkabem_core.kernels import _modalsum  # noqa: E402


def per_call_us(fn, calls: int, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        times.append((time.perf_counter() - t0) / calls * 1e6)
    return statistics.median(times)


def ctypes_library(tmp: Path) -> ctypes.CDLL:
    so = tmp / "libmodalsum.so"
    subprocess.run(["cc", "-O3", "-std=c99", "-fPIC", "-shared", str(ROOT / "bkabem_core/kernels/modalsum.c"),
                    "-o", str(so)], check=True)
    lib = ctypes.CDLL(str(so))
    lib.modal_sum8.argtypes = [ctypes.c_int, ctypes.c_int] + [ctypes.c_void_p] * 9
    lib.modal_sum8.restype = ctypes.c_int
    return lib


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args()
    rng = np.random.default_rng(0)
    k, r = 1, 2
    w = rng.uniform(1.0, 2.0, k)
    lam_re, lam_im = -rng.uniform(1.0, 2.0, (k, r)), rng.uniform(1.0, 2.0, (k, r))
    e_re, e_im = rng.standard_normal((k, r, 8)), rng.standard_normal((k, r, 8))
    x0_re, x0_im = rng.standard_normal((k, 8)), rng.standard_normal((k, 8))
    x_re, x_im = np.empty((k, 8)), np.empty((k, 8))
    arrays = (w, lam_re, lam_im, e_re, e_im, x0_re, x0_im, x_re, x_im)
    with tempfile.TemporaryDirectory() as tmp:
        lib = ctypes_library(Path(tmp))
        fn = lib.modal_sum8
        ptrs = [arr.ctypes.data for arr in arrays]
        rows = {
            "extension (buffer protocol)": lambda: _modalsum.modal_sum(*arrays),
            "ctypes, addresses kept": lambda: fn(k, r, *ptrs),
            "ctypes, addresses per call": lambda: fn(k, r, *(arr.ctypes.data for arr in arrays)),
        }
        rows["ctypes, addresses kept"]()
        ref = x_re.copy(), x_im.copy()
        rows["extension (buffer protocol)"]()
        assert np.array_equal(x_re, ref[0]) and np.array_equal(x_im, ref[1])
        results = {name: per_call_us(f, a.calls, a.repeat) for name, f in rows.items()}
    print(f"modal_sum8 on {k} order x {r} poles (9 arrays, 2 sizes), us per call, median of {a.repeat}:")
    for name, us in results.items():
        print(f"  {name:32s} {us:6.2f}")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
