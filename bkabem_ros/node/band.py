"""The node's sample rate against the machine's lines: refused at start, or a warning once per event while it runs.

The node's synthesiser runs with ``band_limit="taper"`` (:mod:`bkabem_core.synth.synthesizer`): a line fades out (raised cosine)
between 0.85 and 0.95 of the Nyquist frequency ``sample_rate / 2`` and is dropped above, like behind an anti-alias
filter, so nothing ever aliases. That is a property of the stream the user must hear about, never silently:

* **At start** (:func:`start_refusal`): when the speed is known then (a scenario with a ``[speed]`` profile), the
  check of ``bkabem synth --scenario`` (:meth:`Synthesizer.max_speed_for_rate_hz`: some kept line at or above
  Nyquist at the highest speed of the profile) refuses the ``sample_rate`` parameter: one line naming it, exit 2.
  With the speed from the ``speed`` topic, the start-up log says up to which shaft speed every line is carried in
  full (:func:`start_note`).
* **While it runs** (:class:`BandWatch`): when a chunk's speed or a new model (the scenario's next state, a new
  scenario, ``defect_depth``) makes the taper act on some line, one warning names ``sample_rate``, the speed, how
  many lines fade and how many are dropped; the stream goes on band-limited. The next warning comes with the next
  event: a model change, or the speed leaving the taper (3 % hysteresis) and entering it again.

No rclpy here. Units: Hz.
"""

from __future__ import annotations

import numpy as np

#: A band event ends when the speed is this factor below the speed at which the taper starts to act (a speed that
#: hovers at the threshold gives one warning, not one per chunk).
HYSTERESIS = 1.03


def profile_max_speed_hz(scenario, start_s: float) -> float:
    """Highest shaft speed [Hz] of a scenario's ``[speed]`` profile (linear between points, held after the last)
    from scenario time ``start_s`` [s] to its end."""
    times, values = (np.asarray(v, dtype=float) for v in scenario.speed_points)
    end = max(float(scenario.duration_s), float(start_s))
    inside = values[(times > start_s) & (times < end)]
    ends = np.atleast_1d(scenario.speed_hz(np.array([start_s, end])))
    return float(max(np.max(ends), np.max(inside) if inside.size else 0.0))


def start_refusal(synth, scenario, start_s: float, what: str) -> str | None:
    """The one-line reason (``parameter sample_rate: ...``) why the node must not start with this sample rate, or None.

    Only for a scenario with a ``[speed]`` profile (the speeds are known at start): its highest speed from
    ``start_s`` on puts a line of the model at start (``what``) at or above Nyquist: the check that makes
    ``bkabem synth --scenario`` refuse ``--rate``.
    """
    if scenario is None or not scenario.has_speed:
        return None
    f = profile_max_speed_hz(scenario, start_s)
    if f <= synth.min_speed_hz or f < synth.max_speed_for_rate_hz():
        return None
    fs = synth.sample_rate_hz
    top = float(np.max(synth.frequency_hz(f)))
    return (f"parameter sample_rate: {fs:g} Hz is below twice the highest line of {what}: {top:.1f} Hz at "
            f"{f:g} Hz shaft speed, the top of the scenario's [speed] profile (needs sample_rate > {2 * top:.1f} Hz; "
            f"at {fs:g} Hz every line stays below Nyquist only up to {synth.max_speed_for_rate_hz():.4g} Hz)")


def taper_start_speed_hz(synth, up_to_hz: float) -> float | None:
    """Lowest shaft speed [Hz] up to ``up_to_hz`` at which the taper acts on some line (None: it never does)."""
    lo, hi = 2.0 * synth.min_speed_hz, float(up_to_hz)
    if hi <= lo or synth.band_taper(hi) is None:
        return None
    if synth.band_taper(lo) is not None:
        return lo
    for _ in range(50):                    # the lines' frequencies grow with speed: bisection on the taper itself
        mid = 0.5 * (lo + hi)
        if synth.band_taper(mid) is None:
            lo = mid
        else:
            hi = mid
    return hi


def start_note(synth, max_speed_hz: float, what: str) -> str | None:
    """Start-up log line when the ``speed`` topic may drive the lines into the taper (None when it cannot)."""
    f = taper_start_speed_hz(synth, max_speed_hz)
    if f is None:
        return None
    return (f"sample_rate {synth.sample_rate_hz:g} Hz carries every line of {what} in full up to {f:.4g} Hz shaft "
            f"speed; faster (max_speed allows {max_speed_hz:.4g} Hz), the highest lines fade out from 0.85 of "
            f"Nyquist and are dropped from 0.95 (a warning says when)")


class BandWatch:
    """Warns once per event when the taper acts on a line (module docstring).

    Parameters
    ----------
    warn : callable(str)
        The node logger's ``warning``.
    """

    def __init__(self, warn):
        self.warn = warn
        self._model = None
        self._active = False
        self.events = 0

    def check(self, synth, model, speed_hz: float, what) -> None:
        """After a chunk at (highest) shaft speed ``speed_hz`` [Hz] with ``model`` in the signal; ``what()`` names
        that model for the warning."""
        if model is not self._model:
            self._model = model
            self._active = False
        if self._active:
            if synth.band_taper(speed_hz * HYSTERESIS) is None:
                self._active = False
            return
        w = synth.band_taper(speed_hz)
        if w is None:
            return
        self._active = True
        self.events += 1
        fs = synth.sample_rate_hz
        freq = synth.frequency_hz(speed_hz)
        dropped = int(np.count_nonzero(w <= 0.0))
        faded = int(np.count_nonzero((w > 0.0) & (w < 1.0)))
        top = float(np.max(freq))
        self.warn(f"parameter sample_rate: {fs:g} Hz is too low for {faded + dropped} of the {w.size} lines of {what()} "
                  f"at {speed_hz:.4g} Hz shaft speed: {faded} fade out (0.85-0.95 of Nyquist {fs / 2:g} Hz) and "
                  f"{dropped} are dropped (the highest at {top:.1f} Hz); the stream goes on band-limited (restart "
                  f"with sample_rate > {2 * top / 0.85:.0f} Hz to carry them all)")
