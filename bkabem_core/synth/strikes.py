"""A race pit's strikes as they are: each ball meets the pit with a strength of its own.

The quasi-static model (:mod:`bkabem_core.excitation.quasi_static`) gives every ball the same path through a race
pit, so every strike is alike and the pit's lines are a clean comb whose envelope line grows with the pit without
bound. Real strikes are not alike. A ball that keeps its load over the pit (the contact bridges it) rolls through
on the same quasi-static path each time; a ball that loses part of its load in the pit crosses it partly free and
meets the far edge in a state that differs from ball to ball: where it sits in its cage pocket's clearance, its
speed relative to the cage, the lubricant film it carries, the part of the edge it strikes. The lost part of the
load comes back at the exit edge with a strength that varies at random, the kept part does not (the random impact
strengths ``A_j`` of the bearing-signal model of Antoni & Randall, JVA 124 (2002) 165-171, and Randall & Antoni,
MSSP 25 (2011) 485-520, section 2.1).

**The law.** The energy of strike ``n`` is ``E_n = E g_n^2`` with ``E`` the quasi-static strike's and ``g_n^2``
lognormal of mean 1 (the mean energy, so the RMS and every line's expected power, stay the quasi-static model's) and
relative standard deviation

    c = s lambda,      lambda = 1 - (1 - min(h / delta, 1))^1.5,

``lambda`` the share of its load the most loaded ball loses over the pit's centre with the rings held (the model's
own ball law ``Q = K (delta - h)^1.5``: ``delta = (Q / K)^(2/3)`` the ball's approach at the bearing's largest
static ball load ``Q``, ``K`` the inner and outer contact in series, ``h`` the pit's largest drop,
:attr:`~bkabem_core.bearing.defects.base.DefectProfile.depth_eff_m`), and ``s`` the defect's key ``strike_spread``
(default 1: a ball that loses all its load meets the edge with an energy as uncertain as its mean). ``lambda`` is 0
for a pit the contact bridges without unloading the ball and 1 for a pit the ball falls into.

**What it does to a diagnosis.** N strikes of random energy put a floor under the squared-envelope spectrum that
grows with them: the fault line stands at most ``10 log10(N / c^2) + 1.6 dB`` over it (the line of N coherent
impacts over the floor of their random part), however strong the pit. On the CWRU rig (docs/rigs.md,
``bench/impact_spread.py``) the measured race-fault lines sit on that ceiling, and the spread the records show grows
with the pit as ``lambda`` does: a median of 0.25 at 14 mil and 0.48 at 21 mil where the rig case's pits give
``lambda`` = 0.24-0.26 and 0.46-0.48 (0.07-0.08 at 7 mil, where the rig's own floor hides the spread). ``s`` = 1
is that median; single pits of one size differ from it by about a factor 1.5 either way (the edge of each EDM pit is
its own), which a data set spans by giving ``strike_spread`` a distribution.

**In the synthesiser.** The defect's lines on its strike phase (the families whose phase turns once per strike:
BPFO orders for an outer-race pit, the BPFI family and its load-zone sidebands for an inner-race pit, on the
defect's bearing) are multiplied by the gain ``g``, linear in their phase between the strikes around it. Strike
``n`` is where the phase, slip included, passes ``n + offset`` turns (:attr:`StrikeSpread.offset_turns`: the centre
of the defect's quasi-static pulse, where its excitation is strongest), and ``g_n`` is drawn from the run's seed and
``n`` alone (a counter-based draw), so a chunk border anywhere, or a model switch, gives the same strikes. Between
two strikes the blend is divided by the root of its mean square (``1 - 2 x (1 - x) (1 - E[g]^2)`` at a fraction x of
the way), so that the expected power of every sample, not only of the strikes, is the quasi-static model's. The C
line kernel (``kernels/synth_strike.c``) and :func:`strike_gains_reference` compute it alike. Lines of other
families (the shaft's, the other bearing's, the ball set's own BPFO orders where they are another family) are not
touched; the healthy ball set's BPFO orders share the outer-race pit's family and take its gain (they are far
weaker than a pit's).

One strike phase per run: of several race pits with a spread, the first of the case's ``[[defects]]`` gets it (the
others strike alike; the ground truth's ``strikes`` says which).

Units: turns (phases), metres, newtons; spreads and gains [-].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkabem_core.bearing.defects.protocol import DEFAULT_STRIKE_SPREAD, RaceDefect
from bkabem_core.bearing.defects.registry import kind
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.splitmix import GOLDEN, MASK64, mix64_array, stream_key

__all__ = ["StrikeSpread", "load_loss", "strike_key", "strike_gain", "strike_gains_reference"]

_FRAC62 = (1 << 62) - 1
#: The strike stream's word in the seed sequence of a run (next to the noise's and the slip walks')
_TAG = 0x5781CE
#: Points per turn (at least) on which the struck lines' quasi-static pulse is searched for its centre
_OFFSET_GRID = 2048


def load_loss(bearing, state, profile) -> float:
    """The share of its load the most loaded ball loses over the centre of the pit of ``profile`` [-] (module
    docstring: ``1 - (1 - min(h / delta, 1))^1.5``), with the bearing's rings held at its static ``state``."""
    q = float(bearing.peak_ball_load_n(state))
    h = float(profile.depth_eff_m)
    if q <= 0.0 or h <= 0.0:
        return 0.0
    delta = (q / float(bearing.contact_constant_n_m15)) ** (2.0 / 3.0)
    return 1.0 - (1.0 - min(h / delta, 1.0)) ** 1.5


