"""The bearing at each position of a case: ``[bearings.de]`` and ``[bearings.nde]`` resolved against the catalogue.

Each position's table holds the bearing type of that position besides its FE element (nodes, axial load,
linearisation). The type is named by its catalogue designation (:mod:`bkabem_core.model.catalogue`,
docs/catalogue.md); every number of the catalogue row can be given in the table and then overrides the row::

    [bearings.de]
    designation = "6205"           # the catalogue's 6205: bore, outer and pitch diameter, balls, contact angle, C0
    clearance_class = "C3"         # ISO 5753-1 class (default: the designation's own, else CN)
    damping_n_s_m = 550.0          # the viscous damper across the bearing
    ...

How each value is found (:func:`resolve`, in this order):

* **Geometry** (:data:`CATALOGUE_KEYS`: bore, outer and pitch diameter, ball diameter, ball count, contact angle,
  static load rating): the table's value, else the catalogue row's. A number the catalogue does not have (NaN:
  the bore of the MFPT rig's NICE bearing) must be in the table. A designation the catalogue does not have is
  accepted only with every geometry key in the table (the machine's own bearing, named as its maker names it);
  otherwise it is an error naming the designation and the nearest keys.
* **Radial internal clearance**: ``diametral_clearance_m`` if the table gives it, else the **middle** of the
  ISO 5753-1 range of ``clearance_class`` for the bearing's bore (unmounted, zero measuring load: an interference
  fit and a warm inner ring make the operating clearance smaller; give ``diametral_clearance_m`` for a mounted
  value). ``clearance_class`` defaults to the designation's own class (``"6205/C3"``) and else to CN; a table with
  both ``clearance_class`` and ``diametral_clearance_m`` is refused (one of them is the clearance).
* **Groove conformities, elastic constants, lubricant, EHL film, attitude of ball 1** (:data:`MODEL_DEFAULTS`): not
  catalogue data; the table's value, else the bearing model's default
  (:class:`~bkabem_core.bearing.deep_groove.BearingGeometry`: 0.52, 206 GPa, 0.3, ...).
* ``damping_n_s_m`` (the damper across the bearing, rotor to housing) has no default: each table gives it.

:func:`resolve` returns the complete table (every key of :data:`BEARING_KEYS` with its value, SI) and its
provenance: which row, the row's geometry status (published, derived, estimated; ``"case"`` for a bearing that is
not in the catalogue), which keys the case overrides, how the clearance was found.

A schema-3 case had one ``[bearing]`` table used at both positions; :func:`migrate_shared` writes it into both
position tables with every key, so the migrated case computes exactly the numbers it computed before.

Units: SI, every key with its unit as a suffix (``_m``, ``_n``, ``_deg``, ``_pa``, ``_n_s_m``).
"""

from __future__ import annotations

import dataclasses
import math

from bkabem_core.bearing.deep_groove import BearingGeometry
from bkabem_core.model.catalogue import CLEARANCE_CLASSES, CatalogueBearing, CatalogueError, lookup, radial_clearance_m

__all__ = ["BEARING_KEYS", "CATALOGUE_KEYS", "MODEL_DEFAULTS", "ResolvedBearing", "BearingTableError", "resolve",
           "geometry_of", "migrate_shared"]

_POS = ("gt", 0.0)
_NONNEG = ("ge", 0.0)

#: The bearing-type keys of a position table: key -> (kind, check) as in the case schema.
BEARING_KEYS: dict[str, tuple] = {
    "designation": ("str", None),
    "clearance_class": ("str", ("in", set(CLEARANCE_CLASSES))),
    "bore_diameter_m": ("float", _POS),
    "outer_diameter_m": ("float", _POS),
    "pitch_diameter_m": ("float", _POS),
    "ball_diameter_m": ("float", _POS),
    "n_balls": ("int", ("ge", 3)),
    "diametral_clearance_m": ("float", _NONNEG),
    "inner_conformity": ("float", ("gt", 0.5)),
    "outer_conformity": ("float", ("gt", 0.5)),
    "contact_angle_deg": ("float", ("range", 0.0, 45.0)),
    "static_load_rating_n": ("float", _POS),
    "youngs_modulus_pa": ("float", _POS),
    "poisson_ratio": ("float", ("range_open", 0.0, 0.5)),
    "pressure_viscosity_m2_n": ("float", _NONNEG),
    "dynamic_viscosity_pa_s": ("float", _NONNEG),
    "ehl_film": ("bool", None),
    "first_ball_angle_deg": ("float", ("range", -360.0, 360.0)),
    "damping_n_s_m": ("float", _NONNEG),
}
#: Keys the catalogue row gives (table key -> the CatalogueBearing attribute).
CATALOGUE_KEYS = {"bore_diameter_m": "bore_diameter_m", "outer_diameter_m": "outer_diameter_m",
                  "pitch_diameter_m": "pitch_diameter_m", "ball_diameter_m": "ball_diameter_m",
                  "n_balls": "n_balls", "contact_angle_deg": "contact_angle_rad",
                  "static_load_rating_n": "static_load_rating_n"}
