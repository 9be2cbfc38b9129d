"""The core commands of ``bkabem``: ``excitation``, ``spectrum``, ``sweep``, ``validate`` and ``demo``.

They parse, call ``bkabem_core`` and print; none imports rclpy (``demo`` only for its ROS part, after the core
part). Every line of an output is named by what it is (``BPFO``, ``BPFI - 1 f_r``, ``2 BSF + FTF``, ``1x``:
:mod:`bkabem_core.excitation.line_names`) and the tables list the largest lines. Errors follow the contract
of :mod:`bkabem_ros.cli.base` (one line naming the argument or case key, exit code 2).
"""

from __future__ import annotations

import csv
import json
import math
import sys
import time

from bkabem_ros.cli.base import UsageError, check_output_dir, finite_float, output_path, pos_int, writing

#: validate: below 1 Hz one BPFO period of the TDSM reference takes minutes of computing; the TDSM output grows
#: with the simulated time (~10 s of computing and ~100 MB per simulated second).
VALIDATE_MIN_SPEED_HZ = 1.0
VALIDATE_MAX_DURATION_S = 20.0
#: validate: the TDSM's spectral peaks need this many BPFO periods (the main lobe of a Hann window over n periods
#: is +/- 2/n BPFO wide: from 6 on it fits the +/- 0.4 BPFO a peak is searched in).
VALIDATE_MIN_PERIODS = 6
#: validate: at most this many TDSM steps (settling of up to 4 s included): ~0.1 ms and ~100 B each, so ~5 min
#: and ~300 MB (the default step at the longest --duration stays below it).
VALIDATE_MAX_STEPS = 3_000_000

# --------------------------------------------------------------------------- helpers
def _load_case(path):
    from bkabem_core.model.case import Case

    return Case.load(path)


def _model(case, solver="modal"):
    from bkabem_core.solve.harmonic import BkaBem

    return BkaBem(case, solver=solver)


def _numbers(obj):
    """Every float in a JSON-like object."""
    if isinstance(obj, float):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, (list, tuple)):
        for v in obj:
            yield from _numbers(v)


def _print_json(obj) -> None:
    json.dump(obj, sys.stdout, indent=1)
    sys.stdout.write("\n")


def _largest(amplitude, max_rows: int):
    """Indices of the ``max_rows`` largest lines (by their largest amplitude over the other axes), largest first."""
    import numpy as np

    a = np.asarray(amplitude).reshape(len(amplitude), -1).max(axis=1) if len(amplitude) else np.zeros(0)
    return np.argsort(-a, kind="stable")[:max_rows]


def _excitation_table(ex, max_rows: int = 24, designation: str = "") -> str:
    import numpy as np

    from bkabem_core.excitation.line_names import line_labels

    d = ex.to_dict()
    ls = ex.line_set()
    what = "quasi-static excitation" if ex.method == "quasi_static" else \
        f"4-DOF excitation at {ex.reference_speed_hz:g} Hz"
    kept = f"{len(ex.orders)} BPFO orders kept of {len(ex.all_orders)}" if ex.lines is None else \
        f"{len(ls)} lines of its defects"
    lines = [
        f"{(ex.bearing or '').upper()} bearing{' ' + designation if designation else ''}, {what} under {ex.radial_load_n:.1f} N radial + {ex.axial_load_n:.0f} N "
        f"axial  (BPFO {ex.bpfo_per_hz:.4f} x shaft Hz, clearance {ex.clearance_m * 1e6:.1f} um, {kept})",
        f"  DC           vertical {d['dc_m']['vertical'] * 1e6:9.3f} um   horizontal "
        f"{d['dc_m']['horizontal'] * 1e6:9.4f} um",
    ]
    if ex.lines is None:         # the recorded window of a moving defect is not its period: no peak-to-peak
        lines.append(f"  peak-to-peak vertical {d['peak_to_peak_m']['vertical'] * 1e6:9.3f} um   horizontal "
                     f"{d['peak_to_peak_m']['horizontal'] * 1e6:9.4f} um")
    amp = np.abs(ls.amplitude)
    rows = _largest(amp, max_rows)
    labels = line_labels(ls.coefficients[rows], ex.n_balls)
    f_ref = ls.frequency_hz(ex.reference_speed_hz)
    width = max([10] + [len(t) for t in labels])
    lines.append(f"  {'line':<{width}} {'f@ref [Hz]':>10} {'A_v [um]':>10} {'phi_v [rad]':>11} {'A_h [um]':>10} "
                 f"{'phi_h [rad]':>11}" + ("   (the largest first)" if len(ls) else ""))
    ph = np.angle(ls.amplitude)
    for i, label in zip(rows, labels):
        lines.append(f"  {label:<{width}} {f_ref[i]:10.3f} {amp[i, 0] * 1e6:10.4f} {ph[i, 0]:11.4f} "
                     f"{amp[i, 1] * 1e6:10.4f} {ph[i, 1]:11.4f}")
    if len(ls) > max_rows:
        lines.append(f"  ... {len(ls) - max_rows} smaller lines (--json for all)")
    return "\n".join(lines)


