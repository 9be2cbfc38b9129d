"""The bearing catalogue: deep-groove ball bearings by designation, with the source of every number.

Data (package files in ``bkabem_core/embedded/bearings/``, described in its README and in docs/catalogue.md):

``deep_groove.csv``
    The 60, 62 and 63 series for bores 10 to 100 mm and the bearings of public test rigs and data sets: boundary
    dimensions (ISO 15), ball count, ball and pitch diameter, contact angle, load ratings C and C0, limiting and
    reference speed, and per row the status of the internal geometry -- ``published`` (a maker's table or a data
    set's documented bearing), ``derived`` (back-calculated from published fault multipliers) or ``estimated``
    (ISO 76 inversion of a maker's static rating, docs/catalogue.md) -- and the source of each group of numbers.
``clearance_iso5753.csv``
    Radial internal clearance of deep-groove ball bearings by bore, classes C2, CN, C3, C4, C5 (ISO 5753-1).
``sources.csv``
    The citations the rows name by key.

Designations
============
A designation is matched, ignoring case and repeated spaces, first exactly against the catalogue's keys: the
series rows (``"6205"``) and the rig rows, whose keys name the bearing and, in brackets, the rig or data set
(``"6205-2RS JEM"`` is the CWRU drive-end bearing, ``"NICE (MFPT)"``, ``"6203 FAG (Paderborn)"``; ``designations()``
lists them). A rig key may carry a clearance suffix (``"6205-2RS JEM/C3"``). Otherwise the designation is a series
row followed by suffixes that change neither the ball set nor the rings' raceways, and maps to that row's geometry
and ratings:

- seals and shields (SKF ``Z 2Z RS1 2RS1 RSH 2RSH RSL 2RSL RZ 2RZ``, Schaeffler ``ZR 2ZR RSR 2RSR HRS 2HRS``,
  NSK ``ZZ DU DDU V VV``, NTN ``LB LLB LU LLU LH LLH``, generic ``RS 2RS``): the row's limiting and reference
  speeds are those of the open bearing, which a seal or shield lowers (SKF 6205: open 18000 r/min, 2Z 14000,
  2RSH 8500), so they are left unknown (NaN) for such a variant and the notes say so;
- snap-ring grooves ``N`` and ``NR``;
- a clearance class ``C2 CN C3 C4 C5`` (with or without ``/`` or ``-``): the bearing's ``clearance_class``
  (default ``CN``, the normal group).

Anything else (``E``, ``/HC5``, cage or tolerance suffixes, a maker's name) is refused: it may change the
geometry. ``"6205-2RS1/C3"`` is the 6205 row, clearance class C3, speeds unknown.

Units: SI inside (m, N, rad), speeds in r/min as catalogues print them (``_rpm``). An unknown number (a rig whose
boundary dimensions or ratings are not published) is NaN.
"""

from __future__ import annotations

import csv
import difflib
import functools
import math
import re
from dataclasses import asdict, dataclass, field, replace
from decimal import Decimal
from importlib import resources

__all__ = ["CatalogueBearing", "CatalogueError", "lookup", "designations", "radial_clearance_m",
           "parse_clearance_class", "sources", "CLEARANCE_CLASSES", "GEOMETRY_STATUSES"]

#: ISO 5753-1 groups of radial internal clearance, smallest first (CN = the normal group).
CLEARANCE_CLASSES = ("C2", "CN", "C3", "C4", "C5")
#: How a row's internal geometry (ball count, ball and pitch diameter) is known.
GEOMETRY_STATUSES = ("published", "derived", "estimated")

_PACKAGE = "bkabem_core.embedded.bearings"
_MM = "0.001"           # m per mm and per um: decimal scales of the files' numbers (one rounding to float)
_UM = "0.000001"

#: Suffixes that map a series designation to its row: seals and shields (they lower the speeds), snap-ring grooves.
SEAL_SUFFIXES = ("2RS1", "2RSH", "2RSL", "2RSR", "2HRS", "2RS", "RS1", "RSH", "RSL", "RSR", "HRS", "RS", "2RZ",
                 "RZ", "2ZR", "ZR", "2Z", "ZZ", "Z", "DDU", "DU", "VV", "V", "LLB", "LLU", "LLH", "LB", "LU", "LH")
SNAP_RING_SUFFIXES = ("NR", "N")
_SUFFIX_RE = re.compile("|".join(sorted(SEAL_SUFFIXES + SNAP_RING_SUFFIXES + CLEARANCE_CLASSES, key=len,
                                        reverse=True)))
_SEPARATORS = " -/"


class CatalogueError(ValueError):
    """A designation or clearance class the catalogue does not have; the message says which and why."""


