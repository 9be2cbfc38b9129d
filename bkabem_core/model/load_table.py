"""A rig's load table: the shaft speed that each load of its dynamometer gives.

A test rig whose motor runs direct on line does not choose its speed: the load does. An induction motor slows as
its torque grows (its slip), so a rig documents its loads with the speeds they gave, e.g. the CWRU rig: 0, 1, 2
and 3 hp at 1797, 1772, 1750 and 1730 r/min. The case keeps that table in ``[operating]`` (the compact form in
``[machine]``)::

    load_hp = [0.0, 1.0, 2.0, 3.0]                      # the dynamometer's loads [hp], increasing
    load_speed_hz = [29.95, 29.5333, 29.1667, 28.8333]  # the shaft speed at each [Hz]

and a data set that gives a run's load (``load_hp``) renders it at the table's speed, linear between its points
(the slip of an induction motor is nearly proportional to its torque below the rated load). A load outside the
table is refused, never clamped: the table is what was measured. In this model a load changes the speed only: the
bearings' static loads stay the rotor's weight, and a turning coupling force (``[baseline] coupling_force_n``) stays
what the case says.

The load is in horsepower at the edge because that is how the rigs document it (one hp = 745.7 W).
"""

from __future__ import annotations

import numpy as np

__all__ = ["LOAD_KEYS", "HP_W", "load_table_problem", "speed_at_load_hz"]

#: the ``[operating]`` keys of a load table (both or neither)
LOAD_KEYS = ("load_hp", "load_speed_hz")
#: one mechanical horsepower [W]
HP_W = 745.69987


def load_table_problem(operating: dict) -> tuple[str, str] | None:
    """The first rule a load table in ``[operating]`` breaks, as (key, why), or None (also without a table).

    Each key alone is checked by the case's schema (numbers, load >= 0, speed > 0); here: both keys together, one
    speed per load, loads increasing, every speed within the operating range."""
    loads, speeds = operating.get("load_hp"), operating.get("load_speed_hz")
    if loads is None and speeds is None:
        return None
    if loads is None or speeds is None:
        missing = "load_hp" if loads is None else "load_speed_hz"
        return missing, "missing (a load table needs the loads and the speed at each: load_hp and load_speed_hz)"
    if len(loads) == 0:
        return "load_hp", "must list at least one load"
    if len(speeds) != len(loads):
        return "load_speed_hz", f"needs one speed per load: {len(loads)} (got {len(speeds)})"
    if any(b <= a for a, b in zip(loads, loads[1:])):
        return "load_hp", f"loads must increase (got {list(loads)})"
    top = operating.get("max_speed_hz")
    if isinstance(top, (int, float)) and max(speeds) > top:
        return "load_speed_hz", f"{max(speeds):g} Hz is above the operating range's highest speed ({top:g} Hz)"
    return None


def speed_at_load_hz(operating: dict, load_hp: float) -> float:
    """Shaft speed [Hz] at a load [hp] by the case's load table (linear between its points).

    Raises
    ------
    ValueError
        The case has no load table, or the load is not a finite number within the table's loads (the message
        says which and gives the table's range).
    """
    loads, speeds = operating.get("load_hp"), operating.get("load_speed_hz")
    if loads is None or speeds is None:
        raise ValueError("the case has no load table (its [operating] or [machine] needs load_hp and "
                         "load_speed_hz): give the speed instead")
    x = float(load_hp)
    if not (np.isfinite(x) and loads[0] <= x <= loads[-1]):
        raise ValueError(f"{load_hp!r} hp is outside the case's load table ({loads[0]:g} .. {loads[-1]:g} hp)")
    return float(np.interp(x, loads, speeds))
