"""Finite elements of the lateral rotor model: material, Timoshenko shaft element, disk, point mass, linear bearing.

Each element owns its matrices (in its own local DOF order); :class:`bkabem_core.fe.rotor.Rotor` only places them.

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
* Nodes are identified by integer labels; the order of the global DOF vector is the assembly's
  (:class:`bkabem_core.fe.rotor.Rotor`), each node contributing its 4 or 2 DOFs in the order above.
* Equation of motion: ``M q'' + (C + Omega G) q' + K q = F`` with ``Omega`` the shaft speed in rad/s,
  positive for a spin about ``+z`` (from ``+x`` towards ``+y``).  ``G`` is skew-symmetric with
  ``G[alpha, beta] = +Ip`` for a disk; with this sign the forward-whirl (``x -> y``) frequencies
  rise with speed.

Units are SI throughout (m, kg, s, N, Pa, rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Material", "ShaftElement", "Disk", "PointMass", "LinearBearing", "SHAFT_DIRECTIONS",
           "POINT_DIRECTIONS"]

SHAFT_DIRECTIONS = ("x", "y", "alpha", "beta")
POINT_DIRECTIONS = ("x", "y")


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
