"""A case's measurement chain: the ``[measurement]`` section as the synthesiser's defaults.

A monitoring developer who models a rig wants the signal the rig's own acquisition gives: its sensor on its mount,
its anti-alias filter, its AC coupling, the interference of its environment, its converter's step, its sensor noise
and its sample rate, and how evenly the rig's balls pass (the jitter a record's fault lines show). A case carries
them in an optional ``[measurement]`` section (every key optional, units in the suffixes); the synthesiser,
``bkabem synth``, the ROS node and a data set take them as defaults, and an explicit argument or option overrides
each one. A case without the section gives what it gave before (no sensor).

=================================  ==========================================================================
key                                meaning
=================================  ==========================================================================
``sample_rate_hz``                 the acquisition's rate [Hz] (default rate of ``bkabem synth`` and data sets)
``mounting``                       ``"stud"``, ``"adhesive"``, ``"magnet"``, ``"probe"``: the mount, and its typical
                                   resonance unless ``mounting_resonance_hz`` gives one
``mounting_resonance_hz``          mounted resonance of the accelerometer [Hz]
``mounting_damping_ratio``         its damping ratio [-] (default 0.03)
``anti_alias_hz``                  the anti-alias filter's -3 dB frequency [Hz]
``anti_alias_order``               its Butterworth order (default 6)
``anti_alias_phase``               ``"analog"`` (default) or ``"linear"`` (a digital decimation filter)
``high_pass_hz``                   the AC coupling's -3 dB frequency [Hz] (housing channels)
``high_pass_order``                its Butterworth order (default 1)
``tone_frequencies_hz``            interference tones of the environment [Hz] ...
``tone_amplitudes_m_s2``           ... and their 0-peak amplitudes as recorded [m/s^2]
``quantisation_step_m_s2``         the converter's step [m/s^2]
``noise_density_m_s2_per_sqrt_hz`` the accelerometer's white noise, one-sided [m/s^2/sqrt(Hz)]
``input_noise_m_s2_per_sqrt_hz``   the acquisition's broadband floor at the acceleration channels' input, flat,
                                   one-sided [m/s^2/sqrt(Hz)]: after the mount, before the AC coupling and the
                                   anti-alias filter (:mod:`bkabem_core.synth.floor`)
``slip``                           the rig's random jitter of the ball passes: standard deviation of the
                                   ball-pass interval over its mean [-] (the synthesiser's ``slip``)
=================================  ==========================================================================

The elements are the classes of :mod:`bkabem_core.synth.sensors`; the checks of the values are theirs and the
case's (:mod:`bkabem_core.model.case`).
"""

from __future__ import annotations

from dataclasses import dataclass

from bkabem_core.synth.sensors import (
    MOUNTING_RESONANCE_HZ,
    Accelerometer,
    AntiAliasFilter,
    HighPassFilter,
    InterferenceTones,
    Quantiser,
)

#: What an argument of the synthesiser takes to mean "the case's [measurement] value" (the default).
FROM_CASE = "case"
SECTION = "measurement"
#: Sample rate of a case whose ``[measurement]`` names none [Hz]
DEFAULT_SAMPLE_RATE_HZ = 25600.0


def sample_rate_of(case) -> float:
    """The case's acquisition rate [Hz]: ``measurement.sample_rate_hz``, else :data:`DEFAULT_SAMPLE_RATE_HZ`."""
    return float((case.raw.get(SECTION) or {}).get("sample_rate_hz", DEFAULT_SAMPLE_RATE_HZ))


@dataclass(frozen=True)
class Measurement:
    """The measurement chain of a case (module docstring); every element None where the case gives none.

    Attributes
    ----------
    sample_rate_hz : float or None
    accelerometer : Accelerometer or None
    anti_alias : AntiAliasFilter or None
    high_pass : HighPassFilter or None
    tones : InterferenceTones or None
    quantisation : Quantiser or None
    noise_density : dict or None
        ``{"acceleration": m/s^2/sqrt(Hz)}``.
    slip : float or None
        Random jitter of the ball passes [-] (std of the interval / its mean).
    input_noise : float or None
        The acquisition's broadband floor at the acceleration channels' input [m/s^2/sqrt(Hz)].
    """

    sample_rate_hz: float | None = None
    accelerometer: Accelerometer | None = None
    anti_alias: AntiAliasFilter | None = None
    high_pass: HighPassFilter | None = None
    tones: InterferenceTones | None = None
    quantisation: Quantiser | None = None
    noise_density: dict | None = None
    slip: float | None = None
    input_noise: float | None = None

    @classmethod
    def from_section(cls, m: dict | None) -> "Measurement":
        """The chain of a validated ``[measurement]`` table (None or empty: nothing)."""
        if not m:
            return cls()
        acc = None
        if "mounting" in m or "mounting_resonance_hz" in m:
            mounting = m.get("mounting", "custom")
            fn = m.get("mounting_resonance_hz", MOUNTING_RESONANCE_HZ.get(mounting))
            acc = Accelerometer(float(fn), float(m.get("mounting_damping_ratio", 0.03)), mounting=mounting)
        aa = None
        if "anti_alias_hz" in m:
            aa = AntiAliasFilter(float(m["anti_alias_hz"]), int(m.get("anti_alias_order", 6)),
                                 m.get("anti_alias_phase", "analog"))
        hp = HighPassFilter(float(m["high_pass_hz"]), int(m.get("high_pass_order", 1))) if "high_pass_hz" in m \
            else None
        tones = None
        if m.get("tone_frequencies_hz"):
            tones = InterferenceTones(tuple(m["tone_frequencies_hz"]), tuple(m["tone_amplitudes_m_s2"]))
        q = Quantiser(float(m["quantisation_step_m_s2"])) if "quantisation_step_m_s2" in m else None
        noise = None
        if "noise_density_m_s2_per_sqrt_hz" in m:
            noise = {"acceleration": float(m["noise_density_m_s2_per_sqrt_hz"])}
        rate = float(m["sample_rate_hz"]) if "sample_rate_hz" in m else None
        slip = float(m["slip"]) if "slip" in m else None
        floor = float(m["input_noise_m_s2_per_sqrt_hz"]) if "input_noise_m_s2_per_sqrt_hz" in m else None
        return cls(rate, acc, aa, hp, tones, q, noise, slip, floor)

    @classmethod
    def of_case(cls, case) -> "Measurement":
        """The chain of a :class:`~bkabem_core.model.case.Case` (its ``[measurement]`` section, if any)."""
        return cls.from_section(case.raw.get(SECTION))

    def __bool__(self) -> bool:
        return any(v is not None for v in self.__dict__.values())

    def to_dict(self) -> dict:
        """Its elements' parameters (None where absent), JSON-ready."""
        out = {"sample_rate_hz": self.sample_rate_hz, "noise_density": self.noise_density, "slip": self.slip,
               "input_noise": self.input_noise}
        for k in ("accelerometer", "anti_alias", "high_pass", "tones", "quantisation"):
            v = getattr(self, k)
            out[k] = None if v is None else v.to_dict()
        return out
