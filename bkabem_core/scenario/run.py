"""Running a scenario: scenario time of every sample, the state in effect at every chunk, its model, the ground truth.

A stream (the ROS node, or :class:`ScenarioRun` offline) is cut into chunks; a scenario changes the machine only at
chunk borders, where :meth:`Synthesizer.set_model` switches phase-continuously (the amplitudes move from the old to
the new model over the next chunk). :class:`ScenarioDriver` decides, before each chunk, which state is in effect and
hands over its model; it takes the models from a provider:

* :class:`InlineModels` (a :class:`~bkabem_core.scenario.models.ModelPool`): made when needed, blocking. Every state
  applies exactly at the first chunk border at or after its start: what :class:`ScenarioRun` and data sets use.
* :class:`BackgroundModels` (a helper process): prepared ahead, never waited for. A state whose model is not back
  when it falls due is applied as soon as it is; meanwhile the stream goes on with the state it has, and the ground
  truth says so (it always describes the model in the signal). When preparations take longer than the states last
  (a strong time compression), states are skipped: the driver asks for the state that will be due when the model
  could be ready, not for the next one. With a ``warm`` callable (a streaming node's: ``synth.warm``) a model that
  is back is also unpickled and warmed (:mod:`bkabem_core.synth.switch`: the floor's transfer, the line set's
  plans, the first knot's spectrum) by :class:`WarmWorker`, a thread at low CPU priority, and only a warm model
  counts as ready: the chunk after the switch then costs what any chunk costs.

:class:`ScenarioClock` maps stream samples to scenario time: ``t = start + time_scale x (stream time)``; a change of
the scale at a sample keeps the scenario time continuous there. Everything is a function of the sample index (not
of the wall clock), so a run is reproducible by its seed.

No ROS here. Units: s (scenario and stream time), Hz, samples.
"""

from __future__ import annotations

import math
import os
import queue
import threading
import time
from typing import Callable, Iterator

from bkabem_core.scenario.models import ModelHelper, ModelPool
from bkabem_core.scenario.timeline import Scenario, ScenarioState
from bkabem_core.solve.harmonic import BkaBem

#: Time scales a clock accepts (scenario seconds per stream second).
TIME_SCALE_RANGE = (1e-3, 1e7)
#: Ready models a background provider holds ahead of the state in effect.
MAX_READY_AHEAD = 2


class ScenarioClock:
    """Scenario time [s] of stream sample ``i``: ``t_a + time_scale * (i - i_a) / sample_rate_hz``.

    Parameters
    ----------
    sample_rate_hz : float
    time_scale : float
        Scenario seconds per stream second (3600: an hour per second).
    start_s : float
        Scenario time at sample ``start_index`` [s].
    start_index : int
        The stream sample at which the scenario starts (a scenario switched on in a running stream).
    """

    def __init__(self, sample_rate_hz: float, time_scale: float = 1.0, start_s: float = 0.0, start_index: int = 0):
        self.sample_rate_hz = float(sample_rate_hz)
        self.time_scale = check_time_scale(time_scale)
        self._anchor_index = int(start_index)
        self._anchor_s = float(start_s)

    def time_s(self, index) -> float:
        """Scenario time [s] at stream sample ``index``."""
        return self._anchor_s + self.time_scale * (index - self._anchor_index) / self.sample_rate_hz

    def rescale(self, time_scale: float, at_index: int) -> None:
        """A new time scale from sample ``at_index`` on (scenario time continuous there)."""
        t = self.time_s(at_index)
        self.time_scale = check_time_scale(time_scale)
        self._anchor_index, self._anchor_s = int(at_index), t


def check_time_scale(time_scale) -> float:
    v = float(time_scale)
    lo, hi = TIME_SCALE_RANGE
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"time_scale: must be in [{lo:g}, {hi:g}] scenario seconds per second (got {time_scale!r})")
    return v


