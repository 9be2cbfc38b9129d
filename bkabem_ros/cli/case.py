"""``bkabem case``: a machine in minutes -- a documented starting case, and what a case's machine is.

    bkabem case new --de 6205 --nde 6203 --rotor-mass 12 --speed-range 5:60 -o my_motor.toml
    bkabem case check my_motor.toml                 # static loads, stiffnesses, fault frequencies, modes, notes
    bkabem case check electric_motor_6010 --json    # any case: an embedded name or a file

``case new`` writes a case in the compact form (:mod:`bkabem_core.model.compact`) by the rules of
:mod:`bkabem_core.model.starting`, every number with a comment saying where it comes from; the rotor core is
lumped in as many slices as the FE mesh has elements under it (the mesh rule of
:func:`bkabem_core.fe.rotor.mesh_for`). The file is loaded as any case before it is written. ``case check`` prints
:func:`bkabem_core.fe.summary.machine_summary`. docs/machines.md.

Bad input (an unknown designation or clearance class, a speed range that is not LO:HI, a rotor the rules cannot
build, an invalid case): one line naming the option or the case key, exit code 2 (:mod:`bkabem_ros.cli.base`).
Parsing imports nothing of ``bkabem_core``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

from bkabem_ros.cli.base import Parser, UsageError, add_debug, finite_float, output_path, writing

_NAME = re.compile(r"[A-Za-z0-9_.-]+")


def speed_range(text: str) -> tuple[float, float]:
    """argparse type of ``--speed-range LO:HI`` [Hz]: two finite numbers, 0 <= LO < HI."""
    lo_hi = str(text).split(":")
    if len(lo_hi) != 2:
        raise argparse.ArgumentTypeError(f"--speed-range must be LO:HI in Hz, e.g. 5:60 (got {text!r})")
    lo, hi = (finite_float("--speed-range", 0.0)(v.strip()) for v in lo_hi)
    if not lo < hi:
        raise argparse.ArgumentTypeError(f"--speed-range: the lowest speed must be below the highest (got {text!r})")
    return lo, hi


def add_parser(sub):
    """Register ``bkabem case`` with its actions ``new`` and ``check``."""
    p = sub.add_parser("case", help="a machine in minutes: write a documented starting case (new), say what a "
                                    "case's machine is (check)",
                       description="Write a documented starting case in the compact form from two catalogue "
                                   "bearings, a rotor mass and a speed range (new), or validate any case and print "
                                   "its static loads, bearing stiffnesses, fault frequencies, modes in the band and "
                                   "what the plausibility bounds say (check). docs/machines.md")
    actions = p.add_subparsers(dest="case_action", required=True, parser_class=Parser, metavar="ACTION",
                               help="new or check")
    n = actions.add_parser("new", help="write a documented starting case (compact form) from a few numbers")
    n.add_argument("--de", required=True, metavar="DESIGNATION",
                   help='DE bearing, a catalogue designation (e.g. 6205, 6205-2RS1/C3; `bkabem bearing --list`)')
    n.add_argument("--nde", required=True, metavar="DESIGNATION", help="NDE bearing, a catalogue designation")
    n.add_argument("--rotor-mass", required=True, type=finite_float("--rotor-mass", 0.0, strict=True),
                   metavar="KG", help="mass of the rotor, shaft and core [kg]")
    n.add_argument("--speed-range", required=True, type=speed_range, metavar="LO:HI",
                   help="lowest and highest shaft speed [Hz], e.g. 5:60")
    n.add_argument("--clearance", default=None, metavar="CLASS",
                   help="ISO 5753-1 radial clearance class of both bearings: C2, CN, C3, C4, C5 (default: each "
                        "designation's own, else CN)")
    n.add_argument("--name", default=None, help="the case's name (default: the file name without .toml)")
    n.add_argument("--sample-rate", type=finite_float("--sample-rate", 0.0, strict=True), default=51200.0,
                   metavar="HZ", help="highest sample rate the case serves [Hz] (the FE is converged up to half "
                                      "of it; default 51200)")
    n.add_argument("-o", "--out", required=True, type=output_path("-o", (".toml",)), metavar="FILE",
                   help="the case file to write (.toml)")
    n.set_defaults(func=cmd_new)
    c = actions.add_parser("check", help="validate a case and summarise its machine")
    c.add_argument("file", metavar="FILE", help="a case: TOML file (compact or full form) or embedded name")
    c.add_argument("--json", action="store_true", help="one JSON document (SI units)")
    c.set_defaults(func=cmd_check)
    for sp in (n, c):
        add_debug(sp)
    return p


# --------------------------------------------------------------------------- new
def cmd_new(args) -> int:
    import bkabem_core.model.catalogue as catalogue
    from bkabem_core.model.case import Case, CaseError
    from bkabem_core.model.starting import StartingError, starting_case, starting_machine

    for option, designation in (("--de", args.de), ("--nde", args.nde)):
        try:
            catalogue.lookup(designation)
        except catalogue.CatalogueError as exc:
            raise UsageError(f"{option}: {exc}") from None
    cls = None
    if args.clearance is not None:
        try:
            cls = catalogue.parse_clearance_class(args.clearance)
        except catalogue.CatalogueError as exc:
            raise UsageError(f"--clearance: {exc}") from None
    name = args.name if args.name is not None else Path(args.out).name[:-len(".toml")]
    if not _NAME.fullmatch(name):
        raise UsageError(f"--name: {name!r}: a case name is letters, digits, '_', '.' and '-' "
                         f"{'(give --name)' if args.name is None else ''}".rstrip())

    def text(slices: int) -> tuple[str, object]:
        try:
            t = starting_case(args.de, args.nde, args.rotor_mass, args.speed_range, name, cls, args.sample_rate,
                              slices)
        except StartingError as exc:
            option = {"de": "--de", "nde": "--nde", "rotor_mass_kg": "--rotor-mass"}[exc.what]
            raise UsageError(f"{option}: {exc}") from None
        try:
            return t, Case.from_toml(t, source=str(args.out))
        except CaseError as exc:
            raise UsageError(f"the starting case of these options is not valid: {exc.key}: {exc.reason}") from None

    _, first = text(1)
    t, case = text(_core_slices(first, starting_machine(args.de, args.nde, args.rotor_mass).core_length_m))
    with writing("-o", args.out):
        Path(args.out).write_text(t, encoding="utf-8")
    r = case.raw
    z = r["rotor"]["node_positions_m"]
    where = {b: z[r["bearings"][b]["rotor_node"] - 1] for b in ("de", "nde")}
    print(f"wrote {args.out}: case {name}, {args.de} (DE) at {where['de']:g} m and {args.nde} (NDE) at "
          f"{where['nde']:g} m, {len(z)} shaft nodes, {args.speed_range[0]:g}-{args.speed_range[1]:g} Hz; "
          f"what it is: bkabem case check {args.out}")
    return 0


def _core_slices(case, length_m: float) -> int:
    """Slices of a rotor core ``length_m`` long: one per FE element the mesh rule puts under it (``case`` has the
    core in one slice, at its centre: the elements on either side of that node lie under it)."""
    from bkabem_core.fe.rotor import mesh_for

    r = case.raw["rotor"]
    node = int(next(d for d in r["disks"] if d["name"] == "core")["node"])
    mesh = mesh_for(case.raw, case.max_frequency_hz, float(r["elements_per_wavelength"]))
    z = r["node_positions_m"]
    h = min((z[i + 1] - z[i]) / mesh.pieces[i] for i in (node - 2, node - 1))
    return max(1, math.ceil(length_m / h - 1e-9))


# --------------------------------------------------------------------------- check
def cmd_check(args) -> int:
    from bkabem_core.fe.summary import machine_summary
    from bkabem_core.model.case import Case, CaseError, parse_toml, read_input_text
    from bkabem_core.model.compact import speed_range_hz

    case = Case.load(args.file)
    text, source, _ = read_input_text(args.file, "cases", "case", "case", CaseError)
    summary = machine_summary(case, speed_range_hz(parse_toml(text, source, CaseError)))
    if args.json:
        json.dump(summary, sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(summary_text(summary))
    return 0


def summary_text(s: dict, max_modes: int = 24) -> str:
    """The text of :func:`bkabem_core.fe.summary.machine_summary`."""
    r = s["rotor"]
    lo, hi = s["speed_range_hz"]
    z = r["bearing_positions_m"]
    out = [f"case {s['case']} ({s['source']}, hash {s['case_hash']}): valid",
           f"rotor        {r['mass_kg']:.4g} kg, {r['length_m']:.4g} m long; bearings at {z['de']:.4g} m (DE) and "
           f"{z['nde']:.4g} m (NDE), span {r['span_m']:.4g} m",
           f"FE model     {r['shaft_nodes']} shaft nodes, {r['fe_elements']} elements converged up to "
           f"{s['band_hz']:g} Hz, {r['dof']} DOF",
           f"speeds       {lo:g} to {hi:g} Hz ({lo * 60:g} to {hi * 60:g} r/min)"]
    if s.get("load_table"):
        out.append("loads        " + ", ".join(f"{row['load_hp']:g} hp: {row['speed_hz'] * 60:.6g} r/min"
                                               for row in s["load_table"]) + " (a data set's load_hp)")
    for b, d in s["bearings"].items():
        fe = d["fe_bearing"]
        out += [f"{b.upper() + ' bearing':<12} {d['designation']}: {d['n_balls']} balls of {d['ball_diameter_m'] * 1e3:.4g} mm "
                f"on {d['pitch_diameter_m'] * 1e3:.4g} mm (geometry {d['geometry_status']}), clearance "
                f"{d['diametral_clearance_m'] * 1e6:.3g} um ({d['clearance']})",
                f"  static load   {d['static_radial_load_n']:.4g} N radial"
                + (f" (the weight's share and {d['applied_radial_load_n']:.4g} N applied)"
                   if d["applied_radial_load_n"] > 0 else "") + f", {d['axial_load_n']:.4g} N axial; "
                f"s0 = C0 / P0 = {d['static_safety']:.3g} (C0 {d['static_load_rating_n'] / 1e3:.4g} kN)",
                f"  FE bearing    ({fe['source']}) stiffness {fe['stiffness_n_m']['horizontal']:.4g} / "
                f"{fe['stiffness_n_m']['vertical']:.4g} N/m, damping {fe['damping_n_s_m']['horizontal']:.4g} / "
                f"{fe['damping_n_s_m']['vertical']:.4g} N s/m (horizontal / vertical)",
                "  fault freq.   per shaft Hz: " + _ff(d["fault_multipliers"], "{:.4f}")]
        for speed, ff in d["fault_frequencies_hz"].items():
            out.append(f"  at {speed + ' Hz':<10} " + _ff(ff, "{:.2f} Hz"))
    modes = s["modes"]
    out.append(f"modes        {len(modes)} below {s['band_hz']:g} Hz (undamped, at standstill, bearings linearised; where most of a "
               f"mode's kinetic energy is)")
    for m in modes[:max_modes]:
        flag = "  <- in the speed range" if m["in_speed_range"] else ""
        out.append(f"  {m['frequency_hz']:10.2f} Hz  {m['most_energy_at']:<30} housings {100 * m['housing_energy']:3.0f} %"
                   f"{flag}")
    if len(modes) > max_modes:
        out.append(f"  ... {len(modes) - max_modes} more (--json for all)")
    p = s["plausibility"]
    fe = p["fe_elements"]
    widened = f"; bounds widened by the case: {', '.join(p['widened_bounds'])}" if p["widened_bounds"] else ""
    out.append(f"plausibility every value within its bounds (a case that loads is); FE mesh {fe['elements']:.0f} "
               f"elements of at most {fe['bound'][1]:g}{widened}")
    out += ["notes" if s["notes"] else "notes        none"] + [f"  - {n}" for n in s["notes"]]
    return "\n".join(out) + "\n"


def _ff(ff: dict, fmt: str) -> str:
    return ", ".join(f"{k.upper()} {fmt.format(ff[k])}" for k in ("ftf", "bpfo", "bpfi", "bsf"))