def _spectrum_table(sp, max_rows: int = 12, designations: dict | None = None) -> str:
    import numpy as np

    from bkabem_core.model.vocabulary import LOCATIONS

    per = sp.bearing_fault_frequencies_hz or {"de": sp.fault_frequencies_hz, "nde": sp.fault_frequencies_hz}
    names = designations or {}

    def kin(ff):
        return f"FTF {ff.ftf:.3f} Hz, BPFO {ff.bpfo:.3f} Hz, BPFI {ff.bpfi:.3f} Hz, BSF {ff.bsf:.3f} Hz"

    head = f"BKA-BEM spectrum at {sp.speed_hz:g} Hz shaft speed ({sp.speed_hz * 60:.0f} rpm): "
    if per["de"] == per["nde"]:
        lines = [head + kin(per["de"])]
    else:                                            # a bearing of its own at each position: each its own lines
        lines = [head.rstrip(": ")] + [f"  {b.upper()} bearing{' ' + names[b] if names.get(b) else ''}: {kin(ff)}"
                                       for b, ff in per.items()]
    acc = np.abs(sp.acceleration)
    band = np.flatnonzero(sp.in_band)
    rows = band[_largest(acc[band], max_rows)]
    labels = [sp.labels[i] if sp.labels is not None else f"{int(sp.orders[i])} BPFO" for i in rows]
    width = max([12] + [len(t) for t in labels])
    lines.append(f"  the {min(max_rows, len(rows))} largest of {len(sp.frequency_hz)} lines "
                 f"(acceleration amplitude, vertical/horizontal; up to the case's band, {sp.band_hz:g} Hz):")
    lines.append("  " + f"{'line':<{width}} {'f [Hz]':>9}" + "".join(f" {loc + ' v/h [m/s2]':>27}" for loc in LOCATIONS))
    for i, label in zip(rows, labels):
        row = f"  {label:<{width}} {sp.frequency_hz[i]:9.2f}"
        for li in range(len(LOCATIONS)):
            row += f" {acc[i, li, 0]:13.4e}/{acc[i, li, 1]:.4e}"
        lines.append(row)
    if len(sp.frequency_hz) > max_rows:
        lines.append(f"  ... {len(sp.frequency_hz) - max_rows} smaller lines (--json for all)")
    rms_a, rms_d = sp.rms("acceleration"), sp.rms("displacement")
    beyond = int(np.sum(~sp.in_band))
    if beyond:
        lines.append(f"  {beyond} lines above the case's band ({sp.band_hz:g} Hz) at this speed are left out of the "
                     f"overall RMS")
    for li, loc in enumerate(LOCATIONS):
        lines.append(f"  {loc:12s} overall RMS acceleration v/h {rms_a[li, 0]:.4e}/{rms_a[li, 1]:.4e} m/s2, "
                     f"displacement v/h {rms_d[li, 0] * 1e6:.4f}/{rms_d[li, 1] * 1e6:.4f} um, "
                     f"DC v/h {sp.dc_m[li, 0] * 1e6:.3f}/{sp.dc_m[li, 1] * 1e6:.4f} um")
    return "\n".join(lines)


