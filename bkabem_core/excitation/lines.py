"""Sets of lines: the interface between excitation, harmonic solve, improved method and synthesiser.

Every signal of bkabem is a sum of lines whose phases are integer combinations of a few *base phases*. One
bearing's lines (its excitation, :mod:`bkabem_core.excitation.quasi_static`) use the phases of that bearing,
:data:`BEARING_PHASES`:

    x(t) = DC + sum_j Re(A_j exp(i c_j . Phi(t))),      Phi = (theta_shaft, theta_cage, theta_spin, theta_line)

``theta_shaft`` (rate f_r), ``theta_cage`` (rate FTF f_r), ``theta_spin`` (spin of a ball about its own axis
relative to the cage, rate BSF f_r) are integrals of the shaft speed, 0 at t = 0 (cage angle 0, the BKA-BEM phase
reference); ``theta_line`` is the supply's electrical angle (rate f_line, fixed in Hz). A line's frequency is
``f_j = nu_j f_r + mu_j`` with the multiplier ``nu_j = c_j . (1, FTF, BSF, 0)`` [Hz per shaft Hz] and the fixed part
``mu_j = c_j[3] f_line`` [Hz]. Examples (z balls): BPFO order k is ``c = (0, k z, 0, 0)``, BPFI is
``(z, -z, 0, 0)``, its sideband at + f_r ``(z + 1, -z, 0, 0)``, 2 x BSF ``(0, 0, 2, 0)``, unbalance 1x
``(1, 0, 0, 0)``, the electrical 2 x line frequency ``(0, 0, 0, 2)``.

A machine has a bearing of its own at each position, with its own cage and spin rates: its lines use the
machine's phases :data:`BASE_PHASES`, ``(shaft, cage_de, spin_de, cage_nde, spin_nde, line)``, with rates
``(1, FTF_de, BSF_de, FTF_nde, BSF_nde, 0)`` (:class:`MachinePhases`). A bearing's lines are placed there by
:meth:`MachinePhases.place` (its cage and spin on its position's columns); a line never mixes two bearings' cage or
spin (checked). When both positions turn their cages and balls at the same rates (the same bearing at both ends, or
two with the same kinematics) there is one cage and one spin phase: every line is written on the DE columns and the
NDE columns stay 0, so the lines and every number are those of a machine with one bearing type.

Each line is kept once with ``f_j > 0`` (its conjugate is implied by the real part). Amplitudes are complex per
input (e.g. the vertical and horizontal relative displacement of a bearing [m], or a force pattern [N]), and may
scale with a power of the shaft speed (``speed_power``: 2 for an unbalance force, ``F = m e (2 pi f_r)^2``).

Units: amplitudes in the units of their inputs, rates in Hz per shaft Hz, ``line_hz`` in Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

#: The phases of one bearing (its excitation's lines, the defect kinds' tori).
BEARING_PHASES = ("shaft", "cage", "spin", "line")
#: The phases of a machine with a bearing at each position (:class:`MachinePhases`).
BASE_PHASES = ("shaft", "cage_de", "spin_de", "cage_nde", "spin_nde", "line")
N_PHASES = len(BASE_PHASES)
#: The cage and spin columns of each position in :data:`BASE_PHASES`.
BEARING_COLUMNS = {"de": (1, 2), "nde": (3, 4)}
_PHASE_NAMES = {len(BEARING_PHASES): BEARING_PHASES, N_PHASES: BASE_PHASES}


def _multipliers(coefficients: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """``nu_j`` [Hz per shaft Hz] of coefficient rows on :data:`BEARING_PHASES` or :data:`BASE_PHASES`: each row
    as a sum over (shaft, its bearing's cage, its bearing's spin) in that order, so that a machine's line has
    the bit-for-bit multiplier of the same line on one bearing's phases."""
    c = np.asarray(coefficients)
    if c.shape[1] == len(BEARING_PHASES):
        return c[:, :3] @ rates[:3]
    de = c[:, :3] @ rates[:3]
    if not c[:, 3:5].any():
        return de
    nde = c[:, [0, 3, 4]] @ rates[[0, 3, 4]]
    return np.where(c[:, 3:5].any(axis=1), nde, de)


