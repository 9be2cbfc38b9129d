"""A synthesis plan: everything a synthesiser derives from one model and its settings, made once.

A :class:`Plan` holds the kept lines and their families (:mod:`bkabem_core.synth.lines`), the channels and the
combinations of the model's outputs they read (:mod:`bkabem_core.synth.channels`), the spectrum method
(:mod:`bkabem_core.synth.spectrum`), the sensor chain, the line kernels chosen for the settings
(:mod:`bkabem_core.synth.render`), the sensor noise, the broadband floor and the run's ground truth. It never
changes: another model or other settings make another plan (the parts they share carried over, e.g. a new seed
keeps the lines and their kernels, and the floor's transfer). Its memos fill on first use and hold pure functions
of the plan: the line amplitudes and tables per speed (the last few speeds), the checked speed cells, the floor's
frames.

What changes from chunk to chunk (knots, next sample, slip walk) is the stream's
(:mod:`bkabem_core.synth.stream`). A model switch is a new plan swapped in at a chunk border; it can be made and
warmed in another thread (:mod:`bkabem_core.synth.switch`).

Units: speeds and frequencies in Hz, amplitudes in the channels' units.
"""

from __future__ import annotations

import copy
import math
from collections import OrderedDict

import numpy as np

from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.channels import ChannelMap
from bkabem_core.synth.floor import BroadbandFloor
from bkabem_core.synth.lines import LineSelection
from bkabem_core.synth.profile import SynthError
from bkabem_core.synth.randomness import SensorNoise
from bkabem_core.synth.render import Amplitudes, FusedLines, LoopLines
from bkabem_core.synth.spectrum import LineSpectrum

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
        profile by :func:`~bkabem_core.synth.spectrum.choose_method`).
    """

    def __init__(self, model, settings, method: str):
        self.model = model
        self.case = model.case
        self.settings = settings
        self.channels = ChannelMap(settings.channels)
        self.lines = LineSelection(model, settings.max_order, settings.table_size)
        self.spectrum = LineSpectrum(model, self.channels.combination, method)
        self.dc = self.channels.static_part(model)
        #: the static part as float64: the chunk features' moments are taken about it
        self.dc_off = np.ascontiguousarray(self.dc, dtype=np.float64)
        self.lines_kernel, self.accumulate = self._kernels(settings)
        self.floor_density = float(model.case.raw["baseline"].get("broadband_force_n_per_sqrt_hz", 0.0)) \
            if settings.broadband_floor else 0.0
        self._floor = None
        self._seeded(settings)
        self._memo: OrderedDict = OrderedDict()

    def _kernels(self, settings):
        """(line kernels, feature accumulation) for the settings (:class:`~bkabem_core.synth.settings.Settings`
        ``kernel``)."""
        c, fams = len(self.channels), len(self.lines.families)
        if (settings.kernel == "auto" and synth_kernel.LINES_AVAILABLE and settings.dtype == np.float32
                and c <= FUSED_MAX_CHANNELS and fams <= FUSED_MAX_FAMILIES):
            lines = FusedLines(self.lines, self.channels, self.dc, settings.sample_rate_hz, settings.slip > 0)
            return lines, synth_kernel.accumulate
        compiled = synth_kernel.AVAILABLE and settings.kernel != "reference"
        segment = synth_kernel.segment if compiled else synth_kernel.segment_reference
        lines = LoopLines(self.lines, self.channels, self.dc, settings.sample_rate_hz, settings.dtype, segment)
        return lines, synth_kernel.accumulate if compiled else synth_kernel.accumulate_reference

    def _seeded(self, settings) -> None:
        """The parts that follow the seed and the noise: sensor noise, the floor's frames, the ground truth."""
        self.noise = SensorNoise(settings.noise, settings.snr_db, settings.channels, settings.sample_rate_hz,
                                 settings.seed, settings.dtype)
        if self._floor is not None and self._floor.seed != settings.seed:
            self._floor = self._floor.reseeded(settings.seed)
        gt = self.case.ground_truth()
        gt.update({
            "fault_multipliers": self.model.fault_multipliers.to_dict(),
            "seed": settings.seed,
            "slip_std_fraction": settings.slip,
            "noise_density": settings.noise,
            "snr_db": settings.snr_db,
            "sample_rate_hz": settings.sample_rate_hz,
            "orders": [int(k) for k in self.lines.orders],
            **settings.sensors.metadata(),
            "broadband_force_n_per_sqrt_hz": self.floor_density,
            "line_coefficients": self.lines.coefficients.tolist(),
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
            taper = self.lines.band_taper(f, self.settings.sample_rate_hz)
        return fade, taper

    def _through_sensors(self, x: np.ndarray, f: float) -> np.ndarray:
        """The kept lines of x through the sensor chain (each line's complex gain at its frequency)."""
        if self.lines.keep_some:
            x = x[self.lines.keep]
        chain = self.settings.sensors
        if chain:
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
            if spow is not None and (self.lines.keep_some or self.settings.sensors):
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
        per_order = self.lines.bpfo_per_hz * f
        fit = min(int(fs / 2 / per_order) if f > 0 else k, k - 1)
        return (f"sample rate {fs:g} Hz is below twice the highest kept line: {top:.1f} Hz at {f:g} Hz shaft speed "
                f"(order {k}; needs a rate > {2 * top:.1f} Hz, or max_order <= {fit}, or band_limit='taper')")

    def knots_between(self, fa: float, fb: float, max_knots: int) -> int:
        """Segments between knots of speeds fa and fb [Hz]: the speed moves by at most ``max_speed_step_hz`` per
        segment, and with ``band_limit="taper"`` by at most 2 % where a line is near the taper (0.8 .. 0.95 of
        Nyquist; outside that range a change from standstill would ask for a thousand knots); at most ``max_knots``."""
        n = math.ceil(abs(fb - fa) / self.settings.max_speed_step_hz - 1e-12)
        if self.settings.band_limit == "taper":
            near_lo, near_hi = self.lines.taper_speeds_hz(self.settings.sample_rate_hz)
            hi = min(max(fa, fb), near_hi)
            lo = max(min(fa, fb), near_lo)
            if hi > 1.02 * lo:
                n = max(n, math.ceil(math.log(hi / lo) / math.log(1.02)))
        return max(1, min(n, max_knots))

    # ------------------------------------------------------------------ broadband floor
    @property
    def floor(self) -> BroadbandFloor | None:
        """The broadband floor of these channels (made on first use; None without one)."""
        if self.floor_density <= 0:
            return None
        if self._floor is None:
            ch = self.channels
            self._floor = BroadbandFloor(self.model, self.floor_density, ch.combination, ch.cindex, ch.power,
                                         ch.scale, ch.housing_columns, self.settings.sample_rate_hz,
                                         self.settings.seed, self.settings.sensors)
        return self._floor

    def floor_block(self, n0: int, n: int) -> np.ndarray:
        """The floor of samples [n0, n0 + n) in the samples' dtype."""
        x = self.floor.render(n0, n)
        return x if self.settings.dtype == np.float32 else x.astype(self.settings.dtype)

    # ------------------------------------------------------------------ warm-up
    def prepare(self, f_lo_hz: float, f_hi_hz: float, speed_hz: float | None = None) -> None:
        """Make now what the first chunks would make: the floor's frames, the speed cells of [f_lo_hz, f_hi_hz]
        [Hz] and the amplitudes at ``speed_hz`` (if given)."""
        _ = self.floor
        if speed_hz is not None:
            self.amplitudes(speed_hz)
        if f_hi_hz >= f_lo_hz:
            self.spectrum.build(f_lo_hz, f_hi_hz)

    def line_phases_rad(self, shaft_rad: float, cage_rad: float, t_s: float) -> np.ndarray:
        """(L,) phase of every kept line [rad] at shaft and cage angles [rad] and time [s]."""
        fm = self.model.fault_multipliers
        return self.lines.phases_rad(shaft_rad, cage_rad, t_s, fm.bsf / fm.ftf)

