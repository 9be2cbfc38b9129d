"""A ball defect as it is: the pit strikes the races only while the ball's wandering spin axis keeps it in the
contact track, and the ball's spin slips against the cage.

The quasi-static model (:mod:`bkabem_core.bearing.defects.ball`) places the pit on the great circle the ball rolls on,
so it strikes both races once per spin turn: a clean 2 x BSF comb with cage-rate sidebands. A real ball has no
fixed attitude: gyroscopic moments, the cage pocket's contacts and the entry into the load zone turn its spin axis,
so the band of the ball's surface that runs through the contacts drifts over it, and a pit is carried through the
contacts only while the band covers it (Harris & Kotzalas, *Rolling Bearing Analysis*, 2007, ball kinematics; Niu,
Cao, He & Li, Tribology International 109 (2017) 26-39; failure analysis reads a ball that keeps one axis, a
"banded" ball, as abnormal). Measured consequence: no CWRU ball record shows the classic symptoms (Smith & Randall,
MSSP 64-65 (2015) 100-131; Randall & Antoni, MSSP 25 (2011) 485-520), 2 x BSF is a smeared hump a few Hz wide and
6-17 dB over the envelope floor, and the cage lines FTF and 1 - FTF are sometimes the strongest.

The model, two seeded random processes of the run, both functions of the ball passes since t = 0 (so of absolute
time: no chunking changes them):

**Track wander** (:class:`AxisWalk`, :class:`BallTrack`). The spin axis ``n`` (a unit vector in the ball's frame,
the pit at ``e_z``) does a random walk on the sphere, one step per revolution of the cage (the defective ball passes
through the load zone once per cage turn: ``z`` ball passes). A step rotates ``n`` by the angle ``|v|`` towards a
Gaussian tangent vector ``v`` (per component ``sigma``; the exponential map of isotropic rotational diffusion), so
``E[n_k . n_0] = rho^k``, ``rho = E[cos |v|] = 1 - sqrt(2) sigma D(sigma / sqrt(2))`` (D: Dawson's integral), and
``sigma`` is chosen so that ``rho = exp(-1 / tau)``: ``tau`` steps is the axis's correlation time (the key
``wander_revolutions``, in revolutions of the ball about its axis, ``BSF / FTF`` of them per cage turn). The walk
starts uniform on the sphere, and stays so: the pit is in the track a fraction ``sin((a + r) / R)`` of the time
on average (its latitude ``asin(n . e_z)`` within ``(a + r) / R``), but in long visits and long absences.

The pit's centre lies at the arc distance ``s = R asin(|n_z|)`` from the rolling great circle (``R`` the ball's
radius). Its strike strength is the share of the pit's area inside the contact track ``|y| <= a`` (``a``: the
Hertz contact ellipse's semi-axis across the track, Brewe & Hamrock, at the most loaded ball of the bearing's
static state, the mean of its inner and outer contact), relative to a pit on the track's centre line: 1 on it, 0
off it (:meth:`BallTrack.gain`). The pit is the defect's round pit of diameter ``length_m``.

The gain is taken at every step (each pass of the ball through the load zone) and is linear in time between the
steps (:meth:`TrackGate.gain`). In the synthesiser the lines of the ball defect (every line on the spin phase, and
the cage orders that are not multiples of the ball count: the lines a perfect ball set has none of) are multiplied
by the gain at every knot, and amplitudes are linear in time between knots: so the knots of a wandering ball
defect sit on the steps (on the nearest sample), where the gain's slope changes, except where the gain, linear
between the knots kept, stays within :data:`GAIN_TOLERANCE` of it (:func:`keep_knots`): a pit off the track needs
no knots, a pit that moves over the track's edge one every cage revolution. Such a knot takes the amplitudes of its
speed segment blended in time (the samples between two knots are so blended anyway) and needs no spectrum of its
own. The other lines (the BPFO orders of the ball set, the shaft's and the supply's) are not gated: a pit off the
track leaves them as they are.

**Spin slip** (:class:`~bkabem_core.synth.randomness.SlipWalk`, ``spin``). The ball's spin does not keep its
kinematic rate against the cage: its phase walks like the ball pass does under random slip, with an independent
walk of relative standard deviation ``spin_slip`` per ball pass (a fraction of the spin's advance per pass), on top
of the cage's slip. A random walk of the phase turns the line at harmonic ``m`` of the spin into a Lorentzian of
half-power width ``(2 pi m kappa sigma)^2 BPFO / (2 pi)`` [Hz] (``kappa = BSF / (FTF z)`` spin turns per pass):
2 x BSF becomes a hump.

Defaults (:data:`DEFAULT_WANDER_REVOLUTIONS`, :data:`DEFAULT_SPIN_SLIP`) and their argument are on the constants.
Units: m, ball passes, steps (cage revolutions).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from bkabem_core.bearing.defects.ball import DEFAULT_SPIN_SLIP, DEFAULT_WANDER_REVOLUTIONS

#: DEFAULT_WANDER_REVOLUTIONS: correlation of the spin axis [ball revolutions]. No direct measurement of a ball's attitude in a running deep-
#: groove bearing is published. Chosen from what it must give on the CWRU rig (its 6205 at 1797 rpm: 5.9 ball
#: revolutions per cage turn, 12 cage turns a second): visits of the pit to the track of a few tenths of a second,
#: which smear 2 x BSF into the 3-6 Hz wide humps of the CWRU ball records, and absences of seconds, which make
#: some ten-second records show nothing (Smith & Randall 2015: B007 not diagnosable). A walk of correlation tau
#: steps crosses a track of half-width b (in sin-latitude, ~0.1-0.15 for 7-21 mil pits) in ~b^2 tau steps:
#: tau ~ 150 cage turns (~900 ball revolutions, ~13 s). 0 keeps the pit on the track (the quasi-static model).
#: DEFAULT_SPIN_SLIP: spin slip [fraction of the spin's advance per ball pass]. Ball slip in lightly loaded bearings is of the order
#: of the cage's (1-2 %, Randall & Antoni 2011); the spin of a ball outside the load zone is freer than the cage.
#: 2 % gives 2 x BSF a hump of ~0.5 Hz on the CWRU rig by itself, the wander's visits the rest.
__all__ = ["DEFAULT_SPIN_SLIP", "DEFAULT_WANDER_REVOLUTIONS", "AxisWalk", "BallTrack", "TrackGate", "keep_knots"]
#: A step of the walk becomes a knot where the gain, linear between the knots kept, would be off by more than this
GAIN_TOLERANCE = 0.01
#: Largest correlation the walk takes [steps] (longer: the axis does not move in any run; use 0, a fixed track).
MAX_CORRELATION_STEPS = 1.0e9


def rho_of_sigma(sigma: float) -> float:
    """``E[cos |v|]`` of a 2-D Gaussian tangent step ``v`` of per-component standard deviation ``sigma`` [rad]: the
    correlation of the axis over one step."""
    from scipy.special import dawsn

    return 1.0 - math.sqrt(2.0) * sigma * float(dawsn(sigma / math.sqrt(2.0)))


def sigma_for_correlation(tau_steps: float) -> float:
    """The step ``sigma`` [rad] of a walk whose axis correlation falls by ``1/e`` in ``tau_steps`` steps (>= 1)."""
    from scipy.optimize import brentq

    target = math.exp(-1.0 / float(tau_steps))
    return float(brentq(lambda s: rho_of_sigma(s) - target, 1e-12, 2.5, xtol=1e-15, rtol=1e-14))


def track_half_width_m(contact, load_n: float) -> float:
    """Semi-axis of the Hertz contact ellipse across the track [m] at ball load ``load_n`` [N]: the mean of the
    inner and the outer contact of :class:`~bkabem_core.bearing.deep_groove.HertzContact` ``contact``
    (Brewe-Hamrock: ``a = (6 k^2 E Q R / (pi E'))^(1/3)``, ``E = 1.0003 + 0.5968 R_x / R_y``)."""
    q = max(float(load_n), 0.0)
    out = []
    for rx, ry, ke in ((contact.rx_inner_m, contact.ry_inner_m, contact.ellipticity_inner),
                       (contact.rx_outer_m, contact.ry_outer_m, contact.ellipticity_outer)):
        r = 1.0 / (1.0 / rx + 1.0 / ry)
        e_bar = 1.0003 + 0.5968 * rx / ry
        out.append((6.0 * ke * ke * e_bar * q * r / (math.pi * contact.effective_modulus_pa)) ** (1.0 / 3.0))
    return 0.5 * (out[0] + out[1])


def keep_knots(x: np.ndarray, gain: np.ndarray, tol: float) -> list:
    """Indices of the inner points of ``(x, gain)`` (the first and the last are knots already) to keep as knots so
    that the gain, linear between kept points, is within ``tol`` of every point's (greedy: a run of points is
    bridged while the chord from the last kept point stays within ``tol`` of each)."""
    kept, a = [], 0
    for j in range(2, x.size):
        chord = gain[a] + (gain[j] - gain[a]) * (x[a + 1:j] - x[a]) / (x[j] - x[a])
        if np.max(np.abs(gain[a + 1:j] - chord)) > tol:
            kept.append(j - 1)
            a = j - 1
    return kept


def _disc_below(h, r: float):
    """Area of a disc of radius r (centre 0) below the line y = h [m^2]."""
    h = np.clip(h, -r, r)
    return r * r * (math.pi - np.arccos(h / r)) + h * np.sqrt(np.maximum(r * r - h * h, 0.0))


@dataclass(frozen=True)
class BallTrack:
    """The track wander and spin slip of a ball defect in one model (module docstring).

    Attributes
    ----------
    pit_radius_m : float
        Half the pit's diameter (the defect's ``length_m``) [m].
    half_width_m : float
        The contact track's half-width ``a`` [m].
    ball_radius_m : float
    correlation_steps : float
        The spin axis's correlation [cage revolutions]; 0: the pit stays on the track (gain 1).
    passes_per_step : int or float
        Ball passes of the DE (the stream's clock) per revolution of the defective ball's cage: its ball count for a
        ball of the DE, or of a machine whose bearings share their kinematics; ``BPFO_de / FTF_nde`` for a ball of
        an NDE bearing of its own.
    spin_slip : float
        Relative standard deviation of the spin's advance per ball pass [-].
    gated : ndarray of bool (L,)
        The kept lines the gain multiplies.
    wander_revolutions : float
        ``correlation_steps`` in ball revolutions (the case key).
    bearing : str
        The defective ball's bearing (``"de"``, ``"nde"``).
    spin_column : int
        The column of its spin phase in the machine's phases (2: the DE's, also for shared kinematics; 4: the NDE's).
    """

    pit_radius_m: float
    half_width_m: float
    ball_radius_m: float
    correlation_steps: float
    passes_per_step: int
    spin_slip: float
    gated: np.ndarray
    wander_revolutions: float
    bearing: str = "de"
    spin_column: int = 2

    @classmethod
    def of_model(cls, model, coefficients: np.ndarray) -> "BallTrack | None":
        """The ball track of ``model``'s first ball defect for its kept lines of ``coefficients`` (L, 6) on the
        machine's phases (None: the model has no ball defect, or neither wander nor spin slip). The gated lines are
        those on the defective ball's own bearing's cage and spin columns (the DE's where both bearings share their
        kinematics)."""
        case = model.case
        table = next((d for d in case.raw["defects"] if d["race"] == "ball"), None)
        if table is None:
            return None
        wander = float(table.get("wander_revolutions", DEFAULT_WANDER_REVOLUTIONS))
        spin_slip = float(table.get("spin_slip", DEFAULT_SPIN_SLIP))
        if wander == 0.0 and spin_slip == 0.0:
            return None
        geometry = case.bearing_geometry(table["bearing"])
        bearing = case.bearing(table["bearing"])
        load = float(np.max(model.machine.sites[table["bearing"]].state.ball_loads_n))
        own = table["bearing"]
        fm = model.bearing_multipliers[own]                       # the defective ball's own bearing
        z = int(geometry.n_balls)
        c = np.asarray(coefficients)
        cage, spin = model.phases.columns(own)
        gated = (c[:, spin] != 0) | (c[:, cage] % z != 0)
        steps = wander / (fm.bsf / fm.ftf)
        per_step = z if cage == 1 else model.bpfo_per_hz / fm.ftf
        return cls(pit_radius_m=0.5 * float(table["length_m"]), half_width_m=track_half_width_m(bearing.contact, load),
                   ball_radius_m=0.5 * geometry.ball_diameter_m, correlation_steps=steps, passes_per_step=per_step,
                   spin_slip=spin_slip, gated=gated, wander_revolutions=wander, bearing=own, spin_column=spin)

    @property
    def wanders(self) -> bool:
        """Whether the gain changes (a wander correlation > 0 and lines to gate)."""
        return self.correlation_steps > 0.0 and bool(self.gated.any())

    @property
    def in_track_fraction(self) -> float:
        """Mean share of the time the pit touches the track, ``sin((a + r) / R)`` (a uniform axis) [-]."""
        return math.sin(min((self.half_width_m + self.pit_radius_m) / self.ball_radius_m, 0.5 * math.pi))

    def gain(self, sin_latitude) -> np.ndarray:
        """Strike strength [-] of the pit at ``sin_latitude`` = n . e_z (its centre's latitude over the rolling
        great circle, either side): the share of its area within the track, relative to a pit on the centre line."""
        s = self.ball_radius_m * np.arcsin(np.minimum(np.abs(np.asarray(sin_latitude, dtype=float)), 1.0))
        r, a = self.pit_radius_m, self.half_width_m
        inside = _disc_below(a - s, r) - _disc_below(-a - s, r)
        return inside / (_disc_below(a, r) - _disc_below(-a, r))

    def to_dict(self) -> dict:
        return {"wander_revolutions": self.wander_revolutions, "correlation_cage_revolutions": self.correlation_steps,
                "spin_slip": self.spin_slip, "pit_radius_m": self.pit_radius_m,
                "track_half_width_m": self.half_width_m, "ball_radius_m": self.ball_radius_m,
                "in_track_fraction": self.in_track_fraction, "gated_lines": int(self.gated.sum())}


class AxisWalk:
    """The spin axis's random walk on the sphere, one step per cage revolution (module docstring), seeded.

    Steps come in blocks of :data:`BLOCK`, block b from ``SeedSequence([seed, tag, b])`` (three normals a step),
    each going on from the last one's end; the start from ``SeedSequence([seed, tag, -1])`` is uniform on the
    sphere. Values depend on (seed, correlation, step) alone.

    Parameters
    ----------
    correlation_steps : float
        The axis's correlation [steps], >= 0.5 (a case asks for one cage revolution at least).
    seed : int
    """

    BLOCK = 1 << 7                          # ~10 s of a rig's cage revolutions: a run makes what it needs
    _TAG = 0xA715

    def __init__(self, correlation_steps: float, seed: int):
        tau = float(correlation_steps)
        if not (math.isfinite(tau) and 0.5 <= tau <= MAX_CORRELATION_STEPS):
            raise ValueError(f"correlation_steps: must be in [0.5, {MAX_CORRELATION_STEPS:g}] (got {tau!r})")
        self.correlation_steps = tau
        self.seed = int(seed)
        self.sigma = sigma_for_correlation(tau)
        self.reset()

    def reset(self) -> None:
        start = np.random.default_rng(np.random.SeedSequence([self.seed, self._TAG, 2 ** 32 - 1]))
        n = start.standard_normal(3)
        self._start = n / np.linalg.norm(n)
        self._blocks: OrderedDict[int, np.ndarray] = OrderedDict()
        self._next_block, self._next_start = 0, self._start

    def _block(self, b: int) -> np.ndarray:
        """(BLOCK, 3) axes at steps b BLOCK .. (b + 1) BLOCK - 1."""
        if b in self._blocks:
            return self._blocks[b]
        if b < self._next_block:
            self.reset()
        while self._next_block <= b:
            rng = np.random.default_rng(np.random.SeedSequence([self.seed, self._TAG, self._next_block]))
            xi = self.sigma * rng.standard_normal((self.BLOCK, 3))
            out = np.empty((self.BLOCK, 3))
            x, y, z = (float(v) for v in self._next_start)
            for k in range(self.BLOCK):
                out[k] = x, y, z
                vx, vy, vz = xi[k]
                d = vx * x + vy * y + vz * z                     # the step's tangent part
                vx, vy, vz = vx - d * x, vy - d * y, vz - d * z
                r = math.sqrt(vx * vx + vy * vy + vz * vz)
                if r > 0.0:
                    c, s = math.cos(r), math.sin(r) / r
                    x, y, z = c * x + s * vx, c * y + s * vy, c * z + s * vz
                    norm = math.sqrt(x * x + y * y + z * z)
                    x, y, z = x / norm, y / norm, z / norm
            self._next_start = np.array([x, y, z])
            self._blocks[self._next_block] = out
            self._next_block += 1
            while len(self._blocks) > 3:
                self._blocks.popitem(last=False)
        return self._blocks[b]

    def axes(self, k0: int, k1: int) -> np.ndarray:
        """(k1 - k0 + 1, 3) axes at steps k0..k1 (k0 >= 0)."""
        out = np.empty((k1 - k0 + 1, 3))
        k = k0
        while k <= k1:
            b = k // self.BLOCK
            blk = self._block(b)
            s = k - b * self.BLOCK
            e = min(self.BLOCK, k1 - b * self.BLOCK + 1)
            out[k - k0:k - k0 + e - s] = blk[s:e]
            k += e - s
        return out

    def sin_latitude(self, k0: int, k1: int) -> np.ndarray:
        """``n_z`` (the sine of the pit's latitude over the rolling great circle) at steps k0..k1 (k0 >= 0)."""
        return self.axes(k0, k1)[:, 2]


class TrackGate:
    """The gain of a run's ball-defect lines at its knots: a :class:`BallTrack` and the :class:`AxisWalk` of the
    run's seed (one per correlation, kept across model switches of the same ball)."""

    def __init__(self, seed: int):
        self.seed = int(seed)
        self._walks: dict[float, AxisWalk] = {}
        self._gains: OrderedDict = OrderedDict()          # (track, block) -> the gain at the block's steps

    def walk(self, track: BallTrack) -> AxisWalk:
        """The walk of the run's seed with ``track``'s correlation."""
        walk = self._walks.get(track.correlation_steps)
        if walk is None:
            walk = self._walks[track.correlation_steps] = AxisWalk(track.correlation_steps, self.seed)
        return walk

    def _step_gain(self, track: BallTrack, k: int) -> float:
        b = k // AxisWalk.BLOCK
        key = (track.pit_radius_m, track.half_width_m, track.ball_radius_m, track.correlation_steps, b)
        g = self._gains.get(key)
        if g is None:
            g = self._gains[key] = track.gain(self.walk(track).sin_latitude(b * AxisWalk.BLOCK,
                                                                            (b + 1) * AxisWalk.BLOCK - 1))
            while len(self._gains) > 4:
                self._gains.popitem(last=False)
        return float(g[k - b * AxisWalk.BLOCK])

    def gain(self, track: BallTrack, passes: float) -> float:
        """The gain [-] at ``passes`` ball passes since t = 0 (>= 0): the pit's at the steps around it, linear in
        between."""
        steps = passes / track.passes_per_step
        k = int(math.floor(steps))
        g0, g1 = self._step_gain(track, k), self._step_gain(track, k + 1)
        return g0 + (g1 - g0) * (steps - k)
