"""The condition panels of the Rerun view: each bearing's acceleration collected for a window, then its ISO
velocity and zone limits, impulsiveness, envelope spectrum with fault-frequency markers, and health panel.

The window (``condition_window_s`` of :class:`bkabem_ros.viewer.rerun_io.RerunLogger`) follows the stream's sample
indices; a gap, another sample rate or other channels start it again. Its results are logged at the time of its
last sample (:mod:`bkabem_core.analysis.condition` computes them, :mod:`bkabem_core.analysis.health` writes the
panel). Entities: ``/<loc>/iso_velocity``, ``/<loc>/iso_velocity/zones``, ``/<loc>/trend/impulsiveness``,
``/<loc>/envelope/<channel>``, ``/<loc>/envelope/markers/<L>``, ``/<loc>/health``.
"""

from __future__ import annotations

import math

import numpy as np

from bkabem_core.analysis import condition, health

__all__ = ["ENVELOPE_BARS", "ZONE_COLORS", "ConditionPanels"]

#: Colours of the ISO zone limits A/B, B/C, C/D.
ZONE_COLORS = [(120, 200, 80), (240, 200, 40), (230, 60, 50)]
#: Bars per channel of an envelope spectrum (peak hold over groups of bins beyond that): a bar
#: narrower than a pixel is not drawn.
ENVELOPE_BARS = 200


def _peak_hold(f: np.ndarray, amp: np.ndarray, bars: int) -> tuple[np.ndarray, np.ndarray, int]:
    """At most ``bars`` bars: groups of adjacent bins, each bar the largest amplitude of its group
    (so no line loses height) at the group's centre. Returns (freq, amp, bins per group)."""
    g = max(1, math.ceil(f.size / bars))
    if g == 1:
        return f, amp, 1
    m = f.size // g * g
    fg = f[:m].reshape(-1, g).mean(axis=1)
    ag = amp[:, :m].reshape(amp.shape[0], -1, g).max(axis=2)
    return fg, ag, g


class _Window:
    """Acceleration of one bearing collected for the condition window."""

    def __init__(self):
        self.blocks: list[np.ndarray] = []
        self.n = 0
        self.fs = 0.0
        self.next_index: int | None = None
        self.names: list[str] = []
        self.speeds: list[float] = []

    def reset(self) -> None:
        self.blocks, self.n, self.speeds = [], 0, []


