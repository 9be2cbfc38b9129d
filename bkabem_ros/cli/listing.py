"""``bkabem list``: what ships with bkabem, one line each (the embedded cases, scenarios and data-set specs).

    bkabem list                    # everything, grouped by kind, with how each kind is used
    bkabem list cases --json       # machine-readable
"""

from __future__ import annotations

import json
import sys

__all__ = ["add_parser", "cmd_list"]

_KINDS = ("cases", "scenarios", "datasets")


def cmd_list(args) -> int:
    from bkabem_core.embedded.listing import USE, embedded_files

    kinds = tuple(args.kinds) or _KINDS
    entries = embedded_files(kinds)
    if args.json:
        json.dump([{"kind": e.kind, "name": e.name, "description": e.description} for e in entries], sys.stdout,
                  indent=1)
        sys.stdout.write("\n")
        return 0
    width = max((len(e.name) for e in entries), default=0)
    for kind in kinds:
        print(f"{kind}: {USE[kind]}")
        for e in (e for e in entries if e.kind == kind):
            tag = " (fleet)" if e.table == "fleet" else ""
            print(f"  {e.name:<{width}}  {e.description}{tag}")
    return 0


def _kind(text: str) -> str:
    import argparse

    if text not in _KINDS:
        raise argparse.ArgumentTypeError(f"KIND must be one of {', '.join(_KINDS)} (got {text!r})")
    return text


def add_parser(sub):
    """Register ``bkabem list`` on an argparse subparsers object."""
    p = sub.add_parser("list", help="what ships with bkabem: embedded cases, scenarios and data-set specs, one line "
                                    "each (start here)")
    p.add_argument("kinds", nargs="*", type=_kind, metavar="KIND",
                   help=f"only these kinds: {', '.join(_KINDS)} (default all)")
    p.add_argument("--json", action="store_true", help="one JSON list of {kind, name, description}")
    p.set_defaults(func=cmd_list)
    return p
