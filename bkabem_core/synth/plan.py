"""A synthesis plan: everything a synthesiser derives from one model and its settings, made once.

A :class:`Plan` holds the kept lines and their families (:mod:`bkabem_core.synth.lines`), the channels and the
combinations of the model's outputs they read (:mod:`bkabem_core.synth.channels`), the spectrum method
(:class:`LineSpectrum`, below), the sensor chain, the line kernels chosen for the settings
(:mod:`bkabem_core.synth.render`), the sensor noise, the broadband floor and the run's ground truth. It never
changes: another model or other settings make another plan (the parts they share carried over, e.g. a new seed
keeps the lines and their kernels, and the floor's transfer). Its memos fill on first use and hold pure functions
of the plan: the line amplitudes and tables per speed (the last few speeds), the checked speed cells, the floor's
frames.

The spectrum at a knot: the displacement combinations of every line of the model at one shaft speed, by one of two
methods within the stated bound of each other (docs/synthesis.md):

``"modal"``
    The model's order-wise pole-residue form in 0.5-Hz cells of shaft speed
    (:class:`~bkabem_core.fe.modal.SpeedCells`: a Chebyshev interpolant of the far poles, the near poles exactly,
    the interpolation error bounded per pole to 2e-6 of the output's reference). The speed-locked lines come from the
    cells, the fixed-frequency lines (the electrical line) from their dense solve. Checked once against the exact
    response at 25 Hz (every line within 1e-5 of the combination's largest); a check that fails falls back to
    ``"exact"``. Kept on the model: synthesisers of one model share the cells.
``"exact"``
    :meth:`BkaBem.response <bkabem_core.solve.harmonic.BkaBem.response>` at every knot, cached per speed and shared
    by every synthesiser of the model in the process.

:func:`choose_method` is ``spectrum="auto"``'s rule.

What changes from chunk to chunk (knots, next sample, slip walk) is the stream's
(:mod:`bkabem_core.synth.stream`). A model switch is a new plan swapped in at a chunk border; it can be made and
warmed in another thread (:mod:`bkabem_core.synth.switch`).

Units: speeds and frequencies in Hz, amplitudes in the channels' units (the spectrum's in m), costs in s.
"""

from __future__ import annotations

import copy
import weakref
from collections import OrderedDict

import numpy as np

from bkabem_core.fe.modal import SpeedCells
from bkabem_core.model.vocabulary import BEARINGS
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.balltrack import BallTrack
from bkabem_core.synth.channels import ChannelMap
from bkabem_core.synth.floor import BroadbandFloor
from bkabem_core.synth.lines import LineSelection
from bkabem_core.synth.profile import SynthError
from bkabem_core.synth.randomness import SensorNoise
from bkabem_core.synth.render import Amplitudes, FusedLines, LoopLines
from bkabem_core.synth.rolling import RollingSwing
from bkabem_core.synth.strikes import StrikeSpread, strike_key

#: line amplitudes kept per plan (the speeds of the last knots: a held or repeated speed costs nothing)
AMPLITUDE_MEMO = 8
#: the fused C kernels' limits (their per-call arrays are on the stack)
FUSED_MAX_CHANNELS = FUSED_MAX_FAMILIES = 64