@dataclass(frozen=True)
class CatalogueBearing:
    """One deep-groove ball bearing of the catalogue (SI units; NaN where the sources give no number).

    Attributes
    ----------
    designation : str
        As asked, tidied (upper case, single spaces), e.g. ``"6205-2RS1/C3"``; the row key for a rig row.
    catalogue_key : str
        The catalogue row it maps to, e.g. ``"6205"``.
    description : str
        What the row is (``"62 series"``; for a rig row the maker, the bearing and the rig or data set).
    bore_diameter_m, outer_diameter_m, width_m : float
        Boundary dimensions d, D, B [m].
    n_balls : int
        Number of balls z [-].
    ball_diameter_m, pitch_diameter_m : float
        Ball diameter D_w and pitch diameter D_pw [m].
    contact_angle_rad : float
        Nominal contact angle [rad] (0 for every row: radial deep-groove bearings).
    dynamic_load_rating_n, static_load_rating_n : float
        Basic dynamic and static radial load ratings C and C_0 [N].
    limiting_speed_rpm, reference_speed_rpm : float
        The maker's limiting and reference (thermal) speed [r/min].
    clearance_class : str
        ISO 5753-1 radial internal clearance class: from the designation's suffix (``/C3``), else ``"CN"``.
    suffixes : tuple of str
        The suffixes that mapped the designation to the row (``("2RS1", "C3")``), empty for an exact match.
    geometry_status : str
        ``"published"``, ``"derived"`` or ``"estimated"`` (:data:`GEOMETRY_STATUSES`).
    geometry_source, dimensions_source, ratings_source : str
        Where the internal geometry, the boundary dimensions and the ratings and speeds come from ("" for none).
    notes : str
        Caveats: other makers' ball sets, the runner-up of an estimate, edition differences.
    nsk_f0, nsk_static_load_rating_n : float
        The inputs of the estimate for the series rows: NSK's printed ISO 76 factor f0 [-] and C0r [N].
    """

    designation: str
    catalogue_key: str
    description: str
    bore_diameter_m: float
    outer_diameter_m: float
    width_m: float
    n_balls: int
    ball_diameter_m: float
    pitch_diameter_m: float
    contact_angle_rad: float
    dynamic_load_rating_n: float
    static_load_rating_n: float
    limiting_speed_rpm: float
    reference_speed_rpm: float
    clearance_class: str
    geometry_status: str
    geometry_source: str
    dimensions_source: str
    ratings_source: str
    notes: str
    nsk_f0: float = float("nan")
    nsk_static_load_rating_n: float = float("nan")
    suffixes: tuple[str, ...] = field(default=())

    def radial_clearance_m(self, clearance_class: str | None = None) -> tuple[float, float]:
        """(min, max) radial internal clearance [m] of this bearing's bore for ``clearance_class`` (default: the
        bearing's own class), ISO 5753-1; :class:`CatalogueError` when the bore is not known."""
        cls = self.clearance_class if clearance_class is None else clearance_class
        if not math.isfinite(self.bore_diameter_m):
            parse_clearance_class(cls)
            raise CatalogueError(f"the bore of {self.catalogue_key} is not published, so its ISO 5753-1 radial "
                                 f"clearance is not known")
        return radial_clearance_m(self.bore_diameter_m, cls)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["suffixes"] = list(self.suffixes)
        return d


# --------------------------------------------------------------------------- the tables
def _data_lines(name: str) -> list[str]:
    """The lines of a package data file without its ``#`` comment lines."""
    text = resources.files(_PACKAGE).joinpath(name).read_text(encoding="utf-8")
    return [line for line in text.splitlines() if line.strip() and not line.startswith("#")]


@functools.cache
def sources() -> dict[str, str]:
    """The citations the catalogue names by key (``{"GMN": "GMN Paul Mueller Industrie, ...", ...}``)."""
    return {r["key"]: r["citation"] for r in csv.DictReader(_data_lines("sources.csv"))}


def _expand_source(text: str, where: str) -> str:
    """``"KEY[+KEY]: detail"`` -> the citations, then the detail; "" stays ""."""
    if not text:
        return ""
    keys, _, detail = text.partition(":")
    cites = []
    for k in keys.split("+"):
        if k.strip() not in sources():
            raise RuntimeError(f"bearing catalogue, {where}: unknown source key {k.strip()!r}")
        cites.append(sources()[k.strip()])
    return "; ".join(cites) + (f" -- {detail.strip()}" if detail.strip() else "")


def _number(row: dict, key: str, scale: str = "1") -> float:
    """The number in ``row[key]`` times ``scale`` (exact in decimal, then rounded once), NaN when empty."""
    s = row[key].strip()
    return float(Decimal(s) * Decimal(scale)) if s else float("nan")


def _norm(designation: str) -> str:
    return " ".join(str(designation).split()).upper()


def _loose(norm: str) -> str:
    """A key without its separators: ``6205-2RS JEM`` and ``6205 2RS JEM`` are one."""
    return re.sub(r"[ /\-]", "", norm)


