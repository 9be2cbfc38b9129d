"""``bkabem bearing``: a bearing of the catalogue -- its geometry and where it comes from, ratings, speeds, radial
clearance and fault multipliers.

    bkabem bearing 6205                     # the 62 series row: published geometry (GMN), SKF ratings
    bkabem bearing 6205-2RS1/C3 --json      # seals and a clearance class map to the 6205 row
    bkabem bearing 6310 --clearance C4      # an estimated row, with the C4 clearance of its bore
    bkabem bearing "6205-2RS JEM"           # the CWRU rig's drive-end bearing
    bkabem bearing --list                   # every designation with the status of its geometry

The fault multipliers (FTF, BPFO, BPFI, BSF and 2 x BSF, per Hz of shaft speed, outer ring fixed, rolling without
slip) are those of :meth:`bkabem_core.bearing.deep_groove.Bearing.fault_multipliers`, the formulas every model of
bkabem uses. Catalogue and matching rules: :mod:`bkabem_core.model.catalogue` and docs/catalogue.md.

Bad input (an unknown designation or clearance class): one line naming the argument and the reason, exit code 2
(:mod:`bkabem_ros.cli.base`). The catalogue and numpy are imported when the command runs, not by ``bkabem --help``.
"""

from __future__ import annotations

import json
import math
import sys
import textwrap

from bkabem_ros.cli.base import UsageError

_LABEL = 20          # width of the label column of the text output
_WIDTH = 110


