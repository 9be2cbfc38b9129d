"""Characteristic frequencies, the ground-truth defects of a run, and the spectrum markers drawn
for them: all from the messages as recorded (``BearingFaultFrequencies``), data-driven.

A run carries a list of defects (:class:`Defect`: kind, bearing, size) and each bearing's
fault-frequency lines (:data:`LINES`: 1x, FTF, BPFO, BPFI, BSF, 2xBSF, each a multiple of the
shaft speed; :func:`bearing_line_frequencies`: each position has a bearing of its own, with its
own cage and spin rates, stated per bearing since bkabem_msgs 0.3.0). :func:`marker_plan` turns them into the markers of one spectrum view: every line at
its fundamental, and the line a defect of the run excites (its kind's, from the registry of
:mod:`bkabem_core.bearing.defects`: outer race -> BPFO, inner race -> BPFI, ball -> 2xBSF) also
at its kind's marked harmonics (2 and 3). So a spectrum whose every line is a BPFO multiple gets
three BPFO markers, not fifty, and a run with several defects (in DE, NDE or both) marks each
defect's line without any change here. A kind bkabem does not know (a message of another tool)
is named as it is and marked as BPFO.

The messages carry the ground truth (``bkabem_msgs/GroundTruth``, 0.2.0): every defect, the
baseline, the scenario state. :func:`defects_from_message` and :func:`truth_from_message` are
the one place that reads it; a message recorded with bkabem_msgs 0.1.0 has only its one
``defect_*`` fields, read as the single defect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bkabem_core.bearing.defects.registry import find

__all__ = ["LINES", "LINE_COLORS", "Defect", "Marker", "Truth", "bearing_line_frequencies", "defects_from_message",
           "defects_with_lines_of", "describe_defect", "describe_truth", "line_frequencies", "marker_plan", "truth_from_message"]

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
#: The line of a defect whose kind bkabem does not know, and its marked harmonics.
UNKNOWN_KIND_LINE = "BPFO"
DEFECT_HARMONICS = (1, 2, 3)


@dataclass(frozen=True)
class Defect:
    """One simulated defect: ``kind`` (a name of the defect-kind registry: "outer", "inner",
    "ball"), ``bearing`` ("de" or "nde"), ``length_m`` along the raceway, ``depth_m``,
    ``angle_rad`` (position of the dent centre from +x towards +y), ``designation`` of the
    bearing (e.g. "6010"), its ``name`` in the scenario or case, ``ball`` (1..z for a ball
    defect, else 0)."""

    kind: str
    bearing: str
    length_m: float = 0.0
    depth_m: float = 0.0
    angle_rad: float = 0.0
    designation: str = ""
    name: str = ""
    ball: int = 0

    @property
    def line(self) -> str:
        """The fault-frequency line this defect excites (its kind's strike line)."""
        k = find(self.kind)
        return k.line if k is not None else UNKNOWN_KIND_LINE

    @property
    def harmonics(self) -> tuple[int, ...]:
        """Harmonics of :attr:`line` a spectrum marks (its kind's)."""
        k = find(self.kind)
        return k.marked_harmonics if k is not None else DEFECT_HARMONICS

    @property
    def envelope_lines(self) -> tuple[str, ...]:
        """The lines it shows in an envelope spectrum (its kind's: a ball defect 2xBSF and BSF)."""
        k = find(self.kind)
        return k.envelope_lines if k is not None else (self.line,)

    @property
    def place(self) -> str:
        """Where it is, for people: "outer race", "inner race", "ball 3"; an unknown kind by its name."""
        k = find(self.kind)
        return k.place_of(vars(self)) if k is not None else self.kind

    @property
    def words(self) -> str:
        """As in "<words> defect": "outer-race", "ball 3"; an unknown kind by its name."""
        k = find(self.kind)
        return k.adjective_of(vars(self)) if k is not None else self.kind


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
    """{line: frequency [Hz]} of the single fields of a ``BearingFaultFrequencies`` message: the DE bearing's (1x
    from its shaft speed [rad/s]); every bearing's: :func:`bearing_line_frequencies`."""
    return _lines(float(msg.shaft_speed), msg)


def _lines(shaft_rad_s: float, k) -> dict[str, float]:
    bsf = float(k.bsf)
    return {"1x": shaft_rad_s / (2.0 * math.pi), "FTF": float(k.ftf), "BPFO": float(k.bpfo),
            "BPFI": float(k.bpfi), "BSF": bsf, "2xBSF": 2.0 * bsf}


def bearing_line_frequencies(msg) -> dict[str, dict[str, float]]:
    """{bearing: {line: frequency [Hz]}} of a ``BearingFaultFrequencies`` message, each bearing its own
    (its ``bearings``, bkabem_msgs 0.3.0); a message without them (0.1.0, 0.2.0: one bearing type at both
    positions) gives its single fields for both."""
    speed = float(msg.shaft_speed)
    out = {str(b.bearing): _lines(speed, b) for b in (getattr(msg, "bearings", None) or ())}
    if not out:
        shared = line_frequencies(msg)
        out = {"de": shared, "nde": dict(shared)}
    return out


@dataclass(frozen=True)
class Truth:
    """The ground truth a message states (``bkabem_msgs/GroundTruth``): its defects, whether the
    machine is healthy, the baseline, the case, the scenario state and time, the labels.
    ``available`` is false for a message without one (bkabem_msgs 0.1.0 waveforms)."""

    available: bool
    defects: tuple = ()
    healthy: bool = True
    unbalance_grade_m_s: float = 0.0
    misalignment_force_n: float = 0.0
    electrical_force_n: float = 0.0
    line_frequency_hz: float = 0.0
    load_factor: float = 1.0
    case: str = ""
    scenario: str = ""
    state_index: int = 0
    state_label: str = ""
    state_start_s: float = 0.0
    scenario_time_s: float = 0.0
    time_scale: float = 1.0
    labels: tuple = ()


def _designation(msg) -> str:
    return str(getattr(msg, "bearing_designation", ""))


def truth_from_message(msg) -> Truth:
    """The ground truth of any bkabem message (waveform, spectrum, fault frequencies): from its
    ``ground_truth`` (bkabem_msgs 0.2.0), or, for a 0.1.0 fault-frequency message, its one
    ``defect_*`` defect."""
    g = getattr(msg, "ground_truth", None)
    if g is not None and bool(getattr(g, "available", False)):
        defects = tuple(Defect(kind=str(d.kind), bearing=str(d.bearing), length_m=float(d.length),
                               depth_m=float(d.depth), angle_rad=float(d.angle),
                               designation=str(d.bearing_designation) or _designation(msg), name=str(d.name),
                               ball=int(d.ball)) for d in g.defects)
        return Truth(True, defects, bool(g.healthy), float(g.unbalance_grade), float(g.misalignment_force),
                     float(g.electrical_force), float(g.line_frequency), float(g.load_factor), str(g.case_name),
                     str(g.scenario), int(g.state_index), str(g.state_label), float(g.state_start_time),
                     float(g.scenario_time), float(g.time_scale),
                     tuple(zip((str(k) for k in g.label_keys), (str(v) for v in g.label_values))))
    if hasattr(msg, "defect_bearing"):
        if not (float(msg.defect_length) or float(msg.defect_depth)):
            return Truth(True, (), True)
        kind = str(getattr(msg, "defect_race", "outer") or "outer")
        d = Defect(kind=kind, bearing=str(msg.defect_bearing), length_m=float(msg.defect_length),
                   depth_m=float(msg.defect_depth), angle_rad=float(msg.defect_angle), designation=_designation(msg),
                   name="defects[0]")
        return Truth(True, (d,), not d.depth_m > 0)
    return Truth(False)


def defects_from_message(msg) -> list[Defect]:
    """Every defect a message states (:func:`truth_from_message`; [] for a healthy machine)."""
    return list(truth_from_message(msg).defects)


def defect_place(d: Defect) -> str:
    """Where the defect is, for people: ``"outer race"``, ``"inner race"``, ``"ball 3"``."""
    return d.place


def describe_defect(d: Defect) -> str:
    """One line for people, e.g. ``outer-race defect, DE bearing 6010, 2.00 mm x 50 um at -90 deg``
    (a ball defect: ``ball 3 defect, ...``)."""
    size = f"{d.length_m * 1e3:.2f} mm x {d.depth_m * 1e6:.0f} um" if d.length_m or d.depth_m else "size n/a"
    what = d.words
    felt = "" if d.depth_m > 0 else " (depth 0: no ball feels it)"
    return (f"{what} defect, {d.bearing.upper()} bearing"
            f"{' ' + d.designation if d.designation else ''}, {size} at {math.degrees(d.angle_rad):.0f} deg{felt}")


def _hours(t_s: float) -> str:
    return f"{t_s / 3600:.2f} h" if abs(t_s) >= 3600 else f"{t_s:.1f} s"


def describe_truth(t: Truth) -> list[str]:
    """The machine-wide ground truth for people: healthy or not, baseline, scenario state, labels
    (one item per line; the defects are described per bearing by :func:`describe_defect`)."""
    if not t.available:
        return ["not stated in these messages (recorded with bkabem_msgs 0.1.0)"]
    out = ["machine **healthy** (no defect a ball feels)" if t.healthy else
           f"machine **faulty**: {sum(1 for d in t.defects if d.depth_m > 0)} defect(s)"]
    base = []
    if t.unbalance_grade_m_s > 0:
        base.append(f"unbalance G {t.unbalance_grade_m_s * 1e3:g}")
    if t.misalignment_force_n > 0:
        base.append(f"misalignment {t.misalignment_force_n:g} N at 2x")
    if t.electrical_force_n > 0:
        base.append(f"magnetic pull {t.electrical_force_n:g} N at {2 * t.line_frequency_hz:g} Hz")
    if t.load_factor != 1.0:
        base.append(f"radial load x{t.load_factor:g}")
    out.append("baseline: " + (", ".join(base) if base else "none"))
    if t.scenario:
        out.append(f"scenario {t.scenario}: state {t.state_index} ({t.state_label}) since "
                   f"{_hours(t.state_start_s)}, now {_hours(t.scenario_time_s)} (x{t.time_scale:g})")
    elif t.case:
        out.append(f"case {t.case}")
    if t.labels:
        out.append("labels: " + ", ".join(f"{k}={v}" for k, v in t.labels))
    return out


def defects_with_lines_of(defects, bearing_lines: dict, loc: str) -> list[Defect]:
    """The defects in bearings whose fault lines are those of bearing ``loc`` (``bearing_lines``:
    :func:`bearing_line_frequencies`): every defect when both positions carry one bearing type,
    only ``loc``'s own when the other bearing is another one (its lines are elsewhere)."""
    mine = bearing_lines.get(loc)
    return [d for d in defects if bearing_lines.get(d.bearing, mine) == mine]


def marker_plan(lines: dict[str, float], defects: list[Defect], f_max: float,
                harmonics: tuple[int, ...] | None = None) -> list[Marker]:
    """Markers for a spectrum shown up to ``f_max`` [Hz]: every line of ``lines`` (one bearing's) at
    its fundamental; the lines excited by ``defects`` (those of bearings with these lines) also at
    ``harmonics`` (default: each defect kind's marked harmonics). Lines at 0 Hz (speed 0) and markers
    above ``f_max`` are left out."""
    excited: dict[str, set] = {}
    for d in defects:
        if d.depth_m > 0:
            excited.setdefault(d.line, set()).update(d.harmonics if harmonics is None else harmonics)
    out = []
    for name in LINES:
        f = float(lines.get(name, 0.0))
        if not f > 0:
            continue
        for h in (sorted(excited[name]) if name in excited else (1,)):
            if h * f <= f_max:
                out.append(Marker(name, h, h * f, LINE_COLORS[name]))
    return out
