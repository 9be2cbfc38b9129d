"""Random slip must not create artefacts (issue 12): the fast kurtogram picks the structure's band.

A monitoring pipeline chooses the band it envelopes by spectral kurtosis. With the lines cut at a low order and
1 % random slip, the slipped ringing of the top of the comb leaked into the empty band just above it, and a fast
kurtogram picked a narrow band there (7.8-8.0 kHz for the outer race at 25 Hz, K ~ 36, with 50 x BPFO ending at
7.57 kHz). With the physically correct transmission (lines to the band limit, the FE's damping, the case's
broadband floor, sensor noise, a stud-mounted accelerometer and the anti-alias filter) the band it picks must be
one where the structure resonates and the lines are, and slip must not move it.

Oracles written here, never bkabem's own analysis:

* the fast kurtogram of Antoni (2007), "Fast computation of the kurtogram for the detection of transient faults",
  MSSP 21, 108-124, transcribed from his ``Fast_Kurtogram.m``: the 1/3-binary tree of quasi-analytic filters
  (16-tap low-pass at 0.4 of Nyquist shifted by fs/8, its quadrature-mirror high-pass; the three 24-tap filters of
  the 1/3 levels), kurtosis of the complex envelope ``E|x|^4 / (E|x|^2)^2 - 2`` in every band;
* the FE's resonances: the eigenvalues of the machine's reduced model (``model.basis``: M, C, K at standstill),
  as natural frequencies and damping ratios, computed here.

Checks, per kind (outer race, inner race) at 25 Hz: the picked band (1) lies below the highest synthesised line
(the comb is in it, not above it), (2) holds at least one lightly damped resonance of the FE, and (3) is where slip
does not matter: the kurtosis that the slipped signal has in the band picked without slip is within 25 % of the
slipped signal's maximum (a slip artefact is a band far more impulsive with slip than the physical one). A
deliberately artefacted signal (50 x BPFO, no floor) fails all three.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.sensors import Accelerometer, AntiAliasFilter
from bkabem_core.synth.synthesizer import Synthesizer

FS = 51200.0
SPEED_HZ = 25.0
NLEVEL = 7
SECONDS = 4.0


# --------------------------------------------------------------------------- the fast kurtogram (Antoni 2007)
def _kurtosis(x: np.ndarray) -> float:
    """Kurtosis of a (complex) subband signal: E|x|^4 / (E|x|^2)^2 - 2 (complex), - 3 (real); 0 if silent."""
    x = x - x.mean()
    e = np.mean(np.abs(x) ** 2)
    if e <= 1e-300:
        return 0.0
    return float(np.mean(np.abs(x) ** 4) / e ** 2 - (2.0 if np.iscomplexobj(x) else 3.0))


def fast_kurtogram(x: np.ndarray, nlevel: int) -> list[tuple[float, float, float, float]]:
    """Every band of the 1/3-binary tree as (level, low edge, high edge, kurtosis), edges in fractions of fs.

    Level k (2^k bands of fs / 2^(k+1)) comes from splitting every band of level k - 1 with the low-pass ``h`` and
    the high-pass ``g`` and decimating by 2 (the high band shifted down by (-1)^n); level k + 0.6 (3 2^(k-1)
    bands) from splitting level k - 1 with ``h1, h2, h3`` and decimating by 3. The filters' first samples are
    dropped (their transient)."""
    n = 16
    fc = 0.4
    h = signal.firwin(n + 1, fc) * np.exp(2j * np.pi * np.arange(n + 1) * 0.125)
    nn = np.arange(2, n + 2)
    g = h[(1 - nn) % n] * (-1.0) ** (1 - nn)
    n3 = int(1.5 * n)
    h1 = signal.firwin(n3 + 1, 2.0 / 3.0 * fc) * np.exp(2j * np.pi * np.arange(n3 + 1) * 0.25 / 3)
    h2 = h1 * np.exp(2j * np.pi * np.arange(n3 + 1) / 6)
    h3 = h1 * np.exp(2j * np.pi * np.arange(n3 + 1) / 3)
    skip = len(h) - 1
    out = [(0.0, 0.0, 0.5, _kurtosis(x))]
    bands = [np.asarray(x, dtype=float)]
    for level in range(nlevel):
        nb = len(bands)
        if level < nlevel - 1:
            w = 0.5 / (3 * nb)
            for i, s in enumerate(bands):
                for j, hh in enumerate((h1, h2, h3)):
                    t = signal.lfilter(hh, 1.0, s)[2::3]
                    b = 3 * i + j
                    out.append((level + 1.6, b * w, (b + 1) * w, _kurtosis(t[skip:])))
        nxt = []
        for s in bands:
            a = signal.lfilter(h, 1.0, s)[1::2]
            d = signal.lfilter(g, 1.0, s)[1::2]
            nxt += [a, d * (-1.0) ** np.arange(1, d.size + 1)]
        bands = nxt
        w = 0.5 / len(bands)
        out += [(level + 1.0, i * w, (i + 1) * w, _kurtosis(s[skip:])) for i, s in enumerate(bands)]
    return out


def pick(kurtogram) -> tuple[float, float, float, float]:
    """The band of largest kurtosis as (level, low [Hz], high [Hz], kurtosis)."""
    level, lo, hi, k = max(kurtogram, key=lambda e: e[3])
    return level, lo * FS, hi * FS, k


def kurtosis_in(kurtogram, band) -> float:
    """Kurtosis of the kurtogram's band with the same level and edges as ``band`` (a pick)."""
    for level, lo, hi, k in kurtogram:
        if level == band[0] and abs(lo * FS - band[1]) < 1.0 and abs(hi * FS - band[2]) < 1.0:
            return k
    raise KeyError(band)


