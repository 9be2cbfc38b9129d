"""Lateral rotor-bearing-housing model: the assembly of the elements of :mod:`bkabem_core.fe.elements`, the FE mesh
that converges the model to the case's highest frequency, and the model built from a case.

Conventions (DOF order, axes, signs) are those of :mod:`bkabem_core.fe.elements`: Friswell et al. (2010),
*Dynamics of Rotating Machines*, ch. 5, as in ROSS. The assembly only places the element matrices; it computes
none itself. Equation of motion: ``M q'' + (C + Omega G) q' + K q = F`` (SI: m, kg, s, N, rad).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Iterable, Mapping, Sequence

import numpy as np
import scipy.linalg

from bkabem_core.fe.elements import (
    POINT_DIRECTIONS,
    SHAFT_DIRECTIONS,
    Disk,
    LinearBearing,
    Material,
    PointMass,
    ShaftElement,
)

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
    Global DOF order: the shaft nodes along the chain of elements from its free end (ascending labels if the
    elements branch), ``[x, y, alpha, beta]`` each, then the point-mass-only nodes in label order, ``[x, y]`` each.
    :meth:`dof_index` maps a (node, direction) to its index.
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
            dirs = SHAFT_DIRECTIONS if n in shaft_nodes else POINT_DIRECTIONS
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
                f"(valid directions: {list(SHAFT_DIRECTIONS)})"
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
        return self.bearing_reactions_n(self.gravity_force(g_m_s2))

    def bearing_reactions_n(self, force_n: np.ndarray) -> dict[str, tuple[float, float]]:
        """Static forces of the bearing elements under a static force pattern ``force_n`` (ndof,) [N].

        Returns
        -------
        dict
            ``name -> (Fx, Fy)`` in N: the force each bearing element exerts on its ``node`` (as
            :meth:`static_bearing_loads_n`); the load its rolling elements carry is the negative.
        """
        q = self.static_displacement(force_n)
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
