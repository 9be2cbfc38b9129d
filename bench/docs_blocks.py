"""The generated blocks of the docs: a bench script writes its table between ``<!-- BEGIN name -->`` and
``<!-- END name -->`` of a page, and nothing else of the page."""

from __future__ import annotations

import re


def replace_block(text: str, name: str, body: str, page: str = "the page") -> str:
    """``text`` with the block ``name`` holding ``body``; SystemExit naming ``page`` if the block is missing."""
    pat = re.compile(rf"(<!-- BEGIN {re.escape(name)} -->\n)(.*?)(<!-- END {re.escape(name)} -->)", re.S)
    if not pat.search(text):
        raise SystemExit(f"{page} has no block {name!r}")
    return pat.sub(lambda m: m.group(1) + body.rstrip() + "\n" + m.group(3), text)