def add_parser(sub):
    """Register ``bkabem bearing``."""
    p = sub.add_parser("bearing", help="a bearing of the catalogue: geometry, provenance, ratings, fault multipliers",
                       description="Show a deep-groove ball bearing of the catalogue (docs/catalogue.md): its internal "
                                   "geometry and whether it is published, derived or estimated, with the source, the "
                                   "boundary dimensions, load ratings and speeds, the ISO 5753-1 radial clearance of "
                                   "its bore and its fault multipliers.")
    p.add_argument("designation", nargs="?", default=None, metavar="DESIGNATION",
                   help='e.g. 6205, 6205-2RS1/C3, "6205-2RS JEM" (CWRU), "NICE (MFPT)"; --list shows them all')
    p.add_argument("--list", action="store_true", help="list the catalogue's designations and their geometry status")
    p.add_argument("--clearance", default=None, metavar="CLASS",
                   help="radial clearance class C2, CN, C3, C4 or C5 (default: the designation's suffix, else CN)")
    p.add_argument("--json", action="store_true", help="one JSON document (SI units; null where unknown)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import bkabem_core.model.catalogue as catalogue

    if args.list:
        if args.designation is not None or args.clearance is not None:
            raise UsageError("--list: takes no DESIGNATION and no --clearance")
        return _print_list(catalogue, args.json)
    if args.designation is None:
        raise UsageError("DESIGNATION: missing (give a designation, or --list for the catalogue)")
    try:
        b = catalogue.lookup(args.designation)
    except catalogue.CatalogueError as exc:
        raise UsageError(f"DESIGNATION: {exc}") from None
    cls = b.clearance_class
    if args.clearance is not None:
        try:
            cls = catalogue.parse_clearance_class(args.clearance)
        except catalogue.CatalogueError as exc:
            raise UsageError(f"--clearance: {exc}") from None
        stated = b.clearance_class != "CN" or "CN" in b.suffixes
        if stated and cls != b.clearance_class:
            raise UsageError(f"--clearance: {cls} contradicts the clearance class {b.clearance_class} of "
                             f"{b.designation}")
    clearance = None
    if math.isfinite(b.bore_diameter_m):
        try:
            clearance = b.radial_clearance_m(cls)
        except catalogue.CatalogueError as exc:
            raise UsageError(f"--clearance: {exc}" if args.clearance else f"DESIGNATION: {exc}") from None
    elif args.clearance is not None:
        raise UsageError(f"--clearance: the bore of {b.catalogue_key} is not published, so its ISO 5753-1 "
                         f"clearance is not known")
    mult = fault_multipliers(b)
    if args.json:
        _print_json(_document(b, cls, clearance, mult))
    else:
        sys.stdout.write(_text(b, cls, clearance, mult))
    return 0


def fault_multipliers(b):
    """FTF, BPFO, BPFI, BSF [per shaft Hz] of a catalogue bearing: the bearing model's own formulas."""
    from bkabem_core.bearing.deep_groove import Bearing, BearingGeometry

    geometry = BearingGeometry(designation=b.designation, ball_diameter_m=b.ball_diameter_m,
                               pitch_diameter_m=b.pitch_diameter_m, n_balls=b.n_balls,
                               contact_angle_rad=b.contact_angle_rad, bore_diameter_m=b.bore_diameter_m,
                               outer_diameter_m=b.outer_diameter_m, static_load_rating_n=b.static_load_rating_n)
    return Bearing(geometry).fault_multipliers()


# --------------------------------------------------------------------------- output
def _finite(x):
    """JSON has no NaN: an unknown number is null."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def _document(b, cls, clearance, mult) -> dict:
    doc = {k: _finite(v) for k, v in b.to_dict().items()}
    doc["radial_clearance"] = None if clearance is None else {
        "clearance_class": cls, "min_m": clearance[0], "max_m": clearance[1], "standard": "ISO 5753-1"}
    doc["fault_multipliers_per_shaft_hz"] = {"ftf": mult.ftf, "bpfo": mult.bpfo, "bpfi": mult.bpfi, "bsf": mult.bsf,
                                             "two_bsf": 2.0 * mult.bsf}
    return doc


def _print_json(obj) -> None:
    json.dump(obj, sys.stdout, indent=1, allow_nan=False)
    sys.stdout.write("\n")


def _line(label: str, text: str) -> str:
    """``label`` in the label column, ``text`` wrapped beside it."""
    wrapped = textwrap.wrap(text, _WIDTH - _LABEL) or [""]
    return "".join(f"{(label if i == 0 else ''):<{_LABEL}}{w}\n" for i, w in enumerate(wrapped))


def _mm(x: float) -> str:
    return f"{x * 1e3:g} mm" if math.isfinite(x) else "not published"


def _text(b, cls, clearance, mult) -> str:
    what = f"catalogue row {b.catalogue_key} ({b.description})"
    if b.suffixes:
        what += f", suffixes {' '.join(b.suffixes)}"
    status = {"published": "published",
              "derived": "derived (back-calculated from published fault multipliers, not published as such)",
              "estimated": "ESTIMATED (not published: an ISO 76 inversion of a maker's static rating, "
                           "docs/catalogue.md)"}[b.geometry_status]
    out = [f"{b.designation}: {what}\n",
           _line("internal geometry", status),
           _line("  balls", f"{b.n_balls} x {b.ball_diameter_m * 1e3:.3f} mm on a {b.pitch_diameter_m * 1e3:.3f} mm "
                            f"pitch circle, contact angle {math.degrees(b.contact_angle_rad):g} deg"),
           _line("  source", b.geometry_source),
           _line("boundary", f"bore {_mm(b.bore_diameter_m)}, outside diameter {_mm(b.outer_diameter_m)}, "
                             f"width {_mm(b.width_m)}")]
    if b.dimensions_source:
        out.append(_line("  source", b.dimensions_source))

    def kn(x):
        return f"{x / 1e3:g} kN" if math.isfinite(x) else "not known"

    def rpm(x):
        return f"{x:g} r/min" if math.isfinite(x) else "not known"

    out += [_line("load ratings", f"C {kn(b.dynamic_load_rating_n)}, C0 {kn(b.static_load_rating_n)}"),
            _line("speeds", f"limiting {rpm(b.limiting_speed_rpm)}, reference {rpm(b.reference_speed_rpm)}")]
    if b.ratings_source:
        out.append(_line("  source", b.ratings_source))
    if clearance is None:
        out.append(_line("radial clearance", f"{cls}: not known (the bore is not published)"))
    else:
        out.append(_line("radial clearance", f"{cls}: {clearance[0] * 1e6:g} .. {clearance[1] * 1e6:g} um "
                                             f"(ISO 5753-1, unmounted; the model's diametral clearance)"))
    out.append(_line("fault multipliers", "per Hz of shaft speed (outer ring fixed, rolling without slip)"))
    for name, v in (("FTF", mult.ftf), ("BPFO", mult.bpfo), ("BPFI", mult.bpfi), ("BSF", mult.bsf),
                    ("2 x BSF", 2.0 * mult.bsf)):
        out.append(_line(f"  {name}", f"{v:.5f}"))
    if b.notes:
        out.append(_line("notes", b.notes))
    return "".join(out)


def _print_list(catalogue, as_json: bool) -> int:
    rows = [catalogue.lookup(k) for k in catalogue.designations()]
    if as_json:
        _print_json([{"designation": b.catalogue_key, "geometry_status": b.geometry_status,
                      "description": b.description, "n_balls": b.n_balls, "ball_diameter_m": b.ball_diameter_m,
                      "pitch_diameter_m": b.pitch_diameter_m, "bore_diameter_m": _finite(b.bore_diameter_m)}
                     for b in rows])
        return 0
    w = max(len(b.catalogue_key) for b in rows) + 2
    sys.stdout.write(f"{'designation':<{w}}{'geometry':<11}{'balls x ball / pitch [mm]':<28}description\n")
    for b in rows:
        balls = f"{b.n_balls} x {b.ball_diameter_m * 1e3:.3f} / {b.pitch_diameter_m * 1e3:.3f}"
        sys.stdout.write(f"{b.catalogue_key:<{w}}{b.geometry_status:<11}{balls:<28}{b.description}\n")
    counts = {s: len(catalogue.designations(s)) for s in catalogue.GEOMETRY_STATUSES}
    sys.stdout.write(f"{len(rows)} bearings: " + ", ".join(f"{n} {s}" for s, n in counts.items()) + "\n")
    return 0
