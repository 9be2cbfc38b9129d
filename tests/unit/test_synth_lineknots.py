"""The line set's knot and segment calls of the C kernels (:class:`~bkabem_core.synth.render.FusedLines`) against
the numpy path (:class:`~bkabem_core.synth.render.LoopLines` with the numpy reference of the sample loop): the
same channel amplitudes and velocities bit for bit, the same tables to float32 rounding (and bit for bit across the
FFT's instruction-set paths), the same samples to float32 rounding on segments anywhere in a run, hours in; the ISO
velocity to rounding; bad arguments named."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.render import FusedLines, LoopLines
from bkabem_core.synth.stream import ISO_BAND_HZ
from bkabem_core.synth.synthesizer import Synthesizer

if not synth_kernel.LINES_AVAILABLE:     # the set-up builds them (make install): fail, never skip, when missing
    pytest.fail("the C kernels are not built: run `make install`", pytrace=False)

EPS = np.finfo(np.float32).eps


@pytest.fixture(scope="module")
def models(fault_library):
    """The fault library's inner-race and ball models (the session's)."""
    return {k: fault_library[k] for k in ("inner", "ball")}


@pytest.fixture(params=[2, 1, 0], ids=["avx512", "avx2", "baseline"])
def isa(request):
    """The C kernels' instruction-set cap (the knot FFT: two stages per pass with AVX-512, one otherwise)."""
    old = synth_kernel._set_isa_cap(request.param)
    yield request.param
    synth_kernel._set_isa_cap(old)


def _tables_of(buf: np.ndarray, plan) -> list:
    """The fused kernel's table buffer as the numpy path's per-family list of (N + 3, C) tables."""
    layout = plan.lines.families.layout(len(plan.channels))
    c = len(plan.channels)
    out = []
    for i, fam in enumerate(plan.lines.families.families):
        rows = (fam.table_size + 3) * c
        off = int(layout["offset"][i])
        parts = [buf[off:off + rows].reshape(-1, c)]
        if fam.carrier:
            parts.append(buf[off + rows:off + 2 * rows].reshape(-1, c))
        out.append(tuple(parts))
    return out


@pytest.mark.parametrize("kind", ["inner", "ball"])
@pytest.mark.parametrize("kw", [{}, {"quantities": ("acceleration", "velocity", "displacement")},
                                {"sample_rate_hz": 6000.0, "band_limit": "taper"}])
def test_knot_is_the_numpy_knot(models, kind, kw, isa):
    """Channel amplitudes and ISO velocities of one C call equal the numpy formulas exactly, every family's table
    numpy's FFT to float32 rounding, at standstill, in the low-speed fade, near the Nyquist taper, for 8 and 12
    channels, on every FFT path (the same bits on all)."""
    kw = dict(kw)
    fs = kw.pop("sample_rate_hz", 51200.0)
    c_synth = Synthesizer(models[kind], sample_rate_hz=fs, chunk_s=0.1, **kw)
    np_synth = Synthesizer(models[kind], sample_rate_hz=fs, chunk_s=0.1, kernel="reference", **kw)
    assert isinstance(c_synth._plan.lines_kernel, FusedLines)
    assert isinstance(np_synth._plan.lines_kernel, LoopLines)
    first = {}
    for f in (0.0, 0.07, 13.3, 24.37, 29.9):
        if kw.get("band_limit") != "taper" and c_synth._plan.lines.top_hz(f) >= fs / 2:
            continue
        a, b = c_synth._plan.amplitudes(f), np_synth._plan.amplitudes(f)
        assert np.array_equal(a.x, b.x)
        assert np.array_equal(a.y, b.y)
        assert np.array_equal(a.v_iso, b.v_iso)
        for ta, tb in zip(_tables_of(a.tables, c_synth._plan), b.tables):
            for u, v in zip(ta, tb):
                assert np.all(np.abs(u.astype(float) - v) <= 2 * EPS * max(np.abs(v).max(), 1e-300))
        ref = first.setdefault((kind, str(kw), f), a.tables.copy())
        assert np.array_equal(a.tables.view(np.uint32), ref.view(np.uint32))


