"""BKA-BEM solved: each bearing's excitation as a base excitation of the FE model, at any shaft speed.

    BkaBem          -- the model of a case: ``spectrum(speed_hz)``, ``sweep(speeds)``, ``response`` (module ``harmonic``)
    Spectrum        -- the response at one speed: lines x locations x directions
    Sweep           -- responses over many speeds
    HillCorrection  -- the improved method: the bearings' time-varying stiffness (module ``improved``)
"""

from bkabem_core._face import lazy_face

__all__ = ["BkaBem", "Spectrum", "Sweep", "HillCorrection"]

__getattr__, __dir__ = lazy_face(__name__, {
    "BkaBem": "harmonic",
    "Spectrum": "harmonic",
    "Sweep": "harmonic",
    "HillCorrection": "improved",
})
