"""The spectrum at a knot of the :class:`~bkabem_core.synth.synthesizer.Synthesizer`: the low-speed fade and the Nyquist taper
of the lines, the band check, the spectrum method (the modal form's speed cells or the exact BKA-BEM solve, and
``spectrum="auto"``'s choice between them) and, for the BPFO-order path, the channel amplitudes and the spline table
of a knot (``synth_kernel.knot_table``). A mixin, as :class:`~bkabem_core.synth.linesets.LineSetPath`: it reads the
synthesiser's state; any other line set takes its amplitudes from ``LineSetPath._line_amplitudes``.

Units: speeds and frequencies in Hz, amplitudes in the channels' units, costs in s.
"""

from __future__ import annotations

import sys

import numpy as np

from bkabem_core.solve.harmonic import TWO_PI, SpeedCells
from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.linesets import ModalSpectrum, _Amplitudes
from bkabem_core.synth.profile import SpeedProfile, SynthError
from bkabem_core.synth.sensors import chain_gains


class KnotSpectrum:
    """The synthesiser's methods for the spectrum at a knot (module docstring)."""

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

    def band_taper(self, speed_hz: float):
        """The Nyquist taper per line at a shaft speed (``band_limit="taper"``), or None when every line is carried
        in full.

        Parameters
        ----------
        speed_hz : float
            Shaft speed [Hz].

        Returns
        -------
        ndarray (K,) or None
            Weight of each kept line (order) in [0, 1]: 1 below 0.85 of Nyquist, a raised cosine to 0 at 0.95,
            0 above [-].
        """
        return self._order_weights(float(speed_hz))[1]

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
        when first used. Any other line set than BPFO orders: the speed cells of its speed-locked lines over the same
        range (checked against the exact response first; ~10x the order set's cost for 350-670 lines)."""
        if self.floor_density > 0:
            self._floor_source()
        if self._general:
            self._line_spectrum_at(1.0)                          # makes the cells (or falls back to exact)
            if self._cells is not None:
                self._cells.build(0.0, min(self.case.max_speed_hz, self.max_speed_for_rate_hz()))
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
