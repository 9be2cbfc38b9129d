"""Synthesis of any set of lines: the lines grouped into families, one wavetable per family and knot.

A BPFO-order set (outer race, healthy bearings) is one family: harmonics of the ball-pass phase, one table (the
synthesiser's original path, :mod:`bkabem_core.synth.synthesizer`). Any other set (:mod:`bkabem_core.excitation.lines`: inner-race
sidebands, ball-defect combs, the baseline's 1x, 2x and electrical lines) is split into families

    lines  c = k p + q,   k integer,      x_family(t) = Re(exp(i 2 pi phi_q) G(phi_p)),

``phi_p = p . Phi / 2 pi`` the family's phase in turns, ``G`` a periodic function of it. Without a carrier
(``q = 0``) the family is ``Re sum_{k>=1} Y_k e^{i k 2 pi phi_p}``: one real table, exactly the original path.
With a carrier (sidebands: ``q = n`` shaft orders for an inner race, ``n`` cage orders for a ball), ``k`` runs over
both signs and ``G = Re G + i Im G`` takes two real tables; the sample is ``cos(2 pi phi_q) Re G - sin(2 pi phi_q)
Im G``. Families follow the kinds' own phases (fault_kinds.md):

* ball spin ``p = (0, 0, 1, 0)`` (BSF), carrier the rest (``n`` FTF);
* supply ``p = (0, 0, 0, 1)``, carrier the rest;
* no shaft coefficient: the ball-pass phase ``p = (0, z, 0, 0)`` when the cage coefficient is a multiple of z
  (BPFO orders), else the cage phase ``(0, 1, 0, 0)`` (FTF orders);
* a cage coefficient that is a multiple of z: the inner-race phase ``p = (z, -z, 0, 0)`` (BPFI), carrier the
  remaining shaft orders (``n`` f_r: the load-zone sidebands);
* no cage coefficient: shaft orders ``p = (1, 0, 0, 0)`` (1x, 2x);
* anything else: its own primitive direction.

Every family's phase is an exact function of the knots (speed linear in time between them, as the ball-pass phase
of the original path); random slip moves the cage and the spin only (``kappa``: turns of the family phase per
ball pass of slip; 0 for shaft and supply phases, so inner-race sidebands stay tied to f_r).

Units: phases in turns, frequencies in Hz, amplitudes in the channels' units.
"""

from __future__ import annotations

import math
import weakref
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from bkabem_core.model.vocabulary import BEARINGS, DIRECTIONS, LOCATIONS
from bkabem_core.solve.harmonic import TWO_PI, BkaBem
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth import lineknots as synth_lineknots
from bkabem_core.synth.lineknots import LineKnots, LineSegments, band_rms_lines
from bkabem_core.synth.profile import SynthError
from bkabem_core.synth.sensors import chain_gains

PASS = float(synth_kernel.PASS_UNITS)


@dataclass
class Family:
    """Lines ``k p + q`` of one table pair (module docstring).

    Attributes
    ----------
    p, q : tuple of int (4,)
        Phase and carrier coefficients on (shaft, cage, spin, line).
    lines : ndarray of int (K,)
        Indices of the family's lines in the model's line set.
    k : ndarray of int (K,)
        Harmonic of each line (``c = k p + q`` with ``sign = +1``, else ``c = -(k p + q)``).
    sign : ndarray (K,)
        +1, or -1 where the family holds the conjugate of the line (its amplitude enters conjugated).
    harmonics : ndarray of int (H,)
        Table harmonics 1..: for a real family the distinct k; for a carrier family the distinct |k| >= 1.
    table_size : int
    basis : QuarterBasis
        Cosines and sines of ``harmonics`` over the padded table rows.
    """

    p: tuple
    q: tuple
    lines: np.ndarray
    k: np.ndarray
    sign: np.ndarray
    harmonics: np.ndarray
    table_size: int
    basis: object
    rate_p: float = 0.0       # turns of phi_p per shaft turn
    fixed_p: float = 0.0      # turns of phi_p per second besides
    rate_q: float = 0.0
    fixed_q: float = 0.0
    kappa_p: float = 0.0      # turns of phi_p per ball pass of slip
    kappa_q: float = 0.0

    @property
    def carrier(self) -> bool:
        return any(self.q)


