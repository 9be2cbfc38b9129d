"""The finite-element rotor-bearing-housing model: elements, assembly, the machine, its modal form, solvers.

Elements (module ``elements``; each owns its matrices)
======================================================
    Material, ShaftElement, Disk, PointMass, LinearBearing

Assembly (module ``rotor``)
===========================
    Rotor             -- the assembled lateral model (M, C, G, K, node map)
    rotor_from_case   -- the model of a case, meshed to converge up to its highest frequency
    Mesh, mesh_for    -- how the case's shaft is subdivided

Size limits (module ``budget``)
===============================
    check_mesh, check_line_modes -- the model's size and cost from the case, refused before it is allocated

The machine (module ``machine``)
================================
    Machine           -- rotor, bearings and housings of a case, each bearing at its own operating point
    BearingSite       -- one bearing of the machine at its operating point
    static_force_n    -- the static loads on the FE model: the weight and the radial loads applied at bearings

What a machine is (module ``summary``)
======================================
    machine_summary   -- static loads, FE bearings, fault frequencies, modes in the band, notes (``case check``)

Reduced model and solvers (modules ``modal``, ``linemodes``, ``solvers``)
========================================================================
    ModalBasis        -- Ritz reduction for the band the model serves
    OrderModalForm    -- exact pole-residue form line by line: any speed in microseconds
    SpeedCells        -- the modal form in cells of shaft speed
    LineModes         -- the reduced model diagonalised line by line
    ShaftSolver       -- exact batched block-tridiagonal solver
    solve_direct      -- dense batched LU
"""

from bkabem_core._face import lazy_face

__all__ = ["Material", "ShaftElement", "Disk", "PointMass", "LinearBearing", "Rotor", "rotor_from_case", "Mesh", "mesh_for", "check_mesh", "check_line_modes", "Machine", "BearingSite", "static_force_n", "machine_summary", "ModalBasis", "OrderModalForm", "SpeedCells", "LineModes", "ShaftSolver", "solve_direct"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Material": "elements",
    "ShaftElement": "elements",
    "Disk": "elements",
    "PointMass": "elements",
    "LinearBearing": "elements",
    "Rotor": "rotor",
    "rotor_from_case": "rotor",
    "Mesh": "rotor",
    "mesh_for": "rotor",
    "check_mesh": "budget",
    "check_line_modes": "budget",
    "Machine": "machine",
    "BearingSite": "machine",
    "static_force_n": "machine",
    "machine_summary": "summary",
    "ModalBasis": "modal",
    "OrderModalForm": "modal",
    "SpeedCells": "modal",
    "LineModes": "linemodes",
    "ShaftSolver": "solvers",
    "solve_direct": "solvers",
})
