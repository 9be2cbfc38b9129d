"""Lateral rotor finite-element model (Timoshenko beam, disks, point masses, linear bearings).

The model is the classical 4-DOF-per-node rotordynamic beam model of Friswell et al. (2010),
*Dynamics of Rotating Machines*, ch. 5, with the same DOF order and sign conventions as ROSS
(``ross-rotordynamics``; its 6-DOF model reduced with ``ross.utils.convert_6dof_to_4dof``).

Conventions
-----------
* Axes: ``z`` axial, ``x`` horizontal, ``y`` vertical (up; gravity acts along ``-y``).
* Shaft nodes carry 4 DOFs ``[x, y, alpha, beta]``: ``alpha`` is the rotation about ``x``,
  ``beta`` the rotation about ``y``.  For a bending deflection ``x(z), y(z)``:
  ``beta = +dx/dz`` and ``alpha = -dy/dz``.
* Point-mass-only nodes (bearing housings) carry 2 DOFs ``[x, y]``.
* Nodes are identified by integer labels.  The global DOF vector lists the nodes in ascending
  label order, each contributing its 4 or 2 DOFs in the order above.
* Equation of motion: ``M q'' + (C + Omega G) q' + K q = F`` with ``Omega`` the shaft speed in rad/s,
  positive for a spin about ``+z`` (from ``+x`` towards ``+y``).  ``G`` is skew-symmetric with
  ``G[alpha, beta] = +Ip`` for a disk; with this sign the forward-whirl (``x -> y``) frequencies
  rise with speed.

Units are SI throughout (m, kg, s, N, Pa, rad).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Iterable, Mapping, Sequence

import numpy as np
import scipy.linalg

__all__ = [
    "Material",
    "ShaftElement",
    "Disk",
    "PointMass",
    "LinearBearing",
    "Rotor",
    "rotor_from_case",
    "Mesh",
    "mesh_for",
    "shortest_wavelength_m",
    "structural_damping",
    "STANDARD_GRAVITY_M_S2",
]

STANDARD_GRAVITY_M_S2 = 9.80665

_SHAFT_DIRECTIONS = ("x", "y", "alpha", "beta")
_POINT_DIRECTIONS = ("x", "y")


# --------------------------------------------------------------------------------------------
# Material
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material.

    Parameters
    ----------
    youngs_modulus_pa : float
        Young's modulus E (Pa).
    poisson_ratio : float
        Poisson's ratio nu (-).
    density_kg_m3 : float
        Density rho (kg/m^3).
    """

    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float

    def __post_init__(self) -> None:
        if not self.youngs_modulus_pa > 0:
            raise ValueError(f"youngs_modulus_pa must be > 0, got {self.youngs_modulus_pa}")
        if not -1.0 < self.poisson_ratio < 0.5:
            raise ValueError(f"poisson_ratio must be in (-1, 0.5), got {self.poisson_ratio}")
        if not self.density_kg_m3 > 0:
            raise ValueError(f"density_kg_m3 must be > 0, got {self.density_kg_m3}")

    @property
    def shear_modulus_pa(self) -> float:
        """Shear modulus G_s = E / (2 (1 + nu)) (Pa)."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))


# --------------------------------------------------------------------------------------------
# Elements
# --------------------------------------------------------------------------------------------
# Sign pattern mapping an x-z plane matrix (DOFs x0, beta0, x1, beta1) to the y-z plane
# (DOFs y0, alpha0, y1, alpha1): alpha = -dy/dz while beta = +dx/dz.
_PLANE_SIGN = np.diag([1.0, -1.0, 1.0, -1.0])
# Positions of the plane DOFs inside the element vector [x0, y0, a0, b0, x1, y1, a1, b1].
_XZ = np.array([0, 3, 4, 7])  # x0, beta0, x1, beta1
_YZ = np.array([1, 2, 5, 6])  # y0, alpha0, y1, alpha1


def _planes_to_element(a_xz: np.ndarray) -> np.ndarray:
    """Place an x-z plane 4x4 matrix into both bending planes of an 8x8 element matrix."""
    out = np.zeros((8, 8))
    out[np.ix_(_XZ, _XZ)] = a_xz
    out[np.ix_(_YZ, _YZ)] = _PLANE_SIGN @ a_xz @ _PLANE_SIGN
    return out


@dataclass(frozen=True)
class ShaftElement:
    """Uniform (cylindrical, possibly hollow) Timoshenko rotor beam element with 2 nodes.

    Element DOF order: ``[x0, y0, alpha0, beta0, x1, y1, alpha1, beta1]`` (0 = ``node_left``,
    1 = ``node_right``).  Matrices as in Friswell et al. (2010) and ROSS ``ShaftElement``:
    shear deformation through ``phi = 12 E I / (kappa G_s A L^2)`` with Cowper's shear
    coefficient for a hollow circular section, consistent translational mass, rotary inertia
    and gyroscopic matrices.

    Parameters
    ----------
    node_left, node_right : int
        Node labels of the element ends (left = smaller axial coordinate by convention).
    length_m : float
        Element length L (m).
    outer_diameter_m, inner_diameter_m : float
        Outer and inner (bore) diameter (m); ``inner_diameter_m = 0`` for a solid shaft.
    material : Material
        Shaft material.
    shear_effects : bool
        Include Timoshenko shear deformation (``phi > 0``).  False gives Euler-Bernoulli bending.
    rotary_inertia : bool
        Include the rotary (diametral) inertia of the cross-sections in the mass matrix.
    gyroscopic : bool
        Include the gyroscopic matrix (otherwise it is zero).
    """

    node_left: int
    node_right: int
    length_m: float
    outer_diameter_m: float
    inner_diameter_m: float
    material: Material
    shear_effects: bool = True
    rotary_inertia: bool = True
    gyroscopic: bool = True

    def __post_init__(self) -> None:
        if self.node_left == self.node_right:
            raise ValueError(f"shaft element needs two different nodes, got {self.node_left} twice")
        if not self.length_m > 0:
            raise ValueError(f"length_m must be > 0, got {self.length_m}")
        if not self.outer_diameter_m > 0:
            raise ValueError(f"outer_diameter_m must be > 0, got {self.outer_diameter_m}")
        if not 0 <= self.inner_diameter_m < self.outer_diameter_m:
            raise ValueError(
                f"inner_diameter_m must be in [0, outer_diameter_m), got {self.inner_diameter_m}"
            )

    # -- section properties --------------------------------------------------------------
    @property
    def area_m2(self) -> float:
        """Cross-section area A (m^2)."""
        return np.pi / 4.0 * (self.outer_diameter_m**2 - self.inner_diameter_m**2)

    @property
    def second_moment_m4(self) -> float:
        """Second moment of area I about a diameter (m^4)."""
        return np.pi / 64.0 * (self.outer_diameter_m**4 - self.inner_diameter_m**4)

    @property
    def shear_coefficient(self) -> float:
        """Cowper's shear coefficient kappa of a hollow circular section (-)."""
        nu = self.material.poisson_ratio
        r2 = (self.inner_diameter_m / self.outer_diameter_m) ** 2
        s = (1.0 + r2) ** 2
        return 6.0 * (1.0 + nu) * s / ((7.0 + 6.0 * nu) * s + (20.0 + 12.0 * nu) * r2)

    @property
    def phi(self) -> float:
        """Shear-deformation parameter phi = 12 E I / (kappa G_s A L^2) (0 without shear)."""
        if not self.shear_effects:
            return 0.0
        m = self.material
        return (
            12.0 * m.youngs_modulus_pa * self.second_moment_m4
            / (self.shear_coefficient * m.shear_modulus_pa * self.area_m2 * self.length_m**2)
        )

    @property
    def mass_kg(self) -> float:
        """Element mass rho A L (kg)."""
        return self.material.density_kg_m3 * self.area_m2 * self.length_m

    @property
    def nodes(self) -> tuple[int, int]:
        """Node labels ``(node_left, node_right)``."""
        return (self.node_left, self.node_right)

    # -- plane building blocks -----------------------------------------------------------
    def _rotary_xz(self, inertia_m4: float) -> np.ndarray:
        """x-z plane rotary-inertia matrix for section inertia ``inertia_m4`` (times rho)."""
        L, p = self.length_m, self.phi
        a = 252.0
        b = (21.0 - 105.0 * p) * L
        c = (28.0 + 35.0 * p + 70.0 * p**2) * L**2
        d = (7.0 + 35.0 * p - 35.0 * p**2) * L**2
        mat = np.array([
            [a, b, -a, b],
            [b, c, -b, -d],
            [-a, -b, a, -b],
            [b, -d, -b, c],
        ])
        return self.material.density_kg_m3 * inertia_m4 / (210.0 * L * (1.0 + p) ** 2) * mat

    # -- element matrices ----------------------------------------------------------------
    def mass_matrix(self) -> np.ndarray:
        """Consistent mass matrix (8, 8) in kg, kg m, kg m^2.

        Translational inertia plus, if ``rotary_inertia``, the rotary inertia of the sections.
        """
        L, p = self.length_m, self.phi
        m1 = 468.0 + 882.0 * p + 420.0 * p**2
        m2 = (66.0 + 115.5 * p + 52.5 * p**2) * L
        m3 = 162.0 + 378.0 * p + 210.0 * p**2
        m4 = (39.0 + 94.5 * p + 52.5 * p**2) * L
        m5 = (12.0 + 21.0 * p + 10.5 * p**2) * L**2
        m7 = (9.0 + 21.0 * p + 10.5 * p**2) * L**2
        mt = np.array([
            [m1, m2, m3, -m4],
            [m2, m5, m4, -m7],
            [m3, m4, m1, -m2],
            [-m4, -m7, -m2, m5],
        ]) * (self.mass_kg / (1260.0 * (1.0 + p) ** 2))
        if self.rotary_inertia:
            mt = mt + self._rotary_xz(self.second_moment_m4)
        return _planes_to_element(mt)

    def stiffness_matrix(self) -> np.ndarray:
        """Bending stiffness matrix (8, 8) in N/m, N, N m (Timoshenko if ``shear_effects``)."""
        L, p = self.length_m, self.phi
        ei = self.material.youngs_modulus_pa * self.second_moment_m4
        kt = np.array([
            [12.0, 6.0 * L, -12.0, 6.0 * L],
            [6.0 * L, (4.0 + p) * L**2, -6.0 * L, (2.0 - p) * L**2],
            [-12.0, -6.0 * L, 12.0, -6.0 * L],
            [6.0 * L, (2.0 - p) * L**2, -6.0 * L, (4.0 + p) * L**2],
        ]) * (ei / (L**3 * (1.0 + p)))
        return _planes_to_element(kt)

    def gyroscopic_matrix(self) -> np.ndarray:
        """Gyroscopic matrix (8, 8) per unit shaft speed (kg m, kg m^2); skew-symmetric.

        It couples the two bending planes: with ``R`` the x-z rotary-inertia matrix of the polar
        section inertia ``J = 2 I`` and ``S = diag(1, -1, 1, -1)``, the block (x-z rows, y-z
        columns) is ``R S`` and the block (y-z rows, x-z columns) is ``-(R S)^T``.
        """
        g = np.zeros((8, 8))
        if not self.gyroscopic:
            return g
        block = self._rotary_xz(2.0 * self.second_moment_m4) @ _PLANE_SIGN
        g[np.ix_(_XZ, _YZ)] = block
        g[np.ix_(_YZ, _XZ)] = -block.T
        return g


