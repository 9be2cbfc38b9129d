"""Localised defects of a ball bearing: the description of one (:class:`Dent`) and the drop every ball feels from
all of a bearing's defects (:class:`DefectSet`).

A dent (pit, spall) of length l along the rolling direction and depth h lowers the contact under a ball by the
*radial drop of the ball centre* (:mod:`bkabem_core.bearing.defects.profiles`). What differs between the kinds
(``Dent.race``: ``"outer"``, ``"inner"``, ``"ball"``, :data:`~bkabem_core.bearing.defects.registry.KINDS`) -- where
the pit is, which phases place it, its drop profile -- is the kind's (:mod:`bkabem_core.bearing.defects.protocol`, one
module each); this module holds what they share.

Every kind has the alternative ``edge = "cubic"`` profile (flat bottom, ADAMS cubic STEP edges over ``edge_fraction``
of the half-angle; depth at most what the ``"ball"`` profile reaches, for the outer race the ball's sagitta over the
pit). Every kind has both shapes (``Dent.shape``): a ``"slot"`` across the ball track (the profiles above) and a
``"round_pit"`` of diameter ``length_m``, which the contact ellipse bridges (:mod:`bkabem_core.bearing.defects.
round_pit`: its drop at each contact from the elastic half-space, at the ball load ``bridging_load_n``). Several defects in one bearing combine inside the bearing model: drops of the same contact take the deeper one
(a ball is in one pit of a race at a time), the outer and inner contacts are in series, so their drops add.

Angles in rad, lengths in m. Nothing here imports the bearing model: :class:`DefectSet` gets the geometry it needs
(:class:`~bkabem_core.bearing.defects.profiles.ContactGeometry`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from bkabem_core.bearing.defects import round_pit
from bkabem_core.bearing.defects.profiles import EDGE_PROFILES, SHAPES, ContactGeometry, step_cubic
from bkabem_core.bearing.defects.registry import KINDS, find, kind


@dataclass(frozen=True)
class Dent:
    """A localised defect (dent, pit, spall) of one bearing (module docstring).

    Attributes
    ----------
    length_m : float
        Length along the rolling direction [m] (the arc on the race, or on the ball's rolling circle); a round pit's
        diameter.
    depth_m : float
        Depth (the paper's "height") [m]; 0: no defect.
    angle_rad : float
        Where it is at t = 0 [rad], as its kind places it: ``"outer"``: position angle of the centre in the bearing
        plane, from +x towards +y; ``"inner"``: the same at shaft angle 0 (it turns with the shaft); ``"ball"``: spin
        angle of the centre, 0 facing the outer race.
    edge_fraction : float
        ``edge = "cubic"`` only: width of each smoothed edge as a fraction of the half-angle [-], in [0, 1].
    bearing : str
        ``"de"`` or ``"nde"``: which bearing of the machine carries it.
    race : str
        Its kind: a name of :data:`~bkabem_core.bearing.defects.registry.KINDS`.
    edge : str
        ``"ball"`` (the ball-over-edge path) or ``"cubic"``.
    ball_index : int
        Kinds on a ball: which ball (0-based, ball 1 at ``first_ball_angle`` when the cage angle is 0).
    own : tuple of (str, object)
        Any other keys only its kind has (``DefectKind.own_keys``), as ``((key, value), ...)``.
    shape : str
        ``"slot"`` (across the ball track) or ``"round_pit"`` (:data:`~bkabem_core.bearing.defects.profiles.SHAPES`).
    bridging_load_n : float
        ``"round_pit"`` only: the ball load at which the contact's bridging of the pit is evaluated [N] (the
        bearing's largest static ball load: :meth:`~bkabem_core.bearing.deep_groove.Bearing.with_bridging_load`);
        0: a rigid ball, the pit's geometric drop.
    """

    length_m: float
    depth_m: float
    angle_rad: float
    edge_fraction: float = 0.1
    bearing: str = "de"
    race: str = KINDS[0]
    edge: str = "ball"
    ball_index: int = 0
    own: tuple = ()
    shape: str = SHAPES[0]
    bridging_load_n: float = 0.0

    def __post_init__(self):
        if self.edge not in EDGE_PROFILES:
            raise ValueError(f"edge: must be one of {', '.join(EDGE_PROFILES)} (got {self.edge!r})")
        if find(self.race) is None:
            raise ValueError(f"race: must be one of {', '.join(KINDS)} (got {self.race!r})")
        if self.shape not in SHAPES:
            raise ValueError(f"shape: must be one of {', '.join(SHAPES)} (got {self.shape!r})")
        if self.shape == "round_pit" and self.edge != "ball":
            raise ValueError(f"edge: must be 'ball' for a round pit (got {self.edge!r})")
        if not self.bridging_load_n >= 0.0:
            raise ValueError(f"bridging_load_n: must be >= 0 (got {self.bridging_load_n!r})")

    @property
    def kind(self) -> str:
        return self.race

    def to_dict(self) -> dict:
        return asdict(self)


class DefectProfile:
    """One defect with the geometry of its bearing: its half-angle, effective depth and drop profile(s).

    Parameters
    ----------
    dent : Dent
    geometry : ContactGeometry

    Attributes
    ----------
    kind : DefectKind
        Its kind (:func:`~bkabem_core.bearing.defects.registry.kind`).
    half_angle_rad : float
        Half the angle the pit subtends on its surface (race, or ball for a pit in a ball) [rad]; a round pit: half the
        angle over which a ball feels it (its radius and the contact's half-length beyond it).
    depth_eff_m : float
        Largest drop (at the centre) [m]; the larger of its contacts' for a kind that meets two.
    edge_rad : float
        ``"cubic"``: the smoothed edge width [rad]; 0 for ``"ball"``.
    """

    def __init__(self, dent: Dent, geometry: ContactGeometry):
        self.dent = dent
        self.kind = kind(dent.race)
        self.geometry = geometry
        self._radius = self.kind.surface_radius_m(geometry)
        if dent.shape == "round_pit":
            self._pits = {c: round_pit.pit_contact(dent, geometry, c).profile() for c in self.kind.contacts}
            self.half_angle_rad = max(p.support_m for p in self._pits.values()) / self._radius
            self.edge_rad = 0.0
            self.depth_eff_m = max(p.max_drop_m for p in self._pits.values())
            return
        self.half_angle_rad = dent.length_m / (2.0 * self._radius)
        a = self.half_angle_rad
        self.edge_rad = dent.edge_fraction * a if dent.edge == "cubic" else 0.0
        edge_depth = {c: float(self.kind.edge_drop_m(np.array(a), dent, geometry, c))
                      for c in self.kind.contacts}
        if dent.edge == "cubic":
            self._cubic_depth = {c: self.kind.cubic_depth_m(dent, geometry, d) for c, d in edge_depth.items()}
            self.depth_eff_m = max(self._cubic_depth.values())
        else:
            self.depth_eff_m = max(edge_depth.values())

    @property
    def active(self) -> bool:
        """Whether a ball feels it at all (depth > 0)."""
        return self.depth_eff_m > 0.0

    def drop_m(self, rel_angle_rad, contact: str | None = None):
        """Drop [m] at an absolute angular distance ``rel_angle_rad`` [rad] from the pit centre on its surface, at
        ``contact`` (``"outer"``/``"inner"``; default: the first its kind meets)."""
        rel = np.asarray(rel_angle_rad, dtype=float)
        if not self.active:
            return np.zeros(rel.shape)
        contact = self.kind.contacts[0] if contact is None else contact
        if self.dent.shape == "round_pit":
            return self._pits[contact].drop_m(rel * self._radius)
        a = self.half_angle_rad
        if self.dent.edge == "cubic":
            return self._cubic_depth[contact] * (1.0 - step_cubic(rel, a - self.edge_rad, a))
        return np.where(rel < a, self.kind.edge_drop_m(a - rel, self.dent, self.geometry, contact), 0.0)

    def entry_ramp_rad(self) -> float:
        """Angle on its surface over which the drop goes from 0 to its largest value at each edge [rad] (at the first
        contact its kind meets)."""
        if self.dent.edge == "cubic":
            return self.edge_rad
        psi = np.linspace(0.0, self.half_angle_rad, 2049)
        if self.dent.shape == "round_pit":                     # the profile from the far end of its support inwards
            prof = self.drop_m(self.half_angle_rad - psi)
            full = np.nonzero(prof >= prof.max() * (1.0 - 1e-9))[0]
            return float(psi[full[0]]) if full.size and prof.max() > 0.0 else float(self.half_angle_rad)
        prof = self.kind.edge_drop_m(psi, self.dent, self.geometry, self.kind.contacts[0])
        full = np.nonzero(prof >= prof[-1] * (1.0 - 1e-9))[0]
        return float(psi[full[0]]) if full.size else float(self.half_angle_rad)


class DefectSet:
    """The defects of one bearing, as the drop every ball feels at given phases.

    Parameters
    ----------
    dents : sequence of Dent
        The bearing's defects (depth 0 ones are ignored).
    geometry : ContactGeometry

    Attributes
    ----------
    profiles : tuple of DefectProfile
        The active defects.
    kinds : tuple of DefectKind
        Their kinds, without repetition, in listing order (:func:`~bkabem_core.bearing.defects.registry.kinds`).
    """

    def __init__(self, dents, geometry: ContactGeometry):
        self.geometry = geometry
        profiles = [DefectProfile(d, geometry) for d in dents]
        self.profiles = tuple(p for p in profiles if p.active)
        self.n_balls = int(geometry.n_balls)
        for p in self.profiles:
            p.kind.check_dent(p.dent, geometry)
        present = {p.kind.name for p in self.profiles}
        self.kinds = tuple(sorted((kind(name) for name in present), key=lambda k: (k.order, k.name)))

    def __bool__(self) -> bool:
        return bool(self.profiles)

    def of_kind(self, name: str) -> tuple:
        """The active defects of the kind of this name."""
        return tuple(p for p in self.profiles if p.kind.name == name)

    @property
    def phases(self) -> tuple:
        """Base phases besides the cage angle that the drops depend on (``"shaft"``, ``"spin"``)."""
        return tuple(ph for k in self.kinds for ph in k.phases)

    @property
    def moving(self) -> tuple:
        """The kinds present that are not BPFO-periodic (phases of their own, or a drop per ball)."""
        return tuple(k for k in self.kinds if not k.periodic)

    @property
    def per_ball(self) -> bool:
        """Whether some drop belongs to one ball (:meth:`drop_m` then needs the angles of every ball)."""
        return any(k.per_ball for k in self.kinds)

    def drop_m(self, beta_rad, shaft_angle_rad=0.0, spin_angle_rad=0.0):
        """Drop of every ball [m], shape of ``beta_rad`` (..., z), at ball attitude angles ``beta_rad`` [rad], shaft
        angle and spin angle [rad] (broadcast against ``beta_rad[..., 0]``): the kinds' drops added, in listing
        order."""
        beta = np.asarray(beta_rad, dtype=float)
        total = np.zeros(beta.shape)
        for k in self.kinds:
            total = total + k.drop_m(self.of_kind(k.name), beta, shaft_angle_rad, spin_angle_rad)
        return total