def _excitation_dict(ex) -> dict:
    """``Excitation.to_dict`` with the name of every line (``lines.names``: ``"BPFI - 1 f_r"``, ``"3 BPFO"``)."""
    from bkabem_core.excitation.line_names import line_labels

    d = ex.to_dict()
    ls = ex.line_set()
    if d.get("lines") is None:
        d["lines"] = ls.to_dict()
    d["lines"]["names"] = line_labels(ls.coefficients, ex.n_balls)
    return d


# --------------------------------------------------------------------------- commands
def cmd_excitation(args) -> int:
    case = _load_case(args.case)
    from bkabem_core.fe.machine import Machine
    from bkabem_core.model.vocabulary import BEARINGS

    machine = Machine(case, mesh=None)
    names = BEARINGS if args.all_bearings else machine.excited_bearings()
    exs = {n: machine.excitation(n, method=args.method) for n in names}
    kin = case.kinematics(1.0)                       # each bearing's designation and fault multipliers
    ex = exs.get(case.faulty_bearing, next(iter(exs.values())))
    for n, e in exs.items():
        _check_finite(f"excitation of the {n} bearing", list(_numbers(e.to_dict())))
    if args.png:
        from bkabem_core.analysis.plots import plot_excitation

        with writing("--png", args.png):
            plot_excitation(ex, args.png)
    if args.json:
        out = _excitation_dict(ex)          # the faulty bearing's at the top level, every bearing below

        def with_kin(n, d):
            k = kin[n]
            d.update(designation=k["designation"], n_balls=k["n_balls"],
                     fault_multipliers_per_shaft_hz={f: k[f] for f in ("ftf", "bpfo", "bpfi", "bsf")})
            return d

        with_kin(ex.bearing or case.faulty_bearing, out)
        out["bearings"] = {n: with_kin(n, _excitation_dict(e)) for n, e in exs.items()}
        _print_json(out)
    else:
        print("\n\n".join(_excitation_table(e, designation=kin[n]["designation"]) for n, e in exs.items()))
        if args.png:
            print(f"wrote {args.png}")
    return 0


def cmd_spectrum(args) -> int:
    case = _load_case(args.case)
    _check_speeds(case, [args.speed_hz], "--speed-hz")
    model = _model(case)
    sp = model.spectrum(args.speed_hz)
    _check_finite(f"spectrum at {args.speed_hz:g} Hz", sp.displacement, sp.acceleration, sp.dc_m)
    if args.png:
        from bkabem_core.analysis.plots import defects_of_case, plot_spectrum

        with writing("--png", args.png):
            plot_spectrum(sp, args.png, defects=defects_of_case(case), title=case.name)
    if args.json:
        _print_json(sp.to_dict())
    else:
        print(_spectrum_table(sp, designations={b: case.bearing_geometry(b).designation for b in ("de", "nde")}))
        if args.png:
            print(f"wrote {args.png}")
    return 0


#: Sweep sizes: streamed outputs (--csv, --jsonl, the table) hold one batch of speeds at a time; --json (one
#: document) and --png (one figure) hold the whole sweep: ~6.4 kB of complex responses per speed.
SWEEP_MAX_STEPS = 1_000_000
SWEEP_MAX_STEPS_IN_MEMORY = 20_000
SWEEP_BATCH = 256


def _check_speeds(case, speeds_hz, argument: str) -> None:
    """Shaft speeds must lie in the case's operating range (0 .. operating.max_speed_hz)."""
    import numpy as np

    top = float(np.max(speeds_hz))
    if top > case.max_speed_hz:
        raise UsageError(f"{argument}: {top:g} Hz is above the case's operating.max_speed_hz ({case.max_speed_hz:g} Hz; "
                         f"raise it in the case file if the machine runs faster)")


def _check_finite(what: str, *arrays) -> None:
    """The last check before anything is written: no NaN or inf leaves the command."""
    import numpy as np

    for a in arrays:
        a = np.asarray(a)
        if a.size and not np.all(np.isfinite(a)):
            raise UsageError(f"{what}: the result is not finite (NaN or inf); a case value or argument is outside "
                             f"what the model can represent (check the units of the case)")