def _check_one_bearing(coefficients: np.ndarray) -> None:
    """A line on the machine's phases never mixes the two bearings' cage or spin phases."""
    c = coefficients
    mixed = c[:, 1:3].any(axis=1) & c[:, 3:5].any(axis=1)
    if mixed.any():
        raise ValueError(f"a line mixes the DE and NDE bearings' cage/spin phases: {c[np.flatnonzero(mixed)[0]].tolist()}")


@dataclass
class LineSet:
    """Lines with integer coefficients on the base phases and complex amplitudes per input (module docstring).

    Attributes
    ----------
    coefficients : ndarray of int64 (L, N)
        ``c_j`` on one bearing's phases (N = 4: shaft, cage, spin, line) or on the machine's (N = 6: shaft,
        cage_de, spin_de, cage_nde, spin_nde, line); N is the length of ``rates_per_hz``.
    amplitude : ndarray complex (L, P)
        ``A_j`` per input, cosine convention ``x = Re(A exp(i c . Phi))`` [input units].
    inputs : tuple of str (P,)
        Names of the inputs (e.g. ``("vertical", "horizontal")``).
    rates_per_hz : ndarray (N,)
        Rate of each base phase per shaft Hz: (1, FTF, BSF, 0), or (1, FTF_de, BSF_de, FTF_nde, BSF_nde, 0).
    line_hz : float
        Supply frequency [Hz] (rate of ``theta_line``), 0 if no line uses it.
    speed_power : ndarray of int (L,)
        The amplitude is ``A_j (f_r / 1 Hz)^p_j`` (0: independent of speed).
    dc : ndarray (P,)
        Mean value per input [input units].
    """

    coefficients: np.ndarray
    amplitude: np.ndarray
    inputs: tuple
    rates_per_hz: np.ndarray
    line_hz: float = 0.0
    speed_power: np.ndarray | None = None
    dc: np.ndarray | None = None
    source: dict = field(default_factory=dict)

    def __post_init__(self):
        self.rates_per_hz = np.asarray(self.rates_per_hz, dtype=float)
        width = self.rates_per_hz.size
        if width not in _PHASE_NAMES:
            raise ValueError(f"rates_per_hz: {width} base phases (one bearing's 4 or a machine's 6)")
        self.coefficients = np.asarray(self.coefficients, dtype=np.int64).reshape(-1, width)
        if width == N_PHASES:
            _check_one_bearing(self.coefficients)
        n = self.coefficients.shape[0]
        self.amplitude = np.asarray(self.amplitude, dtype=complex).reshape(n, len(self.inputs))
        self.speed_power = (np.zeros(n, dtype=np.int64) if self.speed_power is None
                            else np.asarray(self.speed_power, dtype=np.int64).reshape(n))
        self.dc = np.zeros(len(self.inputs)) if self.dc is None else np.asarray(self.dc, dtype=float)

    # -- construction
    @classmethod
    def empty(cls, inputs, rates_per_hz, line_hz: float = 0.0) -> "LineSet":
        width = np.size(rates_per_hz)
        return cls(np.zeros((0, width), np.int64), np.zeros((0, len(inputs)), complex), tuple(inputs),
                   rates_per_hz, line_hz)

    @classmethod
    def from_orders(cls, orders, amplitude, n_balls: int, rates_per_hz, inputs, dc=None) -> "LineSet":
        """BPFO orders k (cage coefficient k z) with amplitudes (K, P) on one bearing's phases: the excitation of an
        outer race or a healthy bearing."""
        k = np.asarray(orders, dtype=np.int64)
        c = np.zeros((k.size, np.size(rates_per_hz)), np.int64)
        c[:, 1] = k * int(n_balls)
        return cls(c, amplitude, tuple(inputs), rates_per_hz, dc=dc)

    # -- derived
    def __len__(self) -> int:
        return int(self.coefficients.shape[0])

    @property
    def phase_names(self) -> tuple:
        """The names of the base phases of the coefficients' columns."""
        return _PHASE_NAMES[self.coefficients.shape[1]]

    @property
    def multipliers(self) -> np.ndarray:
        """``nu_j`` [Hz per shaft Hz] (the speed-proportional part of each line's frequency)."""
        return _multipliers(self.coefficients, self.rates_per_hz)

    @property
    def fixed_hz(self) -> np.ndarray:
        """``mu_j`` [Hz] (the part of each line's frequency that does not scale with speed)."""
        return self.coefficients[:, -1] * float(self.line_hz)

    @property
    def speed_locked(self) -> np.ndarray:
        """(L,) bool: lines whose frequency is proportional to the shaft speed (no ``line`` coefficient)."""
        return self.coefficients[:, -1] == 0

    def frequency_hz(self, speed_hz: float) -> np.ndarray:
        """Line frequencies [Hz] at a shaft speed [Hz]."""
        return self.multipliers * float(speed_hz) + self.fixed_hz

    def keys(self) -> list:
        return [tuple(int(v) for v in c) for c in self.coefficients]

    def scale(self, speed_hz: float) -> np.ndarray:
        """(L,) amplitude factors ``(f_r / 1 Hz)^p_j`` at a shaft speed [Hz]."""
        return float(speed_hz) ** self.speed_power.astype(float)

    # -- operations
    def subset(self, mask_or_index) -> "LineSet":
        idx = np.asarray(mask_or_index)
        return replace(self, coefficients=self.coefficients[idx], amplitude=self.amplitude[idx],
                       speed_power=self.speed_power[idx])

    def on(self, coefficients) -> "LineSet":
        """The same inputs on the given lines (zero amplitude where a line is not in this set)."""
        coefficients = np.asarray(coefficients, dtype=np.int64).reshape(-1, self.coefficients.shape[1])
        pos = {k: i for i, k in enumerate(self.keys())}
        amp = np.zeros((coefficients.shape[0], len(self.inputs)), complex)
        power = np.zeros(coefficients.shape[0], np.int64)
        for j, c in enumerate(coefficients):
            i = pos.get(tuple(int(v) for v in c))
            if i is not None:
                amp[j] = self.amplitude[i]
                power[j] = self.speed_power[i]
        return replace(self, coefficients=coefficients, amplitude=amp, speed_power=power)

    def sorted(self) -> "LineSet":
        """Lines by increasing frequency at 1 Hz shaft speed (ties: by coefficients)."""
        f = self.frequency_hz(1.0)
        order = np.lexsort((self.speed_power,) + tuple(self.coefficients.T[::-1]) + (f,))
        return self.subset(order)

    def select(self, relative_threshold: float, max_multiplier: float = 0.0, reference: float | None = None):
        """Lines with ``|A| >= threshold x reference`` in some input (reference: the largest |A|) and, if given,
        ``nu <= max_multiplier`` (fixed-frequency lines are kept)."""
        mag = np.abs(self.amplitude).max(axis=1) if len(self) else np.zeros(0)
        ref = float(mag.max()) if reference is None and mag.size else float(reference or 0.0)
        keep = mag >= relative_threshold * ref
        keep &= mag > 0.0
        if max_multiplier > 0:
            keep &= (self.multipliers <= max_multiplier * (1 + 1e-12)) | ~self.speed_locked
        return self.subset(np.flatnonzero(keep))

    def with_inputs(self, inputs, columns) -> "LineSet":
        """This set's amplitudes placed in ``columns`` of a new input list ``inputs`` (other inputs zero)."""
        amp = np.zeros((len(self), len(inputs)), complex)
        amp[:, list(columns)] = self.amplitude
        dc = np.zeros(len(inputs))
        dc[list(columns)] = self.dc
        return replace(self, amplitude=amp, inputs=tuple(inputs), dc=dc)

    def to_dict(self) -> dict:
        return {"base_phases": list(self.phase_names), "rates_per_hz": self.rates_per_hz.tolist(),
                "line_hz": self.line_hz, "coefficients": self.coefficients.tolist(),
                "multipliers": self.multipliers.tolist(), "inputs": list(self.inputs),
                "amplitude": {name: np.abs(self.amplitude[:, i]).tolist() for i, name in enumerate(self.inputs)},
                "phase_rad": {name: np.angle(self.amplitude[:, i]).tolist() for i, name in enumerate(self.inputs)},
                "speed_power": self.speed_power.tolist()}


