"""Hashes of the synthesiser's samples over many configurations, to compare two checkouts bit for bit.

    PYTHONPATH=/tmp/main_checkout .venv/bin/python bench/hash_samples.py > a.txt
    PYTHONPATH=. .venv/bin/python bench/hash_samples.py > b.txt && diff a.txt b.txt

Per fault kind (``motor_6010_<kind>``), channels (4 accelerations, or accelerations + displacements), sample rate
and chunk length (25.6 kHz 0.1 s, 51.2 kHz 0.1 s, 25.6 kHz 0.0371 s: odd blocks), slip and noise (none; 1 % +
sensor noise + floor; 1 % alone), speeds (constant; steps: the knots' blend) and path (the CPU's fast path, or the
baseline C path with the instruction-set cap 0): one line with the SHA-1 of the float32 samples of every chunk.
The ``bkabem_core`` imported is the first on ``sys.path`` (``PYTHONPATH``), not necessarily this checkout's. A first
argument lists the kinds (``inner,ball``) or whole case names (``electric_motor_6010``: BPFO orders only).
"""

import hashlib
import os
import sys

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
try:
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem
    from bkabem_core.synth import kernel as sk
    from bkabem_core.synth.synthesizer import Synthesizer
except ImportError:                     # a checkout of the flat layout before bkabem_core's packages
    from bkabem_core import synth_kernel as sk
    from bkabem_core.case import Case
    from bkabem_core.harmonic import BkaBem
    from bkabem_core.synth import Synthesizer

SPEEDS = {"const": (24.0,) * 5, "ramp": (24.0, 24.0, 25.3, 26.1, 25.7, 25.2, 24.1)}


def main() -> None:
    kinds = sys.argv[1].split(",") if len(sys.argv) > 1 else ["inner", "ball", "healthy", "outer"]
    print(f"# bkabem_core from {os.path.dirname(sk.__file__)}", file=sys.stderr)
    for kind in kinds:
        model = BkaBem(Case.load(kind if "_" in kind else f"motor_6010_{kind}"))
        for q in (("acceleration",), ("acceleration", "displacement")):
            for fs, cs in ((25600.0, 0.1), (51200.0, 0.1), (25600.0, 0.0371)):
                for slip, noise in ((0.0, False), (0.01, True), (0.01, False)):
                    for sname, speeds in SPEEDS.items():
                        for cap in (None, 0):
                            kw = dict(sample_rate_hz=fs, chunk_s=cs, slip=slip, seed=3, features=True, quantities=q)
                            if noise:
                                kw["noise_density"] = {"acceleration": 5e-4, "displacement": 1e-10}
                            s = Synthesizer(model, **kw)
                            h = hashlib.sha1()
                            old = sk._set_isa_cap(cap) if cap is not None else None
                            try:
                                for v in speeds:
                                    h.update(np.ascontiguousarray(s.next_chunk(v).samples).tobytes())
                            finally:
                                if old is not None:
                                    sk._set_isa_cap(old)
                            print(kind, len(q) * 4, fs, cs, slip, noise, sname, "fast" if cap is None else "cap0",
                                  h.hexdigest()[:16], flush=True)


if __name__ == "__main__":
    main()
