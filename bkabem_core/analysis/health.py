"""The text of the health panels: what a bearing's numbers say, next to the run's ground truth.

Pure functions of the numbers :class:`bkabem_ros.viewer.rerun_io.RerunLogger` collects per bearing (no
Rerun here): :func:`envelope_finding` reads an envelope spectrum the way a monitoring pipeline does
(the fault line whose harmonics stand out over the spectrum's median floor), :func:`health_text`
writes the panel, verdicts first.
"""

from __future__ import annotations

import math

import numpy as np

from bkabem_core.analysis import condition, fault_lines

__all__ = ["bearing_truth", "envelope_finding", "health_text", "line_sources"]


def _defect_words(d) -> str:
    return f"{d.bearing.upper()} {d.words} defect"


def line_sources(name: str, loc: str, defects) -> tuple[list, list]:
    """The defects of the ground truth whose fault line ``name`` is (one of the lines its kind
    shows in an envelope spectrum: a ball defect strikes both races, 2xBSF, and BSF when the two
    strikes differ): (this bearing's, the other bearings'). An envelope line of another bearing's
    defect is transmitted (shaft, housing, frame), not a fault of this one."""
    hit = [d for d in defects or () if name in d.envelope_lines]
    return [d for d in hit if d.bearing == loc], [d for d in hit if d.bearing != loc]


def envelope_finding(f, env, lines: dict[str, float], names: list[str], loc: str = "",
                     defects=None, bearing_lines: dict | None = None) -> str:
    """The fault line whose harmonics 1-3 stand out most over the envelope spectrum's median
    floor (what a monitoring pipeline reads first), for bearing ``loc`` (``lines``: its own
    bearing's). With the ground truth (``defects``: every defect of the machine with its bearing),
    a line that stands out and belongs only to a defect of another bearing is said to be that
    defect's, transmitted ("BPFO 89.6 Hz: from the DE outer-race defect (transmitted) ..."), so the
    panel of a healthy bearing never reads like a fault of its own. ``bearing_lines`` ({bearing:
    lines}, a bearing of its own at each position): the defects of a bearing whose lines differ
    from ``loc``'s are looked for at their own bearing's lines ("DE BPFO 107.6 Hz: from ...")."""
    if env.size == 0 or f.size < 8:
        return "no envelope spectrum yet"
    df = f[1] - f[0]
    bl = bearing_lines or {}
    candidates = [(name, lines.get(name, 0.0), "") for name in ("BPFO", "BPFI", "2xBSF", "BSF", "FTF")]
    for d in defects or ():                       # another bearing's defect at its own bearing's lines
        other = bl.get(d.bearing)
        if d.bearing != loc and other is not None and other != lines and d.depth_m > 0:
            candidates += [(name, other.get(name, 0.0), d.bearing) for name in d.envelope_lines
                           if (name, other.get(name, 0.0), d.bearing) not in candidates]
    best = None
    for name, f0, src in candidates:
        if not f0 > 2 * df:
            continue
        for c in range(env.shape[0]):
            floor = float(np.median(env[c, 1:])) or 1e-30
            db = []
            for h in (1, 2, 3):
                if h * f0 > f[-1]:
                    break
                tol = max(1.5 * df, 0.01 * h * f0)
                m = np.abs(f - h * f0) <= tol
                db.append(20 * math.log10(max(float(env[c, m].max()), 1e-30) / floor))
            if db and (best is None or db[0] > best[0][0]):
                best = (db, name, names[c], f0, src)
    if best is None:
        return "no fault line in the envelope range yet"
    db, name, ch, f0, src = best
    stands = db[0] >= 10
    hs = "/".join(f"{v:.0f}" for v in db)
    numbers = f"harmonics 1-{len(db)} at {hs} dB over the median floor ({ch})"
    if src:                                       # the line of another bearing's defect
        mine = [d for d in defects if d.bearing == src and name in d.envelope_lines]
        label = f"{src.upper()} {name} {f0:.1f} Hz"
        if stands:
            return (f"{label}: from the {' and '.join(_defect_words(d) for d in mine)} (transmitted), not a fault "
                    f"of the {loc.upper()} bearing; {numbers}")
        return f"{label} does not stand out: {numbers}"
    same = [d for d in defects or () if bl.get(d.bearing, lines) == lines or d.bearing == loc]
    own, other = line_sources(name, loc, same)
    if stands and other and not own:
        src = " and ".join(_defect_words(d) for d in other)
        return (f"{name} {f0:.1f} Hz: from the {src} (transmitted), not a fault of the "
                f"{loc.upper()} bearing; {numbers}")
    verdict = "stands out" if stands else "does not stand out"
    also = ""
    if stands and own and other:
        also = f"; the {' and '.join(_defect_words(d) for d in other)} has it too (transmitted)"
    return f"{name} ({f0:.1f} Hz) {verdict}: {numbers}{also}"


