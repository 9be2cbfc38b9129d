"""Scenario files for the tests, and the timeline evaluated here from a file alone (independent of
``bkabem_core.scenario.timeline``): shared by test_scenario.py (the library and ``bkabem synth``),
test_node_scenario.py (the node) and test_rerun_io.py (the view).

:func:`scenario_toml` writes a scenario file (docs/scenarios.md) from Python values in one layout,
so that a test can derive a bad file from a good one by replacing one line; :func:`parse`,
:func:`truth_of_timeline`, :func:`speed_of_timeline` and :func:`check_truth` read it back.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

__all__ = ["check_truth", "defect", "parse", "scenario_toml", "speed_of_timeline", "toml_value",
           "truth_of_timeline"]


def toml_value(v) -> str:
    """TOML literal of a str, bool, int, float or list of them (floats as ``repr``: 20.0, 0.0003, 8e-06)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, (int, float)):
        return repr(v)
    raise TypeError(f"no TOML literal for {v!r}")


def _table(header: str, items: dict) -> list[str]:
    return [header] + [f"{k} = {toml_value(v)}" for k, v in items.items()] + [""]


def defect(name: str, bearing: str, race: str, *, time_s, length_m, depth_m, **keys) -> dict:
    """One ``[[defects]]`` entry, its keys in the order of docs/scenarios.md (name, bearing, race, then
    ``keys`` such as ``ball``, ``angle_deg``, ``growth``, then the timeline)."""
    return {"name": name, "bearing": bearing, "race": race, **keys, "time_s": list(time_s),
            "length_m": list(length_m), "depth_m": list(depth_m)}


def scenario_toml(name: str, *, duration_s: float, size_step: float | None = None, labels: dict | None = None,
                  speed=None, defects=(), case: str = "motor_6010_healthy") -> str:
    """A scenario file: ``[scenario]`` (without ``size_step``: the format's default), ``[labels]`` (if any),
    ``[speed]`` (``speed``: (time_s, speed_hz) lists, or None for a scenario without one) and the ``[[defects]]``
    (dicts from :func:`defect`)."""
    head = {"name": name, "schema_version": 1, "case": case, "duration_s": float(duration_s)}
    if size_step is not None:
        head["size_step"] = float(size_step)
    lines = [""] + _table("[scenario]", head)
    if labels:
        lines += _table("[labels]", labels)
    if speed is not None:
        lines += _table("[speed]", {"time_s": list(speed[0]), "speed_hz": list(speed[1])})
    for d in defects:
        lines += _table("[[defects]]", d)
    return "\n".join(lines)


def parse(text: str) -> dict:
    return tomllib.loads(text)


def truth_of_timeline(raw: dict, t: float) -> dict:
    """The defects of a scenario file at scenario time ``t`` [s], evaluated here from the file alone: present from
    their first time, linear or geometric between the points, held after the last one."""
    out = {}
    for d in raw.get("defects", []):
        times = np.asarray(d["time_s"], float)
        if t < times[0]:
            continue
        size = []
        for key in ("length_m", "depth_m"):
            v = np.asarray(d[key], float)
            if t >= times[-1]:
                size.append(v[-1])
                continue
            i = int(np.searchsorted(times, t, side="right") - 1)
            s = (t - times[i]) / (times[i + 1] - times[i])
            if d.get("growth", "linear") == "exponential":
                size.append(v[i] * (v[i + 1] / v[i]) ** s)
            else:
                size.append(v[i] + (v[i + 1] - v[i]) * s)
        out[d["name"]] = {"bearing": d["bearing"], "race": d["race"], "length_m": size[0], "depth_m": size[1],
                          "angle_rad": math.radians(d.get("angle_deg", 0.0))}
    return out


def speed_of_timeline(raw: dict, t: float) -> float:
    return float(np.interp(t, raw["speed"]["time_s"], raw["speed"]["speed_hz"]))


def check_truth(raw: dict, gt: dict, t: float, step: float, speed_hz: float, exact: bool = True) -> None:
    """A chunk's ground truth against the file: the defects of the timeline at the state's start (which lies
    before t), their kinds, places and sizes; with ``exact`` (the state in effect is the one due: models made
    when needed) the same defects as the timeline at t, each within a size step of its size at t; the fault
    frequencies at the chunk's speed; healthy; the labels."""
    assert gt["scenario_time_s"] == pytest.approx(t, abs=1e-6)
    start = gt["state_start_s"]
    assert start <= t + 1e-6
    have = {d["name"]: d for d in gt["defects"]}
    now = truth_of_timeline(raw, t)
    at_start = truth_of_timeline(raw, start)
    assert set(have) == set(at_start), (start, set(have), set(at_start))
    if exact:
        assert set(have) == set(now), (t, set(have), set(now))
    for name, d in have.items():
        ref = at_start[name]
        for k in ("bearing", "race"):
            assert d[k] == ref[k]
        assert d["angle_rad"] == pytest.approx(ref["angle_rad"])
        assert d["length_m"] == pytest.approx(ref["length_m"], rel=1e-9)
        assert d["depth_m"] == pytest.approx(ref["depth_m"], rel=1e-9)
        if exact:                      # quantised: within a step (plus the growth over one chunk) of the timeline
            assert abs(d["length_m"] / now[name]["length_m"] - 1) <= 1.6 * step
        assert d["strike_frequency_hz"] == pytest.approx(d["strike_multiplier"] * speed_hz)
    assert gt["healthy"] == (not any(d["depth_m"] > 0 for d in have.values()))
    assert gt["labels"] == raw.get("labels", {})


def capped_case(folder) -> str:
    """Write the fault library's healthy motor with its lines capped (``excitation.max_order = 50``: BPFO and 49
    harmonics, 7.6 kHz at 25 Hz) into ``folder`` as ``capped_healthy.toml``; returns that name (a scenario's case
    path relative to its file). The library's own cases carry every line above the threshold to the band: a short
    dent then has ~1000 lines and its model takes ~4 s instead of ~0.5 s, which a test about something else (how a
    sample rate too low for capped lines is refused, determinism at a fast time scale) need not wait for."""
    import re
    from importlib import resources
    from pathlib import Path

    text = resources.files("bkabem_core.embedded").joinpath("cases", "motor_6010_healthy.toml").read_text()
    capped = re.sub(r"^max_order = 0 ", "max_order = 50", text, count=1, flags=re.M)
    assert capped != text
    (Path(folder) / "capped_healthy.toml").write_text(capped)
    return "capped_healthy.toml"