# --------------------------------------------------------------------------- the FE's resonances
def fe_resonances(model: BkaBem, max_damping: float = 0.1) -> np.ndarray:
    """Natural frequencies [Hz] of the machine's reduced FE model at standstill with damping ratio below
    ``max_damping``: the eigenvalues of the first-order form of M q'' + C q' + K q = 0."""
    b = model.basis
    m = b.M.shape[0]
    minv = np.linalg.inv(b.M)
    a = np.zeros((2 * m, 2 * m))
    a[:m, m:] = np.eye(m)
    a[m:, :m] = -minv @ b.K
    a[m:, m:] = -minv @ b.C
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    fn = np.abs(lam) / (2 * np.pi)
    zeta = -lam.real / np.abs(lam)
    return np.sort(fn[zeta < max_damping])


# --------------------------------------------------------------------------- signals
def _accelerometer_signal(model: BkaBem, slip: float, floor: bool) -> tuple[np.ndarray, float]:
    """4 s of DE vertical housing acceleration at 25 Hz (seeded) and the highest synthesised line [Hz]."""
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.25, quantities=("acceleration",), slip=slip, seed=3,
                    noise_density={"acceleration": 2e-4}, band_limit="taper", features=False,
                    accelerometer=Accelerometer.mounted("stud"), anti_alias=AntiAliasFilter.for_rate(FS),
                    broadband_floor=floor)
    x = np.concatenate([s.next_chunk(SPEED_HZ).channel("de_vertical_acceleration")
                        for _ in range(int(SECONDS / 0.25))])
    top = float(np.max(s.frequency_hz(SPEED_HZ)[s.frequency_hz(SPEED_HZ) < FS / 2]))
    return x.astype(float), top


def _verdict(model: BkaBem, floor: bool = True) -> dict:
    """The three checks of the module docstring for one machine."""
    x, top = _accelerometer_signal(model, 0.01, floor)
    x0, _ = _accelerometer_signal(model, 0.0, floor)
    kg, kg0 = fast_kurtogram(x, NLEVEL), fast_kurtogram(x0, NLEVEL)
    band, band0 = pick(kg), pick(kg0)
    modes = fe_resonances(model)
    inside = modes[(modes >= band[1]) & (modes <= band[2])]
    return {"band": band, "band_without_slip": band0, "top_line_hz": top, "modes_in_band": inside,
            "below_top_line": band[1] < top,
            "holds_a_resonance": inside.size > 0,
            "slip_invariant": kurtosis_in(kg, band0) >= 0.75 * band[3]}


@pytest.fixture(scope="module")
def machines(fault_library):
    """The fault library's outer- and inner-race machines: their lines to the band limit (max_order = 0: every
    line above the threshold; the FE is converged to half the case's top sample rate)."""
    out = {kind: fault_library[kind] for kind in ("outer", "inner")}
    assert all(m.case.raw["excitation"]["max_order"] == 0 for m in out.values())
    return out


@pytest.mark.parametrize("kind", ["outer", "inner"])
def test_kurtogram_picks_a_structural_band_with_slip(machines, kind):
    v = _verdict(machines[kind])
    print(kind, v)
    assert v["below_top_line"], v
    assert v["holds_a_resonance"], v
    assert v["slip_invariant"], v


def test_kurtogram_check_fails_on_a_truncated_comb(cached_model):
    """The artefact the check must catch: 50 x BPFO (7.57 kHz at 25 Hz), no broadband floor, 1 % slip: the
    kurtogram picks a narrow band just above the comb, with no FE resonance in it, that slip made. The pit's strikes
    all alike (``strike_spread = 0``): random strike strengths spread the comb's power between its lines, which
    hides the artefact this check is built to see."""
    model = cached_model(Case.load("motor_6010_outer").with_overrides({"excitation.max_order": 50,
                                                                        "defects.0.strike_spread": 0.0}))
    v = _verdict(model, floor=False)
    print(v)
    assert not (v["below_top_line"] or v["holds_a_resonance"] or v["slip_invariant"]), v
    assert v["band"][2] - v["band"][1] <= 400.0 and v["band"][1] >= v["top_line_hz"], v