@functools.cache
def _rows() -> dict[str, CatalogueBearing]:
    """Every row by its normalised key, in the file's order."""
    out: dict[str, CatalogueBearing] = {}
    for r in csv.DictReader(_data_lines("deep_groove.csv")):
        key = r["designation"]
        where = f"row {key}"
        if r["geometry_status"] not in GEOMETRY_STATUSES:
            raise RuntimeError(f"bearing catalogue, {where}: geometry_status {r['geometry_status']!r}")
        out[_norm(key)] = CatalogueBearing(
            designation=key, catalogue_key=key, description=r["description"],
            bore_diameter_m=_number(r, "bore_mm", _MM), outer_diameter_m=_number(r, "outside_diameter_mm", _MM),
            width_m=_number(r, "width_mm", _MM), n_balls=int(r["balls"]),
            ball_diameter_m=_number(r, "ball_diameter_mm", _MM), pitch_diameter_m=_number(r, "pitch_diameter_mm", _MM),
            contact_angle_rad=math.radians(_number(r, "contact_angle_deg")),
            dynamic_load_rating_n=_number(r, "dynamic_load_rating_kn", "1000"),
            static_load_rating_n=_number(r, "static_load_rating_kn", "1000"),
            limiting_speed_rpm=_number(r, "limiting_speed_rpm"), reference_speed_rpm=_number(r, "reference_speed_rpm"),
            clearance_class=r["clearance_class"] or "CN", geometry_status=r["geometry_status"],
            geometry_source=_expand_source(r["geometry_source"], where),
            dimensions_source=_expand_source(r["dimensions_source"], where),
            ratings_source=_expand_source(r["ratings_source"], where), notes=r["notes"],
            nsk_f0=_number(r, "nsk_f0"), nsk_static_load_rating_n=_number(r, "nsk_static_load_rating_kn", "1000"))
    return out


@functools.cache
def _clearance_rows() -> tuple[dict, ...]:
    return tuple(csv.DictReader(_data_lines("clearance_iso5753.csv")))


# --------------------------------------------------------------------------- the API
def designations(status: str | None = None) -> tuple[str, ...]:
    """The catalogue's keys in its order (series 60, 62, 63, then the rig rows); only those whose geometry has
    ``status`` (:data:`GEOMETRY_STATUSES`) when given."""
    if status is not None and status not in GEOMETRY_STATUSES:
        raise CatalogueError(f"unknown geometry status {status!r} (one of {', '.join(GEOMETRY_STATUSES)})")
    return tuple(b.catalogue_key for b in _rows().values() if status is None or b.geometry_status == status)


def lookup(designation: str) -> CatalogueBearing:
    """The catalogue bearing of ``designation`` (module docstring: exact keys first, then a series row with
    suffixes); :class:`CatalogueError` naming the designation, the reason and the nearest keys otherwise."""
    if not isinstance(designation, str):
        raise CatalogueError(f'designation must be a string such as "6205" (got {designation!r})')
    if not designation.strip():
        raise CatalogueError("empty designation")
    norm = _norm(designation)
    rows = _rows()
    if norm in rows:
        return rows[norm]
    loose = [r for k, r in rows.items() if _loose(k) == _loose(norm)]
    if len(loose) == 1:                              # "6205 2RS JEM" for "6205-2RS JEM"
        return loose[0]
    m = re.fullmatch(r"(.*?)[ /\-]*(C[2-5N])", norm)
    if m and m.group(1) in rows:                      # a row key with a clearance class ("6205-2RS JEM/C3")
        return _variant(rows[m.group(1)], norm, (m.group(2),))
    m = re.match(r"\d{3,6}", norm)
    if m is None or m.group(0) not in rows:
        raise CatalogueError(f"unknown designation {designation.strip()!r}{_nearest(norm)}")
    return _variant(rows[m.group(0)], norm, _suffixes(norm, m.end(), designation.strip(), m.group(0)))


