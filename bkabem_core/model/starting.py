"""A documented starting case in the compact form (:mod:`bkabem_core.model.compact`) from a few numbers.

:func:`starting_case` writes the TOML of an electric motor on two catalogue bearings: the bearings (``bkabem case
new --de 6205 --nde 6203``), the rotor's mass and the operating range; every other number follows from them by the
rules below, each written into the file as a comment, so that the file is a place to start editing, not a machine
anyone measured. ``bkabem case check FILE`` says what the result is (static loads, stiffnesses, fault frequencies,
the modes in the band, the plausibility bounds).

The shaft (solid steel, from the DE end): a DE shaft end (coupling seat) of twice the DE bore, ``0.9 x`` the bore
in diameter (smaller than the bore, so the bearing is fitted from that end); the DE bearing seat (the bearing's
width, at its bore); the body, ``1.3 x`` the larger bore (the shoulders and the core seat); the NDE bearing seat;
an NDE shaft end of ``1.2 x`` the NDE bore. The body runs one body diameter from each bearing seat to the rotor
core. The rotor core is a stack ``1.2 x`` as long as its diameter (a two- or four-pole motor's proportions) of
laminations with their winding or cage, :data:`CORE_DENSITY_KG_M3`; its diameter is what makes the shaft and the
core weigh ``rotor_mass_kg``. Its inertias are a uniform annulus's. The housings and their supports are the
paper's motor's (3.17 kg, 1e6 N/m, 1e4 N s/m for its 82 kg rotor), scaled with the rotor's mass, so that the
machine bounces on its supports at the same frequency (~25 Hz); each bearing gets the paper's damper (550 N s/m:
no catalogue gives one) and a spring preload of :data:`PRELOAD_N_PER_MM` per mm of its bore.

Units: SI.
"""

from __future__ import annotations

import math

from bkabem_core.model.catalogue import CatalogueError, lookup

__all__ = ["CORE_DENSITY_KG_M3", "PRELOAD_N_PER_MM", "StartingError", "StartingMachine", "starting_machine",
           "starting_case"]

#: Effective density of a rotor core (laminations with their winding or cage) [kg/m^3]; the embedded motor's is
#: 7338 (docs/surrogate_motor.md).
CORE_DENSITY_KG_M3 = 7400.0
#: Spring preload of a deep-groove ball bearing in an electric motor per mm of bore [N/mm]: SKF's guidance is
#: F = k d with k = 5 .. 10 N/mm (SKF rolling bearings catalogue, "Preloading with springs"); the middle of it.
PRELOAD_N_PER_MM = 7.5
_STEEL_KG_M3 = 7850.0
_PAPER_ROTOR_KG, _PAPER_HOUSING_KG, _PAPER_SUPPORT_N_M, _PAPER_SUPPORT_N_S_M = 82.0, 3.17, 1.0e6, 1.0e4
_PAPER_DAMPER_N_S_M = 550.0
_CORE_ASPECT = 1.2


class StartingError(ValueError):
    """The rules cannot make a machine of these numbers: ``what`` is the input at fault (``"de"``, ``"nde"``,
    ``"rotor_mass_kg"``), the message says why."""

    def __init__(self, what: str, reason: str):
        self.what = what
        super().__init__(reason)


