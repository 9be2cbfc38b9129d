"""The defect kinds bkabem knows: one module of this package each, found here.

Every module of :mod:`bkabem_core.bearing.defects` but this one and :mod:`~bkabem_core.bearing.defects.base` (which
build on the registry) is imported once, and each concrete :class:`~bkabem_core.bearing.defects.protocol.DefectKind`
subclass defined in it becomes a kind, listed in the order of its ``order``. So adding a kind is adding its module::

    >>> from bkabem_core.bearing.defects.registry import KINDS, kind
    >>> KINDS
    ('outer', 'inner', 'ball')
    >>> kind("inner").fault_frequency
    'bpfi'

Case validation, scenario files, data-set specs, the excitation, the improved method, the TDSM, the messages'
ground truth, the fault-line markers, the health texts and the viewer ask here instead of testing names.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

from bkabem_core.bearing.defects.protocol import DefectKey, DefectKind

__all__ = ["KINDS", "find", "kind", "kinds", "kinds_with", "moving_kinds", "own_keys", "periodic_kinds"]

_PACKAGE = __name__.rpartition(".")[0]
#: Modules of the package that are not kinds and import this registry (so are not imported by it).
_BUILT_ON_THE_REGISTRY = ("base", "registry")


def _discover() -> tuple[DefectKind, ...]:
    found: dict[str, DefectKind] = {}
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name in _BUILT_ON_THE_REGISTRY or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{_PACKAGE}.{info.name}")
        for obj in vars(module).values():
            if (inspect.isclass(obj) and issubclass(obj, DefectKind) and not inspect.isabstract(obj)
                    and obj.__module__ == module.__name__):
                k = obj()
                if not k.name or k.name in found:
                    raise RuntimeError(f"defect kind {obj.__name__} in {module.__name__}: its name {k.name!r} is "
                                       f"empty or taken")
                found[k.name] = k
    return tuple(sorted(found.values(), key=lambda k: (k.order, k.name)))


_KINDS = _discover()
_BY_NAME = {k.name: k for k in _KINDS}
#: Names of the kinds, in listing order.
KINDS: tuple[str, ...] = tuple(_BY_NAME)


def kinds() -> tuple[DefectKind, ...]:
    """Every kind, in listing order."""
    return _KINDS


def find(name: str) -> DefectKind | None:
    """The kind of this name, or None (a name bkabem does not simulate, e.g. in a message of another tool)."""
    return _BY_NAME.get(name)


def kind(name: str) -> DefectKind:
    """The kind of this name; ValueError naming the kinds if there is none."""
    found = _BY_NAME.get(name)
    if found is None:
        raise ValueError(f"defect kind: must be one of {', '.join(KINDS)} (got {name!r})")
    return found


def periodic_kinds() -> tuple[DefectKind, ...]:
    """The kinds whose drops repeat with the ball pass (BPFO orders)."""
    return tuple(k for k in _KINDS if k.periodic)


def moving_kinds() -> tuple[DefectKind, ...]:
    """The kinds with phases of their own (a torus each, a general line set)."""
    return tuple(k for k in _KINDS if not k.periodic)


def own_keys() -> tuple[DefectKey, ...]:
    """Every key of a ``[[defects]]`` table that only some kinds have, once each, in listing order."""
    out: dict[str, DefectKey] = {}
    for k in _KINDS:
        for key in k.own_keys:
            out.setdefault(key.name, key)
    return tuple(out.values())


def kinds_with(key: str) -> tuple[DefectKind, ...]:
    """The kinds that have the own key ``key`` (a ``[[defects]]`` key only some kinds have)."""
    return tuple(k for k in _KINDS if any(o.name == key for o in k.own_keys))
