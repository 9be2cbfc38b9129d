"""The code blocks of README.md and docs/*.md, and how the tests run them as written.

Every fenced block names its language. ``python``, ``sh`` and ``bash`` blocks are run; ``console`` blocks (a command
with its output) and ``text`` blocks (output, equations, synopses) and ``toml`` blocks (files) are not. An HTML
comment on the line before a block can say how a block is run, always with the reason after a colon:

``<!-- docs-test: unit -->``
    a cheap pure-Python block: run in the unit tier (the others: tests/integration/test_docs_pages_run.py).
``<!-- docs-test: each-runs-for=S: ... -->``
    a block of servers, one line per terminal: every line is started as its own process; each must still run after
    S seconds (or have ended with exit code 0), then each is interrupted and must stop with exit code 0.
``<!-- docs-test: parse: ... -->``
    commands on other hosts or on the user's own files: every ``bkabem`` command line of the block goes through
    the command line's parser (its options are real), nothing is run.
``<!-- docs-test: skip: ... -->``
    not run here, and why (another test runs it, or it rewrites the repository).

The blocks of one page run in order in one temporary folder (a page's commands make the files its Python reads).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
RUN = ("python", "sh", "bash")
NOT_RUN = ("console", "text", "toml")
_FENCE = re.compile(r"^(?P<indent> *)```(?P<lang>[\w-]*)\s*$")
_DIRECTIVE = re.compile(r"<!--\s*docs-test:\s*(?P<what>[\w-]+)(?:=(?P<value>[\d.]+))?\s*(?::\s*(?P<why>.*?))?\s*-->")


@dataclass(frozen=True)
class Snippet:
    page: Path
    line: int               # 1-based line of the opening fence
    lang: str
    body: str
    how: str = "run"        # run, unit, each-runs-for, parse, skip
    value: float = 0.0
    why: str = ""

    @property
    def id(self) -> str:
        return f"{self.page.name}:{self.line}"


def snippets(pages=PAGES) -> list[Snippet]:
    out = []
    for page in pages:
        lines = page.read_text().splitlines()
        i = 0
        while i < len(lines):
            m = _FENCE.match(lines[i])
            if not m:
                i += 1
                continue
            indent, lang = len(m["indent"]), m["lang"]
            j = i + 1
            while j < len(lines) and not _FENCE.match(lines[j]):
                j += 1
            body = "\n".join(ln[indent:] if ln[:indent].strip() == "" else ln for ln in lines[i + 1:j])
            d = _DIRECTIVE.search(lines[i - 1]) if i > 0 else None
            how, value, why = "run", 0.0, ""
            if d:
                how, value, why = d["what"], float(d["value"] or 0.0), d["why"] or ""
            out.append(Snippet(page, i + 1, lang, body + "\n", how, value, why))
            i = j + 1
    return out


def commands(body: str) -> list[str]:
    """The command lines of a shell block: continuation lines joined, comments, prompts (``host A$``) and
    leading ``VAR=value`` assignments kept as they are written."""
    out, cur = [], ""
    for ln in body.splitlines():
        s = ln.rstrip()
        if cur:
            cur += " " + s.lstrip()
        else:
            cur = s
        if cur.endswith("\\"):
            cur = cur[:-1]
            continue
        if cur.strip() and not cur.lstrip().startswith("#"):
            out.append(cur.strip())
        cur = ""
    return out


def bkabem_argv(command: str) -> list[str] | None:
    """The arguments after ``bkabem`` in a command line (a prompt, variables, ``chrt`` and comments around it
    allowed), or None when the line does not run bkabem."""
    import shlex

    words = shlex.split(command, comments=True)
    if "bkabem" not in words:
        return None
    return words[words.index("bkabem") + 1:]