class StartingMachine:
    """The numbers of a starting machine (module docstring); lengths [m], masses [kg], inertias [kg m^2].

    Attributes
    ----------
    steps : list of (length, outer diameter)
    bearing_positions : dict position -> z [m]
    core_position_m, core_length_m, core_diameter_m, core_mass_kg : float
    core_polar_inertia_kg_m2, core_diametral_inertia_kg_m2 : float
    housing_mass_kg, support_stiffness_n_m, support_damping_n_s_m : float
    preload_n : dict position -> axial preload [N]
    """

    def __init__(self, de: str, nde: str, rotor_mass_kg: float):
        rows = {}
        for name, designation in (("de", de), ("nde", nde)):
            try:
                row = lookup(designation)
            except CatalogueError as exc:
                raise StartingError(name, str(exc)) from None
            for what in ("bore_diameter_m", "width_m"):
                if not math.isfinite(getattr(row, what)):
                    raise StartingError(name, f"the catalogue has no {what.split('_')[0]} for {row.catalogue_key} "
                                              f"(a starting case needs a bearing of known dimensions)")
            rows[name] = row
        bore = {n: r.bore_diameter_m for n, r in rows.items()}
        width = {n: r.width_m for n, r in rows.items()}
        body = _mm(1.3 * max(bore.values()))
        ends = [(_mm(2.0 * bore["de"]), _mm(0.9 * bore["de"])), (_mm(1.2 * bore["nde"]), _mm(0.9 * bore["nde"]))]
        fixed = sum(_steel(length, d) for length, d in ends) + sum(_steel(width[n], bore[n]) for n in bore)

        def total(diameter: float) -> float:
            core = _CORE_ASPECT * diameter
            return fixed + _steel(2.0 * body + core, body) + \
                CORE_DENSITY_KG_M3 * math.pi / 4.0 * (diameter ** 2 - body ** 2) * core

        lightest = total(body)
        if not rotor_mass_kg > lightest:
            raise StartingError("rotor_mass_kg", f"{rotor_mass_kg:g} kg: the shaft these bearings need weighs "
                             f"{lightest:.3g} kg already (a rotor core needs more)")
        lo, hi = body, 10.0
        if total(hi) < rotor_mass_kg:
            raise StartingError("rotor_mass_kg", f"{rotor_mass_kg:g} kg is more than a rotor core of 10 m diameter on this "
                             f"shaft weighs")
        for _ in range(100):                                    # bisection: total() rises with the diameter
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if total(mid) < rotor_mass_kg else (lo, mid)
        d_core = _mm(0.5 * (lo + hi))
        l_core = _mm(_CORE_ASPECT * d_core)
        self.steps = [ends[0], (width["de"], bore["de"]), (_mm(2.0 * body + l_core), body),
                      (width["nde"], bore["nde"]), ends[1]]
        z_de = ends[0][0] + 0.5 * width["de"]
        z_body = ends[0][0] + width["de"]
        self.bearing_positions = {"de": _um(z_de), "nde": _um(z_body + 2.0 * body + l_core + 0.5 * width["nde"])}
        self.core_position_m = _um(z_body + body + 0.5 * l_core)
        self.core_length_m, self.core_diameter_m = l_core, d_core
        self.core_mass_kg = CORE_DENSITY_KG_M3 * math.pi / 4.0 * (d_core ** 2 - body ** 2) * l_core
        self.core_polar_inertia_kg_m2 = self.core_mass_kg * (d_core ** 2 + body ** 2) / 8.0
        self.core_diametral_inertia_kg_m2 = 0.5 * self.core_polar_inertia_kg_m2 + self.core_mass_kg * l_core ** 2 / 12
        self.rotor_mass_kg = fixed + _steel(2.0 * body + l_core, body) + self.core_mass_kg     # dimensions in mm
        scale = rotor_mass_kg / _PAPER_ROTOR_KG
        self.housing_mass_kg = _PAPER_HOUSING_KG * scale
        self.support_stiffness_n_m = _PAPER_SUPPORT_N_M * scale
        self.support_damping_n_s_m = _PAPER_SUPPORT_N_S_M * scale
        self.preload_n = {n: PRELOAD_N_PER_MM * bore[n] * 1e3 for n in bore}
        self.designations = {"de": de, "nde": nde}
        self.body_diameter_m = body


def _mm(x: float) -> float:
    """A dimension rounded to the millimetre."""
    return round(x, 3) + 0.0


def _um(x: float) -> float:
    return round(x, 6) + 0.0


def _steel(length: float, diameter: float) -> float:
    return _STEEL_KG_M3 * math.pi / 4.0 * diameter ** 2 * length


