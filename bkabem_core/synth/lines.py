"""The lines a synthesiser renders: a model's line set, the kept lines, and their families.

Every line has the phase ``c . Phi`` (:mod:`bkabem_core.excitation.lines`: ``c`` integer coefficients on the
machine's base phases ``Phi`` = (shaft, cage_de, spin_de, cage_nde, spin_nde, supply)) and a frequency ``nu f + mu``
at shaft speed ``f`` [Hz]. A line follows the cage and spin of one bearing at most (its *bearing*; none for the
shaft's and the supply's lines); when both bearings turn their cages and balls at the same rates every line is on the
DE's columns (one cage and one spin phase). The lines are split into *families*

    lines  c = k p + q,   k integer,      x_family(t) = Re(exp(i 2 pi phi_q) G(phi_p)),

``phi_p = p . Phi / 2 pi`` the family's phase in turns, ``G`` a periodic function of it, tabulated once per knot.
Without a carrier (``q = 0``) the family is ``Re sum_{k>=1} Y_k e^{i k 2 pi phi_p}``: one real table. With a carrier
(sidebands: ``q = n`` shaft orders for an inner race, ``n`` cage orders for a ball), ``k`` runs over both signs and
``G = Re G + i Im G`` takes two real tables; the sample is ``cos(2 pi phi_q) Re G - sin(2 pi phi_q) Im G``.
Families follow the kinds' own phases, written here on one bearing's phases (shaft, cage, spin, supply) with its
ball count z, and placed on the columns of the line's bearing (``p = (0, z, 0, 0, 0, 0)`` is the DE's ball pass,
``(0, 0, 0, z, 0, 0)`` the NDE's):

* ball spin ``p = (0, 0, 1, 0)`` (BSF), carrier the rest (``n`` FTF);
* supply ``p = (0, 0, 0, 1)``, carrier the rest;
* no shaft coefficient: the ball-pass phase ``p = (0, z, 0, 0)`` when the cage coefficient is a multiple of z
  (BPFO orders), else the cage phase ``(0, 1, 0, 0)`` (FTF orders);
* a cage coefficient that is a multiple of z: the inner-race phase ``p = (z, -z, 0, 0)`` (BPFI), carrier the
  remaining shaft orders (``n`` f_r: the load-zone sidebands);
* no cage coefficient: shaft orders ``p = (1, 0, 0, 0)`` (1x, 2x);
* anything else: its own primitive direction.

A set of BPFO orders (an outer race without baseline) is one family, ``p = (0, z, 0, 0, 0, 0)``, without carrier.

Every family's phase is an exact function of the knots (speed linear in time between them); random slip moves the
cages and the spins only, each bearing's by its own walk (``kappa``: turns of the family phase per step of its
bearing's walk; 0 for shaft and supply phases, so inner-race sidebands stay tied to f_r). The walks step once per
ball pass of the DE (the stream's clock, :mod:`bkabem_core.synth.randomness`): the DE's moves its phases
``(p_cage + p_spin BSF/FTF) / z`` turns per pass of slip, the NDE's ``sqrt(BPFO_nde / BPFO_de)`` times its own
``(p_cage + p_spin BSF/FTF) / z``, so that its jitter per NDE ball pass is the same relative ``slip``.

Units: phases in turns, frequencies in Hz, amplitudes in the channels' units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkabem_core.excitation.lines import BEARING_COLUMNS, N_PHASES
from bkabem_core.solve.harmonic import TWO_PI
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.profile import SynthError


@dataclass
class Family:
    """Lines ``k p + q`` of one table pair (module docstring).

    Attributes
    ----------
    p, q : tuple of int (6,)
        Phase and carrier coefficients on the machine's phases (shaft, cage_de, spin_de, cage_nde, spin_nde, line).
    lines : ndarray of int (K,)
        Indices of the family's lines in the kept line set.
    k : ndarray of int (K,)
        Harmonic of each line (``c = k p + q`` with ``sign = +1``, else ``c = -(k p + q)``).
    sign : ndarray (K,)
        +1, or -1 where the family holds the conjugate of the line (its amplitude enters conjugated).
    harmonics : ndarray of int (H,)
        Table harmonics 1..: for a real family the distinct k; for a carrier family the distinct |k| >= 1.
    table_size : int
    rate_p, fixed_p : float
        Turns of phi_p per shaft turn, and per second besides; ``rate_q``, ``fixed_q`` those of the carrier.
    kappa_p, kappa_q : float
        Turns of phi_p (phi_q) per step of the slip walk of its bearing (module docstring).
    bearing_p, bearing_q : str
        The bearing whose cage or spin phi_p (phi_q) follows, ``"de"`` or ``"nde"`` (whose slip walk moves it);
        ``""``: none (shaft and supply only).
    """

    p: tuple
    q: tuple
    lines: np.ndarray
    k: np.ndarray
    sign: np.ndarray
    harmonics: np.ndarray
    table_size: int
    rate_p: float = 0.0
    fixed_p: float = 0.0
    rate_q: float = 0.0
    fixed_q: float = 0.0
    kappa_p: float = 0.0
    kappa_q: float = 0.0
    bearing_p: str = ""
    bearing_q: str = ""

    @property
    def carrier(self) -> bool:
        return any(self.q)


def _family_on_bearing(c, z: int):
    """(p, k, q) with ``c = k p + q`` for the line c on one bearing's phases (shaft, cage, spin, line) (module
    docstring)."""
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


def line_bearing(c) -> str:
    """The bearing whose cage or spin the line (or phase) ``c`` on the machine's phases follows: ``"de"``,
    ``"nde"``, or ``""`` (shaft and supply only)."""
    return "nde" if c[3] != 0 or c[4] != 0 else "de" if c[1] != 0 or c[2] != 0 else ""


def _on_bearing(c, bearing: str) -> tuple:
    """The machine-phase vector ``c`` (6,) on the phases of ``bearing`` (shaft, cage, spin, line)."""
    cage, spin = BEARING_COLUMNS[bearing or "de"]
    return int(c[0]), int(c[cage]), int(c[spin]), int(c[N_PHASES - 1])


def _placed(v, bearing: str) -> tuple:
    """One bearing's phase vector ``v`` (4,) on the machine's phases, on the columns of ``bearing``."""
    out = [0] * N_PHASES
    cage, spin = BEARING_COLUMNS[bearing or "de"]
    out[0], out[cage], out[spin], out[-1] = v
    return tuple(out)


def _family_of(c, n_balls: dict):
    """(p, k, q) with ``c = k p + q`` for the line c on the machine's phases: its bearing's family (module
    docstring), placed on that bearing's columns."""
    own = line_bearing(c)
    p, k, q = _family_on_bearing(_on_bearing(c, own), n_balls[own or "de"])
    return _placed(p, own), k, _placed(q, own)


