"""The long validation: TDSM against BKA-BEM (plain and every improvement) at three speeds, the step-size study
and (optionally) a speed scan. Rewrites the generated tables of docs/validation.md and docs/img/validation_*.png.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python3 bench/validate_speeds.py            # ~1 min
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python3 bench/validate_speeds.py --scan     # + 10..75 Hz scan, ~3 min

Generated blocks in docs/validation.md sit between ``<!-- BEGIN name -->`` and ``<!-- END name -->``; the text
around them is written by hand and must be checked against the new numbers after a change.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from bkabem_core.case import Case
from bkabem_core.harmonic import LOCATIONS as BK_LOCATIONS
from bkabem_core.tdsm import Tdsm
from bkabem_core.validation import (
    COMPARED_LOCATIONS,
    DEFAULT_SPEED_HZ,
    IMPROVEMENTS,
    N_LARGEST,
    ImprovedBkaBem,
    plot_validation,
    validate,
)

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "validation.md"
IMG = ROOT / "docs" / "img"
METHODS = ("plain",) + IMPROVEMENTS
_B = [BK_LOCATIONS.index(l) for l in COMPARED_LOCATIONS]


def db(a, b):
    return 20.0 * np.log10(a / b)


def run_speed(case, speed, duration, models):
    """One TDSM run (inside validate, with the 'hbm' improvement) and every BKA-BEM variant against it."""
    res = validate(case, speed_hz=speed, duration_s=duration, improvement="hbm", progress=True)
    amps = {"plain": res.bkabem_amplitude, "hbm": res.improved_amplitude}
    times = {"plain": res.wall_time_s["bkabem_spectrum"], "hbm": res.wall_time_s["improved_spectrum"]}
    for name in ("nde", "consistent", "full", "parametric"):
        m = models[name]
        t = []
        for _ in range(3 if name == "parametric" else 7):
            t0 = time.perf_counter()
            orders, _, disp, _ = m.spectrum(speed)
            t.append(time.perf_counter() - t0)
        assert np.array_equal(orders, res.orders[: orders.size])
        a = np.full_like(res.bkabem_amplitude, np.nan)
        a[: orders.size] = np.abs(disp[:, _B, :])
        amps[name] = a
        times[name] = float(np.median(t))
    return res, amps, times


def largest_table(res, amps, li=0):
    lines = []
    for di, d in enumerate(("vertical", "horizontal")):
        big = res.largest_orders(li, di)
        lines.append(f"**{COMPARED_LOCATIONS[li]}, {d}** (the {N_LARGEST} largest TDSM orders; error in dB "
                     "against the TDSM)\n")
        lines.append("| order | f [Hz] | TDSM [nm] | " + " | ".join(METHODS) + " |")
        lines.append("|---:|---:|---:|" + "---:|" * len(METHODS))
        for i in big:
            t = res.tdsm_amplitude[i, li, di]
            row = [f"{res.orders[i]}", f"{res.frequency_hz[i]:.1f}", f"{t * 1e9:.1f}"]
            row += [f"{db(amps[m][i, li, di], t):+.2f}" for m in METHODS]
            lines.append("| " + " | ".join(row) + " |")
        worst = [np.max(np.abs(db(amps[m][big, li, di], res.tdsm_amplitude[big, li, di]))) for m in METHODS]
        lines.append("| **max abs** | | | " + " | ".join(f"**{w:.2f}**" for w in worst) + " |")
        lines.append("")
    return "\n".join(lines)


def overview_rows(speed, res, amps):
    out = []
    for li, loc in enumerate(COMPARED_LOCATIONS):
        for di, d in enumerate(("vertical", "horizontal")):
            big = res.largest_orders(li, di)
            w = [np.max(np.abs(db(amps[m][big, li, di], res.tdsm_amplitude[big, li, di]))) for m in METHODS]
            out.append(f"| {speed:g} | {loc} | {d} | {', '.join(str(int(k)) for k in res.orders[big])} | "
                       + " | ".join(f"{x:.2f}" for x in w) + " |")
    return out


def step_study(case, speed, n_rec=0.1, settle=0.4):
    """Largest TDSM orders at the DE rotor node vs the step, both schemes, against the finest exponential run
    (and that run against the harmonic balance of the same model)."""
    steps = (2e-5, 1e-5, 5e-6, 2.5e-6, 1.25e-6)
    amp, cost = {}, {}
    for scheme in ("exponential", "newmark"):
        for h in steps:
            m = Tdsm(case, speed, max_step_s=h, scheme=scheme)
            r = m.run(n_rec, settle_s=settle, progress=False)
            o, x, _ = r.order_spectrum(50)
            amp[scheme, h] = np.abs(x[:, 0, :])
            cost[scheme, h] = (m.h, r.steps, r.wall_time_s)
    ref = amp["exponential", steps[-1]]
    hbm = np.abs(Tdsm(case, speed).harmonic_balance(n_orders=50, n_time=32768).complex_amplitude[:, 0, :])
    lines = ["| scheme | step [us] | steps/BPFO | max abs change of the 5 largest orders, vertical [dB] | "
             "horizontal [dB] | orders 1-20, both directions [dB] |", "|---|---:|---:|---:|---:|---:|"]
    bigs = [np.argsort(ref[:, di])[::-1][:N_LARGEST] for di in range(2)]
    for scheme in ("exponential", "newmark"):
        for h in steps:
            a = amp[scheme, h]
            e = [np.max(np.abs(db(a[bigs[di], di], ref[bigs[di], di]))) for di in range(2)]
            e20 = np.max(np.abs(db(a[:20], ref[:20])))
            hh, n, _ = cost[scheme, h]
            per = round((1.0 / (6.059846 * speed)) / hh)
            lines.append(f"| {scheme} | {hh * 1e6:.2f} | {per} | {e[0]:.3f} | {e[1]:.3f} | {e20:.2f} |")
    lines.append("")
    e_h = [np.max(np.abs(db(ref[bigs[di], di], hbm[bigs[di], di]))) for di in range(2)]
    lines.append(f"Reference: exponential scheme at {steps[-1] * 1e6:.2f} us, {settle:g} s settled, "
                 f"{n_rec:g} s recorded. Five largest orders: vertical {', '.join(str(k + 1) for k in bigs[0])}; "
                 f"horizontal {', '.join(str(k + 1) for k in bigs[1])}. The reference itself against the "
                 f"harmonic balance of the same model (50 orders, 32768 instants per BPFO period): "
                 f"{e_h[0]:.3f} dB vertical, {e_h[1]:.3f} dB horizontal (five largest orders).")
    return "\n".join(lines)


def scan(case, speeds, models):
    rows = ["| speed [Hz] | location | direction | 5 largest orders | " + " | ".join(METHODS) + " |",
            "|---:|---|---|---|" + "---:|" * len(METHODS)]
    for s in speeds:
        m = Tdsm(case, s)
        r = m.run(0.1, progress=False)
        o, x, _ = r.order_spectrum()
        for li, loc in enumerate(COMPARED_LOCATIONS[:1]):
            loc_t = ("de_rotor", "nde_rotor").index(loc) * 2
            t = np.abs(x[:50, loc_t, :])
            cells = {}
            for name in METHODS:
                if name in ("parametric", "hbm"):
                    sol = m.harmonic_balance(linearised=name == "parametric")
                    a = np.abs(sol.complex_amplitude[:50, loc_t, :])
                else:
                    orders, _, disp, _ = models[name].spectrum(s)
                    a = np.abs(disp[:50, BK_LOCATIONS.index(loc), :])
                cells[name] = a
            for di, d in enumerate(("vertical", "horizontal")):
                big = np.argsort(t[:, di])[::-1][:N_LARGEST]
                w = [np.max(np.abs(db(cells[n][big, di], t[big, di]))) for n in METHODS]
                rows.append(f"| {s:g} | {loc} | {d} | {', '.join(str(k + 1) for k in big)} | "
                            + " | ".join(f"{v:.1f}" for v in w) + " |")
        print(f"scan {s:g} Hz done", file=sys.stderr, flush=True)
    return "\n".join(rows)


def replace_block(text, name, body):
    pat = re.compile(rf"(<!-- BEGIN {name} -->\n).*?(<!-- END {name} -->)", re.S)
    if not pat.search(text):
        raise SystemExit(f"docs/validation.md has no block {name!r}")
    return pat.sub(lambda m: m.group(1) + body.rstrip() + "\n" + m.group(2), text)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default=f"15,{DEFAULT_SPEED_HZ:g},50")
    ap.add_argument("--duration", type=float, default=0.5, help="recorded TDSM time per speed [s]")
    ap.add_argument("--scan", action="store_true", help="also scan 10..75 Hz in 2.5 Hz steps")
    ap.add_argument("--no-steps", action="store_true", help="skip the step-size study")
    ap.add_argument("--json", default=None, help="also write every number to this JSON file")
    a = ap.parse_args(argv)
    case = Case.load()
    speeds = [float(s) for s in a.speeds.split(",")]
    models = {n: ImprovedBkaBem(case, n) for n in ("nde", "consistent", "full", "parametric")}
    blocks, overview, timing, dc_rows, freq_rows, dump = {}, [], [], [], [], {}
    for s in speeds:
        res, amps, times = run_speed(case, s, a.duration, models)
        png = IMG / f"validation_{s:g}hz.png"
        plot_validation(res, str(png), extra={"BKA-BEM + full": amps["full"]})
        blocks[s] = largest_table(res, amps, 0) + "\n" + largest_table(res, amps, 1)
        overview += overview_rows(s, res, amps)
        w = res.wall_time_s
        i = res.tdsm_info
        timing.append(f"| {s:g} | {i['settle_s']:.3f} + {i['recorded_s']:.3f} | {i['step_s'] * 1e6:.2f} | {i['steps']} "
                      f"| {i['ms_per_step']:.4f} "
                      f"| {w['tdsm']:.2f} | {times['plain'] * 1e3:.2f} | {w['bkabem_preparation']:.2f} "
                      f"| **{w['tdsm'] / times['plain']:.0f}** | {times['full'] * 1e3:.2f} "
                      f"| {times['parametric']:.3f} | {times['hbm']:.3f} |")
        rel = res.relative_dc
        dc_rows.append(f"| {s:g} | {rel['tdsm'][0, 0] * 1e6:.3f} | {rel['bkabem'][0, 0] * 1e6:.3f} "
                       f"| {rel['improved'][0, 0] * 1e6:.3f} | {rel['tdsm'][1, 0] * 1e6:.3f} "
                       f"| {rel['improved'][1, 0] * 1e6:.3f} |")
        ferr = max(float(np.max(np.abs(res.tdsm_frequency_hz[res.largest_orders(li, di), li, di]
                                       / res.frequency_hz[res.largest_orders(li, di)] - 1.0)))
                   for li in range(2) for di in range(2))
        off = max(v for loc in i["off_order_fraction"].values() for v in loc.values())
        half = max(v for loc in i["half_vs_half_max_abs_db_largest"].values() for v in loc.values())
        freq_rows.append(f"| {s:g} | {res.bpfo_hz:.2f} | {ferr * 100:.4f} | {off * 100:.2f} | {half:.4f} |")
        dump[f"{s:g}"] = {**res.to_dict(), "variants_amplitude_m": {
            k: v.tolist() for k, v in amps.items()}, "variants_spectrum_time_s": times}
        print(res.summary(), flush=True)
    text = DOC.read_text()
    for s in speeds:
        text = replace_block(text, f"speed-{s:g}", blocks[s])
    head = ("| speed [Hz] | location | direction | 5 largest TDSM orders | " + " | ".join(METHODS) + " |\n"
            "|---:|---|---|---|" + "---:|" * len(METHODS) + "\n")
    text = replace_block(text, "overview", head + "\n".join(overview))
    text = replace_block(text, "timing", "| speed [Hz] | TDSM settle + record [s] | step [us] | steps | ms/step "
                         "| TDSM wall [s] | BKA-BEM spectrum [ms] | BKA-BEM preparation [s] | ratio | full spectrum [ms] "
                         "| parametric [s] | hbm [s] |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
                         + "\n".join(timing))
    text = replace_block(text, "dc", "| speed [Hz] | DE TDSM [um] | DE BKA-BEM [um] | DE hbm [um] | NDE TDSM [um] "
                         "| NDE hbm [um] |\n|---:|---:|---:|---:|---:|---:|\n" + "\n".join(dc_rows))
    text = replace_block(text, "frequency", "| speed [Hz] | BPFO [Hz] | largest peak offset from k BPFO [%] "
                         "| off-order RMS / order RMS [%] | half vs half, 5 largest [dB] |\n"
                         "|---:|---:|---:|---:|---:|\n" + "\n".join(freq_rows))
    if not a.no_steps:
        text = replace_block(text, "steps", step_study(case, DEFAULT_SPEED_HZ))
    if a.scan:
        text = replace_block(text, "scan", scan(case, list(np.arange(10.0, 75.1, 2.5)), {
            "plain": ImprovedBkaBem(case, None), **models}))
    DOC.write_text(text)
    if a.json:
        Path(a.json).write_text(json.dumps(dump, indent=1))
    print(f"wrote {DOC} and {IMG}/validation_*.png" + (f" and {a.json}" if a.json else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
