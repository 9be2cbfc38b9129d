"""What ships with bkabem, one line each: the embedded cases, scenarios and data-set specs.

Each is a TOML file of this package read by its name (``Case.load("motor_6010_inner")``,
``Scenario.load("de_outer_run_to_failure")``, ``DatasetSpec.load("dataset_example")``); its one-line description is
the file's own (``[case]``, ``[scenario]`` or ``[fleet]``, ``[dataset]`` ``description``). Reading the list
parses the TOML files only: no model is made.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources

__all__ = ["KINDS", "Entry", "embedded_files"]

#: Folder of each kind of embedded file, in the order they are listed.
KINDS = ("cases", "scenarios", "datasets")
#: The TOML tables whose ``description`` describes a file of each kind (the first present).
_TABLES = {"cases": ("case",), "scenarios": ("scenario", "fleet"), "datasets": ("dataset",)}
#: How each kind is used from the command line.
USE = {"cases": "--case NAME (excitation, spectrum, sweep, validate, synth, node)",
       "scenarios": "--scenario NAME (synth, node, fleet)",
       "datasets": "bkabem dataset NAME --out DIR"}


@dataclass(frozen=True)
class Entry:
    """One embedded file: ``kind`` (:data:`KINDS`), ``name`` (what ``load`` takes), ``description`` (one line),
    ``table`` (``"scenario"`` or ``"fleet"`` for a scenario file)."""

    kind: str
    name: str
    description: str
    table: str


def embedded_files(kinds=KINDS) -> list[Entry]:
    """Every embedded file of ``kinds``, by kind and name."""
    out = []
    for kind in kinds:
        if kind not in _TABLES:
            raise ValueError(f"kind: one of {', '.join(KINDS)} (got {kind!r})")
        folder = resources.files("bkabem_core.embedded").joinpath(kind)
        for item in sorted(folder.iterdir(), key=lambda p: p.name):
            if not item.name.endswith(".toml"):
                continue
            raw = tomllib.loads(item.read_text())
            table = next((t for t in _TABLES[kind] if isinstance(raw.get(t), dict)), _TABLES[kind][0])
            text = " ".join(str(raw.get(table, {}).get("description", "")).split())
            out.append(Entry(kind, item.name[:-len(".toml")], text, table))
    return out
