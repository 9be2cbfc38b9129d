"""Synthesis speed (issue 4): real-time factor of bkabem_core.synth.synthesizer for 8 channels at 51.2 kHz.

8 channels = DE/NDE x vertical/horizontal x (housing acceleration, shaft-relative displacement), every kept order
(50 on the embedded case), float32, chunks of 0.1 s unless stated. Real-time factor = signal seconds / wall
seconds, median of ``--repeat`` runs (CPU seconds of this process alongside: the project machine is shared).

    cd /work/main && OPENBLAS_NUM_THREADS=1 python3 bench/bench_synth.py            # table for BENCHMARKS.md
    python3 bench/bench_synth.py --seconds 5 --repeat 3 --json out.json
    python3 bench/bench_synth.py --figures docs/img        # the figures of docs/synthesis.md (no timing)

Scenarios
---------
constant        constant 25 Hz (one spectrum, then only the sample loop)
stream/exact    next_chunk() with a new speed every chunk (random walk 20..30 Hz): an exact BKA-BEM solve per chunk
stream/modal    the same with spectrum="modal" (prepare() first: the eigen-decompositions and the speed cells up to the
                case's max speed are a one-off cost per model, ~2 s)
ramp            render of ramp:0:50:<seconds> (auto spectrum; knots every 0.1 s and every 0.5 Hz)
+slip+noise     slip 1 %, accelerometer and probe noise
chunk 1 s       a new speed every 1-s chunk
memory          tracemalloc peak of a 10x longer run / the short run (bounded by the chunk, not the run)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.solve.harmonic import BkaBem  # noqa: E402
from bkabem_core.synth.synthesizer import Synthesizer  # noqa: E402

FS = 51200.0


def speeds_random_walk(n: int, seed: int = 0) -> list[float]:
    rng = np.random.default_rng(seed)
    v, out = 25.0, []
    for _ in range(n):
        v = float(np.clip(v + rng.normal(0.0, 0.3), 20.0, 30.0))
        out.append(v)
    return out


def time_stream(model, seconds: float, chunk_s: float, **kw):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=chunk_s, **kw)
    n = int(round(seconds / chunk_s))
    speeds = speeds_random_walk(n)
    s.prepare()                                            # one-off: the modal form's eigen-decompositions
    s.reset()
    t0, c0 = time.perf_counter(), time.process_time()
    for v in speeds:
        s.next_chunk(v)
    return time.perf_counter() - t0, time.process_time() - c0


def time_render(model, profile: str, seconds: float, chunk_s: float = 0.1, **kw):
    s = Synthesizer(model, sample_rate_hz=FS, chunk_s=chunk_s, **kw)
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in s.render(profile, seconds):
        pass
    return time.perf_counter() - t0, time.process_time() - c0, s.spectrum_method


def memory_ratio(model, seconds: float) -> tuple[float, float]:
    def peak(secs):
        s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, slip=0.01, noise_density={"acceleration": 1e-3})
        gen = s.render(f"steps:20,22,21,23:{secs / 8:g}", secs)
        next(gen)
        tracemalloc.start()
        for _ in gen:
            pass
        p = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return p
    a, b = peak(seconds), peak(10 * seconds)
    return a / 1e6, b / 1e6


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="signal seconds per run (default 10)")
    ap.add_argument("--repeat", type=int, default=5, help="runs per scenario; the median is reported")
    ap.add_argument("--json", default=None, help="also write the results here")
    ap.add_argument("--figures", default=None, help="write docs/synthesis.md's figures into this folder and stop")
    args = ap.parse_args(argv)
    if args.figures:
        figures(Path(args.figures))
        return 0

    load0 = os.getloadavg()
    t = time.perf_counter()
    model = BkaBem(Case.load())
    prep = time.perf_counter() - t
    secs = args.seconds
    rows = []

    def record(name, runs, extra=""):
        wall = statistics.median(r[0] for r in runs)
        cpu = statistics.median(r[1] for r in runs)
        rows.append({"scenario": name, "signal_s": secs, "wall_s": wall, "cpu_s": cpu,
                     "rtf_wall": secs / wall, "rtf_cpu": secs / cpu, "note": extra})
        print(f"  {name:34s} {secs / wall:8.0f}x wall  {secs / cpu:8.0f}x cpu   {extra}", flush=True)

    print(f"BkaBem preparation {prep:.2f} s; {secs:g} s of signal per run, median of {args.repeat}", flush=True)
    for feats in (False, True):
        tag = "" if feats else ", no features"
        runs = [time_render(model, "constant:25", secs, features=feats)[:2] for _ in range(args.repeat)]
        record(f"constant 25 Hz{tag}", runs)
    for spec in ("exact", "modal"):
        for feats in (False, True):
            tag = "" if feats else ", no features"
            runs = [time_stream(model, secs, 0.1, spectrum=spec, features=feats) for _ in range(args.repeat)]
            record(f"stream/{spec}: new speed every chunk{tag}", runs)
    runs = [time_stream(model, secs, 1.0, spectrum="modal") for _ in range(args.repeat)]
    record("stream/modal, 1-s chunks", runs)
    runs = [time_render(model, f"ramp:0:50:{secs:g}", secs) for _ in range(args.repeat)]
    record(f"ramp 0-50 Hz in {secs:g} s (auto: {runs[0][2]})", [r[:2] for r in runs])
    runs = [time_render(model, "constant:25", secs, slip=0.01,
                        noise_density={"acceleration": 1e-3, "displacement": 1e-9})[:2] for _ in range(args.repeat)]
    record("constant 25 Hz + slip 1 % + noise", runs)
    m_short, m_long = memory_ratio(model, 2.0)
    print(f"  memory peak (tracemalloc): {m_short:.1f} MB for 2 s, {m_long:.1f} MB for 20 s", flush=True)
    load1 = os.getloadavg()
    info = {"cpu": _cpu_name(), "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "openblas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "loadavg_start": load0, "loadavg_end": load1, "sample_rate_hz": FS, "channels": 8,
            "orders": int(model.orders.size), "memory_mb": {"2s": m_short, "20s": m_long}}
    print(f"machine: {info['cpu']}, {info['cores']} cores, load average {load0[0]:.2f} -> {load1[0]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps({"info": info, "results": rows}, indent=2))
    return 0


def figures(folder: Path) -> None:
    """synth_ramp.png (spectrogram of a run-up with BPFO orders) and synth_slip.png (envelope spectra)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import signal

    folder.mkdir(parents=True, exist_ok=True)
    model = BkaBem(Case.load())
    fs = 51200.0
    s = Synthesizer(model, sample_rate_hz=fs)
    x = np.concatenate([c.samples for c in s.render("ramp:5:40:4", 4.0)], axis=1)
    acc = x[s.channel_names.index("de_vertical_acceleration")].astype(float)
    f, t, sxx = signal.spectrogram(acc, fs, nperseg=2048, noverlap=1536, window="hann")
    fig, ax = plt.subplots(figsize=(10, 5))
    ax.pcolormesh(t, f, 10 * np.log10(sxx + 1e-12), shading="auto", cmap="magma", vmin=-60)
    tt = np.linspace(0, 4, 200)
    for k in (1, 5, 10, 20, 30):
        ax.plot(tt, k * model.bpfo_per_hz * (5 + 35 * tt / 4), "c--", lw=0.8)
        ax.text(4.02, k * model.bpfo_per_hz * 40, f"{k} BPFO", color="c", fontsize=7, va="center")
    ax.set_ylim(0, 10000)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_title("DE vertical housing acceleration, run-up 5 -> 40 Hz in 4 s (51.2 kHz, 50 orders); "
                 "dashed: k x BPFO(t)", fontsize=9)
    fig.tight_layout()
    fig.savefig(folder / "synth_ramp.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(10, 4.5))
    speed = 25.0
    bpfo = model.bpfo_per_hz * speed
    for slip, col in ((0.0, "C0"), (0.015, "C3")):
        s = Synthesizer(model, sample_rate_hz=fs, slip=slip, seed=1, noise_density={"acceleration": 2e-3})
        y = np.concatenate([c.samples for c in s.render(f"constant:{speed}", 4.0)], axis=1)
        y = y[s.channel_names.index("de_vertical_acceleration")].astype(float)
        b, a = signal.butter(4, [2000, 8000], btype="bandpass", fs=fs)
        env = np.abs(signal.hilbert(signal.filtfilt(b, a, y))) ** 2
        env -= env.mean()
        spec = np.abs(np.fft.rfft(env * np.hanning(env.size))) * 2 / np.hanning(env.size).sum()
        fr = np.fft.rfftfreq(env.size, 1 / fs)
        keep = fr < 12 * bpfo
        ax.plot(fr[keep], spec[keep], color=col, lw=0.8, label=f"slip {slip * 100:g} %")
    for k in range(1, 12):
        ax.axvline(k * bpfo, color="k", lw=0.4, alpha=0.3)
    ax.set_xlabel(f"frequency [Hz]  (grey: k x BPFO = {bpfo:.1f} Hz at {speed:g} Hz)")
    ax.set_ylabel("squared-envelope spectrum [(m/s^2)^2]")
    ax.set_title("Squared-envelope spectrum (2-8 kHz band) of the DE vertical acceleration, 4 s at 25 Hz, noise "
                 "2e-3 m/s^2/rtHz\nrandom slip smears the higher BPFO harmonics", fontsize=9)
    ax.legend()
    fig.tight_layout()
    fig.savefig(folder / "synth_slip.png", dpi=110)
    plt.close(fig)
    print(f"wrote {folder / 'synth_ramp.png'}, {folder / 'synth_slip.png'}")


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


if __name__ == "__main__":
    sys.exit(main())