@dataclass(frozen=True)
class Disk:
    """Rigid disk lumped at a shaft node.

    Parameters
    ----------
    node : int
        Shaft node label (must carry 4 DOFs).
    mass_kg : float
        Mass (kg).
    polar_inertia_kg_m2 : float
        Polar moment of inertia Ip about the shaft axis (kg m^2).
    diametral_inertia_kg_m2 : float
        Diametral (transverse) moment of inertia Id about the disk centre (kg m^2).
    name : str
        Optional identifier.
    """

    node: int
    mass_kg: float
    polar_inertia_kg_m2: float
    diametral_inertia_kg_m2: float
    name: str = ""

    def __post_init__(self) -> None:
        for attr in ("mass_kg", "polar_inertia_kg_m2", "diametral_inertia_kg_m2"):
            if getattr(self, attr) < 0:
                raise ValueError(f"Disk {self.name!r}: {attr} must be >= 0")

    def mass_matrix(self) -> np.ndarray:
        """Mass matrix (4, 4) on ``[x, y, alpha, beta]``: diag(m, m, Id, Id)."""
        m, i_d = self.mass_kg, self.diametral_inertia_kg_m2
        return np.diag([m, m, i_d, i_d])

    def gyroscopic_matrix(self) -> np.ndarray:
        """Gyroscopic matrix (4, 4) per unit speed: ``G[alpha, beta] = +Ip = -G[beta, alpha]``."""
        g = np.zeros((4, 4))
        g[2, 3] = self.polar_inertia_kg_m2
        g[3, 2] = -self.polar_inertia_kg_m2
        return g


