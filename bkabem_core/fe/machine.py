"""The machine of a case: one bearing model at every consumer's own operating point.

Every part of bkabem describes the same machine (docs/method.md):

1. The FE rotor (:func:`bkabem_core.fe.rotor.rotor_from_case`) gives each bearing's static radial load under
   gravity and the radial loads a loader applies at the bearings (:func:`static_force_n`). Two bearings make the
   rotor statically determinate, so these loads do not depend on any stiffness.
2. Each bearing (:class:`bkabem_core.bearing.deep_groove.Bearing`, the same Sopanen model; at each position the
   bearing of that position, :meth:`Case.bearing_geometry`, with its own clearance) is put at its static
   equilibrium under that load and its axial load (:class:`BearingSite`).
3. The FE's linear bearing elements are each bearing linearised there (``linearisation = "model"``: mean tangent
   over its ball pitch, axial displacement held, the position's viscous bearing damper), or paper Table 1's values
   (``"table"``).
4. The FE mesh is refined so that every mode below the case's highest frequency is converged
   (:func:`bkabem_core.fe.rotor.mesh_for`), with the rotor's structural damping.
5. Each bearing's excitation (:meth:`Machine.excitations`) is computed under the same load, with the same
   bearing, and the time-domain reference (:mod:`bkabem_core.reference.tdsm`) puts the same nonlinear bearing between the
   same nodes.

Units: SI (m, s, N, kg).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from bkabem_core.bearing.deep_groove import Bearing
from bkabem_core.bearing.statics import BearingLinearisation, BearingState
from bkabem_core.excitation.quasi_static import (
    Excitation,
    FourDofParameters,
    compute_excitation,
    quasi_static_excitation,
)
from bkabem_core.fe.budget import check_mesh, singular_stiffness
from bkabem_core.fe.rotor import Mesh, Rotor, mesh_for, rotor_from_case
from bkabem_core.model.case import Case, CaseError
from bkabem_core.model.vocabulary import BEARINGS


@dataclass
class BearingSite:
    """One bearing of the machine at its operating point.

    Attributes
    ----------
    name : str
        ``"de"`` or ``"nde"``.
    bearing : Bearing
        The bearing with its defects, if it carries any.
    rotor_node, housing_node : int
        FE nodes it connects (case labels).
    radial_load_n : ndarray (2,)
        External load on the shaft that the bearing carries, ``(W_x, W_y)`` [N] (gravity: ``W_y < 0``).
    axial_load_n : float
        Axial load [N].
    state : BearingState
        Static equilibrium under both loads (dent ignored).
    linearisation : BearingLinearisation
        The bearing model linearised there (pitch mean, axial displacement held, the case's damper).
    stiffness_n_m, damping_n_s_m : ndarray (2,)
        ``(horizontal, vertical)`` values of the FE bearing element [N/m], [N s/m]: the linearisation's, or Table
        1's with ``linearisation = "table"``.
    source : str
        ``"model"`` or ``"table"``.
    rotating_load_n : complex
        The load on the shaft that turns with it, ``(Re, Im)(R exp(i theta_shaft))`` [N] (0: none).
    """

    name: str
    bearing: Bearing
    rotor_node: int
    housing_node: int
    radial_load_n: np.ndarray
    axial_load_n: float
    state: BearingState
    linearisation: BearingLinearisation
    stiffness_n_m: np.ndarray
    damping_n_s_m: np.ndarray
    source: str
    rotating_load_n: complex = 0j

    @property
    def has_defect(self) -> bool:
        return self.bearing.has_defect

    def to_dict(self) -> dict:
        return {"radial_load_n": self.radial_load_n.tolist(), "axial_load_n": self.axial_load_n,
                "state": self.state.to_dict(), "source": self.source,
                "stiffness_n_m": {"horizontal": float(self.stiffness_n_m[0]), "vertical": float(self.stiffness_n_m[1])},
                "damping_n_s_m": {"horizontal": float(self.damping_n_s_m[0]), "vertical": float(self.damping_n_s_m[1])},
                "model_stiffness_n_m": {"horizontal": self.linearisation.stiffness_horizontal_n_m,
                                        "vertical": self.linearisation.stiffness_vertical_n_m},
                "stiffness_variation": self.linearisation.stiffness_variation}


def static_force_n(case: Case, rotor: Rotor) -> np.ndarray:
    """The static loads on the FE model ``rotor`` of ``case`` (ndof,) [N, N m]: the weight of every mass
    (:meth:`Rotor.gravity_force`) and each bearing's applied radial load (``[bearings.*] applied_radial_load_n``, a
    loader on the shaft at the bearing's rotor node, downward like the weight).

    The FE statics, the bearings' linearisation and excitation loads (:class:`Machine`) and the time-domain
    reference's equilibrium all start from this one vector."""
    f = rotor.gravity_force(case.gravity_m_s2)
    for name in BEARINGS:
        load = case.applied_radial_load_n(name)
        if load > 0.0:
            f[rotor.dof_index(int(case.raw["bearings"][name]["rotor_node"]), "y")] -= load
    return f


class Machine:
    """The case's rotor, bearings and housings, consistent with each other (module docstring).

    Parameters
    ----------
    case : Case
    mesh : Mesh, "auto" or None
        FE mesh: ``"auto"`` (default) refines for :attr:`Case.max_frequency_hz` with the case's
        ``rotor.elements_per_wavelength`` (0 there: no refinement); a :class:`Mesh`; None: one element per case
        element.

    rotor : Rotor, optional
        The FE model made already for a case with the same FE (:meth:`fe_key`): reused as it is.

    Attributes
    ----------
    rotor : Rotor
        FE model with the linear bearing elements of :attr:`sites`.
    sites : dict name -> BearingSite
    mesh : Mesh
    build_time_s : float
    """

    def __init__(self, case: Case, mesh: Mesh | str | None = "auto", rotor: Rotor | None = None):
        t0 = time.perf_counter()
        self.case = case
        raw = case.raw
        if mesh == "auto":
            check_mesh(case)                                    # its size, before anything is allocated
            epw = float(raw["rotor"]["elements_per_wavelength"])
            mesh = mesh_for(raw, case.max_frequency_hz, epw) if epw > 0 else None
        n_el = len(raw["rotor"]["outer_diameters_m"])
        self.mesh: Mesh = mesh if mesh is not None else Mesh((1,) * n_el)
        with warnings.catch_warnings():                     # an ill-conditioned K: the case's stiffnesses
            warnings.simplefilter("error", scipy.linalg.LinAlgWarning)
            try:
                statics = rotor_from_case(raw, damping={})
                loads = statics.bearing_reactions_n(static_force_n(case, statics))  # statically determinate
                turning = self._turning_loads(statics)
            except (scipy.linalg.LinAlgWarning, np.linalg.LinAlgError) as exc:
                raise singular_stiffness(case, str(exc).rstrip(".")) from None
        self.sites: dict[str, BearingSite] = {}
        for name in BEARINGS:
            b = raw["bearings"][name]
            geometry = case.bearing_geometry(name)                 # each position's own bearing
            damper = case.bearing_damping_n_s_m(name)
            fx, fy = loads[name]
            w = np.array([-fx, -fy], dtype=float)                 # the load on the shaft the bearing carries
            axial = float(b["axial_load_n"])
            try:
                lin = Bearing(geometry).linearise(w[0], w[1], axial_load_n=axial, damping_n_s_m=damper,
                                                  average_over_pitch=True)
            except (ValueError, RuntimeError) as exc:
                raise CaseError(f"bearings.{name}.axial_load_n", f"the {name.upper()} bearing has no static "
                                f"equilibrium under {np.hypot(*w):.4g} N radial and {axial:g} N axial ({exc}): a "
                                f"light rotor in a loose bearing; give it an axial preload", case.source) from None
            bearing = Bearing(geometry, defects=[d for d in case.defects(name) if d.depth_m > 0.0])
            bearing = bearing.with_bridging_load(bearing.peak_ball_load_n(lin.state))   # round pits: at its load
            if b["linearisation"] == "model":
                k = np.array([lin.stiffness_horizontal_n_m, lin.stiffness_vertical_n_m])
                c = np.array([lin.damping_horizontal_n_s_m, lin.damping_vertical_n_s_m])
            else:
                k = np.array([b["table_stiffness_horizontal_n_m"], b["table_stiffness_vertical_n_m"]], float)
                c = np.array([b["table_damping_horizontal_n_s_m"], b["table_damping_vertical_n_s_m"]], float)
            self.sites[name] = BearingSite(name=name, bearing=bearing, rotor_node=int(b["rotor_node"]),
                                           housing_node=int(b["housing_node"]), radial_load_n=w, axial_load_n=axial,
                                           state=lin.state, linearisation=lin, stiffness_n_m=k, damping_n_s_m=c,
                                           source=b["linearisation"], rotating_load_n=turning[name])
        elements = {n: (s.stiffness_n_m[0], s.stiffness_n_m[1], s.damping_n_s_m[0], s.damping_n_s_m[1])
                    for n, s in self.sites.items()}
        self.rotor: Rotor = rotor if rotor is not None else rotor_from_case(raw, bearings=elements, mesh=self.mesh)
        self.build_time_s = time.perf_counter() - t0

    def _turning_loads(self, statics: Rotor) -> dict[str, complex]:
        """Each bearing's share of the load that turns with the shaft (the coupling force of ``[baseline]``), as
        the complex amplitude ``R`` of the load on the shaft it carries, ``(Re, Im)(R exp(i theta_shaft))`` [N].
        Two bearings make the rotor statically determinate, so the shares follow from statics alone (an overhung
        coupling loads the near bearing more than the force and the far one against it)."""
        b = self.case.raw["baseline"]
        force = float(b.get("coupling_force_n", 0.0))
        if force <= 0.0:
            return {name: 0j for name in BEARINGS}
        unit = np.zeros(statics.ndof)
        unit[statics.dof_index(int(b["misalignment_node"]), "x")] = 1.0
        reactions = statics.bearing_reactions_n(unit)
        a = force * np.exp(1j * np.radians(float(b.get("coupling_phase_deg", 0.0))))
        return {name: complex(-reactions[name][0] * a) for name in BEARINGS}

    @staticmethod
    def fe_key(case: Case) -> str:
        """What the FE model depends on (everything but the defect and the excitation settings), as a string.

        Two excitation keys do shape the FE: the gravity (the bearings' static loads, where they are linearised)
        and the highest kept order (the frequency the mesh is converged up to)."""
        import json

        raw = {k: v for k, v in case.resolved.items() if k not in ("case", "defects", "baseline", "excitation")}
        ex = case.raw["excitation"]
        raw["excitation"] = {k: ex[k] for k in ("gravity_m_s2", "max_order")}
        return json.dumps(raw, sort_keys=True)

    @property
    def faulty_bearing(self) -> str:
        return self.case.faulty_bearing

    def rotor_without_bearings(self) -> Rotor:
        """The same FE model without the rotor-housing bearing elements (the time-domain model's linear part)."""
        return rotor_from_case(self.case.raw, mesh=self.mesh, with_bearings=False)

    def excitation_load_n(self, name: str) -> float:
        """Downward radial load of bearing ``name``'s excitation [N] (``[excitation] load``)."""
        ex = self.case.raw["excitation"]
        if ex["load"] == "rotor_weight":
            return float(ex["rotor_mass_kg"]) * self.case.gravity_m_s2
        return float(-self.sites[name].radial_load_n[1])

    def excited_bearings(self) -> tuple[str, ...]:
        """Bearings whose excitation is applied (``[excitation] bearings``): all, or only the faulty one."""
        if self.case.raw["excitation"]["bearings"] == "all":
            return BEARINGS
        return (self.case.faulty_bearing,)

    def excitation(self, name: str, method: str | None = None) -> Excitation:
        """Excitation of bearing ``name`` under its own load, as the case's ``[excitation]`` says.

        Defects each valid alone can together leave the bearing without a static equilibrium (a race covered
        with pits): that is the case's ``defects``, refused with :class:`CaseError` (the numerical warnings of
        the failed iteration are dropped with it; a result that converged keeps its warnings)."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                out = self._excitation(name, method)
            except RuntimeError as exc:
                if "did not converge" not in str(exc):
                    raise
                n = len(self.sites[name].bearing.defects)
                raise CaseError("defects", f"the {name} bearing with its {n} defect{'s' * (n != 1)} has no static "
                                f"equilibrium the model finds ({exc}): the defects together take away too much of "
                                f"the race", self.case.source) from None
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return out

    def _excitation(self, name: str, method: str | None) -> Excitation:
        ex = self.case.raw["excitation"]
        method = ex["method"] if method is None else method
        site = self.sites[name]
        w = self.excitation_load_n(name)
        if method == "quasi_static":
            return quasi_static_excitation(site.bearing, w, site.axial_load_n, int(ex["samples_per_ball_pass"]),
                                           float(ex["relative_amplitude_threshold"]), int(ex["max_order"]),
                                           float(ex["reference_speed_hz"]), location=name,
                                           rotating_load_n=site.rotating_load_n)
        params = dataclasses.replace(FourDofParameters.from_case(self.case, name), rotor_mass_kg=w / self.case.gravity_m_s2)
        return compute_excitation(site.bearing, params, site.axial_load_n, location=name)

    def excitations(self) -> dict[str, Excitation]:
        """The excitation of every excited bearing (:meth:`excited_bearings`)."""
        return {name: self.excitation(name) for name in self.excited_bearings()}

    def to_dict(self) -> dict:
        return {"mesh": {"elements": self.mesh.n_elements, "max_frequency_hz": self.mesh.max_frequency_hz,
                         "elements_per_wavelength": self.mesh.elements_per_wavelength},
                "ndof": self.rotor.ndof, "bearings": {n: s.to_dict() for n, s in self.sites.items()}}
