"""Model switches that cost the stream nothing: a new model bound to a synthesiser's settings before the switch.

:meth:`Synthesizer.set_model <bkabem_core.synth.synthesizer.Synthesizer.set_model>` with a bare model binds it at the chunk
border and leaves the rest to the chunk that follows, in the streaming thread: the line families and their kernels'
plans (~9 ms for the ~350 lines of an inner-race set), the broadband floor's transfer for the synthesiser's
channels, rate and measurement chain (:class:`~bkabem_core.synth.floor.FloorTransfer`: the standstill receptance
at 16 383 frequencies, ~150 ms), the floor's frames of the seed (~5 ms) and the first knot's spectrum (with the
modal spectrum the speed cells of the new line set, ~20-45 ms): 150-240 ms at 25.6 kHz, more than two periods of a
0.1-s chunk, and 115-320 ms on the node's path with the model's unpickling (BENCHMARKS.md, "Model switches").

:meth:`SwitchPath.warm` does all of it before the switch, in any thread, while the synthesiser streams on: it binds
the model to a *shadow* of the synthesiser (a shallow copy that records every attribute it sets), makes the floor,
the fused kernels' plan, the spectrum at the current speed (cached as that speed's knot) and the speed cells within
one ``max_speed_step_hz`` of it, and returns a :class:`WarmModel` that holds the recorded attributes only.
``set_model(warm)`` then installs them (a dictionary update, ~10 us). The samples are those of ``set_model(model)``
bit for bit: the same code makes the same numbers, only earlier (tested: tests/unit/test_synth_switch.py).

A warm model belongs to the synthesiser that made it and to the settings it had then (rate, channels, seed, noise,
slip, sensors, spectrum method, for an order set the running stream's table size, ...): if they changed before the
switch, or it was installed already, ``set_model`` binds its model afresh (correct, only not warm);
:attr:`WarmModel.fresh` tells a provider to make it again instead.

Thread safety: :meth:`SwitchPath.warm` reads the synthesiser's settings and writes only the shadow's attributes and
the new model's shared caches (its floor transfer, speed cells and exact responses, each safe for concurrent use);
the streaming thread is never blocked by it except for the GIL that its pure-Python parts hold (~10 ms in all, in
slices of the interpreter's switch interval). numpy's BLAS and LAPACK calls, most of the work, release it.

Units: speeds in Hz, times in s.
"""

from __future__ import annotations

import time
import weakref
from collections import OrderedDict

from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.profile import SynthError, _finite


class _Recording:
    """Mixin of a synthesiser's shadow during :meth:`SwitchPath.warm`: records the names of the attributes set."""

    def __setattr__(self, name, value):
        self.__dict__["_warm_written"].add(name)
        object.__setattr__(self, name, value)


_RECORDING_CLASSES: dict[type, type] = {}


def _recording_class(cls: type) -> type:
    """``cls`` with :class:`_Recording` in front (made once per class)."""
    rc = _RECORDING_CLASSES.get(cls)
    if rc is None:
        rc = _RECORDING_CLASSES[cls] = type(f"_Warming{cls.__name__}", (_Recording, cls), {})
    return rc


class WarmModel:
    """A model bound ahead to one synthesiser's settings (:meth:`SwitchPath.warm`); ``set_model`` installs it.

    Attributes
    ----------
    model : BkaBem
        The model.
    speed_hz : float or None
        Shaft speed [Hz] whose knot spectrum was made ahead (None: none, the stream had no speed yet).
    seconds : float
        Wall time the warm-up took [s].
    installed : bool
        Whether a synthesiser installed it (then it is spent: a second ``set_model`` with it binds afresh).
    """

    def __init__(self, owner, model: BkaBem, state: dict, settings: tuple, speed_hz: float | None, seconds: float):
        self._owner = weakref.ref(owner)
        self.model = model
        self._state = state
        self._settings = settings
        self.speed_hz = speed_hz
        self.seconds = float(seconds)

    @property
    def case(self):
        return self.model.case

    @property
    def installed(self) -> bool:
        return self._state is None

    def fits(self, synth) -> bool:
        """Whether ``synth`` can install this (it made it, with the settings it has now, and it is not spent)."""
        return self._state is not None and self._owner() is synth \
            and synth._switch_settings(self.model) == self._settings

    @property
    def fresh(self) -> bool:
        """Whether the synthesiser that made it can still install it (:meth:`fits`): a provider that holds warm
        models makes a stale one again (e.g. an order set warmed before the stream switched to another table
        size)."""
        owner = self._owner()
        return owner is not None and self.fits(owner)

    def near(self) -> bool:
        """Whether the spectrum work it made ahead still serves the stream's current speed: within
        ``max_speed_step_hz`` of :attr:`speed_hz` (always with ``spectrum="exact"``: a knot's solve is what any new
        speed costs). A provider that warms ahead makes a far one again while there is time."""
        owner = self._owner()
        if owner is None or owner._spectrum_kind == "exact":
            return True
        f = owner._current_speed_hz()
        if f is None or self.speed_hz is None:
            return f is None and self.speed_hz is None
        return abs(f - self.speed_hz) <= owner.max_speed_step_hz

    def __repr__(self) -> str:
        return (f"WarmModel({self.model.case.name!r}, speed_hz={self.speed_hz}, seconds={self.seconds:.3f}, "
                f"installed={self.installed})")