def union(sets) -> LineSet:
    """One set over the same inputs holding every line of ``sets`` (amplitudes of equal lines with equal speed
    power added; the same line with another speed power stays a separate entry, e.g. the 1x of an inner-race
    defect's load zone and the unbalance; the first set's rates)."""
    sets = [s for s in sets if s is not None]
    first = sets[0]
    width = first.coefficients.shape[1]
    dc = np.zeros(len(first.inputs))
    line_hz = 0.0
    for s in sets:
        if s.inputs != first.inputs:
            raise ValueError(f"union: inputs differ ({s.inputs} vs {first.inputs})")
        if s.coefficients.shape[1] != width:
            raise ValueError(f"union: base phases differ ({s.phase_names} vs {first.phase_names})")
        dc = dc + s.dc
        if np.any(s.coefficients[:, -1] != 0):
            line_hz = s.line_hz
    keys = np.concatenate([np.column_stack([s.coefficients, s.speed_power]) for s in sets]).astype(np.int64)
    uniq, inverse = np.unique(keys.reshape(-1, width + 1), axis=0, return_inverse=True)
    amp = np.zeros((uniq.shape[0], len(first.inputs)), complex)
    np.add.at(amp, inverse.reshape(-1), np.concatenate([s.amplitude for s in sets]))   # in order: as a loop adds
    out = LineSet(uniq[:, :width], amp, first.inputs, first.rates_per_hz, line_hz, uniq[:, width], dc)
    return out.sorted()


