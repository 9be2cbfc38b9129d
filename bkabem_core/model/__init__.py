"""The case of a machine: its TOML file validated key by key, the plausibility bounds, the shared vocabulary.

Case files
==========
    Case             -- a validated machine case (``Case.load(name_or_path)``)
    CaseError        -- a case file is invalid: the dotted key at fault and why
    InputFileError   -- base of the errors of every input file (case, scenario, data-set spec)
    embedded_cases   -- names of the cases shipped with bkabem
    DEFAULT_CASE     -- the embedded default case, ``electric_motor_6010``
    SCHEMA_VERSION   -- the case schema this version writes

Plausibility (module ``plausibility``)
======================================
    problem          -- the first implausible value of a case, or None
    BOUNDS           -- the bounds, each with its reason

Input files (module ``files``)
==============================
    not_a_file       -- why a path cannot be read as an input file (missing, a directory, a FIFO), or None

Vocabulary (module ``vocabulary``)
==================================
    BEARINGS         -- bearing positions: ``de``, ``nde``
    DIRECTIONS       -- ``vertical``, ``horizontal``
    LOCATIONS        -- rotor and housing at each bearing
"""

from bkabem_core._face import lazy_face

__all__ = ["Case", "CaseError", "InputFileError", "embedded_cases", "DEFAULT_CASE", "SCHEMA_VERSION", "problem", "BOUNDS", "not_a_file", "BEARINGS", "DIRECTIONS", "LOCATIONS"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Case": "case",
    "CaseError": "case",
    "InputFileError": "case",
    "embedded_cases": "case",
    "DEFAULT_CASE": "case",
    "SCHEMA_VERSION": "case",
    "problem": "plausibility",
    "BOUNDS": "plausibility",
    "not_a_file": "files",
    "BEARINGS": "vocabulary",
    "DIRECTIONS": "vocabulary",
    "LOCATIONS": "vocabulary",
})