def _sweep_batches(model, speeds, progress: bool):
    """Yield (first index, Sweep of a batch of speeds)."""
    starts = range(0, speeds.size, SWEEP_BATCH)
    if progress:
        from tqdm import tqdm

        starts = tqdm(starts, desc="sweep", unit="batch", file=sys.stderr)
    for i0 in starts:
        sw = model.sweep(speeds[i0:i0 + SWEEP_BATCH])
        _check_finite(f"sweep at {speeds[i0]:g}..{speeds[min(i0 + SWEEP_BATCH, speeds.size) - 1]:g} Hz",
                      sw.displacement, sw.acceleration)
        yield i0, sw


def _sweep_fields(sw, si: int, li: int, di: int) -> dict:
    import numpy as np

    disp, acc = sw.displacement[si, :, li, di], sw.acceleration[si, :, li, di]
    band = sw.in_band[si]
    return {"displacement_m": np.abs(disp).tolist(), "acceleration_m_s2": np.abs(acc).tolist(),
            "phase_rad": np.angle(disp).tolist(),
            "rms_acceleration_m_s2": float(np.sqrt(0.5 * np.sum(np.abs(acc[band]) ** 2))),
            "rms_displacement_m": float(np.sqrt(0.5 * np.sum(np.abs(disp[band]) ** 2)))}


def _write_sweep_json(out, sw, speeds, elapsed: float) -> None:
    """The ``--json`` document, written row by row (no Python lists of the whole sweep): per line its name
    (``lines``), coefficients, BPFO order (0: not one) and frequency at every speed; per location and direction the
    amplitudes, phases and overall RMS."""
    import numpy as np

    from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS

    acc, disp = sw.acceleration, sw.displacement
    rms_a, rms_d = sw.rms("acceleration"), sw.rms("displacement")
    w = out.write
    w('{\n "speeds_hz": ' + json.dumps(speeds.tolist()) + ',\n "orders": ' + json.dumps([int(k) for k in sw.orders])
      + ',\n "lines": ' + json.dumps(list(sw.labels or ()))
      + ',\n "line_coefficients": ' + json.dumps([] if sw.coefficients is None else sw.coefficients.tolist())
      + f',\n "bpfo_per_hz": {json.dumps(float(sw.bpfo_per_hz))},\n "wall_time_s": {json.dumps(elapsed)}'
      + f',\n "band_hz": {json.dumps(float(sw.band_hz))}'
      + ',\n "frequency_hz": [')
    f = sw.frequency_hz
    for si in range(f.shape[0]):
        w(("," if si else "") + "\n  " + json.dumps(f[si].tolist()))
    w("]")
    for li, loc in enumerate(LOCATIONS):
        w(f',\n "{loc}": {{')
        for di, d in enumerate(DIRECTIONS):
            w(("," if di else "") + f'\n  "{d}": {{')
            for ai, (name, arr) in enumerate((("displacement_m", np.abs(disp[:, :, li, di])),
                                              ("acceleration_m_s2", np.abs(acc[:, :, li, di])),
                                              ("phase_rad", np.angle(disp[:, :, li, di])))):
                w(("," if ai else "") + f'\n   "{name}": [')
                for si in range(arr.shape[0]):
                    w(("," if si else "") + "\n    " + json.dumps(arr[si].tolist()))
                w("]")
            w(',\n   "rms_acceleration_m_s2": ' + json.dumps(rms_a[:, li, di].tolist()))
            w(',\n   "rms_displacement_m": ' + json.dumps(rms_d[:, li, di].tolist()) + "}")
        w("}")
    w("\n}\n")


