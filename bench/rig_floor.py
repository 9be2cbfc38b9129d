"""The acquisition's input floor and the bearings' broadband floor of the CWRU rig, from its healthy drive-end
record: the two numbers of ``cwru_rig`` that set the level of what lies between the lines
(``measurement.input_noise_m_s2_per_sqrt_hz``, ``baseline.broadband_force_n_per_sqrt_hz``).

    .venv/bin/python bench/rig_floor.py DATA_DIR              # writes the table between the markers of docs/rigs.md
    .venv/bin/python bench/rig_floor.py DATA_DIR --no-docs    # prints it only

DATA_DIR: the CWRU drive-end records as NumPy files (docs/validation_real.md says where they come from).

What it reads. The healthy record's drive-end channel at 12 kHz (decimated as in ``bench/validate_real.py``), a
Welch PSD with 1 Hz lines, and the twin's own spectra at the same lines, computed (not simulated) from the case: the
PSD of its broadband floor (the rolling contacts' random forces through the FE and the measurement chain) and the
gain of the chain without the mount, which the input floor passes (``BroadbandFloor.psd``,
``FloorTransfer.input_transfer``).

1. **Input floor** ``B`` [m/s^2/sqrt(Hz)]: outside the housing's band, where the floor is at least 15 dB under the
   record, the record's median PSD over :data:`INPUT_BANDS_HZ` (the median over lines is blind to the tones
   and shaft orders that stand out of it), less the twin's floor, over the chain's gain: ``B^2 = median((P - P_floor)
   / |G|^2)``. Per band too, to show how flat it is.
2. **Floor** ``S_F`` [N/sqrt(Hz)]: in the housing's band (:data:`HOUSING_BAND_HZ`) the record's mean PSD (its energy),
   less the input floor's, over the twin's floor per unit density: ``S_F^2 = (E - B^2 E_G) / E_1``.
3. **Spread**: every drive-end record's ``B`` the same way, in dB against the healthy record's. A fault record's
   own strikes and lines raise it, so it bounds from above how much the floor moves from one record to the next.
4. **A seeded bearing's roughness** (a defect's ``roughness_db``): each fault record's energy in the housing's band
   over the healthy record's, both less the input floor's share, in dB. Where the record is Gaussian (kurtosis
   within :data:`GAUSSIAN_KURTOSIS` of 3 at its own rate: its strikes carry no weight) that is the seeded bearing's
   floor over the healthy bearing's; elsewhere an upper bound. The median of the Gaussian records per bearing make
   (CWRU's pits up to 21 mil are in SKF bearings, its 28 mil pits in NTN ones) is the twin's ``roughness_db``
   (``bench/realdata/twin.py``, :data:`~realdata.twin.SEEDED_ROUGHNESS_DB`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from docs_blocks import replace_block  # noqa: E402
from realdata.diagnostics import G, decimate, moments, welch_psd  # noqa: E402
from realdata.records import RecordError, scan, seeded_bearing_make  # noqa: E402

DOCS = ROOT / "docs" / "rigs.md"
FIGURE = ROOT / "docs" / "img" / "rig_floor.png"
FS = 12000.0
CASE = "cwru_rig"
CHANNEL = "de_vertical_acceleration"
#: bands outside the housing's (2-4 kHz) and the interference tones' (4.0-4.4 kHz), below the anti-alias roll-off [Hz]
INPUT_BANDS_HZ = ((100.0, 500.0), (500.0, 1000.0), (1000.0, 2000.0), (4500.0, 5300.0))
HOUSING_BAND_HZ = (2000.0, 4000.0)
#: A record whose kurtosis is within this of 3 is Gaussian: its band energy is its floor
GAUSSIAN_KURTOSIS = 1.0


def twin_spectra(f: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(floor PSD at its case density [(m/s^2)^2/Hz], |gain|^2 of the chain without the mount [-],
    the case's floor density [N/sqrt(Hz)]) of the twin's DE vertical acceleration at ``f`` [Hz], interpolated from
    the floor's frame grid (fs / 2^15: finer than 1 Hz)."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem
    from bkabem_core.synth.synthesizer import Synthesizer

    case = Case.load(CASE)
    s = Synthesizer(BkaBem(case), sample_rate_hz=FS, seed=1, features=False, quantities=["acceleration"])
    fl = s.floor
    c = s.channel_names.index(CHANNEL)
    floor = fl.density ** 2 * np.sum(np.abs(fl.transfer[:, c, :]) ** 2, axis=1)
    gain2 = np.abs(fl.path.by_input_noise[:, c]) ** 2
    return (np.interp(f, fl.frequency_hz, floor), np.interp(f, fl.frequency_hz, gain2), fl.density)


def record_psd(record) -> tuple[np.ndarray, np.ndarray]:
    """(f [Hz], PSD [(m/s^2)^2/Hz]) of a record's DE channel at 12 kHz, 1 Hz lines."""
    ch = record.load()
    f, p = welch_psd(decimate(ch["DE"], record.sample_rate_hz, FS), FS, resolution_hz=1.0)
    return f, p * G ** 2


