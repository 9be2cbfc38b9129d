"""The case of a machine: its TOML file validated key by key, the plausibility bounds, the bearing catalogue,
the shared vocabulary.

Case files
==========
    Case             -- a validated machine case (``Case.load(name_or_path)``)
    CaseError        -- a case file is invalid: the dotted key at fault and why
    InputFileError   -- base of the errors of every input file (case, scenario, data-set spec)
    embedded_cases   -- names of the cases shipped with bkabem
    scale_radial_load -- a case's radial load scaled: gravity and the loads applied at bearings (load factors)
    DEFAULT_CASE     -- the embedded default case, ``electric_motor_6010``
    SCHEMA_VERSION   -- the case schema this version writes

The compact machine form (modules ``compact``, ``starting``)
============================================================
    machine_case     -- a case written as [machine] (shaft steps, disks, bearing positions, housings) loaded
    starting_case    -- the documented starting case of ``bkabem case new`` (two designations, a rotor mass)

The bearing at each position (module ``positions``)
===================================================
    ResolvedBearing  -- a position's bearing: every value found (catalogue, overrides, clearance) and its provenance

The machine baseline's keys (module ``baseline_keys``)
=====================================================
    baseline_problem -- the first rule a ``[baseline]`` section breaks (e.g. odd electrical harmonics), or None

The acquisition's keys (module ``measurement_keys``)
====================================================
    measurement_problem -- the first rule a ``[measurement]`` section breaks (e.g. a tone above Nyquist), or None

A rig's load table (module ``load_table``)
==========================================
    speed_at_load_hz -- the shaft speed [Hz] a load [hp] gives by a case's ``[operating]`` load table

Plausibility (module ``plausibility``)
======================================
    problem          -- the first implausible value of a case, or None
    BOUNDS           -- the bounds, each with its reason

Bearing catalogue (module ``catalogue``)
=================================
    CatalogueBearing -- a deep-groove ball bearing by designation: geometry, ratings, sources (SI)
    CatalogueError   -- a designation or clearance class the catalogue does not have
    lookup           -- the catalogue bearing of a designation (``lookup("6205-2RS1/C3")``)
    designations     -- the catalogue's keys (optionally of one geometry status)
    radial_clearance_m -- ISO 5753-1 radial internal clearance (min, max) [m] of a bore and class
=======
Input files (module ``files``)
==============================
    not_a_file       -- why a path cannot be read as an input file (missing, a directory, a FIFO), or None
    InputFileError   -- an invalid input file: the key at fault and why (each kind of file has its subclass)

Vocabulary (module ``vocabulary``)
==================================
    BEARINGS         -- bearing positions: ``de``, ``nde``
    DIRECTIONS       -- ``vertical``, ``horizontal``
    LOCATIONS        -- rotor and housing at each bearing
"""

from bkabem_core._face import lazy_face

__all__ = ["Case", "CaseError", "InputFileError", "embedded_cases", "scale_radial_load", "DEFAULT_CASE",
           "SCHEMA_VERSION", "machine_case", "starting_case", "ResolvedBearing", "baseline_problem", "measurement_problem", "speed_at_load_hz",
           "problem", "BOUNDS", "CatalogueBearing", "CatalogueError", "lookup", "designations", "radial_clearance_m",
           "not_a_file", "BEARINGS", "DIRECTIONS", "LOCATIONS"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Case": "case",
    "CaseError": "case",
    "InputFileError": "files",
    "embedded_cases": "case",
    "scale_radial_load": "case",
    "baseline_problem": "baseline_keys",
    "measurement_problem": "measurement_keys",
    "speed_at_load_hz": "load_table",
    "DEFAULT_CASE": "case",
    "SCHEMA_VERSION": "case",
    "machine_case": "compact",
    "starting_case": "starting",
    "ResolvedBearing": "positions",
    "problem": "plausibility",
    "BOUNDS": "plausibility",
    "CatalogueBearing": "catalogue",
    "CatalogueError": "catalogue",
    "lookup": "catalogue",
    "designations": "catalogue",
    "radial_clearance_m": "catalogue",
    "not_a_file": "files",
    "BEARINGS": "vocabulary",
    "DIRECTIONS": "vocabulary",
    "LOCATIONS": "vocabulary",
})
