"""Speed profiles and the synthesiser's input checks: shaft speed as a piecewise-linear function of time.

The synthesiser integrates the speed exactly (it is linear between breakpoints), so every base phase of the lines
(:mod:`bkabem_core.excitation.lines`) is a quadratic of time per segment. Profiles come as ``constant:F``, ``ramp:F0:F1:T``,
``steps:F1,F2,...:T`` or a CSV file (:func:`parse_profile`). Bad input raises :class:`SynthError` naming the
argument and the reason. Units: s, Hz.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

TWO_PI = 2.0 * math.pi


class SynthError(ValueError):
    """Bad synthesis input. ``argument`` names the offending argument (or profile field), ``reason`` says why."""

    def __init__(self, argument: str, reason: str):
        self.argument = argument
        self.reason = reason
        super().__init__(f"{argument}: {reason}")


def _finite(name: str, value, minimum: float | None = None, strict: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SynthError(name, f"must be a number (got {value!r})") from None
    if not math.isfinite(v):
        raise SynthError(name, f"must be finite (got {value!r})")
    if minimum is not None and (v <= minimum if strict else v < minimum):
        raise SynthError(name, f"must be {'>' if strict else '>='} {minimum:g} (got {v:g})")
    return v


# =========================================================================== speed profiles
_SPEED_UNIT_TO_HZ = {"hz": 1.0, "rpm": 1.0 / 60.0, "rad_s": 1.0 / TWO_PI}


@dataclass(frozen=True)
class SpeedProfile:
    """Shaft speed as a piecewise-linear function of time, held constant after the last point.

    Attributes
    ----------
    times_s : ndarray (P,)
        Breakpoint times [s], strictly increasing, first one 0.
    speeds_hz : ndarray (P,)
        Shaft speed at the breakpoints [Hz] (revolutions per second), finite and >= 0.
    spec : str
        How the profile was given (for metadata).
    """

    times_s: np.ndarray
    speeds_hz: np.ndarray
    spec: str = ""

    @classmethod
    def from_points(cls, times_s, speeds_hz, spec: str = "points", source: str = "profile") -> "SpeedProfile":
        t = np.asarray(times_s, dtype=float).ravel()
        f = np.asarray(speeds_hz, dtype=float).ravel()
        if t.size == 0 or t.size != f.size:
            raise SynthError(source, "needs at least one (time, speed) point and as many times as speeds")
        if not np.all(np.isfinite(t)):
            raise SynthError(source, "times must be finite")
        if not np.all(np.isfinite(f)):
            raise SynthError(source, "speeds must be finite (NaN or inf found)")
        if np.any(f < 0):
            raise SynthError(source, f"speeds must be >= 0 (got {f.min():g} Hz)")
        if np.any(t < 0):
            raise SynthError(source, "times must be >= 0")
        if np.any(np.diff(t) <= 0):
            raise SynthError(source, "times must be strictly increasing")
        if t[0] > 0:                                   # hold the first value from t = 0
            t, f = np.concatenate([[0.0], t]), np.concatenate([[f[0]], f])
        t.setflags(write=False)
        f.setflags(write=False)
        return cls(t, f, spec)

    @classmethod
    def constant(cls, speed_hz: float) -> "SpeedProfile":
        v = _finite("profile.speed_hz", speed_hz, 0.0)
        return cls.from_points([0.0], [v], f"constant:{v:g}")

    @classmethod
    def ramp(cls, from_hz: float, to_hz: float, duration_s: float) -> "SpeedProfile":
        a = _finite("profile.from_hz", from_hz, 0.0)
        b = _finite("profile.to_hz", to_hz, 0.0)
        d = _finite("profile.duration_s", duration_s, 0.0, strict=True)
        return cls.from_points([0.0, d], [a, b], f"ramp:{a:g}:{b:g}:{d:g}")

    @classmethod
    def steps(cls, speeds_hz, step_s: float) -> "SpeedProfile":
        """Each speed held for ``step_s``, jumps linear over 1 ms (a speed step is never a phase step)."""
        v = [_finite(f"profile.speed[{i}]", s, 0.0) for i, s in enumerate(speeds_hz)]
        d = _finite("profile.step_s", step_s, 0.0, strict=True)
        if not v:
            raise SynthError("profile", "steps needs at least one speed")
        ramp = min(1e-3, d / 10)
        t, f = [0.0], [v[0]]
        for i in range(1, len(v)):
            t += [i * d, i * d + ramp]
            f += [v[i - 1], v[i]]
        return cls.from_points(t, f, "steps:" + ",".join(f"{x:g}" for x in v) + f":{d:g}")

    @classmethod
    def from_csv(cls, path) -> "SpeedProfile":
        """Two columns, time and speed. A header names units: ``time_s`` and ``speed_hz`` | ``speed_rpm`` |
        ``speed_rad_s``; without a header (first row numeric) the units are s and Hz. ``#`` starts a comment."""
        from bkabem_core.model.files import not_a_file

        p = Path(path)
        why = not_a_file(p)
        if why:
            raise SynthError("profile", f"CSV {why}")
        try:
            text = p.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise SynthError("profile", f"cannot read {p}: {exc}") from None
        rows = [r for r in csv.reader(io.StringIO(text))
                if r and any(c.strip() for c in r) and not r[0].strip().startswith("#")]
        if not rows:
            raise SynthError("profile", f"{p}: no data rows")
        factor, unit = 1.0, "hz"
        try:
            float(rows[0][0])
        except ValueError:
            head = [c.strip().lower() for c in rows[0]]
            rows = rows[1:]
            if len(head) < 2 or not head[0].startswith(("time", "t")):
                raise SynthError("profile", f"{p}: header must be 'time_s,speed_<unit>' (got {','.join(head)})")
            if head[0] not in ("time_s", "time", "t", "t_s"):
                raise SynthError("profile", f"{p}: time column must be in seconds ('time_s'), got {head[0]!r}")
            unit = head[1].replace("speed_", "").replace("/", "_").replace("speed", "hz") or "hz"
            if unit not in _SPEED_UNIT_TO_HZ:
                raise SynthError("profile", f"{p}: speed unit {head[1]!r} not one of speed_hz, speed_rpm, speed_rad_s")
            factor = _SPEED_UNIT_TO_HZ[unit]
        t, f = [], []
        for i, r in enumerate(rows):
            if len(r) < 2:
                raise SynthError("profile", f"{p}: row {i + 1} needs two columns (time, speed)")
            try:
                t.append(float(r[0]))
                f.append(float(r[1]) * factor)
            except ValueError:
                raise SynthError("profile", f"{p}: row {i + 1} is not numeric: {','.join(r)}") from None
        return cls.from_points(t, f, f"csv:{p.name}({unit})", source=f"profile ({p.name})")

    # -- evaluation
    def speed_hz(self, t_s):
        """Speed [Hz] at time(s) ``t_s`` [s] (linear between points, held after the last)."""
        return np.interp(t_s, self.times_s, self.speeds_hz)

    def max_speed_hz(self, until_s: float | None = None) -> float:
        if until_s is None:
            return float(self.speeds_hz.max())
        inside = self.speeds_hz[self.times_s <= until_s]
        return float(max(inside.max(), self.speed_hz(until_s)))

    @property
    def duration_s(self) -> float:
        """Time of the last breakpoint [s] (the speed is held afterwards)."""
        return float(self.times_s[-1])

    def to_dict(self) -> dict:
        return {"spec": self.spec, "times_s": self.times_s.tolist(), "speeds_hz": self.speeds_hz.tolist()}