def _canonical(q) -> int:
    """+1 if the carrier's first non-zero coefficient is positive (or q = 0), else -1."""
    for v in q:
        if v != 0:
            return 1 if v > 0 else -1
    return 1


def carrier_sums(families: list) -> np.ndarray:
    """Per family (F, 2): the two families of its rows' group whose carriers add up to its own (``q = q_a + q_b``),
    or -1, -1: its carrier's cos / sin from its own phase. A group is what the C kernel evaluates together (one
    phase ``p``, table size and slip factor); the carriers of an inner race's BPFI families are the shaft orders
    1, 2, 3, ..., a ball's spin families the cage orders: only the first needs its own cos / sin (the others by the
    angle addition: 6 operations a sample instead of a phase and two polynomials). The carrier's rate, fixed part and slip factor are linear in
    ``q``, so the sum's phase is the family's own (to the fixed point's rounding). Each family's sources are taken
    among those already available, the shallowest pair first (each addition adds a float32 rounding or two), the
    rest from their own phase."""
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


class LineFamilies:
    """The families of a line set and their per-knot tables (module docstring).

    Parameters
    ----------
    coefficients : ndarray of int (L, 6)
        On the machine's phases (shaft, cage_de, spin_de, cage_nde, spin_nde, line).
    rates_per_hz : ndarray (6,)
        (1, FTF_de, BSF_de, FTF_nde, BSF_nde, 0).
    line_hz : float
        Supply frequency [Hz].
    n_balls : dict
        Ball count per bearing (``"de"``, ``"nde"``).
    table_size : int or None
        Fixed table size (power of 2), or None: max(64, 8 x the family's highest harmonic) each.
    walk_scale : dict or None
        Per bearing the slip walk's step in its own ball passes per DE ball pass of slip (module docstring:
        ``sqrt(BPFO_b / BPFO_de)``, 1 for the DE; None: 1 for both).
    """

    def __init__(self, coefficients, rates_per_hz, line_hz: float, n_balls: dict, table_size: int | None = None,
                 walk_scale: dict | None = None):
        coef = np.asarray(coefficients, dtype=np.int64)
        rates = np.asarray(rates_per_hz, dtype=float)
        balls = {b: int(z) for b, z in n_balls.items()}
        scale = dict(walk_scale or {})
        groups: dict = {}
        for j, c in enumerate(coef):
            p, k, q = _family_of(c, balls)
            sign = _canonical(q)
            if not any(q) and k < 0:
                sign = -1
            if sign < 0:
                k, q = -k, tuple(-v for v in q)
            groups.setdefault((p, q), []).append((j, k, sign))

        def kinematics(v):
            """(bearing, its phase vector (4,), its rates (4,), kappa per turn of slip) of a phase vector (6,)."""
            own = line_bearing(v)
            cage, spin = BEARING_COLUMNS[own or "de"]
            r4 = rates[[0, cage, spin, N_PHASES - 1]]
            v4 = _on_bearing(v, own)
            kappa = (v4[1] + v4[2] * (r4[2] / r4[1])) / balls[own or "de"]
            w = scale.get(own, 1.0)
            return own, v4, r4, (kappa * w if w != 1.0 else kappa)

        self.families: list[Family] = []
        for (p, q), members in groups.items():
            lines = np.array([m[0] for m in members], dtype=np.int64)
            k = np.array([m[1] for m in members], dtype=np.int64)
            sign = np.array([m[2] for m in members], dtype=float)
            harmonics = np.unique(np.abs(k[k != 0])) if any(q) else np.unique(k)
            if harmonics.size == 0:
                harmonics = np.array([1], dtype=np.int64)           # a carrier alone: tables of DC only
            top = int(harmonics.max())
            n = table_size or max(64, 1 << int(math.ceil(math.log2(8 * top))))
            if n < 4 * top or n > synth_kernel.MAX_TABLE:
                raise SynthError("table_size", f"{n} cannot hold harmonic {top} of the lines' family {p} "
                                               f"(needs a power of 2 >= {4 * top})")
            fam = Family(p=p, q=q, lines=lines, k=k, sign=sign, harmonics=harmonics, table_size=n)
            fam.bearing_p, p4, rp, fam.kappa_p = kinematics(p)
            fam.bearing_q, q4, rq, fam.kappa_q = kinematics(q)
            fam.rate_p = float(np.dot(p4[:3], rp[:3]))
            fam.fixed_p = p4[3] * float(line_hz)
            fam.rate_q = float(np.dot(q4[:3], rq[:3]))
            fam.fixed_q = q4[3] * float(line_hz)
            self.families.append(fam)
        # per family: each line's FFT slot (k mod N) and its B-spline pre-emphasis 1 / sinc(k / N)^4 (the cubic
        # B-spline's droop, so every line comes out exact); the padded rows (r - 1) mod N of each table size
        self._slots = [np.mod(f.k, f.table_size) for f in self.families]
        self._line_emphasis = [1.0 / np.sinc(f.k / f.table_size) ** 4 for f in self.families]
        self._pad = {f.table_size: (np.arange(f.table_size + 3) - 1) % f.table_size for f in self.families}
        self.table_size = max(f.table_size for f in self.families)

    def layout(self, n_channels: int) -> dict:
        """Flat arrays of the families for the C kernels: per family its lines, FFT slots and factors
        (pre-emphasis, negative where the line enters conjugated), table size and its log2, twiddles, carrier flag
        and the offset of its table(s) [floats] in one buffer of ``n_channels`` columns."""
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
        row_off = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int64)
        return {"F": len(fams), "n_lines": n_lines, "line": line, "slot": slot, "factor": factor, "N": sizes,
                "lg": np.array([int(n).bit_length() - 1 for n in sizes], dtype=np.int64),
                "tw": np.concatenate(tw), "tw_off": np.array([tw_off[int(n)] for n in sizes], dtype=np.int64),
                "carrier": carrier, "offset": np.ascontiguousarray(row_off * int(n_channels)),
                "floats": int(rows.sum()) * int(n_channels), "max_n": int(sizes.max())}

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


