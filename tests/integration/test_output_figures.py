"""The figures of the core commands draw the library's numbers, and drawing them changes no output: ``bkabem
sweep --png`` (the line map and the RMS), ``bkabem spectrum --png`` (every stem at its line's frequency and height,
the fault frequencies marked, the largest lines named), ``bkabem excitation --png`` and ``bkabem synth``'s figure,
on ``motor_6010_{outer, inner, ball, healthy}`` (the outputs without figures: tests/unit/test_outputs.py). Slow:
each figure is a few seconds of matplotlib."""

from __future__ import annotations

import json

import numpy as np
import pytest
from outputs_check import KINDS, SPEEDS, SWEEP, library_sweep

from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("kind", KINDS)
def test_sweep_json_and_table_with_a_figure_are_the_library(kind, cli, fault_library, tmp_path):
    model = fault_library[kind]
    sw, acc, rms = library_sweep(model)
    d = json.loads(cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--json", "--png", str(tmp_path / "s.png")))
    assert d["lines"] == list(model.line_labels)
    for li, loc in enumerate(LOCATIONS):
        for di, direction in enumerate(DIRECTIONS):
            np.testing.assert_allclose(d[loc][direction]["acceleration_m_s2"], acc[:, :, li, di], rtol=1e-12, atol=0)
            np.testing.assert_allclose(d[loc][direction]["rms_acceleration_m_s2"], rms[:, li, di], rtol=1e-12)
    out = cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--png", str(tmp_path / "t.png"))
    rows = [ln.split() for ln in out.splitlines() if ln.strip() and ln.split()[0].replace(".", "").isdigit()]
    assert [float(r[0]) for r in rows] == list(SPEEDS)
    for si, r in enumerate(rows):
        got = np.array([[float(v) for v in cell.split("/")] for cell in r[1:]])
        np.testing.assert_allclose(got, rms[si], rtol=1e-4)
    assert (tmp_path / "s.png").stat().st_size > 0 and (tmp_path / "t.png").stat().st_size > 0


@pytest.mark.parametrize("kind", KINDS)
def test_sweep_figure_draws_the_library(kind, cli, fault_library, figures, tmp_path):
    model = fault_library[kind]
    sw, acc, rms = library_sweep(model)
    cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--png", str(tmp_path / "s.png"))
    fig = figures["plot_sweep"][-1]
    line_map, rms_axes = fig.axes[0], fig.axes[1]
    drawn = line_map.collections[0].get_offsets()                             # (frequency, speed) of every dot
    db = 20 * np.log10(np.maximum(acc[:, :, 1, 0], 1e-12))                      # de_housing vertical, as drawn
    shown = db >= db.max() - 80
    want = {(round(float(sw.frequency_hz[si, k]), 6), s) for si, s in enumerate(SPEEDS)
            for k in np.flatnonzero(shown[si])}
    got = {(round(float(x), 6), float(y)) for x, y in drawn}
    assert got == want and all(x > 0 for x, _ in got)
    de_housing_v = rms_axes.get_lines()[2]
    assert de_housing_v.get_label() == "de housing vertical"
    np.testing.assert_allclose(de_housing_v.get_ydata(), rms[:, 1, 0], rtol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_spectrum_figure_draws_the_library(kind, cli, fault_library, figures, tmp_path):
    from bkabem_core.analysis.plots import DISPLAY_FLOOR

    model = fault_library[kind]
    sp = model.spectrum(25.0)
    acc = np.abs(sp.acceleration)
    cli("spectrum", "--case", f"motor_6010_{kind}", "--speed-hz", "25", "--png", str(tmp_path / "p.png"))
    # the figure: every stem at its line's frequency and height, the fault frequencies marked
    fig = figures["plot_spectrum"][-1]
    full_band = [ax for ax in fig.axes if ax.get_title().endswith("acceleration")]
    assert [ax.get_title() for ax in full_band] == [f"{loc.replace('_', ' ')} acceleration" for loc in LOCATIONS]
    in_band = sp.frequency_hz <= model.band_hz
    for li, ax in enumerate(full_band):
        floor = acc[in_band, li].max() * DISPLAY_FLOOR
        for di, direction in enumerate(DIRECTIONS):
            (mark,) = [ln for ln in ax.get_lines() if ln.get_label() == direction]
            keep = (acc[:, li, di] >= floor) & in_band
            np.testing.assert_allclose(mark.get_xdata(), sp.frequency_hz[keep], rtol=1e-12)
            np.testing.assert_allclose(mark.get_ydata(), acc[keep, li, di], rtol=1e-12)
        dashed = sorted(round(ln.get_xdata()[0], 6) for ln in ax.get_lines() if ln.get_linestyle() == "--")
        ff = sp.fault_frequencies_hz
        for f0 in (25.0, ff.ftf, ff.bpfo, ff.bpfi, ff.bsf, 2 * ff.bsf):
            assert round(f0, 6) in dashed
        named = {t.get_text() for t in ax.texts}
        assert named and named <= set(sp.labels)
        assert sp.labels[int(np.argmax(np.where(in_band, acc[:, li].max(axis=1), 0)))] in named   # the largest
    assert "BPFO 151.5 Hz)" not in fig._suptitle.get_text() or "BPFI" in fig._suptitle.get_text()


@pytest.mark.parametrize("kind", KINDS)
def test_excitation_figure_names_every_line(kind, cli, fault_library, figures, tmp_path):
    from bkabem_core.analysis.plots import DISPLAY_FLOOR
    from bkabem_core.excitation.line_names import line_labels

    ex = fault_library[kind].excitations["de"]
    ls = ex.line_set()
    names = line_labels(ls.coefficients, ex.n_balls)
    cli("excitation", "--case", f"motor_6010_{kind}", "--png", str(tmp_path / "e.png"))
    fig = figures["plot_excitation"][-1]
    if ex.lines is None:                                           # BPFO orders: the paper's bars per order
        assert fig.axes[2].get_xlabel() == "BPFO order k"
        return
    lines_ax = fig.axes[2]                                         # line sets: each line at its frequency, named
    (mark,) = [ln for ln in lines_ax.get_lines() if ln.get_label() == "vertical"]
    a = np.abs(ls.amplitude[:, 0]) * 1e6
    keep = a >= a.max() * DISPLAY_FLOOR
    np.testing.assert_allclose(mark.get_xdata(), ls.frequency_hz(ex.reference_speed_hz)[keep], rtol=1e-12)
    assert {t.get_text() for t in lines_ax.texts} <= set(names) and names[int(np.argmax(a))] in \
        {t.get_text() for t in lines_ax.texts}


def test_synth_figure_marks_the_fault_frequencies_and_names_the_lines(fault_library, tmp_path):
    from bkabem_core.synth.synthesizer import Synthesizer
    from bkabem_ros.cli.synth import _plot

    model = fault_library["inner"]
    s = Synthesizer(model, sample_rate_hz=25600.0, chunk_s=0.25, features=False)
    x = np.concatenate([c.samples for c in s.render("constant:25", 0.5)], axis=1)
    fig = _plot(tmp_path / "s.png", x, 25600.0, s, 25.0, "inner")
    ax = fig.axes[1]
    assert "BPFO orders" not in ax.get_xlabel() and "fault frequencies" in ax.get_xlabel()
    dashed = {round(float(ln.get_xdata()[0]), 6) for ln in ax.get_lines() if ln.get_linestyle() == "--"}
    bpfi = model.fault_multipliers.bpfi * 25.0
    assert {round(h * bpfi, 6) for h in (1, 2, 3)} <= dashed       # the defect's line, at 1-3x, where it is
    assert {t.get_text() for t in ax.texts} <= set(model.line_labels) and len(ax.texts) >= 3