class Plan:
    """Model and settings, and what they fix (module docstring).

    Parameters
    ----------
    model : BkaBem
    settings : Settings
    method : {"modal", "exact"}
        The spectrum method (``settings.spectrum`` resolved: ``"auto"`` is modal in streaming and decided per
        profile by :func:`choose_method`).
    """

    def __init__(self, model, settings, method: str):
        self.model = model
        self.case = model.case
        self.settings = settings
        self.channels = ChannelMap(settings.channels)
        self.lines = LineSelection(model, settings.max_order, settings.table_size)
        #: a ball defect's track wander and spin slip (None: no ball defect, or neither)
        self.track = BallTrack.of_model(model, self.lines.coefficients)
        #: a race pit's random strike strength (None: no race pit with a spread, or no line on its strike phase)
        self.strikes = StrikeSpread.of_model(model, self.lines) if settings.strikes else None
        self._gate_families = self._gate_slices = None
        self.spectrum = LineSpectrum(model, self.channels.combination, method)
        self.dc = self.channels.static_part(model)
        #: the static part as float64: the chunk features' moments are taken about it
        self.dc_off = np.ascontiguousarray(self.dc, dtype=np.float64)
        self.lines_kernel, self.accumulate = self._kernels(settings)
        baseline = model.case.raw["baseline"]
        self.floor_density = float(baseline.get("broadband_force_n_per_sqrt_hz", 0.0)) \
            if settings.broadband_floor else 0.0
        #: the acquisition's input floor [m/s^2/sqrt(Hz)] (drawn into the floor's frames)
        self.input_noise = settings.input_noise
        ch = self.channels
        #: the broadband floor and the input floor of these channels (None: neither)
        self.floor = BroadbandFloor(model, self.floor_density, ch.combination, ch.cindex, ch.power, ch.scale,
                                    ch.housing_columns, settings.sample_rate_hz, settings.seed, settings.sensors,
                                    self.input_noise, self._pair_gains(model.case)) \
            if self.floor_density > 0 or self.input_noise > 0 else None
        #: the floor's swing with a load that turns with the shaft (None: no floor force, or no turning load)
        self.rolling = RollingSwing.of_plan(model, self.floor, self.lines.bpfo_per_hz)
        #: shaft speeds [Hz] between which some line is near the Nyquist taper (knot placement)
        self.taper_speeds_hz = self.lines.taper_speeds_hz(settings.sample_rate_hz, settings.taper_band)
        self.n_channels = len(ch.channels)
        self._seeded(settings)
        self._memo: OrderedDict = OrderedDict()

    @staticmethod
    def _pair_gains(case) -> np.ndarray:
        """The floor's force-pair gains (de v, de h, nde v, nde h): each bearing's largest ``roughness_db`` of its
        defects, as an amplitude factor (:mod:`bkabem_core.synth.floor`)."""
        db = {b: 0.0 for b in BEARINGS}
        for d in case.raw["defects"]:
            db[d["bearing"]] = max(db[d["bearing"]], float(d.get("roughness_db", 0.0)))
        return np.array([10.0 ** (db[b] / 20.0) for b in BEARINGS for _ in range(2)])

    def _kernels(self, settings):
        """(line kernels, feature accumulation) for the settings (:class:`~bkabem_core.synth.settings.Settings`
        ``kernel``)."""
        c, fams = len(self.channels.channels), len(self.lines.families.families)
        spin, column = (self.track.spin_slip, self.track.spin_column) if self.track is not None else (0.0, 2)
        if (settings.kernel == "auto" and synth_kernel.LINES_AVAILABLE and settings.dtype == np.float32
                and c <= FUSED_MAX_CHANNELS and fams <= FUSED_MAX_FAMILIES):
            lines = FusedLines(self.lines, self.channels, self.dc, settings.sample_rate_hz, settings.slip > 0, spin,
                               column, self.strikes)
            return lines, synth_kernel.accumulate
        compiled = synth_kernel.AVAILABLE and settings.kernel != "reference"
        segment = synth_kernel.segment if compiled else synth_kernel.segment_reference
        lines = LoopLines(self.lines, self.channels, self.dc, settings.sample_rate_hz, settings.dtype, segment, spin,
                          column, self.strikes)
        return lines, synth_kernel.accumulate if compiled else synth_kernel.accumulate_reference

    def _seeded(self, settings) -> None:
        """The parts that follow the seed and the noise: sensor noise, the floor's frames, the ground truth."""
        self.noise = SensorNoise(settings.noise, settings.snr_db, settings.channels, settings.sample_rate_hz,
                                 settings.seed, settings.dtype)
        if self.floor is not None and self.floor.seed != settings.seed:
            self.floor = self.floor.reseeded(settings.seed)
        if self.rolling is not None and self.rolling.seed != settings.seed:
            self.rolling = self.rolling.reseeded(settings.seed)
        #: the acquisition's output stage bound to the channels and the seed (empty: none)
        self.output = settings.output.bind(settings.channels, settings.sample_rate_hz, settings.seed)
        #: the key of the run's strike stream (a race pit's random strike strength)
        self.strike_key = strike_key(settings.seed)
        gt = self.case.ground_truth()
        gt.update({
            "fault_multipliers": self.lines.multipliers["de"].to_dict(),          # the DE bearing's
            "seed": settings.seed,
            "slip_std_fraction": settings.slip,
            "noise_density": settings.noise,
            "snr_db": settings.snr_db,
            "sample_rate_hz": settings.sample_rate_hz,
            "orders": [int(k) for k in self.lines.orders],
            **settings.sensors.metadata(),
            **settings.output.metadata(),
            "broadband_force_n_per_sqrt_hz": self.floor_density,
            "input_noise_m_s2_per_sqrt_hz": self.input_noise,
            **({"ball_track": self.track.to_dict()} if self.track is not None else {}),
            **({"strikes": self.strikes.to_dict()} if self.strikes is not None else {}),
            **({"floor_swing": self.rolling.to_dict()} if self.rolling is not None else {}),
            "line_coefficients": self.lines.coefficients.tolist(),
            "line_bearings": self.model.phases.line_bearings(self.lines.coefficients),
            "line_multipliers": self.lines.nu.tolist(),
        })
        #: the run's ground truth (JSON-ready; a chunk adds its speed and fault frequencies)
        self.ground_truth = gt

    # ------------------------------------------------------------------ other plans
    def with_settings(self, settings) -> "Plan":
        """The plan of this model under ``settings``: where only the seed or the sensor noise differ, a copy that
        shares everything else (lines, kernels, spectrum, amplitudes, the floor's transfer); else a new plan."""
        if settings == self.settings:
            return self
        same = self.settings.__class__.__dataclass_fields__.keys() - {"seed", "noise_density", "snr_db"}
        if any(getattr(settings, k) != getattr(self.settings, k) for k in same):
            return Plan(self.model, settings, self.spectrum.requested)
        plan = copy.copy(self)
        plan.settings = settings
        plan._seeded(settings)
        return plan

    def with_method(self, method: str) -> "Plan":
        """This plan with another spectrum method (new amplitudes; everything else shared)."""
        if method == self.spectrum.requested:
            return self
        plan = copy.copy(self)
        plan.spectrum = LineSpectrum(self.model, self.channels.combination, method)
        plan._memo = OrderedDict()
        return plan

    # ------------------------------------------------------------------ lines at a speed
    def weights(self, f: float):
        """Line weights at speed f [Hz]: the low-speed fade (a number, smoothstep from ``min_speed_hz`` to twice
        it) and, with ``band_limit="taper"`` near Nyquist, the taper per line ((L,) array; None when it is 1 for
        every line)."""
        lo = self.settings.min_speed_hz
        s = min(max((f - lo) / lo, 0.0), 1.0)
        fade = s * s * (3.0 - 2.0 * s)
        taper = None
        if self.settings.band_limit == "taper" and fade > 0:
            taper = self.lines.band_taper(f, self.settings.sample_rate_hz, self.settings.taper_band)
        return fade, taper

    def _through_sensors(self, x: np.ndarray, f: float) -> np.ndarray:
        """The kept lines of x through the sensor chain (each line's complex gain at its frequency)."""
        if self.lines.keep_some:
            x = x[self.lines.keep]
        chain = self.settings.sensors
        if chain.sensors:
            x = x * chain.gains(self.lines.frequency_hz(f), self.channels.housing_columns, x.shape[1])
        return x

    def amplitudes(self, f: float) -> Amplitudes:
        """The line amplitudes and tables at speed f [Hz] (memo: a held speed costs nothing)."""
        key = float(f)
        hit = self._memo.get(key)
        if hit is not None:
            self._memo.move_to_end(key)
            return hit
        fade, taper = self.weights(key)
        kernel = self.lines_kernel
        if isinstance(kernel, FusedLines):
            x, spow = self.spectrum.raw(key)
            if spow is not None and (self.lines.keep_some or self.settings.sensors.sensors):
                x *= spow[:, None]                            # (before the selection and the sensors)
                spow = None
            x = self._through_sensors(x, key)
            y, v_iso, tables = kernel.knot(x, key, fade, taper, spow)
        else:
            x = self._through_sensors(self.spectrum(key), key)
            y, v_iso, tables = kernel.knot(x, key, fade, taper)
        hit = Amplitudes(f=key, x=x, fade=fade, taper=taper, y=y, v_iso=v_iso, tables=tables, lines=kernel)
        self._memo[key] = hit
        if len(self._memo) > AMPLITUDE_MEMO:
            self._memo.popitem(last=False)
        return hit

    def _gated_families(self):
        """The families whose lines the track gates, each whole (their tables scale with the gain), or None if a
        family mixes gated and other lines (the knot is then made from the gated combinations)."""
        gated = self.track.gated
        out = []
        for i, fam in enumerate(self.lines.families.families):
            g = gated[fam.lines]
            if g.all():
                out.append(i)
            elif g.any():
                return None
        return out

    def gated_amplitudes(self, base: Amplitudes, gain: float) -> Amplitudes:
        """The knot amplitudes ``base`` with the ball defect's lines (``track.gated``) times ``gain`` [-] (the track
        wander at a knot, :mod:`bkabem_core.synth.balltrack`); gain 1: ``base`` itself. Where the gated lines are
        whole families, their tables are scaled (the same numbers to float32 rounding); else the knot is made
        again from the gated combinations."""
        if gain == 1.0:
            return base
        gated = self.track.gated
        if self._gate_families is None:
            self._gate_families = self._gated_families() or []
            kernel = self.lines_kernel
            if isinstance(kernel, FusedLines) and self._gate_families:
                # the table buffer as runs of (slice, gated): consecutive families of one kind joined
                slices, runs = kernel.family_tables(), []
                for i, sl in enumerate(slices):
                    g = i in self._gate_families
                    if runs and runs[-1][1] == g and runs[-1][0].stop == sl.start:
                        runs[-1] = (slice(runs[-1][0].start, sl.stop), g)
                    else:
                        runs.append((sl, g))
                self._gate_slices = runs
        kernel = self.lines_kernel
        fams = self._gate_families
        if not fams:                                    # mixed families: the whole knot again
            x = self.amplitudes(base.f).x.copy() if base.x is None else base.x.copy()
            x[gated] *= gain
            if isinstance(kernel, FusedLines):
                y, v_iso, tables = kernel.knot(x, base.f, base.fade, base.taper, None)
            else:
                y, v_iso, tables = kernel.knot(x, base.f, base.fade, base.taper)
        else:
            g = np.where(gated, gain, 1.0)[:, None]
            y, v_iso = base.y * g, base.v_iso * g
            if isinstance(kernel, FusedLines):
                tables = np.empty_like(base.tables)
                g32 = np.float32(gain)
                for sl, on in self._gate_slices:
                    if on:
                        np.multiply(base.tables[sl], g32, out=tables[sl])
                    else:
                        tables[sl] = base.tables[sl]
                end = self._gate_slices[-1][0].stop
                tables[end:] = base.tables[end:]
            else:
                tables = list(base.tables)
                for i in fams:
                    tables[i] = tuple(t * t.dtype.type(gain) for t in tables[i])
        return Amplitudes(f=base.f, x=None, fade=base.fade, taper=base.taper, y=y, v_iso=v_iso, tables=tables,
                          lines=kernel)

    # ------------------------------------------------------------------ band
    def check_band(self, f: float, argument: str) -> None:
        """SynthError naming ``argument`` if a line is at or above Nyquist at speed f [Hz] (``band_limit="error"``)."""
        s = self.settings
        if s.band_limit == "error" and f > s.min_speed_hz and self.lines.top_hz(f) >= s.sample_rate_hz / 2:
            raise SynthError(argument, self.band_message(f))

    def band_message(self, f: float) -> str:
        fs = self.settings.sample_rate_hz
        top = self.lines.top_hz(f)
        k = self.lines.highest_order
        per_order = self.lines.top_bpfo_per_hz * f
        fit = min(int(fs / 2 / per_order) if f > 0 else k, k - 1)
        return (f"sample rate {fs:g} Hz is below twice the highest kept line: {top:.1f} Hz at {f:g} Hz shaft speed "
                f"(order {k}; needs a rate > {2 * top:.1f} Hz, or max_order <= {fit}, or band_limit='taper')")

    def floor_block(self, n0: int, n: int) -> np.ndarray:
        """The floor of samples [n0, n0 + n) in the samples' dtype."""
        x = self.floor.render(n0, n)
        return x if self.settings.dtype == np.float32 else x.astype(self.settings.dtype)

    # ------------------------------------------------------------------ warm-up
    def prepare(self, f_lo_hz: float, f_hi_hz: float, speed_hz: float | None = None) -> None:
        """Make now what the first chunks would make: the speed cells of [f_lo_hz, f_hi_hz] [Hz] and the amplitudes
        at ``speed_hz`` (if given)."""
        if speed_hz is not None:
            self.amplitudes(speed_hz)
        if f_hi_hz >= f_lo_hz:
            self.spectrum.build(f_lo_hz, f_hi_hz)

    def line_phases_rad(self, shaft_rad: float, cage_rad: dict, t_s: float) -> np.ndarray:
        """(L,) phase of every kept line [rad] at the shaft angle, each bearing's cage angle (``{"de": ..,
        "nde": ..}``) [rad] and time [s]."""
        return self.lines.phases_rad(shaft_rad, cage_rad, t_s)


