"""Characteristic frequencies, the ground-truth defects of a run, and the spectrum markers drawn
for them: all from the messages as recorded (``BearingFaultFrequencies``), data-driven.

A run carries a list of defects (:class:`Defect`: kind, bearing, size) and the bearing's
fault-frequency lines (:data:`LINES`: 1x, FTF, BPFO, BPFI, BSF, 2xBSF, each a multiple of the
shaft speed). :func:`marker_plan` turns them into the markers of one spectrum view: every line at
its fundamental, and the lines a defect of the run excites (:data:`DEFECT_LINE`: outer race ->
BPFO, inner race -> BPFI, ball -> 2xBSF, cage -> FTF) also at harmonics 2 and 3. So a spectrum
whose every line is a BPFO multiple gets three BPFO markers, not fifty, and a run with several
defects (in DE, NDE or both) marks each defect's line without any change here.

Today's message carries one defect (``defect_bearing``, ``defect_race``, ``defect_length``,
``defect_depth``, ``defect_angle``); :func:`defects_from_message` is the one place that reads
it, so a message with a list of defects plugs in there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["DEFECT_LINE", "LINES", "LINE_COLORS", "Defect", "Marker", "defects_from_message",
           "describe_defect", "line_frequencies", "marker_plan"]

#: Fault-frequency lines in display order.
LINES = ("1x", "FTF", "BPFO", "BPFI", "BSF", "2xBSF")
#: Colours on the viewer's dark background (RGB); also used for the fault-frequency trend.
LINE_COLORS = {
    "1x": (220, 220, 220),      # white-grey
    "FTF": (178, 120, 255),     # violet
    "BPFO": (255, 70, 70),      # red
    "BPFI": (70, 220, 90),      # green
    "BSF": (255, 215, 0),       # yellow
    "2xBSF": (0, 215, 225),     # cyan
}
#: Colour names for the key in the health panel.
LINE_COLOR_NAMES = {"1x": "grey", "FTF": "violet", "BPFO": "red", "BPFI": "green", "BSF": "yellow",
                    "2xBSF": "cyan"}
#: The line a defect of each kind excites (its fundamental fault frequency).
DEFECT_LINE = {"outer": "BPFO", "inner": "BPFI", "ball": "2xBSF", "cage": "FTF"}
#: Kinds as an engineer names them.
DEFECT_NAMES = {"outer": "outer-race", "inner": "inner-race", "ball": "ball", "cage": "cage"}
#: Harmonics marked for a line a defect excites (the others: the fundamental only).
DEFECT_HARMONICS = (1, 2, 3)


@dataclass(frozen=True)
class Defect:
    """One simulated defect: ``kind`` ("outer", "inner", "ball", "cage"), ``bearing`` ("de" or
    "nde"), ``length_m`` along the raceway, ``depth_m``, ``angle_rad`` (position of the dent
    centre from +x towards +y), ``designation`` of the bearing (e.g. "6010")."""

    kind: str
    bearing: str
    length_m: float = 0.0
    depth_m: float = 0.0
    angle_rad: float = 0.0
    designation: str = ""

    @property
    def line(self) -> str:
        """The fault-frequency line this defect excites (see :data:`DEFECT_LINE`)."""
        return DEFECT_LINE.get(self.kind, "BPFO")


@dataclass(frozen=True)
class Marker:
    """One marker bar: ``line`` (a name of :data:`LINES`), ``harmonic`` (1, 2, ...),
    ``frequency_hz``, ``color`` (RGB)."""

    line: str
    harmonic: int
    frequency_hz: float
    color: tuple[int, int, int]

    @property
    def label(self) -> str:
        return self.line if self.harmonic == 1 else f"{self.harmonic}x{self.line}"


def line_frequencies(msg) -> dict[str, float]:
    """{line: frequency [Hz]} of a ``BearingFaultFrequencies`` message (1x from its shaft speed
    [rad/s])."""
    bsf = float(msg.bsf)
    return {"1x": float(msg.shaft_speed) / (2.0 * math.pi), "FTF": float(msg.ftf), "BPFO": float(msg.bpfo),
            "BPFI": float(msg.bpfi), "BSF": bsf, "2xBSF": 2.0 * bsf}


def defects_from_message(msg) -> list[Defect]:
    """The defects a ``BearingFaultFrequencies`` message states (today's message: one)."""
    kind = str(getattr(msg, "defect_race", "outer") or "outer")
    return [Defect(kind=kind, bearing=str(msg.defect_bearing), length_m=float(msg.defect_length),
                   depth_m=float(msg.defect_depth), angle_rad=float(msg.defect_angle),
                   designation=str(getattr(msg, "bearing_designation", "")))]


def describe_defect(d: Defect) -> str:
    """One line for people, e.g. ``outer-race dent, DE bearing 6010, 2.00 mm x 50 um at -90 deg``."""
    size = f"{d.length_m * 1e3:.2f} mm x {d.depth_m * 1e6:.0f} um" if d.length_m or d.depth_m else "size n/a"
    return (f"{DEFECT_NAMES.get(d.kind, d.kind)} defect, {d.bearing.upper()} bearing"
            f"{' ' + d.designation if d.designation else ''}, {size} at {math.degrees(d.angle_rad):.0f} deg")


def marker_plan(lines: dict[str, float], defects: list[Defect], f_max: float,
                harmonics: tuple[int, ...] = DEFECT_HARMONICS) -> list[Marker]:
    """Markers for a spectrum shown up to ``f_max`` [Hz]: every line of ``lines`` at its
    fundamental; the lines excited by ``defects`` also at ``harmonics``. Lines at 0 Hz (speed
    0) and markers above ``f_max`` are left out."""
    excited = {d.line for d in defects}
    out = []
    for name in LINES:
        f = float(lines.get(name, 0.0))
        if not f > 0:
            continue
        for h in (harmonics if name in excited else (1,)):
            if h * f <= f_max:
                out.append(Marker(name, h, h * f, LINE_COLORS[name]))
    return out