def input_floor_of(f, p, floor, gain2, bands=INPUT_BANDS_HZ) -> float:
    """``B^2`` [(m/s^2)^2/Hz]: the median over ``bands`` of ``(p - floor) / gain2``."""
    m = np.zeros(f.size, bool)
    for lo, hi in bands:
        m |= (f >= lo) & (f < hi)
    return float(np.median((p[m] - floor[m]) / gain2[m]))


def calibrate(healthy, records) -> dict:
    """The numbers of the module docstring."""
    f, p = record_psd(healthy)
    floor, gain2, density = twin_spectra(f)
    b2 = input_floor_of(f, p, floor, gain2)
    per_band = {band: input_floor_of(f, p, floor, gain2, (band,)) for band in INPUT_BANDS_HZ}
    lo, hi = HOUSING_BAND_HZ
    h = (f >= lo) & (f < hi)
    e_meas, e_gain, e_floor = p[h].sum(), gain2[h].sum(), floor[h].sum()
    spread, rough = [], []
    e_input = b2 * e_gain
    for r in records:
        fr, pr = record_psd(r)
        spread.append((r.label, 10 * np.log10(input_floor_of(fr, pr, floor, gain2) / b2)))
        if r.kind != "healthy":
            k = moments(r.load()["DE"])["kurtosis"]
            db = 10 * np.log10((pr[h].sum() - e_input) / (e_meas - e_input))
            rough.append((r.label, seeded_bearing_make(r.size_mils), float(k), float(db), abs(k - 3.0) < GAUSSIAN_KURTOSIS))
    return {"input_floor": float(np.sqrt(b2)), "per_band": {k: float(np.sqrt(v)) for k, v in per_band.items()},
            "density_case": density, "density": float(density * np.sqrt(max(e_meas - b2 * e_gain, 0.0) / e_floor)),
            "housing_db": (10 * np.log10(e_meas), 10 * np.log10(e_floor + b2 * e_gain), 10 * np.log10(e_floor)),
            "spread": spread, "roughness": rough,
            "roughness_db": {m: float(np.median([db for _, mk, _, db, g in rough if g and mk == m]))
                             for m in sorted({mk for _, mk, _, _, g in rough if g})}}


