"""What the CWRU rig's records carry below 2 kHz, where the twin's housings have no mode: the share of the power
and the tones, read as shaft orders.

    .venv/bin/python bench/rig_low_band.py DATA_DIR              # writes the table between the markers of docs/rigs.md
    .venv/bin/python bench/rig_low_band.py DATA_DIR --no-docs    # prints it only

DATA_DIR: the CWRU drive-end records as NumPy files (docs/validation_real.md says where they come from). For each
record, the drive-end channel at 12 kHz (the 48 kHz healthy record decimated as in ``bench/validate_real.py``), its
shaft speed without a tachometer (``realdata.diagnostics.estimate_speed``), a Welch PSD with 0.5 Hz lines (2 s
Hann segments): the share of the 0-5.5 kHz power below 2 kHz, and the lines of 100-2000 Hz that stand at least
``--over-db`` over the band's median PSD, each as a multiple of the shaft speed. An order that comes back in most
records, at both speeds, is the rig's own (it follows the shaft); one that does not is the record's.

A line at one frequency in most records, at both speeds, that is an even multiple of the supply is the motor's
magnetic force (docs/faults.md, ``electrical_harmonics``): its amplitude in the healthy record over the twin's
acceleration per newton of that force (the harmonic solve of ``cwru_rig``) is the force the case carries
(:func:`electrical_force`).
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.signal import find_peaks

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from docs_blocks import replace_block  # noqa: E402
from realdata.diagnostics import G, amplitude_spectrum, decimate, estimate_speed, welch_psd  # noqa: E402
from realdata.records import RecordError, scan  # noqa: E402

DOCS = ROOT / "docs" / "rigs.md"
FS = 12000.0
BAND_HZ = (100.0, 2000.0)
#: Two lines whose orders differ by less than this are one order [multiples of the shaft speed]
ORDER_TOL = 0.03


def read(record) -> tuple[float, float, np.ndarray, np.ndarray]:
    """(shaft speed [Hz], share of 0-5.5 kHz power below 2 kHz, f [Hz], PSD [g^2/Hz]) of a record's DE channel."""
    ch = record.load()
    fr, _ = estimate_speed(ch, record.sample_rate_hz, record.speed_hz_nominal)
    f, p = welch_psd(decimate(ch["DE"], record.sample_rate_hz, FS), FS, resolution_hz=0.5)
    share = p[f < 2000.0].sum() / p[f < 5500.0].sum()
    return fr, float(share), f, p


def tones(f: np.ndarray, p: np.ndarray, fr: float, over_db: float) -> list[tuple[float, float]]:
    """(order, dB over the band's median PSD) of the peaks of 100-2000 Hz at least ``over_db`` over it."""
    m = (f >= BAND_HZ[0]) & (f <= BAND_HZ[1])
    floor = np.median(p[m])
    db = 10.0 * np.log10(p[m] / floor)
    idx, _ = find_peaks(db, height=over_db, distance=3)
    return [(float(f[m][i] / fr), float(db[i])) for i in idx]


