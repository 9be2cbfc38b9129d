"""The keys of a case's ``[measurement]`` section (the rig's acquisition chain as the synthesiser's defaults) and
their rules.

What each key does to the signal is in :mod:`bkabem_core.synth.measurement` and docs/synthesis.md; this module says
which keys exist (every one optional: a case without the section is measured by an ideal sensor) and the rules that
tie keys together (:func:`measurement_problem`). Units: SI, each key with its unit as a suffix.
"""

from __future__ import annotations

__all__ = ["MEASUREMENT_KEYS", "measurement_problem"]

_POS = ("gt", 0.0)
_NONNEG = ("ge", 0.0)

#: key -> (kind, check) as in the case schema.
MEASUREMENT_KEYS: dict[str, tuple] = {
    "sample_rate_hz": ("float", ("range", 100.0, 1.0e6)),
    "mounting": ("str", ("in", {"stud", "adhesive", "magnet", "probe", "custom"})),
    "mounting_resonance_hz": ("float", _POS),
    "mounting_damping_ratio": ("float", ("range_open", 0.0, 1.0)),
    "anti_alias_hz": ("float", _POS),
    "anti_alias_order": ("int", ("range", 1, 128)),
    "anti_alias_phase": ("str", ("in", {"analog", "linear"})),
    "high_pass_hz": ("float", _POS),
    "high_pass_order": ("int", ("range", 1, 8)),
    "tone_frequencies_hz": ("float[]", _POS),
    "tone_amplitudes_m_s2": ("float[]", _NONNEG),
    "quantisation_step_m_s2": ("float", _POS),
    "noise_density_m_s2_per_sqrt_hz": ("float", _NONNEG),
    "input_noise_m_s2_per_sqrt_hz": ("float", _NONNEG),
    "slip": ("float", ("range", 0.0, 0.1)),
}


def measurement_problem(m: dict) -> tuple[str, str] | None:
    """The first rule the keys of ``[measurement]`` break together, as (key, why), or None (each key alone is checked
    by the schema)."""
    freqs, amps = m.get("tone_frequencies_hz"), m.get("tone_amplitudes_m_s2")
    if (freqs is None) != (amps is None):
        missing = "tone_amplitudes_m_s2" if amps is None else "tone_frequencies_hz"
        return missing, "missing (tones need both frequencies and amplitudes)"
    if freqs is not None and len(freqs) != len(amps):
        return "tone_amplitudes_m_s2", f"needs one amplitude per tone frequency: {len(freqs)} (got {len(amps)})"
    for key in ("mounting_damping_ratio",):
        if key in m and "mounting" not in m and "mounting_resonance_hz" not in m:
            return key, "needs a mounting (mounting or mounting_resonance_hz)"
    if m.get("mounting") == "custom" and "mounting_resonance_hz" not in m:
        return "mounting_resonance_hz", "missing (a custom mounting needs its resonance)"
    for key in ("anti_alias_order", "anti_alias_phase"):
        if key in m and "anti_alias_hz" not in m:
            return key, "needs measurement.anti_alias_hz"
    if m.get("anti_alias_phase", "analog") == "analog" and m.get("anti_alias_order", 6) > 16:
        return "anti_alias_order", (f"must be <= 16 for an analog filter (got {m['anti_alias_order']}; a steeper "
                                    "digital filter: anti_alias_phase = \"linear\")")
    if "high_pass_order" in m and "high_pass_hz" not in m:
        return "high_pass_order", "needs measurement.high_pass_hz"
    if "high_pass_hz" in m and "anti_alias_hz" in m and m["high_pass_hz"] >= m["anti_alias_hz"]:
        return "high_pass_hz", (f"must be below measurement.anti_alias_hz ({m['high_pass_hz']:g} "
                                f">= {m['anti_alias_hz']:g} Hz)")
    rate = m.get("sample_rate_hz")
    if rate is not None:
        for key, values in (("tone_frequencies_hz", freqs or []), ("anti_alias_hz", [m.get("anti_alias_hz", 0.0)])):
            top = max(values, default=0.0)
            if top >= rate / 2:
                return key, (f"{top:g} Hz is at or above the Nyquist frequency of measurement.sample_rate_hz "
                             f"({rate / 2:g} Hz)")
    return None
