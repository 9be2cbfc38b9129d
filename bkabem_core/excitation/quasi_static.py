"""The bearing excitation of BKA-BEM: the "bearing kinematics" as orders of the ball-pass frequency.

For one bearing (with its dent, or healthy) under its static load, the relative displacement rotor - housing that
the ball set and the defect impose repeats once per ball pass (every ball sees the same load zone and the same
fixed dent), so it is a sum of BPFO orders, vertical and horizontal:

    u(t) = DC + sum_k A_k cos(k omega_BPFO t + phi_k),      t = 0 when the cage angle is 0,

or in the angle domain ``omega_BPFO t = z theta_cage``, which is how the synthesiser places the orders under a
varying speed. Two ways to get A_k and phi_k (``[excitation] method``):

``quasi_static`` (:func:`quasi_static_excitation`)
    The bearing's static equilibrium under its load at every cage angle of one ball pitch (no inertia), Newton on
    ``F(e, theta) + W = 0``, then an FFT over the pitch. Exactly periodic, no transient, no model dynamics: valid
    at every order (a few ms for 2048 angles).
``four_dof`` (:func:`compute_excitation`, paper section 3)
    The paper's 4-DOF model: rotor and housing of the bearing, two lateral DOFs each, connected by the nonlinear
    ball-bearing force with the dent and a viscous bearing damper; the housing on a spring-damper support; gravity
    on both. Integrated at the reference speed with a stiff (implicit) solver (LSODA) from the static
    equilibrium, the start transient discarded and a whole number of cage periods recorded. Its orders near and
    above the model's own housing-on-bearing resonance (~1 kHz at 1 Hz, order ~165) carry that ringing, not
    bearing kinematics (docs/method.md compares the two).

Both hold the axial displacement of the bearing at its static value under the axial load (:mod:`bearing`).

Units: SI (m, s, N, kg, rad).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import numpy as np

from bkabem_core.bearing.deep_groove import TWO_PI, Bearing
from bkabem_core.bearing.defects.registry import kind as defect_kind
from bkabem_core.bearing.defects.registry import periodic_kinds
from bkabem_core.bearing.statics import BearingState
from bkabem_core.excitation.lines import LineSet, lines_from_grid, union
from bkabem_core.excitation.path import quasi_static_path_m
from bkabem_core.excitation.turning import turning_lines
from bkabem_core.model.vocabulary import DIRECTIONS

METHODS = ("quasi_static", "four_dof")


def _periodic_words() -> str:
    """The kinds the 4-DOF model takes, for people: "outer-race"."""
    return " and ".join(k.adjective for k in periodic_kinds())


@dataclass(frozen=True)
class FourDofParameters:
    """Parameters of the 4-DOF model (SI).

    Attributes
    ----------
    rotor_mass_kg, housing_mass_kg : float
        Lumped rotor and housing masses [kg]. The rotor's weight is the bearing's radial load.
    support_stiffness_n_m, support_damping_n_s_m : float
        Housing-to-ground support, same in both lateral directions [N/m], [N s/m].
    bearing_damping_n_s_m : float
        Viscous damper between rotor and housing [N s/m] (Table 1: 0.55 N s/mm).
    gravity_m_s2 : float
        Gravitational acceleration along -y [m/s^2].
    reference_speed_hz : float
        Shaft speed of the integration [Hz] (paper: 1 Hz).
    settle_time_s : float
        Minimum start transient discarded [s]; rounded up to whole ball-pass periods.
    record_cage_periods : int
        Whole cage periods recorded for the FFT.
    samples_per_ball_pass : int
        FFT samples per ball-pass (BPFO) period; orders up to half of it are resolved.
    rtol, atol_m : float
        Integrator tolerances (relative; absolute on displacements [m], velocities get atol_m x 1e3 1/s).
    relative_amplitude_threshold : float
        Orders are kept while ``A_k >= threshold * max_k A_k`` in either direction.
    max_order : int
        Keep at most orders 1..max_order (0 = no limit). The paper's choice is 24.
    """

    rotor_mass_kg: float = 82.0
    housing_mass_kg: float = 3.17
    support_stiffness_n_m: float = 1.0e6
    support_damping_n_s_m: float = 1.0e4
    bearing_damping_n_s_m: float = 550.0
    gravity_m_s2: float = 9.80665
    reference_speed_hz: float = 1.0
    settle_time_s: float = 0.3
    record_cage_periods: int = 1
    samples_per_ball_pass: int = 2048
    rtol: float = 1.0e-7
    atol_m: float = 1.0e-12
    relative_amplitude_threshold: float = 1.0e-3
    max_order: int = 0

    @classmethod
    def from_case(cls, case, location: str) -> "FourDofParameters":
        """The 4-DOF model's parameters of the bearing at ``location`` of a case (``[excitation]``; the damper of
        that position, ``[bearings.<location>] damping_n_s_m``)."""
        e = case.raw["excitation"]
        fields = {k: e[k] for k in cls.__dataclass_fields__ if k in e}
        return cls(bearing_damping_n_s_m=case.bearing_damping_n_s_m(location), **fields)


@dataclass
class Excitation:
    """Spectrum of the rotor-housing relative displacement imposed by one bearing.

    Attributes
    ----------
    bpfo_per_hz : float
        BPFO multiplier (BPFO per 1 Hz of shaft speed) [-].
    reference_speed_hz : float
        Shaft speed of the 4-DOF integration [Hz] (the time axis of ``time_s`` for the quasi-static method).
    orders : ndarray of int (n_orders,)
        Kept BPFO orders k (1 = BPFO).
    amplitude_m : dict direction -> ndarray (n_orders,)
        A_k [m], cosine convention, for ``"vertical"`` and ``"horizontal"``.
    phase_rad : dict direction -> ndarray (n_orders,)
        phi_k [rad], referred to t = 0 at cage angle 0.
    dc_m : dict direction -> float
        Mean relative displacement [m] (static deflection of the bearing incl. clearance).
    peak_to_peak_m : dict direction -> float
        Peak-to-peak of the relative displacement over one period [m].
    clearance_m : float
        Diametral clearance of the bearing [m].
    all_orders, all_amplitude_m, all_phase_rad :
        Every resolved order (before the threshold), for plots and diagnostics.
    time_s, relative_displacement_m : ndarray
        The recorded window (time from its start at the reference speed [s]; shape (2, N): vertical,
        horizontal [m]).
    off_order_fraction : float
        RMS of the non-BPFO FFT bins relative to the RMS of the BPFO bins (~0; for the quasi-static method only the
        Nyquist bin is not an order) [-].
    static_displacement_m : ndarray (2,)
        Static equilibrium e (horizontal x, vertical y) without the dent [m].
    wall_time_s : float
        Time spent computing and transforming [s].
    n_steps : int
        Right-hand-side evaluations of the integrator (Newton iterations for the quasi-static method).
    housing_resonance_hz : float
        4-DOF: housing-on-bearing natural frequency of the model at the static equilibrium (vertical) [Hz]; orders
        near and above it carry the model's own ringing. NaN for the quasi-static method (no dynamics).
    method : str
        ``"quasi_static"`` or ``"four_dof"``.
    bearing : str
        Location of the bearing (``"de"``/``"nde"``), if known.
    radial_load_n, axial_load_n : float
        Radial (vertical, downward) and axial load the bearing carries [N].
    state : BearingState or None
        The static equilibrium the excitation starts from.
    lines : LineSet or None
        Every kept line (inner-race and ball defects); None for BPFO orders only.
    n_balls : int
    rates_per_hz : ndarray (4,) or None
        Rates of the base phases per shaft Hz (:func:`rates_per_hz`).
    torus_paths : dict of str -> TorusPath
        The quasi-static path on the torus of each moving defect kind (:func:`torus_path`) the lines came from;
        the improved method takes the stiffness along it (:mod:`bkabem_core.solve.improved`). Empty for BPFO orders.
    """

    bpfo_per_hz: float
    reference_speed_hz: float
    orders: np.ndarray
    amplitude_m: dict
    phase_rad: dict
    dc_m: dict
    peak_to_peak_m: dict
    clearance_m: float
    all_orders: np.ndarray
    all_amplitude_m: dict
    all_phase_rad: dict
    time_s: np.ndarray
    relative_displacement_m: np.ndarray
    off_order_fraction: float
    static_displacement_m: np.ndarray
    wall_time_s: float
    n_steps: int
    housing_resonance_hz: float = float("nan")
    method: str = "four_dof"
    bearing: str = ""
    radial_load_n: float = float("nan")
    axial_load_n: float = 0.0
    state: BearingState | None = field(default=None, repr=False)
    lines: LineSet | None = field(default=None, repr=False)
    n_balls: int = 0
    rates_per_hz: np.ndarray | None = field(default=None, repr=False)
    torus_paths: dict = field(default_factory=dict, repr=False)

    def line_set(self) -> LineSet:
        """The excitation as a :class:`~bkabem_core.excitation.lines.LineSet` (inputs vertical, horizontal [m], the DC as its
        ``dc``): every kept line of the bearing's defects; for an outer race or a healthy bearing exactly the kept
        BPFO orders (``orders``, ``amplitude_m``, ``phase_rad``), which are then all its lines."""
        if self.lines is not None:
            return self.lines
        return LineSet.from_orders(self.orders, self.complex_amplitude_m(), self.n_balls, self.rates_per_hz,
                                   DIRECTIONS, dc=[self.dc_m[d] for d in DIRECTIONS])

    def to_dict(self) -> dict:
        """JSON-ready summary (field names of the CLI contract)."""
        return {
            "bearing": self.bearing,
            "method": self.method,
            "bpfo_per_hz": self.bpfo_per_hz,
            "reference_speed_hz": self.reference_speed_hz,
            "radial_load_n": self.radial_load_n,
            "axial_load_n": self.axial_load_n,
            "dc_m": {d: float(self.dc_m[d]) for d in DIRECTIONS},
            "orders": [int(k) for k in self.orders],
            "amplitude_m": {d: self.amplitude_m[d].tolist() for d in DIRECTIONS},
            "phase_rad": {d: self.phase_rad[d].tolist() for d in DIRECTIONS},
            "peak_to_peak_m": {d: float(self.peak_to_peak_m[d]) for d in DIRECTIONS},
            "clearance_m": self.clearance_m,
            "off_order_fraction": self.off_order_fraction,
            "static_displacement_m": {"vertical": float(self.static_displacement_m[1]),
                                      "horizontal": float(self.static_displacement_m[0])},
            "n_resolved_orders": int(len(self.all_orders)),
            "housing_resonance_hz": _json_float(self.housing_resonance_hz),
            "wall_time_s": self.wall_time_s,
            "integrator_steps": self.n_steps,
            "lines": None if self.lines is None else self.lines.to_dict(),
        }

    def with_selection(self, relative_amplitude_threshold: float, max_order: int = 0) -> "Excitation":
        """The same result with the kept orders chosen again (no re-computation).

        ``max_order=24, relative_amplitude_threshold=0`` is the paper's choice (BPFO and 23 harmonics).
        """
        keep = select_orders(self.all_amplitude_m, relative_amplitude_threshold, max_order)
        return self.on_orders(self.all_orders[keep])

    def on_orders(self, orders) -> "Excitation":
        """The same result on the given orders (zero amplitude where an order is not resolved)."""
        orders = np.asarray(orders, dtype=int)
        out = copy.copy(self)
        out.lines = None                              # rebuilt from the orders (line_set)
        ok = (orders >= 1) & (orders <= self.all_orders[-1])
        out.orders = orders
        out.amplitude_m, out.phase_rad = {}, {}
        for d in DIRECTIONS:
            a = np.zeros(orders.size)
            p = np.zeros(orders.size)
            a[ok] = self.all_amplitude_m[d][orders[ok] - 1]
            p[ok] = self.all_phase_rad[d][orders[ok] - 1]
            out.amplitude_m[d], out.phase_rad[d] = a, p
        return out

    def complex_amplitude_m(self) -> np.ndarray:
        """``U_k = A_k e^{i phi_k}`` (K, 2) [m], columns (vertical, horizontal)."""
        return np.stack([self.amplitude_m[d] * np.exp(1j * self.phase_rad[d]) for d in DIRECTIONS], axis=1)


def _json_float(x: float):
    return float(x) if math.isfinite(x) else None


def select_orders(all_amplitude_m: dict, relative_amplitude_threshold: float, max_order: int) -> np.ndarray:
    """Boolean mask over orders 1..N: ``A_k >= threshold x max A`` in either direction, and ``k <= max_order``."""
    amp = np.vstack([all_amplitude_m[d] for d in DIRECTIONS])
    keep = np.max(amp, axis=0) >= relative_amplitude_threshold * amp.max()
    if max_order > 0:
        keep &= np.arange(1, amp.shape[1] + 1) <= max_order
    return keep


def _orders_from_record(rel: np.ndarray, periods: int, threshold: float, max_order: int):
    """FFT over a record of ``periods`` whole ball passes (2, N): (all orders, amp (2, K), phase (2, K), DC (2,),
    off-order fraction, kept mask)."""
    n = rel.shape[1]
    spec = np.fft.rfft(rel, axis=1) / n
    k_max = (n // 2 - 1) // periods                      # the Nyquist bin is not an order
    all_orders = np.arange(1, k_max + 1)
    bins = all_orders * periods
    amp = 2.0 * np.abs(spec[:, bins])
    pha = np.angle(spec[:, bins])
    mask = np.ones(spec.shape[1], dtype=bool)
    mask[0] = False
    mask[bins] = False
    on = np.sqrt(np.sum(np.abs(spec[:, bins]) ** 2))
    off = np.sqrt(np.sum(np.abs(spec[:, mask]) ** 2))
    keep = select_orders({"vertical": amp[0], "horizontal": amp[1]}, threshold, max_order)
    return all_orders, amp, pha, spec[:, 0].real, (float(off / on) if on > 0 else 0.0), keep


# --------------------------------------------------------------------------- quasi-static
def quasi_static_excitation(bearing: Bearing, radial_load_n: float, axial_load_n: float = 0.0,
                            samples_per_ball_pass: int = 2048, relative_amplitude_threshold: float = 1e-3,
                            max_order: int = 0, reference_speed_hz: float = 1.0, location: str = "",
                            film_m: float = 0.0, n_slow: int = 0, rotating_load_n: complex = 0j) -> Excitation:
    """Excitation of one bearing from its quasi-static equilibrium over one ball pitch (no inertia).

    Parameters
    ----------
    bearing : Bearing
        The bearing with its dent (or healthy: then only its ball-passage variation remains).
    radial_load_n : float
        Downward radial load on the shaft that the bearing carries [N] (its share of the rotor weight).
    axial_load_n : float
        Axial load [N]; the axial displacement is held at its static value under it.
    samples_per_ball_pass : int
        Cage angles per ball pitch; orders up to half of it are resolved.
    relative_amplitude_threshold, max_order :
        Order selection (:func:`select_orders`).
    reference_speed_hz : float
        Only labels the time axis of the result ([s] at this shaft speed).
    location : str
        ``"de"``/``"nde"``, recorded in the result.
    n_slow : int
        Inner-race and ball defects: samples of the slow angle of their 2-torus (shaft angle, cage angle); 0 =
        the next power of 2 >= 4 z (64 for 14 balls: sidebands up to twice the ball passage). The fast angle has
        ``samples_per_ball_pass`` samples.
    rotating_load_n : complex
        The load on the shaft that turns with it (:meth:`bkabem_core.fe.machine.Machine._turning_loads`):
        ``(Re, Im)(R exp(i theta_shaft))`` [N] on top of the static load. With it the bearing's state depends on
        the shaft angle too: the races and their defects are solved on the inner race's torus (the ball-set
        position relative to the shaft, and the shaft angle), giving sidebands at the shaft frequency around every
        line and the ball passage relative to the turning load at BPFI. Its pure shaft orders are left out: the FE
        carries the force itself (the baseline's coupling line). Ball defects add their lines under the static
        load.

    Returns
    -------
    Excitation
        ``method = "quasi_static"``, exactly periodic, no housing resonance. ``lines`` holds every kept line
        (inner-race and ball defects: the BPFO orders of the rest of the bearing plus the lines of the defect,
        :func:`_difference_lines`); for an outer race or healthy bearing it is None and :meth:`Excitation.line_set`
        gives the BPFO orders, exactly as before.
    """
    t0 = time.perf_counter()
    g = bearing.geometry
    z = g.n_balls
    fm = bearing.fault_multipliers()
    n = int(samples_per_ball_pass)
    pitch = TWO_PI / z
    theta = pitch * np.arange(n) / n
    load = (0.0, -float(radial_load_n))
    moving = bearing.defect_set.moving
    # the bearing without its moving defects: ball passage and periodic kinds, exactly BPFO orders
    outer = Bearing(g, defects=bearing.periodic_defects) if moving or not bearing.defect_set else bearing
    path, state, iterations = quasi_static_path_m(outer, load, axial_load_n, theta, film_m)
    rel = np.vstack([path[:, 1], path[:, 0]])                     # vertical, horizontal
    all_orders, amp, pha, dc, off, keep = _orders_from_record(rel, 1, relative_amplitude_threshold, max_order)
    rates = rates_per_hz(fm)
    lines = None
    tori = {}
    if rotating_load_n != 0:
        base = turning_lines(bearing, load, complex(rotating_load_n), axial_load_n, n, n_slow, film_m, rates)
        parts = [base]
        race = Bearing(g, defects=[d for d in bearing.defects if defect_kind(d.race).periodic or d.race == "inner"])
        for kind in moving:
            if kind.name != "inner":
                slow = n_slow if n_slow > 0 else max(32, 1 << math.ceil(math.log2(4 * z)))
                parts.append(_difference_lines(bearing, race, kind.name, load, axial_load_n, n, slow, film_m,
                                               rates, keep=tori))
        lines = union(parts).select(relative_amplitude_threshold, max_order * fm.bpfo if max_order > 0 else 0.0)
        order_like = (lines.coefficients[:, [0, 2, 3]] == 0).all(axis=1) & (lines.coefficients[:, 1] % z == 0)
        keep = np.zeros(all_orders.size, bool)
        keep[np.isin(all_orders, lines.coefficients[order_like, 1] // z)] = True
        dc = lines.dc
    elif moving:
        # moving kinds (inner race, ball): the difference they make, on a 2-torus of their phases
        base = LineSet.from_orders(all_orders, amp.T * np.exp(1j * pha.T), z, rates, DIRECTIONS, dc=dc)
        parts = [base]
        for kind in moving:
            slow = n_slow if n_slow > 0 else max(32, 1 << math.ceil(math.log2(4 * z)))
            parts.append(_difference_lines(bearing, outer, kind.name, load, axial_load_n, n, slow, film_m, rates,
                                           keep=tori))
        every = union(parts)
        lines = every.select(relative_amplitude_threshold, max_order * fm.bpfo if max_order > 0 else 0.0)
        order_like = (lines.coefficients[:, [0, 2, 3]] == 0).all(axis=1) & (lines.coefficients[:, 1] % z == 0)
        keep = np.zeros(all_orders.size, bool)
        keep[np.isin(all_orders, lines.coefficients[order_like, 1] // z)] = True
        dc = lines.dc
    return Excitation(
        bpfo_per_hz=fm.bpfo,
        reference_speed_hz=float(reference_speed_hz),
        orders=all_orders[keep],
        amplitude_m={"vertical": amp[0, keep], "horizontal": amp[1, keep]},
        phase_rad={"vertical": pha[0, keep], "horizontal": pha[1, keep]},
        dc_m={"vertical": float(dc[0]), "horizontal": float(dc[1])},
        peak_to_peak_m={"vertical": float(np.ptp(rel[0])), "horizontal": float(np.ptp(rel[1]))},
        clearance_m=g.diametral_clearance_m,
        all_orders=all_orders,
        all_amplitude_m={"vertical": amp[0], "horizontal": amp[1]},
        all_phase_rad={"vertical": pha[0], "horizontal": pha[1]},
        time_s=theta / (TWO_PI * fm.ftf * reference_speed_hz),
        relative_displacement_m=rel,
        off_order_fraction=off,
        static_displacement_m=state.displacement_m[:2].copy(),
        wall_time_s=time.perf_counter() - t0,
        n_steps=iterations,
        method="quasi_static",
        bearing=location,
        radial_load_n=float(radial_load_n),
        axial_load_n=float(axial_load_n),
        state=state,
        lines=lines,
        n_balls=z,
        rates_per_hz=rates,
        torus_paths=tori,
    )


def _reference_path(base: Bearing, load, axial_load_n: float, cage, film_m: float, ref):
    """The base's path at ``cage`` solved by the same batched Newton as the defective one: subtracted in place of
    the tabulated ``ref`` where the defect acts, so that the difference does not carry the Newton tolerance of
    two different iteration counts."""
    path, _, _ = quasi_static_path_m(base, load, axial_load_n, cage, film_m)
    return path


def rates_per_hz(fault_multipliers) -> np.ndarray:
    """Rates of the base phases (shaft, cage, spin, line) per shaft Hz: (1, FTF, BSF, 0)."""
    return np.array([1.0, fault_multipliers.ftf, fault_multipliers.bsf, 0.0])


@dataclass
class TorusPath:
    """The quasi-static path of a bearing with a moving defect on the 2-torus of the defect's own angles.

    Grid ``(a, b) = 2 pi (i / n_fast, j / n_slow)`` of the kind's torus
    (:class:`~bkabem_core.bearing.defects.protocol.TorusGrid`): e.g. inner race ``a = psi = z (theta_shaft -
    theta_cage)``, ``b = theta_shaft``; ball ``a = theta_spin``, ``b = theta_cage`` (:func:`_difference_lines`).

    Attributes
    ----------
    kind : str
        The name of a moving kind (``"inner"``, ``"ball"``).
    phase_map : ndarray of int (2, 4)
        Coefficients of ``a`` and ``b`` on the base phases (shaft, cage, spin, line).
    cage, shaft, spin : ndarray (n_fast, n_slow) [rad]
        The base phases at every grid point.
    base_index : ndarray of int (n_fast, n_slow)
        Index into the base's one-pitch table (:attr:`base`) of each grid point's ball-set position (exact).
    base : ndarray (n_fast, 2)
        The path of the bearing without these defects over one ball pitch (``n_fast`` cage angles) [m] (x, y).
    path : ndarray (n_fast, n_slow, 2)
        The path with them [m] (x, y).
    touched : ndarray of bool (n_fast, n_slow)
        Where a ball meets the defect (elsewhere ``path`` is exactly the base).
    bearing : Bearing
        The bearing with its periodic (outer-race) defects and the defects of this kind.
    """

    kind: str
    phase_map: np.ndarray
    cage: np.ndarray
    shaft: np.ndarray
    spin: np.ndarray
    base_index: np.ndarray
    base: np.ndarray
    path: np.ndarray
    touched: np.ndarray
    bearing: Bearing


def torus_path(bearing: Bearing, base: Bearing, kind: str, load, axial_load_n: float, n_fast: int, n_slow: int,
               film_m: float = 0.0) -> TorusPath:
    """The quasi-static path of ``bearing``'s defects of ``kind`` (a moving kind's name) on their torus
    (:class:`TorusPath`, :meth:`~bkabem_core.bearing.defects.protocol.DefectKind.torus`), ``base`` the bearing
    without them. Only the grid points where a ball meets a defect are solved (batched Newton)."""
    z = bearing.geometry.n_balls
    if n_fast % n_slow:
        raise ValueError(f"samples: {n_fast} per ball pass must be a multiple of the {n_slow} slow samples")
    with_kind = Bearing(bearing.geometry, defects=[d for d in bearing.defects
                                                   if d.race == kind or defect_kind(d.race).periodic])
    grid = defect_kind(kind).torus(z, n_fast, n_slow)
    phase_map, cage, shaft, spin, u_index = grid.phase_map, grid.cage, grid.shaft, grid.spin, grid.base_index
    # the base's path on its own grid (one ball pitch, the excitation's cage angles): exact at these points
    pitch = TWO_PI / z
    ref_1d, _, _ = quasi_static_path_m(base, load, axial_load_n, pitch * np.arange(n_fast) / n_fast, film_m)
    ref = ref_1d[u_index]
    # only where a ball meets the defect does the equilibrium change: solve there (the rest is exactly the base)
    beta = with_kind.ball_angles_rad(cage)
    touched = np.any(with_kind.defect_set.drop_m(beta, shaft, spin) > 0.0, axis=-1)
    full = ref.copy()
    if touched.any():
        full[touched], _, _ = quasi_static_path_m(with_kind, load, axial_load_n, cage[touched], film_m,
                                                  shaft_angles_rad=shaft[touched], spin_angles_rad=spin[touched])
        full[touched] -= _reference_path(base, load, axial_load_n, cage[touched], film_m, ref[touched])
        full[touched] += ref[touched]
    return TorusPath(kind, phase_map, cage, shaft, spin, u_index, ref_1d, full, touched, with_kind)


def _difference_lines(bearing: Bearing, base: Bearing, kind: str, load, axial_load_n: float, n_fast: int,
                      n_slow: int, film_m: float, rates, keep: dict | None = None) -> LineSet:
    """Lines of what the defects of ``kind`` add to the quasi-static path of ``base`` (the bearing without them).

    Sampled on the 2-torus of the kind's own angles (:func:`torus_path`), fine along the fast one, coarse along
    the slow one: ``"inner"``: ``psi = z (theta_shaft - theta_cage)`` (a ball's position relative to the inner
    race, one ball pitch per turn; BPFI) and ``theta_shaft`` (where the defect is in the load zone), so
    ``theta_cage = theta_shaft - psi / z``. ``"ball"``: the spin angle ``theta_spin`` and ``theta_cage`` (where
    the defective ball is in the load zone). Where no ball meets the defect the difference is exactly zero, so it
    is narrow along the fast angle and smooth along the slow one; the ball passage of the others (harmonics of
    z theta_cage) stays in the base's exact BPFO orders.
    """
    tp = torus_path(bearing, base, kind, load, axial_load_n, n_fast, n_slow, film_m)
    if keep is not None:
        keep[kind] = tp
    diff = (tp.path - tp.base[tp.base_index])[..., ::-1]                    # (vertical, horizontal)
    out = lines_from_grid(diff, tp.phase_map, rates, DIRECTIONS)
    out.dc = np.zeros(2) + out.dc
    return out


# --------------------------------------------------------------------------- 4-DOF
class FourDofModel:
    """Rotor + housing of one bearing, two lateral DOFs each, nonlinear bearing force with the dent.

    State vector ``y = [x_r, y_r, x_h, y_h, vx_r, vy_r, vx_h, vy_h]`` [m, m/s]; x horizontal, y vertical.

    Parameters
    ----------
    bearing : Bearing
        The bearing (its ``dent`` is used, if any).
    params : FourDofParameters
    axial_load_n : float
        Axial load [N]; the axial displacement is held at its static value under it.
    """

    def __init__(self, bearing: Bearing, params: FourDofParameters, axial_load_n: float = 0.0):
        self.bearing = bearing
        self.p = params
        self.axial_load_n = float(axial_load_n)
        g = bearing.geometry
        self.z = g.n_balls
        self.ftf = bearing.fault_multipliers().ftf
        self.cage_speed_rad_s = TWO_PI * self.ftf * params.reference_speed_hz
        self._u0 = np.exp(1j * bearing._ball_offsets)
        self._k = bearing.contact_constant_n_m15
        self._a0 = bearing.groove_centre_distance_m
        self._ar0 = bearing._ar0
        self._beta0 = g.first_ball_angle_rad
        self._inv_mr = 1.0 / params.rotor_mass_kg
        self._inv_mh = 1.0 / params.housing_mass_kg
        self._dy = np.zeros(8)
        self._jac_const = self._constant_jacobian()
        self._static = None
        w = params.rotor_mass_kg * params.gravity_m_s2
        self.state = bearing.state(0.0, -w, self.axial_load_n)
        self._aa = bearing._aa0 + self.state.displacement_m[2]    # held axial groove-centre offset [m]
        d = bearing.dent
        self._dent = d is not None and bearing.dent_effective_depth_m > 0.0
        if self._dent:
            self._phi_d = d.angle_rad
            self._a = bearing.dent_half_angle_rad
            self._one_ball_dent = 2.0 * self._a < TWO_PI / self.z

    # -- bearing force on the rotor, scalar fast path (RHS of the integrator) --
    def _bearing(self, ex, ey, t, stiffness=True):
        """Bearing force on the rotor [N] and, optionally, its tangent stiffness [N/m] (Eqs. 1-4).

        Scalar fast path of :meth:`Bearing.forces_n` at the held axial offset (tested equal to it): ball
        directions as unit complex numbers ``u_i = exp(i beta_i)``, ``A_r = A_r0 + Re(conj(e) u_i) - drop``,
        ``F_x + i F_y = -sum Q_i cos(phi_i) u_i``; the stiffness from ``sum w_i`` and ``sum w_i u_i^2``.
        """
        th = math.fmod(self.cage_speed_rad_s * t, TWO_PI)
        u = self._u0 * complex(math.cos(th), math.sin(th))
        ar = (complex(ex, -ey) * u).real
        ar += self._ar0
        if self._dent:
            if self._one_ball_dent:
                # only the ball nearest to the dent can be inside it (dent shorter than the ball pitch)
                pitch = TWO_PI / self.z
                i = int(round((self._phi_d - th - self._beta0) / pitch)) % self.z
                rel = abs(math.remainder(th + self._beta0 + i * pitch - self._phi_d, TWO_PI))
                if rel < self._a:
                    ar[i] -= float(self.bearing.dent_drop_m(rel))
            else:
                ar -= self.bearing.dent_depth_m(np.angle(u))
        if self._aa == 0.0:
            delta = ar - self._a0
            np.maximum(delta, 0.0, out=delta)
            root = np.sqrt(delta)
            f = -self._k * np.dot(delta * root, u)
            if not stiffness:
                return f.real, f.imag
            w = root * (1.5 * self._k)
        else:
            a = np.sqrt(ar * ar + self._aa * self._aa)
            delta = a - self._a0
            np.maximum(delta, 0.0, out=delta)
            root = np.sqrt(delta)
            c = ar / a
            q = self._k * delta * root
            f = -np.dot(q * c, u)
            if not stiffness:
                return f.real, f.imag
            w = 1.5 * self._k * root * c * c + q * (1.0 - c * c) / a
        s0 = w.sum()
        s2 = np.dot(w, u * u)
        return f.real, f.imag, 0.5 * (s0 + s2.real), 0.5 * s2.imag, 0.5 * (s0 - s2.real)

    def rhs(self, t, y):
        """Time derivative of the state (SI)."""
        p = self.p
        fx, fy = self._bearing(y[0] - y[2], y[1] - y[3], t, stiffness=False)
        fx -= p.bearing_damping_n_s_m * (y[4] - y[6])
        fy -= p.bearing_damping_n_s_m * (y[5] - y[7])
        out = self._dy
        out[0:4] = y[4:8]
        out[4] = fx * self._inv_mr
        out[5] = fy * self._inv_mr - p.gravity_m_s2
        out[6] = (-fx - p.support_stiffness_n_m * y[2] - p.support_damping_n_s_m * y[6]) * self._inv_mh
        out[7] = (-fy - p.support_stiffness_n_m * y[3] - p.support_damping_n_s_m * y[7]) * self._inv_mh - p.gravity_m_s2
        return out.copy()

    def jacobian(self, t, y):
        """Analytic Jacobian of :meth:`rhs` (the bearing tangent stiffness enters with ``dF/de = -K``)."""
        _, _, kxx, kxy, kyy = self._bearing(y[0] - y[2], y[1] - y[3], t)
        kb = np.array([[kxx, kxy], [kxy, kyy]])
        j = self._jac_const.copy()
        j[4:6, 0:2] -= kb * self._inv_mr
        j[4:6, 2:4] += kb * self._inv_mr
        j[6:8, 0:2] += kb * self._inv_mh
        j[6:8, 2:4] -= kb * self._inv_mh
        return j

    def _constant_jacobian(self):
        """The part of the Jacobian that does not depend on the bearing force."""
        p = self.p
        cb = p.bearing_damping_n_s_m * np.eye(2)
        j = np.zeros((8, 8))
        j[0:4, 4:8] = np.eye(4)
        j[4:6, 4:6] = -cb * self._inv_mr
        j[4:6, 6:8] = cb * self._inv_mr
        j[6:8, 2:4] = -p.support_stiffness_n_m * np.eye(2) * self._inv_mh
        j[6:8, 4:6] = cb * self._inv_mh
        j[6:8, 6:8] = (-cb - p.support_damping_n_s_m * np.eye(2)) * self._inv_mh
        return j

    def static_state(self):
        """State at the static equilibrium without the dent (housing on its support, bearing loaded).

        Returns copies (state (8,), bearing e (2,)).
        """
        if self._static is None:
            p = self.p
            e = self.state.displacement_m[:2]
            yh = -(p.rotor_mass_kg + p.housing_mass_kg) * p.gravity_m_s2 / p.support_stiffness_n_m
            self._static = (np.array([e[0], yh + e[1], 0.0, yh, 0.0, 0.0, 0.0, 0.0]), e.copy())
        return self._static[0].copy(), self._static[1].copy()

    def housing_resonance_hz(self) -> float:
        """Vertical housing-on-bearing natural frequency at the static equilibrium [Hz] (rotor held fixed)."""
        e = self.static_state()[1]
        _, _, (_, _, kyy) = self.bearing.forces_n(e[0], e[1], 0.0, with_stiffness=True, with_dent=False,
                                                  e_z_m=self.state.displacement_m[2])
        k = float(kyy) + self.p.support_stiffness_n_m
        return math.sqrt(k / self.p.housing_mass_kg) / TWO_PI

    def max_step_s(self) -> float:
        """Largest integrator step that cannot jump over the dent or its edges [s]."""
        bp = 1.0 / (self.z * self.ftf * self.p.reference_speed_hz)
        if not self._dent:
            return bp / 50.0
        ramp = self.bearing.dent_entry_ramp_rad
        edge = ramp if ramp > 0.0 else self._a / 10.0
        return min(bp / 50.0, 0.5 * edge / self.cage_speed_rad_s)

    def integrate(self, progress=None):
        """Integrate from the static equilibrium; return (record times [s], relative displacement (2, N) [m], steps).

        The recording starts after ``settle_time_s`` rounded up to whole ball-pass periods, so t = 0 of the
        recording is again a cage angle that is a multiple of the ball pitch (phases refer to cage angle 0).
        """
        p = self.p
        f_bp = self.z * self.ftf * p.reference_speed_hz
        t_bp = 1.0 / f_bp
        n_settle = max(1, math.ceil(p.settle_time_s / t_bp - 1e-9))
        t0 = n_settle * t_bp
        n_rec = p.record_cage_periods * self.z
        n = n_rec * p.samples_per_ball_pass
        t_rec = n_rec * t_bp
        t_eval = t0 + t_rec * np.arange(n) / n
        y0, _ = self.static_state()
        atol = np.r_[np.full(4, p.atol_m), np.full(4, p.atol_m * 1e3)]
        # LSODA through odeint: the same integrator as solve_ivp(method="LSODA"), but its Fortran driver steps
        # without a Python round trip per step (about 2x faster here); output by its own interpolation. Imported
        # here: only the paper's 4-DOF model integrates, and scipy.integrate is slow to import.
        from scipy.integrate import odeint

        y, info = odeint(self.rhs, y0, np.r_[0.0, t_eval], Dfun=self.jacobian, tfirst=True, rtol=p.rtol,
                         atol=atol, hmax=self.max_step_s(), mxstep=10_000_000, full_output=True)
        if info["message"] != "Integration successful.":
            raise RuntimeError(f"4-DOF integration failed: {info['message']}")
        y = y[1:].T
        n_eval = int(info["nfe"][-1])
        rel = np.vstack([y[1] - y[3], y[0] - y[2]])                   # vertical, horizontal
        return t_eval - t0, rel, n_eval


def compute_excitation(bearing: Bearing, params: FourDofParameters, axial_load_n: float = 0.0,
                       location: str = "") -> Excitation:
    """Integrate the 4-DOF model and transform it into BPFO orders (DC, A_k, phi_k, vertical and horizontal).

    Parameters
    ----------
    bearing : Bearing
        The bearing with its dent (or healthy).
    params : FourDofParameters
        The bearing's radial load is ``rotor_mass_kg x gravity_m_s2``.
    axial_load_n : float
        Axial load [N] (axial displacement held at its static value under it).
    location : str
        ``"de"``/``"nde"``, recorded in the result.

    Returns
    -------
    Excitation
    """
    t_start = time.perf_counter()
    if bearing.defect_set.moving:
        raise ValueError(f"the 4-DOF excitation models {_periodic_words()} dents only (excitation.method = "
                         f"'quasi_static' takes every kind)")
    model = FourDofModel(bearing, params, axial_load_n)
    t, rel, n_steps = model.integrate()
    all_orders, amp, pha, dc, off, keep = _orders_from_record(rel, params.record_cage_periods * model.z,
                                                              params.relative_amplitude_threshold, params.max_order)
    return Excitation(
        bpfo_per_hz=bearing.fault_multipliers().bpfo,
        reference_speed_hz=params.reference_speed_hz,
        orders=all_orders[keep],
        amplitude_m={"vertical": amp[0, keep], "horizontal": amp[1, keep]},
        phase_rad={"vertical": pha[0, keep], "horizontal": pha[1, keep]},
        dc_m={"vertical": float(dc[0]), "horizontal": float(dc[1])},
        peak_to_peak_m={"vertical": float(np.ptp(rel[0])), "horizontal": float(np.ptp(rel[1]))},
        clearance_m=bearing.geometry.diametral_clearance_m,
        all_orders=all_orders,
        all_amplitude_m={"vertical": amp[0], "horizontal": amp[1]},
        all_phase_rad={"vertical": pha[0], "horizontal": pha[1]},
        time_s=t,
        relative_displacement_m=rel,
        off_order_fraction=off,
        static_displacement_m=model.static_state()[1],
        wall_time_s=time.perf_counter() - t_start,
        n_steps=n_steps,
        housing_resonance_hz=model.housing_resonance_hz(),
        method="four_dof",
        bearing=location,
        radial_load_n=params.rotor_mass_kg * params.gravity_m_s2,
        axial_load_n=float(axial_load_n),
        state=model.state,
        n_balls=model.z,
        rates_per_hz=rates_per_hz(bearing.fault_multipliers()),
    )
