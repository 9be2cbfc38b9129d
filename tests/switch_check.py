"""What the warm-switch tests share (tests/unit/test_synth_switch.py, tests/integration/test_scenario_helper.py):
the synthesiser they stream with and counters of the model-specific set-up a switch would need."""

from __future__ import annotations

from contextlib import contextmanager

import pytest

from bkabem_core.fe.modal import SpeedCells
from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.floor import BroadbandFloor, FloorTransfer
from bkabem_core.synth.lines import LineFamilies
from bkabem_core.synth.render import FusedLines
from bkabem_core.synth.synthesizer import Synthesizer

FS = 25600.0
CHUNK = 0.1


def switch_synth(model, **kw) -> Synthesizer:
    """A stream of ``model`` at 25.6 kHz in 0.1-s chunks: 1 % slip, sensor noise, the exact spectrum."""
    opts = dict(sample_rate_hz=FS, chunk_s=CHUNK, seed=7, slip=0.01, band_limit="taper", features=False,
                spectrum="exact")
    opts.update(kw)
    s = Synthesizer(model, **opts)
    s.set_noise(noise_density={"acceleration": 2e-4})
    return s


@contextmanager
def switch_counts():
    """:func:`counting` with its own patcher."""
    with pytest.MonkeyPatch.context() as mp:
        with counting(mp) as counts:
            yield counts


@contextmanager
def counting(monkeypatch):
    """Counts of the model-specific set-up a switch needs, while the block runs."""
    counts = {}

    def count(cls, name, label):
        orig = getattr(cls, name)

        def wrapped(*a, **k):
            counts[label] = counts.get(label, 0) + 1
            return orig(*a, **k)
        monkeypatch.setattr(cls, name, wrapped)

    count(FloorTransfer, "__init__", "floor transfer")
    count(BroadbandFloor, "_seeded", "floor frames")
    count(SpeedCells, "_make", "speed cell")
    count(LineFamilies, "__init__", "line families")
    count(FusedLines, "__init__", "kernel plan")
    count(BkaBem, "response", "exact solve")
    yield counts
    monkeypatch.undo()
