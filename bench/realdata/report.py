"""Markdown and figures of the real-data validation page (docs/validation_real.md).

The page is written by ``bench/validate_real.py``; ``bench/sim2real.py`` replaces its own block between
:data:`SIM2REAL_BEGIN` and :data:`SIM2REAL_END`, so either script regenerates its part without the other's.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

SIM2REAL_BEGIN = "<!-- sim2real:begin (written by bench/sim2real.py) -->"
SIM2REAL_END = "<!-- sim2real:end -->"
KIND_COLOUR = {"healthy": "k", "inner": "tab:red", "ball": "tab:green", "outer": "tab:blue"}


def code_version(root: Path) -> str:
    """The code's commit (``-dirty`` when tracked files other than the generated pages differ), for the header."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                             timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":!docs",
                                ":!BENCHMARKS.md", ":!bench/records.json"], cwd=root,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return (rev or "unknown") + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def table(header: list[str], rows: list[list]) -> str:
    """A markdown table."""
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def fmt(v, spec: str = "{:.0f}", none: str = "-") -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return none
    return spec.format(v)


def mark(ok) -> str:
    return "" if ok is None else ("yes" if ok else "**no**")


def sim2real_block(page: Path) -> str:
    """The sim2real block of an existing page (with its markers), or a placeholder."""
    if page.is_file():
        text = page.read_text()
        i, j = text.find(SIM2REAL_BEGIN), text.find(SIM2REAL_END)
        if 0 <= i < j:
            return text[i:j + len(SIM2REAL_END)]
    return (f"{SIM2REAL_BEGIN}\n## Sim-to-real: a classifier fitted on the twin alone, scored on the measurements\n\n"
            f"Not run yet: `.venv/bin/python bench/sim2real.py DATA_DIR`.\n{SIM2REAL_END}")


def replace_sim2real_block(page: Path, block: str) -> None:
    """Write ``block`` (with its markers) into ``page`` in place of the old one (appended if there is none)."""
    text = page.read_text() if page.is_file() else "# Held against real measurements\n"
    i, j = text.find(SIM2REAL_BEGIN), text.find(SIM2REAL_END)
    if 0 <= i < j:
        text = text[:i] + block + text[j + len(SIM2REAL_END):]
    else:
        text = text.rstrip("\n") + "\n\n" + block + "\n"
    page.write_text(text)


