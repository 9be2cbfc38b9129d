"""The C line-set kernels (``kernels/synth_lines.c``, ``synth_rows.c``) against the per-family numpy path, for the
line sets that have families on one phase (inner race: the BPFI carriers; ball: the cage-phase spin carriers): its
AVX2 path (families of one phase grouped, carriers' cos / sin 8 at a time), its generic C path and the numpy path
give the same samples to float32 rounding, through speed changes with slip, sensor noise and the broadband
floor."""

import numpy as np
import pytest

from bkabem_core.model.case import Case
from bkabem_core.synth import kernel as sk
from bkabem_core.synth.lines import carrier_sums
from bkabem_core.synth.render import FusedLines, LoopLines
from bkabem_core.synth.synthesizer import Synthesizer

if not sk.LINES_AVAILABLE:     # the set-up builds them (make install): fail, never skip, when they are missing
    pytest.fail("the C line-set kernel is not built: run `make install`", pytrace=False)

SPEEDS = (24.0, 24.0, 25.3, 26.1, 25.7)
TOL = 64 * np.finfo(np.float32).eps


def _chunks(s, cap=None, speeds=SPEEDS):
    out = []
    for v in speeds:
        old = sk._set_isa_cap(cap) if cap is not None else None
        try:
            out.append(s.next_chunk(v).samples.astype(np.float64))
        finally:
            if old is not None:
                sk._set_isa_cap(old)
    return np.concatenate(out, axis=1)


@pytest.mark.parametrize("kind", ["inner", "ball"])
def test_fast_generic_and_numpy_line_set_paths_agree(kind, fault_library):
    model = fault_library[kind]
    kw = dict(sample_rate_hz=51200.0, chunk_s=0.05, slip=0.01, seed=3, features=False,
              noise_density={"acceleration": 1e-3, "displacement": 1e-10})
    fast, generic = (Synthesizer(model, **kw) for _ in range(2))
    numpy_path = Synthesizer(model, kernel="reference", **kw)
    assert isinstance(numpy_path._plan.lines_kernel, LoopLines) and isinstance(fast._plan.lines_kernel, FusedLines)
    fams = fast._plan.lines.families
    phases = {(f.rate_p, f.fixed_p, f.kappa_p, f.table_size) for f in fams.families}
    assert len(phases) < len(fams.families)              # families share a phase: the grouped rows are exercised
    assert any(f.carrier for f in fams.families)
    a, g, r = _chunks(fast), _chunks(generic, cap=0), _chunks(numpy_path)
    top = np.abs(r).max(axis=1, keepdims=True)
    assert np.all(np.abs(a - r) <= TOL * top), (np.abs(a - r) / top).max()
    assert np.all(np.abs(g - r) <= TOL * top), (np.abs(g - r) / top).max()


@pytest.mark.parametrize("kind", ["healthy", "inner", "ball"])
def test_four_channel_fast_path_matches_eight_channels_and_generic(kind, fault_library):
    """4 channels (the data set's acc4) take the grouped rows, the floor render and the knot stages in 128-bit /
    4-lane vectors: their samples (broadband floor on) equal the same channels of the 8-channel synthesiser
    (channels 0, 1, 4, 5: the accelerations) to float32 rounding, and, with noise, the generic C path's (cap 0)
    for the same 4 channels."""
    model = fault_library[kind]
    kw = dict(sample_rate_hz=25600.0, chunk_s=0.05, slip=0.01, seed=3, features=False)
    s8, s4 = Synthesizer(model, **kw), Synthesizer(model, quantities=("acceleration",), **kw)
    assert isinstance(s4._plan.lines_kernel, FusedLines) and len(s4.channels) == 4
    names8 = list(s8.channel_names)
    cols = [names8.index(n) for n in s4.channel_names]
    a8, a4 = _chunks(s8)[cols], _chunks(s4)
    top = np.abs(a8).max(axis=1, keepdims=True)
    assert np.all(np.abs(a4 - a8) <= TOL * top), (np.abs(a4 - a8) / top).max()
    kw["noise_density"] = {"acceleration": 1e-3}
    fast, generic = (Synthesizer(model, quantities=("acceleration",), **kw) for _ in range(2))
    a, g = _chunks(fast), _chunks(generic, cap=0)
    top = np.abs(g).max(axis=1, keepdims=True)
    assert np.all(np.abs(a - g) <= TOL * top), (np.abs(a - g) / top).max()


