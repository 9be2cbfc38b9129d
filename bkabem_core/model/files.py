"""Input paths: what a command can read as a file (stdlib only: the command line checks its inputs with it before
it imports the physics)."""

from __future__ import annotations

import stat
from pathlib import Path

__all__ = ["not_a_file"]


def not_a_file(path, missing: str = "file not found: {path}") -> str | None:
    """Why ``path`` cannot be read as an input file (one phrase naming the path), or None: missing (``missing``
    with ``{path}``), a directory, or not a regular file (a FIFO, socket or device, which a reader would block on
    or read without end)."""
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        return missing.format(path=p)
    except OSError as exc:
        return f"cannot read {p}: {exc.strerror}"
    if stat.S_ISDIR(mode):
        return f"{p} is a directory, not a file"
    if not stat.S_ISREG(mode):
        kind = "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
        return f"{p} is {kind}, not a regular file"
    return None
