"""Input files: what a command can read as a file, the text of an embedded or a user's TOML file, its tables, and
the error every kind of input file raises (stdlib only: the command line checks its inputs with it before it
imports the physics)."""

from __future__ import annotations

import stat
import tomllib
from importlib import resources
from pathlib import Path

__all__ = ["InputFileError", "embedded_names", "not_a_file", "parse_toml", "read_input_text"]


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


class InputFileError(ValueError):
    """An input file (case, scenario, data-set spec) is invalid: ``key`` is the dotted key at fault (or the file),
    ``reason`` says why, ``source`` names the file. Each kind of file raises its own subclass."""

    def __init__(self, key: str, reason: str, source: str = ""):
        self.key = key
        self.reason = reason
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{key}: {reason}")


def embedded_names(folder: str) -> list[str]:
    """Names of the TOML files shipped in the package folder ``folder`` (``cases``, ``scenarios``, ``datasets``)."""
    try:
        files = resources.files("bkabem_core.embedded").joinpath(folder).iterdir()
    except FileNotFoundError:
        return []
    return sorted(p.name[:-5] for p in files if p.name.endswith(".toml"))


def read_input_text(name_or_path: str | Path, folder: str, what: str, key: str,
                    error: type[InputFileError]) -> tuple[str, str, Path | None]:
    """(text, source, base directory) of an input file: the embedded ``<folder>/<name>.toml`` when
    ``name_or_path`` is a bare name (no ``.toml`` suffix, no ``/``, no such file here), else the file at that
    path (UTF-8). ``source`` is ``"embedded:<name>"`` or the path; the base directory (for paths inside the
    file) is None for an embedded file. Errors are ``error`` for ``key`` ("no embedded <what> named ...",
    "file not found", "cannot read") or for ``toml`` (not UTF-8); an empty name is refused."""
    s = str(name_or_path)
    if not s.strip():
        raise error(key, "empty name")
    if not s.endswith(".toml") and "/" not in s and not Path(s).exists():
        try:
            text = resources.files("bkabem_core.embedded").joinpath(folder, f"{s}.toml").read_text()
        except FileNotFoundError:
            raise error(key, f"no embedded {what} named {s!r} (available: "
                             f"{', '.join(embedded_names(folder))})") from None
        return text, f"embedded:{s}", None
    p = Path(s)
    why = not_a_file(p)
    if why:
        raise error(key, why)
    try:
        text = p.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error("toml", f"not a UTF-8 text file (byte {exc.start}: {exc.reason})", str(p)) from None
    except OSError as exc:
        raise error(key, f"cannot read {p}: {exc.strerror}") from None
    return text, str(p), p.parent


def parse_toml(text: str, source: str, error: type[InputFileError]) -> dict:
    """The tables of a TOML text; a syntax error or a too deep nesting raises ``error`` for the key ``toml``."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error("toml", f"not valid TOML: {exc}", source) from None
    except RecursionError:
        raise error("toml", "nested too deeply (arrays or tables inside each other)", source) from None