def starting_machine(de: str, nde: str, rotor_mass_kg: float) -> StartingMachine:
    """The starting machine's numbers (module docstring); :class:`StartingError` naming the input the rules cannot
    use (a designation the catalogue does not have or has no dimensions for, a rotor mass they cannot meet)."""
    return StartingMachine(de, nde, rotor_mass_kg)


def _g(x: float) -> str:
    """A number as TOML writes it back: the shortest repr that reads as the same float."""
    return repr(float(x))


_COLUMN = 31            # comments start here, as in the embedded cases


def _line(text: str, comment: str = "") -> str:
    """``text`` with ``comment`` at the comment column; further comment lines (``\\n``) under it."""
    if not comment:
        return text + "\n"
    first, *more = comment.split("\n")
    out = f"{text:<{_COLUMN - 1}} # {first}\n" if len(text) < _COLUMN - 1 else f"{text}  # {first}\n"
    return out + "".join(f"{'':<{_COLUMN - 1}} # {m}\n" for m in more)


def starting_case(de: str, nde: str, rotor_mass_kg: float, speed_range_hz: tuple[float, float], name: str,
                  clearance_class: str | None = None, max_sample_rate_hz: float = 51200.0, slices: int = 1) -> str:
    """The TOML text of a documented starting case in the compact form (module docstring).

    Parameters
    ----------
    de, nde : str
        Catalogue designations of the bearings (``"6205"``, ``"6205-2RS1/C3"``).
    rotor_mass_kg : float
        Mass of the rotor, shaft and core [kg].
    speed_range_hz : (float, float)
        Lowest and highest shaft speed [Hz].
    name : str
        The case's name.
    clearance_class : str, optional
        ISO 5753-1 class of both bearings (default: each designation's own, else CN).
    max_sample_rate_hz : float
        Highest sample rate the case serves [Hz].
    slices : int
        Slices the rotor core is lumped into (``bkabem case new`` gives one per FE element under it).
    """
    m = starting_machine(de, nde, rotor_mass_kg)
    lo, hi = speed_range_hz
    steps = ", ".join(f"[{_g(length)}, {_g(d)}]" for length, d in m.steps)
    q = '"'
    text = f"""# bkabem case {name}: a starting case written by `bkabem case new` (docs/machines.md).
#
# An electric motor on a {de} (DE) and a {nde} (NDE) bearing, a {rotor_mass_kg:g} kg rotor, {lo:g} to {hi:g} Hz.
# The shaft, the rotor core, the housings and the supports follow from these by the rules of
# bkabem_core/model/starting.py (docs/machines.md): a place to start editing, not a measured machine.
# `bkabem case check FILE` shows the static loads, bearing stiffnesses, fault frequencies and modes of the result.
#
# The compact form (docs/machines.md): the FE model (nodes, elements, housing nodes, the mesh converged up to half
# the sample rate) follows from [machine]. Units: SI, every key with its unit as a suffix; z from the DE end.

"""
    text += _line("defects = []", "a healthy machine; a defect is a [[defects]] table after [case] (docs/faults.md):\n"
                  "bearing = \"de\", race = \"outer\", length_m = 1.0e-3, depth_m = 20.0e-6,\n"
                  "angle_deg = -90.0, edge = \"ball\", edge_fraction = 0.1")
    text += f"""
[case]
name = {q}{name}{q}
description = {q}Electric motor on {de} (DE) and {nde} (NDE) bearings, {rotor_mass_kg:g} kg rotor (bkabem case new){q}
schema_version = 4

"""
    text += _line("[baseline]", "what every motor has besides its bearings (docs/faults.md; 0 = off)")
    text += _line("unbalance_grade_mm_s = 2.5", "ISO 21940-11 balance grade G 2.5, the grade for electric motors")
    text += ("# misalignment_force_n = 0.0 and misalignment_position_m = 0.0 (the coupling, m from the DE end),\n"
             "# electrical_force_n = 0.0 (on the disks named core*), line_frequency_hz = 50.0\n\n")
    text += "[machine]\n"
    text += _line(f"speed_range_hz = [{_g(lo)}, {_g(hi)}]", "lowest and highest shaft speed [Hz]")
    text += _line(f"max_sample_rate_hz = {_g(max_sample_rate_hz)}", "the FE is converged up to half of it (or the "
                  "highest kept order)")
    text += ("# [length, outer diameter] of each step from the DE end: DE shaft end (coupling seat), DE bearing seat,\n"
             "# body (shoulders and core seat), NDE bearing seat, NDE shaft end; [length, outer, inner] for a hollow "
             "step\n")
    text += f"shaft_steps_m = [{steps}]\n\n"
    text += _line("[[machine.disks]]", f"the rotor core: {m.core_diameter_m * 1e3:g} x {m.core_length_m * 1e3:g} mm, "
                  f"{CORE_DENSITY_KG_M3:g} kg/m^3\n(laminations with their winding or cage)")
    text += _line(f'name = "core"', "disks named core* carry the electrical pull")
    text += _line(f"position_m = {_g(m.core_position_m)}", "its centre, m from the DE end")
    text += _line(f"length_m = {_g(m.core_length_m)}")
    text += _line(f"slices = {slices}", "lumped at the slices' centres (one per FE element under it)")
    text += _line(f"mass_kg = {_g(round(m.core_mass_kg, 4))}")
    text += _line(f"polar_inertia_kg_m2 = {_g(round(m.core_polar_inertia_kg_m2, 7))}", "a uniform annulus: "
                  "m (D^2 + d^2) / 8")
    text += _line(f"diametral_inertia_kg_m2 = {_g(round(m.core_diametral_inertia_kg_m2, 7))}", "about its centre: "
                  "I_p / 2 + m L^2 / 12")
    text += "# an impeller, a fan or a coupling half: one more [[machine.disks]] (name, position_m, mass, inertias)\n"
    for pos in ("de", "nde"):
        d = m.designations[pos]
        text += "\n" + _line(f"[machine.bearings.{pos}]", f"the {pos.upper()} bearing: where, which, and any key of "
                             f"[bearings.{pos}]")
        text += _line(f"position_m = {_g(m.bearing_positions[pos])}", "the centre of its seat, m from the DE end")
        text += _line(f'designation = "{d}"', f"the catalogue's (`bkabem bearing {d}`): any of its numbers\n"
                      "given here overrides the catalogue (ball_diameter_m, n_balls, ...)")
        if clearance_class is not None:
            text += _line(f'clearance_class = "{clearance_class}"', "ISO 5753-1: the middle of its range")
        text += _line(f"damping_n_s_m = {_g(_PAPER_DAMPER_N_S_M)}", "viscous damper across the bearing: the paper's "
                      "6010 motor's\n(no catalogue gives one; measure or scale it)")
        text += _line(f"axial_load_n = {_g(round(m.preload_n[pos], 1))}", f"spring preload, {PRELOAD_N_PER_MM:g} N "
                      f"per mm of bore (SKF: 5-10)")
    text += "\n" + _line("[machine.housings]", "both housings ([machine.housings.de] or .nde: one its own values),\n"
                         "the paper's motor's (3.17 kg, 1e6 N/m, 1e4 N s/m for 82 kg)\nscaled by the rotor's mass")
    text += _line(f"mass_kg = {_g(round(m.housing_mass_kg, 4))}")
    text += _line(f"support_stiffness_n_m = {_g(float(f'{m.support_stiffness_n_m:.4g}'))}", "both directions (or "
                  "_vertical_n_m, _horizontal_n_m)")
    text += _line(f"support_damping_n_s_m = {_g(float(f'{m.support_damping_n_s_m:.4g}'))}")
    text += "\n" + _line("[excitation]", "the bearings' excitation (docs/method.md); a key left out\ntakes the "
                         "embedded motor's value (docs/machines.md)")
    text += _line("max_order = 50", "BPFO orders kept (0 = every line above the threshold)")
    return text
