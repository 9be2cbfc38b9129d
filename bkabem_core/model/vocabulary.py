"""The shared vocabulary of bkabem: the names every layer uses for bearing positions, directions and locations.

One definition, imported everywhere (case, excitation, FE, solve, TDSM, synthesis, messages), so that a position or
a location is spelt once.

``BEARINGS``
    The bearing positions of a machine: ``"de"`` (drive end) and ``"nde"`` (non-drive end).
``DIRECTIONS``
    The lateral directions of every output: ``"vertical"`` (y, gravity along -y) and ``"horizontal"`` (x).
``LOCATIONS``
    The response locations of the harmonic solve and the TDSM: the rotor (shaft) and the housing at each bearing.
"""

from __future__ import annotations

__all__ = ["BEARINGS", "DIRECTIONS", "LOCATIONS"]

BEARINGS = ("de", "nde")
DIRECTIONS = ("vertical", "horizontal")
LOCATIONS = ("de_rotor", "de_housing", "nde_rotor", "nde_housing")
