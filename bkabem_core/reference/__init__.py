"""The time-domain reference of the same machine, and the validation of BKA-BEM against it.

    Tdsm              -- the nonlinear rotor-bearing model integrated in time (module ``tdsm``)
    TdsmResult        -- a TDSM run after its start transient
    Integrator        -- the TDSM's step matrices and its Newton iteration on the bearing forces (``integrator``)
    RotatingForce     -- the coupling's running-speed force in the TDSM, turning at its node (module ``coupling``)
    harmonic_balance  -- the periodic steady state of the nonlinear model in the frequency domain (``periodic``)
    validate          -- TDSM against BKA-BEM at one speed, order by order (module ``validation``)
    validate_lines    -- the same for any line set (inner race, ball)
    ValidationResult, LineValidation, plot_validation
"""

from bkabem_core._face import lazy_face

__all__ = ["Tdsm", "TdsmResult", "Integrator", "RotatingForce", "harmonic_balance", "validate", "validate_lines", "ValidationResult", "LineValidation", "plot_validation"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Tdsm": "tdsm",
    "TdsmResult": "tdsm",
    "Integrator": "integrator",
    "RotatingForce": "coupling",
    "harmonic_balance": "periodic",
    "validate": "validation",
    "validate_lines": "validation",
    "ValidationResult": "validation",
    "LineValidation": "validation",
    "plot_validation": "validation",
})