def strike_key(seed: int) -> int:
    """The 64-bit key of the strike stream of ``seed``."""
    return stream_key(seed, _TAG)


def _step(z: np.ndarray) -> np.ndarray:
    """One SplitMix64 step on uint64 arrays: the increment, then the finaliser (``kernels/synth_strike.c``,
    ``mix64``)."""
    with np.errstate(over="ignore"):
        return mix64_array(z + np.uint64(GOLDEN))


def strike_gain(key: int, n, sigma: float) -> np.ndarray:
    """The amplitude gain of strikes ``n`` (int array) of stream ``key``: ``exp(sigma xi_n / 2 - sigma^2 / 4)``, xi_n
    a standard normal from (key, n) (Box-Muller on SplitMix64 words), so the energy is lognormal of mean 1."""
    n = np.asarray(n, dtype=np.int64)
    if sigma == 0.0:
        return np.ones(n.shape)
    a = _step(np.uint64(int(key) & MASK64) ^ _step(n.view(np.uint64)))
    b = _step(a)
    u1 = ((a >> np.uint64(11)).astype(np.float64) + 0.5) * 2.0 ** -53
    u2 = (b >> np.uint64(11)).astype(np.float64) * 2.0 ** -53
    xi = np.sqrt(-2.0 * np.log(u1)) * np.cos(6.283185307179586 * u2)
    return np.exp(0.5 * sigma * xi - 0.25 * sigma * sigma)


def strike_gains_reference(phases: np.ndarray, first: float, offset_turns: float, key: int,
                           sigma: float) -> np.ndarray:
    """The gain of each sample of a segment (float64): ``phases`` the struck families' fixed-point phases of its
    samples (uint64, slip offsets added; one turn = 2^62), ``first`` the same phase of its first sample in turns as a
    float (the knot's ball passes, the advance, the slip walk: its integer turns, which the fixed point wraps). The
    strike passed at the first sample is ``first - offset`` rounded down, made to agree with the fixed point's
    fraction; later ones count the turns the fixed point passes; linear in the phase x between strikes n and n + 1,
    over ``sqrt(1 - 2 x (1 - x) (1 - E[g]^2))``, the mean square of such a blend of two independent gains (every
    sample keeps the mean power of strikes all alike)."""
    off = np.uint64(int(round(offset_turns * synth_kernel.PASS_UNITS)) & MASK64)
    with np.errstate(over="ignore"):
        psi = phases.astype(np.uint64) - off
    turn = (psi >> np.uint64(62)).astype(np.int64)
    step = np.diff(turn) & 3
    step = np.where(step == 3, -1, step)
    n0 = int(round((first - offset_turns) - float(psi[0] & np.uint64(_FRAC62)) * 2.0 ** -62))
    n = n0 + np.concatenate([[0], np.cumsum(step)])
    g0 = strike_gain(key, n, sigma)
    g1 = strike_gain(key, n + 1, sigma)
    # the kernel's float32 operations, in its order: a 24-bit place between the strikes, the blend, and
    # 1 / sqrt(1 - z) by a Taylor start and three Newton steps
    f32 = np.float32
    x = ((psi >> np.uint64(38)) & np.uint64(0xFFFFFF)).astype(f32) * f32(2.0 ** -24)
    z = f32(2.0 * (1.0 - math.exp(-0.25 * sigma * sigma))) * x * (f32(1.0) - x)
    h = f32(0.5) * (f32(1.0) - z)
    y = f32(1.0) + z * (f32(0.5) + f32(0.375) * z)
    for _ in range(3):
        y = y * (f32(1.5) - h * y * y)
    return ((g0.astype(f32) + (g1 - g0).astype(f32) * x) * y).astype(np.float64)