def bearing_truth(loc: str, defects: list, truth: "fault_lines.Truth | None" = None) -> tuple[str, str]:
    """The ground truth of one bearing for its panel, as two texts: what is in *this* bearing
    (its defects, or "no defect in this bearing"), and the defects of the other bearings ("" if
    none), so that a panel never names another bearing's defect as its own.

    Parameters
    ----------
    loc : str
        "de" or "nde".
    defects : list of fault_lines.Defect
        Every defect of the machine the last fault-frequency message states.
    truth : fault_lines.Truth, optional
        The message's ground truth: tells "no defect" (a 0.2.0 message) from "not stated yet".
    """
    here = [d for d in defects if d.bearing == loc]
    other = [d for d in defects if d.bearing != loc]
    if here:
        own = "; ".join(fault_lines.describe_defect(d) for d in here)
    elif defects or (truth is not None and truth.available):
        own = "no defect in this bearing"
    else:
        own = "no fault-frequency message yet"
    return own, "; ".join(fault_lines.describe_defect(d) for d in other)


def health_text(loc: str, h: dict, defects: list, run_lines: dict[str, float], iso_zones: str,
                window_s: float, truth: "fault_lines.Truth | None" = None, marked: list | None = None) -> str:
    """Markdown of one bearing's health panel: verdicts first (ISO zone, this bearing's ground
    truth, envelope finding), then the defects of the other bearing (:func:`bearing_truth`), the
    machine-wide ground truth, the numbers the verdicts rest on and the marker key.

    Parameters
    ----------
    loc : str
        "de" or "nde".
    h : dict
        What the logger collected for the bearing: the last condition window (``iso`` [mm/s],
        ``zone``, ``rms``/``peak`` [m/s^2], ``crest``, ``kurt``, ``band`` [Hz], ``finding``, ...)
        and ``spectra`` (per quantity: BPFO [Hz], orders, static part in display units).
    defects : list of fault_lines.Defect
        The run's ground truth.
    run_lines : dict
        The bearing's fault-frequency lines [Hz] of the last message (used when ``h`` has none).
    iso_zones : str
        Key of :data:`bkabem_core.analysis.condition.ISO_ZONE_SETS`.
    window_s : float
        The condition window [s] (for "no full window yet").
    truth : fault_lines.Truth, optional
        The rest of the ground truth (healthy, baseline, scenario state, labels) for the lines
        under the defects.
    marked : list of fault_lines.Defect, optional
        The defects whose lines the bearing's markers show at their harmonics (those of bearings
        with this bearing's lines; default: ``defects``).
    """
    L = loc.upper()
    names = h.get("names", [])
    limits = condition.ISO_ZONE_SETS[iso_zones]
    out = []
    if "iso" in h:
        worst = max(h["zone"]) if h["zone"] else "?"
        out.append(f"**{L} bearing: ISO zone {worst}**, {condition.ZONE_NAMES.get(worst, '')} "
                   f"({iso_zones}: A/B {limits[0]:g}, B/C {limits[1]:g}, C/D {limits[2]:g} mm/s)")
    else:
        out.append(f"**{L} bearing**: no full {window_s:g} s of acceleration yet")
    own, elsewhere = bearing_truth(loc, defects, truth)
    out += ["", f"**Ground truth, {L} bearing**: {own}"]
    if "iso" in h:
        b = h["band"]
        out += ["", f"**Envelope** ({b[0] / 1e3:g}-{b[1] / 1e3:g} kHz band): {h['finding']}"]
    if elsewhere:
        out += ["", f"**Elsewhere in the machine**: {elsewhere}"]
    out.append("")                    # one list: the machine's ground truth, then the numbers
    if truth is not None:
        out += [f"- {line}" for line in fault_lines.describe_truth(truth)]
    if "iso" in h:
        per = ", ".join(f"{ch} {v:.2f} mm/s ({z})" for ch, v, z in zip(names, h["iso"], h["zone"]))
        out.append(f"- velocity RMS 10-1000 Hz, last {h['window_s']:g} s: {per}")

        def fmt(v):
            return " / ".join(f"{x:.3g}" for x in v)

        out.append(f"- acceleration {' / '.join(names)}: RMS {fmt(h['rms'])} m/s², peak {fmt(h['peak'])} m/s², "
                   f"crest factor {fmt(h['crest'])}, kurtosis {fmt(h['kurt'])}")
        out.append(f"- envelope spectrum: {h['env_df']:g} Hz bins"
                   + (f", each bar the largest of {h['env_group']} bins" if h["env_group"] > 1 else ""))
    for q, sp in h.get("spectra", {}).items():
        line = (f"- model {q} spectrum at {sp['shaft_hz']:.2f} Hz shaft: BPFO {sp['bpfo']:.2f} Hz, orders "
                f"{sp['orders'][0]}-{sp['orders'][1]}, drawn to {sp['shown_to_hz'] / 1e3:.2f} kHz")
        static = np.asarray(sp["static"], dtype=np.float64)
        if np.any(static):
            big = float(np.abs(static).max())
            line += "; static part (order 0, not drawn): " + ", ".join(
                f"{ch} {(v if abs(v) > 1e-6 * big else 0.0):.3g} {sp['unit']}"      # round-off shown as 0
                for ch, v in zip(sp["names"], static))
        out.append(line)
    lines = h.get("lines") or run_lines
    if lines:
        excited: dict[str, set] = {}
        for d in (defects if marked is None else marked):
            excited.setdefault(d.line, set()).update(d.harmonics)
        key = ", ".join(f"{name} {lines[name]:.1f} Hz {fault_lines.LINE_COLOR_NAMES[name]}"
                        + (f" (x{min(excited[name])}-{max(excited[name])})" if name in excited else "")
                        for name in fault_lines.LINES if name in lines)
        out.append(f"- markers (below the zero line of the spectra): {key}")
    return "\n".join(out).rstrip()
