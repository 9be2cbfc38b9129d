"""Validation of BKA-BEM against the time-domain reference (TDSM) of the same machine at the same speed.

``validate(case, speed_hz, duration_s, improvement)`` integrates the full nonlinear model
(:mod:`bkabem_core.reference.tdsm`), discards the start transient, takes the exact BPFO-order spectrum of the recording
(whole BPFO periods, no window) and compares it order by order with BKA-BEM at the DE and NDE rotor and housing
nodes, vertical and horizontal, for the five largest orders of displacement and of acceleration. Both wall times
are measured in the same process.

Methods (:data:`METHODS`):

``"plain"``
    The paper's method on the consistent model, the default everywhere (:class:`bkabem_core.solve.harmonic.BkaBem`):
    each bearing's quasi-static excitation through its own linearised stiffness, one linear solve per order.
``"hill"``
    The improved method (:class:`bkabem_core.solve.improved.HillCorrection`): the same, with the bearings' time-varying
    stiffness (one harmonic-balance Newton step from the quasi-static path), at about the cost of a plain spectrum.
``"paper"``
    The paper's own choices on the same machine: Table 1's bearing stiffness and damping in the FE, the 4-DOF
    excitation with the whole 82 kg rotor on the faulty bearing only, Eq. 5 as printed, the cubic dent edge. Shows
    what the consistency changes buy.
``"four_dof"``
    The plain method with the paper's 4-DOF integration as the excitation (under each bearing's own load) instead
    of the quasi-static one: where the 4-DOF model's own dynamics take over.
``"hbm"``
    The nonlinear harmonic balance of the TDSM's own equations (:func:`bkabem_core.reference.periodic.harmonic_balance`):
    the exact periodic steady state, computed in the frequency domain (~0.1-0.5 s per speed).

Units: SI (m, s, N). JSON field names: see :meth:`ValidationResult.to_dict`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from bkabem_core.model.case import Case
from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS
from bkabem_core.reference.periodic import harmonic_balance
from bkabem_core.reference.tdsm import Tdsm
from bkabem_core.solve.harmonic import BkaBem, Spectrum
from bkabem_core.solve.improved import HillCorrection

__all__ = ["validate", "plot_validation", "ValidationResult", "make_method", "METHODS", "PAPER_OVERRIDES",
           "DEFAULT_SPEED_HZ", "DEFAULT_DURATION_S", "N_LARGEST", "validate_lines", "LineValidation"]

METHODS = ("plain", "hill", "paper", "four_dof", "hbm")
#: Default running speed [Hz]; docs/validation.md explains the choice.
DEFAULT_SPEED_HZ = 30.0
#: Default recorded TDSM time after the start transient [s].
DEFAULT_DURATION_S = 0.2
#: Default discarded start transient: None = adaptive (Tdsm.run: settle until the order spectrum is steady).
DEFAULT_SETTLE_S = None
N_LARGEST = 5
QUANTITIES = ("displacement", "acceleration")
#: The paper's configuration as case overrides (the machine itself is unchanged).
PAPER_OVERRIDES = {"bearings.de.linearisation": "table", "bearings.nde.linearisation": "table",
                   "excitation.method": "four_dof", "excitation.load": "rotor_weight",
                   "excitation.bearings": "faulty", "excitation.force": "paper", "defects.0.edge": "cubic"}


# --------------------------------------------------------------------------- methods
class _Method:
    """A BKA-BEM variant: ``spectrum(speed_hz) -> Spectrum`` and its one-time ``preparation_time_s``."""

    def __init__(self, name: str, case: Case, plain: BkaBem | None = None):
        t0 = time.perf_counter()
        self.name = name
        self.case = case
        self.last_solution = None
        if name == "plain":
            self.model = plain if plain is not None else BkaBem(case, baseline=False)
        elif name == "hill":
            self.model = plain if plain is not None else BkaBem(case, baseline=False)
            self.hill = HillCorrection(self.model)
        elif name == "paper":
            self.model = BkaBem(case.with_overrides(PAPER_OVERRIDES), baseline=False)
        elif name == "four_dof":
            self.model = BkaBem(case.with_overrides({"excitation.method": "four_dof"}), baseline=False)
        elif name == "hbm":
            self.model = plain if plain is not None else BkaBem(case, baseline=False)
        else:
            raise ValueError(f"method: one of {', '.join(METHODS)} (got {name!r})")
        self.preparation_time_s = time.perf_counter() - t0
        if plain is not None and name in ("plain", "hill", "hbm"):
            self.preparation_time_s += sum(v for k, v in plain.preparation_time_s.items() if k != "total")

    @property
    def orders(self) -> np.ndarray:
        return self.model.orders

    def spectrum(self, speed_hz: float) -> Spectrum:
        if self.name == "hill":
            return self.hill.spectrum(speed_hz)
        if self.name == "hbm":
            tm = Tdsm(self.case, speed_hz, machine=self.model.machine)
            sel = np.zeros((12, tm.ndof))
            sel[:4] = tm.B.T
            sel[np.arange(4, 12), tm.out_dofs.reshape(-1)] = 1.0
            basis = self.model.basis.with_ports(tm.B, sel) if tm.rotor.ndof == self.model.rotor.ndof else None
            sol = harmonic_balance(tm, n_orders=int(self.orders.max()), n_time=4096, basis=basis)
            self.last_solution = sol
            if not sol.converged:
                raise RuntimeError(f"harmonic balance did not converge at {speed_hz} Hz "
                                   f"(last update {sol.residual_m:.2e} m)")
            return Spectrum(speed_hz=float(speed_hz), orders=self.orders.copy(),
                            frequency_hz=self.orders * self.model.bpfo_per_hz * speed_hz,
                            displacement=sol.complex_amplitude[self.orders - 1], dc_m=sol.dc_m,
                            fault_frequencies_hz=self.model.fault_multipliers.at_speed(speed_hz))
        return self.model.spectrum(speed_hz)


def make_method(name: str, case: Case, plain: BkaBem | None = None) -> _Method:
    """The BKA-BEM variant ``name`` (:data:`METHODS`) of a case; ``plain`` reuses a model made already."""
    return _Method(name, case, plain)


# --------------------------------------------------------------------------- result
@dataclass
class ValidationResult:
    """TDSM against BKA-BEM at one speed.

    Attributes
    ----------
    case, case_hash : str
    speed_hz, bpfo_hz : float
    improvement : str or None
        The variant compared besides the plain method.
    orders : ndarray (K,)
        BPFO orders compared (BKA-BEM's orders).
    frequency_hz : ndarray (K,)
        ``orders x BPFO`` [Hz].
    tdsm : ndarray complex (K, 4, 2)
        TDSM complex displacement amplitudes [m] at LOCATIONS x DIRECTIONS.
    methods : dict name -> ndarray complex (K, 4, 2)
        The same from each BKA-BEM variant (``"plain"`` always).
    tdsm_frequency_hz : ndarray (K, 4, 2)
        Peak frequency found in the (Hann-windowed) TDSM spectrum near each order [Hz].
    dc : dict
        Mean displacement (4, 2) [m]: ``"tdsm"`` (absolute: static sag included) and per method.
    relative_dc : dict
        Mean rotor-minus-housing displacement at each bearing ``(2 bearings, 2 directions)`` [m].
    wall_time_s : dict
        ``tdsm`` (the run), ``tdsm_setup``, and per method ``<name>_spectrum`` (median of repeated calls) and
        ``<name>_preparation`` (one-time).
    tdsm_info : dict
        Step, steps, ms/step, Newton iterations, off-order fraction, steady-state check, settle time, interruption.
    """

    case: str
    case_hash: str
    speed_hz: float
    bpfo_hz: float
    improvement: str | None
    orders: np.ndarray
    frequency_hz: np.ndarray
    tdsm: np.ndarray
    methods: dict
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
            return 20.0 * np.log10(np.abs(model) / np.abs(ref))

    def amplitude(self, which: str, quantity: str = "displacement") -> np.ndarray:
        """|X| (K, 4, 2) of ``"tdsm"`` or a method, as displacement [m] or acceleration [m/s^2]."""
        x = self.tdsm if which == "tdsm" else self.methods[which]
        a = np.abs(x)
        if quantity == "acceleration":
            a = a * (2.0 * math.pi * self.frequency_hz)[:, None, None] ** 2
        return a

    @property
    def speed_ratio(self) -> float:
        """TDSM wall time over the plain BKA-BEM spectrum time (preparation excluded)."""
        return self.wall_time_s["tdsm"] / self.wall_time_s["plain_spectrum"]

    def largest_orders(self, li: int, di: int, quantity: str = "displacement", n: int = N_LARGEST) -> np.ndarray:
        """Indices (into ``orders``) of the ``n`` largest TDSM orders at location ``li``, direction ``di``."""
        return np.argsort(self.amplitude("tdsm", quantity)[:, li, di])[::-1][:n]

    def max_error_db(self, which: str = "plain", quantity: str = "displacement") -> np.ndarray:
        """Largest |error| [dB] over the ``N_LARGEST`` largest TDSM orders, (4 locations, 2 directions)."""
        out = np.zeros((len(LOCATIONS), len(DIRECTIONS)))
        for li in range(len(LOCATIONS)):
            for di in range(len(DIRECTIONS)):
                idx = self.largest_orders(li, di, quantity)
                out[li, di] = float(np.max(np.abs(self.error_db(self.methods[which][idx, li, di],
                                                                 self.tdsm[idx, li, di]))))
        return out

    def to_dict(self) -> dict:
        """JSON-ready result.

        Per location (``de_rotor``, ``de_housing``, ``nde_rotor``, ``nde_housing``) and direction
        (``vertical``, ``horizontal``): ``orders``, ``frequency_hz``, ``tdsm_amplitude_m``, ``bkabem_amplitude_m``,
        ``error_db`` (plain BKA-BEM vs TDSM), ``tdsm_frequency_hz``, ``dc_m`` {tdsm, plain[, improved]} (mean
        absolute displacement of the node: the TDSM's includes the static sag under gravity, BKA-BEM's is its DC
        response to the excitations' DC), ``largest_orders`` and ``max_abs_error_db_largest`` (the N_LARGEST
        largest TDSM orders of displacement), ``largest_orders_acceleration`` and
        ``max_abs_error_db_largest_acceleration`` (the same for acceleration); with an improvement also
        ``improved_amplitude_m``, ``improved_error_db``, ``improved_max_abs_error_db_largest`` and
        ``improved_max_abs_error_db_largest_acceleration``. Top level: ``wall_time_s``, ``speed_ratio`` (TDSM /
        BKA-BEM spectrum), ``bearing_relative_dc_m``, ``tdsm`` (integration details).
        """
        out = {"case": self.case, "case_hash": self.case_hash, "speed_hz": self.speed_hz, "bpfo_hz": self.bpfo_hz,
               "improvement": self.improvement, "n_largest": N_LARGEST, "methods": sorted(self.methods)}
        t_amp = self.amplitude("tdsm")
        for li, loc in enumerate(LOCATIONS):
            out[loc] = {}
            for di, d in enumerate(DIRECTIONS):
                t = t_amp[:, li, di]
                b = np.abs(self.methods["plain"][:, li, di])
                big = self.largest_orders(li, di)
                big_a = self.largest_orders(li, di, "acceleration")
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
                    "largest_orders_acceleration": [int(self.orders[i]) for i in big_a],
                    "max_abs_error_db_largest_acceleration": float(np.max(np.abs(e[big_a]))),
                }
                if self.improvement is not None:
                    im = np.abs(self.methods[self.improvement][:, li, di])
                    ei = self.error_db(im, t)
                    entry["improved_amplitude_m"] = _json_list(im)
                    entry["improved_error_db"] = _json_list(ei)
                    entry["improved_max_abs_error_db_largest"] = float(np.nanmax(np.abs(ei[big])))
                    entry["improved_max_abs_error_db_largest_acceleration"] = float(np.nanmax(np.abs(ei[big_a])))
                out[loc][d] = entry
        out["bearing_relative_dc_m"] = {
            b: {d: {k: float(v[bi, di]) for k, v in self.relative_dc.items()} for di, d in enumerate(DIRECTIONS)}
            for bi, b in enumerate(("de", "nde"))}
        out["wall_time_s"] = dict(self.wall_time_s)
        out["speed_ratio"] = self.speed_ratio
        out["speed_ratio_including_preparation"] = (
            self.wall_time_s["tdsm"] / (self.wall_time_s["plain_spectrum"] + self.wall_time_s["plain_preparation"]))
        out["tdsm"] = dict(self.tdsm_info)
        return out

    def summary(self) -> str:
        """Human-readable table of the largest orders (and the headline numbers)."""
        imp = self.improvement
        lines = [f"validation of {self.case} at {self.speed_hz:g} Hz (BPFO {self.bpfo_hz:.2f} Hz)"
                 + (f", improvement {imp}" if imp else "")]
        t_amp = self.amplitude("tdsm")
        for li, loc in enumerate(LOCATIONS):
            for di, d in enumerate(DIRECTIONS):
                lines.append(f"  {loc} {d}: {N_LARGEST} largest TDSM orders (displacement)")
                hdr = "    order  f [Hz]    TDSM [nm]  BKA-BEM [nm]  err [dB]"
                if imp:
                    hdr += f"  {imp} [nm]  err [dB]"
                lines.append(hdr)
                for i in self.largest_orders(li, di):
                    t, b = t_amp[i, li, di], abs(self.methods["plain"][i, li, di])
                    s = (f"    {self.orders[i]:5d} {self.frequency_hz[i]:8.1f} {t * 1e9:11.2f} {b * 1e9:13.2f}"
                         f" {self.error_db(b, t):9.2f}")
                    if imp:
                        im = abs(self.methods[imp][i, li, di])
                        s += f" {im * 1e9:11.2f} {self.error_db(im, t):9.2f}"
                    lines.append(s)
        w = self.wall_time_s
        lines.append(f"  wall time: TDSM {w['tdsm']:.2f} s ({self.tdsm_info['steps']} steps, "
                     f"{self.tdsm_info['ms_per_step']:.3f} ms/step, settled after {self.tdsm_info['settle_s']:.3f} s), "
                     f"BKA-BEM spectrum {w['plain_spectrum'] * 1e3:.2f} ms (+ {w['plain_preparation']:.2f} s one-time "
                     f"preparation); ratio {self.speed_ratio:.0f}x")
        if imp:
            lines.append(f"  {imp}: {w[imp + '_spectrum'] * 1e3:.2f} ms per speed "
                         f"(+ {w[imp + '_preparation']:.2f} s preparation)")
        if not self.tdsm_info.get("settled", True):
            lines.append("  NOTE: the TDSM start transient had not settled within the limit; see tdsm.settled")
        if self.tdsm_info.get("interrupted"):
            lines.append("  NOTE: the TDSM run was interrupted; the spectrum uses the periods recorded so far")
        return "\n".join(lines)


def _json_list(x):
    """Floats for JSON; NaN/inf (an order one method does not have) become null."""
    return [float(v) if math.isfinite(v) else None for v in np.asarray(x, dtype=float)]


def _order_amplitudes(x, periods, orders):
    spec = np.fft.rfft(x, axis=0) / x.shape[0]
    return 2.0 * np.abs(spec[np.asarray(orders) * periods])


# --------------------------------------------------------------------------- validate
def _time_spectrum(method, speed_hz, repeats=7):
    times = []
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = method.spectrum(speed_hz)
        times.append(time.perf_counter() - t0)
    return out, float(np.median(times))


def validate(case: Case | None = None, speed_hz: float = DEFAULT_SPEED_HZ, duration_s: float = DEFAULT_DURATION_S,
             improvement: str | None = "hill", progress: bool = True, settle_s: float | None = DEFAULT_SETTLE_S,
             max_step_s: float | None = None, extra: tuple = (), plain: BkaBem | None = None) -> ValidationResult:
    """Run the TDSM and BKA-BEM for the same case and speed and compare their spectra order by order.

    Parameters
    ----------
    case : Case, optional
        Default: the embedded case.
    speed_hz : float
        Shaft speed [Hz].
    duration_s : float
        TDSM time recorded after the start transient [s] (rounded up to whole BPFO periods).
    improvement : None or one of METHODS
        Also evaluate this variant (default ``"hill"``; the plain method is always reported).
    progress : bool
        tqdm progress bar for the TDSM run.
    settle_s : float or None
        Discarded start transient [s]; None = adaptive, until the order spectrum is steady (:meth:`Tdsm.run`).
    max_step_s : float, optional
        Largest TDSM step [s] (default: the Tdsm rule).
    extra : tuple of str
        Further variants to evaluate (``result.methods``).
    plain : BkaBem, optional
        A plain model of this case made already (its machine is shared with the TDSM).

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
    names = ["plain"] + [n for n in ([improvement] if improvement else []) + list(extra) if n != "plain"]
    for n in names:
        if n not in METHODS:
            raise ValueError(f"improvement: one of {', '.join(METHODS)} (got {n!r})")
    plain_model = plain if plain is not None else BkaBem(case, baseline=False)
    if not plain_model.is_order_set:
        raise ValueError("validate: the order-by-order TDSM comparison takes BPFO-order line sets (outer race or "
                         "healthy, no baseline); inner-race, ball and mixed defects: validate_lines "
                         "(bench/validate_kinds.py)")
    methods, wall = {}, {}
    for n in dict.fromkeys(names):
        m = make_method(n, case, plain_model)
        sp, t = _time_spectrum(m, speed_hz, repeats=2 if n == "hbm" else 7)
        methods[n] = (m, sp)
        wall[f"{n}_spectrum"] = t
        wall[f"{n}_preparation"] = m.preparation_time_s
    orders = plain_model.orders
    freq = orders * plain_model.bpfo_per_hz * speed_hz

    # TDSM on the same machine
    model = Tdsm(case, speed_hz, max_step_s=max_step_s, machine=plain_model.machine)
    run = model.run(duration_s, settle_s=settle_s, progress=progress)
    if run.whole_periods < 1:
        raise KeyboardInterrupt("TDSM interrupted before one BPFO period was recorded")
    k_all, x_t, dc_t = run.order_spectrum()
    if orders.max() > k_all.max():
        raise ValueError(f"max_step_s: the TDSM sampling resolves orders up to {k_all.max()} only "
                         f"(BKA-BEM uses up to {orders.max()})")
    tdsm_x = x_t[orders - 1]
    tdsm_freq = np.stack([np.stack([run.peak_frequencies_hz(orders, li, di) for di in range(2)], axis=1)
                          for li in range(len(LOCATIONS))], axis=1)
    rel = lambda d: np.stack([d[0] - d[1], d[2] - d[3]])
    dc = {"tdsm": dc_t}
    _, _, dc_rel_t = run.order_spectrum(1, signal="bearing_relative")
    relative_dc = {"tdsm": dc_rel_t}
    for n, (_, sp) in methods.items():
        dc[n] = sp.dc_m
        relative_dc[n] = rel(sp.dc_m)

    # steady-state check: the order amplitudes of the first and second half of the recording
    steady = None
    if run.whole_periods >= 2:
        half = run.whole_periods // 2
        per = run.steps_per_bpfo // run.record_every
        a1 = _order_amplitudes(run.displacement_m[:half * per], half, orders)
        a2 = _order_amplitudes(run.displacement_m[half * per:2 * half * per], half, orders)
        steady = {}
        for li, loc in enumerate(LOCATIONS):
            steady[loc] = {}
            for di, d in enumerate(DIRECTIONS):
                big = np.argsort(np.abs(tdsm_x[:, li, di]))[::-1][:N_LARGEST]
                steady[loc][d] = float(np.max(np.abs(20 * np.log10(a2[big, li, di] / a1[big, li, di]))))
    off = run.off_order_fraction()
    wall.update({"tdsm": run.wall_time_s, "tdsm_setup": run.setup_time_s})
    info = {"step_s": run.step_s, "steps_per_bpfo": run.steps_per_bpfo, "steps": run.steps,
            "settle_s": run.settle_s, "recorded_s": run.time_s.size * run.step_s * run.record_every,
            "recorded_bpfo_periods": run.whole_periods, "ms_per_step": run.ms_per_step,
            "newton_iterations_mean": run.newton_iterations_mean,
            "newton_iterations_max": run.newton_iterations_max,
            "interrupted": run.interrupted, "settled": bool(getattr(run, "settled", True)),
            "settle_mode": run.settings.get("settle"),
            "off_order_fraction": {loc: {d: float(off[li, di]) for di, d in enumerate(DIRECTIONS)}
                                   for li, loc in enumerate(LOCATIONS)},
            "half_vs_half_max_abs_db_largest": steady,
            "static_bearing_force_n": {b: v.tolist() for b, v in run.static.force_n.items()},
            "static_bearing_relative_m": {b: v.tolist() for b, v in run.static.relative_m.items()},
            "settings": run.settings}
    # continuous TDSM spectrum for the plot (Hann window, amplitude-corrected)
    x = run.displacement_m
    n = x.shape[0]
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft((x - x.mean(axis=0)) * w[:, None, None], axis=0)) * 2.0 / w.sum()
    f = np.fft.rfftfreq(n, run.step_s * run.record_every)
    keep = f <= 1.05 * freq.max()
    return ValidationResult(
        case=case.name, case_hash=case.case_hash, speed_hz=speed_hz, bpfo_hz=run.bpfo_hz, improvement=improvement,
        orders=orders, frequency_hz=freq, tdsm=tdsm_x, methods={n: sp.displacement for n, (_, sp) in methods.items()},
        tdsm_frequency_hz=tdsm_freq, dc=dc, relative_dc=relative_dc, wall_time_s=wall, tdsm_info=info,
        tdsm_spectrum={"frequency_hz": f[keep], "amplitude_m": spec[keep]})