def cmd_sweep(args) -> int:
    import numpy as np

    if args.to_hz < args.from_hz:
        raise UsageError(f"--to-hz ({args.to_hz:g}) must be >= --from-hz ({args.from_hz:g})")
    if (args.json or args.png) and args.steps > SWEEP_MAX_STEPS_IN_MEMORY:
        raise UsageError(f"--steps: {args.steps} speeds is more than {SWEEP_MAX_STEPS_IN_MEMORY} for "
                         f"{'--json' if args.json else '--png'} (one document/figure in memory); --csv and --jsonl "
                         f"stream up to {SWEEP_MAX_STEPS}")
    case = _load_case(args.case)
    speeds = np.linspace(args.from_hz, args.to_hz, args.steps)
    _check_speeds(case, speeds, "--to-hz")
    model = _model(case)
    from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS
    from bkabem_core.solve.harmonic import Sweep

    progress = not (args.json or args.csv or args.jsonl) and sys.stderr.isatty()
    t0 = time.perf_counter()
    if args.json or args.png:                       # whole sweep (bounded by SWEEP_MAX_STEPS_IN_MEMORY)
        sw_all = Sweep.concatenate(sw for _, sw in _sweep_batches(model, speeds, progress))
        elapsed = time.perf_counter() - t0
        if args.png:
            from bkabem_core.analysis.plots import defects_of_case, plot_sweep

            with writing("--png", args.png):
                plot_sweep(sw_all, args.png, defects=defects_of_case(case), fault_multipliers=model.fault_multipliers,
                           title=case.name)
        if args.json:
            _write_sweep_json(sys.stdout, sw_all, speeds, elapsed)
            return 0
        batches = [(0, sw_all)]
    else:
        batches = _sweep_batches(model, speeds, progress)
    if args.csv:
        w = csv.writer(sys.stdout)
        w.writerow(["speed_hz", "order", "frequency_hz", "location", "direction", "displacement_m",
                    "acceleration_m_s2", "phase_rad", "line"])
        for i0, sw in batches:
            acc, disp, f = sw.acceleration, sw.displacement, sw.frequency_hz
            for si, s in enumerate(sw.speeds_hz):
                for ki, k in enumerate(sw.orders):
                    for li, loc in enumerate(LOCATIONS):
                        for di, d in enumerate(DIRECTIONS):
                            x = disp[si, ki, li, di]
                            w.writerow([f"{s:.6g}", int(k), f"{f[si, ki]:.6g}", loc, d, f"{abs(x):.6e}",
                                        f"{abs(acc[si, ki, li, di]):.6e}", f"{np.angle(x):.6f}", sw.labels[ki]])
        return 0
    if args.jsonl:
        for i0, sw in batches:
            f = sw.frequency_hz
            for si, s in enumerate(sw.speeds_hz):
                row = {"speed_hz": float(s), "lines": list(sw.labels), "orders": [int(k) for k in sw.orders],
                       "frequency_hz": f[si].tolist(), "band_hz": float(sw.band_hz)}
                for li, loc in enumerate(LOCATIONS):
                    row[loc] = {d: _sweep_fields(sw, si, li, di) for di, d in enumerate(DIRECTIONS)}
                sys.stdout.write(json.dumps(row) + "\n")
        return 0
    step = max(1, args.steps // 15)
    lines = []
    n_orders = 0
    for i0, sw in batches:
        rms = sw.rms("acceleration")
        n_orders = sw.orders.size
        for si in range(sw.speeds_hz.size):
            if (i0 + si) % step == 0:
                lines.append(f"  {sw.speeds_hz[si]:10.3f}" + "".join(f" {rms[si, li, 0]:13.4e}/{rms[si, li, 1]:.4e}"
                                                                     for li in range(len(LOCATIONS))))
    elapsed = time.perf_counter() - t0
    print(f"sweep {args.from_hz:g}..{args.to_hz:g} Hz, {args.steps} speeds x {n_orders} lines "
          f"in {elapsed * 1e3:.1f} ms (overall RMS of the lines up to the case's band, {model.band_hz:g} Hz)")
    print(f"  {'speed [Hz]':>10}" + "".join(f" {loc + ' v/h RMS [m/s2]':>27}" for loc in LOCATIONS))
    print("\n".join(lines))
    if args.png:
        print(f"wrote {args.png}")
    return 0


def cmd_validate(args) -> int:
    try:
        from bkabem_core.reference import validation
    except ImportError as exc:  # pragma: no cover - until the TDSM lands
        raise UsageError(f"validate is not available: {exc}") from None
    case = _load_case(args.case)
    kwargs = {}
    if args.speed_hz is not None:
        _check_speeds(case, [args.speed_hz], "--speed-hz")
        kwargs["speed_hz"] = args.speed_hz
    speed_hz = kwargs.get("speed_hz", validation.DEFAULT_SPEED_HZ)
    bpfo_hz = case.bearing(case.faulty_bearing).fault_multipliers().bpfo * speed_hz
    duration = validation.DEFAULT_DURATION_S if args.duration is None else args.duration
    if duration * bpfo_hz < VALIDATE_MIN_PERIODS - 1e-9:
        raise UsageError(f"--duration: {duration:g} s{' (the default)' if args.duration is None else ''} is shorter than {VALIDATE_MIN_PERIODS} BPFO periods at "
                         f"{speed_hz:g} Hz ({VALIDATE_MIN_PERIODS / bpfo_hz:.4g} s): the TDSM's spectral peaks "
                         f"need them")
    kwargs["duration_s"] = duration
    if args.improvement:
        kwargs["improvement"] = None if args.improvement == "none" else args.improvement
    from bkabem_core.solve.harmonic import BkaBem

    plain = BkaBem(case, baseline=False)
    if args.max_step_us is not None:
        import numpy as np

        _check_tdsm_step(args.max_step_us * 1e-6, bpfo_hz, duration, int(np.max(plain.orders, initial=1)))
        kwargs["max_step_s"] = args.max_step_us * 1e-6
    result = validation.validate(case, progress=not args.json and sys.stderr.isatty(), plain=plain, **kwargs)
    d = result.to_dict()
    _check_finite("validate", [v for v in _numbers(d)])
    if args.png:
        with writing("--png", args.png):
            validation.plot_validation(result, args.png)
    if args.json:
        _print_json(result.to_dict())
    else:
        print(result.summary() if hasattr(result, "summary") else json.dumps(result.to_dict(), indent=1))
    return 0


def _check_tdsm_step(max_step_s: float, bpfo_hz: float, duration_s: float, top_order: int) -> None:
    """``--max-step-us`` against what the TDSM can resolve (2 steps per period of the highest order) and afford
    (:data:`VALIDATE_MAX_STEPS`, settling included)."""
    period = 1.0 / bpfo_hz
    per_period = math.ceil(period / max_step_s - 1e-9)
    if per_period < 2 * top_order:
        raise UsageError(f"--max-step-us: {max_step_s * 1e6:g} us gives {per_period} steps per BPFO period; order "
                         f"{top_order} needs at least {2 * top_order} (at most {period / (2 * top_order) * 1e6:.4g} us)")
    steps = per_period * (math.ceil(duration_s / period - 1e-9) + math.ceil(4.0 / period - 1e-9))
    if steps > VALIDATE_MAX_STEPS:
        shortest = period / math.floor(VALIDATE_MAX_STEPS / (math.ceil(duration_s / period - 1e-9)
                                                             + math.ceil(4.0 / period - 1e-9)))
        raise UsageError(f"--max-step-us: {max_step_s * 1e6:g} us needs up to {steps:.3g} TDSM steps (--duration "
                         f"and up to 4 s of settling), more than {VALIDATE_MAX_STEPS:g} (~0.1 ms and ~100 B each); "
                         f"at least {shortest * 1e6:.3g} us")


def cmd_demo(args) -> int:
    """The main job on the embedded case.

    1. the BKA-BEM core: excitation table, spectra at a few speeds, figures in ``--out`` (default out/demo);
    2. the ROS 2 node through a run-up and a hold, recorded to ``recordings/demo.mcap`` and ``demo.rrd``
       (bkabem_ros.cli.demo), with progress, a summary and the command that opens the result in Rerun.
    """
    from pathlib import Path

    import numpy as np

    case = _load_case(args.case)
    _check_speeds(case, args.speeds, "--speeds")
    if not args.no_ros:
        _check_speeds(case, [args.top_hz], "--top-hz")
        check_output_dir("--recordings", args.recordings)
    out = Path(args.out)
    check_output_dir("--out", out)
    t0 = time.perf_counter()
    model = _model(case)
    prep = time.perf_counter() - t0
    ex = model.excitation
    info = model.solver_info()
    print(f"== 1/2  BKA-BEM core: case {case.name} ({case.source}, hash {case.case_hash})")
    print(f"prepared in {prep:.2f} s (excitation of {', '.join(b.upper() for b in model.excitations)} "
          f"{model.preparation_time_s['excitation']:.2f} s; {info['ndof']}-DOF FE model of {info['fe_elements']} "
          f"elements, reduced to {info.get('modal_basis_size', '-')} modes; "
          f"{info['orders']} orders diagonalised {model.preparation_time_s['solver_setup']:.2f} s)")
    print(_excitation_table(ex, max_rows=12))
    from bkabem_core.analysis.plots import defects_of_case, plot_excitation, plot_spectrum, plot_sweep

    plot_excitation(ex, str(out / "excitation.png"))
    for s in args.speeds:
        t1 = time.perf_counter()
        sp = model.spectrum(s)
        dt = time.perf_counter() - t1
        print()
        print(_spectrum_table(sp, max_rows=6))
        print(f"  (solved in {dt * 1e3:.2f} ms)")
    defects = defects_of_case(case)
    plot_spectrum(model.spectrum(args.speeds[-1]), str(out / "spectrum.png"), defects=defects, title=case.name)
    speeds = np.linspace(0.5, case.max_speed_hz, 500)
    t1 = time.perf_counter()
    sw = model.sweep(speeds)
    print(f"\nsweep of {speeds.size} speeds x {sw.orders.size} orders in {(time.perf_counter() - t1) * 1e3:.0f} ms")
    plot_sweep(sw, str(out / "sweep.png"), defects=defects, fault_multipliers=model.fault_multipliers, title=case.name)
    print(f"wrote {out / 'excitation.png'}, {out / 'spectrum.png'}, {out / 'sweep.png'}")
    if args.no_ros:
        return 0
    try:
        from bkabem_ros.cli.demo import run_demo
    except ImportError as exc:
        raise UsageError(f"the ROS 2 part needs the ROS set-up (make demo installs it): {exc}") from None
    print(f"\n== 2/2  ROS 2 node: run-up 0 -> {args.top_hz:g} Hz in {args.ramp:g} s, hold {args.hold:g} s, "
          f"recording to {args.recordings}/demo.mcap and demo.rrd", flush=True)
    r = run_demo(args.recordings, ramp_s=args.ramp, hold_s=args.hold, top_hz=args.top_hz,
                 sample_rate=args.sample_rate, case=args.case, rerun=not args.no_rerun)
    if r.errors:                        # a recording failed (full disk ...): the summary above lists them all
        raise UsageError(f"--recordings: {r.errors[0]}")
    return 0


# --------------------------------------------------------------------------- parser
def add_case(sp) -> None:
    """``--case`` of every command that loads a case."""
    sp.add_argument("--case", default=None,
                    help="embedded case name or TOML file (default: electric_motor_6010)")


def add_parsers(sub) -> None:
    """Register ``excitation``, ``spectrum``, ``sweep``, ``validate`` and ``demo`` on an argparse subparsers object."""
    e = sub.add_parser("excitation", help="each bearing's excitation: DC, amplitudes and phases of its lines")
    add_case(e)
    e.add_argument("--json", action="store_true", help="machine-readable output")
    e.add_argument("--png", type=output_path("--png", (".png",)), help="write a figure of the waveform and orders")
    e.add_argument("--method", choices=("quasi_static", "four_dof"), default=None,
                   help="excitation model (default: the case's [excitation] method)")
    e.add_argument("--all-bearings", action="store_true",
                   help="every bearing, also those the case does not excite ([excitation] bearings)")
    e.set_defaults(func=cmd_excitation)

    s = sub.add_parser("spectrum", help="BKA-BEM spectrum at one shaft speed")
    add_case(s)
    s.add_argument("--speed-hz", required=True, type=finite_float("--speed-hz", 0.0),
                   help="shaft speed [Hz]")
    s.add_argument("--json", action="store_true",
                   help="one JSON document: every line (name, coefficients, frequency) per location and direction: "
                        "displacement [m], velocity [m/s], acceleration [m/s^2], phase [rad], static part [m]")
    s.add_argument("--png", type=output_path("--png", (".png",)),
                   help="figure: the line spectra of the four locations, each line at its frequency, the largest "
                        "named, the fault frequencies marked")
    s.set_defaults(func=cmd_spectrum)

    w = sub.add_parser("sweep", help="BKA-BEM spectra over a range of shaft speeds")
    add_case(w)
    w.add_argument("--from-hz", required=True, type=finite_float("--from-hz", 0.0), help="first speed [Hz]")
    w.add_argument("--to-hz", required=True, type=finite_float("--to-hz", 0.0), help="last speed [Hz]")
    w.add_argument("--steps", required=True, type=pos_int("--steps", 1, SWEEP_MAX_STEPS),
                   help=f"number of speeds (at most {SWEEP_MAX_STEPS}; {SWEEP_MAX_STEPS_IN_MEMORY} with --json or --png)")
    w.add_argument("--png", type=output_path("--png", (".png",)), help="order map and RMS vs speed")
    g = w.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true", help="one JSON document: speeds, lines (names, frequencies) and per "
                                                       "location and direction amplitudes, phases, overall RMS")
    g.add_argument("--csv", action="store_true", help="tidy CSV: one row per speed, line, location, direction "
                                                      "(streamed as computed)")
    g.add_argument("--jsonl", action="store_true", help="JSON lines: one object per speed (streamed as computed)")
    w.set_defaults(func=cmd_sweep)

    v = sub.add_parser("validate", help="time-domain reference (TDSM) against BKA-BEM at one speed")
    add_case(v)
    v.add_argument("--speed-hz", type=finite_float("--speed-hz", VALIDATE_MIN_SPEED_HZ), default=None,
                   help=f"shaft speed [Hz], {VALIDATE_MIN_SPEED_HZ:g} .. the case's operating.max_speed_hz")
    v.add_argument("--duration", type=finite_float("--duration", 0.0, strict=True, maximum=VALIDATE_MAX_DURATION_S),
                   default=None, help=f"simulated time after the transient [s] (at most {VALIDATE_MAX_DURATION_S:g}: "
                                      f"the TDSM takes ~10 s of computing per simulated s)")
    v.add_argument("--improvement", default=None, choices=("hill", "paper", "four_dof", "hbm", "none"),
                   help="also evaluate this variant of BKA-BEM (default hill: the improved method; "
                        "docs/validation.md)")
    v.add_argument("--max-step-us", type=finite_float("--max-step-us", 0.0, strict=True), default=None,
                   help="largest TDSM step [us] (default: the TDSM's rule)")
    v.add_argument("--json", action="store_true",
                   help="one JSON document: the TDSM's and BKA-BEM's amplitudes per line and the errors in dB")
    v.add_argument("--png", type=output_path("--png", (".png",)),
                   help="figure: the TDSM and BKA-BEM spectra overlaid at the rotor and housing nodes")
    v.set_defaults(func=cmd_validate)

    d = sub.add_parser("demo", help="the main job: core tables and figures, then the ROS 2 node run-up recorded "
                                    "to MCAP and Rerun")
    add_case(d)
    d.add_argument("--out", default="out/demo", help="folder for the core figures (default out/demo)")
    d.add_argument("--speeds", type=finite_float("--speeds", 0.0), nargs="+", default=[10.0, 25.0, 50.0],
                   help="shaft speeds [Hz] for the spectrum tables")
    d.add_argument("--recordings", default="recordings", help="folder for demo.mcap and demo.rrd")
    from bkabem_ros.cli.demo import add_run_up_arguments  # options only; rclpy is imported when it runs

    add_run_up_arguments(d)
    d.add_argument("--no-ros", action="store_true", help="core part only (no ROS 2 node run)")
    d.set_defaults(func=cmd_demo, ros_network=lambda a: not a.no_ros)
