"""The deep-groove ball bearing: geometry, kinematics, Hertz contact, clearance, defects and ball forces.

Bearing model (module ``deep_groove``)
======================================
    Bearing              -- a deep-groove ball bearing, healthy or with defects: ball forces, equilibrium
    BearingGeometry      -- geometry and material (SI)
    FaultFrequencies     -- FTF, BPFO, BPFI, BSF [Hz or per shaft Hz]
    HertzContact         -- Hertz point-contact constants (Brewe-Hamrock)

Statics (module ``statics``: a base class of ``Bearing``)
=========================================================
    BearingState         -- the bearing at its static equilibrium
    BearingLinearisation -- lateral stiffness and damping at an equilibrium

Defects (package ``defects``: module ``base``; the kinds, one module each, in its registry)
===========================================================================================
    Dent                 -- a localised defect (dent, pit, spall): kind, size, angle, edge profile
    DefectSet            -- the defects of one bearing: the drop every ball feels
    DefectProfile        -- one defect with its bearing's geometry

Elastic half-space contact (module ``halfspace``)
=================================================
    HalfSpaceGrid        -- frictionless contact of two elastic bodies on a grid (a round pit's bridging)

Contact forces of the time-domain models (module ``contacts``)
=============================================================
    HertzPair            -- nonlinear ball forces of both bearings, tabulated over a ball pass
    LinearPair           -- the linear counterpart
"""

from bkabem_core._face import lazy_face

__all__ = ["Bearing", "BearingGeometry", "FaultFrequencies", "HertzContact", "BearingState", "BearingLinearisation", "Dent", "DefectSet", "DefectProfile", "HalfSpaceGrid", "HertzPair", "LinearPair"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Bearing": "deep_groove",
    "BearingGeometry": "deep_groove",
    "FaultFrequencies": "deep_groove",
    "HertzContact": "deep_groove",
    "BearingState": "statics",
    "BearingLinearisation": "statics",
    "Dent": "defects.base",
    "DefectSet": "defects.base",
    "DefectProfile": "defects.base",
    "HalfSpaceGrid": "halfspace",
    "HertzPair": "contacts",
    "LinearPair": "contacts",
})