def table(c: dict) -> str:
    b = c["input_floor"]
    rows = [f"The healthy record's input floor, `B = {b:.2g}` m/s^2/sqrt(Hz) ({b / G:.2g} g/sqrt(Hz), "
            f"{20 * np.log10(b / G):.0f} dB re 1 g^2/Hz): the median over "
            + ", ".join(f"{lo / 1e3:g}-{hi / 1e3:g}" for lo, hi in INPUT_BANDS_HZ)
            + " kHz of the record's PSD less the twin's floor, over the gain of the chain without the mount. Per band:",
            "", "| band [kHz] | B [m/s^2/sqrt(Hz)] | dB against B |", "|---|---|---|"]
    for (lo, hi), v in c["per_band"].items():
        rows.append(f"| {lo / 1e3:g}-{hi / 1e3:g} | {v:.2g} | {20 * np.log10(v / b):+.1f} |")
    m, t, fl = c["housing_db"]
    rows += ["", f"In the housing's band ({HOUSING_BAND_HZ[0] / 1e3:g}-{HOUSING_BAND_HZ[1] / 1e3:g} kHz) the record "
             f"holds {m:.1f} dB re 1 (m/s^2)^2, the twin {t:.1f} dB with the input floor ({fl:.1f} dB of it its floor "
             f"at {c['density_case']:.2g} N/sqrt(Hz)): the floor that the record's energy there leaves room for is "
             f"{c['density']:.2g} N/sqrt(Hz).", "",
             "Each drive-end record's B the same way, in dB against the healthy record's (a fault record's strikes and "
             "lines raise it):", "", "| record | B against the healthy record [dB] |", "|---|---|"]
    rows += [f"| {label} | {db:+.1f} |" for label, db in c["spread"]]
    v = np.array([db for _, db in c["spread"]])
    rows += ["", f"Over the {v.size} records: median {np.median(v):+.1f} dB, 10-90 % {np.percentile(v, 10):+.1f} "
             f"to {np.percentile(v, 90):+.1f} dB.", "",
             f"A seeded bearing's roughness: each fault record's energy in {HOUSING_BAND_HZ[0] / 1e3:g}-"
             f"{HOUSING_BAND_HZ[1] / 1e3:g} kHz over the healthy record's (both less the input floor's share). Where "
             f"the record is Gaussian (kurtosis within {GAUSSIAN_KURTOSIS:g} of 3) it is the bearing's floor over the "
             "healthy one's; elsewhere an upper bound (the strikes add to it).", "",
             "| record | bearing | kurtosis | energy over the healthy record [dB] | Gaussian |", "|---|---|---|---|---|"]
    rows += [f"| {label} | {mk} | {k:.1f} | {db:+.1f} | {'yes' if g else ''} |" for label, mk, k, db, g in c["roughness"]]
    rows += ["", "The twin's `roughness_db` of a seeded bearing, the median of the Gaussian records: "
             + ", ".join(f"{mk} {db:.1f} dB" for mk, db in c["roughness_db"].items()) + "."]
    return "\n".join(rows)


def figure(healthy, path: Path) -> None:
    """The healthy record's DE PSD and the twin's (one 10 s run of ``cwru_rig`` at the record's speed), 1 Hz lines."""
    from realdata.diagnostics import estimate_speed
    from realdata.report import _plt
    from realdata.twin import Condition, synthesize

    f, p = record_psd(healthy)
    fr, _ = estimate_speed(healthy.load(), healthy.sample_rate_hz, healthy.speed_hz_nominal)
    twin = synthesize(Condition("healthy"), CASE, 1, fr, FS, 10.0)
    ft, pt = welch_psd(twin["DE"], FS, resolution_hz=1.0)
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 3.6))
    ax.semilogy(f / 1e3, p / G ** 2, color="black", lw=0.6, label="measured (healthy, 0 hp)")
    ax.semilogy(ft / 1e3, pt, color="tab:orange", lw=0.6, alpha=0.85, label=f"twin ({CASE})")
    ax.set_xlim(0, 6)
    ax.set_ylim(1e-10, 1e-3)
    ax.set_xlabel("frequency [kHz]")
    ax.set_ylabel("PSD [g$^2$/Hz]")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data_dir", type=Path, help="folder of the CWRU records (.npz)")
    ap.add_argument("--no-docs", action="store_true", help="print the table, do not write docs/rigs.md")
    a = ap.parse_args(argv)
    try:
        records = [r for r in scan(a.data_dir) if r.fault_bearing in (None, "de")]
    except RecordError as exc:                     # a missing folder, or one without records
        print(f"rig_floor: data_dir: {exc}", file=sys.stderr)
        return 2
    healthy = [r for r in records if r.kind == "healthy"]
    if not healthy:
        print(f"rig_floor: data_dir: no healthy CWRU record in {a.data_dir}", file=sys.stderr)
        return 2
    text = table(calibrate(healthy[0], records))
    print(text)
    if not a.no_docs:
        DOCS.write_text(replace_block(DOCS.read_text(), "rig_floor", text, "docs/rigs.md"))
        figure(healthy[0], FIGURE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