_FIELDS = {f.name: f.default for f in dataclasses.fields(BearingGeometry)}
#: Keys that are not catalogue data: the bearing model's defaults.
MODEL_DEFAULTS = {"inner_conformity": _FIELDS["inner_conformity"], "outer_conformity": _FIELDS["outer_conformity"],
                  "youngs_modulus_pa": _FIELDS["youngs_modulus_pa"], "poisson_ratio": _FIELDS["poisson_ratio"],
                  "pressure_viscosity_m2_n": _FIELDS["pressure_viscosity_m2_n"],
                  "dynamic_viscosity_pa_s": _FIELDS["dynamic_viscosity_pa_s"], "ehl_film": False,
                  "first_ball_angle_deg": 0.0}
#: Keys every position table gives itself.
REQUIRED = ("designation", "damping_n_s_m")
#: Keys that may be left out (found in the catalogue or defaulted).
OPTIONAL = tuple(k for k in BEARING_KEYS if k not in REQUIRED)


class BearingTableError(ValueError):
    """A position's bearing cannot be resolved: ``key`` (dotted, e.g. ``bearings.de.designation``) and ``reason``."""

    def __init__(self, key: str, reason: str):
        self.key, self.reason = key, reason
        super().__init__(f"{key}: {reason}")


@dataclasses.dataclass(frozen=True)
class ResolvedBearing:
    """The bearing type of one position, every value found (module docstring).

    Attributes
    ----------
    table : dict
        Every key of :data:`BEARING_KEYS` but ``clearance_class`` when the table gives ``diametral_clearance_m``
        (then the clearance is that number, not a class), SI.
    catalogue : CatalogueBearing or None
        The catalogue row the designation names; None for a bearing the catalogue does not have.
    overridden : tuple of str
        Catalogue keys whose value the case gives (all of them for a bearing not in the catalogue).
    clearance : str
        How the diametral clearance was found, for people (``"CN: middle of 6-20 um"``, ``"given"``).
    """

    table: dict
    catalogue: CatalogueBearing | None
    overridden: tuple
    clearance: str

    @property
    def geometry_status(self) -> str:
        """``"published"``, ``"derived"``, ``"estimated"`` (the row's, when no geometry key is overridden),
        ``"case"`` (a bearing not in the catalogue, or every internal-geometry key given), or e.g.
        ``"estimated, ball_diameter_m from the case"``."""
        if self.catalogue is None:
            return "case"
        internal = ("n_balls", "ball_diameter_m", "pitch_diameter_m")
        if all(k in self.overridden for k in internal):
            return "case"
        own = [k for k in internal if k in self.overridden]
        return self.catalogue.geometry_status + (f", {', '.join(own)} from the case" if own else "")

    def provenance(self) -> dict:
        """JSON-ready: designation, catalogue row and status, its sources, the overridden keys, the clearance."""
        c = self.catalogue
        return {"designation": self.table["designation"], "catalogue_key": None if c is None else c.catalogue_key,
                "geometry_status": self.geometry_status,
                "geometry_source": "the case" if self.geometry_status == "case" else c.geometry_source,
                "overridden": list(self.overridden), "clearance_class": self.table.get("clearance_class"),
                "clearance": self.clearance}