@dataclass(frozen=True)
class PointMass:
    """Lumped translational mass at a node (acts on ``x`` and ``y``).

    Parameters
    ----------
    node : int
        Node label.  A node that only carries point masses gets 2 DOFs ``[x, y]``.
    mass_kg : float
        Mass (kg).
    name : str
        Optional identifier.
    """

    node: int
    mass_kg: float
    name: str = ""

    def __post_init__(self) -> None:
        if self.mass_kg < 0:
            raise ValueError(f"PointMass {self.name!r}: mass_kg must be >= 0")

    def mass_matrix(self) -> np.ndarray:
        """Mass matrix (2, 2) on ``[x, y]``."""
        return np.eye(2) * self.mass_kg


@dataclass(frozen=True)
class LinearBearing:
    """Linear spring-damper on ``x`` and ``y`` between ``node`` and ``other_node`` (or ground).

    Parameters
    ----------
    node : int
        First node label (e.g. the rotor node of a bearing).
    other_node : int or None
        Second node label (e.g. the housing node), or None for a connection to ground.
    kxx_n_m, kyy_n_m : float
        Direct stiffness, horizontal and vertical (N/m).
    cxx_n_s_m, cyy_n_s_m : float
        Direct viscous damping, horizontal and vertical (N s/m).
    name : str
        Identifier (keys the result of :meth:`Rotor.static_bearing_loads_n`).

    Notes
    -----
    The element DOFs are ``[x_node, y_node]`` for a grounded element, else
    ``[x_node, y_node, x_other, y_other]``; the matrices are ``[[k, -k], [-k, k]]`` blocks.
    """

    node: int
    other_node: int | None
    kxx_n_m: float
    kyy_n_m: float
    cxx_n_s_m: float = 0.0
    cyy_n_s_m: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        if self.other_node is not None and self.other_node == self.node:
            raise ValueError(f"LinearBearing {self.name!r}: node and other_node are both {self.node}")

    @property
    def nodes(self) -> tuple[int, ...]:
        """Connected node labels (1 for a grounded element, else 2)."""
        return (self.node,) if self.other_node is None else (self.node, self.other_node)

    def _expand(self, diag: np.ndarray) -> np.ndarray:
        d = np.diag(diag)
        if self.other_node is None:
            return d
        return np.block([[d, -d], [-d, d]])

    def stiffness_matrix(self) -> np.ndarray:
        """Stiffness matrix (2, 2) grounded or (4, 4) linked, N/m."""
        return self._expand(np.array([self.kxx_n_m, self.kyy_n_m], dtype=float))

    def damping_matrix(self) -> np.ndarray:
        """Damping matrix (2, 2) grounded or (4, 4) linked, N s/m."""
        return self._expand(np.array([self.cxx_n_s_m, self.cyy_n_s_m], dtype=float))


# --------------------------------------------------------------------------------------------
# Rotor assembly
# --------------------------------------------------------------------------------------------
def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