# --------------------------------------------------------------------------- providers
class InlineModels:
    """Models made when asked for, blocking (a :class:`ModelPool`)."""

    def __init__(self, pool: ModelPool | None = None):
        self.pool = pool if pool is not None else ModelPool()
        self.idle = True
        self.estimate_s = 0.0

    def get(self, state: ScenarioState) -> BkaBem:
        return self.pool.get(state.case)

    def prefetch(self, state: ScenarioState) -> None:
        pass

    def prepare(self, state: ScenarioState) -> None:
        pass

    def has(self, state: ScenarioState) -> bool:
        return state.case.case_hash in self.pool

    def failed(self, state: ScenarioState) -> str | None:
        return None

    def release(self, state: ScenarioState) -> None:
        pass


class WarmWorker:
    """A thread that runs the warm-ups of models (:meth:`BackgroundModels.get`) off the streaming threads, one job
    at a time in request order, at a lower CPU priority (nice +10 for this thread on Linux): numpy's parts release
    the GIL and then run on the other core without taking it from a real-time stream. One per process can be
    shared (:meth:`shared`); the thread starts with the first job and is a daemon."""

    _shared: "WarmWorker | None" = None
    _shared_lock = threading.Lock()
    NICE = 10

    def __init__(self):
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    @classmethod
    def shared(cls) -> "WarmWorker":
        with cls._shared_lock:
            if cls._shared is None:
                cls._shared = cls()
            return cls._shared

    def submit(self, job: Callable[[], None]) -> None:
        """Run ``job()`` in the worker thread (it reports its own result and errors)."""
        with self._lock:
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, daemon=True, name="bkabem-model-warm")
                self._thread.start()
        self._jobs.put(job)

    def _run(self) -> None:
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), self.NICE)   # this thread only (Linux)
        except (AttributeError, OSError):
            pass
        while True:
            job = self._jobs.get()
            try:
                job()
            except Exception:  # noqa: BLE001 - a job reports its errors itself; the worker goes on
                pass


class BackgroundModels:
    """Models prepared ahead in a helper process (:class:`bkabem_core.scenario.models.ModelHelper`, shared by
    default), never waited for. ``estimate_s`` is a running estimate of one preparation [s] (the warm-up included).

    Parameters
    ----------
    helper : ModelHelper or None
    warm : callable or None
        ``warm(model) -> WarmModel`` (:meth:`Synthesizer.warm <bkabem_core.synth.synthesizer.Synthesizer.warm>` of the
        stream's synthesiser). Given, a model that is back is unpickled and warmed in ``worker`` and :meth:`get`
        returns the warm model once it is; None: :meth:`get` unpickles the model in the caller's thread and
        returns it bare.
    worker : WarmWorker or None
        Where the warm-ups run (default the process's shared one).
    """

    def __init__(self, helper: ModelHelper | None = None, warm: Callable | None = None,
                 worker: WarmWorker | None = None):
        self.helper = helper if helper is not None else ModelHelper.shared()
        self.estimate_s = 3.0
        self._mine: set[str] = set()
        self.warm = warm
        self._worker = worker
        self._lock = threading.Lock()
        self._warming: set[str] = set()
        self._warmed: dict = {}                  # case hash -> WarmModel
        self._warm_errors: dict[str, str] = {}
        #: case hash -> seconds of its warm-up (unpickling included), in the worker
        self.warm_times_s: dict[str, float] = {}

    @property
    def idle(self) -> bool:
        return not any(self.helper.pending(h) for h in self._mine)

    def get(self, state: ScenarioState):
        """The model if it is back (bare) or warm (with ``warm``), else None; never waits (the driver's
        look-ahead asks for models and :meth:`prepare` warms them ahead; a model that is back but not warm, or
        warmed for settings the stream no longer has, starts its warm-up here)."""
        key = state.case.case_hash
        if self.warm is None:
            model = self.helper.take(key)
            if model is not None:
                self._estimate(key, 0.0)
            return model
        with self._lock:
            model = self._warmed.get(key)
            if model is not None and not model.fresh:
                del self._warmed[key]
                model = None
        if model is None:
            self._start_warm(key)
            return None
        self._estimate(key, self.warm_times_s.get(key, 0.0))
        return model

    def prepare(self, state: ScenarioState) -> None:
        """Warm the model of a coming state ahead if it is back (again if the held one went stale or its speed
        cells no longer cover the stream's speed: :meth:`WarmModel.near`), so that it is warm when it is due."""
        if self.warm is None:
            return
        key = state.case.case_hash
        with self._lock:
            held = self._warmed.get(key)
            if held is not None and held.fresh and held.near():
                return
        self._start_warm(key)

    def _start_warm(self, key: str) -> None:
        with self._lock:
            if key in self._warming or key in self._warm_errors or not self.helper.ready(key):
                return
            self._warming.add(key)
        (self._worker or WarmWorker.shared()).submit(lambda: self._warm_job(key))

    def _estimate(self, key: str, extra_s: float) -> None:
        if key in self.helper.times_s:
            self.estimate_s = 0.5 * self.estimate_s + 0.5 * (self.helper.times_s[key] + extra_s)

    def _warm_job(self, key: str) -> None:
        """In the worker: unpickle (:meth:`ModelHelper.take`) and warm the model of ``key``."""
        t0 = time.perf_counter()
        warm, err = None, None
        try:
            model = self.helper.take(key)
            if model is not None:
                warm = self.warm(model)
        except Exception as exc:  # noqa: BLE001 - the state is reported as failed; the stream goes on
            err = f"{type(exc).__name__}: {exc}"
        with self._lock:
            if key not in self._warming:                      # released meanwhile
                return
            self._warming.discard(key)
            if warm is not None:
                self._warmed[key] = warm
                self.warm_times_s[key] = time.perf_counter() - t0
            elif err is not None:
                self._warm_errors[key] = err

    def prefetch(self, state: ScenarioState) -> None:
        self._mine.add(state.case.case_hash)
        self.helper.request(state.case)

    def has(self, state: ScenarioState) -> bool:
        return self.helper.ready(state.case.case_hash)

    def failed(self, state: ScenarioState) -> str | None:
        key = state.case.case_hash
        err = self.helper.failed(key)
        if err is None:
            with self._lock:
                err = self._warm_errors.get(key)
        return err

    def release(self, state: ScenarioState) -> None:
        key = state.case.case_hash
        self.helper.drop(key)
        self._mine.discard(key)
        with self._lock:
            self._warming.discard(key)
            self._warmed.pop(key, None)
            self._warm_errors.pop(key, None)


