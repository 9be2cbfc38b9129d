"""Package faces that import on first use.

A package's ``__init__.py`` is its table of contents: it names what the package offers and in which module each
name is defined. :func:`lazy_face` turns that table into the package's ``__getattr__`` and ``__dir__`` (PEP 562),
so that ``from bkabem_core.synth import Synthesizer`` works while ``import bkabem_core.synth.profile`` does not
import the synthesiser, the FE model and scipy with it: the command line parses its arguments without the physics.

Modules inside the project import from the defining module, never from a face, so that the faces add no import
edges: the import graph stays the data flow.
"""

from __future__ import annotations

import importlib
import sys

__all__ = ["lazy_face"]


def lazy_face(package: str, table: dict[str, str]):
    """``(__getattr__, __dir__)`` of ``package``, whose public names live in its modules.

    Parameters
    ----------
    package : str
        The package's dotted name (its ``__name__``).
    table : dict of str to str
        Public name -> the module of ``package`` that defines it (relative dotted name, e.g. ``"synthesizer"``).

    Returns
    -------
    tuple of callables
        The module-level ``__getattr__`` (imports the defining module on first use and keeps the name in the
        package) and ``__dir__``.
    """

    def __getattr__(name: str):
        try:
            module = table[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__
