"""The code blocks of README.md and docs/*.md (tests/docs_snippets.py): every block names its language, every
exception to "run it as written" says why, the cheap Python blocks run here, and the commands of the blocks that
cannot run on one test host (other hosts, the user's files) parse with the real command line."""

from __future__ import annotations

import contextlib
import io
import re
import runpy

import pytest
from docs_snippets import NOT_RUN, RUN, bkabem_argv, commands, snippets

ALL = snippets()
KNOWN = ("run", "unit", "each-runs-for", "parse", "skip")


def test_every_block_names_its_language_and_every_exception_its_reason():
    bad = [(s.id, s.lang) for s in ALL if s.lang not in RUN + NOT_RUN]
    assert bad == [], "a code block without a known language: " + repr(bad)
    assert [s.id for s in ALL if s.how not in KNOWN] == []
    assert [s.id for s in ALL if s.how in ("parse", "skip", "each-runs-for") and not s.why] == []
    assert [s.id for s in ALL if s.how == "unit" and s.lang != "python"] == []
    assert len([s for s in ALL if s.lang in RUN]) >= 15


@pytest.mark.parametrize("snippet", [s for s in ALL if s.how == "unit"], ids=lambda s: s.id)
def test_cheap_python_blocks_run_as_written(snippet, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "snippet.py"
    path.write_text(snippet.body)
    with contextlib.redirect_stdout(io.StringIO()):
        runpy.run_path(str(path), run_name="__main__")


@pytest.mark.parametrize("snippet", [s for s in ALL if s.how == "parse"], ids=lambda s: s.id)
def test_commands_of_blocks_for_other_hosts_parse(snippet, tmp_path, monkeypatch):
    from bkabem_ros.cli.main import build_parser

    monkeypatch.chdir(tmp_path)
    parsed = 0
    for cmd in commands(snippet.body):
        argv = bkabem_argv(re.sub(r"^[\w .-]*\$\s+", "", cmd))             # without a prompt ("host A$ ")
        if argv is None:
            continue
        try:
            build_parser().parse_args(argv)
        except SystemExit as exc:
            pytest.fail(f"{snippet.id}: `bkabem {' '.join(argv)}` does not parse (exit {exc.code})")
        parsed += 1
    assert parsed, f"{snippet.id}: no bkabem command to parse"
