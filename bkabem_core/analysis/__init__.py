"""Signal analysis as a monitoring pipeline reads a bearing signal, and figures of the core results.

Condition (module ``condition``)
================================
    envelope_spectrum      -- amplitude spectrum of the band-passed signal's envelope
    iso_velocity_rms       -- RMS velocity [mm/s] in the ISO band from acceleration
    iso_zone               -- ISO 10816/20816 zone of an RMS velocity
    kurtosis, crest_factor

Fault lines and health (modules ``fault_lines``, ``health``)
===========================================================
    line_frequencies       -- the fault frequencies a message states
    marker_plan            -- markers of the fault lines in a spectrum
    envelope_finding       -- which fault line stands out in an envelope spectrum
    health_text            -- a bearing's health panel

Figures (module ``plots``)
==========================
    plot_excitation, plot_spectrum, plot_sweep
"""

from bkabem_core._face import lazy_face

__all__ = ["envelope_spectrum", "iso_velocity_rms", "iso_zone", "kurtosis", "crest_factor", "line_frequencies", "marker_plan", "envelope_finding", "health_text", "plot_excitation", "plot_spectrum", "plot_sweep"]

__getattr__, __dir__ = lazy_face(__name__, {
    "envelope_spectrum": "condition",
    "iso_velocity_rms": "condition",
    "iso_zone": "condition",
    "kurtosis": "condition",
    "crest_factor": "condition",
    "line_frequencies": "fault_lines",
    "marker_plan": "fault_lines",
    "envelope_finding": "health",
    "health_text": "health",
    "plot_excitation": "plots",
    "plot_spectrum": "plots",
    "plot_sweep": "plots",
})