# --------------------------------------------------------------------------- the driver
class ScenarioDriver:
    """The state in effect at every chunk border of a stream, and its model (module docstring).

    Parameters
    ----------
    scenario : Scenario
    clock : ScenarioClock
    models : InlineModels or BackgroundModels
    chunk_samples : int
        Samples per chunk (for the look-ahead).
    start_applied : bool
        True: the caller's synthesiser starts with the model of the state at the clock's start (``applied``).
        False: the stream runs another model until this driver's first state is ready (a switch in a running
        stream): ``applied`` is None until then, and :meth:`before_chunk` returns the first model when it is.

    Attributes
    ----------
    applied : ScenarioState or None
        The state whose model is in the signal.
    events : list of str
        What happened (a state applied, a state late or skipped), for the caller to log; the caller empties it.
    """

    def __init__(self, scenario: Scenario, clock: ScenarioClock, models, chunk_samples: int,
                 start_applied: bool = True):
        self.scenario = scenario
        self.clock = clock
        self.models = models
        self.chunk_samples = int(chunk_samples)
        self.first_state: ScenarioState = scenario.state_at(clock.time_s(clock._anchor_index))
        self.applied: ScenarioState | None = self.first_state if start_applied else None
        self.events: list[str] = []
        self.late: set[int] = set()          # states that fell due before their model was ready
        self._requested: set[int] = set()    # states ahead whose models were asked for (warmed when back)
        self._failed: set[int] = set()
        #: state index -> the first sample it was in effect from
        self.applied_at: dict[int, int] = {self.first_state.index: clock._anchor_index} if start_applied else {}
        if start_applied and len(scenario.states) > 1:
            # the provider makes the first state's model too (the caller has it already): the later states are
            # then made like it (their FE, basis and line modes reused: ~10x faster for a grown defect)
            models.prefetch(self.first_state)

    def before_chunk(self, index: int):
        """Called before the chunk that starts at stream sample ``index``: the model to switch to there (the state
        due then, or the newest state before it that is ready), or None to keep the current one. What the provider
        gives: a BkaBem, or a :class:`~bkabem_core.synth.switch.WarmModel` (``BackgroundModels`` with ``warm``);
        either goes to :meth:`Synthesizer.set_model`."""
        states = self.scenario.states
        t = self.clock.time_s(index)
        due = self.scenario.state_index_at(t)
        cur = -1 if self.applied is None else self.applied.index
        switched = None
        if due != cur:
            order = [due] + (list(range(due - 1, cur, -1)) if due > cur else [])
            for j in order:
                if j in self._failed:
                    continue
                model = self.models.get(states[j])
                if model is not None:
                    switched = (states[j], model)
                    break
                err = self.models.failed(states[j])
                if err is not None:
                    self._failed.add(j)
                    self.events.append(f"scenario state {j} ({states[j].label}) could not be prepared: {err}; "
                                       f"it is skipped")
            if switched is not None:
                state, model = switched
                old = self.applied
                self.applied = state
                self.applied_at[state.index] = int(index)
                late = t - state.start_s
                self.events.append(
                    f"scenario state {state.index} ({state.label}) in effect from scenario time {t:.6g} s "
                    f"({t / 3600:.4g} h)" + (f", {late:.3g} s after its start (its model came late)"
                                             if state.index != due or late > self._chunk_scenario_s() else ""))
                if old is not None and old.index != state.index:
                    self.models.release(old)
                lo = -1 if old is None else old.index
                for k in range(min(lo, state.index) + 1, max(lo, state.index)):
                    self.models.release(states[k])               # skipped states: their models are not needed
            elif due not in self.late and due not in self._failed:
                self.late.add(due)
                now = "the model it has" if self.applied is None else \
                    f"state {self.applied.index} ({self.applied.label})"
                self.events.append(f"scenario state {due} ({states[due].label}) is due at scenario time "
                                   f"{states[due].start_s:.6g} s but its model is not ready yet: the stream goes on "
                                   f"with {now}; the ground truth says so")
        self._prefetch(index)
        self._prepare_ahead()
        return None if switched is None else switched[1]

    def _prepare_ahead(self) -> None:
        """Let the provider warm the models of the coming states it was asked for and has back, so that a state
        switches at once when it falls due (the look-ahead holds at most ``MAX_READY_AHEAD`` of them)."""
        cur = -1 if self.applied is None else self.applied.index
        if any(j <= cur for j in self._requested):
            self._requested = {j for j in self._requested if j > cur}
        states = self.scenario.states
        for j in sorted(self._requested):
            if j not in self._failed and self.models.has(states[j]):
                self.models.prepare(states[j])

    def _chunk_scenario_s(self) -> float:
        return self.clock.time_scale * self.chunk_samples / self.clock.sample_rate_hz

    def _prefetch(self, index: int) -> None:
        """Ask for the next model while the provider is idle: the state due when that model could be ready."""
        m = self.models
        if not m.idle:
            return
        states = self.scenario.states
        cur = -1 if self.applied is None else self.applied.index
        lead = 1.5 * m.estimate_s * self.clock.sample_rate_hz + 2 * self.chunk_samples
        k = max(self.scenario.state_index_at(self.clock.time_s(index + lead)), cur + 1)
        ahead = sum(1 for j in range(cur + 1, len(states)) if m.has(states[j]))
        if ahead >= MAX_READY_AHEAD:
            return
        while k < len(states) and (m.has(states[k]) or k in self._failed or m.failed(states[k]) is not None):
            k += 1
        if k < len(states):
            m.prefetch(states[k])
            self._requested.add(k)

    def end_speed_hz(self, index: int, n: int) -> float | None:
        """The scenario's shaft speed [Hz] at the end of the chunk of ``n`` samples from ``index`` (None: the
        scenario has no speed profile)."""
        if not self.scenario.has_speed:
            return None
        return float(self.scenario.speed_hz(self.clock.time_s(index + n)))

    def ground_truth(self, index: int, speed_hz: float | None = None) -> dict:
        """Ground truth of the chunk starting at sample ``index`` (the state in effect, scenario time there)."""
        if self.applied is None:
            raise RuntimeError("no state of this scenario is in effect yet")
        return self.scenario.ground_truth(self.applied, self.clock.time_s(index), speed_hz, self.clock.time_scale)