@pytest.mark.parametrize("kind", ["inner", "ball"])
@pytest.mark.parametrize("quantities", [("acceleration",), ("acceleration", "displacement")])
def test_vector_and_generic_paths_agree_with_noise_floor_and_odd_blocks(kind, quantities, fault_library):
    """The AVX2 rows (two families a pass; at 4 channels two samples a 256-bit register), the one-pass noise and
    the floor render against the generic C path (cap 0) at 4 and 8 channels, through speed changes (the knots'
    blend), with slip, sensor noise and the broadband floor, and chunks that end in odd blocks: float32
    rounding, and the features to their block sums' round-off."""
    if not sk.fast_path():
        pytest.skip("no AVX2 + FMA on this CPU")
    model = fault_library[kind]
    kw = dict(sample_rate_hz=25600.0, chunk_s=0.0371, slip=0.01, seed=7, features=True, quantities=quantities,
              noise_density={"acceleration": 5e-4, "displacement": 1e-10})
    fast, generic = Synthesizer(model, **kw), Synthesizer(model, **kw)
    speeds = SPEEDS + (24.4, 24.4)
    a, g = _chunks(fast, speeds=speeds), _chunks(generic, cap=0, speeds=speeds)
    top = np.abs(g).max(axis=1, keepdims=True)
    assert np.all(np.abs(a - g) <= TOL * top), (np.abs(a - g) / top).max()


def test_carrier_sums_follow_the_families_groups_and_orders(cached_model):
    """The plan's carrier sums (:func:`~bkabem_core.synth.lines.carrier_sums`): an inner race's BPFI families take
    the shaft orders 2, 3, 4 as sums of the others of their group (table size and phase), the first one and
    families of another group from their own phase; a ball's spin families the cage orders likewise. Every sum
    adds up to the family's own carrier, its sources are carrier families of the same group, and the shallowest
    pair is taken (4 = 2 + 2)."""
    for kind, axis in (("inner", 0), ("ball", 1)):
        case = Case.load(f"motor_6010_{kind}").with_overrides({"excitation.max_order": 50})   # the 50-order plan
        s = Synthesizer(cached_model(case), sample_rate_hz=25600.0, chunk_s=0.05, features=False)
        ff = s._plan.lines.families.families
        cs = carrier_sums(ff)
        summed = {ff[i].q[axis]: tuple(int(v) for v in cs[i]) for i in range(len(ff)) if cs[i][0] >= 0}
        assert sorted(summed) == [2, 3, 4], (kind, summed)
        for i, (a, b) in enumerate(cs):
            if a < 0:
                assert b < 0
                continue
            fi, fa, fb = ff[i], ff[a], ff[b]
            assert fa.carrier and fb.carrier and a != i and b != i
            assert tuple(x + y for x, y in zip(fa.q, fb.q)) == fi.q
            assert (fa.p, fa.table_size, fa.kappa_p) == (fb.p, fb.table_size, fb.kappa_p) == (fi.p, fi.table_size,
                                                                                               fi.kappa_p)
        four = summed[4]
        assert ff[four[0]].q[axis] == ff[four[1]].q[axis] == 2       # depth 2, not 3 + 1 (depth 3)


def test_segment_plan_rejects_bad_carrier_sums(fault_library):
    """The segment plan takes carrier sources only as two other carrier families and without a cycle: one line
    naming what is wrong, never a kernel that reads a slip row it did not compute."""
    s = Synthesizer(fault_library["inner"], sample_rate_hz=25600.0, chunk_s=0.05, slip=0.01,
                    features=False)
    s.next_chunk(24.0)
    fl = s._plan.lines_kernel
    fams = s._plan.lines.families
    good = fl.csrc
    car = [i for i, f in enumerate(fams.families) if f.carrier]
    plain = [i for i, f in enumerate(fams.families) if not f.carrier]
    cyc = good.copy()
    a, b = car[0], car[1]
    cyc[a] = (b, b)
    cyc[b] = (a, a)
    own = good.copy()
    own[a] = (a, b)
    nocar = good.copy()
    nocar[a] = (plain[0], b)
    half = good.copy()
    half[a] = (b, -1)
    for bad, what in ((cyc, "a cycle"), (own, "carrier sources"), (nocar, "carrier sources"),
                      (half, "carrier sources")):
        with pytest.raises(ValueError, match=what):
            FusedLines.segment_plan(fl._layout, fl._consts, fl.kappas, fl.wp, fl.wq, bad)
    FusedLines.segment_plan(fl._layout, fl._consts, fl.kappas, fl.wp, fl.wq, good)