class SwitchPath:
    """The :class:`~bkabem_core.synth.synthesizer.Synthesizer`'s methods for warm model switches (a mixin; module docstring)."""

    def _switch_settings(self, model: BkaBem) -> tuple:
        """Everything besides ``model`` that binding it and its first knot read: a warm model made under other
        settings is not installed. (An order set keeps the table size of a running stream's current model.)"""
        keeps_table = bool(self._knots) and self._table_size_arg is None and model.is_order_set
        return (self.sample_rate_hz, self.chunk_samples, self.channel_names, self.band_limit, self._spectrum_kind,
                self._use_modal, self._max_order_arg, self._table_size_arg,
                self.table_size if keeps_table else None, self.min_speed_hz, self.max_speed_step_hz,
                self.dtype, self.seed, self.slip, self.noise_density, self.snr_db, self.accelerometer,
                self.anti_alias, self._floor_wanted)

    def _current_speed_hz(self) -> float | None:
        """The stream's speed now [Hz]: the last knot's (None before the first chunk without ``initial_speed_hz``);
        safe to call from another thread than the streaming one."""
        try:
            return self._knots[-1].f
        except IndexError:
            return self.initial_speed_hz

    def warm(self, model: BkaBem, speed_hz: float | None = None, margin_hz: float | None = None) -> WarmModel:
        """Bind ``model`` to this synthesiser's settings now, for a later ``set_model`` that costs the stream
        nothing (module docstring); callable from any thread while this synthesiser streams.

        Parameters
        ----------
        model : BkaBem
            The model to switch to.
        speed_hz : float or None
            Shaft speed [Hz] at which the first knot after the switch is expected (its spectrum is made now and
            the speed cells within ``margin_hz`` of it); None: the stream's current speed.
        margin_hz : float or None
            Speed range [Hz] either side of ``speed_hz`` whose speed cells are made too (modal spectrum); None:
            ``max_speed_step_hz`` (a stream whose next speed is not known yet); 0: the knot's own cell only (the
            next knot's speed is ``speed_hz``, as in an offline run).

        Returns
        -------
        WarmModel
            For :meth:`set_model`. Bad models raise :class:`SynthError` here as ``set_model`` would.
        """
        if not isinstance(model, BkaBem):
            raise SynthError("model", f"must be a BkaBem (got {type(model).__name__})")
        f = self._current_speed_hz() if speed_hz is None else _finite("speed_hz", speed_hz, 0.0)
        t0 = time.perf_counter()
        settings = self._switch_settings(model)
        shadow = object.__new__(_recording_class(type(self)))
        shadow.__dict__.update(self.__dict__)              # one C call: a consistent snapshot
        written: set = set()
        shadow.__dict__["_warm_written"] = written
        use_modal = shadow._use_modal                       # as set_model: the streaming choice stays
        shadow._bind_model(model)
        shadow._use_modal = use_modal
        shadow._table_cache = OrderedDict()
        if shadow.floor_density > 0:
            shadow._floor_source()                          # the transfer (shared per model) and this seed's frames
        if shadow._general and shadow._lines_fused:
            shadow._fused_plan(shadow._families)            # the line-set kernel's per-segment plan
        if f is not None:
            shadow._amplitudes(f)                           # the first knot's spectrum and tables, cached
            margin = self.max_speed_step_hz if margin_hz is None else _finite("margin_hz", margin_hz, 0.0)
            lo, hi = max(f - margin, 0.0), f + margin
            if shadow._general:
                if shadow._cells is not None:
                    shadow._cells.build(lo, hi)
            elif shadow._use_modal and shadow._modal is not None:
                shadow._modal.build(lo, hi)
        state = {k: shadow.__dict__[k] for k in written}
        return WarmModel(self, model, state, settings, f, time.perf_counter() - t0)

    def _install(self, warm: WarmModel) -> bool:
        """Install a warm model (True), or False if it does not fit (:meth:`WarmModel.fits`)."""
        if not warm.fits(self):
            return False
        state, warm._state = warm._state, None
        old_key = old_plan = None
        if getattr(self, "_general", False) and self._lines_fused:
            # the segment across the swap renders the old line set once more: its plan stays next to the new one
            old_key = (id(self._families), self._slip_walk is not None)
            old_plan = self._scratch.get("fused", {}).get(old_key)
        self.__dict__.update(state)
        if old_plan is not None:
            plans = self._scratch.setdefault("fused", OrderedDict())
            if old_key not in plans:
                plans[old_key] = old_plan
                plans.move_to_end(old_key, last=False)
        return True