def lines_from_grid(values: np.ndarray, phase_map: np.ndarray, rates_per_hz, inputs) -> LineSet:
    """Lines of a function sampled on a uniform grid of a 2-torus, by 2-D FFT.

    Parameters
    ----------
    values : ndarray (N1, N2, P)
        Samples at ``(a_1, a_2) = 2 pi (i / N1, j / N2)``, real.
    phase_map : ndarray of int (2, N)
        Coefficients of the grid's two angles on the base phases: ``a_r = phase_map[r] . Phi`` (N = the length of
        ``rates_per_hz``).
    rates_per_hz, inputs :
        As :class:`LineSet`.

    Returns
    -------
    LineSet
        Every resolved harmonic ``(m_1, m_2)`` (``|m_r| < N_r / 2``) with ``f > 0`` at 1 Hz, amplitude
        ``2 F[m_1, m_2]``, coefficients ``m_1 phase_map[0] + m_2 phase_map[1]``; the mean as ``dc``.
    """
    n1, n2, n_p = values.shape
    spec = np.fft.fft2(values, axes=(0, 1)) / (n1 * n2)
    m1 = np.fft.fftfreq(n1, 1.0 / n1).astype(np.int64)
    m2 = np.fft.fftfreq(n2, 1.0 / n2).astype(np.int64)
    ok1 = np.abs(m1) < n1 / 2
    ok2 = np.abs(m2) < n2 / 2
    g1, g2 = np.meshgrid(m1, m2, indexing="ij")
    pm = np.asarray(phase_map, dtype=np.int64)
    coef = g1[..., None] * pm[0] + g2[..., None] * pm[1]                         # (N1, N2, N)
    rates = np.asarray(rates_per_hz, dtype=float)
    if coef.shape[-1] == len(BEARING_PHASES):
        f1 = coef[..., :3] @ rates[:3]
    else:
        f1 = _multipliers(coef.reshape(-1, coef.shape[-1]), rates).reshape(coef.shape[:2])
    keep = (f1 > 1e-12) & ok1[:, None] & ok2[None, :]
    c = coef[keep]
    a = 2.0 * spec[keep]
    return LineSet(c, a, tuple(inputs), rates, dc=spec[0, 0].real.copy()).sorted()


