"""The MFPT rig's twin at the loads of MFPT's records, read as a monitoring pipeline reads them.

    .venv/bin/python bench/mfpt_loads.py                         # renders mfpt_rig_loads, writes docs/rigs.md's table
    .venv/bin/python bench/mfpt_loads.py --out out/mfpt --png docs/img/mfpt_rig_loads.png

Renders the embedded data set ``mfpt_rig_loads`` with the product's command (``bkabem dataset``: healthy, outer and
inner race at 0-300 lbf, 3 s at 48,828 Hz each) into ``--out`` (a temporary folder by default), and reads each run's
test-bearing (DE vertical) acceleration with the textbook diagnostics of ``bench/realdata/diagnostics.py``
(Randall & Antoni 2011, not the product's code): RMS, kurtosis, the squared-envelope spectrum of the 2-8 kHz band
and the level of BPFO, BPFI and 2 x BSF over its floor, and the no-training verdict. Writes the table between the
``mfpt_loads`` markers of docs/rigs.md (``--no-docs``: print only) and, with ``--png``, a figure: the fault lines'
levels and the RMS against the load, and three envelope spectra.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from docs_blocks import replace_block  # noqa: E402
from realdata.diagnostics import envelope_analysis, moments  # noqa: E402

LBF_N = 4.4482216152605
G = 9.80665
BAND_HZ = (2000.0, 8000.0)
DOCS = ROOT / "docs" / "rigs.md"


def render(out: Path) -> Path:
    """``bkabem dataset mfpt_rig_loads --out out`` (resumes a folder already rendered)."""
    exe = Path(sys.executable).parent / "bkabem"
    subprocess.run([str(exe), "dataset", "mfpt_rig_loads", "--out", str(out)], check=True)
    return out


def read(out: Path) -> list[dict]:
    """One row per run: fault, load [lbf], RMS [g], kurtosis, line levels [dB], verdict, and its SES."""
    import pyarrow.parquet as pq

    rows = []
    labels = pq.read_table(out / "labels.parquet").to_pylist()
    for lab in labels:
        table = pq.read_table(out / lab["file"])
        col = [c for c in table.column_names if c.startswith("de_") and "vertical" in c and "acc" in c]
        x = table.column(col[0]).to_numpy().astype(np.float64) / G
        fs, fr = lab["sample_rate_hz"], lab["speed_hz_mean"]
        mult = {k: lab[f"{k}_per_hz"] for k in ("bpfo", "bpfi", "bsf", "ftf")}
        env = envelope_analysis(x, fs, BAND_HZ, fr, mult, keep_spectrum=True)
        rows.append({"fault": lab["fault"], "lbf": lab["radial_load_n"] / LBF_N, "rms_g": float(np.std(x)),
                     "kurtosis": moments(x)["kurtosis"], "verdict": env["verdict"],
                     "levels": {k: env["levels"][k] for k in ("BPFO", "BPFI", "2BSF")},
                     "f": env["f"], "S": env["S"], "floor": env["floor"], "mult": mult, "fr": fr})
    return sorted(rows, key=lambda r: (("healthy", "outer", "inner").index(r["fault"]), r["lbf"]))


def table(rows: list[dict]) -> str:
    out = ["| fault | load [lbf] | RMS [g] | kurtosis | BPFO [dB] | BPFI [dB] | 2 x BSF [dB] | verdict |",
           "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lv = r["levels"]
        right = r["verdict"] == r["fault"]
        out.append(f"| {r['fault']} | {r['lbf']:.0f} | {r['rms_g']:.3f} | {r['kurtosis']:.1f} | {lv['BPFO']:.1f} | "
                   f"{lv['BPFI']:.1f} | {lv['2BSF']:.1f} | {r['verdict']}{'' if right else ' (wrong)'} |")
    return "\n".join(out)


def figure(rows: list[dict], png: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5))
    ax = axes[0, 0]
    for fault, line, colour in (("outer", "BPFO", "C3"), ("inner", "BPFI", "C2"), ("healthy", "BPFO", "0.5")):
        rs = [r for r in rows if r["fault"] == fault]
        ax.plot([r["lbf"] for r in rs], [r["levels"][line] for r in rs], "o-", color=colour,
                label=f"{fault}: {line}")
    ax.axhline(10.0, color="k", lw=0.8, ls=":", label="the verdict's 10 dB")
    ax.set(xlabel="radial load on the test bearing [lbf]", ylabel="line over the SES floor [dB]",
           title="fault line in the 2-8 kHz squared envelope")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    for fault, colour in (("outer", "C3"), ("inner", "C2"), ("healthy", "0.5")):
        rs = [r for r in rows if r["fault"] == fault]
        ax.plot([r["lbf"] for r in rs], [r["rms_g"] for r in rs], "o-", color=colour, label=fault)
    ax.set(xlabel="radial load on the test bearing [lbf]", ylabel="RMS [g]", yscale="log",
           title="test bearing's housing, vertical, full band")
    ax.legend(fontsize=8)
    for ax, fault, line in ((axes[1, 0], "outer", "bpfo"), (axes[1, 1], "inner", "bpfi")):
        for lbf, colour in ((50, "C0"), (150, "C1"), (300, "C4")):
            r = min((r for r in rows if r["fault"] == fault), key=lambda r: abs(r["lbf"] - lbf))
            keep = r["f"] <= 500.0
            ax.plot(r["f"][keep], 20 * np.log10(r["S"][keep] / r["floor"]), color=colour, lw=0.8,
                    label=f"{r['lbf']:.0f} lbf")
        f0 = rows[0]["mult"][line] * rows[0]["fr"]
        for k in (1, 2, 3):
            ax.axvline(k * f0, color="k", lw=0.6, ls="--")
        ax.set(xlabel="frequency [Hz]", ylabel="SES over its floor [dB]", xlim=(0, 500),
               title=f"{fault} race: squared-envelope spectrum (dashed: {line.upper()} x 1, 2, 3)")
        ax.legend(fontsize=8)
    fig.suptitle("mfpt_rig at the loads of MFPT's records (mfpt_rig_loads, 25 Hz, 3 s at 48,828 Hz): "
                 "a 0.5 mm round pit", fontsize=11)
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=100)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="data-set folder (default: a temporary one)")
    ap.add_argument("--png", default=None, help="figure file")
    ap.add_argument("--no-docs", action="store_true", help="print the table, leave docs/rigs.md alone")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bkabem_mfpt_") as tmp:
        out = render(Path(args.out) if args.out else Path(tmp) / "mfpt")
        rows = read(out)
    text = table(rows)
    print(text)
    if not args.no_docs:
        DOCS.write_text(replace_block(DOCS.read_text(), "mfpt_loads", text, "docs/rigs.md"))
        print(f"wrote the table into {DOCS.relative_to(ROOT)}")
    if args.png:
        figure(rows, Path(args.png))
        print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
