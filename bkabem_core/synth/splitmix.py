"""Counter-based random words: the SplitMix64 finaliser and the keys of the synthesiser's random streams.

A stream's value at a position is a pure function of (stream key, position), so a chunk border, a model switch or
a replay from any sample gives the same numbers. The C kernels (``kernels/synth_noise.c``, ``kernels/synth_strike.c``)
use the same finaliser (``mix64``); the functions here are their numpy and Python transcriptions.

    mix64        -- SplitMix64's finaliser of one 64-bit Python integer
    mix64_array  -- the same on uint64 arrays (wrapping arithmetic)
    stream_key   -- the 64-bit key of a run seed's stream named by a tag
"""

from __future__ import annotations

import numpy as np

__all__ = ["GOLDEN", "MASK64", "mix64", "mix64_array", "stream_key"]

#: SplitMix64's increment (2^64 / golden ratio) and the 64-bit mask of Python-integer arithmetic
GOLDEN = 0x9E3779B97F4A7C15
MASK64 = (1 << 64) - 1


def mix64(z: int) -> int:
    """SplitMix64's finaliser of ``z`` (a Python integer in [0, 2^64)): a 64-bit word whose bits all depend on
    all of ``z``'s."""
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9 & MASK64
    z = (z ^ (z >> 27)) * 0x94D049BB133111EB & MASK64
    return z ^ (z >> 31)


def mix64_array(z: np.ndarray) -> np.ndarray:
    """:func:`mix64` of every element of the uint64 array ``z``."""
    with np.errstate(over="ignore"):
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def stream_key(seed: int, tag: int) -> int:
    """The 64-bit key of the stream ``tag`` of run seed ``seed`` (numpy's ``SeedSequence([seed, tag])``: distinct
    tags give independent streams of one seed)."""
    return int(np.random.SeedSequence([int(seed), int(tag)]).generate_state(1, np.uint64)[0])
