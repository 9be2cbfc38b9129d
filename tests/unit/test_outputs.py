"""Every output of the core commands gives the library's numbers, for every defect kind of the fault library.

``bkabem sweep`` (table, ``--json``, ``--csv``, ``--jsonl``), ``bkabem spectrum`` (table, ``--json``) and ``bkabem
excitation`` (table, ``--json``) on ``motor_6010_{outer, inner, ball, healthy}`` against
:class:`bkabem_core.solve.harmonic.BkaBem` of the same case: line by line, each line at its frequency, named by what
it is. The commands run in this process (``bkabem_ros.cli.main.main``) on the models of the session (the command's
model preparation is what every other test covers). The figures (``--png``) and the outputs beside them:
tests/integration/test_output_figures.py.
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
from outputs_check import KINDS, SPEEDS, SWEEP, library_sweep

from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS


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
def test_sweep_json_is_the_library(kind, cli, fault_library):
    model = fault_library[kind]
    sw, acc, rms = library_sweep(model)
    d = json.loads(cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP, "--json"))
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
def test_sweep_table_is_the_library(kind, cli, fault_library):
    model = fault_library[kind]
    _, _, rms = library_sweep(model)
    out = cli("sweep", "--case", f"motor_6010_{kind}", *SWEEP)
    assert f"x {len(model.lines)} lines" in out
    rows = [ln.split() for ln in out.splitlines() if ln.strip() and ln.split()[0].replace(".", "").isdigit()]
    assert [float(r[0]) for r in rows] == list(SPEEDS)
    for si, r in enumerate(rows):
        got = np.array([[float(v) for v in cell.split("/")] for cell in r[1:]])          # (4 locations, 2)
        np.testing.assert_allclose(got, rms[si], rtol=1e-4)


@pytest.mark.parametrize("kind", KINDS)
def test_sweep_csv_and_jsonl_are_the_library(kind, cli, fault_library):
    model = fault_library[kind]
    sw, acc, _ = library_sweep(model)
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
def test_spectrum_json_and_table_are_the_library(kind, cli, fault_library):
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
    out = cli("spectrum", "--case", f"motor_6010_{kind}", "--speed-hz", "25")
    band = np.flatnonzero(sp.frequency_hz <= model.band_hz)                   # the lines the case's band holds
    largest = band[np.argsort(-acc[band].reshape(len(band), -1).max(axis=1), kind="stable")[:min(12, len(band))]]
    for i in largest:
        row = next((ln for ln in out.splitlines() if ln.strip().startswith(sp.labels[i] + " ")
                    and f"{sp.frequency_hz[i]:9.2f}" in ln), None)
        assert row is not None, (sp.labels[i], out)
        assert f"{acc[i, 1, 0]:13.4e}/{acc[i, 1, 1]:.4e}" in row
    assert "order 0" not in out and "     0 " not in out


@pytest.mark.parametrize("kind", KINDS)
def test_excitation_json_names_every_line(kind, cli, fault_library):
    from bkabem_core.excitation.line_names import line_labels

    ex = fault_library[kind].excitations["de"]
    ls = ex.line_set()
    d = json.loads(cli("excitation", "--case", f"motor_6010_{kind}", "--json"))
    names = line_labels(ls.coefficients, ex.n_balls)
    assert d["lines"]["names"] == names and d["bearings"]["de"]["lines"]["names"] == names
    np.testing.assert_allclose(d["lines"]["amplitude"]["vertical"], np.abs(ls.amplitude[:, 0]), rtol=1e-12)


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
