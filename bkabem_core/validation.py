"""Validation of BKA-BEM against the time-domain reference (TDSM) of the same case at the same speed.

``validate(case, speed_hz, duration_s, improvement)`` integrates the full nonlinear model
(:mod:`bkabem_core.tdsm`), discards the start transient, takes the exact BPFO-order spectrum of the recording
(whole BPFO periods, no window) and compares it order by order with the BKA-BEM spectrum
(:class:`bkabem_core.harmonic.BkaBem`) at the DE and NDE rotor nodes, vertical and horizontal. Both wall times
are measured in the same process.

Improvements (``improvement=``), beyond the paper's plain method (which stays the reference result and the
default). The first three keep BKA-BEM's structure (4-DOF excitation at 1 Hz, one linear solve per order):

``"nde"``
    Adds the healthy NDE bearing's own ball-passage excitation: the 4-DOF model of the NDE bearing under its
    static load (lever rule of the FE), applied at the NDE bearing exactly as the DE excitation is at the DE
    bearing. The responses add (linear FE, same orders, same time origin).
``"consistent"``
    Makes the linear model consistent with the nonlinear bearing it stands for: the FE bearing elements get the
    ball-pitch-averaged tangent stiffness of the Sopanen bearing (with the case's clearance) at the FE's static
    bearing load, and the bearing damper of the nonlinear model (``[excitation] bearing_damping_n_s_m``) instead
    of the Table-1 values; the 4-DOF excitation model carries the DE bearing's static load of the FE (rotor
    mass = load / g) instead of the whole rotor weight.
``"full"``
    Both of the above.

The last two replace the 4-DOF excitation by the complete (complex, two-sided) spectra of the ball forces *and*
ball stiffnesses of both bearings, evaluated at the static equilibrium of the FE (:meth:`Tdsm.harmonic_balance`):

``"parametric"``
    The linear time-periodic model: ball-force spectrum as excitation, ball-passage and dent stiffness
    variation coupling the orders (Hill's method, one linear solve of 4 (2K+1) unknowns).
``"hbm"``
    The nonlinear harmonic balance of the same equations (Newton from the parametric solution): the exact
    periodic steady state of the TDSM's model, computed in the frequency domain.

The paper's own suggestion, a "full spectrum" (complex ``x + i y``, forward and backward whirl) excitation,
is *not* an option here because for BKA-BEM's linear solve it is an identity: the implementation already
applies both directions with their phases in one complex solve, and splitting the excitation into forward and
backward components gives the same response to round-off (``tests/test_validation.py`` shows it). The
amplitude errors have other causes; docs/validation.md lists them.

Units: SI (m, s, N). JSON field names: see :meth:`ValidationResult.to_dict`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .case import Case
from .excitation import compute_excitation
from .harmonic import LOCATIONS as BKABEM_LOCATIONS
from .harmonic import BkaBem
from .tdsm import DIRECTIONS, LOCATIONS, Tdsm

__all__ = ["validate", "plot_validation", "ValidationResult", "ImprovedBkaBem", "IMPROVEMENTS",
           "DEFAULT_SPEED_HZ", "DEFAULT_DURATION_S", "consistent_bearing_stiffness"]

IMPROVEMENTS = ("nde", "consistent", "full", "parametric", "hbm")
#: Default running speed [Hz]; docs/validation.md explains the choice.
DEFAULT_SPEED_HZ = 30.0
#: Default recorded TDSM time after the start transient [s].
DEFAULT_DURATION_S = 0.2
#: Default discarded start transient: None = adaptive (Tdsm.run: settle until the order spectrum is steady).
DEFAULT_SETTLE_S = None
#: Default largest TDSM step: None = Tdsm's rule (10 us, or a quarter of a dent-edge crossing if shorter;
#: step-size study in docs/validation.md).
DEFAULT_MAX_STEP_S = None
COMPARED_LOCATIONS = ("de_rotor", "nde_rotor")
N_LARGEST = 5


# --------------------------------------------------------------------------- BKA-BEM variants
def static_bearing_loads_n(case: Case) -> dict:
    """Static force of each bearing on its rotor node under gravity, ``name -> (F_x, F_y)`` [N].

    Two bearings make the rotor statically determinate, so this lever-rule result of the linear FE is also the
    load of the nonlinear model (tests/test_tdsm.py checks it).
    """
    from .rotor import rotor_from_case

    g = float(case.raw["excitation"]["gravity_m_s2"])
    loads = rotor_from_case(case.raw).static_bearing_loads_n(g)
    return {b: np.array(loads[b], dtype=float) for b in ("de", "nde")}


def consistent_bearing_stiffness(case: Case, n_angles: int = 64) -> dict:
    """Ball-pitch-averaged tangent stiffness ``(k_xx, k_yy)`` [N/m] of each bearing at its static load.

    The Sopanen bearing with the case's clearance, at the static equilibrium under the FE's static bearing
    load; the tangent ``-dF/de`` is averaged over one ball pitch of cage angle (the ball-passage variation is
    the parametric part the linear model cannot hold).
    """
    loads = static_bearing_loads_n(case)
    out = {}
    for b in ("de", "nde"):
        brg = case.bearing(b)
        e = brg.static_equilibrium_m(-loads[b][0], -loads[b][1])
        theta = np.arange(n_angles) * (2.0 * math.pi / brg.geometry.n_balls / n_angles)
        _, _, (kxx, _, kyy) = brg.forces_n(e[0], e[1], theta, with_stiffness=True, with_dent=False)
        out[b] = (float(np.mean(kxx)), float(np.mean(kyy)))
    return out


class ImprovedBkaBem:
    """BKA-BEM, plain or with an improvement, through the public :class:`BkaBem` API only.

    Parameters
    ----------
    case : Case
    improvement : None or one of IMPROVEMENTS

    Attributes
    ----------
    models : list of BkaBem
        One model per excited bearing (their responses add).
    case : Case
        The case the models are built from (the overridden one for ``"consistent"``).
    preparation_time_s : float
        Wall time of the set-up (4-DOF excitation(s), FE, solver) [s].
    """

    def __init__(self, case: Case, improvement: str | None = None, excitation=None):
        if improvement not in (None,) + IMPROVEMENTS:
            raise ValueError(f"improvement: one of {', '.join(IMPROVEMENTS)} or None (got {improvement!r})")
        t0 = time.perf_counter()
        self.improvement = improvement
        self.original_case = case
        self.details = {}
        self.last_solution = None
        if improvement in ("parametric", "hbm"):
            self.case = case
            self.models = []
            self.orders = np.arange(1, int(case.raw["excitation"]["max_order"] or 50) + 1)
            self.preparation_time_s = time.perf_counter() - t0
            return
        consistent = improvement in ("consistent", "full")
        nde = improvement in ("nde", "full")
        g = float(case.raw["excitation"]["gravity_m_s2"])
        loads = static_bearing_loads_n(case)
        if consistent:
            kc = consistent_bearing_stiffness(case)
            cb = float(case.raw["excitation"]["bearing_damping_n_s_m"])
            ov = {"excitation.rotor_mass_kg": float(abs(loads[case.faulty_bearing][1]) / g)}
            for b in ("de", "nde"):
                ov[f"bearings.{b}.stiffness_horizontal_n_m"] = kc[b][0]
                ov[f"bearings.{b}.stiffness_vertical_n_m"] = kc[b][1]
                ov[f"bearings.{b}.damping_horizontal_n_s_m"] = cb
                ov[f"bearings.{b}.damping_vertical_n_s_m"] = cb
            case = case.with_overrides(ov)
            self.details["overrides"] = ov
            excitation = None
        self.case = case
        main = BkaBem(case, excitation=excitation)
        self.models = [main]
        self.orders = main.orders
        if nde:
            healthy = "nde" if case.faulty_bearing == "de" else "de"
            params = dataclasses.replace(case.four_dof_parameters(),
                                         rotor_mass_kg=float(abs(loads[healthy][1]) / g))
            ex = compute_excitation(case.bearing(healthy), params)
            ex = _on_orders(ex, main.orders)
            routed = case.with_overrides({"dent.bearing": healthy})   # BkaBem excites the "faulty" bearing
            self.models.append(BkaBem(routed, excitation=ex))
            self.details["second_bearing"] = {"bearing": healthy, "rotor_mass_kg": params.rotor_mass_kg}
        self.preparation_time_s = time.perf_counter() - t0

    def spectrum(self, speed_hz: float):
        """(orders, frequency_hz (K,), displacement complex (K, 4, 2), dc_m (4, 2)) at a shaft speed [Hz]."""
        if self.improvement in ("parametric", "hbm"):
            sol = Tdsm(self.case, speed_hz).harmonic_balance(n_orders=int(self.orders[-1]),
                                                             linearised=self.improvement == "parametric")
            self.last_solution = sol
            if not sol.converged:
                raise RuntimeError(f"harmonic balance did not converge at {speed_hz} Hz "
                                   f"(last update {sol.residual_m:.2e} m)")
            freq = self.orders * sol.bpfo_hz
            return self.orders, freq, sol.complex_amplitude[self.orders - 1], sol.dc_m
        sps = [m.spectrum(speed_hz) for m in self.models]
        disp = sum(s.displacement for s in sps)
        dc = sum(s.dc_m for s in sps)
        return sps[0].orders, sps[0].frequency_hz, disp, dc


def _on_orders(ex, orders):
    """The excitation restricted to (or padded to) the given orders (all resolved orders are kept in ``all_*``)."""
    orders = np.asarray(orders, dtype=int)
    amp, pha = {}, {}
    for d in DIRECTIONS:
        a = np.zeros(orders.size)
        p = np.zeros(orders.size)
        ok = orders <= ex.all_orders[-1]
        a[ok] = ex.all_amplitude_m[d][orders[ok] - 1]
        p[ok] = ex.all_phase_rad[d][orders[ok] - 1]
        amp[d], pha[d] = a, p
    return dataclasses.replace(ex, orders=orders, amplitude_m=amp, phase_rad=pha)


# --------------------------------------------------------------------------- result
@dataclass
class ValidationResult:
    """TDSM against BKA-BEM at one speed.

    Attributes
    ----------
    case, case_hash : str
    speed_hz, bpfo_hz : float
    improvement : str or None
    orders : ndarray (K,)
        BPFO orders compared (BKA-BEM's kept orders).
    frequency_hz : ndarray (K,)
        ``orders x BPFO`` [Hz].
    tdsm_amplitude, bkabem_amplitude, improved_amplitude : ndarray (K, 2, 2)
        Amplitudes [m] at COMPARED_LOCATIONS x DIRECTIONS (improved: None without an improvement).
    tdsm_frequency_hz : ndarray (K, 2, 2)
        Peak frequency found in the (Hann-windowed) TDSM spectrum near each order [Hz].
    dc : dict
        ``{"tdsm": (2, 2), "bkabem": (2, 2), "improved": ...}`` mean displacement [m]; see ``to_dict``.
    relative_dc : dict
        Mean rotor-minus-housing displacement at each bearing ``(2 bearings, 2 directions)`` [m].
    wall_time_s : dict
        ``tdsm`` (integration of the run), ``tdsm_setup``, ``bkabem_spectrum`` (median of repeated calls),
        ``bkabem_preparation`` (one-time), and the same for the improvement.
    tdsm_info : dict
        Step, steps, ms/step, Newton iterations, off-order fraction, steady-state check, interruption.
    """

    case: str
    case_hash: str
    speed_hz: float
    bpfo_hz: float
    improvement: str | None
    orders: np.ndarray
    frequency_hz: np.ndarray
    tdsm_amplitude: np.ndarray
    bkabem_amplitude: np.ndarray
    improved_amplitude: np.ndarray | None
    tdsm_frequency_hz: np.ndarray
    dc: dict
    relative_dc: dict
    wall_time_s: dict
    tdsm_info: dict
    tdsm_spectrum: dict = field(default_factory=dict, repr=False)

    # -- derived --
    @staticmethod
    def error_db(model, ref):
        with np.errstate(divide="ignore", invalid="ignore"):
            return 20.0 * np.log10(model / ref)

    @property
    def speed_ratio(self) -> float:
        """TDSM wall time over the BKA-BEM spectrum time (plain method, preparation excluded)."""
        return self.wall_time_s["tdsm"] / self.wall_time_s["bkabem_spectrum"]

    def largest_orders(self, li: int, di: int, n: int = N_LARGEST) -> np.ndarray:
        """Indices (into ``orders``) of the ``n`` largest TDSM orders at location ``li``, direction ``di``."""
        return np.argsort(self.tdsm_amplitude[:, li, di])[::-1][:n]

    def max_error_db(self, which: str = "bkabem", li: int = 0, n: int = N_LARGEST) -> dict:
        """Largest |error| [dB] over the ``n`` largest TDSM orders, per direction."""
        amp = self.bkabem_amplitude if which == "bkabem" else self.improved_amplitude
        out = {}
        for di, d in enumerate(DIRECTIONS):
            idx = self.largest_orders(li, di, n)
            out[d] = float(np.max(np.abs(self.error_db(amp[idx, li, di], self.tdsm_amplitude[idx, li, di]))))
        return out

    def to_dict(self) -> dict:
        """JSON-ready result.

        Per location (``de_rotor``, ``nde_rotor``) and direction (``vertical``, ``horizontal``): ``orders``,
        ``frequency_hz``, ``tdsm_amplitude_m``, ``bkabem_amplitude_m``, ``error_db`` (BKA-BEM vs TDSM),
        ``tdsm_frequency_hz``, ``dc_m`` {tdsm, bkabem[, improved]} (mean absolute displacement of the node: the
        TDSM's includes the static sag under gravity, BKA-BEM's is its DC response to the excitation's DC, see
        docs/validation.md), ``largest_orders`` (the N_LARGEST largest TDSM orders) and
        ``max_abs_error_db_largest``; with an improvement also ``improved_amplitude_m``, ``improved_error_db``,
        ``improved_max_abs_error_db_largest``. Top level: ``wall_time_s`` {tdsm, bkabem_spectrum,
        bkabem_preparation, ...}, ``speed_ratio`` (TDSM / BKA-BEM spectrum), ``bearing_relative_dc_m``, ``tdsm``
        (integration details).
        """
        out = {"case": self.case, "case_hash": self.case_hash, "speed_hz": self.speed_hz, "bpfo_hz": self.bpfo_hz,
               "improvement": self.improvement, "n_largest": N_LARGEST}
        for li, loc in enumerate(COMPARED_LOCATIONS):
            out[loc] = {}
            for di, d in enumerate(DIRECTIONS):
                t = self.tdsm_amplitude[:, li, di]
                b = self.bkabem_amplitude[:, li, di]
                big = self.largest_orders(li, di)
                e = self.error_db(b, t)
                entry = {
                    "orders": [int(k) for k in self.orders],
                    "frequency_hz": self.frequency_hz.tolist(),
                    "tdsm_amplitude_m": _json_list(t),
                    "bkabem_amplitude_m": _json_list(b),
                    "error_db": _json_list(e),
                    "tdsm_frequency_hz": _json_list(self.tdsm_frequency_hz[:, li, di]),
                    "dc_m": {k: float(v[li, di]) for k, v in self.dc.items()},
                    "largest_orders": [int(self.orders[i]) for i in big],
                    "max_abs_error_db_largest": float(np.max(np.abs(e[big]))),
                }
                if self.improved_amplitude is not None:
                    im = self.improved_amplitude[:, li, di]
                    ei = self.error_db(im, t)
                    entry["improved_amplitude_m"] = _json_list(im)
                    entry["improved_error_db"] = _json_list(ei)
                    entry["improved_max_abs_error_db_largest"] = float(np.nanmax(np.abs(ei[big])))
                out[loc][d] = entry
        out["bearing_relative_dc_m"] = {
            b: {d: {k: float(v[bi, di]) for k, v in self.relative_dc.items()} for di, d in enumerate(DIRECTIONS)}
            for bi, b in enumerate(("de", "nde"))}
        out["wall_time_s"] = dict(self.wall_time_s)
        out["speed_ratio"] = self.speed_ratio
        out["speed_ratio_including_preparation"] = (
            self.wall_time_s["tdsm"] / (self.wall_time_s["bkabem_spectrum"] + self.wall_time_s["bkabem_preparation"]))
        out["tdsm"] = dict(self.tdsm_info)
        return out

    def summary(self) -> str:
        """Human-readable table of the largest orders at the DE rotor node (and the headline numbers)."""
        lines = [f"validation of {self.case} at {self.speed_hz:g} Hz (BPFO {self.bpfo_hz:.2f} Hz)"
                 + (f", improvement {self.improvement}" if self.improvement else "")]
        for li, loc in enumerate(COMPARED_LOCATIONS):
            for di, d in enumerate(DIRECTIONS):
                lines.append(f"  {loc} {d}: {N_LARGEST} largest TDSM orders")
                hdr = "    order  f [Hz]    TDSM [nm]  BKA-BEM [nm]  err [dB]"
                if self.improved_amplitude is not None:
                    hdr += "  improved [nm]  err [dB]"
                lines.append(hdr)
                for i in self.largest_orders(li, di):
                    t, b = self.tdsm_amplitude[i, li, di], self.bkabem_amplitude[i, li, di]
                    s = (f"    {self.orders[i]:5d} {self.frequency_hz[i]:8.1f} {t * 1e9:11.2f} {b * 1e9:13.2f}"
                         f" {self.error_db(b, t):9.2f}")
                    if self.improved_amplitude is not None:
                        im = self.improved_amplitude[i, li, di]
                        s += f" {im * 1e9:14.2f} {self.error_db(im, t):9.2f}"
                    lines.append(s)
        w = self.wall_time_s
        lines.append(f"  wall time: TDSM {w['tdsm']:.2f} s ({self.tdsm_info['steps']} steps, "
                     f"{self.tdsm_info['ms_per_step']:.3f} ms/step), BKA-BEM spectrum {w['bkabem_spectrum'] * 1e3:.2f} ms"
                     f" (+ {w['bkabem_preparation']:.2f} s one-time preparation); ratio {self.speed_ratio:.0f}x")
        if not self.tdsm_info.get("settled", True):
            lines.append("  NOTE: the TDSM start transient had not settled within the limit; see tdsm.settled")
        if self.tdsm_info.get("interrupted"):
            lines.append("  NOTE: the TDSM run was interrupted; the spectrum uses the periods recorded so far")
        return "\n".join(lines)


# --------------------------------------------------------------------------- validate
def _time_spectrum(model, speed_hz, repeats=7):
    times = []
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = model.spectrum(speed_hz)
        times.append(time.perf_counter() - t0)
    return out, float(np.median(times)), times


def validate(case: Case | None = None, speed_hz: float = DEFAULT_SPEED_HZ, duration_s: float = DEFAULT_DURATION_S,
             improvement: str | None = None, progress: bool = True, settle_s: float | None = DEFAULT_SETTLE_S,
             max_step_s: float | None = DEFAULT_MAX_STEP_S, hht_alpha: float = 0.0) -> ValidationResult:
    """Run the TDSM and BKA-BEM for the same case and speed and compare their spectra order by order.

    Parameters
    ----------
    case : Case, optional
        Default: the embedded case.
    speed_hz : float
        Shaft speed [Hz].
    duration_s : float
        TDSM time recorded after the start transient [s] (rounded up to whole BPFO periods).
    improvement : None or one of IMPROVEMENTS
        Also evaluate this improved BKA-BEM variant (the plain method is always reported).
    progress : bool
        tqdm progress bar for the TDSM run.
    settle_s : float or None
        Discarded start transient [s]; None = adaptive, until the order spectrum is steady (:meth:`Tdsm.run`; see
        docs/validation.md).
    max_step_s : float, optional
        Largest TDSM step [s] (default: the Tdsm rule).
    hht_alpha : float
        HHT-alpha of the TDSM integrator (0 = Newmark average acceleration).

    Returns
    -------
    ValidationResult

    Ctrl-C during the TDSM run stops it; the comparison then uses the whole BPFO periods recorded so far
    (``tdsm.interrupted`` is true in the result). If not even one period was recorded, KeyboardInterrupt is
    raised again.
    """
    case = Case.load() if case is None else case
    speed_hz = float(speed_hz)
    if not (math.isfinite(speed_hz) and speed_hz > 0):
        raise ValueError(f"speed_hz: must be > 0 (got {speed_hz})")
    if improvement not in (None,) + IMPROVEMENTS:
        raise ValueError(f"improvement: one of {', '.join(IMPROVEMENTS)} (got {improvement!r})")

    # BKA-BEM first (cheap), plain and improved
    plain = ImprovedBkaBem(case, None)
    (orders, freq, disp, dc_b), t_spec, _ = _time_spectrum(plain, speed_hz)
    imp_model = None
    if improvement is not None:
        imp_model = ImprovedBkaBem(case, improvement)
        (orders_i, _, disp_i, dc_i), t_spec_i, _ = _time_spectrum(
            imp_model, speed_hz, repeats=3 if improvement in ("parametric", "hbm") else 7)
        disp_i = _align(orders, orders_i, disp_i)

    # TDSM
    model = Tdsm(case, speed_hz, max_step_s=max_step_s, hht_alpha=hht_alpha)
    run = model.run(duration_s, settle_s=settle_s, progress=progress)
    if run.whole_periods < 1:
        raise KeyboardInterrupt("TDSM interrupted before one BPFO period was recorded")

    loc_idx = [LOCATIONS.index(l) for l in COMPARED_LOCATIONS]
    b_idx = [BKABEM_LOCATIONS.index(l) for l in COMPARED_LOCATIONS]
    k_all, x_t, dc_t_all = run.order_spectrum()
    if orders.max() > k_all.max():
        raise ValueError(f"max_step_s: the TDSM sampling resolves orders up to {k_all.max()} only "
                         f"(BKA-BEM uses up to {orders.max()})")
    tdsm_amp = np.abs(x_t[orders - 1][:, loc_idx, :])
    tdsm_freq = np.stack([np.stack([run.peak_frequencies_hz(orders, li, di) for di in range(2)], axis=1)
                          for li in loc_idx], axis=1)
    bk_amp = np.abs(disp[:, b_idx, :])
    im_amp = np.abs(disp_i[:, b_idx, :]) if improvement is not None else None

    dc = {"tdsm": dc_t_all[loc_idx], "bkabem": dc_b[b_idx]}
    _, _, dc_rel_t = run.order_spectrum(1, signal="bearing_relative")
    rel = lambda d: np.stack([d[BKABEM_LOCATIONS.index("de_rotor")] - d[BKABEM_LOCATIONS.index("de_housing")],
                              d[BKABEM_LOCATIONS.index("nde_rotor")] - d[BKABEM_LOCATIONS.index("nde_housing")]])
    relative_dc = {"tdsm": dc_rel_t, "bkabem": rel(dc_b)}
    if improvement is not None:
        dc["improved"] = dc_i[b_idx]
        relative_dc["improved"] = rel(dc_i)

    # steady-state check: the order amplitudes of the first and second half of the recording
    steady = None
    if run.whole_periods >= 2:
        half = run.whole_periods // 2
        per = run.steps_per_bpfo // run.record_every
        a1 = _order_amplitudes(run.displacement_m[:half * per], half, orders)[:, loc_idx]
        a2 = _order_amplitudes(run.displacement_m[half * per:2 * half * per], half, orders)[:, loc_idx]
        steady = {}
        for li, loc in enumerate(COMPARED_LOCATIONS):
            steady[loc] = {}
            for di, d in enumerate(DIRECTIONS):
                big = np.argsort(tdsm_amp[:, li, di])[::-1][:N_LARGEST]
                steady[loc][d] = float(np.max(np.abs(20 * np.log10(a2[big, li, di] / a1[big, li, di]))))
    off = run.off_order_fraction()[loc_idx]
    wall = {"tdsm": run.wall_time_s, "tdsm_setup": run.setup_time_s, "bkabem_spectrum": t_spec,
            "bkabem_preparation": plain.preparation_time_s}
    if improvement is not None:
        wall["improved_spectrum"] = t_spec_i
        wall["improved_preparation"] = imp_model.preparation_time_s
    info = {"step_s": run.step_s, "steps_per_bpfo": run.steps_per_bpfo, "steps": run.steps,
            "settle_s": run.settle_s, "recorded_s": run.time_s.size * run.step_s * run.record_every,
            "recorded_bpfo_periods": run.whole_periods, "ms_per_step": run.ms_per_step,
            "newton_iterations_mean": run.newton_iterations_mean,
            "newton_iterations_max": run.newton_iterations_max, "hht_alpha": hht_alpha,
            "interrupted": run.interrupted, "settled": bool(getattr(run, "settled", True)),
            "settle_mode": run.settings.get("settle"),
            "off_order_fraction": {loc: {d: float(off[li, di]) for di, d in enumerate(DIRECTIONS)}
                                   for li, loc in enumerate(COMPARED_LOCATIONS)},
            "half_vs_half_max_abs_db_largest": steady,
            "static_bearing_force_n": {b: v.tolist() for b, v in run.static.force_n.items()},
            "static_bearing_relative_m": {b: v.tolist() for b, v in run.static.relative_m.items()},
            "settings": run.settings}
    # continuous TDSM spectrum for the plot (Hann window, amplitude-corrected), DE/NDE rotor
    x = run.displacement_m[:, loc_idx, :]
    n = x.shape[0]
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft((x - x.mean(axis=0)) * w[:, None, None], axis=0)) * 2.0 / w.sum()
    f = np.fft.rfftfreq(n, run.step_s * run.record_every)
    keep = f <= 1.05 * freq.max()
    return ValidationResult(
        case=case.name, case_hash=case.case_hash, speed_hz=speed_hz, bpfo_hz=run.bpfo_hz, improvement=improvement,
        orders=orders, frequency_hz=freq, tdsm_amplitude=tdsm_amp, bkabem_amplitude=bk_amp,
        improved_amplitude=im_amp, tdsm_frequency_hz=tdsm_freq, dc=dc, relative_dc=relative_dc, wall_time_s=wall,
        tdsm_info=info, tdsm_spectrum={"frequency_hz": f[keep], "amplitude_m": spec[keep]})


def _json_list(x):
    """Floats for JSON; NaN/inf (an order one method does not have) become null."""
    return [float(v) if math.isfinite(v) else None for v in np.asarray(x, dtype=float)]


def _align(orders, orders_i, x_i):
    """x_i (K_i, ...) given at orders_i, re-indexed to orders (NaN where missing)."""
    out = np.full((len(orders),) + x_i.shape[1:], np.nan, dtype=x_i.dtype)
    pos = {int(k): i for i, k in enumerate(orders_i)}
    for j, k in enumerate(orders):
        if int(k) in pos:
            out[j] = x_i[pos[int(k)]]
    return out


def _order_amplitudes(x, periods, orders):
    spec = np.fft.rfft(x, axis=0) / x.shape[0]
    return 2.0 * np.abs(spec[np.asarray(orders) * periods])


# --------------------------------------------------------------------------- plot
def plot_validation(result: ValidationResult, png_path: str, extra: dict | None = None, max_order: int | None = 30) -> None:
    """TDSM and BKA-BEM spectra overlaid (paper Figs. 6 and 7) at the DE and NDE rotor nodes.

    Grey line: the TDSM displacement spectrum (Hann window). Black circles: TDSM at the BPFO orders (red dots:
    its five largest). Bars: BKA-BEM (plain), the result's improvement if any, and ``extra`` variants
    (``name -> amplitudes (K, 2, 2)`` at ``result.orders``). Log amplitude axis; orders up to ``max_order``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = result
    bars = [("BKA-BEM (paper)", r.bkabem_amplitude)]
    if r.improved_amplitude is not None:
        bars.append((f"BKA-BEM + {r.improvement}", r.improved_amplitude))
    for name, amp in (extra or {}).items():
        bars.append((name, np.asarray(amp)))
    if max_order is not None:                          # always show the largest TDSM orders
        max_order = max([max_order] + [int(r.orders[r.largest_orders(li, di)].max())
                                       for li in range(len(COMPARED_LOCATIONS)) for di in range(2)])
    keep = np.ones(r.orders.size, bool) if max_order is None else r.orders <= max_order
    f_max = r.frequency_hz[keep].max() + 0.5 * r.bpfo_hz
    fig, axes = plt.subplots(2, 2, figsize=(14, 8.5), constrained_layout=True, sharex=True)
    width = 0.8 * r.bpfo_hz / (len(bars) + 1)
    for li, loc in enumerate(COMPARED_LOCATIONS):
        for di, d in enumerate(DIRECTIONS):
            ax = axes[li, di]
            if r.tdsm_spectrum:
                f = r.tdsm_spectrum["frequency_hz"]
                sel = f <= f_max
                ax.plot(f[sel], r.tdsm_spectrum["amplitude_m"][sel, li, di] * 1e9, color="0.6", lw=0.6, zorder=3,
                        label="TDSM spectrum (Hann)")
            for bi, (name, amp) in enumerate(bars):
                off = (bi - 0.5 * (len(bars) - 1)) * width
                ax.bar(r.frequency_hz[keep] + off, amp[keep, li, di] * 1e9, width=width, color=f"C{bi}", alpha=0.85,
                       label=name, zorder=2)
            ax.plot(r.frequency_hz[keep], r.tdsm_amplitude[keep, li, di] * 1e9, "o", mfc="none", mec="k", ms=5,
                    zorder=4, label="TDSM at BPFO orders")
            big = r.largest_orders(li, di)
            ax.plot(r.frequency_hz[big], r.tdsm_amplitude[big, li, di] * 1e9, "o", color="C3", ms=3, zorder=5,
                    label=f"{N_LARGEST} largest TDSM orders")
            title = f"{loc}, {d}: plain within {r.max_error_db('bkabem', li)[d]:.1f} dB"
            if r.improved_amplitude is not None:
                title += f", +{r.improvement} {r.max_error_db('improved', li)[d]:.1f} dB"
            ax.set_yscale("log")
            top = np.nanmax(np.r_[r.tdsm_amplitude[keep, li, di], r.bkabem_amplitude[keep, li, di]]) * 1e9
            ax.set_ylim(top * 3e-4, top * 3)
            ax.set_xlim(0, f_max)
            ax.set(title=title, xlabel="frequency [Hz]", ylabel="displacement amplitude [nm]")
            ax.grid(alpha=0.3, which="both")
            if li == 0 and di == 0:
                ax.legend(fontsize=7, loc="lower left")
    fig.suptitle(f"{r.case}: TDSM vs BKA-BEM at {r.speed_hz:g} Hz (BPFO {r.bpfo_hz:.1f} Hz); "
                 f"TDSM {r.wall_time_s['tdsm']:.1f} s, BKA-BEM spectrum {r.wall_time_s['bkabem_spectrum'] * 1e3:.1f} ms "
                 f"({r.speed_ratio:.0f}x); errors over the {N_LARGEST} largest TDSM orders")
    fig.savefig(png_path, dpi=100)
    plt.close(fig)