class Rotor:
    """Assembled lateral rotor-bearing-housing model.

    Parameters
    ----------
    shaft_elements : sequence of ShaftElement
        Beam elements; their nodes become 4-DOF shaft nodes.
    disks : sequence of Disk
        Rigid disks on shaft nodes.
    point_masses : sequence of PointMass
        Lumped masses; nodes not on the shaft become 2-DOF nodes.
    bearings : sequence of LinearBearing
        Spring-dampers between nodes or to ground.  Names must be unique (empty names are
        replaced by ``"bearing_<node>_<other_node|ground>"``).

    Attributes
    ----------
    M, C, G, K : ndarray, shape (ndof, ndof)
        Mass, damping, gyroscopic (per unit speed, rad/s) and stiffness matrices.  They are
        assembled once, cached and read-only (copy them before modifying).

    Notes
    -----
    Global DOF order: nodes in ascending label order, ``[x, y, alpha, beta]`` per shaft node and
    ``[x, y]`` per point-mass-only node.
    """

    def __init__(
        self,
        shaft_elements: Sequence[ShaftElement],
        disks: Sequence[Disk] = (),
        point_masses: Sequence[PointMass] = (),
        bearings: Sequence[LinearBearing] = (),
        modal_damping_ratio: float = 0.0,
        stiffness_damping_s: float = 0.0,
    ) -> None:
        if not 0.0 <= modal_damping_ratio < 1.0:
            raise ValueError(f"modal_damping_ratio must be in [0, 1), got {modal_damping_ratio}")
        if not 0.0 <= stiffness_damping_s < 1e-2:
            raise ValueError(f"stiffness_damping_s must be in [0, 1e-2) s, got {stiffness_damping_s}")
        self.modal_damping_ratio = float(modal_damping_ratio)
        self.stiffness_damping_s = float(stiffness_damping_s)
        self.shaft_elements: tuple[ShaftElement, ...] = tuple(shaft_elements)
        self.disks: tuple[Disk, ...] = tuple(disks)
        self.point_masses: tuple[PointMass, ...] = tuple(point_masses)
        self.bearings: tuple[LinearBearing, ...] = tuple(self._named_bearings(bearings))

        shaft_nodes = {n for e in self.shaft_elements for n in e.nodes}
        mass_nodes = {p.node for p in self.point_masses}
        for d in self.disks:
            if d.node not in shaft_nodes:
                raise ValueError(f"Disk {d.name!r} is on node {d.node}, which is not a shaft node")
        all_nodes = shaft_nodes | mass_nodes
        for b in self.bearings:
            for n in b.nodes:
                if n not in all_nodes:
                    raise ValueError(
                        f"bearing {b.name!r} connects node {n}, which has no shaft element or point mass"
                    )
        if not all_nodes:
            raise ValueError("the rotor has no nodes (no shaft elements and no point masses)")

        # DOF order: shaft nodes along the chain of elements (so the shaft matrix is block-tridiagonal whatever the
        # labels of nodes added by mesh refinement), then the point-mass-only nodes in label order
        self.shaft_node_labels: tuple[int, ...] = self._chain_order(shaft_nodes)
        self.node_labels: tuple[int, ...] = self.shaft_node_labels + tuple(sorted(mass_nodes - shaft_nodes))
        self._node_dirs: dict[int, tuple[str, ...]] = {}
        self._node_start: dict[int, int] = {}
        start = 0
        for n in self.node_labels:
            dirs = _SHAFT_DIRECTIONS if n in shaft_nodes else _POINT_DIRECTIONS
            self._node_dirs[n] = dirs
            self._node_start[n] = start
            start += len(dirs)
        self.ndof: int = start

    def _chain_order(self, shaft_nodes: set[int]) -> tuple[int, ...]:
        """Shaft node labels along the element chain from its free end, or sorted if the elements branch."""
        if not shaft_nodes:
            return ()
        by_left = {e.node_left: e.node_right for e in self.shaft_elements}
        rights = set(by_left.values())
        starts = [n for n in shaft_nodes if n not in rights]
        if len(by_left) != len(self.shaft_elements) or len(starts) != 1:
            return tuple(sorted(shaft_nodes))
        chain = [starts[0]]
        while chain[-1] in by_left and len(chain) <= len(shaft_nodes):
            chain.append(by_left[chain[-1]])
        return tuple(chain) if len(chain) == len(shaft_nodes) else tuple(sorted(shaft_nodes))

    @staticmethod
    def _named_bearings(bearings: Iterable[LinearBearing]) -> list[LinearBearing]:
        out: list[LinearBearing] = []
        seen: set[str] = set()
        for b in bearings:
            if not b.name:
                other = "ground" if b.other_node is None else str(b.other_node)
                b = LinearBearing(b.node, b.other_node, b.kxx_n_m, b.kyy_n_m, b.cxx_n_s_m,
                                  b.cyy_n_s_m, name=f"bearing_{b.node}_{other}")
            if b.name in seen:
                raise ValueError(f"duplicate bearing name {b.name!r}")
            seen.add(b.name)
            out.append(b)
        return out

    # -- DOF map -------------------------------------------------------------------------
    def dof_index(self, node: int, direction: str) -> int:
        """Global DOF index of ``direction`` (``"x"``, ``"y"``, ``"alpha"``, ``"beta"``) at ``node``.

        Raises
        ------
        KeyError
            If the node does not exist or has no such DOF (point-mass nodes only have x, y).
        """
        if node not in self._node_dirs:
            raise KeyError(f"node {node!r} is not in the rotor model; node labels are {list(self.node_labels)}")
        dirs = self._node_dirs[node]
        if direction not in dirs:
            kind = "shaft" if len(dirs) == 4 else "point-mass"
            raise KeyError(
                f"node {node} is a {kind} node with DOFs {list(dirs)}; no DOF {direction!r} "
                f"(valid directions: {list(_SHAFT_DIRECTIONS)})"
            )
        return self._node_start[node] + dirs.index(direction)

    def node_dofs(self, node: int) -> np.ndarray:
        """Global DOF indices of all DOFs of ``node`` (4 or 2 of them)."""
        if node not in self._node_dirs:
            raise KeyError(f"node {node!r} is not in the rotor model; node labels are {list(self.node_labels)}")
        s = self._node_start[node]
        return np.arange(s, s + len(self._node_dirs[node]))

    @property
    def dof_labels(self) -> list[str]:
        """Human-readable DOF labels ``"<direction>_<node>"`` in global order."""
        return [f"{d}_{n}" for n in self.node_labels for d in self._node_dirs[n]]

    def _xy_dofs(self, nodes: Iterable[int]) -> np.ndarray:
        return np.array([self.dof_index(n, d) for n in nodes for d in ("x", "y")])

    # -- assembly ------------------------------------------------------------------------
    def _assemble(self, parts: Iterable[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
        a = np.zeros((self.ndof, self.ndof))
        for idx, mat in parts:
            a[np.ix_(idx, idx)] += mat
        return _readonly(a)

    def _shaft_idx(self, e: ShaftElement) -> np.ndarray:
        return np.concatenate([self.node_dofs(e.node_left), self.node_dofs(e.node_right)])

    @cached_property
    def M(self) -> np.ndarray:
        """Mass matrix (ndof, ndof)."""
        parts = [(self._shaft_idx(e), e.mass_matrix()) for e in self.shaft_elements]
        parts += [(self.node_dofs(d.node), d.mass_matrix()) for d in self.disks]
        parts += [(self._xy_dofs([p.node]), p.mass_matrix()) for p in self.point_masses]
        return self._assemble(parts)

    @cached_property
    def K(self) -> np.ndarray:
        """Stiffness matrix (ndof, ndof): shaft bending plus bearings."""
        parts = [(self._shaft_idx(e), e.stiffness_matrix()) for e in self.shaft_elements]
        parts += [(self._xy_dofs(b.nodes), b.stiffness_matrix()) for b in self.bearings]
        return self._assemble(parts)

    @cached_property
    def C(self) -> np.ndarray:
        """Damping matrix (ndof, ndof): bearings and supports, plus the rotor's structural damping.

        Structural damping of the shaft: ``stiffness_damping_s`` x the shaft elements' stiffness (element by element,
        so the matrix keeps the shaft's band: damping ratio ``pi beta f`` of a mode at f), and/or modal damping of
        every elastic free-free rotor mode (:meth:`structural_damping_matrix`, dense over the shaft DOFs).
        """
        parts = [(self._xy_dofs(b.nodes), b.damping_matrix()) for b in self.bearings]
        if self.stiffness_damping_s > 0.0:
            parts += [(self._shaft_idx(e), self.stiffness_damping_s * e.stiffness_matrix()) for e in self.shaft_elements]
        c = np.array(self._assemble(parts))
        if self.modal_damping_ratio > 0.0:
            idx = np.concatenate([self.node_dofs(n) for n in self.shaft_node_labels])
            c[np.ix_(idx, idx)] += self.structural_damping_matrix()
        return _readonly(c)

    def free_free_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Modes of the rotor alone (shaft and disks, no bearings, supports or housings), free-free.

        Returns
        -------
        frequencies_hz : ndarray (n,)
            Ascending; the first four (rigid-body translation and tilt in both planes) are ~0.
        mode_shapes : ndarray (n, n)
            Mass-normalised columns over the shaft DOFs (``shaft_node_labels`` order).
        """
        idx = np.concatenate([self.node_dofs(n) for n in self.shaft_node_labels])
        parts_m = [(self._shaft_idx(e), e.mass_matrix()) for e in self.shaft_elements]
        parts_m += [(self.node_dofs(d.node), d.mass_matrix()) for d in self.disks]
        parts_k = [(self._shaft_idx(e), e.stiffness_matrix()) for e in self.shaft_elements]
        m = self._assemble(parts_m)[np.ix_(idx, idx)]
        k = self._assemble(parts_k)[np.ix_(idx, idx)]
        w2, phi = scipy.linalg.eigh(k, m)
        return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi), phi

    def structural_damping_matrix(self) -> np.ndarray:
        """Modal damping of the rotor over its shaft DOFs: every free-free elastic mode damped by
        ``modal_damping_ratio`` (the rigid-body modes not at all).

        ``C_r = M Phi diag(2 zeta omega_r) Phi^T M`` over the elastic free-free modes ``Phi`` (mass-normalised) of
        shaft and disks: in those coordinates ``Phi^T C_r Phi = diag(2 zeta omega_r)``. Dense over the shaft DOFs.
        The bearings, supports and housings keep their own dampers.
        """
        f, phi = self.free_free_modes()
        idx = np.concatenate([self.node_dofs(n) for n in self.shaft_node_labels])
        parts_m = [(self._shaft_idx(e), e.mass_matrix()) for e in self.shaft_elements]
        parts_m += [(self.node_dofs(d.node), d.mass_matrix()) for d in self.disks]
        m = self._assemble(parts_m)[np.ix_(idx, idx)]
        elastic = f > 1.0              # [Hz]: the four rigid-body modes are numerically ~0, the first bending > 100 Hz
        u = m @ phi[:, elastic]
        w = 2.0 * np.pi * f[elastic]
        return (u * (2.0 * self.modal_damping_ratio * w)) @ u.T

    @cached_property
    def G(self) -> np.ndarray:
        """Gyroscopic matrix (ndof, ndof) per unit shaft speed (multiply by Omega in rad/s)."""
        parts = [(self._shaft_idx(e), e.gyroscopic_matrix()) for e in self.shaft_elements]
        parts += [(self.node_dofs(d.node), d.gyroscopic_matrix()) for d in self.disks]
        return self._assemble(parts)

    # -- masses, positions ---------------------------------------------------------------
    @property
    def shaft_mass_kg(self) -> float:
        """Mass of the shaft elements (kg)."""
        return float(sum(e.mass_kg for e in self.shaft_elements))

    @property
    def rotor_mass_kg(self) -> float:
        """Shaft plus disks (kg)."""
        return self.shaft_mass_kg + float(sum(d.mass_kg for d in self.disks))

    @property
    def total_mass_kg(self) -> float:
        """Shaft plus disks plus point masses (kg)."""
        return self.rotor_mass_kg + float(sum(p.mass_kg for p in self.point_masses))

    @cached_property
    def shaft_node_positions_m(self) -> dict[int, float]:
        """Axial position of each shaft node (m), chaining element lengths from the chain's free end (z = 0).

        Raises
        ------
        ValueError
            If the shaft elements do not form a single chain ``n -> n'`` from the lowest label.
        """
        if not self.shaft_elements:
            return {}
        by_left = {e.node_left: e for e in self.shaft_elements}
        if len(by_left) != len(self.shaft_elements):
            raise ValueError("shaft elements do not form a single chain (repeated left node)")
        node = self.shaft_node_labels[0]
        pos = {node: 0.0}
        while node in by_left:
            e = by_left[node]
            pos[e.node_right] = pos[node] + e.length_m
            node = e.node_right
        if len(pos) != len(self.shaft_node_labels):
            raise ValueError("shaft elements do not form a single chain from the lowest node label")
        return pos

    # -- static analysis -----------------------------------------------------------------
    def gravity_force(self, g_m_s2: float = STANDARD_GRAVITY_M_S2) -> np.ndarray:
        """Weight vector (ndof,) in N (and N m on rotational DOFs).

        Consistent load ``M @ a`` with the rigid-body acceleration ``a = -g`` on every ``y`` DOF
        (2-DOF point-mass nodes included), so the ``y`` entries sum to ``-total_mass_kg * g``.
        """
        a = np.zeros(self.ndof)
        a[[self.dof_index(n, "y") for n in self.node_labels]] = -g_m_s2
        return self.M @ a

    def static_displacement(self, force: np.ndarray) -> np.ndarray:
        """Static solution ``q = K^-1 F`` (ndof,) in m and rad."""
        return scipy.linalg.solve(self.K, force, assume_a="sym")

    def static_bearing_loads_n(self, g_m_s2: float = STANDARD_GRAVITY_M_S2) -> dict[str, tuple[float, float]]:
        """Static bearing forces under gravity alone.

        Returns
        -------
        dict
            ``name -> (Fx, Fy)`` in N: the force each bearing element exerts **on its ``node``**
            (the rotor node of a rotor-housing bearing, the housing node of a support).  Under
            gravity ``Fy > 0`` (the bearing holds the rotor up); the load the rolling elements
            carry is ``-Fy`` downward, i.e. ``|Fy|``.
        """
        q = self.static_displacement(self.gravity_force(g_m_s2))
        loads: dict[str, tuple[float, float]] = {}
        for b in self.bearings:
            rel = q[self._xy_dofs([b.node])]
            if b.other_node is not None:
                rel = rel - q[self._xy_dofs([b.other_node])]
            f = -np.array([b.kxx_n_m, b.kyy_n_m]) * rel + 0.0  # + 0.0 turns -0.0 into 0.0
            loads[b.name] = (float(f[0]), float(f[1]))
        return loads

    # -- modal analysis ------------------------------------------------------------------
    def undamped_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped, non-rotating modes from ``K phi = w^2 M phi``.

        Returns
        -------
        frequencies_hz : ndarray (ndof,)
            Natural frequencies in ascending order (Hz).
        mode_shapes : ndarray (ndof, ndof)
            Mass-normalised mode shapes as columns (``Phi.T @ M @ Phi = I``).
        """
        w2, phi = scipy.linalg.eigh(self.K, self.M)
        return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi), phi

    def state_matrix(self, speed_rad_s: float) -> np.ndarray:
        """First-order state matrix (2 ndof, 2 ndof) for the state ``[q, q']``."""
        n = self.ndof
        minv_k = scipy.linalg.solve(self.M, self.K, assume_a="pos")
        minv_c = scipy.linalg.solve(self.M, self.C + speed_rad_s * self.G, assume_a="pos")
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -minv_k
        a[n:, n:] = -minv_c
        return a

    def damped_modes(self, speed_rad_s: float, return_vectors: bool = False):
        """Complex eigenvalues of the state matrix at shaft speed ``speed_rad_s`` (rad/s).

        Parameters
        ----------
        speed_rad_s : float
            Shaft speed Omega (rad/s).
        return_vectors : bool
            Also return the right eigenvectors of the state matrix (columns; the first ``ndof``
            rows are the displacement part).

        Returns
        -------
        eigenvalues : ndarray (2 ndof,) complex
            ``lambda = -zeta w_n +/- i w_d`` (1/s), sorted by ``|Im|`` then ``Im`` (conjugate pairs
            adjacent, negative imaginary part first).  Damped natural frequency in Hz is
            ``|Im| / (2 pi)``; damping ratio ``-Re / |lambda|``.  Overdamped modes give real
            eigenvalues (``Im = 0``), which therefore come first.
        eigenvectors : ndarray (2 ndof, 2 ndof) complex, only if ``return_vectors``.
        """
        lam, vec = scipy.linalg.eig(self.state_matrix(speed_rad_s))
        order = np.lexsort((lam.imag, np.round(np.abs(lam.imag), 9)))
        lam, vec = lam[order], vec[:, order]
        return (lam, vec) if return_vectors else lam


# --------------------------------------------------------------------------------------------
# Case file
# --------------------------------------------------------------------------------------------
def _require(d: Mapping, key: str, where: str):
    try:
        return d[key]
    except KeyError:
        raise KeyError(f"case file: missing key {key!r} in [{where}]") from None


@dataclass(frozen=True)
class Mesh:
    """How the case's shaft elements are subdivided for the FE model.

    Attributes
    ----------
    pieces : tuple of int
        Number of equal sub-elements of each case element.
    max_frequency_hz : float
        Frequency the mesh is made for [Hz] (0: no refinement).
    elements_per_wavelength : float
        Sub-elements per shortest wavelength at ``max_frequency_hz`` (see :func:`mesh_for`).
    """

    pieces: tuple[int, ...]
    max_frequency_hz: float = 0.0
    elements_per_wavelength: float = 0.0

    @property
    def n_elements(self) -> int:
        return int(sum(self.pieces))

    def doubled(self) -> "Mesh":
        """Every piece split in two again (the convergence check)."""
        return Mesh(tuple(2 * n for n in self.pieces), self.max_frequency_hz, 2 * self.elements_per_wavelength)


def shortest_wavelength_m(outer_diameter_m: float, inner_diameter_m: float, material: Material,
                          frequency_hz: float) -> float:
    """Shortest wavelength [m] of the waves a Timoshenko shaft section carries at ``frequency_hz``.

    The smaller of the Euler-Bernoulli bending wavelength ``2 pi (E I / rho A)^(1/4) / sqrt(omega)`` and the shear
    wavelength ``sqrt(kappa G / rho) / f`` (the slower of the two branches of Timoshenko's dispersion relation sets
    the element size at high frequency).
    """
    e = ShaftElement(0, 1, 1.0, outer_diameter_m, inner_diameter_m, material)
    w = 2.0 * np.pi * frequency_hz
    bending = 2.0 * np.pi * (material.youngs_modulus_pa * e.second_moment_m4
                             / (material.density_kg_m3 * e.area_m2)) ** 0.25 / np.sqrt(w)
    shear = np.sqrt(e.shear_coefficient * material.shear_modulus_pa / material.density_kg_m3) / frequency_hz
    return float(min(bending, shear))


def mesh_for(case_dict: Mapping, max_frequency_hz: float, elements_per_wavelength: float) -> Mesh:
    """Subdivision of every case element so that each sub-element is at most 1 / ``elements_per_wavelength`` of
    the shortest wavelength of its section at ``max_frequency_hz`` (:func:`shortest_wavelength_m`)."""
    r = case_dict["rotor"]
    mat = Material(float(r["youngs_modulus_pa"]), float(r["poisson_ratio"]), float(r["density_kg_m3"]))
    z = np.asarray(r["node_positions_m"], dtype=float)
    pieces = []
    for i, (do, di) in enumerate(zip(r["outer_diameters_m"], r["inner_diameters_m"])):
        h = shortest_wavelength_m(float(do), float(di), mat, max_frequency_hz) / elements_per_wavelength
        pieces.append(max(1, int(np.ceil((z[i + 1] - z[i]) / h - 1e-9))))
    return Mesh(tuple(pieces), float(max_frequency_hz), float(elements_per_wavelength))


def rotor_from_case(case_dict: Mapping, bearings: Mapping[str, tuple] | None = None, mesh: Mesh | None = None,
                    damping: dict | None = None, with_bearings: bool = True) -> Rotor:
    """Build the rotor model from a parsed case (``Case.raw``).

    Uses ``[rotor]`` (material, flags, ``node_positions_m``, ``outer_diameters_m``,
    ``inner_diameters_m``; element ``i`` joins shaft nodes ``i+1`` and ``i+2``), ``[[rotor.disks]]``,
    ``[[housings]]`` (a :class:`PointMass` named ``"housing_<name>"`` plus a grounded
    :class:`LinearBearing` named ``"support_<name>"``) and ``[bearings.<name>]`` (a
    :class:`LinearBearing` named ``<name>`` from ``rotor_node`` to ``housing_node``; vertical values
    go to ``yy``, horizontal to ``xx``).

    Parameters
    ----------
    case_dict : mapping
        Parsed case file.
    bearings : mapping, optional
        ``name -> (k_xx, k_yy, c_xx, c_yy)`` [N/m, N s/m] for the rotor-housing bearings (e.g. linearised from the
        bearing model); default: the case's ``table_*`` values.
    mesh : Mesh, optional
        Subdivision of the case elements (default: none, one FE element per case element). Nodes added inside
        an element get labels above every label of the case, so the case's node numbers keep their meaning.
    damping : dict, optional
        Structural damping as :class:`Rotor` keywords (default: the case's, :func:`structural_damping`).
    with_bearings : bool
        False: leave the rotor-housing bearings out (the time-domain model puts nonlinear bearings there).

    Returns
    -------
    Rotor
    """
    r = _require(case_dict, "rotor", "rotor")
    mat = Material(
        youngs_modulus_pa=float(_require(r, "youngs_modulus_pa", "rotor")),
        poisson_ratio=float(_require(r, "poisson_ratio", "rotor")),
        density_kg_m3=float(_require(r, "density_kg_m3", "rotor")),
    )
    z = np.asarray(_require(r, "node_positions_m", "rotor"), dtype=float)
    od = np.asarray(_require(r, "outer_diameters_m", "rotor"), dtype=float)
    idi = np.asarray(r.get("inner_diameters_m", np.zeros(len(od))), dtype=float)
    if not (len(od) == len(idi) == len(z) - 1):
        raise ValueError(
            f"[rotor]: need len(outer_diameters_m) == len(inner_diameters_m) == len(node_positions_m) - 1, "
            f"got {len(od)}, {len(idi)}, {len(z)}"
        )
    lengths = np.diff(z)
    if np.any(lengths <= 0):
        raise ValueError("[rotor]: node_positions_m must be strictly increasing")
    flags = {k: bool(r.get(k, True)) for k in ("shear_effects", "rotary_inertia", "gyroscopic")}
    pieces = mesh.pieces if mesh is not None else (1,) * len(od)
    if len(pieces) != len(od):
        raise ValueError(f"mesh: {len(pieces)} pieces for {len(od)} case elements")
    labels = [int(h["node"]) for h in case_dict.get("housings", [])] + list(range(1, len(z) + 1))
    next_label = max(labels) + 1
    shaft = []
    for i in range(len(od)):
        left = i + 1
        for j in range(pieces[i]):
            right = i + 2 if j == pieces[i] - 1 else next_label
            if right == next_label:
                next_label += 1
            shaft.append(ShaftElement(left, right, float(lengths[i]) / pieces[i], float(od[i]), float(idi[i]), mat,
                                      **flags))
            left = right
    disks = [
        Disk(
            node=int(d["node"]),
            mass_kg=float(d["mass_kg"]),
            polar_inertia_kg_m2=float(d["polar_inertia_kg_m2"]),
            diametral_inertia_kg_m2=float(d["diametral_inertia_kg_m2"]),
            name=str(d.get("name", "")),
        )
        for d in r.get("disks", [])
    ]
    point_masses: list[PointMass] = []
    elements: list[LinearBearing] = []
    for h in case_dict.get("housings", []):
        name = str(_require(h, "name", "housings"))
        node = int(_require(h, "node", "housings"))
        point_masses.append(PointMass(node, float(_require(h, "mass_kg", "housings")), name=f"housing_{name}"))
        elements.append(LinearBearing(
            node=node, other_node=None,
            kxx_n_m=float(h["support_stiffness_horizontal_n_m"]),
            kyy_n_m=float(h["support_stiffness_vertical_n_m"]),
            cxx_n_s_m=float(h["support_damping_horizontal_n_s_m"]),
            cyy_n_s_m=float(h["support_damping_vertical_n_s_m"]),
            name=f"support_{name}",
        ))
    if with_bearings:
        for name, b in case_dict.get("bearings", {}).items():
            if bearings is not None and name in bearings:
                kxx, kyy, cxx, cyy = (float(v) for v in bearings[name])
            else:
                kxx, kyy = float(b["table_stiffness_horizontal_n_m"]), float(b["table_stiffness_vertical_n_m"])
                cxx, cyy = float(b["table_damping_horizontal_n_s_m"]), float(b["table_damping_vertical_n_s_m"])
            elements.append(LinearBearing(
                node=int(_require(b, "rotor_node", f"bearings.{name}")),
                other_node=int(_require(b, "housing_node", f"bearings.{name}")),
                kxx_n_m=kxx, kyy_n_m=kyy, cxx_n_s_m=cxx, cyy_n_s_m=cyy, name=str(name),
            ))
    damping = structural_damping(case_dict) if damping is None else damping
    return Rotor(shaft, disks, point_masses, elements, **damping)


def structural_damping(case_dict: Mapping) -> dict:
    """Structural damping of the case's rotor as :class:`Rotor` keywords.

    ``[rotor] damping_model = "stiffness"``: ``beta = damping_ratio / (pi damping_reference_hz)`` times the shaft
    stiffness (damping ratio proportional to frequency, ``damping_ratio`` at ``damping_reference_hz``);
    ``"modal"``: ``damping_ratio`` on every elastic free-free rotor mode; ``"none"``.
    """
    r = case_dict["rotor"]
    model = r.get("damping_model", "none")
    zeta = float(r.get("damping_ratio", 0.0))
    if model == "stiffness":
        return {"stiffness_damping_s": zeta / (np.pi * float(r["damping_reference_hz"]))}
    if model == "modal":
        return {"modal_damping_ratio": zeta}
    return {}
