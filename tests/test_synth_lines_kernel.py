"""The C line-set kernel (``_synthlines.h`` / ``_synthrows.h``) against the per-family numpy path, for the line
sets that have families on one phase (inner race: the BPFI carriers; ball: the cage-phase spin carriers): its AVX2
path (families of one phase grouped, carriers' cos / sin 8 at a time), its generic C path and the numpy path give
the same samples to float32 rounding, through speed changes with slip, sensor noise and the broadband floor."""

import numpy as np
import pytest

from bkabem_core import synth_kernel as sk
from bkabem_core.case import Case
from bkabem_core.harmonic import BkaBem
from bkabem_core.synth import Synthesizer

pytestmark = pytest.mark.skipif(not sk.LINES_AVAILABLE, reason="the C line-set kernel is not built")

SPEEDS = (24.0, 24.0, 25.3, 26.1, 25.7)


def _chunks(s, cap=None):
    out = []
    for v in SPEEDS:
        old = sk._set_isa_cap(cap) if cap is not None else None
        try:
            out.append(s.next_chunk(v).samples.astype(np.float64))
        finally:
            if old is not None:
                sk._set_isa_cap(old)
    return np.concatenate(out, axis=1)


@pytest.mark.parametrize("kind", ["inner", "ball"])
def test_fast_generic_and_numpy_line_set_paths_agree(kind):
    model = BkaBem(Case.load(f"motor_6010_{kind}"))
    kw = dict(sample_rate_hz=51200.0, chunk_s=0.05, slip=0.01, seed=3, features=False,
              noise_density={"acceleration": 1e-3, "displacement": 1e-10})
    fast, generic, numpy_path = (Synthesizer(model, **kw) for _ in range(3))
    numpy_path._lines_fused = False                      # before any knot: the per-family numpy path
    fams = fast._families
    phases = {(f.rate_p, f.fixed_p, f.kappa_p, f.table_size) for f in fams.families}
    assert len(phases) < len(fams.families)              # families share a phase: the grouped rows are exercised
    assert any(f.carrier for f in fams.families)
    a, g, r = _chunks(fast), _chunks(generic, cap=0), _chunks(numpy_path)
    top = np.abs(r).max(axis=1, keepdims=True)
    tol = 64 * np.finfo(np.float32).eps
    assert np.all(np.abs(a - r) <= tol * top), (np.abs(a - r) / top).max()
    assert np.all(np.abs(g - r) <= tol * top), (np.abs(g - r) / top).max()
