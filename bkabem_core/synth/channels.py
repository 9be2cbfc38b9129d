"""The synthesiser's channels and the displacement combinations they read.

Per bearing and direction: ``acceleration`` of the housing [m/s^2] (accelerometer), ``displacement`` of the shaft
relative to the housing [m] (proximity probe), optionally ``velocity`` of the housing [mm/s]. Names
``<bearing>_<direction>_<quantity>``, e.g. ``de_vertical_acceleration``. A channel is a displacement combination of
the model's outputs (:data:`~bkabem_core.model.vocabulary.LOCATIONS` x
:data:`~bkabem_core.model.vocabulary.DIRECTIONS`) times ``(i omega)^p`` and a unit scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bkabem_core.model.vocabulary import BEARINGS, DIRECTIONS, LOCATIONS
from bkabem_core.synth.profile import SynthError

#: quantity -> (unit, power of (i omega) applied to the displacement amplitude, scale to the unit)
QUANTITIES = {
    "acceleration": ("m/s^2", 2, 1.0),
    "displacement": ("m", 0, 1.0),
    "velocity": ("mm/s", 1, 1.0e3),
}
DEFAULT_QUANTITIES = ("acceleration", "displacement")


@dataclass(frozen=True)
class Channel:
    name: str
    bearing: str
    direction: str
    quantity: str
    unit: str


def make_channels(quantities=DEFAULT_QUANTITIES) -> tuple[Channel, ...]:
    """Channels in a fixed order: bearing (de, nde) > quantity (as given) > direction (vertical, horizontal)."""
    if isinstance(quantities, str):
        quantities = [q.strip() for q in quantities.split(",") if q.strip()]
    quantities = list(quantities)
    if not quantities:
        raise SynthError("quantities", "at least one of acceleration, displacement, velocity")
    for q in quantities:
        if q not in QUANTITIES:
            raise SynthError("quantities", f"unknown quantity {q!r} (use acceleration, displacement, velocity)")
    if len(set(quantities)) != len(quantities):
        raise SynthError("quantities", "listed twice")
    return tuple(Channel(f"{b}_{d}_{q}", b, d, q, QUANTITIES[q][0])
                 for b in BEARINGS for q in quantities for d in DIRECTIONS)


def _combination(channels):
    """The distinct displacement combinations the channels need, as rows (U, 8) over the 8 output displacements
    (LOCATIONS x DIRECTIONS): housing displacement (acceleration, velocity) and rotor minus housing (displacement).
    Returns the rows, per channel the row index, power p of (i omega) and unit scale, and the rows of the housing
    displacements (DE/NDE x vertical/horizontal) that the ISO 10816 velocity needs."""
    def col(loc, d):
        return LOCATIONS.index(loc) * len(DIRECTIONS) + DIRECTIONS.index(d)

    keys: list[tuple] = []
    rows = []

    def row_of(b, d, relative):
        key = (b, d, relative)
        if key not in keys:
            r = np.zeros(len(LOCATIONS) * len(DIRECTIONS))
            r[col(f"{b}_housing", d)] = -1.0 if relative else 1.0
            if relative:
                r[col(f"{b}_rotor", d)] = 1.0
            keys.append(key)
            rows.append(r)
        return keys.index(key)

    index, power, scale = [], [], []
    for c in channels:
        index.append(row_of(c.bearing, c.direction, c.quantity == "displacement"))
        power.append(QUANTITIES[c.quantity][1])
        scale.append(QUANTITIES[c.quantity][2])
    iso = [row_of(b, d, False) for b in BEARINGS for d in DIRECTIONS]
    return np.array(rows), np.array(index), np.array(power), np.array(scale), np.array(iso)


class ChannelMap:
    """How a set of channels reads the model (read-only arrays).

    Attributes
    ----------
    channels : tuple of Channel
    combination : ndarray (U, 8)
        The distinct displacement combinations of the model's outputs the channels read.
    cindex, power, scale : ndarray (C,)
        Per channel its combination row, power of (i omega) and unit scale.
    iso_rows : ndarray (4,)
        The combinations of the housing displacements DE/NDE x vertical/horizontal (ISO 10816 velocity).
    housing_columns : ndarray
        The combinations that are housing displacements alone (where a sensor of the housing's motion acts).
    """

    def __init__(self, channels):
        self.channels = tuple(channels)
        self.names = tuple(c.name for c in self.channels)
        self.units = tuple(c.unit for c in self.channels)
        comb, index, power, scale, iso = _combination(self.channels)
        self.combination, self.cindex, self.power, self.scale, self.iso_rows = comb, index, power, scale, iso
        self.housing_columns = np.flatnonzero((comb != 0).sum(axis=1) == 1)
        for a in (comb, index, power, scale, iso, self.housing_columns):
            a.flags.writeable = False

    def __len__(self) -> int:
        return len(self.channels)

    def static_part(self, model) -> np.ndarray:
        """(C,) the channels' static part [channel units]: the displacement channels' DC, 0 for the others."""
        dc8 = np.asarray(model.dc_m).reshape(-1)
        return (self.combination @ dc8)[self.cindex] * (self.power == 0)
