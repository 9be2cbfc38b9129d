"""The node's sample rate against the machine's lines: refused at start, or a warning once per event while it runs.

The node's synthesiser runs with ``band_limit="taper"`` (:mod:`bkabem_core.synth.synthesizer`): a line fades out (raised cosine)
between 0.85 and 0.95 of the Nyquist frequency ``sample_rate / 2`` and is dropped above, like behind an anti-alias
filter, so nothing ever aliases. Two kinds of machines:

* A case that **carries its lines to the band** (``excitation.max_order = 0``, the fault library's: every line above
  its amplitude threshold) has lines beyond any sample rate at speed; the taper is then the acquisition's band
  itself, not a loss. The start-up log says up to which frequency the lines are carried (:func:`start_note`); nothing
  is refused, and a speed or model change is an info line, once per event.
* A case that **caps its lines** (``excitation.max_order = K``: BPFO and K - 1 harmonics, the paper's machine) asked
  for every one of them, so losing one to the sample rate is news the user must hear, never silently:

* **At start** (:func:`start_refusal`): when the speed is known then (a scenario with a ``[speed]`` profile), the
  check of ``bkabem synth --scenario`` (:meth:`Synthesizer.max_speed_for_rate_hz`: some kept line at or above
  Nyquist at the highest speed of the profile) refuses the ``sample_rate`` parameter: one line naming it, exit 2.
  With the speed from the ``speed`` topic, the start-up log says up to which shaft speed every line is carried in
  full (:func:`start_note`).
* **While it runs** (:class:`BandWatch`): when a chunk's speed or a new model (the scenario's next state, a new
  scenario, ``defect_depth``) makes the taper act on some line, one warning names ``sample_rate``, the speed, how
  many lines fade and how many are dropped; the stream goes on band-limited. The next warning comes with the next
  event: a model change, or the speed leaving the taper (3 % hysteresis) and entering it again.

The node's health on ``/diagnostics`` reports the same (:func:`band_status`). No rclpy here. Units: Hz.
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


def carries_to_band(model) -> bool:
    """Whether ``model``'s case keeps every line above its threshold (``excitation.max_order = 0``): its lines are
    meant to reach the acquisition's band, and the taper near Nyquist is that band (module docstring)."""
    return int(model.case.raw["excitation"].get("max_order", 0)) == 0


def start_refusal(synth, scenario, start_s: float, what: str) -> str | None:
    """The one-line reason (``parameter sample_rate: ...``) why the node must not start with this sample rate, or None.

    Only for a scenario with a ``[speed]`` profile (the speeds are known at start): its highest speed from
    ``start_s`` on puts a line of the model at start (``what``) at or above Nyquist: the check that makes
    ``bkabem synth --scenario`` refuse ``--rate``.
    """
    if scenario is None or not scenario.has_speed or carries_to_band(synth.model):
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
    if carries_to_band(synth.model):
        fs = synth.sample_rate_hz
        return (f"{what} carries its lines up to the acquisition's band: in full up to {0.85 * fs / 2:.0f} Hz "
                f"(0.85 x Nyquist of sample_rate {fs:g} Hz), fading out to {0.95 * fs / 2:.0f} Hz, none beyond")
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
    info : callable(str), optional
        The node logger's ``info``: the event of a machine that carries its lines to the band (default ``warn``).
    """

    def __init__(self, warn, info=None):
        self.warn = warn
        self.info = info or warn
        self._model = None
        self._active = False
        self.events = 0
        self.last: dict = {}

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
        self.last = {"speed_hz": float(speed_hz), "faded": faded, "dropped": dropped, "lines": int(w.size),
                     "to_band": carries_to_band(model)}
        if self.last["to_band"]:
            self.info(f"{what()} at {speed_hz:.4g} Hz shaft speed: {faded} of its {w.size} lines fade out at the band "
                      f"edge (0.85-0.95 of Nyquist {fs / 2:g} Hz) and {dropped} are beyond it (the highest at "
                      f"{top:.1f} Hz): the acquisition's band, as a sensor behind an anti-alias filter sees it")
            return
        self.warn(f"parameter sample_rate: {fs:g} Hz is too low for {faded + dropped} of the {w.size} lines of {what()} "
                  f"at {speed_hz:.4g} Hz shaft speed: {faded} fade out (0.85-0.95 of Nyquist {fs / 2:g} Hz) and "
                  f"{dropped} are dropped (the highest at {top:.1f} Hz); the stream goes on band-limited (restart "
                  f"with sample_rate > {2 * top / 0.85:.0f} Hz to carry them all)")


def band_status(synth, model, speed_hz: float) -> tuple[str, str, dict]:
    """``(level, message, values)`` of the band limit at a shaft speed [Hz] for the node's ``/diagnostics``: ``"OK"``
    when every line is carried in full or the machine carries its lines to the band (the taper is the acquisition),
    ``"WARN"`` when the sample rate drops lines a capped case asked for."""
    fs = synth.sample_rate_hz
    freq = synth.frequency_hz(speed_hz)
    w = synth.band_taper(speed_hz) if speed_hz > 0 else None
    faded = 0 if w is None else int(np.count_nonzero((w > 0.0) & (w < 1.0)))
    dropped = 0 if w is None else int(np.count_nonzero(w <= 0.0))
    values = {"sample_rate_hz": fs, "nyquist_hz": fs / 2, "carried_in_full_up_to_hz": 0.85 * fs / 2,
              "lines": int(freq.size), "lines_fading": faded, "lines_beyond_band": dropped,
              "highest_line_hz": float(np.max(freq)) if freq.size else 0.0,
              "lines_to_band": carries_to_band(model)}
    if w is None:
        return "OK", f"every line in full below {0.85 * fs / 2:.0f} Hz", values
    if carries_to_band(model):
        return "OK", f"lines carried to the band: {faded} fading, {dropped} beyond {0.95 * fs / 2:.0f} Hz", values
    return "WARN", (f"sample_rate {fs:g} Hz too low for {faded + dropped} of {freq.size} lines at "
                    f"{speed_hz:.4g} Hz (restart with sample_rate > {2 * values['highest_line_hz'] / 0.85:.0f} Hz)"), \
        values
