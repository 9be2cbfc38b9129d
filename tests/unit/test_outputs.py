"""Every output of the core commands gives the library's numbers, for every defect kind of the fault library.

``bkabem sweep`` (table, ``--json``, ``--csv``, ``--jsonl``, with and without ``--png``), ``bkabem spectrum``
(table, ``--json``, the figure's data) and ``bkabem excitation`` (table) on ``motor_6010_{outer, inner, ball,
healthy}`` against :class:`bkabem_core.solve.harmonic.BkaBem` of the same case: line by line, each line at its
frequency, named by what it is. The commands run in this process (``bkabem_ros.cli.main.main``) on the models of
the session (the command's model preparation is what every other test covers).
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS

KINDS = ("outer", "inner", "ball", "healthy")
SPEEDS = (5.0, 25.0, 45.0)
SWEEP = ["--from-hz", "5", "--to-hz", "45", "--steps", "3"]


@pytest.fixture
def cli(monkeypatch, fault_library, capsys):
    """``cli(*argv) -> stdout`` of ``bkabem argv`` in this process, on the session's fault-library models."""
    from bkabem_ros.cli import core as core_cli
    from bkabem_ros.cli.main import main

    by_name = {f"motor_6010_{k}": m for k, m in fault_library.items()}
    monkeypatch.setattr(core_cli, "_model", lambda case, solver="modal": by_name[case.name])

    def run(*argv):
        capsys.readouterr()
        rc = main(list(argv))
        out = capsys.readouterr()
        assert rc == 0, out.err
        return out.out

    return run


@pytest.fixture
def figures(monkeypatch):
    """The figures the commands draw (the plotting functions return them): name -> [Figure]."""
    from bkabem_core.analysis import plots

    seen: dict[str, list] = {}
    for name in ("plot_spectrum", "plot_sweep", "plot_excitation"):
        real = getattr(plots, name)

        def wrapped(*a, _real=real, _name=name, **kw):
            fig = _real(*a, **kw)
            seen.setdefault(_name, []).append(fig)
            return fig

        monkeypatch.setattr(plots, name, wrapped)
    return seen


def _library_sweep(model):
    sw = model.sweep(np.array(SPEEDS))
    return sw, np.abs(sw.acceleration), sw.rms("acceleration")


def test_line_names_say_what_a_line_is():
    from bkabem_core.excitation.line_names import line_family, line_label

    z = 14
    assert line_label((z - 1, -z, 0, 0), z) == "BPFI - 1 f_r"
    assert line_label((3 * z + 2, -3 * z, 0, 0), z) == "3 BPFI + 2 f_r"
    assert line_label((0, 1, 2, 0), z) == "2 BSF + FTF"
    assert line_label((0, -1, 30, 0), z) == "30 BSF - FTF"
    assert line_label((1, 0, 0, 0), z) == "1x" and line_label((2, 0, 0, 0), z) == "2x"
    assert line_label((0, z, 0, 0), z) == "BPFO" and line_label((0, 7 * z, 0, 0), z) == "7 BPFO"
    assert line_label((0, 1, 0, 0), z) == "FTF" and line_label((0, 0, 0, 2), z) == "2 f_line"
    assert line_label((0, 0, 0, 0), z) == "DC"
    assert [line_family(c, z) for c in ((z + 1, -z, 0, 0), (0, 2 * z, 0, 0), (0, 1, 4, 0), (3, 0, 0, 0))] == \
        ["BPFI", "BPFO", "BSF", "1x"]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("png", [False, True], ids=["", "png"])
