"""The six findings of the physics review, reproduced on the earlier model and measured on the current one, and
every number the paper states next to ours. Rewrites the ``findings`` and ``paper`` blocks of docs/method.md.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python3 bench/physics_findings.py        # ~1 min

"The earlier model" is the model schema 1 described (what the code computed before the physics review): Table 1's
bearings in the FE, the 4-DOF excitation with the whole 82 kg on the DE bearing only, Eq. 5 as printed, the cubic
dent edge, no axial load, no shaft damping, one FE element per case element. It is the current code with these
keys (``EARLIER`` below), so both columns come from the same implementation.
"""

from __future__ import annotations

import dataclasses
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from docs_blocks import replace_block

from bkabem_core.bearing.deep_groove import Bearing
from bkabem_core.excitation.quasi_static import FourDofParameters, compute_excitation, quasi_static_excitation
from bkabem_core.fe.machine import Machine
from bkabem_core.fe.rotor import Mesh, rotor_from_case
from bkabem_core.model.case import Case
from bkabem_core.reference.validation import PAPER_OVERRIDES
from bkabem_core.solve.harmonic import BkaBem

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "method.md"
G = 9.80665
EARLIER = {**PAPER_OVERRIDES, "bearings.de.axial_load_n": 0.0, "bearings.nde.axial_load_n": 0.0,
           "rotor.damping_model": "none", "rotor.elements_per_wavelength": 0.0}


def zeta_range(rotor, f_lo, f_hi, speed_hz=30.0):
    lam = rotor.damped_modes(2 * np.pi * speed_hz)
    f = np.abs(lam.imag) / (2 * np.pi)
    z = -lam.real / np.abs(lam)
    sel = (f > f_lo) & (f < f_hi) & (lam.imag > 0)
    return float(z[sel].min()), float(z[sel].max())


def order_swing(model, f0=50.0, half=0.5, n=201):
    """Largest max/min ratio of one order's DE rotor vertical amplitude within f0 +/- half [Hz]."""
    sw = model.sweep(np.linspace(f0 - half, f0 + half, n))
    a = np.abs(sw.displacement[:, :, 0, 0])
    return float(np.max(a.max(axis=0) / a.min(axis=0)))


def rms_acc(model, f=30.0):
    return float(np.sqrt(0.5 * np.sum(np.abs(model.spectrum(f).acceleration[:, 0, 0]) ** 2)))


def band_db(a, b, lo, hi):
    return 20 * np.log10(np.sqrt(np.sum(a[lo - 1:hi] ** 2)) / np.sqrt(np.sum(b[lo - 1:hi] ** 2)))