@dataclass(frozen=True)
class StrikeSpread:
    """The random strength of one race pit's strikes in one model's line set (module docstring).

    Attributes
    ----------
    bearing : str
        The pit's bearing (``"de"``, ``"nde"``).
    kind : str
        Its kind (``"outer"``, ``"inner"``).
    load_loss : float
        ``lambda``: the share of its load the most loaded ball loses over the pit [-].
    coefficient : float
        The defect's ``strike_spread`` ``s`` [-].
    families : ndarray of bool (F,)
        The line set's families on the pit's strike phase (the gain multiplies them).
    offset_turns : float
        Where a strike stands in its families' phase [turns, 0..1): the centre of the pit's quasi-static pulse.
    """

    bearing: str
    kind: str
    load_loss: float
    coefficient: float
    families: np.ndarray
    offset_turns: float

    @property
    def spread(self) -> float:
        """``c = s lambda``: the relative standard deviation of a strike's energy [-]."""
        return self.coefficient * self.load_loss

    @property
    def sigma(self) -> float:
        """The log-standard deviation of a strike's energy, ``sqrt(ln(1 + c^2))`` [-]."""
        return math.sqrt(math.log1p(self.spread ** 2))

    @property
    def on(self) -> bool:
        """Whether the strikes differ (a spread > 0 and lines to multiply)."""
        return self.spread > 0.0 and bool(self.families.any())

    @classmethod
    def of_model(cls, model, selection) -> "StrikeSpread | None":
        """The strikes of ``model``'s first race pit with a spread, for the line set ``selection``
        (:class:`~bkabem_core.synth.lines.LineSelection`); None: the model has no such pit, or none of its lines
        are on the pit's strike phase."""
        seen: dict = {}
        for table in model.case.raw["defects"]:
            b = table["bearing"]
            j = seen[b] = seen.get(b, -1) + 1                  # its place among its bearing's defects
            k = kind(table["race"])
            s = float(table.get("strike_spread", DEFAULT_STRIKE_SPREAD))
            if not isinstance(k, RaceDefect) or s == 0.0:
                continue
            site = model.machine.sites[b]
            own = site.bearing.defects                           # the model's own (round pits: bridged at its load)
            dent = own[j] if j < len(own) and own[j].race == table["race"] else None
            profile = next((p for p in site.bearing.defect_set.profiles if p.dent is dent), None)
            if profile is None:                 # a pit of depth 0 (or a machine not of this case): no strikes
                continue
            fams = _struck_families(model, selection, k, b)
            if not fams.any():
                continue
            return cls(bearing=b, kind=k.name, load_loss=load_loss(site.bearing, site.state, profile), coefficient=s,
                       families=fams, offset_turns=_pulse_centre(model, selection, fams, b))
        return None

    def to_dict(self) -> dict:
        return {"bearing": self.bearing, "kind": self.kind, "strike_spread": self.coefficient,
                "load_loss": self.load_loss, "energy_spread": self.spread, "offset_turns": self.offset_turns,
                "struck_families": int(self.families.sum())}


def _struck_families(model, selection, k, bearing: str) -> np.ndarray:
    """(F,) bool: the families whose phase turns once per strike of a pit of kind ``k`` in ``bearing``: a rate of
    the kind's fault frequency per shaft turn, no fixed part, on that bearing's cage column."""
    rate = getattr(model.bearing_multipliers[bearing], k.fault_frequency)
    cage, _ = model.phases.columns(bearing)
    return np.array([abs(f.rate_p - rate) <= 1e-9 * rate and f.fixed_p == 0.0 and f.p[cage] != 0
                     for f in selection.families.families], dtype=bool)


def _pulse_centre(model, selection, fams: np.ndarray, bearing: str) -> float:
    """The place of the strikes in the struck families' phase [turns]: where the pit's quasi-static excitation of
    its bearing (the relative displacements, speed independent) has most energy, summed over the families (a
    family with a carrier by the magnitude of its complex table: its envelope) and the bearing's directions."""
    lines = model.lines
    amp = np.asarray(lines.amplitude)[selection.keep]
    cols = [i for i, name in enumerate(lines.inputs) if name.split(".")[0] == bearing]
    members = [selection.families.families[i] for i in np.flatnonzero(fams)]
    top = max(int(np.max(np.abs(f.k))) for f in members)
    n = max(_OFFSET_GRID, 1 << (4 * top).bit_length())         # no harmonic folds over on the grid
    energy = np.zeros(n)
    for f in members:
        y = amp[f.lines][:, cols]
        y = np.where(f.sign[:, None] < 0, np.conj(y), y)
        spec = np.zeros((n, len(cols)), complex)                 # sum_k y_k e^(i 2 pi k phi) on the grid: an FFT
        np.add.at(spec, np.asarray(f.k) % n, y)
        energy += np.sum(np.abs(np.fft.ifft(spec, axis=0)) ** 2, axis=1)
    return int(np.argmax(energy)) / n
