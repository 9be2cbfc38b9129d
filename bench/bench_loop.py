"""Sample loop and knot table of the synthesiser: the C kernels of bkabem_core/kernels/_synthloop.c against the code they
replaced, measured in the same run.

The old code is built from git (``--old-ref``, default the commit before the computed spline weights, the fast path
and the knot table): its ``_synthloop.c`` compiled into a temporary directory with the flags of setup.py and its
``synth_kernel.py`` loaded against that library, so the old numbers include the old wrapper. Old and new calls
alternate in one loop (the machine is shared and noisy: both see the same noise); medians of ``--repeat`` calls.

    cd /work/main && OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_loop.py
    .venv/bin/python bench/bench_loop.py --repeat 5000 --old-ref HEAD~3

Cases
-----
segment         5120 samples x 8 channels float32 (0.1 s at 51.2 kHz), N = 512, time blend on (a new speed every
                chunk), without / with the fused feature moments, and without the blend; per call through the Python
                wrapper (``synth_kernel.segment``), and the new generic path (``exact=True``, bit for bit the numpy
                reference) beside the fast one; "new" with numpy's 16-byte aligned arrays (a 32-byte row straddles a
                cache line every other row), "aligned" with 64-byte aligned tables and output (``empty_aligned``)
knot table      K = 50 orders, C = 8 channels, N = 512, float32 table: ``synth_kernel.knot_table`` against the numpy
                code of ``Synthesizer._amplitudes`` it replaces (channel factor, amplitudes, float32 GEMM with the
                (N + 3) x (2K + 1) basis), alternating (each evicts the other's basis from L1/L2: the cold case) and
                each alone (warm caches, as between chunks of a stream whose other work fits in L2); both include
                the glue (scale, output arrays); the call alone last
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import sysconfig
import tempfile
import time
import types
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bkabem_core.synth import kernel as sk  # noqa: E402

OLD_REF = "0835588886be0b299f596faa62471cd2f302f5c9"     # 12-bit weight table, ctypes wrapper, numpy table build


def build_old(ref: str, tmp: Path):
    """The synth_kernel module of git ``ref`` bound to its _synthloop.c, compiled into ``tmp`` (flags of setup.py)."""
    src = subprocess.run(["git", "show", f"{ref}:bkabem_core/kernels/_synthloop.c"], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    py = subprocess.run(["git", "show", f"{ref}:bkabem_core/synth/kernel.py"], cwd=ROOT, check=True,
                        capture_output=True, text=True).stdout
    (tmp / "_synthloop_old.c").write_text(src)
    so = tmp / "_synthloop_old.so"
    subprocess.run(["gcc", "-O3", "-std=c99", "-ffp-contract=off", "-shared", "-fPIC",
                    "-I" + sysconfig.get_paths()["include"], str(tmp / "_synthloop_old.c"), "-o", str(so), "-lm"],
                   check=True)
    needle = 'importlib.util.find_spec("bkabem_core.kernels._synthloop")'
    if needle not in py:
        raise SystemExit(f"{ref}: synth_kernel.py does not load the kernel as expected")
    mod = types.ModuleType("old_synth_kernel")
    mod.__dict__["_OLD_SPEC"] = types.SimpleNamespace(origin=str(so))
    exec(compile(py.replace(needle, "_OLD_SPEC"), f"{ref}:synth_kernel.py", "exec"), mod.__dict__)
    if not mod.AVAILABLE:
        raise SystemExit("the old kernel did not load")
    return mod


def alternate(fns, repeat: int):
    """Median seconds per call of each function, called in turn ``repeat`` times (after a warm-up)."""
    for f in fns:
        for _ in range(50):
            f()
    times = [[] for _ in fns]
    clock = time.perf_counter
    for _ in range(repeat):
        for f, t in zip(fns, times):
            t0 = clock()
            f()
            t.append(clock() - t0)
    return [float(np.median(t)) for t in times]


def segment_cases(old, repeat: int):
    rng = np.random.default_rng(1)
    m, c, n = 5120, 8, 512
    ta = sk.pad_coefficients(rng.standard_normal((n, c))).astype(np.float32)
    tb = sk.pad_coefficients(rng.standard_normal((n, c))).astype(np.float32)
    ta_al, tb_al = sk.empty_aligned(ta.shape), sk.empty_aligned(tb.shape)      # the same tables, 64-byte aligned
    ta_al[...], tb_al[...] = ta, tb
    d0 = int(25.0 * 4.9 / 51200 * sk.PASS_UNITS)            # ~25 Hz shaft, BPFO ~4.9 x: ~1.2 table steps per sample
    args = (12345678901234567, d0, 1 << 20)
    off = rng.standard_normal(c)
    out_old, out_new = np.empty((m + 2, c), np.float32)[2:], np.empty((m + 2, c), np.float32)[2:]
    if out_new.ctypes.data % 32 == 0:                       # numpy's 16-byte alignment, as a chunk buffer gets it
        out_old, out_new = np.empty((m + 3, c), np.float32)[2:-1], np.empty((m + 3, c), np.float32)[2:-1]
    out_al = sk.empty_aligned((m, c))
    rows = []
    for name, blend, feats in (("blend, no features", True, False), ("blend, features", True, True),
                               ("no blend, no features", False, False), ("no blend, features", False, True)):
        b, b_al = (tb, tb_al) if blend else (None, None)

        def f_old():
            old.segment(*args, None, ta, b, 100.0, 65536.0 / 5120.0, out_old,
                        old.new_acc(c) if feats else None, off)

        def f_new():
            sk.segment(*args, None, ta, b, 100.0, 65536.0 / 5120.0, out_new, sk.new_acc(c) if feats else None, off)

        def f_aligned():
            sk.segment(*args, None, ta_al, b_al, 100.0, 65536.0 / 5120.0, out_al, sk.new_acc(c) if feats else None,
                       off)

        def f_exact():
            sk.segment(*args, None, ta, b, 100.0, 65536.0 / 5120.0, out_new, sk.new_acc(c) if feats else None, off,
                       exact=True)

        rows.append((name, *alternate([f_old, f_new, f_aligned, f_exact], repeat)))
    # the wrapper alone: one sample
    one_old, one_new = np.empty((1, c), np.float32), np.empty((1, c), np.float32)
    w_old, w_new = alternate([lambda: old.segment(*args, None, ta, tb, 100.0, 12.8, one_old),
                              lambda: sk.segment(*args, None, ta, tb, 100.0, 12.8, one_new)], repeat)
    return rows, (w_old, w_new)


def knot_case(repeat: int):
    """knot_table against the numpy code of Synthesizer._amplitudes (as of the old ref)."""
    rng = np.random.default_rng(2)
    k_n, c, n, u = 50, 8, 512, 16
    orders = np.arange(1, k_n + 1)
    kk = orders.astype(float)
    power = np.array([2, 2, 2, 2, 0, 0, 0, 0])
    scale0 = rng.uniform(0.5, 2.0, c)
    emphasis = 1.0 / np.sinc(kk / n) ** 4
    chan_factor = (1j * kk[:, None]) ** power[None, :] * scale0[None, :] * emphasis[:, None]
    cindex = np.array([0, 1, 2, 3, 4, 5, 6, 7], dtype=np.int64)
    dc = rng.standard_normal(c) * (power == 0)
    x = (rng.standard_normal((k_n, u)) + 1j * rng.standard_normal((k_n, u))) * 1e-6
    th = 2 * np.pi * (np.arange(n + 3) - 1) / n
    basis_np = np.ascontiguousarray(np.concatenate(
        [np.cos(np.outer(th, kk)), -np.sin(np.outer(th, kk)), np.ones((n + 3, 1))], axis=1).astype(np.float32))
    coef = np.zeros((2 * k_n + 1, c), dtype=np.float32)
    coef[-1] = dc
    qb = sk.quarter_basis(orders, n)
    chan_power = power.astype(float)
    f, bpfo, fade = 25.0, 4.9, 1.0

    def f_numpy():
        fac = chan_factor * ((2 * np.pi * bpfo * f) ** chan_power * fade)
        yc = x[:, cindex]
        yc *= fac
        coef[:k_n] = yc.real
        coef[k_n:2 * k_n] = yc.imag
        return basis_np @ coef

    def f_c():
        scale = (2 * np.pi * bpfo * f) ** chan_power * fade
        return sk.knot_table(x, cindex, chan_factor, scale, None, dc, qb, np.empty((n + 3, c), np.float32),
                             np.empty((k_n, c), complex))

    scale_k, tab_k, y_k = (2 * np.pi * bpfo * f) ** chan_power * fade, np.empty((n + 3, c), np.float32), \
        np.empty((k_n, c), complex)

    def f_kernel():                                              # the call alone: outputs and scale made already
        sk.knot_table(x, cindex, chan_factor, scale_k, None, dc, qb, tab_k, y_k)

    t_np, t_c = alternate([f_numpy, f_c], repeat)              # each evicts the other's data from the caches
    (t_np_alone,), (t_c_alone,) = alternate([f_numpy], repeat), alternate([f_c], repeat)     # warm caches
    (t_kernel,) = alternate([f_kernel], repeat)
    err = np.abs(f_c()[0] - f_numpy()).max() / np.abs(f_numpy()).max()
    return (t_np, t_c), (t_np_alone, t_c_alone), t_kernel, err


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3000, help="calls per case and code (median)")
    ap.add_argument("--old-ref", default=OLD_REF, help="git ref of the old code")
    opts = ap.parse_args()
    if not sk.AVAILABLE:
        raise SystemExit("the kernel is not built: pip install -e .")
    with tempfile.TemporaryDirectory() as tmp:
        old = build_old(opts.old_ref, Path(tmp))
        rows, (w_old, w_new) = segment_cases(old, opts.repeat)
        (t_np, t_c), (t_np1, t_c1), t_kernel, err = knot_case(opts.repeat)
    us = 1e6
    print(f"fast path (AVX2 + FMA, 8 x float32): {'yes' if sk.FAST_PATH else 'no'}; median of {opts.repeat} calls")
    print(f"{'segment 5120 x 8 float32':<34}{'old us':>9}{'new us':>9}{'old/new':>9}{'aligned us':>12}"
          f"{'old/aligned':>13}{'generic us':>12}")
    for name, t_old, t_new, t_al, t_exact in rows:
        print(f"  {name:<32}{t_old * us:9.1f}{t_new * us:9.1f}{t_old / t_new:9.2f}{t_al * us:12.1f}"
              f"{t_old / t_al:13.2f}{t_exact * us:12.1f}")
    print(f"  {'wrapper (1 sample, blend)':<32}{w_old * us:9.2f}{w_new * us:9.2f}{w_old / w_new:9.2f}")
    print(f"{'knot table K=50 C=8 N=512 float32':<34}{'numpy us':>9}{'C us':>9}{'ratio':>9}")
    print(f"  {'alternating':<32}{t_np * us:9.1f}{t_c * us:9.1f}{t_np / t_c:9.2f}")
    print(f"  {'each alone (warm caches)':<32}{t_np1 * us:9.1f}{t_c1 * us:9.1f}{t_np1 / t_c1:9.2f}"
          f"   (max |diff| / max |table| = {err:.1e}: the numpy code's float32 GEMM)")
    print(f"  {'knot_table call alone':<32}{'':9}{t_kernel * us:9.1f}   (outputs allocated and scale computed before)")


if __name__ == "__main__":
    main()