@pytest.mark.parametrize("kind", ["inner", "ball"])
def test_segment_is_the_numpy_segment(models, kind):
    """One C call per segment (phases, slip offsets of every slip factor, samples with noise, floor and features)
    gives the samples of the per-family numpy path (+ the noise and the floor added after) to float32 rounding,
    and its moments to their round-off, on segments that start anywhere in a knot interval, hours into a run,
    speeding up and slowing down."""
    kw = dict(sample_rate_hz=51200.0, chunk_s=0.1, slip=0.015, seed=4,
              noise_density={"acceleration": 1e-3, "displacement": 1e-10})
    fused, loop = Synthesizer(models[kind], **kw), Synthesizer(models[kind], kernel="reference", **kw)
    for s in (fused, loop):
        s.next_chunk(23.0)
        s.next_chunk(25.5)
    plan = fused._plan
    (a, b), (la, lb) = fused._stream.knots[-2:], loop._stream.knots[-2:]
    walk = fused._stream.walk
    rng = np.random.default_rng(2)
    for shift, (fa, fb) in ((0, (a.f, b.f)), (3 * 3600 * 51200, (25.5, 24.1))):
        du = 70_000 * (shift > 0)
        ka, kb = replace(a, x=a.x + shift, f=fa, u_int=a.u_int + du), replace(b, x=b.x + shift, f=fb)
        na, nb = replace(ka, amp=la.amp), replace(kb, amp=lb.amp)
        for _ in range(3):
            lo = ka.x + int(rng.integers(0, kb.x - ka.x - 1))
            hi = min(kb.x, lo + int(rng.integers(1, 3000)))
            floor = plan.floor.render(lo, hi - lo).copy()                  # (the plan's floor: made with it)
            noise = plan.noise.segment(ka, kb, lo)
            out, acc = np.empty((hi - lo, 8), np.float32), synth_kernel.new_acc(8)
            assert plan.lines_kernel.segment(ka, kb, lo, hi, out, acc, plan.dc_off, walk, noise + (floor,))
            ref, racc = np.empty_like(out), synth_kernel.new_acc(8)
            assert not loop._plan.lines_kernel.segment(na, nb, lo, hi, ref, None, None, walk, None)
            synth_kernel.noise_add(ref, noise[0], lo, noise[2], plan.dc_off, racc, floor)
            top = np.abs(ref).max(axis=0)
            assert np.all(np.abs(out - ref) <= 64 * EPS * top), (np.abs(out - ref) / top).max()
            np.testing.assert_allclose(acc[:, 1], racc[:, 1], rtol=1e-4)
            np.testing.assert_allclose(acc[:, 4:], racc[:, 4:], rtol=1e-4, atol=64 * EPS * top.max())


def test_iso_velocity_of_the_lines_is_the_numpy_one(models):
    """The ISO 10816 band RMS of the C knots' velocities equals sqrt(0.5 sum |v|^2) in numpy to rounding, and the
    band's edges are the numpy mask's."""
    s = Synthesizer(models["ball"], sample_rate_hz=51200.0, chunk_s=0.1)
    plan = s._plan
    a, b = plan.amplitudes(21.0), plan.amplitudes(22.5)
    nu, mu = plan.lines.nu, plan.lines.mu
    for f, t in ((21.0, 0.0), (21.7, 0.4), (22.5, 1.0), (1.2, 0.5), (90.0, 0.5)):
        freq = nu * f + mu
        band = (freq >= ISO_BAND_HZ[0]) & (freq <= ISO_BAND_HZ[1])
        va, vb = a.v_iso[:, :4] + 1j * a.v_iso[:, 4:], b.v_iso[:, :4] + 1j * b.v_iso[:, 4:]
        v = (va + t * (vb - va))[band]
        ref = np.sqrt(0.5 * np.sum(np.abs(v) ** 2, axis=0)) if v.size else np.zeros(4)
        got = synth_kernel.band_rms_lines(a.v_iso, b.v_iso, nu, mu, f, *ISO_BAND_HZ, t)
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0.0)
        np.testing.assert_allclose(synth_kernel.band_rms_lines_reference(a.v_iso, b.v_iso, nu, mu, f, *ISO_BAND_HZ, t),
                                   ref, rtol=1e-13, atol=0.0)


def test_bad_arguments_raise_value_errors(models):
    """Wrong shapes and dtypes name the argument (no crash, nothing written out of bounds)."""
    s = Synthesizer(models["inner"], sample_rate_hz=51200.0, chunk_s=0.1)
    k = s._plan.lines_kernel
    x = s._plan.spectrum(20.0)
    with pytest.raises(ValueError, match="x"):
        k.knot(x[:-1], 20.0, 1.0, None, None)
    with pytest.raises(ValueError, match="x"):
        k.knot(x.astype(np.complex64), 20.0, 1.0, None, None)
    with pytest.raises(ValueError, match="lines_knot"):
        k.knot(x, 20.0, 1.0, np.ones(3), None)
    s.next_chunk(20.0)
    s.next_chunk(20.5)
    a, b = s._stream.knots[-2:]
    out = np.empty((100, 8), np.float32)
    bad = replace(a, amp=replace(a.amp, tables=a.amp.tables[:-1]))
    with pytest.raises(ValueError, match="ta"):
        k.segment(bad, b, a.x, a.x + 100, out, None, None, None, None)
    with pytest.raises(ValueError, match="out"):
        k.segment(a, b, a.x, a.x + 100, out[:50], None, None, None, None)