def resolve(table: dict, prefix: str) -> ResolvedBearing:
    """The bearing type of the position table ``table`` (``prefix`` = ``"bearings.de"``, for the error keys), every
    value found (module docstring); :class:`BearingTableError` naming the key when it cannot be."""
    designation = table["designation"]
    try:
        row = lookup(designation)
    except CatalogueError as exc:
        missing = [k for k in CATALOGUE_KEYS if k not in table]
        if missing:
            raise BearingTableError(f"{prefix}.designation", f"{exc}; a bearing the catalogue does not have needs "
                                    f"{', '.join(missing)} in [{prefix}]") from None
        row = None
    out = {"designation": designation}
    overridden = []
    for key, attr in CATALOGUE_KEYS.items():
        if key in table:
            out[key] = table[key]
            overridden.append(key)
            continue
        value = getattr(row, attr)
        if isinstance(value, float) and not math.isfinite(value):
            raise BearingTableError(f"{prefix}.{key}", f"missing: the catalogue has no value for "
                                    f"{row.catalogue_key!r}; give it in [{prefix}]")
        out[key] = math.degrees(value) if key == "contact_angle_deg" else value
    for key, default in MODEL_DEFAULTS.items():
        out[key] = table.get(key, default)
    out["damping_n_s_m"] = table["damping_n_s_m"]
    cls, out["diametral_clearance_m"], how = _clearance(table, row, out["bore_diameter_m"], prefix)
    if cls is not None:
        out["clearance_class"] = cls
    return ResolvedBearing(out, row, tuple(overridden), how)


def _clearance(table: dict, row: CatalogueBearing | None, bore_m: float, prefix: str) -> tuple:
    """(class or None, diametral clearance [m], how it was found) of a position table."""
    own = None if row is None or row.clearance_class == "CN" else row.clearance_class    # the designation's class
    if "diametral_clearance_m" in table:
        if "clearance_class" in table:
            raise BearingTableError(f"{prefix}.diametral_clearance_m", "give either clearance_class (the middle of "
                                    "its ISO 5753-1 range) or diametral_clearance_m, not both")
        return None, table["diametral_clearance_m"], "given"
    cls = table.get("clearance_class")
    if cls is not None and own is not None and cls != own:
        raise BearingTableError(f"{prefix}.clearance_class", f"{cls} contradicts the designation "
                                f"{table['designation']!r} (class {own})")
    cls = cls or own or "CN"
    try:
        lo, hi = radial_clearance_m(bore_m, cls)
    except CatalogueError as exc:
        key = "clearance_class" if "clearance_class" in table else "diametral_clearance_m"
        raise BearingTableError(f"{prefix}.{key}", f"{exc}; give diametral_clearance_m in [{prefix}]") from None
    return cls, 0.5 * (lo + hi), f"{cls}: middle of {lo * 1e6:g}-{hi * 1e6:g} um (ISO 5753-1, unmounted)"


def geometry_of(table: dict) -> BearingGeometry:
    """The bearing model's geometry of a resolved table (:attr:`ResolvedBearing.table`)."""
    b = table
    return BearingGeometry(
        designation=b["designation"],
        ball_diameter_m=float(b["ball_diameter_m"]),
        pitch_diameter_m=float(b["pitch_diameter_m"]),
        n_balls=int(b["n_balls"]),
        diametral_clearance_m=float(b["diametral_clearance_m"]),
        inner_conformity=float(b["inner_conformity"]),
        outer_conformity=float(b["outer_conformity"]),
        contact_angle_rad=math.radians(b["contact_angle_deg"]),
        youngs_modulus_pa=float(b["youngs_modulus_pa"]),
        poisson_ratio=float(b["poisson_ratio"]),
        bore_diameter_m=float(b["bore_diameter_m"]),
        outer_diameter_m=float(b["outer_diameter_m"]),
        static_load_rating_n=float(b["static_load_rating_n"]),
        pressure_viscosity_m2_n=float(b["pressure_viscosity_m2_n"]),
        dynamic_viscosity_pa_s=float(b["dynamic_viscosity_pa_s"]),
        first_ball_angle_rad=math.radians(b["first_ball_angle_deg"]),
    )


def migrate_shared(raw: dict, positions=("de", "nde")) -> dict:
    """A schema-3 case (one ``[bearing]`` for both positions) with that table's keys written into each position's
    table (in place; returns ``raw``): every key explicit, so the numbers are those the shared table gave. Keys of
    ``[plausibility]`` named ``bearing.<key>`` become ``bearings.*.<key>``."""
    shared = raw.pop("bearing", None)
    brg = raw.get("bearings")
    if isinstance(shared, dict) and isinstance(brg, dict):
        for name in positions:
            if isinstance(brg.get(name), dict):
                for k, v in shared.items():
                    brg[name].setdefault(k, v)
    plaus = raw.get("plausibility")
    if isinstance(plaus, dict):
        raw["plausibility"] = {("bearings.*." + k[len("bearing."):] if k.startswith("bearing.") else k): v
                               for k, v in plaus.items()}
    return raw
