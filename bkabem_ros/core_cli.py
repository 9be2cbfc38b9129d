"""The core commands of ``bkabem``: ``excitation``, ``spectrum``, ``sweep``, ``validate`` and ``demo``.

They parse, call ``bkabem_core`` and print; none imports rclpy (``demo`` only for its ROS part, after the core
part). Field names of the JSON outputs follow the contract in ``architecture.md``. Errors follow the contract
of :mod:`bkabem_ros.cli_base` (one line naming the argument or case key, exit code 2).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time

import numpy as np

from .cli_base import UsageError, finite_float, output_path, pos_int

# --------------------------------------------------------------------------- helpers
def _load_case(path):
    from bkabem_core.case import Case

    return Case.load(path)


def _model(case, solver="modal"):
    from bkabem_core.harmonic import BkaBem

    return BkaBem(case, solver=solver)


def _print_json(obj) -> None:
    json.dump(obj, sys.stdout, indent=1)
    sys.stdout.write("\n")


def _excitation_table(ex, max_rows: int = 24) -> str:
    d = ex.to_dict()
    what = "quasi-static excitation" if ex.method == "quasi_static" else \
        f"4-DOF excitation at {ex.reference_speed_hz:g} Hz"
    lines = [
        f"{(ex.bearing or '').upper()} bearing, {what} under {ex.radial_load_n:.1f} N radial + {ex.axial_load_n:.0f} N "
        f"axial  (BPFO {ex.bpfo_per_hz:.4f} x shaft Hz, clearance {ex.clearance_m * 1e6:.1f} um, "
        f"{len(ex.orders)} orders kept of {len(ex.all_orders)}"
        + (f"; {len(ex.lines)} lines of its defects, --json for all)" if ex.lines is not None else ")"),
        f"  DC           vertical {d['dc_m']['vertical'] * 1e6:9.3f} um   horizontal "
        f"{d['dc_m']['horizontal'] * 1e6:9.4f} um",
        f"  peak-to-peak vertical {d['peak_to_peak_m']['vertical'] * 1e6:9.3f} um   horizontal "
        f"{d['peak_to_peak_m']['horizontal'] * 1e6:9.4f} um",
        f"  {'order':>5} {'f@ref [Hz]':>10} {'A_v [um]':>10} {'phi_v [rad]':>11} {'A_h [um]':>10} {'phi_h [rad]':>11}",
    ]
    for i, k in enumerate(ex.orders[:max_rows]):
        lines.append(f"  {k:5d} {k * ex.bpfo_per_hz * ex.reference_speed_hz:10.3f} "
                     f"{ex.amplitude_m['vertical'][i] * 1e6:10.4f} {ex.phase_rad['vertical'][i]:11.4f} "
                     f"{ex.amplitude_m['horizontal'][i] * 1e6:10.4f} {ex.phase_rad['horizontal'][i]:11.4f}")
    if len(ex.orders) > max_rows:
        lines.append(f"  ... {len(ex.orders) - max_rows} more orders (--json for all)")
    return "\n".join(lines)


def _spectrum_table(sp, max_rows: int = 12) -> str:
    from bkabem_core.harmonic import LOCATIONS

    ff = sp.fault_frequencies_hz
    lines = [f"BKA-BEM spectrum at {sp.speed_hz:g} Hz shaft speed ({sp.speed_hz * 60:.0f} rpm): FTF {ff.ftf:.3f} Hz, "
             f"BPFO {ff.bpfo:.3f} Hz, BPFI {ff.bpfi:.3f} Hz, BSF {ff.bsf:.3f} Hz"]
    acc = np.abs(sp.acceleration)
    disp = np.abs(sp.displacement)
    head = "  " + f"{'order':>5} {'f [Hz]':>9}" + "".join(f" {loc + ' v/h [m/s2]':>27}" for loc in LOCATIONS)
    lines.append(head)
    for i, k in enumerate(sp.orders[:max_rows]):
        row = f"  {k:5d} {sp.frequency_hz[i]:9.2f}"
        for li in range(len(LOCATIONS)):
            row += f" {acc[i, li, 0]:13.4e}/{acc[i, li, 1]:.4e}"
        lines.append(row)
    if len(sp.orders) > max_rows:
        lines.append(f"  ... {len(sp.orders) - max_rows} more orders (--json for all)")
    rms_a = np.sqrt(0.5 * np.sum(acc ** 2, axis=0))
    rms_d = np.sqrt(0.5 * np.sum(disp ** 2, axis=0))
    for li, loc in enumerate(LOCATIONS):
        lines.append(f"  {loc:12s} overall RMS acceleration v/h {rms_a[li, 0]:.4e}/{rms_a[li, 1]:.4e} m/s2, "
                     f"displacement v/h {rms_d[li, 0] * 1e6:.4f}/{rms_d[li, 1] * 1e6:.4f} um, "
                     f"DC v/h {sp.dc_m[li, 0] * 1e6:.3f}/{sp.dc_m[li, 1] * 1e6:.4f} um")
    return "\n".join(lines)


# --------------------------------------------------------------------------- commands
def cmd_excitation(args) -> int:
    case = _load_case(args.case)
    from bkabem_core.machine import BEARINGS, Machine

    machine = Machine(case, mesh=None)
    names = BEARINGS if args.all_bearings else machine.excited_bearings()
    exs = {n: machine.excitation(n, method=args.method) for n in names}
    ex = exs.get(case.faulty_bearing, next(iter(exs.values())))
    if args.png:
        from bkabem_core.plots import plot_excitation

        plot_excitation(ex, args.png)
    if args.json:
        out = ex.to_dict()          # the faulty bearing's at the top level (CLI contract), every bearing below
        out["bearings"] = {n: e.to_dict() for n, e in exs.items()}
        _print_json(out)
    else:
        print("\n\n".join(_excitation_table(e) for e in exs.values()))
        if args.png:
            print(f"wrote {args.png}")
    return 0


def cmd_spectrum(args) -> int:
    case = _load_case(args.case)
    model = _model(case)
    sp = model.spectrum(args.speed_hz)
    if args.png:
        from bkabem_core.plots import plot_spectrum

        plot_spectrum(sp, args.png)
    if args.json:
        _print_json(sp.to_dict())
    else:
        print(_spectrum_table(sp))
        if args.png:
            print(f"wrote {args.png}")
    return 0


def cmd_sweep(args) -> int:
    if args.to_hz < args.from_hz:
        raise UsageError(f"--to-hz ({args.to_hz:g}) must be >= --from-hz ({args.from_hz:g})")
    case = _load_case(args.case)
    model = _model(case)
    speeds = np.linspace(args.from_hz, args.to_hz, args.steps)
    t0 = time.perf_counter()
    sw = model.sweep(speeds, progress=not (args.json or args.csv) and sys.stderr.isatty())
    elapsed = time.perf_counter() - t0
    if args.png:
        from bkabem_core.plots import plot_sweep

        plot_sweep(sw, args.png)
    from bkabem_core.excitation import DIRECTIONS
    from bkabem_core.harmonic import LOCATIONS

    acc, disp = sw.acceleration, sw.displacement
    if args.json:
        out = {"speeds_hz": speeds.tolist(), "orders": [int(k) for k in sw.orders], "bpfo_per_hz": sw.bpfo_per_hz,
               "wall_time_s": elapsed}
        rms_a, rms_d = sw.rms("acceleration"), sw.rms("displacement")
        for li, loc in enumerate(LOCATIONS):
            out[loc] = {}
            for di, d in enumerate(DIRECTIONS):
                out[loc][d] = {
                    "displacement_m": np.abs(disp[:, :, li, di]).tolist(),
                    "acceleration_m_s2": np.abs(acc[:, :, li, di]).tolist(),
                    "phase_rad": np.angle(disp[:, :, li, di]).tolist(),
                    "rms_acceleration_m_s2": rms_a[:, li, di].tolist(),
                    "rms_displacement_m": rms_d[:, li, di].tolist(),
                }
        _print_json(out)
    elif args.csv:
        w = csv.writer(sys.stdout)
        w.writerow(["speed_hz", "order", "frequency_hz", "location", "direction", "displacement_m",
                    "acceleration_m_s2", "phase_rad"])
        f = sw.frequency_hz
        for si, s in enumerate(speeds):
            for ki, k in enumerate(sw.orders):
                for li, loc in enumerate(LOCATIONS):
                    for di, d in enumerate(DIRECTIONS):
                        x = disp[si, ki, li, di]
                        w.writerow([f"{s:.6g}", int(k), f"{f[si, ki]:.6g}", loc, d, f"{abs(x):.6e}",
                                    f"{abs(acc[si, ki, li, di]):.6e}", f"{np.angle(x):.6f}"])
    else:
        rms = sw.rms("acceleration")
        print(f"sweep {args.from_hz:g}..{args.to_hz:g} Hz, {args.steps} speeds x {sw.orders.size} orders "
              f"in {elapsed * 1e3:.1f} ms")
        print(f"  {'speed [Hz]':>10}" + "".join(f" {loc + ' v/h RMS [m/s2]':>27}" for loc in LOCATIONS))
        step = max(1, args.steps // 15)
        for si in range(0, args.steps, step):
            print(f"  {speeds[si]:10.3f}" + "".join(f" {rms[si, li, 0]:13.4e}/{rms[si, li, 1]:.4e}"
                                                    for li in range(len(LOCATIONS))))
        if args.png:
            print(f"wrote {args.png}")
    return 0


def cmd_validate(args) -> int:
    try:
        from bkabem_core import validation
    except ImportError as exc:  # pragma: no cover - until the TDSM lands
        raise UsageError(f"validate is not available: {exc}") from None
    case = _load_case(args.case)
    kwargs = {}
    if args.speed_hz is not None:
        kwargs["speed_hz"] = args.speed_hz
    if args.duration is not None:
        kwargs["duration_s"] = args.duration
    if args.improvement:
        kwargs["improvement"] = None if args.improvement == "none" else args.improvement
    if args.max_step_us is not None:
        kwargs["max_step_s"] = args.max_step_us * 1e-6
    result = validation.validate(case, progress=not args.json and sys.stderr.isatty(), **kwargs)
    if args.png:
        validation.plot_validation(result, args.png)
    if args.json:
        _print_json(result.to_dict())
    else:
        print(result.summary() if hasattr(result, "summary") else json.dumps(result.to_dict(), indent=1))
    return 0


def cmd_demo(args) -> int:
    """The main job on the embedded case.

    1. the BKA-BEM core: excitation table, spectra at a few speeds, figures in ``--out`` (default out/demo);
    2. the ROS 2 node through a run-up and a hold, recorded to ``recordings/demo.mcap`` and ``demo.rrd``
       (bkabem_ros.demo), with progress, a summary and the command that opens the result in Rerun.
    """
    from pathlib import Path

    case = _load_case(args.case)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
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
    from bkabem_core.plots import plot_excitation, plot_spectrum, plot_sweep

    plot_excitation(ex, str(out / "excitation.png"))
    for s in args.speeds:
        t1 = time.perf_counter()
        sp = model.spectrum(s)
        dt = time.perf_counter() - t1
        print()
        print(_spectrum_table(sp, max_rows=6))
        print(f"  (solved in {dt * 1e3:.2f} ms)")
    plot_spectrum(model.spectrum(args.speeds[-1]), str(out / "spectrum.png"))
    speeds = np.linspace(0.5, case.max_speed_hz, 500)
    t1 = time.perf_counter()
    sw = model.sweep(speeds)
    print(f"\nsweep of {speeds.size} speeds x {sw.orders.size} orders in {(time.perf_counter() - t1) * 1e3:.0f} ms")
    plot_sweep(sw, str(out / "sweep.png"))
    print(f"wrote {out / 'excitation.png'}, {out / 'spectrum.png'}, {out / 'sweep.png'}")
    if args.no_ros:
        return 0
    try:
        from .demo import run_demo
    except ImportError as exc:
        raise UsageError(f"the ROS 2 part needs the ROS set-up (make demo installs it): {exc}") from None
    print(f"\n== 2/2  ROS 2 node: run-up 0 -> {args.top_hz:g} Hz in {args.ramp:g} s, hold {args.hold:g} s, "
          f"recording to {args.recordings}/demo.mcap and demo.rrd", flush=True)
    r = run_demo(args.recordings, ramp_s=args.ramp, hold_s=args.hold, top_hz=args.top_hz,
                 sample_rate=args.sample_rate, case=args.case, rerun=not args.no_rerun)
    return 1 if r.errors else 0


# --------------------------------------------------------------------------- parser
def add_case(sp) -> None:
    """``--case`` of every command that loads a case."""
    sp.add_argument("--case", default=None,
                    help="embedded case name or TOML file (default: electric_motor_6010)")


def add_parsers(sub) -> None:
    """Register ``excitation``, ``spectrum``, ``sweep``, ``validate`` and ``demo`` on an argparse subparsers object."""
    e = sub.add_parser("excitation", help="bearing excitation: DC, amplitudes and phases per BPFO order")
    add_case(e)
    e.add_argument("--json", action="store_true", help="machine-readable output")
    e.add_argument("--png", help="write a figure of the waveform and orders")
    e.add_argument("--method", choices=("quasi_static", "four_dof"), default=None,
                   help="excitation model (default: the case's [excitation] method)")
    e.add_argument("--all-bearings", action="store_true",
                   help="every bearing, also those the case does not excite ([excitation] bearings)")
    e.set_defaults(func=cmd_excitation)

    s = sub.add_parser("spectrum", help="BKA-BEM spectrum at one shaft speed")
    add_case(s)
    s.add_argument("--speed-hz", required=True, type=finite_float("--speed-hz", 0.0),
                   help="shaft speed [Hz]")
    s.add_argument("--json", action="store_true")
    s.add_argument("--png")
    s.set_defaults(func=cmd_spectrum)

    w = sub.add_parser("sweep", help="BKA-BEM spectra over a range of shaft speeds")
    add_case(w)
    w.add_argument("--from-hz", required=True, type=finite_float("--from-hz", 0.0), help="first speed [Hz]")
    w.add_argument("--to-hz", required=True, type=finite_float("--to-hz", 0.0), help="last speed [Hz]")
    w.add_argument("--steps", required=True, type=pos_int("--steps", 1), help="number of speeds")
    w.add_argument("--png", help="order map and RMS vs speed")
    g = w.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true")
    g.add_argument("--csv", action="store_true", help="tidy CSV: one row per speed, order, location, direction")
    w.set_defaults(func=cmd_sweep)

    v = sub.add_parser("validate", help="time-domain reference (TDSM) against BKA-BEM at one speed")
    add_case(v)
    v.add_argument("--speed-hz", type=finite_float("--speed-hz", 0.0, strict=True), default=None)
    v.add_argument("--duration", type=finite_float("--duration", 0.0, strict=True), default=None,
                   help="simulated time after the transient [s]")
    v.add_argument("--improvement", default=None, choices=("hill", "paper", "four_dof", "hbm", "none"),
                   help="also evaluate this variant of BKA-BEM (default hill: the improved method; "
                        "docs/validation.md)")
    v.add_argument("--max-step-us", type=finite_float("--max-step-us", 0.0, strict=True), default=None,
                   help="largest TDSM step [us] (default: the TDSM's rule)")
    v.add_argument("--json", action="store_true")
    v.add_argument("--png")
    v.set_defaults(func=cmd_validate)

    d = sub.add_parser("demo", help="the main job: core tables and figures, then the ROS 2 node run-up recorded "
                                    "to MCAP and Rerun")
    add_case(d)
    d.add_argument("--out", default="out/demo", help="folder for the core figures (default out/demo)")
    d.add_argument("--speeds", type=finite_float("--speeds", 0.0), nargs="+", default=[10.0, 25.0, 50.0],
                   help="shaft speeds [Hz] for the spectrum tables")
    d.add_argument("--recordings", default="recordings", help="folder for demo.mcap and demo.rrd")
    from .demo import add_run_up_arguments    # options only; rclpy is imported when it runs

    add_run_up_arguments(d)
    d.add_argument("--no-ros", action="store_true", help="core part only (no ROS 2 node run)")
    d.set_defaults(func=cmd_demo)