def _family_of(c, z: int):
    """(p, k, q) with ``c = k p + q`` for the line c (module docstring)."""
    s, cc, b, ln = (int(v) for v in c)
    if b != 0:
        return (0, 0, 1, 0), b, (s, cc, 0, ln)
    if ln != 0:
        return (0, 0, 0, 1), ln, (s, cc, 0, 0)
    if s == 0:
        if cc % z == 0:
            return (0, z, 0, 0), cc // z, (0, 0, 0, 0)
        return (0, 1, 0, 0), cc, (0, 0, 0, 0)
    if cc != 0 and cc % z == 0:
        k = -cc // z
        return (z, -z, 0, 0), k, (s - k * z, 0, 0, 0)
    if cc == 0:
        return (1, 0, 0, 0), s, (0, 0, 0, 0)
    g = math.gcd(abs(s), abs(cc))
    return (s // g, cc // g, 0, 0), g, (0, 0, 0, 0)


def _carrier_sums(families: list) -> np.ndarray:
    """Per family (F, 2): the two families of its rows' group whose carriers add up to its own (``q = q_a + q_b``),
    or -1, -1: its carrier's cos / sin from its own phase. A group is what the C kernel evaluates together (one
    phase ``p``, table size and slip factor); the carriers of an inner race's BPFI families are the shaft orders
    1, 2, 3, ..., a ball's spin families the cage orders: only the first needs its own cos / sin (``_synthlines.h``
    ``carrier_sum``: the angle addition, 6 operations a sample against ~40). The carrier's rate, fixed part and
    slip factor are linear in ``q``, so the sum's phase is the family's own (to the fixed point's rounding). Each
    family's sources are taken among those already available, the shallowest pair first (each addition adds a
    float32 rounding or two), the rest from their own phase."""
    out = np.full((len(families), 2), -1, dtype=np.int64)
    groups: dict = {}
    for i, f in enumerate(families):
        if f.carrier:
            groups.setdefault((f.p, f.table_size, f.kappa_p), []).append(i)
    for members in groups.values():
        depth: dict = {}                                    # q -> (depth, family) of the carriers available
        for i in sorted(members, key=lambda i: (sum(abs(v) for v in families[i].q), families[i].q)):
            q = families[i].q
            best = None
            for qa, (da, a) in depth.items():
                qb = tuple(x - y for x, y in zip(q, qa))
                if qb in depth:
                    d = 1 + max(da, depth[qb][0])
                    if best is None or d < best[0]:
                        best = (d, a, depth[qb][1])
            if best is None:
                depth[q] = (0, i)
            else:
                depth[q] = (best[0], i)
                out[i] = best[1], best[2]
    return out


def _canonical(q) -> int:
    """+1 if the carrier's first non-zero coefficient is positive (or q = 0), else -1."""
    for v in q:
        if v != 0:
            return 1 if v > 0 else -1
    return 1


class LineFamilies:
    """The families of a line set and their per-knot tables (module docstring).

    Parameters
    ----------
    coefficients : ndarray of int (L, 4)
    rates_per_hz : ndarray (4,)
        (1, FTF, BSF, 0).
    line_hz : float
        Supply frequency [Hz].
    n_balls : int
    bpfo_per_hz : float
    table_size : int or None
        Fixed table size (power of 2), or None: max(64, 8 x the family's highest harmonic) each.
    """

    def __init__(self, coefficients, rates_per_hz, line_hz: float, n_balls: int, bpfo_per_hz: float,
                 table_size: int | None = None):
        coef = np.asarray(coefficients, dtype=np.int64)
        rates = np.asarray(rates_per_hz, dtype=float)
        z = int(n_balls)
        spin_per_cage = rates[2] / rates[1]
        groups: dict = {}
        for j, c in enumerate(coef):
            p, k, q = _family_of(c, z)
            sign = _canonical(q)
            if not any(q) and k < 0:
                sign = -1
            if sign < 0:
                k, q = -k, tuple(-v for v in q)
            groups.setdefault((p, q), []).append((j, k, sign))
        self.families: list[Family] = []
        for (p, q), members in groups.items():
            lines = np.array([m[0] for m in members], dtype=np.int64)
            k = np.array([m[1] for m in members], dtype=np.int64)
            sign = np.array([m[2] for m in members], dtype=float)
            harmonics = np.unique(np.abs(k[k != 0])) if any(q) else np.unique(k)
            if harmonics.size == 0:
                harmonics = np.array([1], dtype=np.int64)           # a carrier alone: tables of DC only
            n = table_size or max(64, 1 << int(math.ceil(math.log2(8 * int(harmonics.max())))))
            if n < 4 * int(harmonics.max()) or n > synth_kernel.MAX_TABLE:
                raise ValueError(f"table size {n} cannot hold harmonic {int(harmonics.max())} of family {p}")
            fam = Family(p=p, q=q, lines=lines, k=k, sign=sign, harmonics=harmonics, table_size=n,
                         basis=synth_kernel.quarter_basis(harmonics, n))
            fam.rate_p = float(np.dot(p[:3], rates[:3]))
            fam.fixed_p = p[3] * float(line_hz)
            fam.rate_q = float(np.dot(q[:3], rates[:3]))
            fam.fixed_q = q[3] * float(line_hz)
            fam.kappa_p = (p[1] + p[2] * spin_per_cage) / z
            fam.kappa_q = (q[1] + q[2] * spin_per_cage) / z
            self.families.append(fam)
        self.bpfo_per_hz = float(bpfo_per_hz)
        # per family: each line's FFT slot (k mod N) and its B-spline pre-emphasis 1 / sinc(k / N)^4 (the cubic
        # B-spline's droop, so every line comes out exact); the padded rows (r - 1) mod N of each table size
        self._slots = [np.mod(f.k, f.table_size) for f in self.families]
        self._line_emphasis = [1.0 / np.sinc(f.k / f.table_size) ** 4 for f in self.families]
        self._pad = {f.table_size: (np.arange(f.table_size + 3) - 1) % f.table_size for f in self.families}
        self.plan = self._plan()

    def _plan(self) -> dict:
        """Flat arrays of the families for the C kernels (synth_kernel.family_tables, lines_segment): per family
        its lines, FFT slots and factors (pre-emphasis, negative where the line enters conjugated), table size and
        its log2, twiddles, carrier flag and table offset (floats per channel-row unit: x C by the caller)."""
        fams = self.families
        n_lines = np.array([f.lines.size for f in fams], dtype=np.int64)
        line = np.concatenate([f.lines for f in fams]).astype(np.int64)
        slot = np.concatenate(self._slots).astype(np.int64)
        factor = np.concatenate([e * f.sign for e, f in zip(self._line_emphasis, fams)]).astype(np.float64)
        sizes = np.array([f.table_size for f in fams], dtype=np.int64)
        tw, tw_off = [], {}
        for n in sorted(set(sizes.tolist())):
            tw_off[n] = sum(t.size for t in tw)
            j = np.arange(n // 2)
            tw.append(np.stack([np.cos(2 * np.pi * j / n), np.sin(2 * np.pi * j / n)], axis=1).ravel())
        carrier = np.array([int(f.carrier) for f in fams], dtype=np.int64)
        rows = (sizes + 3) * (1 + carrier)                        # table rows of each family (two for a carrier)
        return {"F": len(fams), "n_lines": n_lines, "line": line, "slot": slot, "factor": factor, "N": sizes,
                "lg": np.array([int(n).bit_length() - 1 for n in sizes], dtype=np.int64),
                "tw": np.concatenate(tw), "tw_off": np.array([tw_off[int(n)] for n in sizes], dtype=np.int64),
                "carrier": carrier, "row_off": np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int64),
                "rows": int(rows.sum()), "max_n": int(sizes.max())}

    def __len__(self) -> int:
        return len(self.families)

    def tables(self, y: np.ndarray, dtype) -> list:
        """Per family its padded spline table(s) (N + 3, C) for channel amplitudes ``y`` (L, C) complex: one for a
        real family, (Re G, Im G) for a carrier family; no DC (added once by the caller).

        ``G(phi) = sum_k E_|k| Y_k exp(i k 2 pi phi)`` with the B-spline pre-emphasis ``E`` is one inverse FFT of
        the family's amplitudes placed at their harmonics (k mod N); a real family's table is its real part."""
        out = []
        for fam, slot, emph in zip(self.families, self._slots, self._line_emphasis):
            yl = y[fam.lines]
            yl = np.where(fam.sign[:, None] > 0, yl, np.conj(yl)) * emph[:, None]
            spec = np.zeros((fam.table_size, y.shape[1]), complex)
            np.add.at(spec, slot, yl)
            g = np.fft.ifft(spec, axis=0)[self._pad[fam.table_size]]
            g *= fam.table_size
            out.append((g.real.astype(dtype),) if not fam.carrier else (g.real.astype(dtype), g.imag.astype(dtype)))
        return out

    @staticmethod
    def turns(fam_rate: float, fam_fixed: float, u_passes: float, x_samples: int, bpfo_per_hz: float,
              sample_rate_hz: float) -> float:
        """Fractional turns of a family phase at ``u_passes`` ball passes (BPFO phase) and sample ``x_samples``."""
        t = (fam_rate / bpfo_per_hz) * u_passes + fam_fixed * (x_samples / sample_rate_hz)
        return t - math.floor(t)


#: quantity -> (unit, power of (i omega) applied to the displacement amplitude, scale to the unit)
QUANTITIES = {
    "acceleration": ("m/s^2", 2, 1.0),
    "displacement": ("m", 0, 1.0),
    "velocity": ("mm/s", 1, 1.0e3),
}
DEFAULT_QUANTITIES = ("acceleration", "displacement")


# =========================================================================== channels
@dataclass(frozen=True)
class Channel:
    name: str
    bearing: str
    direction: str
    quantity: str
    unit: str


def make_channels(quantities=DEFAULT_QUANTITIES) -> list[Channel]:
    """Channels in a fixed order: bearing (de, nde) > quantity (as given) > direction (vertical, horizontal)."""
    if isinstance(quantities, str):
        quantities = [q.strip() for q in quantities.split(",") if q.strip()]
    quantities = list(quantities)
    if not quantities:
        raise SynthError("quantities", "at least one of acceleration, displacement, velocity")
    for q in quantities:
        if q not in QUANTITIES:
            raise SynthError("quantities", f"unknown quantity {q!r} (use acceleration, displacement, velocity)")
    if len(set(quantities)) != len(quantities):
        raise SynthError("quantities", "listed twice")
    return [Channel(f"{b}_{d}_{q}", b, d, q, QUANTITIES[q][0])
            for b in BEARINGS for q in quantities for d in DIRECTIONS]


def _combination(channels: list[Channel]):
    """The distinct displacement combinations the channels need, as rows (U, 8) over the 8 output displacements
    (LOCATIONS x DIRECTIONS): housing displacement (acceleration, velocity) and rotor minus housing (displacement).
    Returns the rows, per channel the row index, power p of (i omega) and unit scale, and the rows of the housing
    displacements (DE/NDE x vertical/horizontal) that the ISO 10816 velocity needs."""
    def col(loc, d):
        return LOCATIONS.index(loc) * len(DIRECTIONS) + DIRECTIONS.index(d)

    keys: list[tuple] = []
    rows = []

    def row_of(b, d, relative):
        key = (b, d, relative)
        if key not in keys:
            r = np.zeros(len(LOCATIONS) * len(DIRECTIONS))
            r[col(f"{b}_housing", d)] = -1.0 if relative else 1.0
            if relative:
                r[col(f"{b}_rotor", d)] = 1.0
            keys.append(key)
            rows.append(r)
        return keys.index(key)

    index, power, scale = [], [], []
    for c in channels:
        index.append(row_of(c.bearing, c.direction, c.quantity == "displacement"))
        power.append(QUANTITIES[c.quantity][1])
        scale.append(QUANTITIES[c.quantity][2])
    iso = [row_of(b, d, False) for b in BEARINGS for d in DIRECTIONS]
    return np.array(rows), np.array(index), np.array(power), np.array(scale), np.array(iso)


# =========================================================================== spectrum at a speed
class ModalSpectrum:
    """Displacement combinations from the model's exact order-wise pole-residue form, in cells of shaft speed.

    A thin view of :class:`~bkabem_core.solve.harmonic.OrderModalForm` and its :class:`~bkabem_core.solve.harmonic.SpeedCells`
    (kept on the model, so synthesisers of one model share them): per 0.5 Hz cell a Chebyshev interpolant of the
    far poles and the near poles exactly, with a rigorous bound (2e-6 of the output's largest order). Costs one
    eigen-decomposition per order once, and ~4 ms per cell when first used (:meth:`build` makes them ahead).
    """

    def __init__(self, model: BkaBem, combination: np.ndarray):
        self.model = model
        self._comb = combination
        self.form = model.order_modal_form(combination)
        self.cells = self.form.speed_cells()

    def __call__(self, speed_hz: float) -> np.ndarray:
        """Displacement combinations (K, U) complex [m] at shaft speed ``speed_hz`` [Hz]."""
        return self.cells(speed_hz)

    def build(self, f_lo_hz: float, f_hi_hz: float) -> None:
        """Make the speed cells of ``[f_lo_hz, f_hi_hz]`` [Hz] now."""
        self.cells.build(f_lo_hz, f_hi_hz)

    def check(self, speed_hz: float) -> float:
        """Largest error relative to the largest amplitude, against the exact solver, per combination."""
        exact = self.model.response([speed_hz])[0].reshape(self.form.orders.size, -1) @ self._comb.T
        mine = self(speed_hz)
        return float(np.max(np.abs(mine - exact).max(axis=0) / np.maximum(np.abs(exact).max(axis=0), 1e-300)))


class ExactSpectrum:
    """Displacement combinations from :meth:`BkaBem.response` at each requested speed (LRU cache).

    The cache is shared by every ExactSpectrum of the same model object and combination in the process: the
    machines of a fleet that run one case share its model, and when they follow the same speed (one speed topic,
    a line of identical drives) a speed step costs its amplitude knots once per process instead of once per
    machine (a 0 -> 25 Hz step: ~2-5 ms of knots per machine, 50 machines of a process in one chunk period). The
    entries are the model's exact response, so sharing changes no sample. Returned arrays are shared: read only.
    """

    #: id(model) -> {combination: LRU}; an entry goes with its model (weakref.finalize), so an id is never reused
    _shared: dict[int, dict] = {}

    def __init__(self, model: BkaBem, combination: np.ndarray, cache: int = 256):
        self.model = model
        self._comb = combination
        comb = np.ascontiguousarray(combination)
        key = (comb.shape, comb.dtype.str, comb.tobytes())
        caches = self._shared.get(id(model))
        if caches is None:
            caches = self._shared[id(model)] = {}
            weakref.finalize(model, self._shared.pop, id(model), None)
        # one LRU per (model, combination) that holds as many entries as the sharers' caches did together
        self._lru = caches.setdefault(key, [OrderedDict(), 0])
        self._lru[1] += cache
        self._cache: OrderedDict[float, np.ndarray] = self._lru[0]

    def __call__(self, speed_hz: float) -> np.ndarray:
        key = float(speed_hz)
        x = self._cache.get(key)
        if x is None:
            k = self.model.orders.size
            x = self.model.response([key])[0].reshape(k, -1) @ self._comb.T
            self._cache[key] = x
            if len(self._cache) > self._lru[1]:
                self._cache.popitem(last=False)
        else:
            try:
                self._cache.move_to_end(key)
            except KeyError:                  # dropped meanwhile by a sharer in another thread (a model's warm-up)
                pass
        return x


# =========================================================================== knots
@dataclass(slots=True)
class _Amplitudes:
    """What a knot needs at its speed (shared by knots of the same speed)."""
    f: float                    # shaft speed [Hz]
    x: np.ndarray               # (K, U) complex displacement combinations [m]
    fade: float                 # low-speed fade of every order
    taper: np.ndarray | None    # (K,) Nyquist taper (None: 1)
    y_emphasised: np.ndarray    # (K, C) complex channel amplitudes x spline pre-emphasis (weights applied)
    emphasis: np.ndarray        # (K,) the pre-emphasis 1 / sinc(k/N)^4
    table: np.ndarray | None    # (N + 3, C) cubic B-spline coefficients of one ball pass (see Synthesizer._bind_model)
    v_iso: np.ndarray | None = None     # (K, 8) housing velocity [mm/s], Re | Im, made when first needed
    ftables: list | None = None         # any other line set: per family its table(s) (synth_lines.LineFamilies)
    families: object | None = None      # ... and the LineFamilies they belong to (None: an order set)
    fbuf: np.ndarray | None = None      # ... or all of them in one float32 buffer (the C line-set kernels)
    dc: np.ndarray | None = None        # ... and the static part per channel (an order set has it in its table)
    dc32: np.ndarray | None = None      # ... the same as float32 (the C line-set kernel's argument)
    _y: np.ndarray | None = None
    _rms: np.ndarray | None = None

    @property
    def weights(self) -> np.ndarray:
        """(K,) order weights (fade x taper)."""
        return self.fade * (np.ones(self.x.shape[0]) if self.taper is None else self.taper)

    @property
    def y(self) -> np.ndarray:
        """(K, C) complex channel amplitudes (weights applied, no pre-emphasis)."""
        if self._y is None:
            self._y = self.y_emphasised / self.emphasis[:, None]
        return self._y

    @property
    def rms(self) -> np.ndarray:
        """(C,) RMS of the dynamic part (channel units)."""
        if self._rms is None:
            self._rms = np.sqrt(0.5 * np.sum(np.abs(self.y) ** 2, axis=0))
        return self._rms


@dataclass(slots=True)
class _Knot:
    x: int              # position [samples] (time * sample rate); knots sit on samples
    f: float            # shaft speed [Hz]
    u_int: int          # ball passes since t = 0: integer part ...
    u_frac: float       # ... and fraction in [0, 1)
    amp: "_Amplitudes"  # channel amplitudes and spline table at f




# =========================================================================== any line set in the synthesiser
#: ISO 10816 evaluation band for velocity RMS [Hz]
ISO_BAND_HZ = (10.0, 1000.0)


class LineSetPath:
    """The :class:`~bkabem_core.synth.synthesizer.Synthesizer`'s methods for any line set that is not BPFO orders only
    (families of :class:`LineFamilies`; module docstring). A mixin: it reads the synthesiser's state."""

    def _bind_lines(self, model: BkaBem) -> None:
        """Any line set (:mod:`bkabem_core.synth.linesets`): families of lines, one table (pair) each per knot; the
        spectrum at a knot from the model's exact response (its fixed-frequency and speed-scaled lines included)."""
        self._general = True
        try:                                         # the lines on one bearing's phases (shaft, cage, spin, line)
            lines = model.shared_phase_lines()
        except ValueError:
            raise SynthError("model", "the DE and NDE bearings have different kinematics: synthesis of two different "
                                      "bearings lands with the synthesiser rewrite") from None
        nu, mu = lines.multipliers, lines.fixed_hz
        keep = np.ones(len(lines), bool)
        if self._max_order_arg is not None:
            mo = self._max_order_arg
            if isinstance(mo, bool) or not isinstance(mo, (int, np.integer)) or mo < 1:
                raise SynthError("max_order", f"must be an integer >= 1 (got {mo!r})")
            keep = (nu <= mo * model.bpfo_per_hz) | ~lines.speed_locked
        self._model = model
        self.case = model.case
        self._keep = keep
        self._keep_some = not bool(np.all(keep))
        self.orders = np.asarray(model.orders, dtype=int)[keep]
        self.coefficients = lines.coefficients[keep]
        self._nu, self._mu = nu[keep], mu[keep]
        self._nu_top = float(self._nu.max()) if self._nu.size and not np.any(self._mu) else None
        self.bpfo_per_hz = float(model.bpfo_per_hz)
        self.n_balls = int(model.n_balls)
        self.fault_multipliers = model.bearing_multipliers["de"]        # the phases of shared_phase_lines
        self._k_max = max(1, int(math.ceil(float(self._nu.max()) / self.bpfo_per_hz)))
        self._families = LineFamilies(self.coefficients, lines.rates_per_hz, lines.line_hz, self.n_balls,
                                      self.bpfo_per_hz, self._table_size_arg)
        c = len(self.channels)
        # the C line-set kernels (float32): per knot one call from the spectrum to every family's tables (an FFT
        # each, into one buffer), per segment one pass over all families with noise and features fused
        # (_synthknot.h, _synthlines.h; synth_lineknots)
        self._lines_fused = synth_lineknots.AVAILABLE and self.dtype == np.float32 and c <= 64 \
            and len(self._families) <= 64
        plan = self._families.plan
        plan["out_off"] = plan["off_t"] = np.ascontiguousarray(plan["row_off"] * c)
        self.table_size = max(f.table_size for f in self._families.families)
        # (cos, sin) of a carrier's phase: one line each, a 64-point spline table (pre-emphasised: exact line)
        n = 64
        g = np.exp(2j * np.pi * ((np.arange(n + 3) - 1) % n) / n) / np.sinc(1.0 / n) ** 4
        self._carrier_table = np.ascontiguousarray(np.stack([g.real, g.imag], axis=1), dtype=self.dtype)
        comb, index, power, scale, iso = _combination(self.channels)
        self._comb, self._cindex, self._power, self._scale, self._iso_rows = comb, index, power, scale, iso
        self._housing_cols = np.flatnonzero((comb != 0).sum(axis=1) == 1)
        self._chain = self.accelerometer is not None or self.anti_alias is not None
        self._exact = ExactSpectrum(model, comb)
        self._modal = None
        self._modal_failed = None
        self._use_modal = False
        self._cells = None                   # the speed cells of the speed-locked lines (made on first use)
        dc8 = np.asarray(model.dc_m).reshape(-1)
        self._dc = (comb @ dc8)[index] * (power == 0)
        self._dc_off = np.ascontiguousarray(self._dc, dtype=np.float64)
        self._dc32 = np.ascontiguousarray(self._dc, dtype=np.float32)
        self._line_knots = LineKnots(plan, self._nu, self._mu, index, power, scale, iso, comb.shape[0]) \
            if self._lines_fused else None
        self._speed_scaled = bool(np.any(model._speed_power != 0.0))
        self._ones = np.ones(len(self._nu))
        self._chan_power = power.astype(float)
        self._power_index = power.astype(np.int64)
        self._chan_scale = scale.astype(float)
        self._scratch: dict = {}
        self._gt_base = self._ground_truth_base()

    def _top_line_hz(self, f: float) -> float:
        """Highest line frequency [Hz] at shaft speed f [Hz], max(nu f + mu): without fixed parts (mu = 0) and f >= 0
        the same float as max(nu) f (rounding is monotonic), without a pass over the lines."""
        if self._nu_top is not None and f >= 0.0:
            return self._nu_top * f
        return float(np.max(self._nu * f + self._mu))

    def _line_spectrum_at(self, f: float) -> np.ndarray:
        """Displacement combinations (K, U) [m] of every line at speed f [Hz]: the speed-locked lines from the
        model's speed cells (as the order path's modal spectrum, checked against the exact response once; the
        exact response per knot if the check fails or ``spectrum="exact"``), the others by their dense solve."""
        x, spow = self._line_spectrum_raw(f)
        if spow is not None:
            x *= spow[:, None]
        return x

    def _line_spectrum_raw(self, f: float):
        """(x, spow): :meth:`_line_spectrum_at` before the lines' speed powers, and those (``f ** p`` (K,), None
        if x has them or they are all 0). x is the speed cells' own array where they hold every line in order."""
        m = self._model
        if self._spectrum_kind != "exact" and self._cells is None and self._modal_failed is None:
            cells = m.order_modal_form(self._comb).speed_cells()
            self._cells = cells
            err = self._line_check(25.0)
            if err >= 1e-5:
                self._cells, self._modal_failed = None, f"error {err:.1e}"
        if self._cells is None:
            return np.ascontiguousarray(self._exact(f)), None
        li, fi = m._locked_idx, m._fixed_idx
        if fi.size or li.size != len(m.lines) or li[-1] != li.size - 1:
            x = np.empty((len(m.lines), self._comb.shape[0]), complex)
            x[li] = self._cells(f)
            if fi.size:
                x[fi] = m._fixed_lines(f) @ self._comb.T
        else:
            x = self._cells(f)                                # every line locked, in order (sorted indices)
        return x, (f ** m._speed_power if self._speed_scaled else None)

    def _line_check(self, f: float) -> float:
        """Largest error of the speed cells relative to the largest amplitude per combination, vs the exact one."""
        exact = self._exact(f)
        cells, self._cells = self._cells, None
        self._cells = cells
        m = self._model
        mine = np.array(exact, copy=True)
        mine[m._locked_idx] = cells(f) * (f ** m._speed_power[m._locked_idx])[:, None]
        return float(np.max(np.abs(mine - exact).max(axis=0) / np.maximum(np.abs(exact).max(axis=0), 1e-300)))

    @property
    def _general_method(self) -> str:
        return "modal" if self._cells is not None else "exact"

    def _kept_through_chain(self, x: np.ndarray, f: float) -> np.ndarray:
        """The kept lines of x (``max_order``) through the measurement chain (each line's complex gain at f [Hz])."""
        if self._keep_some:
            x = x[self._keep]
        if self._chain:
            x = x * chain_gains(self._nu * f + self._mu, self._housing_cols, self.accelerometer, self.anti_alias,
                                x.shape[1])
        return x

    def _line_amplitudes(self, f: float) -> "_Amplitudes":
        """Channel amplitudes and the families' tables at speed f [Hz] (any line set): with the C line-set kernels
        one call (:meth:`synth_lineknots.LineKnots.knot`: the numbers of :meth:`_line_amplitudes_numpy`)."""
        if self._line_knots is None:
            return self._line_amplitudes_numpy(f)
        x, spow = self._line_spectrum_raw(f)
        if spow is not None and (self._keep_some or self._chain):
            x *= spow[:, None]                                # (before the selection and the sensor chain)
            spow = None
        x = self._kept_through_chain(x, f)
        fade, taper = self._order_weights(f)
        y, v_iso, buf = self._line_knots.knot(x, f, fade, taper, spow)
        return _Amplitudes(f=f, x=x, fade=fade, taper=taper, y_emphasised=y, emphasis=self._ones, table=None,
                           v_iso=v_iso, ftables=None, families=self._families, dc=self._dc.copy(), fbuf=buf,
                           dc32=self._dc32)

    def _line_amplitudes_numpy(self, f: float) -> "_Amplitudes":
        """:meth:`_line_amplitudes` in numpy (float64 samples, or the C kernels not built)."""
        x = self._kept_through_chain(self._line_spectrum_at(f), f)
        fade, taper = self._order_weights(f)
        w = TWO_PI * (self._nu * f + self._mu)                               # (K,) [rad/s]
        iw = 1j * w
        powers = np.stack([np.ones_like(iw), iw, iw * iw])                  # (i w)^p, p = 0, 1, 2 (no complex pow)
        fac = powers[self._power_index].T * (self._chan_scale * fade)[None, :]
        if taper is not None:
            fac = fac * taper[:, None]
        y = x[:, self._cindex] * fac
        tables = self._families.tables(y, self.dtype)
        return _Amplitudes(f=f, x=x, fade=fade, taper=taper, y_emphasised=y, emphasis=np.ones(y.shape[0]),
                           table=None, ftables=tables, families=self._families, dc=self._dc.copy())

    @staticmethod
    def _phase_args(rate: float, fixed: float, ua: float, a: "_Knot", b: "_Knot", j: int, fs: float, bpfo: float):
        """(phase0, dphase0, ddphase) of the sample loop for a phase of ``rate`` turns per shaft turn plus ``fixed``
        turns per second, at sample j after knot a (speed linear from a to b): as the ball-pass phase of
        Synthesizer._segment, exact integers per (knot, sample)."""
        length = b.x - a.x
        t0 = LineFamilies.turns(rate, fixed, ua, a.x, bpfo, fs)
        c1 = (rate * a.f + fixed) / fs
        c2 = 0.5 * rate * (b.f - a.f) / (fs * length)
        d0 = round((c1 + c2) * PASS)
        dd = round(2.0 * c2 * PASS)
        return round(t0 * PASS) + j * d0 + dd * (j * (j - 1) // 2), d0 + j * dd, dd

    def _fused_plan(self, fams: "LineFamilies") -> dict:
        """What :meth:`_segment_lines_fused` needs of the families, made once per line set and slip setting: per
        phase (each family's, then its carrier's) the constants of :meth:`_phase_args` (rate / BPFO, fixed, rate,
        rate / 2), and the slip-offset row of each family's phase and carrier (-1: none) over the distinct slip
        factors ``kappas``, the carrier sums ``csrc`` (:func:`_carrier_sums`), handed to C once (``segments``:
        :class:`synth_lineknots.LineSegments`). The plan holds its families, so that another line set cannot take
        their id while it is cached (a model swap). Two plans are kept, so that the segment across a swap between
        line sets (both rendered) makes neither again."""
        key = (id(fams), self._slip_walk is not None)
        plans = self._scratch.setdefault("fused", OrderedDict())
        cached = plans.get(key)
        if cached is not None and cached["families"] is fams:
            plans.move_to_end(key)
            return cached
        walk = self._slip_walk
        kappas: list = []

        def row(kappa: float) -> int:
            if walk is None or kappa == 0.0:
                return -1
            if kappa not in kappas:
                kappas.append(kappa)
            return kappas.index(kappa)

        ff = fams.families
        bpfo = self.bpfo_per_hz
        phases = []
        for f in ff:
            phases.append((f.rate_p / bpfo, f.fixed_p, f.rate_p, 0.5 * f.rate_p))
            phases.append((f.rate_q / bpfo, f.fixed_q, f.rate_q, 0.5 * f.rate_q) if f.carrier else None)
        wp = np.array([row(f.kappa_p) for f in ff], dtype=np.int64)
        wq = np.array([row(f.kappa_q) if f.carrier else -1 for f in ff], dtype=np.int64)
        csrc = _carrier_sums(ff)
        plan = {"key": key, "families": fams, "kappas": tuple(kappas), "phases": phases, "wp": wp, "wq": wq,
                "csrc": csrc, "segments": LineSegments(fams.plan, phases, kappas, wp, wq, self.sample_rate_hz, csrc)}
        plans[key] = plan
        while len(plans) > 2:
            plans.popitem(last=False)
        return plan

    def _segment_lines_fused(self, a: _Knot, b: _Knot, lo: int, hi: int, out: np.ndarray, acc, noise) -> None:
        """:meth:`_segment_lines` by the C line-set kernel, one call (:meth:`synth_lineknots.LineSegments.segment`):
        every family (its phase and carrier in exact fixed point, :meth:`_phase_args`' integers, and their slip
        offsets) in one pass, the static part, the noise and the features of the block fused."""
        tb = None if b.amp is a.amp else b.amp.fbuf
        self._fused_plan(a.amp.families)["segments"].segment(hi - lo, lo - a.x, a, b, self._slip_walk,
                                                              self.bpfo_per_hz, a.amp.fbuf, tb, out, acc,
                                                              self._dc_off, a.amp.dc32, noise)

    def _segment_lines(self, a: _Knot, b: _Knot, lo: int, hi: int, out: np.ndarray, acc=None, noise=None) -> bool:
        """Samples [lo, hi) between knots a and b of any line set: every family's table(s) through the sample loop
        at the family's own phase (exact fixed point, as :meth:`_segment`); a carrier's cosine and sine through the
        same loop from a two-column table, mixed in C (:func:`synth_kernel.carrier_mix`). With the C line-set
        kernel, all of it in one pass (:meth:`_segment_lines_fused`), and then the noise and the features (``acc``)
        are taken there too: returns True if they were."""
        if a.amp.fbuf is not None:
            self._segment_lines_fused(a, b, lo, hi, out, acc, noise)
            return True
        m = hi - lo
        length = b.x - a.x
        fs, bpfo = self.sample_rate_hz, self.bpfo_per_hz
        j = lo - a.x
        ua = a.u_int + a.u_frac
        warps: dict = {}
        walk = self._slip_walk
        c1u = bpfo / fs * a.f
        c2u = 0.5 * bpfo / fs * (b.f - a.f) / length

        def warp_of(kappa: float):
            """Fixed-point slip offsets of a phase that moves kappa turns per ball pass of slip (None: no slip)."""
            if walk is None or kappa == 0.0:
                return None
            if kappa not in warps:
                warps[kappa] = walk.warp_fixed(a.u_int, j, m, c1u, c2u, a.u_frac, (kappa,))[0]
            return warps[kappa]

        out[...] = a.amp.dc
        scratch = self._scratch.get(m)
        if scratch is None:
            c = out.shape[1]
            scratch = self._scratch[m] = (np.empty((m, c), self.dtype), np.empty((m, c), self.dtype),
                                          np.empty((m, 2), self.dtype))
        same = b.amp is a.amp
        blend = 65536.0 / length
        for fi, fam in enumerate(a.amp.families.families):
            phase0, dphase0, dd = self._phase_args(fam.rate_p, fam.fixed_p, ua, a, b, j, fs, bpfo)
            warp = warp_of(fam.kappa_p)
            ta, tb = a.amp.ftables[fi], (None if same else b.amp.ftables[fi])
            for ti in range(len(ta)):
                self._segment_fn(phase0, dphase0, dd, warp, ta[ti], None if tb is None else tb[ti], float(j), blend,
                                 scratch[ti], None, self._dc_off)
            if not fam.carrier:
                out += scratch[0]
                continue
            q0, dq0, ddq = self._phase_args(fam.rate_q, fam.fixed_q, ua, a, b, j, fs, bpfo)
            self._segment_fn(q0, dq0, ddq, warp_of(fam.kappa_q), self._carrier_table, None, float(j), blend, scratch[2], None,
                             self._dc_off[:2])
            synth_kernel.carrier_mix(scratch[2], scratch[0], scratch[1], out)
        return False

    def _segment_swap(self, a: _Knot, b: _Knot, lo: int, hi: int, out: np.ndarray) -> None:
        """A segment across a model swap between line sets of different families (``set_model``): each knot's
        lines rendered on their own at the common phases, blended linearly in time as the tables of one model are
        (the 2^-16 steps of the sample loop): phase continuous, the amplitudes move from one model to the other
        over the segment."""
        other = np.empty_like(out)
        for side, dest in ((a, out), (b, other)):
            ka = _Knot(x=a.x, f=a.f, u_int=a.u_int, u_frac=a.u_frac, amp=side.amp)
            kb = _Knot(x=b.x, f=b.f, u_int=b.u_int, u_frac=b.u_frac, amp=side.amp)
            if side.amp.families is None:
                self._segment(ka, kb, lo, hi, dest, None)
            else:
                self._segment_lines(ka, kb, lo, hi, dest)
        xi = np.arange(lo - a.x, hi - a.x, dtype=np.float64) * (65536.0 / (b.x - a.x))
        w = (np.clip(np.floor(xi), 0.0, 65536.0) / 65536.0).astype(out.dtype)
        other -= out
        other *= w[:, None]
        out += other

    def _iso_velocity_lines(self, f: float, a, b, s: float) -> dict:
        """:meth:`_iso_velocity` for any line set: housing velocity of the lines in 10-1000 Hz at speed f."""
        freq = self._nu * f + self._mu
        band = (freq >= ISO_BAND_HZ[0]) & (freq <= ISO_BAND_HZ[1])
        if a.amp.families is not b.amp.families:                   # just swapped from another model
            a = b
        if b.amp.fbuf is not None:                                 # the C knots' velocities (L, 8): Re | Im
            va, vb = a.amp.v_iso, b.amp.v_iso
            r = band_rms_lines(vb if va.shape != vb.shape else va, vb, self._nu, self._mu, f, ISO_BAND_HZ, s)
            return {"de": {"vertical": r[0], "horizontal": r[1], "overall": max(r[0], r[1])},
                    "nde": {"vertical": r[2], "horizontal": r[3], "overall": max(r[2], r[3])}}

        def vel(amp):
            if amp.v_iso is None:                                   # once per knot speed
                w = TWO_PI * (self._nu * amp.f + self._mu)
                amp.v_iso = amp.x[:, self._iso_rows] * (1j * w * 1e3 * amp.weights)[:, None]
            return amp.v_iso

        va, vb = vel(a.amp), vel(b.amp)
        if va.shape != vb.shape:
            va = vb
        v = (va + s * (vb - va))[band]
        r = np.sqrt(0.5 * np.sum(np.abs(v) ** 2, axis=0)).tolist() if v.size else [0.0] * 4
        return {"de": {"vertical": r[0], "horizontal": r[1], "overall": max(r[0], r[1])},
                "nde": {"vertical": r[2], "horizontal": r[3], "overall": max(r[2], r[3])}}

