"""Model switches that cost the stream nothing: the next plan made before the switch.

:meth:`Synthesizer.set_model <bkabem_core.synth.synthesizer.Synthesizer.set_model>` with a bare model makes its
plan at the chunk border and leaves the rest to the chunk that follows, in the streaming thread: the line
families and their kernels, the broadband floor's transfer for the synthesiser's channels, rate and sensors
(:class:`~bkabem_core.synth.floor.FloorTransfer`, shared by the models of one machine), the floor's frames of the
seed and the first knot's spectrum (with the modal spectrum the speed cells of the new line set): together more
than a chunk period of a streaming node.

:meth:`Synthesizer.warm <bkabem_core.synth.synthesizer.Synthesizer.warm>` makes all of it before the switch, in any
thread, while the synthesiser streams on: the plan of the model under the synthesiser's settings, its floor, the
spectrum at the current speed (kept as that speed's amplitudes) and the speed cells within one
``max_speed_step_hz`` of it, in a :class:`WarmModel`. ``set_model(warm)`` then swaps the plan in: one reference.
The samples are those of ``set_model(model)`` bit for bit: the same plan, only made earlier (tested:
tests/unit/test_synth_switch.py).

A warm model belongs to the synthesiser that made it and to the settings and spectrum method it had then: if they
changed before the switch, or it was installed already, ``set_model`` makes its model's plan afresh (correct, only
not warm); :attr:`WarmModel.fresh` tells a provider to make it again instead.

Thread safety: the warm-up reads the synthesiser's settings (an immutable object) and the stream's speed, and
writes only the new plan and the new model's shared caches (its floor transfer, speed cells and exact responses,
each safe for concurrent use); the streaming thread is never blocked by it except for the GIL that its pure-Python
parts hold. numpy's BLAS and LAPACK calls, most of the work, release it.

Units: speeds in Hz, times in s.
"""

from __future__ import annotations

import weakref


class WarmModel:
    """A model's plan made ahead for one synthesiser (:meth:`Synthesizer.warm`); ``set_model`` installs it.

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

    def __init__(self, owner, plan, key: tuple, speed_hz: float | None, seconds: float):
        self._owner = weakref.ref(owner)
        self.model = plan.model
        self._plan = plan
        self._key = key
        self.speed_hz = speed_hz
        self.seconds = float(seconds)

    @property
    def case(self):
        return self.model.case

    @property
    def installed(self) -> bool:
        return self._plan is None

    def fits(self, synth) -> bool:
        """Whether ``synth`` can install this (it made it, with the settings and spectrum method it has now, and it
        is not spent)."""
        return self._plan is not None and self._owner() is synth and synth._switch_key() == self._key

    def take(self, synth):
        """The plan, for ``synth`` to install (then this is spent), or None if it does not fit (:meth:`fits`)."""
        if not self.fits(synth):
            return None
        plan, self._plan = self._plan, None
        return plan

    @property
    def fresh(self) -> bool:
        """Whether the synthesiser that made it can still install it (:meth:`fits`): a provider that holds warm
        models makes a stale one again."""
        owner = self._owner()
        return owner is not None and self.fits(owner)

    def near(self) -> bool:
        """Whether the spectrum work it made ahead still serves the stream's current speed: within
        ``max_speed_step_hz`` of :attr:`speed_hz` (always with ``spectrum="exact"``: a knot's solve is what any new
        speed costs). A provider that warms ahead makes a far one again while there is time."""
        owner = self._owner()
        if owner is None or owner.settings.spectrum == "exact":
            return True
        f = owner.speed_now_hz()
        if f is None or self.speed_hz is None:
            return f is None and self.speed_hz is None
        return abs(f - self.speed_hz) <= owner.max_speed_step_hz

    def __repr__(self) -> str:
        return (f"WarmModel({self.model.case.name!r}, speed_hz={self.speed_hz}, seconds={self.seconds:.3f}, "
                f"installed={self.installed})")
