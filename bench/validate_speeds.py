"""The long validation: TDSM against every BKA-BEM variant at 14 speeds (10-75 Hz), every location, displacement
and acceleration; the TDSM's step study and settling times; the FE mesh study. Rewrites the generated tables of
docs/validation.md and docs/img/validation_*.png.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python3 bench/validate_speeds.py          # ~5 min on 2 cores
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python3 bench/validate_speeds.py --quick  # 3 speeds, no studies

Generated blocks in docs/validation.md sit between ``<!-- BEGIN name -->`` and ``<!-- END name -->``; the text
around them is written by hand and must be checked against the new numbers after a change. The raw numbers go
to out/validation/validation.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from docs_blocks import replace_block
from tqdm import tqdm

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case
from bkabem_core.model.vocabulary import LOCATIONS
from bkabem_core.reference.tdsm import Tdsm
from bkabem_core.reference.validation import N_LARGEST, QUANTITIES, plot_validation, validate
from bkabem_core.solve.harmonic import BkaBem

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "validation.md"
IMG = ROOT / "docs" / "img"
OUT = ROOT / "out" / "validation"
SPEEDS = (10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 70, 75)
METHODS = ("plain", "hill", "paper", "four_dof", "hbm")
DIRS = ("vertical", "horizontal")


def db(a, b):
    return 20.0 * np.log10(np.abs(a) / np.abs(b))


# --------------------------------------------------------------------------- tables
def summary_table(errs):
    """errs[method][quantity] -> array (speeds, 4 locations, 2 directions) of max |dB| over the 5 largest."""
    lines = ["| method | quantity | direction | median [dB] | worst [dB] | worst at |",
             "|---|---|---|---:|---:|---|"]
    for m in METHODS:
        for q in QUANTITIES:
            e = errs[m][q]
            for di, d in enumerate(DIRS):
                x = e[:, :, di]
                s, li = np.unravel_index(np.argmax(x), x.shape)
                lines.append(f"| {m} | {q} | {d} | {np.median(x):.2f} | {x.max():.2f} | "
                             f"{SPEEDS_RUN[s]} Hz, {LOCATIONS[li]} |")
    return "\n".join(lines)


def targets_table(errs, times):
    p, h = errs["plain"], errs["hill"]
    allp = np.stack([p[q] for q in QUANTITIES])
    allh = np.stack([h[q] for q in QUANTITIES])
    t_plain = np.median([t["plain_spectrum"] for t in times]) * 1e3
    t_hill = np.median([t["hill_spectrum"] for t in times]) * 1e3
    rows = [("plain method, median over speeds, locations, directions, both quantities", "<= 3 dB",
             f"{np.median(allp):.2f} dB"),
            ("plain method, worst", "<= 5 dB", f"{allp.max():.2f} dB"),
            ("improved method (hill), worst", "<= 1 dB", f"{allh.max():.2f} dB"),
            ("improved method, cost per new speed (median)", "<= 1 ms", f"{t_hill:.2f} ms (plain {t_plain:.3f} ms)")]
    lines = ["| target | required | result |", "|---|---|---|"]
    lines += [f"| {a} | {b} | **{c}** |" for a, b, c in rows]
    return "\n".join(lines)


def scan_table(errs):
    lines = ["| speed [Hz] | direction | plain disp. | plain acc. | hill disp. | hill acc. | paper disp. | "
             "paper acc. | four_dof disp. | four_dof acc. | hbm disp. | hbm acc. |",
             "|---:|---|" + "---:|" * 10]
    for s, f in enumerate(SPEEDS_RUN):
        for di, d in enumerate(DIRS):
            row = [f"{errs[m][q][s, :, di].max():.2f}" for m in METHODS for q in QUANTITIES]
            lines.append(f"| {f} | {d} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def detail_table(res):
    lines = []
    for li, loc in enumerate(LOCATIONS):
        for di, d in enumerate(DIRS):
            for q in QUANTITIES:
                big = res.largest_orders(li, di, q)
                unit, scale = ("nm", 1e9) if q == "displacement" else ("m/s^2", 1.0)
                lines.append(f"**{loc}, {d}, {q}** (the {N_LARGEST} largest TDSM orders; error in dB against "
                             "the TDSM)\n")
                lines.append(f"| order | f [Hz] | TDSM [{unit}] | " + " | ".join(METHODS) + " |")
                lines.append("|---:|---:|---:|" + "---:|" * len(METHODS))
                t = res.amplitude("tdsm", q)
                for i in big:
                    row = [f"{res.orders[i]}", f"{res.frequency_hz[i]:.1f}", f"{t[i, li, di] * scale:.4g}"]
                    row += [f"{db(res.methods[m][i, li, di], res.tdsm[i, li, di]):+.2f}" for m in METHODS]
                    lines.append("| " + " | ".join(row) + " |")
                lines.append("")
    return "\n".join(lines)


def timing_table(results, times):
    lines = ["| speed [Hz] | TDSM settle + record [s] | step [us] | steps | ms/step | TDSM wall [s] | "
             "plain [ms] | hill [ms] | hbm [s] | TDSM / plain | TDSM / hill |",
             "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for f, r, t in zip(SPEEDS_RUN, results, times):
        i = r.tdsm_info
        lines.append(f"| {f} | {i['settle_s']:.3f} + {i['recorded_s']:.3f} | {i['step_s'] * 1e6:.2f} | "
                     f"{i['steps']} | {i['ms_per_step']:.4f} | {t['tdsm']:.2f} | {t['plain_spectrum'] * 1e3:.3f} | "
                     f"{t['hill_spectrum'] * 1e3:.2f} | {t['hbm_spectrum']:.3f} | "
                     f"**{t['tdsm'] / t['plain_spectrum']:.0f}** | {t['tdsm'] / t['hill_spectrum']:.0f} |")
    return "\n".join(lines)


def frequency_table(results):
    lines = ["| speed [Hz] | BPFO [Hz] | largest peak offset from k BPFO [%] | off-order RMS / order RMS [%] | "
             "half vs half, 5 largest [dB] | settled |", "|---:|---:|---:|---:|---:|---|"]
    for f, r in zip(SPEEDS_RUN, results):
        off = max(v for loc in r.tdsm_info["off_order_fraction"].values() for v in loc.values())
        hh = max(v for loc in r.tdsm_info["half_vs_half_max_abs_db_largest"].values() for v in loc.values())
        peak = 0.0
        for li in range(4):
            for di in range(2):
                big = r.largest_orders(li, di)
                peak = max(peak, float(np.max(np.abs(r.tdsm_frequency_hz[big, li, di] / r.frequency_hz[big] - 1))))
        lines.append(f"| {f} | {r.bpfo_hz:.2f} | {100 * peak:.4f} | {100 * off:.3f} | {hh:.4f} | "
                     f"{r.tdsm_info['settled']} |")
    return "\n".join(lines)


def dc_table(results):
    lines = ["| speed [Hz] | DE TDSM [um] | DE plain [um] | DE hill [um] | NDE TDSM [um] | NDE plain [um] |",
             "|---:|---:|---:|---:|---:|---:|"]
    for f, r in zip(SPEEDS_RUN, results):
        rd = r.relative_dc
        lines.append(f"| {f} | {rd['tdsm'][0, 0] * 1e6:.3f} | {rd['plain'][0, 0] * 1e6:.3f} | "
                     f"{rd['hill'][0, 0] * 1e6:.3f} | {rd['tdsm'][1, 0] * 1e6:.3f} | {rd['plain'][1, 0] * 1e6:.3f} |")
    return "\n".join(lines)


# --------------------------------------------------------------------------- studies
def step_study(case, machine, speed=30.0, record=0.1, settle=0.3):
    """The five largest orders (displacement and acceleration) at the DE rotor node against the finest step."""
    steps = (2e-5, 1e-5, 5e-6, 2.5e-6, 1.25e-6)
    amp = {}
    for h in tqdm(steps, desc="step study", leave=False):
        m = Tdsm(case, speed, max_step_s=h, machine=machine)
        r = m.run(record, settle_s=settle, progress=False)
        o, x, _ = r.order_spectrum(50)
        amp[h] = (m.h, np.abs(x[:, 0, :]), o)
    ref = amp[steps[-1]][1]
    o = amp[steps[-1]][2]
    w2 = (2 * np.pi * o * machine.sites["de"].bearing.fault_multipliers().bpfo * speed) ** 2
    lines = ["| step [us] | max change, 5 largest displacement orders [dB] | 5 largest acceleration orders [dB] |",
             "|---:|---:|---:|"]
    for h in steps[:-1]:
        hh, a, _ = amp[h]
        worst_d = worst_a = 0.0
        for di in range(2):
            big = np.argsort(ref[:, di])[::-1][:N_LARGEST]
            worst_d = max(worst_d, float(np.max(np.abs(db(a[big, di], ref[big, di])))))
            big = np.argsort(ref[:, di] * w2)[::-1][:N_LARGEST]
            worst_a = max(worst_a, float(np.max(np.abs(db(a[big, di], ref[big, di])))))
        lines.append(f"| {hh * 1e6:.2f} | {worst_d:.3f} | {worst_a:.3f} |")
    lines.append(f"\nReference: {amp[steps[-1]][0] * 1e6:.2f} us, {settle} s settled, {record} s recorded, DE rotor "
                 "node, both directions.")
    return "\n".join(lines)


def mesh_study(case):
    """FE mesh: modes and BKA-BEM orders of the automatic mesh against one with every element split again."""
    base = BkaBem(case)
    m2 = Machine(case, mesh=base.machine.mesh.doubled())
    fine = BkaBem(case, machine=m2)
    coarse = BkaBem(case, machine=Machine(case, mesh=None))
    f_top = case.max_frequency_hz
    f1, f2 = base.rotor.undamped_modes()[0], fine.rotor.undamped_modes()[0]
    f0 = coarse.rotor.undamped_modes()[0]
    n = int(np.sum(f2 < f_top))
    rows = ["| mesh | elements | DOF | modes below 25.6 kHz | max mode change vs doubled [%] | "
            "max order change vs doubled, 30 Hz [dB] | 60 Hz [dB] | DE rotor vertical acc. RMS at 30 Hz [m/s^2] |",
            "|---|---:|---:|---:|---:|---:|---:|---:|"]

    def order_change(m, f):
        a = np.abs(m.spectrum(f).displacement)
        b = np.abs(fine.spectrum(f).displacement)
        big = b >= 0.01 * b.max(axis=0)
        return float(np.max(np.abs(db(a[big], b[big]))))

    def rms(m):
        return float(np.sqrt(0.5 * np.sum(np.abs(m.spectrum(30.0).acceleration[:, 0, 0]) ** 2)))

    for name, m, f in (("case elements", coarse, f0), ("automatic (default)", base, f1), ("doubled", fine, f2)):
        change = np.max(np.abs(f[:n] - f2[:n]) / f2[:n]) * 100
        rows.append(f"| {name} | {m.machine.mesh.n_elements} | {m.rotor.ndof} | {int(np.sum(f < f_top))} | "
                    f"{change:.3f} | {order_change(m, 30.0):.3f} | {order_change(m, 60.0):.3f} | {rms(m):.2f} |")
    return "\n".join(rows)


# --------------------------------------------------------------------------- main
def main(argv=None) -> int:
    global SPEEDS_RUN
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="15, 30 and 50 Hz only; no step and mesh studies")
    ap.add_argument("--duration", type=float, default=0.2, help="TDSM time recorded per speed [s]")
    ap.add_argument("--no-doc", action="store_true", help="do not rewrite docs/validation.md")
    args = ap.parse_args(argv)
    SPEEDS_RUN = (15, 30, 50) if args.quick else SPEEDS
    case = Case.load()
    t_start = time.perf_counter()
    plain = BkaBem(case)
    results, times = [], []
    errs = {m: {q: np.zeros((len(SPEEDS_RUN), 4, 2)) for q in QUANTITIES} for m in METHODS}
    for s, f in enumerate(tqdm(SPEEDS_RUN, desc="speeds")):
        r = validate(case, speed_hz=float(f), duration_s=args.duration, improvement="hill",
                     extra=("paper", "four_dof", "hbm"), progress=False, plain=plain)
        results.append(r)
        times.append(r.wall_time_s)
        for m in METHODS:
            for q in QUANTITIES:
                errs[m][q][s] = r.max_error_db(m, q)
        if f in (15, 30, 50):
            plot_validation(r, str(IMG / f"validation_{f}hz.png"), quantity="acceleration")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "validation.json").write_text(json.dumps([r.to_dict() for r in results]))
    blocks = {"targets": targets_table(errs, times), "summary": summary_table(errs), "scan": scan_table(errs),
              "timing": timing_table(results, times), "frequency": frequency_table(results),
              "dc": dc_table(results), "speed-30": detail_table(results[SPEEDS_RUN.index(30)])}
    if not args.quick:
        blocks.update(steps=step_study(case, plain.machine), mesh=mesh_study(case))
    text = DOC.read_text()
    for name, body in blocks.items():
        text = replace_block(text, name, body, "docs/validation.md")
    if not args.no_doc:
        DOC.write_text(text)
    print(targets_table(errs, times))
    print(f"done in {time.perf_counter() - t_start:.0f} s")
    return 0


SPEEDS_RUN = SPEEDS

if __name__ == "__main__":
    sys.exit(main())
