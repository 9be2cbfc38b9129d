"""Waveform synthesis: speed-driven, phase-continuous sensor signals for the DE and NDE bearings.

A monitoring pipeline consumes samples. :class:`Synthesizer` turns the BKA-BEM spectra of a case into the signals
real sensors give, chunk by chunk, under a shaft speed that may change at any time (a profile, or a stream of
updates arriving between chunks). The method, its error bounds and the realism options are described in
``docs/synthesis.md``; in short:

* **Angle domain.** Speed is integrated exactly (it is piecewise linear in time, so the ball-pass phase is a
  quadratic per segment) and order ``k`` contributes ``Re(Y_k exp(i k u 2 pi))`` where ``u`` is the number of
  ball passes since t = 0 (``u = z theta_cage / 2 pi``, cage angle 0 at t = 0, the convention of
  :mod:`bkabem_core.harmonic`). Signals are continuous in value and slope across chunks and speed changes.
* **Knots.** The complex amplitudes ``Y_k`` (per channel) are evaluated at *knots*: every chunk border in streaming,
  every ``knot_s`` of run time and every profile breakpoint when rendering a profile, plus subdivisions so that the
  speed moves by at most ``max_speed_step_hz`` between knots. Between knots amplitudes are linear in time.
* **Spectrum at a knot.** ``spectrum="modal"``: the FE model's order-wise pole-residue form
  (:class:`~bkabem_core.harmonic.OrderModalForm`): along an order the gyroscopic speed is proportional to the
  order frequency, so each order's response is an exact rational function of its frequency, evaluated in 0.5 Hz
  cells of shaft speed (:class:`~bkabem_core.harmonic.SpeedCells`: a Chebyshev interpolant of the far poles, the
  poles near the cell exactly, interpolation error bounded per pole to 2e-6 of the output's reference; ~7-13 us).
  Stated bound (tested): every order within 1e-5 of the channel's largest order, against
  :meth:`BkaBem.response`, at shaft speeds >= ``min_speed_hz``. ``spectrum="exact"`` calls
  :meth:`BkaBem.response` at every knot (about 0.6-1 ms each). ``"auto"`` (default): modal when streaming, the
  cheaper of the two for a rendered profile (the modal form's set-up, ~1.5 s once per model, and ~4 ms per speed
  cell, against ~0.6 ms saved per knot).
* **Wavetable.** At each knot one ball pass is tabulated as the coefficients of a periodic cubic B-spline
  (``table_size`` points, default max(256, 8 x highest order); the spline's droop sinc(k/N)^4 pre-emphasised, so
  every order comes out exact). Samples evaluate the spline at their phase (4 taps) and blend the two knot tables
  linearly in time, in a C loop (``_synthloop.c``: an AVX2 + FMA path for 8 float32 channels, within float32
  rounding of the numpy reference; a generic path bit-identical to it; the reference itself when the kernel is not
  built). The tables are made in C over a quarter wave (``synth_kernel.knot_table``). Phase is
  carried in fixed point (one pass = 2^62) as an exact function of knot and sample. Interpolation images of order
  k stay below ``(k / (N - k))^4`` of it (-77 dB for order 50 and 512 points).
* **Channels.** Per bearing and direction: ``acceleration`` of the housing [m/s^2] (accelerometer), ``displacement``
  of the shaft relative to the housing [m] (proximity probe), optionally ``velocity`` of the housing [mm/s].
  Names ``<bearing>_<direction>_<quantity>``, e.g. ``de_vertical_acceleration``.

Everything random (slip, noise) is seeded and indexed by absolute ball pass / sample number, so the samples do not
depend on how a run is cut into chunks. Bad input raises :class:`SynthError` naming the argument and the reason.
"""

from __future__ import annotations

import bisect
import csv
import io
import math
import sys
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from . import synth_kernel
from .harmonic import DIRECTIONS, LOCATIONS, TWO_PI, BkaBem, SpeedCells
from .sensors import Accelerometer, AntiAliasFilter, chain_gains
from .synth_lines import LineFamilies

BEARINGS = ("de", "nde")
#: quantity -> (unit, power of (i omega) applied to the displacement amplitude, scale to the unit)
QUANTITIES = {
    "acceleration": ("m/s^2", 2, 1.0),
    "displacement": ("m", 0, 1.0),
    "velocity": ("mm/s", 1, 1.0e3),
}
DEFAULT_QUANTITIES = ("acceleration", "displacement")
#: ISO 10816 evaluation band for velocity RMS [Hz]
ISO_BAND_HZ = (10.0, 1000.0)

MAX_SAMPLE_RATE_HZ = 1.0e6
MAX_SLIP = 0.1
_PASS = float(synth_kernel.PASS_UNITS)   # fixed-point units of one ball pass (2^62): phase arithmetic of the loop


class SynthError(ValueError):
    """Bad synthesis input. ``argument`` names the offending argument (or profile field), ``reason`` says why."""

    def __init__(self, argument: str, reason: str):
        self.argument = argument
        self.reason = reason
        super().__init__(f"{argument}: {reason}")