class ConditionPanels:
    """The condition window of each bearing and the panels logged at its end, for one :class:`RerunLogger`.

    Parameters
    ----------
    logger : RerunLogger
        Where the panels go (its rows, bar charts and markers), and what the run's fault-frequency messages said
        (lines, defects, ground truth) with its settings (window length, envelope band, ISO zone set).
    """

    def __init__(self, logger):
        self.logger = logger
        self._windows: dict[str, _Window] = {}

    def collect(self, msg, a: np.ndarray, names: list[str], stamp: int) -> None:
        """Add a block of acceleration to its bearing's window; at a full window, log the
        condition results at the time of the window's last sample."""
        w = self._windows.setdefault(msg.location, _Window())
        fs = float(msg.sample_rate)
        first = int(msg.first_sample_index)
        if w.fs != fs or w.next_index != first or w.names != names:
            w.reset()                                        # new stream, gap or other layout
            w.fs, w.names = fs, names
        w.next_index = first + a.shape[1]
        w.blocks.append(a)                  # float32 view of the message; the window is float64
        w.n += a.shape[1]
        w.speeds.append(float(msg.shaft_speed))
        need = max(int(round(self.logger.condition_window_s * fs)), 16)
        if w.n < need:
            return
        x = np.concatenate(w.blocks, axis=1)                # float32, SI
        rest = x[:, need:]
        x = x[:, :need]
        speed = float(np.mean(w.speeds))
        w.blocks = [rest] if rest.shape[1] else []
        w.n = rest.shape[1]
        w.speeds = [w.speeds[-1]] if rest.shape[1] else []
        end = stamp + int(round((a.shape[1] - rest.shape[1] - 1) * 1e9 / fs))
        self._log(msg.location, x, fs, names, end, speed)

    def _log(self, loc: str, x: np.ndarray, fs: float, names: list[str], stamp: int, speed_rad_s: float) -> None:
        """The panels of bearing ``loc`` from one full window ``x`` (channels, samples) [m/s^2] at ``stamp`` [ns]."""
        lg = self.logger
        rr = lg.rr
        L = loc.upper()
        colors = [lg.color(ch, c) for c, ch in enumerate(names)]
        ws = condition.window_spectrum(x, fs)
        iso = condition.iso_velocity_rms(x, fs, ws=ws)
        kurt = condition.kurtosis(x)
        crest = condition.crest_factor(x)
        band = lg.envelope_band_hz or condition.default_envelope_band(fs)
        lines = lg.lines_at(speed_rad_s, loc)
        f_top = self._envelope_range(lines, band, loc)
        f, env = condition.envelope_spectrum(x, fs, band, f_top, ws=ws)
        limits = condition.ISO_ZONE_SETS[lg.iso_zones]
        lg.at(stamp)
        p = f"/{loc}/iso_velocity"
        lg.series(p, [f"{L} {ch} [mm/s]" for ch in names], colors, widths=[2.0] * len(names))
        lg.scalars(p, iso, stamp, batch=False)
        lg.series(f"{p}/zones", [f"zone {z} limit {v:g} mm/s" for z, v in zip(("A/B", "B/C", "C/D"), limits)],
                  ZONE_COLORS, widths=[1.0] * 3)
        lg.scalars(f"{p}/zones", limits, stamp, batch=False)
        p = f"/{loc}/trend/impulsiveness"
        lg.series(p, [f"kurtosis {ch}" for ch in names] + [f"crest factor {ch}" for ch in names],
                  colors + [lg.color(ch, c, light=True) for c, ch in enumerate(names)])
        lg.scalars(p, np.concatenate([kurt, crest]), stamp, batch=False)
        fg, eg, group = _peak_hold(f, env, ENVELOPE_BARS)
        dfg = fg[1] - fg[0] if fg.size > 1 else 1.0
        nch = max(len(names), 1)
        for c, ch in enumerate(names):
            lg.bars(f"/{loc}/envelope/{ch}", eg[c], fg + (c - (nch - 1) / 2) * dfg / nch,
                    np.full(fg.size, 0.9 * dfg / nch, dtype=np.float32), colors[c])
        top = float(env.max()) if env.size else 0.0
        lg.log_markers(f"/{loc}/envelope/markers", lines, f_top, top, loc)
        h = lg.health.setdefault(loc, {})
        h.update(iso=iso, zone=[condition.iso_zone(v, limits) for v in iso], kurt=kurt, crest=crest,
                 rms=np.sqrt(np.mean(x * x, axis=1, dtype=np.float64)), peak=np.max(np.abs(x), axis=1).astype(np.float64),
                 names=names,
                 band=band, window_s=x.shape[1] / fs, env_df=(f[1] - f[0]) if f.size > 1 else 0.0, env_group=group,
                 finding=health.envelope_finding(f, env, lines, names, loc, lg.defects,
                                                 {b: lg.lines_at(speed_rad_s, b) for b in lg.bearing_lines}),
                 speed_hz=speed_rad_s / (2 * math.pi), lines=lines)
        text = health.health_text(loc, lg.health.get(loc, {}), lg.defects,
                                  lg.lines_of(loc), lg.iso_zones, lg.condition_window_s,
                                  lg.truth, marked=lg.defects_with_lines_of(loc))
        lg.rec.log(f"/{loc}/health", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))

    def _envelope_range(self, lines: dict[str, float], band: tuple[float, float], loc: str) -> float:
        """Envelope spectrum shown up to 3.5x the highest line a defect excites and past every
        fundamental, at most half the band width [Hz]; 500 Hz while no lines are known."""
        cap = (band[1] - band[0]) / 2
        if not lines or not max(lines.values()) > 0:
            return min(500.0, cap)
        excited = [lines[d.line] for d in self.logger.defects_with_lines_of(loc) if d.line in lines] or \
            [lines.get("BPFO", 0.0)]
        want = max(3.5 * max(excited), 1.15 * max(lines.values()))
        return float(min(cap, 50.0 * math.ceil(want / 50.0)))