# --------------------------------------------------------------------------- plot
def plot_validation(result: ValidationResult, png_path: str, max_order: int | None = 50,
                    quantity: str = "acceleration") -> None:
    """TDSM and BKA-BEM spectra overlaid (paper Figs. 6 and 7) at the DE and NDE rotor and housing nodes.

    Grey line: the TDSM spectrum (Hann window). Black circles: TDSM at the BPFO orders (red dots: its five
    largest). Bars: every method of the result. Log amplitude axis, ``quantity`` displacement [nm] or
    acceleration [m/s^2].
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = result
    names = list(r.methods)
    scale, unit = (1e9, "nm") if quantity == "displacement" else (1.0, "m/s$^2$")
    keep = np.ones(r.orders.size, bool) if max_order is None else r.orders <= max_order
    f_max = r.frequency_hz[keep].max() + 0.5 * r.bpfo_hz
    fig, axes = plt.subplots(4, 2, figsize=(15, 15), constrained_layout=True, sharex=True)
    width = 0.8 * r.bpfo_hz / (len(names) + 1)
    w2 = (2.0 * math.pi * r.tdsm_spectrum.get("frequency_hz", np.zeros(1))) ** 2
    t_amp = r.amplitude("tdsm", quantity)
    for li, loc in enumerate(LOCATIONS):
        for di, d in enumerate(DIRECTIONS):
            ax = axes[li, di]
            if r.tdsm_spectrum:
                fr = r.tdsm_spectrum["frequency_hz"]
                a = r.tdsm_spectrum["amplitude_m"][:, li, di] * (w2 if quantity == "acceleration" else 1.0)
                sel = fr <= f_max
                ax.plot(fr[sel], a[sel] * scale, color="0.6", lw=0.6, zorder=3, label="TDSM spectrum (Hann)")
            for bi, name in enumerate(names):
                off = (bi - 0.5 * (len(names) - 1)) * width
                ax.bar(r.frequency_hz[keep] + off, r.amplitude(name, quantity)[keep, li, di] * scale, width=width,
                       color=f"C{bi}", alpha=0.85, label=name, zorder=2)
            ax.plot(r.frequency_hz[keep], t_amp[keep, li, di] * scale, "o", mfc="none", mec="k", ms=4, zorder=4,
                    label="TDSM at BPFO orders")
            big = r.largest_orders(li, di, quantity)
            ax.plot(r.frequency_hz[big], t_amp[big, li, di] * scale, "o", color="C3", ms=3, zorder=5,
                    label=f"{N_LARGEST} largest TDSM orders")
            errs = ", ".join(f"{n} {r.max_error_db(n, quantity)[li, di]:.2f} dB" for n in names)
            ax.set_yscale("log")
            top = np.nanmax(t_amp[keep, li, di]) * scale
            ax.set_ylim(top * 1e-4, top * 3)
            ax.set_xlim(0, f_max)
            ax.set_title(f"{loc}, {d}: {errs}", fontsize=9)
            ax.set(xlabel="frequency [Hz]", ylabel=f"{quantity} amplitude [{unit}]")
            ax.grid(alpha=0.3, which="both")
            if li == 0 and di == 0:
                ax.legend(fontsize=7, loc="lower left")
    fig.suptitle(f"{r.case}: TDSM vs BKA-BEM at {r.speed_hz:g} Hz (BPFO {r.bpfo_hz:.1f} Hz), {quantity}; "
                 f"TDSM {r.wall_time_s['tdsm']:.1f} s, BKA-BEM spectrum {r.wall_time_s['plain_spectrum'] * 1e3:.2f} ms "
                 f"({r.speed_ratio:.0f}x); errors over the {N_LARGEST} largest TDSM orders")
    fig.savefig(png_path, dpi=90)
    plt.close(fig)


# --------------------------------------------------------------------------- any defect kind
@dataclass
class LineValidation:
    """TDSM against plain BKA-BEM for any line set (inner-race and ball defects: not BPFO-periodic).

    The TDSM record is quasi-periodic; each BKA-BEM line's complex amplitude is fitted to it by linear least
    squares (cosine and sine of every line frequency and a constant, over the whole record: exact for a steady
    state made of these lines), then compared line by line.

    Attributes
    ----------
    case, speed_hz :
    frequency_hz : ndarray (K,)
        The model's line frequencies at the speed [Hz].
    coefficients : ndarray (K, 4)
    tdsm, plain : ndarray complex (K, 4, 2)
        Fitted TDSM and BKA-BEM displacement amplitudes [m] at LOCATIONS x DIRECTIONS.
    improved : ndarray complex (K, 4, 2) or None
        The improved method's (:class:`~bkabem_core.solve.improved.HillCorrection`), if it was compared [m].
    residual_fraction : ndarray (4, 2)
        RMS of what the lines do not explain over the RMS of the record's dynamic part (start transient,
        lines below the threshold).
    wall_time_s : dict
    """

    case: str
    speed_hz: float
    frequency_hz: np.ndarray
    coefficients: np.ndarray
    tdsm: np.ndarray
    plain: np.ndarray
    residual_fraction: np.ndarray
    wall_time_s: dict
    improved: np.ndarray | None = None

    def resolvable(self, min_separation_hz: float) -> np.ndarray:
        """(K,) bool: lines whose nearest other line is at least ``min_separation_hz`` [Hz] away. Closer pairs
        (lines of two defects in two bearings can fall within 0.03 Hz of each other) are not separable by a record
        of duration ``T`` unless their spacing is well above ``1 / T``: the fit splits their sum arbitrarily and
        amplifies what the lines do not explain by about ``1 / (pi spacing T)^2``."""
        f = self.frequency_hz
        o = np.argsort(f)
        gap = np.diff(f[o])
        near = np.full(f.size, np.inf)
        near[o[1:]] = gap
        near[o[:-1]] = np.minimum(near[o[:-1]], gap)
        return near >= min_separation_hz

    def largest(self, li: int, di: int, quantity: str = "displacement", n: int = N_LARGEST,
                min_separation_hz: float = 0.0) -> np.ndarray:
        """Indices of the ``n`` largest TDSM lines at location ``li``, direction ``di`` among those resolvable
        with ``min_separation_hz`` [Hz] (:meth:`resolvable`; 0: all)."""
        a = np.abs(self.tdsm[:, li, di])
        if quantity == "acceleration":
            a = a * self.frequency_hz ** 2
        if min_separation_hz > 0.0:
            a = np.where(self.resolvable(min_separation_hz), a, -1.0)
        return np.argsort(a)[::-1][:n]

    def max_error_db(self, quantity: str = "displacement", which: str = "plain",
                     min_separation_hz: float = 0.0) -> np.ndarray:
        """Largest |error| [dB] of ``which`` (``"plain"`` or ``"improved"``) over the N_LARGEST largest TDSM lines
        (resolvable ones only if ``min_separation_hz`` > 0 [Hz]), (4 locations, 2 directions)."""
        x = self.plain if which == "plain" else self.improved
        if x is None:
            raise ValueError(f"which: {which!r} was not compared")
        out = np.zeros((len(LOCATIONS), len(DIRECTIONS)))
        for li in range(len(LOCATIONS)):
            for di in range(len(DIRECTIONS)):
                i = self.largest(li, di, quantity, min_separation_hz=min_separation_hz)
                out[li, di] = np.max(np.abs(20 * np.log10(np.abs(x[i, li, di]) / np.abs(self.tdsm[i, li, di]))))
        return out

    def to_dict(self) -> dict:
        return {"case": self.case, "speed_hz": self.speed_hz, "n_lines": int(self.frequency_hz.size),
                "max_abs_error_db_largest": {loc: {d: float(v) for d, v in zip(DIRECTIONS, row)}
                                             for loc, row in zip(LOCATIONS, self.max_error_db())},
                "max_abs_error_db_largest_acceleration": {
                    loc: {d: float(v) for d, v in zip(DIRECTIONS, row)}
                    for loc, row in zip(LOCATIONS, self.max_error_db("acceleration"))},
                "residual_fraction": {loc: {d: float(v) for d, v in zip(DIRECTIONS, row)}
                                      for loc, row in zip(LOCATIONS, self.residual_fraction)},
                "wall_time_s": dict(self.wall_time_s),
                **({} if self.improved is None else {
                    f"improved_max_abs_error_db_largest{sfx}": {
                        loc: {d: float(v) for d, v in zip(DIRECTIONS, row)}
                        for loc, row in zip(LOCATIONS, self.max_error_db(q, "improved"))}
                    for q, sfx in (("displacement", ""), ("acceleration", "_acceleration"))})}


#: Largest condition number of the Gram matrix ``A^T A`` for which :func:`_fit_lines` solves the normal equations:
#: their solution is then within ~1e-8 of the least-squares one (relative), far below a line's error in dB
GRAM_CONDITION_MAX = 1e8


def _fit_lines(a: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares coefficients ``c`` of ``a c ~ y`` for a record ``y`` (N, C) and the columns ``a`` (N, P) of the
    lines' cosines and sines.

    When the record resolves every line (the Gram matrix ``a^T a`` is well conditioned, at most
    :data:`GRAM_CONDITION_MAX`: lines further apart than ~1 / duration) the normal equations are solved by Cholesky;
    forming ``a^T a`` is one matrix product, several times faster than a factorisation of ``a`` and with the same
    solution to ~1e-8 relative. Otherwise (lines closer than the record resolves) numpy's SVD least squares gives
    the minimum-norm split of the lines it cannot tell apart, as before.
    """
    from scipy.linalg import cho_factor, cho_solve, lapack

    gram = a.T @ a
    try:
        factor = cho_factor(gram, check_finite=False)
        rcond, info = lapack.dpocon(factor[0], np.abs(gram).sum(axis=0).max(), uplo="L" if factor[1] else "U")
    except np.linalg.LinAlgError:                       # not positive definite: lines the record cannot tell apart
        rcond, info = 0.0, 1
    if info == 0 and rcond * GRAM_CONDITION_MAX >= 1.0:
        return cho_solve(factor, a.T @ y, check_finite=False)
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return coef


