"""BENCHMARKS.md is generated (bench/run_all.py): the committed page is what its records and template make, and a
table cell that holds a "|" stays one cell."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench"))

import run_all  # noqa: E402


def test_the_committed_page_is_what_the_records_and_the_template_make():
    """Edit bench/BENCHMARKS.template.md or re-measure, then `bench/run_all.py --render`: a hand edit of
    BENCHMARKS.md is lost at the next run."""
    assert (ROOT / "BENCHMARKS.md").read_text() == run_all.render(run_all.load_records())


def test_a_note_with_a_bar_stays_in_its_cell():
    rec = {"command": "x", "machine": {"cpu": "c", "cores": 2}, "load": [0.1, 0.2], "date": "d", "commit": "k",
           "duration_s": 1.0,
           "rows": {"suite": [{"case": "a", "quantity": "q", "value": 1.0, "fmt": "{:.0f}", "unit": "s",
                               "note": "unit 1 passed | integration 2 passed", "target": "<= 8 min", "met": False}]}}
    table = run_all.render_area("suite", {"suite": rec}).splitlines()
    row = next(ln for ln in table if ln.startswith("| a |"))
    assert row.replace("\\|", "").count("|") == table[0].count("|") and "\\|" in row, row
