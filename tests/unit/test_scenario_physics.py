"""Why the acceleration RMS of ``de_outer_run_to_failure`` falls while its dent grows (docs/scenarios.md): the zero
of the dent's pulse spectrum (``f T`` ~ 1.1, ``T = L / v`` the time a ball takes to cross it) sweeps across the
machine's modes near 1 kHz. The numbers of the docs' table are recomputed here from the scenario's states."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"
SPEED_HZ = 24.6
LINE_HZ = 1043.5                                       # 7 x BPFO at 24.6 Hz, beside the modes at 1007 and 1037 Hz
IN_BAND_HZ = 0.85 * 25600.0 / 2                        # lines a 25.6-kHz acquisition carries fully


def _table() -> list[tuple[float, float, float, float, float, float, float]]:
    """(t [h], L [mm], d [um], f T, excitation [nm], its acceleration, RMS [m/s^2]) of the docs' table."""
    text = DOC.read_text()
    rows = re.findall(r"^\| ([\d.]+) h \| ([\d.]+) mm × ([\d.]+) µm \| ([\d.]+) \| ([\d.]+) nm \| ([\d.]+) m/s² \| "
                      r"([\d.]+) m/s² \|$", text, flags=re.M)
    return [tuple(float(v) for v in r) for r in rows]


@pytest.fixture(scope="module")
def states(cached_model):
    from bkabem_core.scenario.timeline import Scenario

    s = Scenario.load("de_outer_run_to_failure")
    out, base = {}, None
    for t_h, *_ in _table():
        st = next(x for x in s.states if math.isclose(x.start_s / 3600, t_h, abs_tol=0.006))
        m = cached_model(st.case, like=base)
        base = base or m
        out[t_h] = (st, m)
    return out


def test_the_docs_table_is_the_model(states):
    rows = _table()
    assert len(rows) == 7
    for t_h, length_mm, depth_um, ft, exc_nm, acc_line, rms in rows:
        st, m = states[t_h]
        d = st.defects[0]
        assert d["length_m"] * 1e3 == pytest.approx(length_mm, abs=0.006)
        assert d["depth_m"] * 1e6 == pytest.approx(depth_um, abs=0.6)
        g = st.case.bearing_geometry("de")
        v = 2 * math.pi * m.fault_multipliers.ftf * SPEED_HZ * (g.pitch_diameter_m + g.ball_diameter_m) / 2
        assert LINE_HZ * d["length_m"] / v == pytest.approx(ft, abs=0.006)
        u = m.bearing_lines["de"]
        k = int(np.argmin(np.abs(u.frequency_hz(SPEED_HZ) - LINE_HZ)))
        assert abs(u.amplitude[k, 0]) * 1e9 == pytest.approx(exc_nm, rel=0.01, abs=0.6)
        sp = m.spectrum(SPEED_HZ)
        a = np.abs(sp.acceleration[:, 1, 0])
        assert a[int(np.argmin(np.abs(sp.frequency_hz - LINE_HZ)))] == pytest.approx(acc_line, abs=0.06)
        band = sp.frequency_hz < IN_BAND_HZ
        assert math.sqrt(0.5 * np.sum(a[band] ** 2)) == pytest.approx(rms, abs=0.06)


def test_the_rms_falls_where_the_pulse_zero_crosses_the_modes(states):
    rows = {r[0]: r for r in _table()}
    assert rows[11.32][6] < 0.75 * rows[9.0][6]                        # RMS falls by > 25 % ...
    assert rows[11.32][2] > 2 * rows[9.0][2]                           # ... while the dent gets twice as deep
    assert rows[11.0][4] < 0.2 * rows[9.45][4]                         # the line by the modes loses 5/6 of its drive
    assert 0.9 < rows[11.0][3] < 1.3                                   # there the pulse's zero is on it
    assert rows[12.0][6] > rows[11.32][6]                              # and past it the first side lobe grows
    _, m = states[9.0]
    modes = m.basis.natural_frequencies_hz
    assert np.any(np.abs(modes - 1007.0) < 15) and np.any(np.abs(modes - 1037.0) < 15)
