"""The bearing excitation of BKA-BEM and the machine baseline, as sets of lines.

Lines (module ``lines``)
========================
    LineSet               -- lines with integer coefficients on the base phases and complex amplitudes
    MachinePhases         -- the base phases of a machine: shaft, each bearing's cage and spin, line
    union                 -- one set holding every line of several sets
    lines_from_grid       -- lines of a function sampled on a 2-torus (2-D FFT)
    line_label            -- what a line is: "BPFO", "BPFI - 1 f_r", "2 BSF + FTF", "1x" (module ``line_names``)

Quasi-static excitation (module ``quasi_static``)
=================================================
    Excitation            -- the rotor-housing relative displacement one bearing imposes, as lines
    quasi_static_excitation -- a bearing's excitation from its quasi-static equilibrium over a ball pitch
    torus_path            -- the quasi-static path of a moving defect on the torus of its phases
    FourDofModel          -- the paper's 4-DOF rotor + housing model of one bearing
    compute_excitation    -- the 4-DOF excitation (integrated, then BPFO orders)
    rates_per_hz          -- rates of the base phases per shaft Hz

The quasi-static path (module ``path``)
=======================================
    quasi_static_path_m   -- a bearing's static equilibrium at many ball-set (and shaft) angles at once

A load that turns with the shaft (module ``turning``)
=====================================================
    turning_lines         -- a bearing's lines under a load that turns with the shaft (sidebands at f_r)

Machine baseline (module ``baseline``)
======================================
    baseline_forces       -- unbalance, misalignment, coupling, looseness, electrical lines as force lines on the FE
                             rotor
"""

from bkabem_core._face import lazy_face

__all__ = ["LineSet", "MachinePhases", "union", "line_label", "lines_from_grid", "Excitation", "quasi_static_excitation", "torus_path", "FourDofModel", "compute_excitation", "rates_per_hz", "quasi_static_path_m", "turning_lines", "baseline_forces"]

__getattr__, __dir__ = lazy_face(__name__, {
    "LineSet": "lines",
    "MachinePhases": "lines",
    "union": "lines",
    "lines_from_grid": "lines",
    "line_label": "line_names",
    "Excitation": "quasi_static",
    "quasi_static_excitation": "quasi_static",
    "torus_path": "quasi_static",
    "FourDofModel": "quasi_static",
    "compute_excitation": "quasi_static",
    "rates_per_hz": "quasi_static",
    "quasi_static_path_m": "path",
    "turning_lines": "turning",
    "baseline_forces": "baseline",
})
