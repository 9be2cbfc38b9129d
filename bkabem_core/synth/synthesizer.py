"""Waveform synthesis: speed-driven, phase-continuous sensor signals for the DE and NDE bearings.

A monitoring pipeline consumes samples. :class:`Synthesizer` turns the BKA-BEM spectra of a case into the signals
real sensors give, chunk by chunk, under a shaft speed that may change at any time (a profile, or a stream of
updates arriving between chunks). The method, its error bounds and the realism options are described in
``docs/synthesis.md``; in short:

* **Angle domain.** Speed is integrated exactly (it is piecewise linear in time, so the ball-pass phase is a
  quadratic per segment) and order ``k`` contributes ``Re(Y_k exp(i k u 2 pi))`` where ``u`` is the number of
  ball passes since t = 0 (``u = z theta_cage / 2 pi``, cage angle 0 at t = 0, the convention of
  :mod:`bkabem_core.solve.harmonic`). Signals are continuous in value and slope across chunks and speed changes.
* **Knots.** The complex amplitudes ``Y_k`` (per channel) are evaluated at *knots*: every chunk border in streaming,
  every ``knot_s`` of run time and every profile breakpoint when rendering a profile, plus subdivisions so that the
  speed moves by at most ``max_speed_step_hz`` between knots. Between knots amplitudes are linear in time.
* **Spectrum at a knot.** ``spectrum="modal"``: the FE model's order-wise pole-residue form
  (:class:`~bkabem_core.solve.harmonic.OrderModalForm`): along an order the gyroscopic speed is proportional to the
  order frequency, so each order's response is an exact rational function of its frequency, evaluated in 0.5 Hz
  cells of shaft speed (:class:`~bkabem_core.solve.harmonic.SpeedCells`: a Chebyshev interpolant of the far poles, the
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
import math
from collections import OrderedDict
from typing import Iterator

import numpy as np

from bkabem_core.model.vocabulary import BEARINGS, DIRECTIONS, LOCATIONS
from bkabem_core.solve.harmonic import TWO_PI, BkaBem
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.features import _FOLD, Chunk, _moment_features, waveform_features  # noqa: F401  (re-exported)
from bkabem_core.synth.floor import FloorPath
from bkabem_core.synth.knots import KnotSpectrum
from bkabem_core.synth.linesets import (
    DEFAULT_QUANTITIES,
    ISO_BAND_HZ,
    QUANTITIES,
    Channel,
    ExactSpectrum,
    LineSetPath,
    ModalSpectrum,
    _Amplitudes,
    _combination,
    _Knot,
    make_channels,
)
from bkabem_core.synth.profile import SpeedProfile, SynthError, _finite, parse_profile  # noqa: F401  (re-exported)
from bkabem_core.synth.randomness import NoisePath, _NoiseBlocks, _SlipWalk, noise_key  # noqa: F401
from bkabem_core.synth.sensors import Accelerometer, AntiAliasFilter
from bkabem_core.synth.switch import SwitchPath, WarmModel

MAX_SAMPLE_RATE_HZ = 1.0e6
MAX_SLIP = 0.1
_PASS = float(synth_kernel.PASS_UNITS)   # fixed-point units of one ball pass (2^62): phase arithmetic of the loop


# =========================================================================== the synthesiser
class Synthesizer(KnotSpectrum, LineSetPath, FloorPath, NoisePath, SwitchPath):
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
        The mounted sensor's resonance on the housing channels (:mod:`bkabem_core.synth.sensors`; None: ideal).
    anti_alias : AntiAliasFilter or None
        The acquisition's low-pass on every channel (None: none; ``AntiAliasFilter.for_rate(fs)`` the usual one).
    broadband_floor : bool
        Add the case's broadband floor (``baseline.broadband_force_n_per_sqrt_hz``: random force pairs across the
        bearings through the machine's receptance, :mod:`bkabem_core.synth.floor`) when the case sets one (default
        True); its frames are made by :meth:`prepare` or the first chunk (~0.3 s).
    """

    def __init__(self, model: BkaBem, sample_rate_hz: float = 25600.0, chunk_s: float = 0.1, *,
                 quantities=DEFAULT_QUANTITIES, noise_density: dict | None = None, snr_db: float | None = None,
                 slip: float = 0.0, seed: int | None = 0, max_order: int | None = None, band_limit: str = "error",
                 spectrum: str = "auto", knot_s: float = 0.1, max_speed_step_hz: float = 0.5,
                 min_speed_hz: float = 0.05, initial_speed_hz: float | None = None, dtype=np.float32,
                 features: bool = True, table_size: int | None = None, accelerometer: Accelerometer | None = None,
                 anti_alias: AntiAliasFilter | None = None, broadband_floor: bool = True):
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
        #: Most knots one speed step (one streamed chunk) may add; a real-time caller (the ROS node) lowers it so a
        #: jump of any size costs a bounded time (coarser amplitude interpolation through the jump, exact phase).
        self.max_knots_per_step = 100000
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
        self._floor_wanted = bool(broadband_floor)
        self._spectrum_kind = spectrum
        self._max_order_arg = max_order
        self._table_size_arg = table_size
        self.set_noise(noise_density=noise_density, snr_db=snr_db)
        self._bind_model(model)
        self.reset()

    # ------------------------------------------------------------------ model
    def _bind_model(self, model: BkaBem) -> None:
        self._floor = None
        self.floor_density = float(model.case.raw["baseline"].get("broadband_force_n_per_sqrt_hz", 0.0)) \
            if self._floor_wanted else 0.0
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
        self.n_balls = int(model.n_balls)
        self.fault_multipliers = model.bearing_multipliers["de"]        # an order set: the DE bearing's orders
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

    def _top_hz(self, f: float) -> float:
        """Highest line frequency [Hz] at shaft speed f [Hz]."""
        if self._general:
            return self._top_line_hz(f)
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

    def set_model(self, model: "BkaBem | WarmModel") -> None:
        """Switch to another model (e.g. a new defect depth) from the next knot on (``synth.model = m`` does the
        same). Phase stays continuous; the amplitudes move from the old to the new spectrum over one segment.

        A bare model is bound now and the rest is made by the next chunk: the floor's transfer (~150 ms), the
        line set's plans and the first knot's spectrum (with the modal spectrum its speed cells, and the modal
        form at its first use, ~1.5 s once per model). Where the next chunk must not wait, pass
        ``self.warm(model)`` made earlier (off the streaming thread: :mod:`bkabem_core.synth.switch`): then this
        only installs it, and the samples are the same. A warm model that no longer fits (other settings, spent)
        is bound afresh."""
        if isinstance(model, WarmModel):
            if self._install(model):
                return
            model = model.model
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
        # with the C kernel the noise is made inside the sample loop (synth_kernel.segment, noise=...), keyed by
        # absolute sample; without it, numpy's generator in blocks, added after the samples (_NoiseBlocks)
        self._noise_fused = self._noise_on and synth_kernel.AVAILABLE
        self._noise_key = noise_key(self.seed)
        self._noise_sigma_t = np.ascontiguousarray(self._noise_sigma, dtype=self.dtype)
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
        floor = getattr(self, "_floor", None)
        if floor is not None and floor.seed != self.seed:   # a new seed (a data set's next run): its frames only
            self._floor = floor.reseeded(self.seed)

    @property
    def next_sample_index(self) -> int:
        return self._next_index

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
            # knots at most 2 % apart in speed where a line is near the Nyquist taper; clipped to the speeds
            # where some line is (0.8 .. 0.95 of Nyquist): below, log(hi / lo) of a change from standstill asked
            # for ~1250 knots (0.5 s of solves in one chunk: the stall at speed jumps to or from 0, issue 14)
            near_lo, near_hi = self._taper_speeds_hz()
            hi = min(max(fa, fb), near_hi)
            lo = max(min(fa, fb), near_lo)
            if hi > 1.02 * lo:
                n = max(n, math.ceil(math.log(hi / lo) / math.log(1.02)))
        return max(1, min(n, self.max_knots_per_step))

    def _taper_speeds_hz(self) -> tuple[float, float]:
        """Shaft speeds [Hz] between which some line is near the Nyquist taper (0.8 .. 0.95 of Nyquist); an empty
        range (lo > hi) when no line moves with speed."""
        if not self._general:
            return 0.8 / self._top_ratio_per_hz, 0.95 / float(self._order_ratio_per_hz.min())
        nyq = self.sample_rate_hz / 2
        moving = self._nu > 0
        if not moving.any():
            return math.inf, 0.0
        nu, mu = self._nu[moving], self._mu[moving]
        lo = float(np.min(np.maximum((0.8 * nyq - mu) / nu, 1e-9)))
        hi = float(np.max((0.95 * nyq - mu) / nu))
        return lo, hi

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
        segments = list(self._segments(n0, n)) if not (len(ks) == 2 and ks[1].x >= n0 + n) else \
            [(ks[0], ks[1], n0, n0 + n)]
        floor_on = self.floor_density > 0
        # the C line-set kernel renders the floor per block itself (lazy); any other path adds the chunk's floor
        lazy = floor_on and self._general and self._lines_fused
        floor = self._floor_block(n0, n) if floor_on and not lazy else None
        fused = self._noise_fused or (floor_on and synth_kernel.AVAILABLE)
        late = not fused and (self._noise_on or floor is not None)   # numpy: added, moments taken, at the end
        seg_acc = None if late else acc
        for a, b, lo, hi in segments:
            dest = out[lo - n0:hi - n0]
            noise = None
            if fused:
                noise = self._segment_noise(a, b, lo) if self._noise_on else (self._noise_key, lo, None)
                if lazy:
                    noise = noise + (self._floor_part(a, b, lo, hi),)
                else:
                    noise = noise + (None if floor is None else self._floor_faded(floor[lo - n0:hi - n0], a, b, lo),)
            if a.amp.families is None and b.amp.families is None:
                self._segment(a, b, lo, hi, dest, seg_acc, noise)  # noise and features inside the sample loop
                continue
            if a.amp.families is not b.amp.families:
                self._segment_swap(a, b, lo, hi, dest)              # a model swap across line-set layouts
            elif self._segment_lines(a, b, lo, hi, dest, seg_acc, noise):
                continue                                             # noise and features in the C line-set pass
            if noise is not None:                                    # the families' sum first, then one pass
                synth_kernel.noise_add(dest, noise[0], lo, noise[2], self._dc_off, seg_acc, noise[3])
            elif seg_acc is not None:
                self._accumulate(dest, self._dc_off, seg_acc)
        if late:
            if self._noise_on:
                self._add_noise(n0, n, out)
            if floor is not None:
                out += floor
            if acc is not None:
                self._accumulate(out, self._dc_off, acc)
        return self._make_chunk(n0, n, out, acc)

    def _segment(self, a: _Knot, b: _Knot, lo: int, hi: int, out: np.ndarray, acc, noise=None) -> None:
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
        if self._slip_walk is not None:              # the walk at the samples' passes, as fixed-point offsets (C)
            warp = self._slip_walk.warp_fixed(a.u_int, j, m, c1, c2, a.u_frac)[0]
        tb = b.amp.table if b.amp is not a.amp else None
        if noise is None:
            self._segment_fn(phase0, dphase0, dd, warp, a.amp.table, tb, float(j), 65536.0 / length, out,
                             acc, self._dc_off)
        else:
            self._segment_fn(phase0, dphase0, dd, warp, a.amp.table, tb, float(j), 65536.0 / length, out,
                             acc, self._dc_off, noise=noise)

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
        if a.amp.families is not None:                              # just swapped from another line set
            a = b
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
            "broadband_force_n_per_sqrt_hz": self.floor_density,
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
