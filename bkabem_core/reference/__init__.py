"""The time-domain reference of the same machine, and the validation of BKA-BEM against it.

    Tdsm              -- the nonlinear rotor-bearing model integrated in time (module ``tdsm``)
    TdsmResult        -- a TDSM run after its start transient
    Integrator        -- the TDSM's step matrices and its Newton iteration on the bearing forces (``integrator``)
    harmonic_balance  -- the periodic steady state of the nonlinear model in the frequency domain (``periodic``)
    validate          -- TDSM against BKA-BEM at one speed, order by order (module ``validation``)
    validate_lines    -- the same for any line set (inner race, ball)
    ValidationResult, LineValidation, plot_validation
"""

from bkabem_core._face import lazy_face

__all__ = ["Tdsm", "TdsmResult", "Integrator", "harmonic_balance", "validate", "validate_lines", "ValidationResult", "LineValidation", "plot_validation"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Tdsm": "tdsm",
    "TdsmResult": "tdsm",
    "Integrator": "integrator",
    "harmonic_balance": "periodic",
    "validate": "validation",
    "validate_lines": "validation",
    "ValidationResult": "validation",
    "LineValidation": "validation",
    "plot_validation": "validation",
})
