"""The protocol of a defect kind: what the rest of bkabem needs to know of one kind of localised defect.

A kind (a pit in the outer race, in the inner race, in a ball) is one module of this package with one subclass of
:class:`DefectKind`; the registry (:mod:`bkabem_core.bearing.defects.registry`) finds it. Everything that differs
between kinds lives on it:

* **where it is and what a ball feels**: the surface it is cut in (:meth:`DefectKind.surface_radius_m`), its sharp-
  edge drop profile at each contact it meets (:meth:`DefectKind.edge_drop_m`, :attr:`DefectKind.contacts`), the
  depth of its ``"cubic"`` profile, and how the drops of its defects place themselves at given phases and combine
  into the drop every ball feels (:meth:`DefectKind.drop_m`);
* **which phases it needs**: besides the ball-set position every bearing has, the shaft angle (a pit turning with
  the inner race) or the ball's spin (a pit in a ball) (:attr:`DefectKind.phases`). A kind without phases whose drop
  is the same for every ball repeats with the ball pass: its lines are BPFO orders (:attr:`DefectKind.periodic`);
  any other kind is sampled on the 2-torus of its own angles (:meth:`DefectKind.torus`) and gives a general line set;
* **its fault frequency** (a field of :class:`~bkabem_core.bearing.deep_groove.FaultFrequencies`), the strikes per
  period, the line it is marked with and the harmonics marked, its rate over the ball;
* **its words**: name in files and messages (``"outer"``), the place ("outer race"), the adjective
  ("outer-race defect");
* **its keys** in case, scenario and data-set files besides the common ones (a ball defect's ``ball``), their
  checks against the bearing, and how they fill a :class:`~bkabem_core.bearing.defects.base.Dent`.

A kind module may import the bearing geometry (:mod:`bkabem_core.bearing.defects.profiles`) and this protocol, never
the FE, the excitation or the synthesis. The shape of a defect (a slot across the track, a round pit) is not the
kind's: every kind has both (:mod:`bkabem_core.bearing.defects.round_pit`). Units: SI (m, rad, Hz per shaft Hz).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from bkabem_core.bearing.defects import round_pit
from bkabem_core.bearing.defects.profiles import TWO_PI, ContactGeometry, wrap_to_pi

__all__ = ["DEFAULT_STRIKE_SPREAD", "MAX_ROUGHNESS_DB", "MAX_STRIKE_SPREAD", "ROUGHNESS", "DefectKey", "DefectKind",
           "RaceDefect", "TorusGrid", "roughness_field", "roughness_problem", "torus_axes"]


@dataclass(frozen=True)
class DefectKey:
    """A key of a ``[[defects]]`` table that only some kinds have (case, scenario), and the data-set run parameter
    of the same name.

    Attributes
    ----------
    name : str
        The key, e.g. ``"ball"``.
    type : str
        ``"int"``, ``"float"`` or ``"str"``.
    lo : float or None
        Lowest value (inclusive); the checks against the bearing are the kind's (:meth:`DefectKind.check_own_key`).
    default : object
        The data-set run parameter's default.
    doc : str
        What it is, for people (with its unit and range).
    unit : str
        Its unit ("" for a number without one).
    required : bool
        Whether a ``[[defects]]`` table of the kind must give it (else it may leave it out: ``default``).
    """

    name: str
    type: str
    lo: float | None
    default: object
    doc: str
    unit: str = ""
    required: bool = True

    @property
    def schema(self) -> tuple:
        """Its entry in the case schema: ``(type, check)``."""
        return self.type, (("ge", self.lo) if self.lo is not None else None)


@dataclass(frozen=True)
class TorusGrid:
    """The 2-torus of a moving kind's own angles, sampled: ``(a, b) = 2 pi (i / n_fast, j / n_slow)``.

    Attributes
    ----------
    phase_map : ndarray of int (2, 4)
        Coefficients of ``a`` and ``b`` on the base phases (shaft, cage, spin, line).
    cage, shaft, spin : ndarray (n_fast, n_slow)
        The base phases at every grid point [rad].
    base_index : ndarray of int (n_fast, n_slow)
        Index of each grid point's ball-set position in a table of one ball pitch of ``n_fast`` cage angles.
    """

    phase_map: np.ndarray
    cage: np.ndarray
    shaft: np.ndarray
    spin: np.ndarray
    base_index: np.ndarray


def torus_axes(n_fast: int, n_slow: int):
    """``(i, j, a, b)`` of a torus grid (:class:`TorusGrid`), each (n_fast, n_slow); a, b in [rad]."""
    i, j = np.meshgrid(np.arange(n_fast), np.arange(n_slow), indexing="ij")
    return i, j, TWO_PI * i / n_fast, TWO_PI * j / n_slow


class DefectKind(ABC):
    """One kind of localised defect (module docstring). Subclasses set the class attributes and implement the
    abstract methods; the registry makes one instance of each.

    Attributes
    ----------
    name : str
        Its name in case, scenario and data-set files (``race = "outer"``), in messages (``Defect.kind``).
    order : int
        Its place in listings (:data:`~bkabem_core.bearing.defects.registry.KINDS`); the drops of several kinds add
        in this order.
    place : str
        Where it sits, as a diagnostics engineer says it ("outer race"; series "DE outer race depth [µm]").
    adjective : str
        As an adjective ("outer-race" defect).
    fault_frequency : str
        Its fault frequency, a field of ``FaultFrequencies``: ``"bpfo"``, ``"bpfi"``, ``"bsf"``, ``"ftf"``.
    strikes : int
        Strikes per period of the fault frequency (a pit in a ball meets both races once per spin turn: 2).
    marked_harmonics : tuple of int
        Harmonics of its strike line that a spectrum marks.
    phases : tuple of str
        Base phases besides the ball-set position its drops depend on (``"shaft"``, ``"spin"``).
    contacts : tuple of str
        The contacts of a ball it lowers (``"outer"``, ``"inner"``): one drop profile each.
    per_ball : bool
        Whether its drop belongs to one ball (the drops need the angle of every ball).
    own_keys : tuple of DefectKey
        Keys of a ``[[defects]]`` table only this kind has.
    """

    name: str = ""
    order: int = 0
    place: str = ""
    adjective: str = ""
    fault_frequency: str = ""
    strikes: int = 1
    marked_harmonics: tuple = (1, 2, 3)
    phases: tuple = ()
    contacts: tuple = ("outer",)
    per_ball: bool = False
    own_keys: tuple = ()

    def __repr__(self) -> str:
        return f"<defect kind {self.name!r}>"

    # ------------------------------------------------------------------ kinematics
    @property
    def periodic(self) -> bool:
        """Whether its drops repeat with the ball pass (no phase of its own, the same for every ball): BPFO
        orders, and the 4-DOF model can take it."""
        return not self.phases and not self.per_ball

    @property
    def line(self) -> str:
        """The fault-frequency line of its strikes: ``"BPFO"``, ``"BPFI"``, ``"2xBSF"``."""
        return (f"{self.strikes}x" if self.strikes > 1 else "") + self.fault_frequency.upper()

    @property
    def envelope_lines(self) -> tuple:
        """Lines it shows in an envelope spectrum: the strike line, and the fault frequency itself when it strikes
        more than once per period (the strikes differ)."""
        return (self.line,) + ((self.fault_frequency.upper(),) if self.strikes > 1 else ())

    def fault_multiplier(self, fault_multipliers) -> float:
        """Its fault frequency per shaft Hz (from the bearing's ``FaultFrequencies`` per shaft Hz)."""
        return getattr(fault_multipliers, self.fault_frequency)

    def strike_multiplier(self, fault_multipliers) -> float:
        """Strikes per shaft turn: ``strikes`` x its fault frequency per shaft Hz."""
        return self.strikes * self.fault_multiplier(fault_multipliers)

    @abstractmethod
    def surface_rate_per_hz(self, fault_multipliers) -> float:
        """Turns per shaft turn of its surface relative to the ball on it (outer race: the cage, FTF)."""

    def phase_map(self, n_balls: int) -> np.ndarray:
        """Coefficients (2, 4) of its torus angles on the base phases (:class:`TorusGrid`); moving kinds only."""
        return self.torus(n_balls, 1, 1).phase_map

    def torus(self, n_balls: int, n_fast: int, n_slow: int) -> TorusGrid:
        """The grid of its torus: the fast angle (its strikes) and the slow one (where it is in the load zone)."""
        raise ValueError(f"a {self.adjective} defect repeats with the ball pass: BPFO orders, no torus")

    # ------------------------------------------------------------------ what a ball feels
    @abstractmethod
    def surface_radius_m(self, geometry: ContactGeometry) -> float:
        """Radius of the surface the pit is cut in, in the rolling direction [m] (half-angle = l / (2 R))."""

    @abstractmethod
    def edge_drop_m(self, psi, dent, geometry: ContactGeometry, contact: str):
        """The ``"ball"`` (sharp-edge) profile of ``dent`` (its depth, and any keys of its own): drop of the ball
        centre [m] at an angle ``psi`` [rad] on the pit's surface inside the nearer edge, at ``contact`` (one of
        :attr:`contacts`); at most the depth."""

    def cubic_depth_m(self, dent, geometry: ContactGeometry, edge_depth_m: float) -> float:
        """Largest drop of the ``"cubic"`` profile [m] at a contact whose ``"ball"`` profile reaches
        ``edge_depth_m`` at the pit's centre: that same depth."""
        return edge_depth_m

    @abstractmethod
    def drop_m(self, profiles, beta_rad, shaft_angle_rad, spin_angle_rad):
        """Drop of every ball [m] (shape of ``beta_rad``: (..., z), or (..., 1) for a kind that is not per ball)
        from ``profiles`` (its :class:`~bkabem_core.bearing.defects.base.DefectProfile`\\ s, at least one) at
        ball attitude angles ``beta_rad``, shaft and spin angles [rad] (broadcast against ``beta_rad[..., 0]``)."""

    def check_dent(self, dent, geometry: ContactGeometry) -> None:
        """Raise ValueError if ``dent`` cannot be placed in a bearing of this geometry."""

    # ------------------------------------------------------------------ files
    def check_own_key(self, key: str, value, bearing: dict) -> str | None:
        """Why ``value`` of own key ``key`` does not fit the case's ``[bearing]`` table (None: it fits)."""
        return None

    def check_size(self, table: dict, bearing: dict) -> tuple[str, str] | None:
        """``(key, reason)`` if the size of a ``[[defects]]`` table of this kind does not fit the case's
        ``[bearing]`` (None: it fits)."""
        return None

    def check_table(self, table: dict, bearing: dict) -> tuple[str, str] | None:
        """``(key, reason)`` of the first problem of a type-checked ``[[defects]]`` table of this kind against the
        case's ``[bearing]``: its place (``angle_deg`` or ``clock``), its own keys (those it gives), its size, then its
        shape (a round pit's width; None: none)."""
        if "clock" in table:
            if "angle_deg" in table:
                return "clock", "give angle_deg or clock, not both"
            if self.clock_angle_deg(table["clock"]) is None:
                return "clock", (f"only for a pit fixed in the bearing plane (an outer-race defect); a {self.adjective} "
                                 f"defect's place is angle_deg")
        for k in self.own_keys:
            if k.name not in table and not k.required:
                continue
            reason = self.check_own_key(k.name, table[k.name], bearing)
            if reason:
                return k.name, reason
        problem = self.check_size(table, bearing)
        if problem is None and table.get("shape") == "round_pit":
            problem = round_pit.check_table(table, bearing)
        return problem

    def clock_angle_deg(self, hours: int) -> float | None:
        """Its ``angle_deg`` at a clock position (``clock = 1..12``, 12 at the top), or None if its place is not fixed
        in the bearing plane (a pit turning with the shaft or a ball has no clock position)."""
        return None

    def table_angle_deg(self, table: dict) -> float:
        """``angle_deg`` of a valid ``[[defects]]`` table of this kind: its own, or the one of its ``clock`` [deg]."""
        if "clock" in table:
            return float(self.clock_angle_deg(table["clock"]))
        return float(table["angle_deg"])

    def dent_fields(self, table: dict) -> dict:
        """Fields of a :class:`~bkabem_core.bearing.defects.base.Dent` its own keys fill (by default ``own``, the
        pairs in :attr:`own_keys` order)."""
        return {"own": tuple((k.name, table[k.name]) for k in self.own_keys)} if self.own_keys else {}

    def table_fields(self, dent) -> dict:
        """Its own keys of a ``[[defects]]`` table (or ground-truth entry) describing ``dent``."""
        return dict(dent.own)

    # ------------------------------------------------------------------ words
    def part_name(self, fields: Mapping) -> str:
        """The part that carries the defect when the kind names one ("ball 3"), else "". ``fields``: the defect's
        record (a ``[[defects]]`` table, a ground-truth entry, a message's fields), of which the kind reads its
        own keys."""
        return ""

    def place_of(self, fields: Mapping | None = None) -> str:
        """Where it sits: "outer race", "ball 3"."""
        return self.part_name(fields or {}) or self.place

    def adjective_of(self, fields: Mapping | None = None) -> str:
        """As in "outer-race defect", "ball 3 defect"."""
        return self.part_name(fields or {}) or self.adjective

    def label_of(self, fields: Mapping | None = None) -> str:
        """Short, as in a scenario state's label: "outer", "ball 3"."""
        return self.part_name(fields or {}) or self.name


#: Largest ``roughness_db`` a case may give [dB] (a floor 1000 times the case's in amplitude).
MAX_ROUGHNESS_DB = 60.0
#: Every kind's key ``roughness_db``: the faulty bearing's broadband floor over the case's. A bearing with a defect
#: rolls rougher than a sound one: a seeded pit's bearing was taken apart and put back, a worn one carries debris and
#: wear, the "generalized roughness" that comes with damage (Stack, Habetler & Harley, IEEE Trans. Ind. Appl. 40(3),
#: 2004). Read by the synthesiser (:mod:`bkabem_core.synth.floor`), not by the quasi-static model.
ROUGHNESS = DefectKey("roughness_db", "float", 0.0, 0.0,
                      "how much louder the faulty bearing's broadband floor is than the case's "
                      "(baseline.broadband_force_n_per_sqrt_hz), in dB of its force (0: as the case's); "
                      "bkabem_core.synth.floor", "dB", required=False)


def roughness_problem(value) -> str | None:
    """Why ``value`` is not a ``roughness_db`` (None: it is one)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= MAX_ROUGHNESS_DB:
        return f"must be a number of dB from 0 (the case's floor) to {MAX_ROUGHNESS_DB:g} (got {value!r})"
    return None


def roughness_field(table: dict) -> tuple:
    """``("roughness_db", value)`` of a ``[[defects]]`` table (0 where it gives none): an entry of ``own``."""
    return ("roughness_db", float(table.get("roughness_db", 0.0)))


#: Default of a race pit's ``strike_spread`` [-]: its argument is in :mod:`bkabem_core.synth.strikes`.
DEFAULT_STRIKE_SPREAD = 1.0
#: Largest ``strike_spread`` a case may give (a relative spread of the strikes' energy of 5 for a ball that loses all
#: its load: beyond any measured pit; the lognormal's tail would then be a handful of strikes).
MAX_STRIKE_SPREAD = 5.0


class RaceDefect(DefectKind):
    """A pit in a race, at an angle of the bearing plane that the kind places (fixed, or turning with the shaft):
    a ball is in one pit of a race at a time, so the drops of several pits of the kind take the deeper one.

    Its own key ``strike_spread`` describes how the balls meet the pit, not the pit, and is read by the synthesiser
    (:mod:`bkabem_core.synth.strikes`), not by the quasi-static model (whose strikes are all alike): the random
    spread of the strikes' energy from ball to ball, per unit of the share of its load a ball loses in the pit.
    """

    own_keys = (DefectKey("strike_spread", "float", 0.0, DEFAULT_STRIKE_SPREAD,
                          "random spread of the pit's strikes from ball to ball: the relative standard deviation of a "
                          "strike's energy per unit of the share of its load a ball loses in the pit (0: every strike "
                          "alike, the quasi-static model); bkabem_core.synth.strikes", required=False), ROUGHNESS)

    def check_own_key(self, key: str, value, bearing: dict) -> str | None:
        if key == "roughness_db":
            return roughness_problem(value)
        if key == "strike_spread":
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    0.0 <= value <= MAX_STRIKE_SPREAD):
                return f"must be a number from 0 (every strike alike) to {MAX_STRIKE_SPREAD:g} (got {value!r})"
        return None

    def dent_fields(self, table: dict) -> dict:
        """The strikes' spread and the bearing's roughness (``own``: carried to the ground truth and read by the
        synthesiser)."""
        return {"own": (("strike_spread", float(table.get("strike_spread", DEFAULT_STRIKE_SPREAD))),
                        roughness_field(table))}

    @abstractmethod
    def centre_rad(self, angle_rad: float, shaft_angle_rad):
        """Position angle of the pit centre [rad] of a defect at ``angle_rad`` at shaft angles ``shaft_angle_rad``
        (broadcast against the ball angles: a trailing axis)."""

    @abstractmethod
    def table_race_radius_m(self, bearing: dict) -> float:
        """Radius of the race at the contact [m] from the case's ``[bearing]`` table (the size checks)."""

    def drop_m(self, profiles, beta_rad, shaft_angle_rad, spin_angle_rad):
        race = None
        for p in profiles:
            d = p.drop_m(np.abs(wrap_to_pi(beta_rad - self.centre_rad(p.dent.angle_rad, shaft_angle_rad))))
            race = d if race is None else np.maximum(race, d)
        return race

    def check_size(self, table: dict, bearing: dict) -> tuple[str, str] | None:
        """Shorter than the race's circumference and than one ball pitch along it (longer spalls meet two balls at
        once: outside this model)."""
        circ = 2.0 * math.pi * self.table_race_radius_m(bearing)
        length = table["length_m"]
        if length >= circ:
            return "length_m", (f"must be shorter than the {self.adjective} circumference {circ * 1e3:.1f} mm "
                                f"(got {length * 1e3:g} mm)")
        z = bearing["n_balls"]
        if length >= circ / z:
            return "length_m", (f"must be shorter than one ball pitch along the {self.place} "
                                f"({circ / z * 1e3:.2f} mm): longer spalls are outside this model "
                                f"(got {length * 1e3:g} mm)")
        return None