def test_sweep_json_is_the_library(kind, png, cli, fault_library, tmp_path):
    model = fault_library[kind]
    sw, acc, rms = _library_sweep(model)
    argv = ["sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--json"]
    if png:
        argv += ["--png", str(tmp_path / "s.png")]
    d = json.loads(cli(*argv))
    assert d["speeds_hz"] == list(SPEEDS)
    assert d["lines"] == list(model.line_labels) and len(d["lines"]) == len(model.lines)
    np.testing.assert_allclose(d["frequency_hz"], sw.frequency_hz, rtol=1e-12)
    assert np.all(np.asarray(d["frequency_hz"]) > 0)                     # no line at 0 Hz
    for li, loc in enumerate(LOCATIONS):
        for di, direction in enumerate(DIRECTIONS):
            e = d[loc][direction]
            np.testing.assert_allclose(e["acceleration_m_s2"], acc[:, :, li, di], rtol=1e-12, atol=0)
            np.testing.assert_allclose(e["rms_acceleration_m_s2"], rms[:, li, di], rtol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("png", [False, True], ids=["", "png"])
def test_sweep_table_is_the_library(kind, png, cli, fault_library, tmp_path):
    model = fault_library[kind]
    _, _, rms = _library_sweep(model)
    argv = ["sweep", "--case", f"motor_6010_{kind}", *SWEEP] + (["--png", str(tmp_path / "s.png")] if png else [])
    out = cli(*argv)
    assert f"x {len(model.lines)} lines" in out
    rows = [ln.split() for ln in out.splitlines() if ln.strip() and ln.split()[0].replace(".", "").isdigit()]
    assert [float(r[0]) for r in rows] == list(SPEEDS)
    for si, r in enumerate(rows):
        got = np.array([[float(v) for v in cell.split("/")] for cell in r[1:]])          # (4 locations, 2)
        np.testing.assert_allclose(got, rms[si], rtol=1e-4)


@pytest.mark.parametrize("kind", KINDS)
def test_sweep_csv_and_jsonl_are_the_library(kind, cli, fault_library):
    model = fault_library[kind]
    sw, acc, _ = _library_sweep(model)
    f = sw.frequency_hz
    labels = model.line_labels                          # a property that names every line again on each call
    rows = list(csv.DictReader(io.StringIO(cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--csv"))))
    assert len(rows) == len(SPEEDS) * len(model.lines) * 8
    for r in rows[:: max(1, len(rows) // 997)]:
        si = SPEEDS.index(float(r["speed_hz"]))
        assert r["line"] in labels, r
        li, di = LOCATIONS.index(r["location"]), DIRECTIONS.index(r["direction"])
        cand = [k for k, label in enumerate(labels) if label == r["line"]
                and np.isclose(f[si, k], float(r["frequency_hz"]), rtol=1e-5)]
        assert cand, r
        assert any(np.isclose(acc[si, k, li, di], float(r["acceleration_m_s2"]), rtol=1e-5, atol=1e-300)
                   for k in cand), r
    for si, line in enumerate(cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--jsonl").splitlines()):
        row = json.loads(line)
        assert row["lines"] == list(labels)
        np.testing.assert_allclose(row["frequency_hz"], f[si], rtol=1e-12)
        for li, loc in enumerate(LOCATIONS):
            for di, direction in enumerate(DIRECTIONS):
                np.testing.assert_allclose(row[loc][direction]["acceleration_m_s2"], acc[si, :, li, di], rtol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_sweep_figure_draws_the_library(kind, cli, fault_library, figures, tmp_path):
    model = fault_library[kind]
    sw, acc, rms = _library_sweep(model)
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
def test_spectrum_json_table_and_figure_are_the_library(kind, cli, fault_library, figures, tmp_path):
    from bkabem_core.analysis.plots import DISPLAY_FLOOR

    model = fault_library[kind]
    sp = model.spectrum(25.0)
    acc = np.abs(sp.acceleration)
    d = json.loads(cli("spectrum", "--case", f"motor_6010_{kind}", "--speed-hz", "25", "--json"))
    assert d["lines"] == list(model.line_labels)
    for li, loc in enumerate(LOCATIONS):
        for di, direction in enumerate(DIRECTIONS):
            np.testing.assert_allclose(d[loc][direction]["frequency_hz"], sp.frequency_hz, rtol=1e-12)
            np.testing.assert_allclose(d[loc][direction]["acceleration_m_s2"], acc[:, li, di], rtol=1e-12)
    # the table: the largest lines, named, with their amplitudes
    out = cli("spectrum", "--case", f"motor_6010_{kind}", "--speed-hz", "25", "--png", str(tmp_path / "p.png"))
    band = np.flatnonzero(sp.frequency_hz <= model.band_hz)                   # the lines the case's band holds
    largest = band[np.argsort(-acc[band].reshape(len(band), -1).max(axis=1), kind="stable")[:min(12, len(band))]]
    for i in largest:
        row = next((ln for ln in out.splitlines() if ln.strip().startswith(sp.labels[i] + " ")
                    and f"{sp.frequency_hz[i]:9.2f}" in ln), None)
        assert row is not None, (sp.labels[i], out)
        assert f"{acc[i, 1, 0]:13.4e}/{acc[i, 1, 1]:.4e}" in row
    assert "order 0" not in out and "     0 " not in out
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
def test_excitation_json_and_figure_name_every_line(kind, cli, fault_library, figures, tmp_path):
    from bkabem_core.analysis.plots import DISPLAY_FLOOR
    from bkabem_core.excitation.line_names import line_labels

    ex = fault_library[kind].excitations["de"]
    ls = ex.line_set()
    d = json.loads(cli("excitation", "--case", f"motor_6010_{kind}", "--json"))
    names = line_labels(ls.coefficients, ex.n_balls)
    assert d["lines"]["names"] == names and d["bearings"]["de"]["lines"]["names"] == names
    np.testing.assert_allclose(d["lines"]["amplitude"]["vertical"], np.abs(ls.amplitude[:, 0]), rtol=1e-12)
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


@pytest.mark.parametrize("kind", KINDS)
def test_excitation_table_lists_the_largest_lines_by_name(kind, cli, fault_library):
    ex = fault_library[kind].excitations["de"]
    ls = ex.line_set()
    out = cli("excitation", "--case", f"motor_6010_{kind}")
    de = out.split("\n\n")[0]
    from bkabem_core.excitation.line_names import line_label

    amp = np.abs(ls.amplitude).max(axis=1)
    for i in np.argsort(-amp, kind="stable")[:5]:
        label = line_label(ls.coefficients[i], ex.n_balls)
        assert any(ln.strip().startswith(label + " ") and f"{abs(ls.amplitude[i, 0]) * 1e6:10.4f}" in ln
                   for ln in de.splitlines()), (label, de)
