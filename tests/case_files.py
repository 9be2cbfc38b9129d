"""Case files for the tests: the embedded machine with a bearing of its own at each position, and the textbook
fault multipliers of a bearing written here (independent of the bearing model). Shared by test_positions.py (unit)
and the TDSM, validation and CLI tests (integration)."""

from __future__ import annotations

import re
from importlib import resources

__all__ = ["embedded_text", "textbook_multipliers", "two_bearing_text"]


def embedded_text(name: str = "electric_motor_6010") -> str:
    """The TOML text of an embedded case."""
    return resources.files("bkabem_core.embedded").joinpath("cases", f"{name}.toml").read_text()


def two_bearing_text(text: str | None = None) -> str:
    """The embedded machine with a 6205 at the DE and a 6203 at the NDE (the CWRU rig's two bearing types; their
    catalogue geometry and CN clearance: the paper's ball diameter and clearance removed) and an outer-race dent in
    the NDE bearing too (1 mm x 20 um at the bottom)."""
    text = embedded_text() if text is None else text
    text = re.sub(r'^designation = "6010"', 'designation = "6205"', text, count=1, flags=re.M)
    text = re.sub(r'^designation = "6010"', 'designation = "6203"', text, count=1, flags=re.M)
    text = re.sub(r"^(ball_diameter_m|diametral_clearance_m) = .*\n", "", text, flags=re.M)
    return text.replace("[baseline]", '[[defects]]\nbearing = "nde"\nrace = "outer"\nlength_m = 1.0e-3\n'
                        'depth_m = 20.0e-6\nangle_deg = -90.0\nedge = "ball"\nedge_fraction = 0.1\n\n[baseline]', 1)


def textbook_multipliers(b: dict) -> dict:
    """FTF, BPFO, BPFI, BSF per shaft Hz from a bearing table's ball and pitch diameter and ball count (contact
    angle 0): the textbook formulas, written here."""
    g = b["ball_diameter_m"] / b["pitch_diameter_m"]
    z = b["n_balls"]
    return {"ftf": (1 - g) / 2, "bpfo": z * (1 - g) / 2, "bpfi": z * (1 + g) / 2, "bsf": (1 - g * g) / (2 * g)}