# =========================================================================== the spectrum at a knot
#: largest error of the speed cells at the check, relative to the combination's largest line (docs/synthesis.md)
MODAL_BOUND = 1e-5
#: speed of the check [Hz]
CHECK_SPEED_HZ = 25.0


class ExactSpectrum:
    """Displacement combinations from :meth:`BkaBem.response` at each requested speed (LRU cache).

    The cache is shared by every ExactSpectrum of the same model object and combination in the process: the
    machines of a fleet that run one case share its model, and when they follow the same speed (one speed topic,
    a line of identical drives) a speed step costs its amplitude knots once per process instead of once per
    machine. The entries are the model's exact response, so sharing changes no sample. Returned arrays are
    shared: read only.
    """

    #: id(model) -> {combination: LRU}; an entry goes with its model (weakref.finalize), so an id is never reused
    _shared: dict[int, dict] = {}

    def __init__(self, model, combination: np.ndarray, cache: int = 256):
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
        """(L, U) complex [m] of every line of the model at ``speed_hz`` [Hz]."""
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


class LineSpectrum:
    """Displacement combinations (L, U) [m] of every line of ``model`` by ``method`` (module docstring).

    Parameters
    ----------
    model : BkaBem
    combination : ndarray (U, 8)
        The output combinations (:class:`~bkabem_core.synth.channels.ChannelMap`).
    method : {"modal", "exact"}
    """

    def __init__(self, model, combination: np.ndarray, method: str):
        self.model = model
        self.combination = combination
        self.requested = method
        self.exact = ExactSpectrum(model, combination)
        self._cells = None
        #: why the speed cells were refused (their check's error), or None
        self.failed: str | None = None
        self._speed_scaled = bool(np.any(model.lines.speed_power != 0.0))
        li, fi = model.speed_locked_index, model.fixed_frequency_index
        #: the cells hold every line, in order (then their array is the spectrum itself)
        self._cells_are_all = not fi.size and li.size == len(model.lines) and (li.size == 0 or li[-1] == li.size - 1)

    @property
    def method(self) -> str:
        """``"modal"`` or ``"exact"`` (and why, where the speed cells failed their check)."""
        if self.failed is not None:
            return f"exact (speed cells failed their check: {self.failed})"
        return self.requested

    @property
    def cells(self):
        """The checked speed cells of the speed-locked lines, or None (``"exact"``, or the check failed); made and
        checked on first use."""
        if self.requested != "modal" or self.failed is not None:
            return None
        if self._cells is None:
            cells = self.model.order_modal_form(self.combination).speed_cells()
            err = self._check(cells, CHECK_SPEED_HZ)
            if err >= MODAL_BOUND:
                self.failed = f"error {err:.1e}"
                return None
            self._cells = cells
        return self._cells

    def _check(self, cells, f: float) -> float:
        """Largest error of the cells relative to the largest amplitude per combination, against the exact one."""
        m = self.model
        exact = self.exact(f)
        mine = np.array(exact, copy=True)
        mine[m.speed_locked_index] = cells(f) * (f ** m.lines.speed_power[m.speed_locked_index])[:, None]
        return float(np.max(np.abs(mine - exact).max(axis=0) / np.maximum(np.abs(exact).max(axis=0), 1e-300)))

    def raw(self, speed_hz: float):
        """(x, spow): the combinations (L, U) of every line of the model at ``speed_hz`` [Hz] before the lines'
        speed powers, and those (``f ** p`` (L,), None where x has them or they are all 0). x is the speed cells'
        own array where they hold every line in order: read only."""
        f = float(speed_hz)
        cells = self.cells
        if cells is None:
            return np.ascontiguousarray(self.exact(f)), None
        m = self.model
        if self._cells_are_all:
            x = cells(f)
        else:
            x = np.empty((len(m.lines), self.combination.shape[0]), complex)
            x[m.speed_locked_index] = cells(f)
            if m.fixed_frequency_index.size:
                x[m.fixed_frequency_index] = m.fixed_frequency_lines(f) @ self.combination.T
        return x, (f ** m.lines.speed_power if self._speed_scaled else None)

    def __call__(self, speed_hz: float) -> np.ndarray:
        """(L, U) combinations [m] of every line of the model at ``speed_hz`` [Hz], speed powers applied."""
        x, spow = self.raw(speed_hz)
        if spow is not None:
            x = x * spow[:, None]
        return x

    def build(self, f_lo_hz: float, f_hi_hz: float) -> None:
        """Make the speed cells of ``[f_lo_hz, f_hi_hz]`` [Hz] now (nothing with ``"exact"``)."""
        cells = self.cells
        if cells is not None:
            cells.build(f_lo_hz, f_hi_hz)