def findings(case):
    earlier = case.with_overrides(EARLIER)
    rows = []
    geo = case.bearing_geometry("de")
    b0 = Bearing(geo)
    # 1. bearings
    rad = b0.linearise(0.0, -495.0, average_over_pitch=True)
    zero = Bearing(dataclasses.replace(geo, diametral_clearance_m=0.0)).linearise(0.0, -495.0)
    paper_pt = b0.linearise(0.0, -82 * G, axial_load_n=390.0)
    m = Machine(case)
    de = m.sites["de"].linearisation
    rows.append((
        "1. FE bearings and nonlinear bearings were different bearings",
        f"FE: Table 1, k_v {1.18e8:.3g} / k_h {6.90e7:.3g} N/m; the nonlinear bearing with the 0.059 mm clearance at "
        f"the DE load (495 N): k_v {rad.stiffness_vertical_n_m:.3g} / k_h {rad.stiffness_horizontal_n_m:.3g} N/m "
        f"(pitch mean; zero clearance would give {zero.stiffness_vertical_n_m:.3g} / "
        f"{zero.stiffness_horizontal_n_m:.3g})",
        f"one bearing: Table 1 is the clearance bearing under the paper's 4-DOF load (804 N) and 390 N of axial "
        f"preload (k_v {paper_pt.stiffness_vertical_n_m:.3g}, k_h {paper_pt.stiffness_horizontal_n_m:.3g} N/m, DC "
        f"{paper_pt.displacement_m[1] * 1e6:.2f} um); every consumer uses it at its own load: the FE's DE bearing at "
        f"495 N + 390 N has k_v {de.stiffness_vertical_n_m:.3g} / k_h {de.stiffness_horizontal_n_m:.3g} N/m"))
    # 2. mesh
    old = BkaBem(earlier)
    old4 = BkaBem(earlier, machine=Machine(earlier, mesh=Mesh((4,) * 13)))
    f1 = rotor_from_case(earlier.raw, damping={}).undamped_modes()[0]
    f8 = rotor_from_case(earlier.raw, damping={}, mesh=Mesh((8,) * 13)).undamped_modes()[0]
    near = [float(f1[np.argmin(np.abs(f1 - t))]) for t in (7800.0, 8300.0)]
    moved = [float(f8[np.argmin(np.abs(f1 - t))]) for t in (7800.0, 8300.0)]
    now = BkaBem(case)
    now2 = BkaBem(case, machine=Machine(case, mesh=now.machine.mesh.doubled()))
    f_now = now.rotor.undamped_modes()[0]
    f_now2 = now2.rotor.undamped_modes()[0]
    k = int(np.sum(f_now2 < case.max_frequency_hz))
    rows.append((
        "2. FE mesh not converged",
        f"13 elements: modes {near[0]:.0f} and {near[1]:.0f} Hz move to {moved[0]:.0f} and {moved[1]:.0f} Hz with "
        f"every element split in 8; DE rotor vertical acceleration RMS at 30 Hz {rms_acc(old):.0f} m/s^2, "
        f"{rms_acc(old4):.0f} with 4x refinement",
        f"{now.machine.mesh.n_elements} elements (automatic, 16 per shortest wavelength at 25.6 kHz): every one of "
        f"the {k} modes below 25.6 kHz within {100 * np.max(np.abs(f_now[:k] - f_now2[:k]) / f_now2[:k]):.2f} % of "
        f"the doubled mesh; RMS {rms_acc(now):.1f} m/s^2 against {rms_acc(now2):.1f} doubled"))
    # 3. damping
    z_old = zeta_range(rotor_from_case(earlier.raw, damping={}), 2000.0, 7500.0)
    z_new = zeta_range(now.rotor, 2000.0, 7500.0)
    rows.append((
        "3. no material damping in the shaft",
        f"bending modes 2-7.5 kHz: damping ratio {z_old[0]:.1e} to {z_old[1]:.1e}; one order's amplitude changes "
        f"{order_swing(old):.0f}-fold within +-0.5 Hz of 50 Hz",
        f"stiffness-proportional damping, 1 % at 2 kHz: {z_new[0]:.1e} to {z_new[1]:.1e}; the largest swing within "
        f"+-0.5 Hz of 50 Hz is {order_swing(now):.2f}-fold; the TDSM settles in 0.3-0.5 s (docs/validation.md)"))
    # 4. dent edge (the earlier model's excitation: 4-DOF, 82 kg, no axial load)
    d0 = case.dent()
    cub = Bearing(geo, dataclasses.replace(d0, edge="cubic"))
    ball = Bearing(geo, d0)
    p82 = dataclasses.replace(FourDofParameters.from_case(case, "de"), rotor_mass_kg=82.0, relative_amplitude_threshold=0.0,
                              max_order=0)
    e_c = compute_excitation(cub, p82, 0.0).all_amplitude_m["vertical"]
    e_b = compute_excitation(ball, p82, 0.0).all_amplitude_m["vertical"]
    n_c = quasi_static_excitation(cub, 495.0, 390.0, 4096, 0, 0).all_amplitude_m["vertical"]
    n_b = quasi_static_excitation(ball, 495.0, 390.0, 4096, 0, 0).all_amplitude_m["vertical"]
    rows.append((
        "4. dent edge unphysical at high orders",
        f"10 % cubic edge: a ball unloads over {cub.dent_entry_ramp_rad * cub.outer_race_radius_m * 1e3:.2f} mm; "
        f"against the ball-over-edge path (4-DOF, 82 kg) orders 10-20 {band_db(e_c, e_b, 10, 20):+.1f} dB, "
        f"20-30 {band_db(e_c, e_b, 20, 30):+.1f} dB, 30-50 {band_db(e_c, e_b, 30, 50):+.1f} dB (the review's 7-8 dB "
        f"on orders 10-30 we do not reproduce: {band_db(e_c, e_b, 10, 30):+.1f} dB over that band)",
        f"the ball centre's path over the sharp edges: entry ramp {ball.dent_entry_ramp_rad * ball.outer_race_radius_m * 1e3:.2f} "
        f"mm, ~sqrt(2 R_x h) with R_x = 4.95 mm (the review's ~0.3 mm would be sqrt(2 r_b h) for a ~10 um deep dent); "
        f"the cubic edge is one key away (`dent.edge`); at the case's own load it would be "
        f"{band_db(n_c, n_b, 10, 30):+.1f} dB on orders 10-30"))
    # 5. NDE excitation, 4-DOF ringing
    ex_nde = now.excitations["nde"]
    site = m.sites["de"]
    qs = quasi_static_excitation(site.bearing, 495.0, 390.0, 4096, 0, 0)
    p = dataclasses.replace(FourDofParameters.from_case(case, "de"), rotor_mass_kg=495.0 / G, relative_amplitude_threshold=0.0,
                            max_order=0, samples_per_ball_pass=4096)
    fd = compute_excitation(site.bearing, p, 390.0)
    a_q, a_f = qs.all_amplitude_m["vertical"], fd.all_amplitude_m["vertical"]
    rows.append((
        "5. the NDE's own excitation missing; 4-DOF ringing above ~1/3 of its resonance",
        f"only the DE excited; 4-DOF orders above ~50 carry its {fd.housing_resonance_hz:.0f} Hz housing mode",
        f"every bearing excited under its own load (NDE ball passage: "
        f"{np.sqrt(0.5 * np.sum(ex_nde.amplitude_m['vertical'] ** 2)) * 1e12:.1f} pm RMS vertical, 0 horizontal: "
        f"with the preload all 14 balls carry load and the ball set is stiff; without it the NDE's would be "
        f"{np.sqrt(0.5 * np.sum(quasi_static_excitation(Bearing(geo), 309.1, 0.0).amplitude_m['vertical'] ** 2)) * 1e9:.0f}"
        f" nm); the quasi-static excitation is valid at every order: "
        f"the 4-DOF at 1 Hz agrees to {abs(band_db(a_f, a_q, 1, 30)):.2f} dB on orders 1-30, "
        f"{band_db(a_f, a_q, 100, 150):+.1f} dB on 100-150, {band_db(a_f, a_q, 300, 500):+.1f} dB on 300-500"))
    # 6. DC
    radial804 = b0.linearise(0.0, -82 * G)
    rows.append((
        "6. 'the paper's 12.27 um DC cannot be the relative displacement'",
        "docs/method.md said so",
        f"it can: radial only, the approach beyond the 29.5 um radial play under 804 N is "
        f"{(-radial804.displacement_m[1] - 0.5 * geo.diametral_clearance_m) * 1e6:.2f} um; with the 390 N preload "
        f"the relative displacement itself is {-paper_pt.displacement_m[1] * 1e6:.2f} um"))
    lines = ["| finding | earlier model | now |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines)


def paper_numbers(case):
    geo = case.bearing_geometry("de")
    b = case.bearing("de")
    ex804 = compute_excitation(b, dataclasses.replace(FourDofParameters.from_case(case, "de"), rotor_mass_kg=82.0,
                                                      relative_amplitude_threshold=0, max_order=0), 390.0)
    model = BkaBem(case)
    ex495 = model.excitations["de"]
    rad = dataclasses.replace(FourDofParameters.from_case(case, "de"), rotor_mass_kg=495.0 / G, relative_amplitude_threshold=0,
                              max_order=0)
    b_cubic = case.with_overrides({"dent.edge": "cubic"}).bearing("de")
    ex495r = compute_excitation(b_cubic, rad, 0.0)
    qs495r = quasi_static_excitation(b_cubic, 495.0, 0.0, 2048, 0, 0)
    lin = Bearing(geo).linearise(0.0, -82 * G, axial_load_n=390.0)
    amp = ex804.all_amplitude_m["vertical"]
    n_peaks = [int(np.sum(amp > t * amp.max())) for t in (1e-4, 1e-3, 1e-2)]

    def dominant(speed, di):
        sp = model.spectrum(speed)
        return int(sp.orders[np.argmax(np.abs(sp.displacement[:, 0, di]))])

    dom_v = ", ".join(f"{f:g} Hz: {dominant(f, 0)}" for f in (15, 30, 50))
    dom_h = ", ".join(f"{f:g} Hz: {dominant(f, 1)}" for f in (15, 30, 50))
    rows = [
        ("BPFO at 1 Hz", "6.0598 Hz", f"{b.fault_multipliers().bpfo:.4f} Hz", "textbook kinematics, nominal contact angle"),
        ("impulses per cage period", "14", "14", "one per ball pass (tests/unit/test_excitation.py)"),
        ("Table 1 k_v / k_h", "1.18e8 / 6.90e7 N/m", f"{lin.stiffness_vertical_n_m:.3g} / {lin.stiffness_horizontal_n_m:.3g} N/m",
         "the clearance bearing at 804 N + 390 N axial (the load the paper's 4-DOF model carries)"),
        ("Table 1 c_v / c_h", "2.95e3 / 1.72e3 N s/m", "550 N s/m (both)",
         "Table 1's values are 2.5e-5 s x k (Kraemer); the same table's 0.55 N s/mm damper is what the nonlinear "
         "models use, so the FE uses it too"),
        ("DC vertical", "12.27 um", f"{-lin.displacement_m[1] * 1e6:.2f} um static, {-ex804.dc_m['vertical'] * 1e6:.2f} um "
         f"mean of the 4-DOF response with the dent", "804 N + 390 N axial (393 N would make the mean 12.27); "
         "radial only, 12.28 um is the approach beyond the radial play"),
        ("DC horizontal", "7.6e-4 um", f"{abs(ex804.dc_m['horizontal']) * 1e6:.1e} um", "symmetric load zone: ~0"),
        ("peak-to-peak vertical", "~4 um", f"{ex804.peak_to_peak_m['vertical'] * 1e6:.2f} um (4-DOF at 804 N + 390 N), "
         f"{ex495.peak_to_peak_m['vertical'] * 1e6:.2f} (the FE's 495 N + 390 N), "
         f"{qs495r.peak_to_peak_m['vertical'] * 1e6:.2f} / {ex495r.peak_to_peak_m['vertical'] * 1e6:.2f} "
         "(495 N radial only, cubic edge, quasi-static / 4-DOF)", "only the radial-only 495 N reading gives ~4 um"),
        ("peak-to-peak horizontal", "~0.5 um", f"{ex804.peak_to_peak_m['horizontal'] * 1e6:.2f} um (804 N + 390 N), "
         f"{qs495r.peak_to_peak_m['horizontal'] * 1e6:.2f} / {ex495r.peak_to_peak_m['horizontal'] * 1e6:.2f} (495 N radial only)",
         "as above"),
        ("FFT peaks that are BPFO harmonics", "683", f"{len(ex804.all_orders)} resolved; {n_peaks[0]} / {n_peaks[1]} / "
         f"{n_peaks[2]} above 1e-4 / 1e-3 / 1e-2 of the largest", "depends on the sampling and a threshold the paper "
         "does not give"),
        ("dominant order at the DE, vertical", "2 x BPFO (Fig. 6)", dom_v, "the FE's resonances reorder the lines "
         "with speed; the paper does not state its speed"),
        ("dominant order at the DE, horizontal", "1 x BPFO (Fig. 7)", dom_h, "as above"),
        ("TDSM step / duration", "5e-5 s / 600 s", "10 us or less / 0.3-0.5 s settle + 0.2 s", "exact linear part; the "
         "step resolves the dent's entry ramp (docs/validation.md)"),
    ]
    lines = ["| quantity | paper | bkabem | interpretation |", "|---|---|---|---|"]
    lines += [f"| {a} | {p} | {o} | {i} |" for a, p, o, i in rows]
    return "\n".join(lines)


def main() -> int:
    case = Case.load()
    f = findings(case)
    p = paper_numbers(case)
    text = DOC.read_text()
    text = replace_block(text, "findings", f, "docs/method.md")
    text = replace_block(text, "paper", p, "docs/method.md")
    DOC.write_text(text)
    print(f)
    print()
    print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