def electrical_force(healthy, multiple: int, mains_hz: float = 60.0) -> tuple[float, float, float]:
    """(the healthy record's DE amplitude at ``multiple`` x the supply [m/s^2], the twin's DE vertical acceleration
    per newton of that magnetic force [m/s^2/N], their ratio: the force [N]). The record's amplitude: the largest
    line of its Hann-windowed amplitude spectrum within 0.5 Hz of the frequency; the twin's: ``cwru_rig``'s
    harmonic solve at the record's speed with ``electrical_harmonics = [multiple]`` and 1 N."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem

    ch = healthy.load()
    fr, _ = estimate_speed(ch, healthy.sample_rate_hz, healthy.speed_hz_nominal)
    f, a = amplitude_spectrum(decimate(ch["DE"], healthy.sample_rate_hz, FS), FS)
    f0 = multiple * mains_hz
    measured = float(np.max(a[np.abs(f - f0) <= 0.5])) * G
    case = Case.load("cwru_rig").with_overrides({"baseline.electrical_harmonics": [float(multiple)],
                                                 "baseline.electrical_harmonic_forces_n": [1.0]})
    sp = BkaBem(case).spectrum(fr)
    i = int(np.argmin(np.abs(sp.frequency_hz - f0)))
    per_n = float(np.abs(sp.displacement[i, 1, 0]) * (2.0 * np.pi * sp.frequency_hz[i]) ** 2)   # DE housing, vertical
    return measured, per_n, measured / per_n


def table(rows: list, over_db: float) -> str:
    """The docs' table: per record its speed, low-band share and strongest orders; then the orders most records
    share."""
    out = [f"Lines of 100-2000 Hz at least {over_db:.0f} dB over the band's median PSD (0.5 Hz lines), as orders of "
           "the record's\nshaft speed; the five strongest per record.", "",
           "| record | 1x [Hz] | power below 2 kHz | strongest orders (dB over the floor) |", "|---|---|---|---|"]
    count: dict = defaultdict(list)
    for name, fr, share, lines in rows:
        strongest = sorted(lines, key=lambda t: -t[1])[:5]
        cells = ", ".join(f"{o:.2f}x ({d:.0f})" for o, d in sorted(strongest))
        out.append(f"| {name} | {fr:.2f} | {100 * share:.0f} % | {cells} |")
        seen = set()
        for o, d in lines:
            key = round(o / ORDER_TOL) * ORDER_TOL
            if key not in seen:
                seen.add(key)
                count[key].append(d)
    merged: dict = {}
    for key in sorted(count):
        near = [k for k in merged if abs(k - key) <= ORDER_TOL]
        if near:
            merged[near[0]] += count[key]
        else:
            merged[key] = list(count[key])
    common = sorted(((k, v) for k, v in merged.items() if len(v) >= len(rows) / 2), key=lambda kv: kv[0])
    out += ["", f"Orders present in at least half of the {len(rows)} records (median dB over the floor where "
            "present):", "",
            "| order | records | median dB |", "|---|---|---|"]
    out += [f"| {k:.2f}x | {len(v)} | {np.median(v):.0f} |" for k, v in common]
    fixed: dict = defaultdict(list)                # the same lines by frequency: what does not follow the shaft
    for _name, fr, _share, lines in rows:
        for hz in {round(o * fr) for o, _d in lines}:
            fixed[hz].append(fr)
    steady = [(hz, v) for hz, v in sorted(fixed.items()) if len(v) >= len(rows) / 2 and max(v) - min(v) > 0.2]
    out += ["", "Lines at one frequency [Hz] in at least half of the records, at both speeds (they do not follow the "
            "shaft):", "", "| line [Hz] | records | multiple of 60 Hz |", "|---|---|---|"]
    out += [f"| {hz} | {len(v)} | {hz / 60.0:.2f} |" for hz, v in steady]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data_dir", type=Path, help="folder of the CWRU records (.npz)")
    ap.add_argument("--over-db", type=float, default=25.0, help="a line's least level over the band's median [dB]")
    ap.add_argument("--no-docs", action="store_true", help="print the table, do not write docs/rigs.md")
    a = ap.parse_args(argv)
    try:
        records = [r for r in scan(a.data_dir) if r.fault_bearing in (None, "de")]
    except RecordError as exc:                     # a missing folder, or one without records
        print(f"rig_low_band: data_dir: {exc}", file=sys.stderr)
        return 2
    if not records:
        print(f"rig_low_band: data_dir: no CWRU record in {a.data_dir}", file=sys.stderr)
        return 2
    rows = []
    for r in records:
        fr, share, f, p = read(r)
        rows.append((r.label, fr, share, tones(f, p, fr, a.over_db)))
        print(f"{r.name}: 1x {fr:.3f} Hz, {100 * share:.0f} % below 2 kHz", file=sys.stderr)
    text = table(rows, a.over_db)
    healthy = [r for r in records if r.kind == "healthy"]
    if healthy:
        amp, per_n, force = electrical_force(healthy[0], 6)
        text += (f"\n\nThe 360 Hz line (6 x the supply) in the healthy record: {amp:.3g} m/s^2 at the drive end; the "
                 f"twin's drive-end acceleration per newton of a 6 x supply magnetic force on its core: {per_n:.3g} "
                 f"m/s^2/N; so `electrical_harmonics = [6.0]`, `electrical_harmonic_forces_n = [{force:.2g}]`.")
    print(text)
    if not a.no_docs:
        DOCS.write_text(replace_block(DOCS.read_text(), "rig_low_band", text, "docs/rigs.md"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