class LineSelection:
    """The lines of a model that a synthesiser renders (``max_order``), their frequencies and families.

    Parameters
    ----------
    model : BkaBem
    max_order : int or None
        Keep the speed-locked lines up to this BPFO order, each line counted in the BPFO of its own bearing (a
        shaft's or supply's line in the DE's; fixed-frequency lines are always kept); None: all.
    table_size : int or None
        Table size of every family (None: each its own, :class:`LineFamilies`).

    Attributes
    ----------
    nu, mu : ndarray (L,)
        Line frequency ``nu f + mu`` [Hz] at shaft speed f [Hz]: ``nu`` [Hz per shaft Hz] (for BPFO orders exactly
        ``k BPFO``), ``mu`` [Hz].
    coefficients : ndarray of int (L, 6)
        On the machine's phases (shaft, cage_de, spin_de, cage_nde, spin_nde, line).
    orders : ndarray of int (L,)
        The DE bearing's BPFO order of each line (0 for lines that are not DE BPFO orders).
    keep : ndarray of bool
        Which of the model's lines are kept (``max_order``).
    highest_order : int
        The highest BPFO order any kept line reaches, in its own bearing's BPFO (at least 1).
    bpfo_per_hz : float
        The DE bearing's BPFO per shaft Hz: the unit of ``orders`` and of the stream's ball passes.
    n_balls : int
        The DE bearing's ball count.
    multipliers : dict
        Per bearing its :class:`~bkabem_core.bearing.deep_groove.FaultFrequencies` per shaft Hz.
    shared : bool
        Both bearings turn their cages and balls at the same rates (every line on the DE's columns).
    families : LineFamilies
    """

    def __init__(self, model, max_order: int | None = None, table_size: int | None = None):
        lines = model.lines                             # on the machine's phases (shaft, cage/spin per bearing, line)
        self.multipliers = dict(model.bearing_multipliers)
        self.shared = bool(model.phases.shared)
        self.balls = {b: int(model.case.bearing_geometry(b).n_balls) for b in self.multipliers}
        nu, mu = np.asarray(model.multipliers, dtype=float), lines.fixed_hz
        bpfo = float(model.bpfo_per_hz)
        nde = lines.coefficients[:, 3:5].any(axis=1)
        own_bpfo = np.where(nde, self.multipliers["nde"].bpfo, bpfo) if nde.any() else np.full(nu.size, bpfo)
        keep = np.ones(len(lines), bool)
        if max_order is not None:
            if isinstance(max_order, bool) or not isinstance(max_order, (int, np.integer)) or max_order < 1:
                raise SynthError("max_order", f"must be an integer >= 1 (got {max_order!r})")
            keep = (nu <= max_order * own_bpfo * (1.0 + 1e-12)) | ~lines.speed_locked
            if not keep.any():
                raise SynthError("max_order", f"{max_order} keeps no line: the lowest is at order "
                                               f"{float(np.min(nu / own_bpfo)):.3g}")
        self.keep = keep
        self.keep_some = not bool(np.all(keep))
        self.bpfo_per_hz = bpfo
        self.nu, self.mu = nu[keep], mu[keep]
        self.coefficients = lines.coefficients[keep]
        self.orders = np.asarray(model.orders, dtype=int)[keep]
        self.n_balls = self.balls["de"]
        self.line_hz = float(lines.line_hz)
        #: the highest line frequency is max(nu) f where no line has a fixed part (f >= 0: rounding is monotonic)
        self._nu_top = float(self.nu.max()) if not np.any(self.mu) else None
        self.highest_order = max(1, int(math.ceil(float(np.max(self.nu / own_bpfo[keep])) - 1e-9)))
        #: the largest BPFO per shaft Hz of the bearings the kept lines follow (the band's unit of max_order)
        self.top_bpfo_per_hz = max([bpfo] + [self.multipliers["nde"].bpfo] * bool(nde[keep].any()))
        scale = {"de": 1.0, "nde": math.sqrt(self.multipliers["nde"].bpfo / bpfo)}
        self.families = LineFamilies(self.coefficients, lines.rates_per_hz, lines.line_hz, self.balls, table_size,
                                     scale)
        for a in (self.nu, self.mu, self.coefficients, self.orders, self.keep):
            a.flags.writeable = False

    def cage_angles_rad(self, ball_passes: float) -> dict:
        """Each bearing's cage angle [rad] in [0, 2 pi) at ``ball_passes`` ball passes of the DE since t = 0 (the
        stream's clock), before slip."""
        de = (TWO_PI * (ball_passes / self.n_balls)) % TWO_PI
        if self.shared:
            return {"de": de, "nde": de}
        nde = self.multipliers["nde"].ftf / self.bpfo_per_hz
        return {"de": de, "nde": (TWO_PI * (ball_passes * nde)) % TWO_PI}

    def __len__(self) -> int:
        return int(self.nu.size)

    def frequency_hz(self, speed_hz: float) -> np.ndarray:
        """(L,) line frequencies [Hz] at a shaft speed [Hz]."""
        return self.nu * float(speed_hz) + self.mu

    def top_hz(self, speed_hz: float) -> float:
        """The highest line frequency [Hz] at a shaft speed [Hz]."""
        if self._nu_top is not None and speed_hz >= 0.0:
            return self._nu_top * speed_hz
        return float(np.max(self.nu * speed_hz + self.mu))

    def max_speed_for_rate_hz(self, sample_rate_hz: float) -> float:
        """Highest shaft speed at which every line is below Nyquist [Hz]."""
        nyq = sample_rate_hz / 2
        with np.errstate(divide="ignore"):
            lim = np.where(self.nu > 0, (nyq - self.mu) / np.maximum(self.nu, 1e-300), np.inf)
        return float(max(lim.min(), 0.0))

    def taper_speeds_hz(self, sample_rate_hz: float, band=(0.8, 0.85, 0.95, 0.1)) -> tuple[float, float]:
        """Shaft speeds [Hz] between which some line is near the Nyquist taper (``band[0]`` .. ``band[2]`` of
        Nyquist: 0.8 .. 0.95 by default; ``band`` as :data:`~bkabem_core.synth.settings.TAPER_BAND`); an empty range
        (lo > hi) when no line moves with speed."""
        nyq = sample_rate_hz / 2
        moving = self.nu > 0
        if not moving.any():
            return math.inf, 0.0
        nu, mu = self.nu[moving], self.mu[moving]
        lo = float(np.min(np.maximum((band[0] * nyq - mu) / nu, 1e-9)))
        hi = float(np.max((band[2] * nyq - mu) / nu))
        return lo, hi

    def band_taper(self, speed_hz: float, sample_rate_hz: float, band=(0.8, 0.85, 0.95, 0.1)) -> np.ndarray | None:
        """The Nyquist taper per line at a shaft speed (raised cosine from ``band[1]`` to ``band[2]`` of Nyquist,
        0.85 to 0.95 by default), or None when every line is below ``band[1]``."""
        _, lo, hi, width = band
        r = (self.nu * speed_hz + self.mu) / (sample_rate_hz / 2)
        if r.max() <= lo:
            return None
        return np.where(r <= lo, 1.0, np.where(r >= hi, 0.0, 0.5 * (1 + np.cos(np.pi * (r - lo) / width))))

    def phases_rad(self, shaft_rad: float, cage_rad: dict, t_s: float) -> np.ndarray:
        """(L,) phase ``c . Phi`` of every line [rad] at the shaft angle, each bearing's cage angle ``cage_rad``
        (``{"de": .., "nde": ..}``) [rad] and time [s]: a bearing's spin angle is its cage angle times its
        BSF / FTF."""
        c = self.coefficients.astype(float)
        de, nde = self.multipliers["de"], self.multipliers["nde"]
        cage = float(cage_rad["de"])
        out = c[:, 0] * shaft_rad + c[:, 1] * cage + c[:, 2] * (de.bsf / de.ftf) * cage
        if c[:, 3:5].any():
            cn = float(cage_rad["nde"])
            out = out + c[:, 3] * cn + c[:, 4] * (nde.bsf / nde.ftf) * cn
        return out + c[:, 5] * 2.0 * math.pi * self.line_hz * t_s
