"""Waveform synthesis: speed-driven, phase-continuous sensor signals for the DE and NDE bearings.

    Synthesizer      -- signals of one model, chunk by chunk, under any speed (module ``synthesizer``)
    Settings         -- everything besides the model that decides the samples, checked once (``settings``)
    Plan             -- model and settings and what they fix: lines, kernels, sensors, floor (``plan``)
    WarmModel        -- a model's plan made ahead, for a switch that costs the stream nothing (``switch``)
    Chunk            -- one block of samples with its features (module ``features``)
    waveform_features -- mean, RMS, peak, crest factor, kurtosis of a block
    SpeedProfile     -- shaft speed as a piecewise-linear function of time (module ``profile``)
    parse_profile    -- ``constant:F``, ``ramp:F0:F1:T``, ``steps:...``, ``FILE.csv``
    SynthError       -- bad synthesis input: the argument and why
    Accelerometer    -- a mounted accelerometer's resonance (module ``sensors``)
    AntiAliasFilter  -- the acquisition's low-pass
    HighPassFilter   -- the acquisition's AC coupling
    InterferenceTones -- fixed-frequency interference of the acquisition's environment (its output stage)
    Quantiser        -- the converter's step (its output stage)
    SensorChain      -- the sensors between the machine and the samples
    Measurement      -- a case's [measurement] section: the rig's acquisition as defaults (module ``measurement``)
    BallTrack        -- a ball defect's wandering pit and spin slip (module ``balltrack``)
    StrikeSpread     -- a race pit's strikes of random strength (module ``strikes``)
    RollingSwing     -- a bearing's floor swinging with a load that turns with the shaft (module ``rolling``)
"""

from bkabem_core._face import lazy_face

__all__ = ["Synthesizer", "Settings", "Plan", "WarmModel", "Chunk", "waveform_features", "SpeedProfile",
           "parse_profile", "SynthError", "Accelerometer", "AntiAliasFilter", "HighPassFilter", "InterferenceTones",
           "Quantiser", "SensorChain", "Measurement", "BallTrack", "StrikeSpread", "RollingSwing"]

__getattr__, __dir__ = lazy_face(__name__, {
    "Synthesizer": "synthesizer",
    "Settings": "settings",
    "Plan": "plan",
    "WarmModel": "switch",
    "Chunk": "features",
    "waveform_features": "features",
    "SpeedProfile": "profile",
    "parse_profile": "profile",
    "SynthError": "profile",
    "Accelerometer": "sensors",
    "AntiAliasFilter": "sensors",
    "HighPassFilter": "sensors",
    "InterferenceTones": "sensors",
    "Quantiser": "sensors",
    "SensorChain": "sensors",
    "Measurement": "measurement",
    "BallTrack": "balltrack",
    "StrikeSpread": "strikes",
    "RollingSwing": "rolling",
})