#: cost model of ``spectrum="auto"`` for a rendered profile [s]: one exact solve per knot of a new speed; one modal
#: evaluation per knot; the modal form's set-up per line, scaled with the cube of the model's DOFs; one speed cell
#: per line (measured on the embedded 60-DOF case of 50 BPFO orders)
COST_EXACT_S, COST_MODAL_S, COST_MODAL_SETUP_PER_LINE_S, COST_CELL_PER_LINE_S = 0.6e-3, 0.01e-3, 0.036, 0.08e-3


def choose_method(model, combination: np.ndarray, profile, seconds: float, knot_s: float,
                  max_speed_step_hz: float) -> str:
    """``spectrum="auto"``'s method for rendering ``profile`` over ``seconds``: the cheaper of the two by the cost
    model above for a model of BPFO orders (the set-up of the speed cells pays off after a few thousand knots,
    and a constant speed has one); the speed cells for any other line set (their exact solve grows with its
    ~50-700 lines and its dense fixed-frequency lines, the cells do not per knot)."""
    if not model.is_order_set:
        return "modal"
    t = profile.times_s
    t_end = np.concatenate([t[t < seconds], [seconds]])
    f_end = profile.speed_hz(t_end)
    knots = 1.0
    for i in range(len(t_end) - 1):
        df = abs(f_end[i + 1] - f_end[i])
        if df > 0:
            knots += max((t_end[i + 1] - t_end[i]) / knot_s, df / max_speed_step_hz) + 1
    made = model.has_order_modal_form(combination)
    n_k, scale = model.orders.size, model.basis.size / 60.0          # cost per pole, relative to 60 DOF
    setup = 0.0 if made or model.has_line_modes() else COST_MODAL_SETUP_PER_LINE_S * n_k * scale ** 3
    if made:
        cells = model.order_modal_form(combination).speed_cells().missing(f_end.min(), f_end.max())
    else:
        cells = len(SpeedCells.cell_range(SpeedCells.DEFAULT_CELL_HZ, f_end.min(), f_end.max()))
    setup += cells * COST_CELL_PER_LINE_S * n_k * scale
    return "modal" if setup + COST_MODAL_S * knots < COST_EXACT_S * knots else "exact"