# --------------------------------------------------------------------------- offline
class ScenarioRun:
    """A scenario rendered offline, chunk by chunk, with the ground truth of every chunk (exact state timing).

    Parameters
    ----------
    scenario : Scenario
    time_scale : float
        Scenario seconds per second of signal.
    start_s : float
        Scenario time at the first sample [s].
    sample_rate_hz, chunk_s : float
        As for :class:`~bkabem_core.synth.synthesizer.Synthesizer`.
    speed : SpeedProfile or None
        Shaft speed over *signal* time for a scenario without ``[speed]`` (ignored when it has one).
    pool : ModelPool or None
        Models to reuse (e.g. of an earlier run of the same machine).
    **synth_options
        Further :class:`~bkabem_core.synth.synthesizer.Synthesizer` keywords (slip, seed, noise_density, band_limit, ...).

    Examples
    --------
    >>> run = ScenarioRun(Scenario.load("de_outer_run_to_failure"), time_scale=3600, sample_rate_hz=25600)
    >>> for chunk, truth in run.chunks(run.seconds_to_end()):
    ...     x = chunk.samples; truth["state_label"], truth["defects"]
    """

    def __init__(self, scenario: Scenario, time_scale: float = 1.0, start_s: float = 0.0,
                 sample_rate_hz: float | None = None, chunk_s: float = 0.1, speed=None,
                 pool: ModelPool | None = None, **synth_options):
        from bkabem_core.synth.measurement import sample_rate_of
        from bkabem_core.synth.synthesizer import SynthError, Synthesizer

        if sample_rate_hz is None:                  # the acquisition of the scenario's machine (25.6 kHz without one)
            sample_rate_hz = sample_rate_of(scenario.case)
        self.scenario = scenario
        self.clock = ScenarioClock(sample_rate_hz, time_scale, start_s)
        if not scenario.has_speed and speed is None:
            raise SynthError("speed", f"scenario {scenario.name!r} has no [speed] profile: give a speed profile")
        self.speed = None if scenario.has_speed else speed
        self.models = InlineModels(pool)
        n = max(1, int(round(chunk_s * sample_rate_hz)))
        self.driver = ScenarioDriver(scenario, self.clock, self.models, n)
        model = self.models.get(self.driver.applied)
        synth_options.setdefault("initial_speed_hz", self._speed_at(0))
        self.synth = Synthesizer(model, sample_rate_hz=sample_rate_hz, chunk_s=chunk_s, **synth_options)

    def _speed_at(self, index: int) -> float:
        if self.speed is None:
            return float(self.scenario.speed_hz(self.clock.time_s(index)))
        return float(self.speed.speed_hz(index / self.clock.sample_rate_hz))

    def seconds_to_end(self) -> float:
        """Signal time [s] from the first sample to the end of the scenario."""
        return max(self.scenario.duration_s - self.clock.time_s(0), 0.0) / self.clock.time_scale

    def chunks(self, seconds: float) -> Iterator[tuple]:
        """``(Chunk, ground truth dict)`` for ``seconds`` of signal."""
        synth = self.synth
        fs = synth.sample_rate_hz
        n_total = int(round(float(seconds) * fs))
        n = synth.chunk_samples
        index = 0
        while index < n_total:
            m = min(n, n_total - index)
            model = self.driver.before_chunk(index)
            if model is not None:
                # warmed at the next knot's speed (known here: no cells around it) before the switch: the chunk
                # after it costs what any chunk does
                synth.set_model(synth.warm(model, self._speed_at(index + m), margin_hz=0.0))
            chunk = synth.next_chunk(self._speed_at(index + m), n_samples=m)
            yield chunk, self.driver.ground_truth(index, chunk.shaft_speed_hz)
            index += m