def primitive(vector) -> tuple:
    """(g, p): the integer vector as ``g p`` with ``g = gcd`` of its components > 0 and ``p`` primitive."""
    v = [int(x) for x in vector]
    g = 0
    for x in v:
        g = math.gcd(g, abs(x))
    if g == 0:
        return 0, tuple(v)
    return g, tuple(x // g for x in v)


@dataclass(frozen=True)
class MachinePhases:
    """The base phases of a machine with a bearing at each position (module docstring).

    Attributes
    ----------
    rates_per_hz : ndarray (6,)
        ``(1, FTF_de, BSF_de, FTF_nde, BSF_nde, 0)`` [Hz per shaft Hz] on :data:`BASE_PHASES`.
    shared : bool
        Both bearings turn their cage and balls at the same rates (equal FTF and BSF multipliers): one cage and one
        spin phase, every line on the DE columns.
    """

    rates_per_hz: np.ndarray
    shared: bool

    @classmethod
    def of(cls, multipliers: dict) -> "MachinePhases":
        """The phases of a machine whose bearings have the fault multipliers ``multipliers`` (``{"de": ...,
        "nde": ...}``, :class:`~bkabem_core.bearing.deep_groove.FaultFrequencies` per shaft Hz)."""
        de, nde = multipliers["de"], multipliers["nde"]
        rates = np.array([1.0, de.ftf, de.bsf, nde.ftf, nde.bsf, 0.0])
        return cls(rates, bool(de.ftf == nde.ftf and de.bsf == nde.bsf))

    def columns(self, location: str) -> tuple[int, int]:
        """The (cage, spin) columns of the bearing at ``location`` (``"de"``/``"nde"``) in :data:`BASE_PHASES`."""
        return BEARING_COLUMNS["de" if self.shared else location]

    def bearing_rates(self, location: str) -> np.ndarray:
        """(4,) rates of the phases of the bearing at ``location`` (:data:`BEARING_PHASES`): (1, FTF, BSF, 0)."""
        cage, spin = BEARING_COLUMNS[location]
        return self.rates_per_hz[[0, cage, spin, N_PHASES - 1]]

    def place_coefficients(self, coefficients, location: str) -> np.ndarray:
        """(L, 6) coefficients on the machine's phases of lines (L, 4) on the phases of the bearing at
        ``location``."""
        c = np.asarray(coefficients, dtype=np.int64).reshape(-1, len(BEARING_PHASES))
        out = np.zeros((c.shape[0], N_PHASES), np.int64)
        cage, spin = self.columns(location)
        out[:, 0], out[:, cage], out[:, spin], out[:, -1] = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
        return out

    def place(self, lines: LineSet, location: str) -> LineSet:
        """The lines of the bearing at ``location`` (on its own phases) on the machine's phases."""
        return replace(lines, coefficients=self.place_coefficients(lines.coefficients, location),
                       rates_per_hz=self.rates_per_hz)

    def line_bearings(self, coefficients) -> list[str]:
        """Per line the bearing whose cage or spin it follows: ``"de"``, ``"nde"``, ``"de+nde"`` (shared phases:
        both bearings' lines are one line), or ``""`` (shaft and supply only: unbalance, misalignment, the
        electrical line, a shaft order)."""
        c = np.asarray(coefficients, dtype=np.int64).reshape(-1, N_PHASES)
        de, nde = c[:, 1:3].any(axis=1), c[:, 3:5].any(axis=1)
        return ["de+nde" if a and self.shared else "de" if a else "nde" if b else "" for a, b in zip(de, nde)]

    def on_one_bearing(self, lines: LineSet) -> LineSet:
        """The machine's lines on one bearing's phases (shaft, cage, spin, line), the form of a machine with one
        bearing type: possible when no line follows the NDE's own cage or spin (shared phases, or an NDE
        that is not excited); ValueError otherwise."""
        c = lines.coefficients
        if c[:, 3:5].any():
            raise ValueError("the lines follow two bearings' cages (different bearings at DE and NDE): they have no "
                             "form on one bearing's phases")
        return replace(lines, coefficients=c[:, [0, 1, 2, N_PHASES - 1]], rates_per_hz=self.bearing_rates("de"))