def validate_lines(case: Case, speed_hz: float = DEFAULT_SPEED_HZ, duration_s: float = 0.3, settle_s: float = 0.5,
                   decimate: int = 4, plain: BkaBem | None = None, progress: bool = False,
                   improved: HillCorrection | None = None) -> LineValidation:
    """TDSM vs plain (and improved) BKA-BEM for any defect kind (:class:`LineValidation`); the machine baseline is
    left out of both (the TDSM has the bearings only).

    Parameters
    ----------
    case : Case
    speed_hz : float
    duration_s : float
        Recorded time after ``settle_s`` [s]; the lines must be resolved by it (1 / duration well below the
        closest line spacing, e.g. FTF f_r).
    settle_s : float
        Discarded start transient [s] (fixed: the adaptive rule of :meth:`Tdsm.run` needs BPFO-periodic data).
    decimate : int
        Every ``decimate``-th recorded step enters the fit.
    plain : BkaBem, optional
        The plain model (made here if not given).
    improved : HillCorrection, optional
        The improved method of ``plain`` (any line set): compared as well, its spectrum time measured.
    """
    t0 = time.perf_counter()
    model = plain if plain is not None else BkaBem(case, baseline=False)
    t_prep = time.perf_counter() - t0
    tm = Tdsm(case, speed_hz, machine=model.machine)
    run = tm.run(duration_s, settle_s=settle_s, progress=progress)
    t = (run.time_s + run.settle_s)[::decimate]
    y = run.displacement_m[::decimate].reshape(t.size, -1)
    f = model.frequency_hz(speed_hz)
    ph = 2 * np.pi * np.outer(t, f)
    a = np.hstack([np.ones((t.size, 1)), np.cos(ph), -np.sin(ph)])
    coef = _fit_lines(a, y)
    amp = (coef[1:1 + f.size] + 1j * coef[1 + f.size:]).reshape(f.size, len(LOCATIONS), len(DIRECTIONS))
    resid = y - a @ coef
    dyn = y - y.mean(axis=0)
    frac = (np.sqrt(np.mean(resid ** 2, axis=0)) / np.sqrt(np.mean(dyn ** 2, axis=0))).reshape(4, 2)
    t1 = time.perf_counter()
    x = model.spectrum(speed_hz).displacement
    wall = {"tdsm": run.wall_time_s, "plain_preparation": t_prep, "plain_spectrum": time.perf_counter() - t1}
    x_imp = None
    if improved is not None:
        if improved.model is not model:
            raise ValueError("improved: must be the improved method of the plain model compared")
        improved.spectrum(speed_hz)                       # first call: caches (receptance shapes)
        t2 = time.perf_counter()
        x_imp = improved.spectrum(speed_hz).displacement
        wall["improved_spectrum"] = time.perf_counter() - t2
        wall["improved_preparation"] = improved.preparation_time_s
    return LineValidation(case=case.name, speed_hz=float(speed_hz), frequency_hz=f,
                          coefficients=model.lines.coefficients.copy(), tdsm=amp, plain=x, residual_fraction=frac,
                          wall_time_s=wall, improved=x_imp)
