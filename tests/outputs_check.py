"""What the output tests share (tests/unit/test_outputs.py, tests/integration/test_output_figures.py): the fault
library's kinds, the sweep they run and the library's own sweep to compare with. The fixtures ``cli`` and
``figures`` are in tests/conftest.py."""

from __future__ import annotations

import numpy as np

KINDS = ("outer", "inner", "ball", "healthy")
SPEEDS = (5.0, 25.0, 45.0)
SWEEP = ["--from-hz", "5", "--to-hz", "45", "--steps", "3"]


def library_sweep(model):
    """(Sweep, |acceleration| (S, K, 4, 2) [m/s^2], RMS acceleration (S, 4, 2) [m/s^2]) of ``model`` at SPEEDS."""
    sw = model.sweep(np.array(SPEEDS))
    return sw, np.abs(sw.acceleration), sw.rms("acceleration")