def parse_profile(spec) -> SpeedProfile:
    """``constant:F`` | ``ramp:F0:F1:T`` | ``steps:F1,F2,...:T`` | ``FILE.csv`` (speeds in Hz, times in s)."""
    if isinstance(spec, SpeedProfile):
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise SynthError("profile", f"must be constant:F, ramp:F0:F1:T, steps:F1,F2,...:T or a CSV file (got {spec!r})")
    s = spec.strip()
    if s.lower().endswith(".csv") or (Path(s).suffix and Path(s).is_file()):
        return SpeedProfile.from_csv(s)
    kind, _, rest = s.partition(":")
    kind = kind.lower()
    parts = rest.split(":") if rest else []
    if kind == "constant":
        if len(parts) != 1:
            raise SynthError("profile", f"constant takes one value, constant:F [Hz] (got {s!r})")
        return SpeedProfile.constant(_num("profile.speed_hz", parts[0]))
    if kind == "ramp":
        if len(parts) != 3:
            raise SynthError("profile", f"ramp takes three values, ramp:F0:F1:T [Hz, Hz, s] (got {s!r})")
        a, b, d = (_num(n, x) for n, x in zip(("profile.from_hz", "profile.to_hz", "profile.duration_s"), parts))
        return SpeedProfile.ramp(a, b, d)
    if kind == "steps":
        if len(parts) != 2:
            raise SynthError("profile", f"steps takes steps:F1,F2,...:T [Hz..., s] (got {s!r})")
        vals = [_num("profile.speed_hz", x) for x in parts[0].split(",") if x.strip()]
        return SpeedProfile.steps(vals, _num("profile.step_s", parts[1]))
    raise SynthError("profile", f"unknown profile kind {kind!r}: use constant:F, ramp:F0:F1:T, "
                                f"steps:F1,F2,...:T or FILE.csv")


def _num(name: str, text: str) -> float:
    try:
        if "_" in text:                     # float("1_0") is 10: a typo is not a number
            raise ValueError(text)
        return float(text)
    except ValueError:
        raise SynthError(name, f"not a number: {text!r}") from None