# --------------------------------------------------------------------------- figures
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def kind_figure(path: Path, kind: str, panels: list[dict], twin_name: str) -> None:
    """One row per record of ``kind``: the DE Welch PSD, measured and twin; the SES (fixed band) of each, in dB
    over its floor, with the kind's line, its harmonics and 1x marked.

    ``panels``: dicts with ``label``, ``psd_f``, ``psd_meas``, ``psd_twin``, ``ses_meas`` = (f, dB),
    ``ses_twin`` = (f, dB), ``lines_meas``, ``lines_twin`` (name -> Hz).
    """
    plt = _plt()
    n = len(panels)
    fig, axes = plt.subplots(n, 3, figsize=(15, 2.6 * n + 0.6), squeeze=False)
    for row, p in zip(axes, panels):
        a = row[0]
        a.semilogy(p["psd_f"] / 1e3, p["psd_meas"], color="k", lw=0.6, label="measured")
        a.semilogy(p["psd_f"] / 1e3, p["psd_twin"], color="tab:orange", lw=0.6, alpha=0.8, label=f"twin ({twin_name})")
        a.set_xlim(0, 6)
        a.set_ylabel("PSD [g²/Hz]")
        a.set_title(f"{p['label']}: DE PSD", fontsize=9)
        a.legend(fontsize=7, loc="upper left")
        for a, key, lines, title in ((row[1], "ses_meas", p["lines_meas"], "measured"),
                                     (row[2], "ses_twin", p["lines_twin"], "twin")):
            f, db = p[key]
            m = f <= 500
            a.plot(f[m], db[m], color="k" if title == "measured" else "tab:orange", lw=0.5)
            for name, fl in lines.items():
                if fl <= 500:
                    a.axvline(fl, color="tab:red" if name != "1x" else "tab:blue", lw=0.6, ls=":", alpha=0.8)
            a.axhline(10.0, color="0.5", lw=0.6, ls="--")
            a.set_xlim(0, 500)
            a.set_ylim(-20, max(30.0, float(np.nanmax(db[m])) + 5))
            a.set_ylabel("SES [dB over floor]")
            a.set_title(f"{title}: SES 2-4 kHz (red: kind line and harmonics, blue: 1x; dashed: 10 dB)",
                        fontsize=8)
    for a in axes[-1]:
        a.set_xlabel("frequency [kHz]" if a is axes[-1][0] else "frequency [Hz]")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def summary_figure(path: Path, points: list[dict], twin_name: str) -> None:
    """Measured against twin: DE RMS, kurtosis and the kind line's SES level, one dot per record, by kind, with
    the target bands (factor 2, +-10 dB).

    ``points``: dicts with ``kind``, ``rms`` = (meas, twin), ``kurtosis`` = (meas, twin), ``line`` = (meas, twin)
    (dB; None for the healthy record).
    """
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4))
    for a, key, title, log in ((axes[0], "rms", "DE RMS [g]", True), (axes[1], "kurtosis", "DE kurtosis", True),
                               (axes[2], "line", "kind line in the SES, 2-4 kHz [dB over floor]", False)):
        xs = [p[key][0] for p in points if p[key] is not None]
        ys = [p[key][1] for p in points if p[key] is not None]
        if not xs:
            continue
        lo, hi = min(xs + ys), max(xs + ys)
        if log:
            lo, hi = lo / 1.5, hi * 1.5
            t = np.geomspace(lo, hi, 50)
            a.set_xscale("log")
            a.set_yscale("log")
            if key == "rms":
                a.fill_between(t, t / 2, t * 2, color="0.9", label="factor 2")
        else:
            lo, hi = lo - 5, hi + 5
            t = np.linspace(lo, hi, 50)
            a.fill_between(t, t - 10, t + 10, color="0.9", label="+-10 dB")
        a.plot(t, t, color="0.5", lw=0.8)
        for kind, c in KIND_COLOUR.items():
            pk = [p for p in points if p["kind"] == kind and p[key] is not None]
            if pk:
                a.scatter([p[key][0] for p in pk], [p[key][1] for p in pk], color=c, s=22, label=kind)
        a.set_xlim(lo, hi)
        a.set_ylim(lo, hi)
        if log:
            from matplotlib.ticker import NullFormatter, ScalarFormatter

            for axis in (a.xaxis, a.yaxis):
                axis.set_major_formatter(ScalarFormatter())
                axis.set_minor_formatter(NullFormatter())
        a.set_xlabel(f"measured {title}")
        a.set_ylabel(f"twin ({twin_name})")
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def confusion_figure(path: Path, matrices: list[tuple[str, np.ndarray]], classes: list[str]) -> None:
    """Confusion matrices (rows: truth, columns: predicted) side by side."""
    plt = _plt()
    fig, axes = plt.subplots(1, len(matrices), figsize=(4.2 * len(matrices), 3.8), squeeze=False)
    for a, (title, m) in zip(axes[0], matrices):
        a.imshow(m, cmap="Blues")
        for i in range(m.shape[0]):
            for j in range(m.shape[1]):
                a.text(j, i, str(int(m[i, j])), ha="center", va="center",
                       color="white" if m[i, j] > m.max() / 2 else "black")
        a.set_xticks(range(len(classes)), classes, rotation=30, fontsize=8)
        a.set_yticks(range(len(classes)), classes, fontsize=8)
        a.set_xlabel("predicted")
        a.set_ylabel("truth")
        a.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
