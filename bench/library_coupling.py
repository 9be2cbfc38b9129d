"""How much shaft-rate content a load that turns with the shaft gives the fault library's outer race, and what the
same load does to the library's healthy machine.

    .venv/bin/python bench/library_coupling.py                  # writes the table between the markers of docs/faults.md
    .venv/bin/python bench/library_coupling.py --no-docs        # prints it only

The CWRU rig's outer-race records read 1x about 35 dB over their squared-envelope floor; the fault library's outer
race (``motor_6010_outer``) about 3 dB, because no load turns with its shaft. A coupling force (``baseline.
coupling_force_n``: a flexible coupling's hub runout times its radial stiffness) is one. It is also a 1x force on
the rotor, so it raises the machine's own vibration: ISO 10816-1 (ISO 20816-1) puts a class I machine's healthy
zone A/B under 1.8 mm/s RMS of housing velocity. For each force this script reads:

- the healthy machine (``motor_6010_healthy`` with the force): the largest housing velocity RMS over 10-1000 Hz of
  the four housing channels, from the harmonic solve's lines at 25 Hz;
- the outer race (``motor_6010_outer`` with the force): 8 s of DE vertical housing acceleration at 25 Hz rendered
  by the product's synthesiser as a user runs it (slip 1 %, the strikes' spread, the case's floor and sensor
  noise, seed 1), read by the textbook diagnostics of ``bench/realdata/diagnostics.py`` (not the product's code):
  the squared-envelope spectrum of the band the fast kurtogram picks, and the level of 1x and BPFO over its floor.

Nothing is fitted: the forces are a sweep, the rest is the library's cases.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from docs_blocks import replace_block  # noqa: E402
from realdata.diagnostics import envelope_analysis  # noqa: E402
from realdata.kurtogram import fast_kurtogram, pick_band  # noqa: E402

DOCS = ROOT / "docs" / "faults.md"
FORCES_N = (0.0, 10.0, 15.0, 20.0, 30.0, 50.0)
SPEED_HZ = 25.0
FS = 25600.0
SECONDS = 8.0
ISO_AB_MM_S = 1.8


def healthy_velocity_mm_s(force_n: float) -> float:
    """Largest housing velocity RMS [mm/s] over 10-1000 Hz of the healthy library machine with ``force_n``."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem

    sp = BkaBem(Case.load("motor_6010_healthy").with_overrides({"baseline.coupling_force_n": force_n})).spectrum(
        SPEED_HZ)
    band = (sp.frequency_hz >= 10.0) & (sp.frequency_hz <= 1000.0)
    return max(float(np.sqrt(0.5 * np.sum(np.abs(sp.velocity[band, li, di]) ** 2))) * 1e3
               for li in (1, 3) for di in (0, 1))


def outer_envelope(force_n: float) -> dict:
    """1x and BPFO [dB over the floor] in the kurtogram band's squared envelope of the library's outer race."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem
    from bkabem_core.synth.synthesizer import Synthesizer

    model = BkaBem(Case.load("motor_6010_outer").with_overrides({"baseline.coupling_force_n": force_n}))
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.5, quantities=("acceleration",), slip=0.01, seed=1,
                    features=False)
    x = np.concatenate([s.next_chunk(SPEED_HZ).channel("de_vertical_acceleration")
                        for _ in range(int(SECONDS / 0.5))]).astype(float)
    fm = model.fault_multipliers
    mult = {"bpfo": fm.bpfo, "bpfi": fm.bpfi, "ftf": fm.ftf, "bsf": fm.bsf}
    node = pick_band(fast_kurtogram(x, FS, 3), FS)
    ses = envelope_analysis(x, FS, (node.f_lo, node.f_hi), SPEED_HZ, mult, mains_hz=50.0)
    return {"band_hz": (node.f_lo, node.f_hi), "1x": ses["levels"]["1x"], "BPFO": ses["levels"]["BPFO"]}


def table(rows: list[dict]) -> str:
    out = [f"The fault library with a coupling force, at {SPEED_HZ:g} Hz (`bench/library_coupling.py`): the healthy "
           f"machine's largest housing velocity RMS over 10-1000 Hz (ISO 10816-1 zone A/B of a class I machine: "
           f"under {ISO_AB_MM_S} mm/s), and the outer race's 1x and BPFO over the floor of the squared envelope of "
           f"the band the fast kurtogram picks ({SECONDS:g} s, slip 1 %, seed 1).", "",
           "| coupling force [N] | healthy: velocity RMS [mm/s] | zone A/B | outer race: 1x [dB] | BPFO [dB] | band [kHz] |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        lo, hi = r["band_hz"]
        out.append(f"| {r['force_n']:g} | {r['velocity_mm_s']:.2f} | {'yes' if r['velocity_mm_s'] < ISO_AB_MM_S else 'no'}"
                   f" | {r['1x']:.0f} | {r['BPFO']:.0f} | {lo / 1e3:.1f}-{hi / 1e3:.1f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-docs", action="store_true", help="print the table only")
    args = ap.parse_args(argv)
    rows = []
    for f in FORCES_N:
        rows.append({"force_n": f, "velocity_mm_s": healthy_velocity_mm_s(f), **outer_envelope(f)})
        print(f"force {f:g} N done", file=sys.stderr)
    text = table(rows)
    print(text)
    if not args.no_docs:
        DOCS.write_text(replace_block(DOCS.read_text(), "library_coupling", text, "docs/faults.md"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