def radial_clearance_m(bore_m: float, clearance_class: str) -> tuple[float, float]:
    """(min, max) radial internal clearance [m] of a deep-groove ball bearing of bore ``bore_m`` [m] in
    ``clearance_class`` (C2, CN, C3, C4, C5; ISO 5753-1, unmounted, zero measuring load).

    The radial internal clearance is the total radial travel of one ring against the other, i.e. the diametral
    clearance ``d_o - d_i - 2 D_w`` of the bearing model. :class:`CatalogueError` for an unknown class, a bore
    outside the table (over 2.5 up to 500 mm) or a class the table has no value for at that bore.
    """
    cls = parse_clearance_class(clearance_class)
    try:
        bore_mm = round(float(bore_m) * 1e3, 6)
    except (TypeError, ValueError):
        raise CatalogueError(f"bore must be a number in m (got {bore_m!r})") from None
    if not math.isfinite(bore_mm):
        raise CatalogueError(f"bore must be finite (got {bore_m!r})")
    table = _clearance_rows()
    for row in table:
        if float(row["bore_over_mm"]) < bore_mm <= float(row["bore_incl_mm"]):
            lo, hi = row[f"{cls}_min_um"], row[f"{cls}_max_um"]
            if not lo or not hi:
                have = [c for c in CLEARANCE_CLASSES if row[f"{c}_min_um"] and row[f"{c}_max_um"]]
                raise CatalogueError(f"clearance class {cls} has no ISO 5753-1 value for a bore of {bore_mm:g} mm "
                                     f"(classes there: {', '.join(have)})")
            return float(Decimal(lo) * Decimal(_UM)), float(Decimal(hi) * Decimal(_UM))
    raise CatalogueError(f"a bore of {bore_mm:g} mm is outside the ISO 5753-1 table (over "
                         f"{float(table[0]['bore_over_mm']):g} up to {float(table[-1]['bore_incl_mm']):g} mm)")


# --------------------------------------------------------------------------- designation helpers
def parse_clearance_class(clearance_class) -> str:
    """The ISO 5753-1 class ``clearance_class`` names (``"c3"``, ``"/C3"`` -> ``"C3"``); :class:`CatalogueError`
    for anything else."""
    cls = str(clearance_class).strip().upper().lstrip("/-")
    if cls not in CLEARANCE_CLASSES:
        raise CatalogueError(f"unknown clearance class {str(clearance_class)!r} (ISO 5753-1 classes: "
                             f"{', '.join(CLEARANCE_CLASSES)})")
    return cls


def _suffixes(norm: str, start: int, asked: str, base: str) -> tuple[str, ...]:
    """The suffix tokens of ``norm`` after the series row ``base`` (known ones only, see the module docstring)."""
    out, i = [], start
    while i < len(norm):
        if norm[i] in _SEPARATORS:
            i += 1
            continue
        m = _SUFFIX_RE.match(norm, i)
        if m is None:
            first = max(start, *(norm.rfind(c, 0, i) + 1 for c in _SEPARATORS))
            rest = re.match(r"[^ /\-]+", norm[first:]).group(0)      # the whole word: "NSK", not "SK" after "N"
            raise CatalogueError(f"designation {asked!r}: suffix {rest!r} is not one that keeps the {base} row's "
                                 f"geometry (seals and shields such as 2RS1, 2Z, ZZ, LLU; snap rings N, NR; "
                                 f"clearance classes {', '.join(CLEARANCE_CLASSES)}){_nearest(norm)}")
        out.append(m.group(0))
        i = m.end()
    if sum(s in CLEARANCE_CLASSES for s in out) > 1:
        raise CatalogueError(f"designation {asked!r}: more than one clearance class")
    return tuple(out)


def _variant(row: CatalogueBearing, norm: str, suffixes: tuple[str, ...]) -> CatalogueBearing:
    """``row`` as the variant ``norm`` with ``suffixes``: its clearance class, and no speeds when sealed."""
    classes = [s for s in suffixes if s in CLEARANCE_CLASSES]
    cls = row.clearance_class
    if classes:
        if row.clearance_class != "CN" and classes[0] != row.clearance_class:
            raise CatalogueError(f"designation {norm!r}: clearance class {classes[0]} contradicts the row "
                                 f"{row.catalogue_key} ({row.clearance_class})")
        cls = classes[0]
    changes = {"designation": norm, "clearance_class": cls, "suffixes": suffixes}
    seals = [s for s in suffixes if s in SEAL_SUFFIXES]
    if seals:
        changes.update(limiting_speed_rpm=float("nan"), reference_speed_rpm=float("nan"),
                       notes="; ".join(n for n in (
                           row.notes, f"speeds of the {'-'.join(seals)} variant not in the catalogue (the open "
                           f"{row.catalogue_key}'s: limiting {row.limiting_speed_rpm:g}, reference "
                           f"{row.reference_speed_rpm:g} r/min; seals and shields lower them)") if n))
    return replace(row, **changes)


def _nearest(norm: str) -> str:
    """`` (nearest: ...)``: the keys that contain what was asked (in the key, then in the description: ``CWRU``),
    then the most similar ones; "" for none."""
    rows = _rows()
    keys = {k: r.catalogue_key for k, r in rows.items()}
    words = [w for w in re.split(r"[ /\-()]+", norm) if len(w) >= 3]
    near = [k for k in keys if any(w in k for w in words)]
    near += [k for k in keys if k not in near and any(w in rows[k].description.upper() for w in words)]
    near += [k for k in difflib.get_close_matches(norm, keys, n=5, cutoff=0.6) if k not in near]
    return f" (nearest: {', '.join(keys[k] for k in near[:6])})" if near else ""
