"""TDSM vs plain BKA-BEM for every defect kind (issue 12): the "kinds" block of docs/validation.md.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/validate_kinds.py                 # rewrites the block
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/validate_kinds.py --speeds 30 --no-write

For each fault-library case (outer race, inner race, ball; the baseline is left out of both models: the TDSM has
the bearings only) and speed: :func:`bkabem_core.validation.validate_lines` (TDSM settled 2 s, 0.3 s fitted by
least squares at the BKA-BEM line frequencies), the largest |error| over the five largest TDSM lines of every
location and direction, displacement and acceleration, the residual the lines leave, and the wall times.
Only the block between ``<!-- BEGIN kinds -->`` and ``<!-- END kinds -->`` is written.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


from bkabem_core.case import Case  # noqa: E402
from bkabem_core.harmonic import BkaBem  # noqa: E402
from bkabem_core.validation import validate_lines  # noqa: E402

DOC = ROOT / "docs" / "validation.md"
BEGIN, END = "<!-- BEGIN kinds -->", "<!-- END kinds -->"
KINDS = ("outer", "inner", "ball")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="15,30,50")
    ap.add_argument("--settle", type=float, default=2.0, help="discarded start transient [s]")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    speeds = [float(s) for s in args.speeds.split(",")]
    rows = []
    for kind in KINDS:
        case = Case.load(f"motor_6010_{kind}")
        t0 = time.perf_counter()
        model = BkaBem(case, baseline=False)
        prep = time.perf_counter() - t0
        for f in speeds:
            r = validate_lines(case, f, settle_s=args.settle, plain=model)
            d, a = r.max_error_db(), r.max_error_db("acceleration")
            rows.append((kind, f, len(model.lines), d[[1, 3]].max(), d[[0, 2]].max(), a[[1, 3]].max(),
                         a[[0, 2]].max(), float(r.residual_fraction.max()), r.wall_time_s["tdsm"],
                         r.wall_time_s["plain_spectrum"], prep))
            print(rows[-1], flush=True)
    lines = [BEGIN, "",
             f"Command: `OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/validate_kinds.py` ({time.strftime('%Y-%m-%d')}). "
             "Plain BKA-BEM against the TDSM of the same machine for each defect kind of the fault library "
             "(`motor_6010_{outer,inner,ball}`, 2 mm x 50 um outer/inner-race dents, 1.5 mm x 50 um on ball 1, DE "
             "bearing; the baseline left out of both). The TDSM moves the inner-race defect with the shaft and the "
             "ball defect with its ball and spin (docs/faults.md section 6); its record (" f"{args.settle:g} s settled, 0.3 s) is "
             "fitted by least squares at the BKA-BEM line frequencies. Errors: the largest |dB| over the five "
             "largest TDSM lines of each location and direction.", "",
             "| kind | speed [Hz] | lines | displacement, housings [dB] | displacement, rotor [dB] | "
             "acceleration, housings [dB] | acceleration, rotor [dB] | residual | TDSM [s] | BKA-BEM spectrum [ms] |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k, f, n, dh, dr, ah, ar, res, tt, ts, _ in rows:
        lines.append(f"| {k} | {f:g} | {n} | {dh:.2f} | {dr:.2f} | {ah:.2f} | {ar:.2f} | {res:.3f} | {tt:.1f} | "
                     f"{ts * 1e3:.2f} |")
    disp = max(max(r[3], r[4]) for r in rows)
    acc_h = max(r[5] for r in rows)
    acc_r = max(r[6] for r in rows)
    lines += ["", f"Worst over every kind, speed, location and direction: displacement {disp:.2f} dB (the 3 dB "
              f"criterion of the plain method, as tests/test_validation.py holds it for issue 11's outer race); "
              f"acceleration {acc_h:.2f} dB at the housings and {acc_r:.2f} dB at the rotor nodes. The acceleration "
              "excess is the plain method's known high-frequency deficit (mean bearing stiffness; section 6), "
              "the same for the outer race as for the new kinds; the improved method removes it for the outer race "
              "(0.3 dB) but is not generalised to the 2-phase harmonic lattice of inner-race and ball defects yet.",
              "", END]
    block = "\n".join(lines)
    print(block)
    if not args.no_write:
        text = DOC.read_text()
        if BEGIN in text and END in text:
            a, b = text.index(BEGIN), text.index(END) + len(END)
            text = text[:a] + block + text[b:]
        else:
            text = text.rstrip() + "\n\n## Every defect kind (issue 12)\n\n" + block + "\n"
        DOC.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
