"""The line set's knot and segment calls (synth_lineknots, _synthknot.h) against their numpy / Python references:
the same numbers bit for bit (amplitudes, velocities, family tables, phases and samples), the ISO velocity to
rounding."""

from __future__ import annotations

import numpy as np
import pytest

from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import TWO_PI, BkaBem
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth import lineknots as synth_lineknots
from bkabem_core.synth.linesets import ISO_BAND_HZ
from bkabem_core.synth.synthesizer import Synthesizer

if not synth_lineknots.AVAILABLE:     # the set-up builds them (make install): fail, never skip, when they are missing
    pytest.fail("the C kernels are not built: run `make install`", pytrace=False)


@pytest.fixture(scope="module")
def models():
    return {k: BkaBem(Case.load(f"motor_6010_{k}")) for k in ("inner", "ball")}


def _numpy_knot(s: Synthesizer, f: float):
    """y, v_iso (L, 8) and the tables of a knot by the numpy formulas and synth_kernel.family_tables."""
    x = s._line_spectrum_at(f)
    fade, taper = s._order_weights(f)
    w = TWO_PI * (s._nu * f + s._mu)
    iw = 1j * w
    powers = np.stack([np.ones_like(iw), iw, iw * iw])
    fac = powers[s._power_index].T * (s._chan_scale * fade)[None, :]
    if taper is not None:
        fac = fac * taper[:, None]
    y = x[:, s._cindex] * fac
    wt = fade * (np.ones(x.shape[0]) if taper is None else taper)
    v = x[:, s._iso_rows] * (1j * w * 1e3 * wt)[:, None]
    plan = s._families.plan
    buf = np.empty(plan["rows"] * y.shape[1], dtype=np.float32)
    synth_kernel.family_tables(y, plan, buf, np.empty(2 * plan["max_n"] * y.shape[1]))
    return x, y, np.concatenate([v.real, v.imag], axis=1), buf


@pytest.fixture(params=[2, 1], ids=["avx512", "avx2"])
def isa(request):
    """The C kernels' instruction-set cap (the knot FFT: two stages per pass with AVX-512, one otherwise)."""
    old = synth_kernel._set_isa_cap(request.param)
    yield request.param
    synth_kernel._set_isa_cap(old)


@pytest.mark.parametrize("kind", ["inner", "ball"])
@pytest.mark.parametrize("kw", [{}, {"quantities": ("acceleration", "velocity", "displacement")},
                                {"sample_rate_hz": 6000.0, "band_limit": "taper"}])
def test_knot_is_the_numpy_knot_bit_for_bit(models, kind, kw, isa):
    """Channel amplitudes, ISO velocities and every family's table of one C call equal the numpy formulas and the
    ctypes FFT exactly, at standstill, in the low-speed fade, near the Nyquist taper, for 8 and 12 channels, on
    either FFT path."""
    kw = dict(kw)
    fs = kw.pop("sample_rate_hz", 51200.0)
    s = Synthesizer(models[kind], sample_rate_hz=fs, chunk_s=0.1, **kw)
    assert s._line_knots is not None
    for f in (0.0, 0.07, 13.3, 24.37, 29.9):
        if s.band_limit == "error" and s._top_hz(f) >= fs / 2:
            continue
        x, y, v, tables = _numpy_knot(s, f)
        amp = s._line_amplitudes(f)
        assert np.array_equal(amp.x, x)
        assert np.array_equal(amp.y_emphasised, y)
        assert np.array_equal(amp.v_iso, v)
        assert np.array_equal(amp.fbuf.view(np.uint32), tables.view(np.uint32))     # signed zeros too


def _python_segment(s: Synthesizer, a, b, lo: int, hi: int, out, acc, noise) -> None:
    """The line-set segment as it was written in Python: the phases of _phase_args per family, the slip offsets
    by _SlipWalk.warp_fixed, then synth_kernel.lines_segment (ctypes)."""
    m, j = hi - lo, lo - a.x
    fs, bpfo = s.sample_rate_hz, s.bpfo_per_hz
    fams = a.amp.families
    plan = s._fused_plan(fams)
    mask = (1 << 64) - 1
    vals = []
    for fam in fams.families:
        for rate, fixed, on in ((fam.rate_p, fam.fixed_p, True), (fam.rate_q, fam.fixed_q, fam.carrier)):
            if not on:
                vals += (0, 0, 0)
                continue
            p0, d0, dd = s._phase_args(rate, fixed, a.u_int + a.u_frac, a, b, j, fs, bpfo)
            vals += (p0 & mask, d0 & mask, dd & mask)
    warp = None
    if plan["kappas"]:
        length = b.x - a.x
        warp = np.ascontiguousarray(s._slip_walk.warp_fixed(a.u_int, j, m, bpfo / fs * a.f,
                                                            0.5 * bpfo / fs * (b.f - a.f) / length, a.u_frac,
                                                            plan["kappas"]))
    tb = None if b.amp is a.amp else b.amp.fbuf
    synth_kernel.lines_segment(m, np.array(vals, dtype=np.uint64), fams.plan, a.amp.fbuf, tb, warp, plan["wp"],
                               plan["wq"], a.amp.dc32, float(j), 65536.0 / (b.x - a.x), out, acc, s._dc_off, noise,
                               csrc=plan["csrc"])


