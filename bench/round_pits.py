"""What a ball feels from CWRU's round pits: the bridged drop of 7/14/21/28 mil pits in a 6205 (docs/faults.md).

    .venv/bin/python bench/round_pits.py                       # the CWRU drive-end 6205, 36 N radial (~20 N per ball)
    .venv/bin/python bench/round_pits.py --radial-n 36 200 600 --mils 7 14 21 28 40
    .venv/bin/python bench/round_pits.py --case cwru_rig              # the drops the rig's machine gives its DE pits

For each radial load on the bearing (gravity, downwards): the static equilibrium of the intact 6205-2RS JEM
(catalogue geometry, CN clearance, the model's conformity 0.52 and steel), its largest ball load Q, and at each
contact (inner, outer) the Hertz ellipse (a across, b along the rolling direction) and approach; then for each pit
(diameter in mil, CWRU's depth 11 mil): the share of the contact's load over the centred pit, the drop of a rigid
ball onto the rim, the effective drop the models use (the elastic half-space's extra approach at Q,
:mod:`bkabem_core.bearing.defects.round_pit`) and the half-width of the drop profile. With ``--case``: the machine of
that case (its FE's static load on the DE bearing) with each pit in the DE inner race and in the outer race at
6 o'clock, as every model of it sees the pit (``Dent.bridging_load_n``, the effective drop at the pit's centre).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import copy  # noqa: E402

from bkabem_core.bearing.deep_groove import Bearing, Dent  # noqa: E402
from bkabem_core.bearing.defects.round_pit import pit_contact  # noqa: E402
from bkabem_core.model.positions import geometry_of, resolve  # noqa: E402

MIL = 25.4e-6
DEPTH_M = 11 * MIL


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designation", default="6205-2RS JEM")
    ap.add_argument("--radial-n", type=float, nargs="+", default=[36.0], help="radial loads on the bearing [N]")
    ap.add_argument("--mils", type=float, nargs="+", default=[7, 14, 21, 28], help="pit diameters [0.001 in]")
    ap.add_argument("--case", default=None, help="a case (embedded name or TOML): its machine's DE pits instead")
    args = ap.parse_args(argv)
    if args.case:
        return in_machine(args.case, args.mils)
    g = geometry_of(resolve({"designation": args.designation, "damping_n_s_m": 0.0}, "bearing").table)
    intact = Bearing(g)
    print(f"{g.designation}: {g.n_balls} balls of {g.ball_diameter_m * 1e3:.3f} mm, pitch {g.pitch_diameter_m * 1e3:.2f}"
          f" mm, clearance {g.diametral_clearance_m * 1e6:.1f} um; pits {DEPTH_M * 1e6:.0f} um deep")
    for radial in args.radial_n:
        q = intact.peak_ball_load_n(intact.state(0.0, -radial))
        print(f"\nradial load {radial:g} N: largest ball load Q = {q:.1f} N")
        for contact in ("inner", "outer"):
            ref = pit_contact(Dent(MIL, DEPTH_M, 0.0, shape="round_pit", bridging_load_n=q), intact.contact_geometry,
                              contact)
            a, b = ref.contact_ellipse_m()
            print(f"  {contact} contact: a = {a * 1e6:.0f} um across, b = {b * 1e6:.0f} um along, approach "
                  f"{ref.hertz_approach_m() * 1e6:.3f} um")
            print("    pit [mil]  D [um]  share of load  rigid drop [um]  effective drop [um]  profile half-width [um]"
                  "  [s]")
            for mils in args.mils:
                dent = Dent(mils * MIL, DEPTH_M, 0.0, shape="round_pit", bridging_load_n=q)
                pc = pit_contact(dent, intact.contact_geometry, contact)
                t0 = time.perf_counter()
                prof = pc.profile()
                dt = time.perf_counter() - t0
                print(f"    {mils:9g}  {mils * MIL * 1e6:6.0f}  {pc.hertz_load_fraction():13.3f}  "
                      f"{pc.rigid_drop_m(0.0) * 1e6:15.3f}  {prof.max_drop_m * 1e6:19.3f}  "
                      f"{prof.support_m * 1e6:23.0f}  {dt:4.1f}")
    return 0


def in_machine(name: str, mils_list) -> int:
    """Each pit in the DE bearing of the case's machine: the load it is bridged at and its effective drop."""
    from bkabem_core.fe.machine import Machine
    from bkabem_core.model.case import Case

    base = Case.load(name)
    print(f"{name}: pits {DEPTH_M * 1e6:.0f} um deep in the DE bearing ({base.bearing_geometry('de').designation})")
    print("  race   pit [mil]  radial load [N]  bridging ball load [N]  effective drop [um]")
    for race in ("inner", "outer"):
        for mils in mils_list:
            raw = copy.deepcopy(base.raw)
            d = {"bearing": "de", "race": race, "shape": "round_pit", "length_m": mils * MIL, "depth_m": DEPTH_M,
                 "edge": "ball", "edge_fraction": 0.1, **({"clock": 6} if race == "outer" else {"angle_deg": 0.0})}
            raw["defects"] = [d]
            site = Machine(Case.from_dict(raw, f"{name} + pit")).sites["de"]
            print(f"  {race:5s}  {mils:9g}  {abs(site.radial_load_n[1]):15.1f}  "
                  f"{site.bearing.defects[0].bridging_load_n:22.1f}  {site.bearing.dent_effective_depth_m * 1e6:19.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
