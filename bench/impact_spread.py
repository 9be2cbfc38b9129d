"""How much a race fault's impacts vary from one ball pass to the next, on the CWRU rig and in its twin, and the
ceiling that spread puts on the fault line of a squared-envelope spectrum.

    .venv/bin/python bench/impact_spread.py DATA_DIR              # the table into docs/rigs.md, the figure
    .venv/bin/python bench/impact_spread.py DATA_DIR --no-docs    # prints the table only

The figure: docs/img/impact_spread.png.

DATA_DIR: the CWRU drive-end records as NumPy files (docs/validation_real.md says where they come from).

For each inner- and outer-race record of the drive-end bearing, and for the twin of its condition
(``realdata.twin``: the same mapping as ``bench/validate_real.py``), the drive-end channel at 12 kHz:

1. the squared envelope of 2-4 kHz (``realdata.diagnostics.squared_envelope``), the fault frequency refined to the
   strongest squared-envelope component within +-0.4 % of the nominal line (the measured records at the 6205's
   measured multipliers, the twin at its own bearing's);
2. the energy of each ball pass: the squared envelope summed over one period centred on the impacts (the phase of
   that component);
3. its **random spread**: the part of the passes' energies that does not repeat. Periodic modulation (the shaft
   turning the inner-race pit through the load zone, the cage, the balls not all alike) puts lines into the
   sequence's periodogram; what is left between them is the pass-to-pass randomness. Its variance is the median of
   the periodogram over ln 2 (the median of an exponential variable is ln 2 times its mean), its spread
   ``c = sqrt(variance) / mean energy``.

Why it matters (Antoni & Randall, J. Vib. Acoust. 124 (2002) 165-171; Antoni, MSSP 21 (2007) 597-630: the impacts
of a bearing fault as ``sum_j A_j h(t - jT - tau_j)`` with random strengths ``A_j`` and arrival jitter ``tau_j``):
N impacts of random strength give a squared envelope whose spectrum has lines of power ``(N mean(E))^2 |H|^2`` at
the fault frequency and a floor of ``N var(E) |H|^2`` between them, so the line stands at most

    10 log10(N / c^2) - 10 log10(ln 2)   [dB over the floor's median]

over the squared-envelope spectrum's floor taken near the line (the median of a Rayleigh-distributed
magnitude, 1.6 dB under its mean), whatever the size of the impacts: a larger pit does not raise it, only a more
regular one does. A periodic modulation of the impacts (the shaft's, the cage's) moves power from the line to its
sidebands and leaves it under the ceiling; so does a floor made by something other than the impacts (a weak fault
under other vibration). The line measure of ``bench/validate_real.py`` (the table's) takes its floor over 5-500 Hz,
where the impact's own envelope spectrum falls with frequency: it reads a few dB off the ceiling in either
direction. tests/unit/test_realdata.py checks the estimate and the law on impact trains of known spread.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from scipy.signal import zoom_fft

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from docs_blocks import replace_block  # noqa: E402
from realdata.diagnostics import decimate, envelope_analysis, estimate_speed, squared_envelope  # noqa: E402
from realdata.records import EFFECTIVE_6205, race_record_main, scan  # noqa: E402

DOCS = ROOT / "docs" / "rigs.md"
FIGURE = ROOT / "docs" / "img" / "impact_spread.png"
FS = 12000.0
BAND_HZ = (2000.0, 4000.0)
#: Search range of the refined fault frequency [fraction of the nominal]; step [fraction]
REFINE_SPAN, REFINE_STEP = 4e-3, 2e-5
#: The floor's median over its mean, for a Rayleigh-distributed SES magnitude, in dB (module docstring)
MEDIAN_DB = -10.0 * math.log10(math.log(2.0))
KEY = {"inner": "bpfi", "outer": "bpfo"}


def refine_frequency(e: np.ndarray, fs: float, f0: float) -> tuple[float, float]:
    """(frequency [Hz], phase [rad]) of the strongest Fourier component of ``e`` within +-REFINE_SPAN of ``f0``."""
    m = int(round(2 * REFINE_SPAN / REFINE_STEP)) + 1
    lo, hi = f0 * (1.0 - REFINE_SPAN), f0 * (1.0 + REFINE_SPAN)
    c = zoom_fft(e - e.mean(), [lo, hi], m=m, fs=fs, endpoint=True)     # the DFT at m frequencies in [lo, hi]
    i = int(np.argmax(np.abs(c)))
    return float(lo + (hi - lo) * i / (m - 1)), float(np.angle(c[i]))


def pass_energies(x: np.ndarray, fs: float, f_fault_hz: float, band=BAND_HZ) -> tuple[np.ndarray, float]:
    """The energy of each ball pass (the squared envelope of ``band`` [Hz] of ``x`` [g] summed over a window of one
    period centred on the impacts) [g^2 x samples], and the refined fault frequency [Hz]."""
    e = squared_envelope(x, fs, band[0], band[1])
    f, phase = refine_frequency(e, fs, f_fault_hz)
    period = fs / f
    peak = (-phase / (2.0 * np.pi)) % 1.0 * period           # samples from the start to the first impact's centre
    start = peak - period / 2.0 if peak >= period / 2.0 else peak + period / 2.0
    n = int((e.size - start) // period)
    edges = np.round(start + period * np.arange(n + 1)).astype(int)
    return np.add.reduceat(e, edges[:-1])[:n] if n > 0 else np.empty(0), f


def random_spread(energies: np.ndarray) -> float:
    """The pass-to-pass random spread of ``energies`` (module docstring) [-]: the square root of the median of
    their Hann-windowed periodogram over ln 2, over their mean."""
    e = np.asarray(energies, dtype=float)
    w = np.hanning(e.size)                               # the strong periodic lines must not leak between them
    p = np.abs(np.fft.rfft((e - e.mean()) * w))[1:] ** 2 / np.sum(w ** 2)   # mean over frequencies: the variance
    return float(math.sqrt(np.median(p) / math.log(2.0)) / e.mean())


def ceiling_db(n_passes: int, spread: float) -> float:
    """The highest the fault line can stand over the SES floor's median with ``n_passes`` impacts of random
    spread ``spread`` [dB]."""
    return 10.0 * math.log10(n_passes / spread ** 2) + MEDIAN_DB


def measure(x: np.ndarray, fs: float, fr: float, mult: dict, kind: str) -> dict:
    """Passes, spread, ceiling and the line's level (``bench/validate_real.py``'s measure) of one DE signal [g]."""
    key = KEY[kind]
    e, f = pass_energies(x, fs, mult[key] * fr)
    s = random_spread(e)
    line = envelope_analysis(x, fs, BAND_HZ, fr, mult)["levels"][key.upper()]
    return {"passes": int(e.size), "spread": s, "ceiling_db": ceiling_db(e.size, s), "line_db": float(line),
            "f_hz": f}


def run(data_dir: Path, seeds: int) -> list[dict]:
    from realdata.twin import Condition, synthesize
    from tqdm import tqdm

    records = [r for r in scan(data_dir) if r.kind in KEY and r.fault_bearing in (None, "de")]
    rows = []
    for r in tqdm(records, unit="record", desc="impact_spread", dynamic_ncols=True):
        ch = r.load()
        fr, _ = estimate_speed(ch, r.sample_rate_hz, r.speed_hz_nominal)
        meas = measure(decimate(ch["DE"], r.sample_rate_hz, FS), FS, fr, EFFECTIVE_6205, r.kind)
        duration = ch["DE"].size / r.sample_rate_hz
        twins = []
        for seed in range(1, seeds + 1):
            out = synthesize(Condition.of(r), "cwru_rig", seed, fr, FS, duration)
            twins.append(measure(out["DE"], FS, fr, out["mult"], r.kind))
        rows.append({"label": r.label, "kind": r.kind, "size": r.size_mils, "measured": meas,
                     "twin": {k: float(np.mean([t[k] for t in twins])) for k in ("passes", "spread", "ceiling_db",
                                                                                 "line_db")}})
    return rows


def table(rows: list[dict], seeds: int) -> str:
    out = [f"Each cell: measured / twin (`cwru_rig`, the mean over its seeds: {seeds}). Spread: the random part of "
           "the pass-to-pass\nenergy of the 2-4 kHz impacts, over its mean; ceiling: the highest the fault line can "
           "stand over the SES floor\nwith that spread; line: the fault line's level (2-4 kHz SES, the measure of "
           "docs/validation_real.md).", "",
           "| record | passes | spread | ceiling [dB] | line [dB] | line - ceiling [dB] |", "|---|---|---|---|---|---|"]
    for r in rows:
        m, t = r["measured"], r["twin"]
        out.append(f"| {r['label']} | {m['passes']} | {m['spread']:.2f} / {t['spread']:.2f} | "
                   f"{m['ceiling_db']:.0f} / {t['ceiling_db']:.0f} | {m['line_db']:.0f} / {t['line_db']:.0f} | "
                   f"{m['line_db'] - m['ceiling_db']:+.0f} / {t['line_db'] - t['ceiling_db']:+.0f} |")
    out += ["", "Median spread by pit size, measured / twin:", "", "| pit [mil] | records | spread |", "|---|---|---|"]
    for size in sorted({r["size"] for r in rows}):
        sel = [r for r in rows if r["size"] == size]
        out.append(f"| {size} | {len(sel)} | {np.median([r['measured']['spread'] for r in sel]):.2f} / "
                   f"{np.median([r['twin']['spread'] for r in sel]):.2f} |")
    return "\n".join(out)


def figure(rows: list[dict], path: Path) -> None:
    """Two panels, one dot per record (measured: filled, twin: open; by kind): the fault line against the ceiling
    its impacts' spread allows [dB], and the spread against the pit's size [mil]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colour = {"inner": "tab:red", "outer": "tab:blue"}
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.6))
    levels = [r[w][k] for r in rows for w in ("measured", "twin") for k in ("ceiling_db", "line_db")]
    lo, hi = min(levels) - 3.0, max(levels) + 3.0
    a.plot([lo, hi], [lo, hi], color="0.5", lw=0.8, label="line = ceiling")
    for r in rows:
        c = colour[r["kind"]]
        for w, face in (("measured", c), ("twin", "none")):
            a.scatter(r[w]["ceiling_db"], r[w]["line_db"], s=28, edgecolors=c, facecolors=face)
            b.scatter(r["size"] + (-0.6 if w == "measured" else 0.6), r[w]["spread"], s=28, edgecolors=c,
                      facecolors=face)
    for kind, c in colour.items():
        for w, face in (("measured", c), ("twin", "none")):
            a.scatter([], [], s=28, edgecolors=c, facecolors=face, label=f"{kind} race, {w}")
    a.set_xlim(lo, hi)
    a.set_ylim(lo, hi)
    a.set_xlabel("ceiling from the impacts' spread [dB over the SES floor]")
    a.set_ylabel("fault line, 2-4 kHz SES [dB over the floor]")
    a.legend(fontsize=7)
    b.set_yscale("log")
    b.set_xticks(sorted({r["size"] for r in rows}))
    b.set_xlabel("pit diameter [mil]")
    b.set_ylabel("random spread of the pass energy [-]")
    b.grid(True, which="both", color="0.9")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _write_docs(rows: list[dict], text: str, _args) -> None:
    DOCS.write_text(replace_block(DOCS.read_text(), "impact_spread", text, "docs/rigs.md"))
    figure(rows, FIGURE)


def main(argv=None) -> int:
    return race_record_main("impact_spread", __doc__.split("\n\n")[0], argv, lambda a: run(a.data_dir, a.seeds),
                            lambda rows, a: table(rows, a.seeds), _write_docs)


if __name__ == "__main__":
    sys.exit(main())