@pytest.mark.parametrize("kind", ["inner", "ball"])
def test_segment_is_the_python_segment_bit_for_bit(models, kind):
    """One C call per segment (phases, slip offsets of every slip factor, samples with noise, floor and features)
    gives the samples and moments of the Python phases + ctypes kernel, on segments that start anywhere in a
    knot interval, hours into a run, speeding up and slowing down."""
    s = Synthesizer(models[kind], sample_rate_hz=51200.0, chunk_s=0.1, slip=0.015, seed=4,
                    noise_density={"acceleration": 1e-3, "displacement": 1e-10})
    s.next_chunk(23.0)
    s.next_chunk(25.5)
    a, b = s._knots[-2], s._knots[-1]
    rng = np.random.default_rng(2)
    for shift, (fa, fb) in ((0, (a.f, b.f)), (3 * 3600 * 51200, (25.5, 24.1))):
        a2 = type(a)(x=a.x + shift, f=fa, u_int=a.u_int + 70_000 * (shift > 0), u_frac=a.u_frac, amp=a.amp)
        b2 = type(b)(x=b.x + shift, f=fb, u_int=b.u_int, u_frac=b.u_frac, amp=b.amp)
        for _ in range(3):
            lo = a2.x + int(rng.integers(0, b2.x - a2.x - 1))
            hi = min(b2.x, lo + int(rng.integers(1, 3000)))
            floor = s._floor_part(a2, b2, lo, hi)
            results = []
            for render in (lambda *q: _python_segment(s, *q), s._segment_lines_fused):
                out, acc = np.empty((hi - lo, 8), np.float32), synth_kernel.new_acc(8)
                render(a2, b2, lo, hi, out, acc, s._segment_noise(a2, b2, lo) + (floor,))
                results.append((out, acc))
            assert np.array_equal(results[0][0], results[1][0])
            assert np.array_equal(results[0][1], results[1][1])


def test_iso_velocity_of_the_lines_is_the_numpy_one(models):
    """The ISO 10816 band RMS of the C knots' velocities equals sqrt(0.5 sum |v|^2) in numpy to rounding, and the
    band's edges are the numpy mask's."""
    s = Synthesizer(models["ball"], sample_rate_hz=51200.0, chunk_s=0.1)
    a, b = s._line_amplitudes(21.0), s._line_amplitudes(22.5)
    for f, t in ((21.0, 0.0), (21.7, 0.4), (22.5, 1.0), (1.2, 0.5), (90.0, 0.5)):
        freq = s._nu * f + s._mu
        band = (freq >= ISO_BAND_HZ[0]) & (freq <= ISO_BAND_HZ[1])
        va, vb = a.v_iso[:, :4] + 1j * a.v_iso[:, 4:], b.v_iso[:, :4] + 1j * b.v_iso[:, 4:]
        v = (va + t * (vb - va))[band]
        ref = np.sqrt(0.5 * np.sum(np.abs(v) ** 2, axis=0)) if v.size else np.zeros(4)
        got = synth_lineknots.band_rms_lines(a.v_iso, b.v_iso, s._nu, s._mu, f, ISO_BAND_HZ, t)
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0.0)


def test_bad_arguments_raise_value_errors(models):
    """Wrong shapes and dtypes name the argument (no crash, nothing written out of bounds)."""
    s = Synthesizer(models["inner"], sample_rate_hz=51200.0, chunk_s=0.1)
    k = s._line_knots
    x = s._line_spectrum_at(20.0)
    with pytest.raises(ValueError, match="x"):
        k.knot(x[:-1], 20.0, 1.0, None, None)
    with pytest.raises(ValueError, match="x"):
        k.knot(x.astype(np.complex64), 20.0, 1.0, None, None)
    with pytest.raises(ValueError, match="lines_knot"):
        k.knot(x, 20.0, 1.0, np.ones(3), None)
    s.next_chunk(20.0)
    s.next_chunk(20.5)
    a, b = s._knots[-2], s._knots[-1]
    seg = s._fused_plan(a.amp.families)["segments"]
    out = np.empty((100, 8), np.float32)
    with pytest.raises(ValueError, match="ta"):
        seg.segment(100, 0, a, b, None, s.bpfo_per_hz, a.amp.fbuf[:-1], None, out, None, None, a.amp.dc32, None)
    with pytest.raises(ValueError, match="out"):
        seg.segment(100, 0, a, b, None, s.bpfo_per_hz, a.amp.fbuf, None, out[:50], None, None, a.amp.dc32, None)
