"""Waveform synthesis: speed-driven, phase-continuous sensor signals for the DE and NDE bearings.

    Synthesizer      -- signals of one model, chunk by chunk, under any speed (module ``synthesizer``)
    Chunk            -- one block of samples with its features (module ``features``)
    waveform_features -- mean, RMS, peak, crest factor, kurtosis of a block
    SpeedProfile     -- shaft speed as a piecewise-linear function of time (module ``profile``)
    parse_profile    -- ``constant:F``, ``ramp:F0:F1:T``, ``steps:...``, ``FILE.csv``
    SynthError       -- bad synthesis input: the argument and why
    Accelerometer    -- a mounted accelerometer's resonance (module ``sensors``)
    AntiAliasFilter  -- the acquisition's low-pass
"""

from bkabem_core._face import lazy_face

__all__ = ["Synthesizer", "Chunk", "waveform_features", "SpeedProfile", "parse_profile", "SynthError", "Accelerometer", "AntiAliasFilter"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Synthesizer": "synthesizer",
    "Chunk": "features",
    "waveform_features": "features",
    "SpeedProfile": "profile",
    "parse_profile": "profile",
    "SynthError": "profile",
    "Accelerometer": "sensors",
    "AntiAliasFilter": "sensors",
})