def _finite(name: str, value, minimum: float | None = None, strict: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SynthError(name, f"must be a number (got {value!r})") from None
    if not math.isfinite(v):
        raise SynthError(name, f"must be finite (got {value!r})")
    if minimum is not None and (v <= minimum if strict else v < minimum):
        raise SynthError(name, f"must be {'>' if strict else '>='} {minimum:g} (got {v:g})")
    return v


# =========================================================================== speed profiles
_SPEED_UNIT_TO_HZ = {"hz": 1.0, "rpm": 1.0 / 60.0, "rad_s": 1.0 / TWO_PI}


@dataclass(frozen=True)
class SpeedProfile:
    """Shaft speed as a piecewise-linear function of time, held constant after the last point.

    Attributes
    ----------
    times_s : ndarray (P,)
        Breakpoint times [s], strictly increasing, first one 0.
    speeds_hz : ndarray (P,)
        Shaft speed at the breakpoints [Hz] (revolutions per second), finite and >= 0.
    spec : str
        How the profile was given (for metadata).
    """

    times_s: np.ndarray
    speeds_hz: np.ndarray
    spec: str = ""

    @classmethod
    def from_points(cls, times_s, speeds_hz, spec: str = "points", source: str = "profile") -> "SpeedProfile":
        t = np.asarray(times_s, dtype=float).ravel()
        f = np.asarray(speeds_hz, dtype=float).ravel()
        if t.size == 0 or t.size != f.size:
            raise SynthError(source, "needs at least one (time, speed) point and as many times as speeds")
        if not np.all(np.isfinite(t)):
            raise SynthError(source, "times must be finite")
        if not np.all(np.isfinite(f)):
            raise SynthError(source, "speeds must be finite (NaN or inf found)")
        if np.any(f < 0):
            raise SynthError(source, f"speeds must be >= 0 (got {f.min():g} Hz)")
        if np.any(t < 0):
            raise SynthError(source, "times must be >= 0")
        if np.any(np.diff(t) <= 0):
            raise SynthError(source, "times must be strictly increasing")
        if t[0] > 0:                                   # hold the first value from t = 0
            t, f = np.concatenate([[0.0], t]), np.concatenate([[f[0]], f])
        t.setflags(write=False)
        f.setflags(write=False)
        return cls(t, f, spec)

    @classmethod
    def constant(cls, speed_hz: float) -> "SpeedProfile":
        v = _finite("profile.speed_hz", speed_hz, 0.0)
        return cls.from_points([0.0], [v], f"constant:{v:g}")

    @classmethod
    def ramp(cls, from_hz: float, to_hz: float, duration_s: float) -> "SpeedProfile":
        a = _finite("profile.from_hz", from_hz, 0.0)
        b = _finite("profile.to_hz", to_hz, 0.0)
        d = _finite("profile.duration_s", duration_s, 0.0, strict=True)
        return cls.from_points([0.0, d], [a, b], f"ramp:{a:g}:{b:g}:{d:g}")

    @classmethod
    def steps(cls, speeds_hz, step_s: float) -> "SpeedProfile":
        """Each speed held for ``step_s``, jumps linear over 1 ms (a speed step is never a phase step)."""
        v = [_finite(f"profile.speed[{i}]", s, 0.0) for i, s in enumerate(speeds_hz)]
        d = _finite("profile.step_s", step_s, 0.0, strict=True)
        if not v:
            raise SynthError("profile", "steps needs at least one speed")
        ramp = min(1e-3, d / 10)
        t, f = [0.0], [v[0]]
        for i in range(1, len(v)):
            t += [i * d, i * d + ramp]
            f += [v[i - 1], v[i]]
        return cls.from_points(t, f, "steps:" + ",".join(f"{x:g}" for x in v) + f":{d:g}")

    @classmethod
    def from_csv(cls, path) -> "SpeedProfile":
        """Two columns, time and speed. A header names units: ``time_s`` and ``speed_hz`` | ``speed_rpm`` |
        ``speed_rad_s``; without a header (first row numeric) the units are s and Hz. ``#`` starts a comment."""
        p = Path(path)
        if not p.is_file():
            raise SynthError("profile", f"CSV file not found: {p}")
        try:
            text = p.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise SynthError("profile", f"cannot read {p}: {exc}") from None
        rows = [r for r in csv.reader(io.StringIO(text))
                if r and any(c.strip() for c in r) and not r[0].strip().startswith("#")]
        if not rows:
            raise SynthError("profile", f"{p}: no data rows")
        factor, unit = 1.0, "hz"
        try:
            float(rows[0][0])
        except ValueError:
            head = [c.strip().lower() for c in rows[0]]
            rows = rows[1:]
            if len(head) < 2 or not head[0].startswith(("time", "t")):
                raise SynthError("profile", f"{p}: header must be 'time_s,speed_<unit>' (got {','.join(head)})")
            if head[0] not in ("time_s", "time", "t", "t_s"):
                raise SynthError("profile", f"{p}: time column must be in seconds ('time_s'), got {head[0]!r}")
            unit = head[1].replace("speed_", "").replace("/", "_").replace("speed", "hz") or "hz"
            if unit not in _SPEED_UNIT_TO_HZ:
                raise SynthError("profile", f"{p}: speed unit {head[1]!r} not one of speed_hz, speed_rpm, speed_rad_s")
            factor = _SPEED_UNIT_TO_HZ[unit]
        t, f = [], []
        for i, r in enumerate(rows):
            if len(r) < 2:
                raise SynthError("profile", f"{p}: row {i + 1} needs two columns (time, speed)")
            try:
                t.append(float(r[0]))
                f.append(float(r[1]) * factor)
            except ValueError:
                raise SynthError("profile", f"{p}: row {i + 1} is not numeric: {','.join(r)}") from None
        return cls.from_points(t, f, f"csv:{p.name}({unit})", source=f"profile ({p.name})")

    # -- evaluation
    def speed_hz(self, t_s):
        """Speed [Hz] at time(s) ``t_s`` [s] (linear between points, held after the last)."""
        return np.interp(t_s, self.times_s, self.speeds_hz)

    def max_speed_hz(self, until_s: float | None = None) -> float:
        if until_s is None:
            return float(self.speeds_hz.max())
        inside = self.speeds_hz[self.times_s <= until_s]
        return float(max(inside.max(), self.speed_hz(until_s)))

    @property
    def duration_s(self) -> float:
        """Time of the last breakpoint [s] (the speed is held afterwards)."""
        return float(self.times_s[-1])

    def to_dict(self) -> dict:
        return {"spec": self.spec, "times_s": self.times_s.tolist(), "speeds_hz": self.speeds_hz.tolist()}


def parse_profile(spec) -> SpeedProfile:
    """``constant:F`` | ``ramp:F0:F1:T`` | ``steps:F1,F2,...:T`` | ``FILE.csv`` (speeds in Hz, times in s)."""
    if isinstance(spec, SpeedProfile):
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise SynthError("profile", f"must be constant:F, ramp:F0:F1:T, steps:F1,F2,...:T or a CSV file (got {spec!r})")
    s = spec.strip()
    if s.lower().endswith(".csv") or (Path(s).suffix and Path(s).is_file()):
        return SpeedProfile.from_csv(s)
    kind, _, rest = s.partition(":")
    kind = kind.lower()
    parts = rest.split(":") if rest else []
    if kind == "constant":
        if len(parts) != 1:
            raise SynthError("profile", f"constant takes one value, constant:F [Hz] (got {s!r})")
        return SpeedProfile.constant(_num("profile.speed_hz", parts[0]))
    if kind == "ramp":
        if len(parts) != 3:
            raise SynthError("profile", f"ramp takes three values, ramp:F0:F1:T [Hz, Hz, s] (got {s!r})")
        a, b, d = (_num(n, x) for n, x in zip(("profile.from_hz", "profile.to_hz", "profile.duration_s"), parts))
        return SpeedProfile.ramp(a, b, d)
    if kind == "steps":
        if len(parts) != 2:
            raise SynthError("profile", f"steps takes steps:F1,F2,...:T [Hz..., s] (got {s!r})")
        vals = [_num("profile.speed_hz", x) for x in parts[0].split(",") if x.strip()]
        return SpeedProfile.steps(vals, _num("profile.step_s", parts[1]))
    raise SynthError("profile", f"unknown profile kind {kind!r}: use constant:F, ramp:F0:F1:T, "
                                f"steps:F1,F2,...:T or FILE.csv")


def _num(name: str, text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise SynthError(name, f"not a number: {text!r}") from None


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

    A thin view of :class:`~bkabem_core.harmonic.OrderModalForm` and its :class:`~bkabem_core.harmonic.SpeedCells`
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
    """Displacement combinations from :meth:`BkaBem.response` at each requested speed (LRU cache)."""

    def __init__(self, model: BkaBem, combination: np.ndarray, cache: int = 256):
        self.model = model
        self._comb = combination
        self._cache: OrderedDict[float, np.ndarray] = OrderedDict()
        self._size = cache

    def __call__(self, speed_hz: float) -> np.ndarray:
        key = float(speed_hz)
        x = self._cache.get(key)
        if x is None:
            k = self.model.orders.size
            x = self.model.response([key])[0].reshape(k, -1) @ self._comb.T
            self._cache[key] = x
            if len(self._cache) > self._size:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return x


# =========================================================================== randomness
class _SlipWalk:
    """Random walk W_j of the ball-pass phase [passes] at integer nominal passes j (W_j = 0 for j <= 0).

    ``W_{j+1} - W_j ~ N(0, sigma^2)`` i.i.d.: the j-th inter-arrival lasts ``1 - (W_{j+1} - W_j)`` nominal passes,
    i.e. a relative jitter of standard deviation ``sigma`` (Antoni & Randall's random slip). Increments come in
    blocks of 2^14 passes, each from its own seeded generator, so values depend only on (seed, j).
    """

    BLOCK = 1 << 14

    def __init__(self, sigma: float, seed: int):
        self.sigma = float(sigma)
        self.seed = int(seed)
        self.reset()

    def reset(self):
        self._blocks: OrderedDict[int, np.ndarray] = OrderedDict()
        self._next_block = 0
        self._next_start = 0.0

    def _block(self, b: int) -> np.ndarray:
        if b in self._blocks:
            return self._blocks[b]
        if b < self._next_block:                         # went back beyond the kept blocks: replay
            self.reset()
        while self._next_block <= b:
            rng = np.random.default_rng(np.random.SeedSequence([self.seed, 0x51117, self._next_block]))
            eps = self.sigma * rng.standard_normal(self.BLOCK)
            w = np.empty(self.BLOCK)
            w[0] = 0.0
            np.cumsum(eps[:-1], out=w[1:])
            w += self._next_start
            self._next_start = float(w[-1] + eps[-1])
            self._blocks[self._next_block] = w
            self._next_block += 1
            while len(self._blocks) > 3:
                self._blocks.popitem(last=False)
        return self._blocks[b]

    def values(self, j0: int, j1: int) -> np.ndarray:
        """W_j for j in [j0, j1] (inclusive)."""
        out = np.zeros(j1 - j0 + 1)
        lo = max(j0, 0)
        j = lo
        while j <= j1:
            b = j // self.BLOCK
            blk = self._block(b)
            s = j - b * self.BLOCK
            e = min(self.BLOCK, j1 - b * self.BLOCK + 1)
            out[j - j0:j - j0 + e - s] = blk[s:e]
            j += e - s
        return out

    def warp(self, u_int: int, u: np.ndarray) -> np.ndarray:
        """W at absolute passes ``u_int + u`` (C1 cubic Hermite, Catmull-Rom slopes)."""
        fl = np.floor(u)
        j_lo, j_hi = int(fl[0]) if u.size else 0, int(fl[-1]) if u.size else 0
        j_lo, j_hi = min(j_lo, int(fl.min())), max(j_hi, int(fl.max()))
        w = self.values(u_int + j_lo - 1, u_int + j_hi + 2)
        m = np.empty_like(w)
        m[1:-1] = 0.5 * (w[2:] - w[:-2])
        m[0], m[-1] = m[1], m[-2]
        idx = fl.astype(np.intp) - (j_lo - 1)
        t = u - fl
        t2 = t * t
        t3 = t2 * t
        w0, w1 = w[idx], w[idx + 1]
        m0, m1 = m[idx], m[idx + 1]
        return (2 * t3 - 3 * t2 + 1) * w0 + (t3 - 2 * t2 + t) * m0 + (3 * t2 - 2 * t3) * w1 + (t3 - t2) * m1


class _NoiseBlocks:
    """Standard normal noise (n, C) indexed by absolute sample, generated in seeded blocks.

    Block b comes from the stream keyed by ``SeedSequence([seed, tag, b])``: the C generator of ``_synthloop.c``
    (~3x faster than numpy's, which made noise the largest cost of a noisy run), or numpy's generator when the
    kernel is not built (then the noise is another, equally valid, realisation for the same seed)."""

    BLOCK = 1 << 13
    _TAG = 0x4015E

    def __init__(self, seed: int, n_channels: int, dtype):
        self.seed, self.c, self.dtype = int(seed), int(n_channels), dtype
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()

    def _block(self, b: int) -> np.ndarray:
        z = self._cache.get(b)
        if z is None:
            seq = np.random.SeedSequence([self.seed, self._TAG, b])
            dt = np.float32 if self.dtype == np.float32 else np.float64
            if synth_kernel.AVAILABLE:
                key = int(seq.generate_state(1, np.uint64)[0])
                z = synth_kernel.normals(key, self.BLOCK * self.c, dt).reshape(self.BLOCK, self.c)
            else:
                z = np.random.default_rng(seq).standard_normal((self.BLOCK, self.c), dtype=dt)
            self._cache[b] = z
            while len(self._cache) > 4:
                self._cache.popitem(last=False)
        return z

    def get(self, n0: int, n: int) -> np.ndarray:
        out = np.empty((n, self.c), dtype=self.dtype)
        i = n0
        while i < n0 + n:
            b = i // self.BLOCK
            s = i - b * self.BLOCK
            e = min(self.BLOCK, n0 + n - b * self.BLOCK)
            out[i - n0:i - n0 + e - s] = self._block(b)[s:e]
            i += e - s
        return out


# =========================================================================== chunks
@dataclass
class Chunk:
    """One block of samples of every channel.

    Attributes
    ----------
    samples : ndarray (channels, n), float32 or float64
        Signals in ``units`` (a transposed view of a sample-major buffer: rows are strided; use
        ``np.ascontiguousarray`` if a contiguous row is needed).
    first_sample_index : int
        Index of the first sample in the stream (sample i is at ``i / sample_rate_hz`` s).
    t0_s : float
        Time of the first sample [s].
    sample_rate_hz : float
    channel_names, units : tuple of str
    shaft_speed_hz : float
        Shaft speed at the first sample [Hz]; ``shaft_speed_end_hz`` at the first sample of the next chunk.
    cage_angle_rad, shaft_angle_rad : float
        Cage and shaft angle at the first sample [rad], in [0, 2 pi) (0 at t = 0). Order k of the BKA-BEM spectrum
        has phase ``k z cage_angle`` there (z balls), before slip.
    features : dict
        Per channel (arrays aligned with ``channel_names``): ``mean``, ``rms`` (about the mean), ``peak``
        (largest |x - mean|), ``peak_to_peak``, ``crest_factor`` (peak/rms), ``kurtosis`` (non-excess, 3 for a
        Gaussian); and ``iso10816_velocity_rms_mm_s`` per housing and direction (+ ``overall`` = the larger).
        Constant signals have crest factor and kurtosis 0 (never NaN).
    ground_truth : dict
        Case identity, bearing, defect, fault frequencies at ``shaft_speed_hz``, seed and realism settings.
    """

    samples: np.ndarray
    first_sample_index: int
    t0_s: float
    sample_rate_hz: float
    channel_names: tuple
    units: tuple
    shaft_speed_hz: float
    shaft_speed_end_hz: float
    cage_angle_rad: float
    shaft_angle_rad: float
    features: dict = field(default_factory=dict)
    ground_truth: dict = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[1])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    @property
    def time_s(self) -> np.ndarray:
        """Sample times [s]."""
        return (self.first_sample_index + np.arange(self.n_samples)) / self.sample_rate_hz

    def channel(self, name: str) -> np.ndarray:
        return self.samples[self.channel_names.index(name)]

    def rows(self, bearing: str, quantity: str) -> list[int]:
        """Row indices [vertical, horizontal] of ``bearing`` (de/nde) and ``quantity``."""
        return [self.channel_names.index(f"{bearing}_{d}_{quantity}") for d in DIRECTIONS]

    def to_dict(self) -> dict:
        """Everything except the samples, JSON-ready."""
        feats = {}
        for k, v in self.features.items():
            if isinstance(v, np.ndarray):
                feats[k] = dict(zip(self.channel_names, (float(x) for x in v)))
            else:
                feats[k] = v
        return {"first_sample_index": int(self.first_sample_index), "t0_s": self.t0_s,
                "n_samples": self.n_samples, "sample_rate_hz": self.sample_rate_hz,
                "channel_names": list(self.channel_names), "units": list(self.units),
                "shaft_speed_hz": self.shaft_speed_hz, "shaft_speed_end_hz": self.shaft_speed_end_hz,
                "cage_angle_rad": self.cage_angle_rad, "shaft_angle_rad": self.shaft_angle_rad,
                "features": feats, "ground_truth": self.ground_truth}


_FOLD = 64   # numpy is slow on short rows: (n, C) blocks are processed as (n / 64, 64 C)


def _colwise(x: np.ndarray, fn) -> np.ndarray:
    """``fn`` (np.max or np.min) over the rows of a sample-major (n, C) block."""
    n, c = x.shape
    q = n // _FOLD * _FOLD
    r = None
    if q:
        r = fn(fn(x[:q].reshape(-1, _FOLD * c), axis=0).reshape(_FOLD, c), axis=0)
    if q < n:
        t = fn(x[q:], axis=0)
        r = t if r is None else (np.maximum(r, t) if fn is np.max else np.minimum(r, t))
    return r


def waveform_features(x: np.ndarray, offset: np.ndarray | None = None) -> dict:
    """Features of a sample-major block ``x`` (n, C): mean, rms, peak, peak_to_peak, crest_factor, kurtosis.

    ``offset`` (C,), e.g. the known static part, is removed before the mean is taken, so that signals riding on a
    large DC keep their precision in float32; moments are then central (two passes)."""
    n, c = x.shape
    off = np.zeros(c, x.dtype) if offset is None else np.asarray(offset, x.dtype)
    ones = np.ones(n, x.dtype)
    q = n // _FOLD * _FOLD
    xc = np.empty_like(x)

    def sub(v):                                   # xc = x - v (rows folded, see _FOLD)
        if q:
            np.subtract(x[:q].reshape(-1, _FOLD * c), np.tile(v, _FOLD), out=xc[:q].reshape(-1, _FOLD * c))
        if q < n:
            np.subtract(x[q:], v, out=xc[q:])

    sub(off)
    mu = (ones @ xc) / x.dtype.type(n)
    centre = (off + mu).astype(x.dtype)
    sub(centre)
    s1 = (ones @ xc).astype(np.float64) / n               # ~0 (round-off of the centre)
    x2 = xc * xc
    s2 = (ones @ x2).astype(np.float64) / n
    np.multiply(x2, x2, out=x2)
    s4 = (ones @ x2).astype(np.float64) / n
    hi = _colwise(xc, np.max).astype(np.float64)
    lo = _colwise(xc, np.min).astype(np.float64)
    return _moment_features(s1, s2, 0.0 * s1, s4, hi, lo, centre)


def _moment_features(s1, s2, s3, s4, hi, lo, off) -> dict:
    """Features from raw moments s_p = mean((x - off)^p) and the extremes of x - off."""
    m2 = np.maximum(s2 - s1 * s1, 0.0)
    m4 = np.maximum(s4 - 4 * s1 * s3 + 6 * s1 * s1 * s2 - 3 * s1 ** 4, 0.0)
    rms = np.sqrt(m2)
    peak = np.maximum(hi - s1, s1 - lo)
    ok = m2 > 0
    safe = np.where(ok, m2, 1.0)
    return {"mean": s1 + off.astype(np.float64), "rms": rms, "peak": peak, "peak_to_peak": hi - lo,
            "crest_factor": np.where(ok, peak / np.sqrt(safe), 0.0),
            "kurtosis": np.where(ok, m4 / (safe * safe), 0.0)}


# =========================================================================== the synthesiser
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


class Synthesizer:
    """Speed-driven, phase-continuous sensor signals of one case, chunk by chunk.

    Parameters
    ----------
    model : BkaBem
        The prepared model of the case (its spectrum is evaluated at every knot).
    sample_rate_hz : float
        Samples per second (default 25 600; up to 1 MHz).
    chunk_s : float
        Chunk length [s] (default 0.1); ``round(chunk_s * sample_rate_hz)`` samples.
    quantities : sequence of str
        Any of ``"acceleration"`` (housing, m/s^2), ``"displacement"`` (shaft relative to housing, m),
        ``"velocity"`` (housing, mm/s). Default acceleration and displacement (8 channels).
    noise_density : dict or None
        White sensor noise, one-sided density per quantity: ``{"acceleration": m/s^2/sqrt(Hz), "displacement":
        m/sqrt(Hz), "velocity": mm/s/sqrt(Hz)}``; noise RMS = density * sqrt(sample_rate / 2).
    snr_db : float or None
        Alternative to ``noise_density``: noise RMS = dynamic signal RMS of the channel (from the order amplitudes
        at the segment's knots) / 10^(snr_db / 20).
    slip : float
        Standard deviation of the ball-pass inter-arrival as a fraction of its nominal value (0 = off; real
        bearings 0.01-0.02). Must be in [0, 0.1].
    seed : int or None
        Seed of slip and noise (None: a random seed, reported in the ground truth).
    max_order : int or None
        Synthesise model orders up to this one (None: every order the model keeps).
    band_limit : {"error", "taper"}
        ``"error"``: every kept order must stay below Nyquist at every speed (else :class:`SynthError`).
        ``"taper"``: orders fade out (raised cosine) between 0.85 and 0.95 of Nyquist and are dropped above,
        evaluated at the knots, with knots close enough that nothing aliases.
    spectrum : {"auto", "modal", "exact"}
        How the BKA-BEM spectrum is evaluated at a knot (see the module docstring). ``"auto"``: modal when
        streaming; for a rendered profile the cheaper of the two for that profile (both within the stated bound).
    knot_s : float
        Largest time between amplitude knots when rendering a profile [s] (default 0.1). In streaming, knots are
        the chunk borders.
    max_speed_step_hz : float
        Largest speed change between knots [Hz]; longer segments are subdivided (default 0.5).
    min_speed_hz : float
        Below this speed only the static part is output; the orders fade in (smoothstep) up to twice it.
    initial_speed_hz : float or None
        Speed at t = 0 for streaming; None: the first update (the first chunk is then at constant speed).
    dtype : numpy dtype
        ``np.float32`` (default) or ``np.float64`` samples.
    features : bool
        Compute per-chunk features (default True).
    table_size : int or None
        Spline coefficients per ball pass (power of 2, default max(256, 8 x highest order): 512 for 50 orders).
    accelerometer : Accelerometer or None
        The mounted sensor's resonance on the housing channels (:mod:`bkabem_core.sensors`; None: ideal).
    anti_alias : AntiAliasFilter or None
        The acquisition's low-pass on every channel (None: none; ``AntiAliasFilter.for_rate(fs)`` the usual one).
    """

    def __init__(self, model: BkaBem, sample_rate_hz: float = 25600.0, chunk_s: float = 0.1, *,
                 quantities=DEFAULT_QUANTITIES, noise_density: dict | None = None, snr_db: float | None = None,
                 slip: float = 0.0, seed: int | None = 0, max_order: int | None = None, band_limit: str = "error",
                 spectrum: str = "auto", knot_s: float = 0.1, max_speed_step_hz: float = 0.5,
                 min_speed_hz: float = 0.05, initial_speed_hz: float | None = None, dtype=np.float32,
                 features: bool = True, table_size: int | None = None, accelerometer: Accelerometer | None = None,
                 anti_alias: AntiAliasFilter | None = None):
        if not isinstance(model, BkaBem):
            raise SynthError("model", f"must be a BkaBem (got {type(model).__name__})")
        fs = _finite("sample_rate_hz", sample_rate_hz, 0.0, strict=True)
        if fs > MAX_SAMPLE_RATE_HZ:
            raise SynthError("sample_rate_hz", f"must be <= {MAX_SAMPLE_RATE_HZ:g} (got {fs:g})")
        self.sample_rate_hz = fs
        cs = _finite("chunk_s", chunk_s, 0.0, strict=True)
        n_chunk = int(round(cs * fs))
        if n_chunk < 1:
            raise SynthError("chunk_s", f"{cs:g} s is less than one sample at {fs:g} Hz")
        if n_chunk > 1 << 24:
            raise SynthError("chunk_s", f"{cs:g} s is more than 2^24 samples")
        self.chunk_samples = n_chunk
        self.channels = make_channels(quantities)
        self.channel_names = tuple(c.name for c in self.channels)
        self.units = tuple(c.unit for c in self.channels)
        if band_limit not in ("error", "taper"):
            raise SynthError("band_limit", f"must be 'error' or 'taper' (got {band_limit!r})")
        self.band_limit = band_limit
        if spectrum not in ("auto", "modal", "exact"):
            raise SynthError("spectrum", f"must be 'auto', 'modal' or 'exact' (got {spectrum!r})")
        self.knot_s = _finite("knot_s", knot_s, 0.0, strict=True)
        self.max_speed_step_hz = _finite("max_speed_step_hz", max_speed_step_hz, 0.0, strict=True)
        self.min_speed_hz = _finite("min_speed_hz", min_speed_hz, 0.0, strict=True)
        self.slip = _finite("slip", slip, 0.0)
        if self.slip > MAX_SLIP:
            raise SynthError("slip", f"must be <= {MAX_SLIP:g} (a fraction of the ball-pass period; "
                                     f"real bearings 0.01-0.02), got {self.slip:g}")
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % (1 << 63))
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise SynthError("seed", f"must be an integer >= 0 (got {seed!r})")
        self.seed = int(seed)
        if dtype not in (np.float32, np.float64, "float32", "float64"):
            raise SynthError("dtype", f"must be float32 or float64 (got {dtype!r})")
        self.dtype = np.dtype(dtype).type
        # the sample loop: C kernel, or its numpy reference (bit-identical) when the kernel is not built
        if synth_kernel.AVAILABLE:
            self._segment_fn, self._accumulate = synth_kernel.segment, synth_kernel.accumulate
        else:
            self._segment_fn, self._accumulate = synth_kernel.segment_reference, synth_kernel.accumulate_reference
        self.compute_features = bool(features)
        if initial_speed_hz is not None:
            initial_speed_hz = _finite("initial_speed_hz", initial_speed_hz, 0.0)
        self.initial_speed_hz = initial_speed_hz
        for name, v, kind in (("accelerometer", accelerometer, Accelerometer), ("anti_alias", anti_alias,
                                                                                 AntiAliasFilter)):
            if v is not None and not isinstance(v, kind):
                raise SynthError(name, f"must be a {kind.__name__} or None (got {type(v).__name__})")
        self.accelerometer, self.anti_alias = accelerometer, anti_alias
        self._spectrum_kind = spectrum
        self._max_order_arg = max_order
        self._table_size_arg = table_size
        self.set_noise(noise_density=noise_density, snr_db=snr_db)
        self._bind_model(model)
        self.reset()

    # ------------------------------------------------------------------ model
    def _bind_model(self, model: BkaBem) -> None:
        if not model.is_order_set:
            self._bind_lines(model)
            return
        self._general = False
        orders = np.asarray(model.orders, dtype=int)
        max_order = self._max_order_arg
        if max_order is not None:
            if isinstance(max_order, bool) or not isinstance(max_order, (int, np.integer)) or max_order < 1:
                raise SynthError("max_order", f"must be an integer >= 1 (got {max_order!r})")
            if max_order < orders.min():
                raise SynthError("max_order", f"{max_order} is below the lowest model order {orders.min()}")
        keep = orders <= max_order if max_order is not None else np.ones(orders.size, bool)
        self._model = model
        self.case = model.case
        self.orders = orders[keep]
        self._keep = keep
        self.bpfo_per_hz = float(model.bpfo_per_hz)
        self.n_balls = int(model.case.bearing_geometry().n_balls)
        self.fault_multipliers = model.fault_multipliers
        k_max = int(self.orders.max())
        self._k_max = k_max
        n = self._table_size_arg
        if n is None:
            n = max(256, 1 << int(math.ceil(math.log2(8 * k_max))))
            if getattr(self, "_knots", None) and n != self.table_size:
                n = self.table_size                          # a model swap mid-stream keeps the table size
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 64 or n & (n - 1) or n > 1 << 16:
            raise SynthError("table_size", f"must be a power of 2 in 64..65536 (got {n!r})")
        if n < 4 * k_max:
            raise SynthError("table_size", f"{n} is too small for order {k_max} (needs >= {4 * k_max})")
        self.table_size = int(n)
        comb, index, power, scale, iso = _combination(self.channels)
        self._comb, self._cindex, self._power, self._scale, self._iso_rows = comb, index, power, scale, iso
        self._housing_cols = np.flatnonzero((comb != 0).sum(axis=1) == 1)
        self._chain = self.accelerometer is not None or self.anti_alias is not None
        self._orders_list = [int(k) for k in orders[keep]]                 # for bisect (the ISO band)
        self._iso_factor = 1j * orders[keep].astype(float)[:, None]       # v = i k w1 x [m/s per m]
        self._exact = ExactSpectrum(model, comb)
        self._modal = None                                     # made (and checked) when first chosen
        self._modal_failed = None
        self._use_modal = self._spectrum_kind == "modal"
        dc8 = np.asarray(model.dc_m).reshape(-1)
        self._dc = (comb @ dc8)[index] * (power == 0)
        self._dc_off = np.ascontiguousarray(self._dc, dtype=np.float64)   # moments are taken about the static part
        # channel factor per order: y = x[:, index] * (i k)^p scale * (2 pi BPFO f)^p  (p = power of i omega)
        kk = self.orders.astype(float)
        self._keep_some = not bool(np.all(keep))
        self._chan_power = power.astype(float)
        self._scale_buf = np.empty(len(self.channels))                   # knot_table's per-channel factor
        self._order_ratio_per_hz = kk * self.bpfo_per_hz / (self.sample_rate_hz / 2)   # order frequency / Nyquist
        self._top_ratio_per_hz = float(self._order_ratio_per_hz.max())
        # spline coefficient table of one ball pass, N + 3 rows (row r = coefficient (r - 1) mod N, so the four
        # taps of any position are consecutive rows): T[n] = DC + sum_k Re(Yc_k e^{i k 2 pi n / N}) with
        # Yc = Y / sinc(k/N)^4, the cubic B-spline's droop pre-emphasised (docs/synthesis.md); made in C from a
        # quarter-wave cos/sin basis (synth_kernel.knot_table), or by the direct formula in numpy without it
        self._emphasis = 1.0 / np.sinc(kk / n) ** 4
        self._table_basis = synth_kernel.quarter_basis(self.orders, n)
        self._table_pool: list[np.ndarray] = []
        self._knot_table = synth_kernel.knot_table if synth_kernel.AVAILABLE else synth_kernel.knot_table_reference
        self._cindex64 = np.ascontiguousarray(index, dtype=np.int64)
        # y_k = x_k[index] (i k w1)^p scale, pre-emphasised: x_k[index] * _chan_factor * w1^p (* weights)
        self._chan_factor = np.ascontiguousarray(
            (1j * kk[:, None]) ** power[None, :] * scale[None, :] * self._emphasis[:, None], dtype=complex)
        self._gt_base = self._ground_truth_base()

    def _bind_lines(self, model: BkaBem) -> None:
        """Any line set (:mod:`bkabem_core.synth_lines`): families of lines, one table (pair) each per knot; the
        spectrum at a knot from the model's exact response (its fixed-frequency and speed-scaled lines included)."""
        self._general = True
        lines = model.lines
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
        self.bpfo_per_hz = float(model.bpfo_per_hz)
        self.n_balls = int(model.case.bearing_geometry().n_balls)
        self.fault_multipliers = model.fault_multipliers
        self._k_max = max(1, int(math.ceil(float(self._nu.max()) / self.bpfo_per_hz)))
        self._families = LineFamilies(self.coefficients, lines.rates_per_hz, lines.line_hz, self.n_balls,
                                      self.bpfo_per_hz, self._table_size_arg)
        self.table_size = max(f.table_size for f in self._families.families)
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
        self._chan_power = power.astype(float)
        self._chan_scale = scale.astype(float)
        self._scratch: dict = {}
        self._gt_base = self._ground_truth_base()

    def _top_hz(self, f: float) -> float:
        """Highest line frequency [Hz] at shaft speed f [Hz]."""
        if self._general:
            return float(np.max(self._nu * f + self._mu))
        return self.highest_order * self.bpfo_per_hz * f

    @property
    def multipliers(self) -> np.ndarray:
        """Speed-proportional part of each synthesised line's frequency [Hz per shaft Hz]."""
        return self._nu.copy() if self._general else self.orders * self.bpfo_per_hz

    def frequency_hz(self, speed_hz: float) -> np.ndarray:
        """Frequencies of the synthesised lines [Hz] at a shaft speed [Hz]."""
        if self._general:
            return self._nu * float(speed_hz) + self._mu
        return self.orders * self.bpfo_per_hz * float(speed_hz)

    def line_orders(self) -> np.ndarray:
        """Each synthesised line's frequency in BPFO orders [-] (the integer orders of an order set as floats)."""
        if self._general:
            return self._nu / self.bpfo_per_hz
        return np.asarray(self.orders, dtype=float)

    def line_phases_rad(self, chunk: "Chunk") -> np.ndarray:
        """Phase of every line at the first sample of ``chunk`` [rad], before slip: ``c . Phi`` (an order set:
        ``k z theta_cage``), so that ``line_spectrum`` amplitudes times ``exp(i phase)`` are the lines at t0."""
        cage = float(chunk.cage_angle_rad)
        if not self._general:
            return np.asarray(self.orders, dtype=float) * self.n_balls * cage
        fm = self.fault_multipliers
        c = self.coefficients.astype(float)
        line_hz = self._model.lines.line_hz
        return (c[:, 0] * float(chunk.shaft_angle_rad) + c[:, 1] * cage + c[:, 2] * (fm.bsf / fm.ftf) * cage
                + c[:, 3] * TWO_PI * line_hz * float(chunk.t0_s))

    @property
    def model(self) -> BkaBem:
        return self._model

    @model.setter
    def model(self, model: BkaBem) -> None:
        self.set_model(model)

    def set_model(self, model: BkaBem) -> None:
        """Switch to another model (e.g. a new defect depth) from the next knot on (``synth.model = m`` does the
        same). Phase stays continuous; the amplitudes move from the old to the new spectrum over one segment.
        With the modal spectrum the new model's modal form is made at its first use (~1.5 s, once per model): call
        :meth:`prepare` right after this one where the next chunk must not wait."""
        if not isinstance(model, BkaBem):
            raise SynthError("model", f"must be a BkaBem (got {type(model).__name__})")
        use_modal = self._use_modal
        self._bind_model(model)
        self._use_modal = use_modal
        self._table_cache = OrderedDict()

    def set_noise(self, noise_density: dict | None = None, snr_db: float | None = None) -> None:
        """Sensor noise from the next chunk on (see the class parameters); both None switches it off."""
        if noise_density is not None and snr_db is not None:
            raise SynthError("noise", "give noise_density or snr_db, not both")
        dens = {}
        if noise_density is not None:
            if not isinstance(noise_density, dict):
                raise SynthError("noise_density", "must be a dict quantity -> density")
            for q, v in noise_density.items():
                if q not in QUANTITIES:
                    raise SynthError("noise_density", f"unknown quantity {q!r}")
                dens[q] = _finite(f"noise_density.{q}", v, 0.0)
        self.noise_density = dens or None
        self.snr_db = None if snr_db is None else _finite("snr_db", snr_db)
        fs = self.sample_rate_hz
        self._noise_sigma = np.array([dens.get(c.quantity, 0.0) * math.sqrt(fs / 2) for c in self.channels])
        self._noise_on = bool(np.any(self._noise_sigma > 0)) or self.snr_db is not None
        self._noise = _NoiseBlocks(self.seed, len(self.channels), self.dtype) if self._noise_on else None

    @property
    def highest_order(self) -> int:
        return self._k_max

    def max_speed_for_rate_hz(self) -> float:
        """Highest shaft speed at which every kept line is below Nyquist [Hz]."""
        if self._general:
            nyq = self.sample_rate_hz / 2
            with np.errstate(divide="ignore"):
                lim = np.where(self._nu > 0, (nyq - self._mu) / np.maximum(self._nu, 1e-300), np.inf)
            return float(max(lim.min(), 0.0))
        return self.sample_rate_hz / 2 / (self.highest_order * self.bpfo_per_hz)

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Start a new stream at sample 0, cage angle 0."""
        self._knots: list[_Knot] = []
        self._next_index = 0
        self._table_cache: OrderedDict = OrderedDict()
        self._slip_walk = _SlipWalk(self.slip, self.seed) if self.slip > 0 else None

    @property
    def next_sample_index(self) -> int:
        return self._next_index

    # ------------------------------------------------------------------ knots
    def _order_weights(self, f: float):
        """Order weights at speed f: the low-speed fade (a number, smoothstep from min_speed_hz to twice it) and,
        in taper mode near Nyquist, the taper per order ((K,) array; None when it is 1 for every order)."""
        lo = self.min_speed_hz
        s = min(max((f - lo) / lo, 0.0), 1.0)
        fade = s * s * (3.0 - 2.0 * s)
        taper = None
        if self._general:
            if self.band_limit == "taper" and fade > 0:
                r = (self._nu * f + self._mu) / (self.sample_rate_hz / 2)
                if r.max() > 0.85:
                    taper = np.where(r <= 0.85, 1.0, np.where(r >= 0.95, 0.0,
                                                              0.5 * (1 + np.cos(np.pi * (r - 0.85) / 0.1))))
            return fade, taper
        if self.band_limit == "taper" and fade > 0 and self._top_ratio_per_hz * f > 0.85:
            r = self._order_ratio_per_hz * f
            taper = np.where(r <= 0.85, 1.0, np.where(r >= 0.95, 0.0, 0.5 * (1 + np.cos(np.pi * (r - 0.85) / 0.1))))
        return fade, taper

    def _check_band(self, f: float, argument: str) -> None:
        if self.band_limit == "error" and f > self.min_speed_hz:
            top = self._top_hz(f)
            if top >= self.sample_rate_hz / 2:
                raise SynthError(argument, self._band_message(f))

    def _band_message(self, f: float) -> str:
        if self._general:
            top = self._top_hz(f)
            return (f"sample rate {self.sample_rate_hz:g} Hz is below twice the highest kept line: {top:.1f} Hz at "
                    f"{f:g} Hz shaft speed (needs a rate > {2 * top:.1f} Hz, or band_limit='taper')")
        k = self.highest_order
        top = k * self.bpfo_per_hz * f
        fit = int(self.sample_rate_hz / 2 / (self.bpfo_per_hz * f)) if f > 0 else k
        if fit >= k:
            fit = k - 1
        return (f"sample rate {self.sample_rate_hz:g} Hz is below twice the highest kept order: order {k} is at "
                f"{top:.1f} Hz at {f:g} Hz shaft speed (needs a rate > {2 * top:.1f} Hz, or max_order <= {fit}, "
                f"or band_limit='taper')")

    # ------------------------------------------------------------------ spectrum at a knot
    @property
    def spectrum_method(self) -> str:
        if getattr(self, "_general", False):
            return self._general_method if self._modal_failed is None else \
                f"exact (speed cells failed their check: {self._modal_failed})"
        if self._use_modal and self._modal is not None:
            return "modal"
        if self._modal_failed:
            return f"exact (modal form failed its check: {self._modal_failed})"
        return "exact"

    def _provider(self):
        if self._use_modal:
            if self._modal is None and self._modal_failed is None:
                modal = ModalSpectrum(self.model, self._comb)
                err = modal.check(25.0)
                if err < 1e-5:                                 # the stated bound (docs/synthesis.md)
                    self._modal = modal
                else:
                    self._modal_failed = f"error {err:.1e}"
            if self._modal is not None:
                return self._modal
        return self._exact

    def prepare(self) -> None:
        """Make the spectrum method ready now, so that the first chunk carries no set-up: with ``"modal"``, or
        ``"auto"`` (modal when streaming), the modal form's eigen-decompositions (~1.5 s on the embedded case) and
        its speed cells up to the case's ``operating.max_speed_hz`` (or the rate's limit if lower; ~4 ms per 0.5 Hz,
        ~0.6 s and 10 MB for 75 Hz). Once per model: synthesisers of one model share them. Cells above are made
        when first used. Any other line set than BPFO orders takes the exact response per knot: nothing to make."""
        if self._general:
            return
        if self._spectrum_kind == "auto":
            self._use_modal = True
        spectrum = self._provider()
        if spectrum is self._modal:
            spectrum.build(0.0, min(self.case.max_speed_hz, self.max_speed_for_rate_hz()))

    #: cost model of ``spectrum="auto"`` [s]: one exact solve per knot of a new speed; one modal evaluation per
    #: knot; the modal form's set-up per order, scaled with the cube of the model's DOFs; one speed cell per
    #: order (measured on the embedded 60-DOF case, BENCHMARKS.md)
    _COST_EXACT_S, _COST_MODAL_S, _COST_MODAL_SETUP_PER_ORDER_S = 0.6e-3, 0.01e-3, 0.036
    _COST_CELL_PER_ORDER_S = 0.08e-3

    def _choose_spectrum(self, profile: "SpeedProfile | None", seconds: float) -> None:
        """``spectrum="auto"``: modal when streaming (an unknown number of speeds: the set-up pays off after a few
        thousand chunks, and is done once per model); for a profile, the cheaper of the two for its knots."""
        if self._spectrum_kind != "auto" or self._general:
            return
        if profile is None:
            self._use_modal = True
            return
        t = profile.times_s
        t_end = np.concatenate([t[t < seconds], [seconds]])
        f_end = profile.speed_hz(t_end)
        knots = 1.0
        for i in range(len(t_end) - 1):
            df = abs(f_end[i + 1] - f_end[i])
            if df > 0:
                knots += max((t_end[i + 1] - t_end[i]) / self.knot_s, df / self.max_speed_step_hz) + 1
        made = self._modal is not None or self.model.has_order_modal_form(self._comb)
        n_k, scale = self.model.orders.size, self.model.basis.size / 60.0     # cost per pole, relative to 60 DOF
        setup = 0.0 if made or self.model.has_line_modes() else self._COST_MODAL_SETUP_PER_ORDER_S * n_k * scale ** 3
        if made:
            cells = self.model.order_modal_form(self._comb).speed_cells().missing(f_end.min(), f_end.max())
        else:
            cells = len(SpeedCells.cell_range(SpeedCells.DEFAULT_CELL_HZ, f_end.min(), f_end.max()))
        setup += cells * self._COST_CELL_PER_ORDER_S * n_k * scale
        self._use_modal = setup + self._COST_MODAL_S * knots < self._COST_EXACT_S * knots

    def _amplitudes(self, f: float) -> "_Amplitudes":
        """Channel amplitudes and the spline table at speed f [Hz] (cached: a held speed costs nothing)."""
        key = float(f)
        hit = self._table_cache.get(key)
        if hit is not None:
            self._table_cache.move_to_end(key)
            return hit
        if self._general:
            hit = self._line_amplitudes(key)
            self._table_cache[key] = hit
            if len(self._table_cache) > 8:
                self._table_cache.popitem(last=False)
            return hit
        modal = self._modal
        if self._use_modal and modal is not None:
            x = modal.cells(key)                                            # (K, U) displacement combinations
        else:
            x = np.ascontiguousarray(self._provider()(key))
        if self._keep_some:
            x = x[self._keep]
        if self._chain:
            x = x * chain_gains(self.orders * self.bpfo_per_hz * key, self._housing_cols, self.accelerometer,
                                self.anti_alias, x.shape[1])
        fade, taper = self._order_weights(key)
        scale = self._scale_buf                                             # (2 pi BPFO f)^p * fade per channel
        np.power(TWO_PI * self.bpfo_per_hz * key, self._chan_power, out=scale)
        scale *= fade
        table = self._free_table()
        yc = np.empty((x.shape[0], len(self.channels)), complex)   # channel amplitudes, pre-emphasised for the spline
        self._knot_table(x, self._cindex64, self._chan_factor, scale, taper, self._dc_off, self._table_basis,
                         table, yc)
        hit = _Amplitudes(f=key, x=x, fade=fade, taper=taper, y_emphasised=yc, emphasis=self._emphasis, table=table)
        self._table_cache[key] = hit
        if len(self._table_cache) > 8:
            self._table_cache.popitem(last=False)
        return hit

    def _line_spectrum_at(self, f: float) -> np.ndarray:
        """Displacement combinations (K, U) [m] of every line at speed f [Hz]: the speed-locked lines from the
        model's speed cells (as the order path's modal spectrum, checked against the exact response once; the
        exact response per knot if the check fails or ``spectrum="exact"``), the others by their dense solve."""
        m = self._model
        if self._spectrum_kind != "exact" and self._cells is None and self._modal_failed is None:
            cells = m.order_modal_form(self._comb).speed_cells()
            self._cells = cells
            err = self._line_check(25.0)
            if err >= 1e-5:
                self._cells, self._modal_failed = None, f"error {err:.1e}"
        if self._cells is None:
            return np.ascontiguousarray(self._exact(f))
        li, fi = m._locked_idx, m._fixed_idx
        x = np.empty((len(m.lines), self._comb.shape[0]), complex)
        x[li] = self._cells(f)
        if fi.size:
            x[fi] = m._fixed_lines(f) @ self._comb.T
        if np.any(m._speed_power != 0.0):
            x *= (f ** m._speed_power)[:, None]
        return x

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

    def _line_amplitudes(self, f: float) -> "_Amplitudes":
        """Channel amplitudes and the families' tables at speed f [Hz] (any line set)."""
        x = self._line_spectrum_at(f)
        if self._keep_some:
            x = x[self._keep]
        if self._chain:
            x = x * chain_gains(self._nu * f + self._mu, self._housing_cols, self.accelerometer, self.anti_alias,
                                x.shape[1])
        fade, taper = self._order_weights(f)
        w = TWO_PI * (self._nu * f + self._mu)                               # (K,) [rad/s]
        fac = (1j * w[:, None]) ** self._chan_power[None, :] * (self._chan_scale * fade)[None, :]
        if taper is not None:
            fac = fac * taper[:, None]
        y = x[:, self._cindex] * fac
        tables = self._families.tables(y, self.dtype)
        return _Amplitudes(f=f, x=x, fade=fade, taper=taper, y_emphasised=y, emphasis=np.ones(y.shape[0]),
                           table=None, ftables=tables)

    def _segment_lines(self, a: _Knot, b: _Knot, lo: int, hi: int, out: np.ndarray) -> None:
        """Samples [lo, hi) between knots a and b of any line set: every family's table(s) through the sample loop
        at the family's own phase (exact fixed point, as :meth:`_segment`), carriers applied in numpy."""
        m = hi - lo
        length = b.x - a.x
        fs = self.sample_rate_hz
        j = lo - a.x
        ua = a.u_int + a.u_frac
        w = None
        xi = np.arange(j, j + m, dtype=np.float64)
        if self._slip_walk is not None:
            c1u = self.bpfo_per_hz / fs * a.f
            c2u = 0.5 * self.bpfo_per_hz / fs * (b.f - a.f) / length
            w = self._slip_walk.warp(a.u_int, (c2u * xi + c1u) * xi + a.u_frac)       # slip [ball passes]
        out[...] = self._dc
        scratch = self._scratch.get(m)
        if scratch is None:
            scratch = self._scratch[m] = (np.empty((m, out.shape[1]), self.dtype),
                                          np.empty((m, out.shape[1]), self.dtype))
        same = b.amp is a.amp
        for fi, fam in enumerate(self._families.families):
            t0 = LineFamilies.turns(fam.rate_p, fam.fixed_p, ua, a.x, self.bpfo_per_hz, fs)
            c1 = (fam.rate_p * a.f + fam.fixed_p) / fs
            c2 = 0.5 * fam.rate_p * (b.f - a.f) / (fs * length)
            d0 = round((c1 + c2) * _PASS)
            dd = round(2.0 * c2 * _PASS)
            phase0 = round(t0 * _PASS) + j * d0 + dd * (j * (j - 1) // 2)
            dphase0 = d0 + j * dd
            warp = None
            if w is not None and fam.kappa_p != 0.0:
                wp = fam.kappa_p * w
                warp = np.rint((wp - np.rint(wp)) * _PASS).astype(np.int64)
            ta, tb = a.amp.ftables[fi], (None if same else b.amp.ftables[fi])
            for ti in range(len(ta)):
                self._segment_fn(phase0, dphase0, dd, warp, ta[ti], None if tb is None else tb[ti], float(j),
                                 65536.0 / length, scratch[ti], None, self._dc_off)
            if not fam.carrier:
                out += scratch[0]
                continue
            q0 = LineFamilies.turns(fam.rate_q, fam.fixed_q, ua, a.x, self.bpfo_per_hz, fs)
            cq1 = (fam.rate_q * a.f + fam.fixed_q) / fs
            cq2 = 0.5 * fam.rate_q * (b.f - a.f) / (fs * length)
            ph = (cq2 * xi + cq1) * xi + q0
            if w is not None and fam.kappa_q != 0.0:
                ph = ph + fam.kappa_q * w
            ang = TWO_PI * (ph - np.floor(ph))
            out += np.cos(ang).astype(self.dtype)[:, None] * scratch[0]
            out -= np.sin(ang).astype(self.dtype)[:, None] * scratch[1]

    def _free_table(self) -> np.ndarray:
        """A knot table buffer, (N + 3, C) and 64-byte aligned (synth_kernel.empty_aligned), recycled: a buffer of
        the pool that nothing else refers to any more (no knot, no cache entry) is reused. Saves the aligned
        allocation (~2.5 us) per knot and keeps the tables' memory warm in the cache."""
        pool = self._table_pool
        for t in pool:
            if sys.getrefcount(t) == 3:                    # the pool's list, the loop variable, the call's argument
                return t
        t = synth_kernel.empty_aligned((self.table_size + 3, len(self.channels)), self.dtype)
        if len(pool) < 32:
            pool.append(t)
        return t

    def line_spectrum(self, speed_hz: float) -> dict:
        """The lines the waveform holds at ``speed_hz`` [Hz] (what an FFT of a steady run shows).

        Returns ``orders`` (K,), ``frequency_hz`` (K,), ``amplitude`` (K, C) complex in the channel units (quantity,
        Nyquist taper and low-speed fade applied; x = Re(A e^{i k 2 pi u}), phase origin cage angle 0, before slip)
        and ``dc`` (C,), the static part."""
        f = _finite("speed_hz", speed_hz, 0.0)
        y = self._amplitudes(f).y
        return {"orders": self.orders.copy(), "frequency_hz": self.frequency_hz(f),
                "amplitude": y.copy(), "dc": self._dc.copy(), "channel_names": self.channel_names,
                "units": self.units}

    def _make_knot(self, x: int, f: float, prev: _Knot | None) -> _Knot:
        if prev is None:
            u_int, u_frac = 0, 0.0
        else:
            du = self.bpfo_per_hz / self.sample_rate_hz * 0.5 * (prev.f + f) * (x - prev.x)
            tot = prev.u_frac + du
            fl = math.floor(tot)
            u_int, u_frac = prev.u_int + int(fl), tot - fl
        return _Knot(x=int(x), f=float(f), u_int=u_int, u_frac=u_frac, amp=self._amplitudes(f))

    def _n_sub(self, fa: float, fb: float) -> int:
        n = math.ceil(abs(fb - fa) / self.max_speed_step_hz - 1e-12)
        if self.band_limit == "taper":
            hi, lo = max(fa, fb), min(fa, fb)
            if self._top_hz(hi) > 0.8 * self.sample_rate_hz / 2 and hi > 1.02 * lo:
                n = max(n, math.ceil(math.log(hi / max(lo, 1e-9)) / math.log(1.02)))
        return max(1, min(n, 100000))

    def _append(self, x: int, f: float) -> None:
        """Add knot(s) up to sample x with speed f [Hz] (speed linear in time from the last knot). Subdivision
        knots sit on samples too, with the speed of the straight line at that sample."""
        x = int(x)
        if not self._knots:
            self._knots.append(self._make_knot(x, f, None))
            return
        last = self._knots[-1]
        span = x - last.x
        n = min(self._n_sub(last.f, f), span)
        if n == 1:                                      # one step (streaming: nearly always)
            self._knots.append(self._make_knot(x, f, last))
            return
        for i in range(1, n + 1):
            xi = last.x + (span * i) // n
            fi = last.f + (f - last.f) * (xi - last.x) / span if i < n else f
            self._knots.append(self._make_knot(xi, fi, self._knots[-1]))

    # ------------------------------------------------------------------ streaming
    def next_chunk(self, speed_hz: float | None = None, n_samples: int | None = None) -> Chunk:
        """The next chunk of the stream.

        ``speed_hz`` is the shaft speed [Hz] at the *end* of this chunk; within the chunk the speed goes linearly
        from the previous chunk's end speed to it (so angle and its derivative stay continuous). None keeps the
        previous speed. On the very first call, without ``initial_speed_hz``, the chunk is at constant speed.
        """
        if speed_hz is None:
            if not self._knots and self.initial_speed_hz is None:
                raise SynthError("speed_hz", "the first chunk needs a speed (or initial_speed_hz)")
            f = self._knots[-1].f if self._knots else self.initial_speed_hz
        else:
            f = _finite("speed_hz", speed_hz, 0.0)
        n = self.chunk_samples if n_samples is None else int(n_samples)
        if n < 1:
            raise SynthError("n_samples", f"must be >= 1 (got {n_samples!r})")
        self._check_band(f, "speed_hz")
        n0 = self._next_index
        if not self._knots:
            self._choose_spectrum(None, 0.0)
            f0 = f if self.initial_speed_hz is None else self.initial_speed_hz
            self._check_band(f0, "initial_speed_hz")
            self._append(n0, f0)
        self._append(n0 + n, f)
        chunk = self._render(n0, n)
        self._next_index = n0 + n
        return chunk

    # ------------------------------------------------------------------ profiles
    def render(self, profile, seconds: float, progress=None) -> Iterator[Chunk]:
        """Chunks of a whole run under ``profile`` (SpeedProfile or a spec for :func:`parse_profile`).

        Starts a new stream (:meth:`reset`). Knots every ``knot_s`` of run time and at every profile breakpoint,
        independent of the chunk length, so that any chunk length gives the same samples. ``progress``: an
        optional callable receiving the number of samples done after each chunk.
        """
        profile = parse_profile(profile)
        secs = _finite("seconds", seconds, 0.0, strict=True)
        fs = self.sample_rate_hz
        n_total = int(round(secs * fs))
        if n_total < 1:
            raise SynthError("seconds", f"{secs:g} s is less than one sample at {fs:g} Hz")
        f_max = profile.max_speed_hz(secs)
        if self.band_limit == "error" and f_max > self.min_speed_hz and self._top_hz(f_max) >= fs / 2:
            raise SynthError("sample_rate_hz", self._band_message(f_max))
        self._choose_spectrum(profile, secs)
        return self._render_profile(profile, n_total, progress)

    def _render_profile(self, profile: SpeedProfile, n_total: int, progress) -> Iterator[Chunk]:
        self.reset()
        fs = self.sample_rate_hz
        knot_n = max(1, int(round(self.knot_s * fs)))
        breaks = sorted({int(round(t * fs)) for t in profile.times_s if round(t * fs) > 0})   # on samples
        bi = 0
        self._append(0, float(profile.speed_hz(0.0)))
        n0 = 0
        while n0 < n_total:
            n = min(self.chunk_samples, n_total - n0)
            while self._knots[-1].x < n0 + n:
                last = self._knots[-1].x
                nxt = (last // knot_n + 1) * knot_n
                while bi < len(breaks) and breaks[bi] <= last:
                    bi += 1
                if bi < len(breaks) and breaks[bi] < nxt:
                    nxt = breaks[bi]
                self._append(nxt, float(profile.speed_hz(nxt / fs)))
            yield self._render(n0, n)
            n0 += n
            self._next_index = n0
            if progress is not None:
                progress(n)

    # ------------------------------------------------------------------ rendering
    def _segment_at(self, start: int, pos: float) -> int:
        ks = self._knots
        i = start
        while i + 2 < len(ks) and ks[i + 1].x <= pos:
            i += 1
        return i

    def _segments(self, n0: int, n: int):
        """(knot a, knot b, first sample, end sample) of the segments covering samples [n0, n0 + n)."""
        ks = self._knots
        pos, i = n0, 0
        while pos < n0 + n:
            i = self._segment_at(i, pos)
            a, b = ks[i], ks[i + 1]
            end = min(n0 + n, max(pos + 1, b.x))
            yield a, b, pos, end
            pos = end

    def _render(self, n0: int, n: int) -> Chunk:
        ks = self._knots
        i0 = self._segment_at(0, n0)                   # drop knots before the segment holding n0
        if i0 > 0:
            del ks[:i0]
        out = np.empty((n, len(self.channels)), dtype=self.dtype)
        acc = None
        if self.compute_features:
            acc = synth_kernel.new_acc(len(self.channels))
        after = self._noise_on or self._general         # moments taken after the noise / the families' sum
        fused = acc if not after else None
        seg = self._segment_lines if self._general else None
        if len(ks) == 2 and ks[1].x >= n0 + n:         # one segment (streaming: every chunk)
            if seg is not None:
                seg(ks[0], ks[1], n0, n0 + n, out)
            else:
                self._segment(ks[0], ks[1], n0, n0 + n, out, fused)
        else:
            for a, b, lo, hi in self._segments(n0, n):
                if seg is not None:
                    seg(a, b, lo, hi, out[lo - n0:hi - n0])
                else:
                    self._segment(a, b, lo, hi, out[lo - n0:hi - n0], fused)
        if self._noise_on:
            self._add_noise(n0, n, out)
        if after and acc is not None:
            self._accumulate(out, self._dc_off, acc)
        return self._make_chunk(n0, n, out, acc)

    def _segment(self, a: _Knot, b: _Knot, lo: int, hi: int, out: np.ndarray, acc) -> None:
        """Samples [lo, hi) of the segment between knots a and b into ``out`` (hi - lo, C).

        Ball passes since knot a, u(xi) = u_frac + c1 xi + c2 xi^2 at xi = sample - a.x (speed linear in time),
        go to the loop as fixed-point integers (one pass = 2^62): the value, first and second difference at
        ``lo``, exact functions of (knot, sample), so a chunk border anywhere gives the same samples."""
        m = hi - lo
        length = b.x - a.x
        c1 = self.bpfo_per_hz / self.sample_rate_hz * a.f              # passes per sample at a
        c2 = 0.5 * self.bpfo_per_hz / self.sample_rate_hz * (b.f - a.f) / length
        u0 = round(a.u_frac * _PASS)
        d0 = round((c1 + c2) * _PASS)                                   # u(1) - u(0)
        dd = round(2.0 * c2 * _PASS)
        j = lo - a.x
        phase0 = u0 + j * d0 + dd * (j * (j - 1) // 2)
        dphase0 = d0 + j * dd
        warp = None
        if self._slip_walk is not None:
            xi = np.arange(j, j + m, dtype=np.float64)
            u = (c2 * xi + c1) * xi + a.u_frac                           # passes since a.u_int (float: slip only)
            w = self._slip_walk.warp(a.u_int, u)
            warp = np.rint((w - np.rint(w)) * _PASS).astype(np.int64)   # whole passes drop out of the phase
        tb = b.amp.table if b.amp is not a.amp else None
        self._segment_fn(phase0, dphase0, dd, warp, a.amp.table, tb, float(j), 65536.0 / length, out,
                         acc, self._dc_off)

    @staticmethod
    def _add_scaled(out: np.ndarray, z: np.ndarray, sigma: np.ndarray) -> None:
        """out += z * sigma (per channel), rows folded (see _FOLD)."""
        m, c = out.shape
        q = m // _FOLD * _FOLD
        sig = sigma.astype(out.dtype)
        if q:
            zz = z[:q].reshape(-1, _FOLD * c)
            zz *= np.tile(sig, _FOLD)
            out[:q].reshape(-1, _FOLD * c)[...] += zz
        if q < m:
            out[q:] += z[q:] * sig

    def _add_noise(self, n0: int, n: int, out: np.ndarray) -> None:
        z = self._noise.get(n0, n)
        if self.snr_db is None:
            self._add_scaled(out, z, self._noise_sigma)
            return
        g = 10 ** (-self.snr_db / 20)
        for a, b, lo, hi in self._segments(n0, n):
            sigma = g * np.sqrt(0.5 * (a.amp.rms ** 2 + b.amp.rms ** 2))
            self._add_scaled(out[lo - n0:hi - n0], z[lo - n0:hi - n0], sigma)

    # ------------------------------------------------------------------ chunk metadata
    def _state_at(self, pos: float):
        """Speed [Hz], ball passes (int, frac) and the knot pair at sample position ``pos``."""
        ks = self._knots
        if len(ks) > 1:                                     # chunk borders on knots (streaming: always)
            if ks[0].x == pos:
                return ks[0].f, ks[0].u_int, ks[0].u_frac, ks[0], ks[1], 0.0
            if ks[-1].x == pos:
                return ks[-1].f, ks[-1].u_int, ks[-1].u_frac, ks[-2], ks[-1], 1.0
        i = self._segment_at(0, pos)
        a, b = ks[i], ks[i + 1]
        xi = pos - a.x
        f = a.f + (b.f - a.f) * xi / (b.x - a.x)
        du = self.bpfo_per_hz / self.sample_rate_hz * 0.5 * (a.f + f) * xi
        tot = a.u_frac + du
        fl = math.floor(tot)
        return f, a.u_int + int(fl), tot - fl, a, b, xi / (b.x - a.x)

    def _make_chunk(self, n0: int, n: int, out: np.ndarray, acc) -> Chunk:
        fs = self.sample_rate_hz
        f0, ui, uf, *_ = self._state_at(n0)
        f_end, *_ = self._state_at(n0 + n)
        passes = ui + uf
        cage = (TWO_PI * (passes / self.n_balls)) % TWO_PI
        shaft = (TWO_PI * (passes / self.bpfo_per_hz)) % TWO_PI
        feats = {}
        if acc is not None:
            feats = synth_kernel.features_from_acc(acc, n, self._dc_off)
            feats["iso10816_velocity_rms_mm_s"] = self._iso_velocity(n0 + 0.5 * n)
        gt = dict(self._gt_base)
        gt["shaft_speed_hz"] = f0
        fm = self.fault_multipliers
        gt["fault_frequencies_hz"] = {"ftf": fm.ftf * f0, "bpfo": fm.bpfo * f0, "bpfi": fm.bpfi * f0,
                                      "bsf": fm.bsf * f0}
        return Chunk(samples=out.T, first_sample_index=int(n0), t0_s=n0 / fs, sample_rate_hz=fs,
                     channel_names=self.channel_names, units=self.units, shaft_speed_hz=float(f0),
                     shaft_speed_end_hz=float(f_end), cage_angle_rad=float(cage), shaft_angle_rad=float(shaft),
                     features=feats, ground_truth=gt)

    def _v_iso(self, amp: "_Amplitudes") -> np.ndarray:
        """Housing velocity [mm/s] of DE/NDE x vertical/horizontal, weights applied, as real (K, 8) [Re | Im] (made
        once per knot speed)."""
        if amp.v_iso is None:
            w = amp.fade * TWO_PI * self.bpfo_per_hz * amp.f * 1e3
            fac = self._iso_factor if amp.taper is None else self._iso_factor * amp.taper[:, None]
            v = amp.x[:, self._iso_rows] * (fac * w)
            amp.v_iso = vv = np.empty((v.shape[0], 8))
            vv[:, :4] = v.real
            vv[:, 4:] = v.imag
        return amp.v_iso

    def _iso_velocity(self, pos: float) -> dict:
        """ISO 10816 velocity RMS [mm/s] in 10-1000 Hz per housing and direction, from the order amplitudes
        (linear in time between knots, as the samples) at ``pos``; noise and slip smearing excluded."""
        f, _, _, a, b, s = self._state_at(pos)
        if self._general:
            return self._iso_velocity_lines(f, a, b, s)
        per_order = self.bpfo_per_hz * f                           # Hz per order; orders sorted: the band is a slice
        lo = hi = 0
        if per_order > 0:
            lo = bisect.bisect_left(self._orders_list, ISO_BAND_HZ[0] / per_order)
            hi = bisect.bisect_right(self._orders_list, ISO_BAND_HZ[1] / per_order)
        va, vb = self._v_iso(a.amp), self._v_iso(b.amp)
        if va.shape != vb.shape:                                    # a model swap changed the orders: the new one
            va = vb
        r = synth_kernel.band_rms(va, vb, lo, hi, s)                # of va + s (vb - va), (K, 8) [mm/s] Re | Im
        return {"de": {"vertical": r[0], "horizontal": r[1], "overall": max(r[0], r[1])},
                "nde": {"vertical": r[2], "horizontal": r[3], "overall": max(r[2], r[3])}}

    def _iso_velocity_lines(self, f: float, a, b, s: float) -> dict:
        """:meth:`_iso_velocity` for any line set: housing velocity of the lines in 10-1000 Hz at speed f."""
        freq = self._nu * f + self._mu
        band = (freq >= ISO_BAND_HZ[0]) & (freq <= ISO_BAND_HZ[1])

        def vel(amp):
            w = TWO_PI * (self._nu * amp.f + self._mu)
            return amp.x[:, self._iso_rows] * (1j * w * 1e3 * amp.weights)[:, None]

        va, vb = vel(a.amp), vel(b.amp)
        if va.shape != vb.shape:
            va = vb
        v = (va + s * (vb - va))[band]
        r = np.sqrt(0.5 * np.sum(np.abs(v) ** 2, axis=0)).tolist() if v.size else [0.0] * 4
        return {"de": {"vertical": r[0], "horizontal": r[1], "overall": max(r[0], r[1])},
                "nde": {"vertical": r[2], "horizontal": r[3], "overall": max(r[2], r[3])}}

    def _ground_truth_base(self) -> dict:
        gt = self.case.ground_truth()
        gt.update({
            "fault_multipliers": self.fault_multipliers.to_dict(),
            "seed": self.seed,
            "slip_std_fraction": self.slip,
            "noise_density": self.noise_density,
            "snr_db": self.snr_db,
            "sample_rate_hz": self.sample_rate_hz,
            "orders": [int(k) for k in self.orders],
            "accelerometer": None if self.accelerometer is None else self.accelerometer.to_dict(),
            "anti_alias": None if self.anti_alias is None else self.anti_alias.to_dict(),
        })
        if self._general:
            gt["line_coefficients"] = self.coefficients.tolist()
            gt["line_multipliers"] = self._nu.tolist()
        return gt

    def info(self) -> dict:
        """Settings and method, JSON-ready (goes into output metadata)."""
        return {"sample_rate_hz": self.sample_rate_hz, "chunk_samples": self.chunk_samples,
                "channel_names": list(self.channel_names), "units": list(self.units),
                "orders": [int(k) for k in self.orders], "bpfo_per_hz": self.bpfo_per_hz,
                "n_balls": self.n_balls, "band_limit": self.band_limit, "spectrum": self.spectrum_method,
                "knot_s": self.knot_s, "max_speed_step_hz": self.max_speed_step_hz,
                "min_speed_hz": self.min_speed_hz, "table_size": self.table_size,
                "slip_std_fraction": self.slip, "noise_density": self.noise_density, "snr_db": self.snr_db,
                "seed": self.seed, "dtype": np.dtype(self.dtype).name, "case_hash": self.case.case_hash}
