"""Fault library (issue 12): preparation per defect kind, a new speed, synthesis with slip and noise.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_faults.py --repeat 3        # table for BENCHMARKS.md
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_faults.py --repeat 1 --seconds 2 --json out.json

Cases: ``electric_motor_6010`` (the in-run reference: outer race, BPFO orders only, the original fast path) and the
fault library's ``motor_6010_{healthy,outer,inner,ball}`` (G 2.5 unbalance; inner-race and ball defects on the
2-torus). Per case:

preparation     ``BkaBem(case)``: excitation (quasi-static, 2-torus for inner/ball) + FE + modal basis + one
                eigen-decomposition per speed-locked line; median of ``--repeat``
new speed       ``model.response([f])`` at 200 random speeds in 5-75 Hz; median [us]
synthesis       ``next_chunk(v)`` with a new speed every 0.1-s chunk (random walk 20-30 Hz), 8 channels at 51.2
                kHz, float32, slip 1 % and accelerometer + probe noise, features on (the realistic path; ``--features
                off``: the waveform stream alone), after
                ``prepare()`` and one pass over the speed range (speed cells made); real-time factor = signal
                seconds / wall seconds, median of ``--repeat``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "bench"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import numpy as np  # noqa: E402
from bench_synth import speeds_random_walk  # noqa: E402  (the same speed stream as the synthesis benchmark)

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402
from bkabem_core.synth.synthesizer import Synthesizer  # noqa: E402

FS = 51200.0
CASES = ("electric_motor_6010", "motor_6010_healthy", "motor_6010_outer", "motor_6010_inner", "motor_6010_ball")
NOISE = {"acceleration": 1e-3, "displacement": 1e-10}


def bench_case(name: str, repeat: int, seconds: float, features: bool = True) -> dict:
    case = Case.load(name)
    prep, parts, model = [], None, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        model = BkaBem(case)
        prep.append(time.perf_counter() - t0)
        parts = dict(model.preparation_time_s)
    rng = np.random.default_rng(1)
    times = []
    for f in rng.uniform(5.0, 75.0, 200):
        t0 = time.perf_counter()
        model.response([f])
        times.append(time.perf_counter() - t0)
    out = {"case": name, "lines": len(model.lines), "order_set": model.is_order_set,
           "preparation_s": statistics.median(prep), "preparation_parts_s": parts,
           "new_speed_us": 1e6 * statistics.median(times)}
    for label, kw in (("plain", {}), ("slip_noise", {"slip": 0.01, "noise_density": NOISE})):
        rts = []
        for r in range(repeat):
            s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, features=features, **kw)
            s.prepare()
            for v in np.linspace(20.0, 30.0, 41):                  # speed cells of the range made (one-off)
                s.next_chunk(float(v))
            s.reset()
            speeds = speeds_random_walk(int(round(seconds / 0.1)), seed=r)
            t0 = time.perf_counter()
            for v in speeds:
                s.next_chunk(v)
            rts.append(seconds / (time.perf_counter() - t0))
        out[f"synthesis_{label}_rt"] = statistics.median(rts)
        out["spectrum_method"] = s.spectrum_method
    return out


def figures(out_dir: Path) -> None:
    """docs/img/fault_envelopes.png: envelope spectra of the four fault-library machines at 25 Hz (no timing)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import signal

    speed = 25.0
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True, constrained_layout=True)
    for ax, kind in zip(axes, ("healthy", "outer", "inner", "ball")):
        model = BkaBem(Case.load(f"motor_6010_{kind}"))
        s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.25, quantities=("acceleration",), slip=0.01, seed=3,
                        noise_density={"acceleration": 2e-4}, band_limit="taper", features=False)
        x = np.concatenate([s.next_chunk(speed).channel("de_vertical_acceleration") for _ in range(8)])
        x = x.astype(float)
        f, pxx = signal.welch(x, FS, nperseg=4096)
        edges = np.arange(1000.0, 0.4 * FS, 500.0)
        lo = edges[int(np.argmax([pxx[(f >= e) & (f < e + 1000.0)].sum() for e in edges]))]
        sos = signal.butter(4, [lo, lo + 1000.0], btype="bandpass", fs=FS, output="sos")
        env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x))) ** 2
        env -= env.mean()
        spec = np.abs(np.fft.rfft(env * np.hanning(env.size)))
        fr = np.fft.rfftfreq(env.size, 1.0 / FS)
        keep = fr <= 400.0
        ax.plot(fr[keep], spec[keep] / np.median(spec[keep]), lw=0.7, color="k")
        fm = model.fault_multipliers
        for name, fc, col in (("FTF", fm.ftf, "C4"), ("BPFO", fm.bpfo, "C0"), ("BPFI", fm.bpfi, "C3"),
                              ("2 BSF", 2 * fm.bsf, "C2")):
            for h in (1, 2):
                ax.axvline(h * fc * speed, color=col, lw=0.8, alpha=0.6, ls="-" if h == 1 else ":",
                           label=name if h == 1 else None)
        ax.set_yscale("log")
        ax.set_ylabel("envelope / median")
        ax.set_title(f"motor_6010_{kind} at {speed:g} Hz: band {lo / 1e3:.1f}-{lo / 1e3 + 1:.1f} kHz", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=4, loc="upper right")
    axes[-1].set_xlabel("frequency [Hz]")
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "fault_envelopes.png", dpi=90)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=5.0, help="signal seconds per synthesis run")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--json", default=None)
    ap.add_argument("--features", choices=("on", "off"), default="on",
                    help="per-chunk features (RMS, kurtosis, ISO velocity...; on = the node's default) or the "
                         "waveform stream alone (off, as issue 4's 1000x target was measured)")
    ap.add_argument("--figures", default=None, metavar="DIR", help="write the docs figure to DIR and stop")
    args = ap.parse_args(argv)
    if args.figures:
        figures(Path(args.figures))
        return 0
    rows = []
    for name in args.cases.split(","):
        r = bench_case(name, args.repeat, args.seconds, features=args.features == "on")
        rows.append(r)
        print(json.dumps(r), flush=True)
    print(f"\nmachine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"features {args.features}, load {os.getloadavg()[0]:.1f}, python {platform.python_version()}, "
          f"numpy {np.__version__}")
    print("| case | lines | preparation [s] (excitation / solver set-up) | new speed [us] | synthesis, new speed "
          "every 0.1-s chunk [x real time] | same + slip 1 % + noise |")
    print("|---|---:|---|---:|---:|---:|")
    for r in rows:
        p = r["preparation_parts_s"]
        print(f"| {r['case']} | {r['lines']} | {r['preparation_s']:.2f} ({p['excitation']:.2f} / "
              f"{p['solver_setup']:.2f}) | {r['new_speed_us']:.0f} | {r['synthesis_plain_rt']:.0f} | "
              f"{r['synthesis_slip_noise_rt']:.0f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
