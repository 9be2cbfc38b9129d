"""``bkabem synth``: render sensor waveforms of a case under a speed profile, or of a scenario, to .npz or .csv.

    bkabem synth --profile constant:25 --seconds 10 --rate 51200 --out run.npz
    bkabem synth --profile ramp:0:50:10 --rate 51200 --out ramp.csv --png ramp.png
    bkabem synth --profile speeds.csv --out run.npz --slip 0.01 --noise-acc 1e-3 --seed 7
    bkabem synth --scenario de_outer_run_to_failure --time-scale 3600 --out rtf.npz     # 12 h in 12 s

With ``--scenario`` (docs/scenarios.md) the machine changes over scenario time (``--time-scale`` scenario seconds
per second of signal, ``--scenario-start`` the scenario time of the first sample): its speed profile (or
``--profile`` in signal time when it has none), its defects state by state, switched at chunk borders
(:class:`bkabem_core.scenario.run.ScenarioRun`). ``--seconds`` defaults to the rest of the scenario. The ``.npz``
then also holds, per chunk, ``chunk_state_index``, ``chunk_scenario_time_s`` and ``chunk_healthy``, and in its
metadata the scenario with every state's ground truth (``scenario.states``); the ``.csv`` a ``state`` column.

Output
------
``.npz`` (``numpy.load``): ``samples`` (channels, n) float32 [units per channel], ``speed_hz`` (n,) shaft speed per
sample, ``chunk_first_sample`` / ``chunk_speed_hz`` (chunks,), ``features_<name>`` (chunks, channels),
``iso10816_velocity_rms_mm_s`` (chunks, 2 bearings, 3: vertical, horizontal, overall; the labels of its axes in
``iso10816_bearing`` and ``iso10816_direction``), and ``metadata``: a JSON
string with channel names and units, sample rate, profile, settings, ground truth (case, bearing, defect, fault
multipliers, seed), the synthesiser's method and ``axes``: the name and labels of every array's axes. Written chunk by chunk: memory stays bounded by the chunk.

``.csv``: ``# metadata: {json}`` comment line, then a header ``time_s,speed_hz,<channel>_<unit>...`` (units in the
column names: ``m_s2``, ``m``, ``mm_s``) and one row per sample.

Bad input: one line on stderr naming the argument and the reason, exit code 2 (the contract of
:mod:`bkabem_ros.cli.base`: this module raises, the command line reports).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

from bkabem_ros.cli.base import UsageError, output_path, times_real_time, writing

if TYPE_CHECKING:                   # numpy and the synthesiser are imported when the command runs, not to parse
    import numpy as np

    from bkabem_core.synth.synthesizer import SynthError, Synthesizer

_UNIT_SUFFIX = {"m/s^2": "m_s2", "m": "m", "mm/s": "mm_s"}
#: Bounds of the options (beyond them the samples overflow float32 or the output does not fit a disk):
MAX_SECONDS = 1e5                   # ~28 h of signal
MAX_CHUNK_S = 10.0
SNR_DB_RANGE = (-40.0, 200.0)
MAX_NOISE_DENSITY = {"acceleration": 1e3, "displacement": 1e-2, "velocity": 1e5}   # per sqrt(Hz), in each unit
FEATURE_NAMES = ("mean", "rms", "peak", "peak_to_peak", "crest_factor", "kurtosis")
#: The third axis of ``iso10816_velocity_rms_mm_s``: each direction's ISO velocity RMS and the larger of the two.
ISO_DIRECTIONS = ("vertical", "horizontal", "overall")


def _axes(synth, iso_bearings, scenario: bool) -> dict:
    """The axis names of every array of the .npz (its ``metadata["axes"]``): array -> [(axis, labels or unit)]."""
    chunk = ["chunk", "one per chunk, first sample chunk_first_sample"]
    channels = ["channel", list(synth.channel_names)]
    out = {"samples": [channels, ["sample", "i / sample_rate_hz s"]], "speed_hz": [["sample", "shaft speed [Hz]"]],
           "chunk_first_sample": [chunk], "chunk_speed_hz": [chunk],
           "iso10816_velocity_rms_mm_s": [chunk, ["bearing", list(iso_bearings)], ["direction", list(ISO_DIRECTIONS)]],
           "iso10816_bearing": [["bearing", list(iso_bearings)]],
           "iso10816_direction": [["direction", list(ISO_DIRECTIONS)]]}
    out.update({f"features_{k}": [chunk, channels] for k in FEATURE_NAMES})
    if scenario:
        out.update({k: [chunk] for k in ("chunk_state_index", "chunk_scenario_time_s", "chunk_healthy")})
    return out


def add_synth_arguments(p: argparse.ArgumentParser, with_case: bool = False) -> None:
    """Options of ``bkabem synth`` (``--case`` is added by the main CLI; ``with_case`` for standalone use)."""
    if with_case:
        p.add_argument("--case", default=None, help="embedded case name or TOML file (default: electric_motor_6010)")
    p.add_argument("--profile", default=None,
                   help="constant:F | ramp:F0:F1:T | steps:F1,F2,...:T | FILE.csv (speeds in Hz, times in s; CSV "
                        "header time_s,speed_hz|speed_rpm|speed_rad_s); required without --scenario")
    p.add_argument("--scenario", default=None, metavar="NAME_OR_FILE",
                   help="scenario (embedded name or TOML, docs/scenarios.md) instead of --case: the machine over time")
    p.add_argument("--time-scale", default=None, help="scenario seconds per second of signal (default 1; e.g. 3600)")
    p.add_argument("--scenario-start", default=None, help="scenario time of the first sample [s] (default 0)")
    p.add_argument("--seconds", default=None,
                   help="duration [s] (default: the profile's last breakpoint; required for constant profiles)")
    p.add_argument("--rate", default=None, help="sample rate [Hz] (default: the case's measurement.sample_rate_hz, "
                                                  "else 25600)")
    p.add_argument("--chunk", default="0.1", help="chunk length [s] (default 0.1)")
    p.add_argument("--out", required=True, type=output_path("--out", (".npz", ".csv"), make_parents=True),
                   help="output file, .npz or .csv")
    p.add_argument("--png", default=None, type=output_path("--png", (".png",), make_parents=True),
                   help="figure: waveform excerpt and its spectrum, the fault frequencies marked and the largest "
                        "lines named")
    p.add_argument("--seed", default="0", help="seed of slip and noise (default 0)")
    p.add_argument("--slip", default=None, help="random slip: std of the ball-pass interval / its mean (e.g. 0.01; "
                   "default: the case's [measurement] slip, else 0)")
    p.add_argument("--noise-acc", default=None, help="accelerometer noise density [m/s^2/sqrt(Hz)] (e.g. 1e-3; "
                                                      "default: the case's measurement section, else none)")
    p.add_argument("--noise-disp", default=None, help="proximity-probe noise density [m/sqrt(Hz)] (e.g. 1e-9)")
    p.add_argument("--noise-vel", default=None, help="velocity noise density [mm/s/sqrt(Hz)]")
    p.add_argument("--snr-db", default=None, help="noise by signal-to-noise ratio [dB] instead of densities")
    p.add_argument("--quantities", default="acceleration,displacement",
                   help="comma list of acceleration, displacement, velocity (default acceleration,displacement)")
    p.add_argument("--max-order", default=None, help="synthesise BPFO orders up to this one (default: all kept)")
    p.add_argument("--band-limit", default="auto", choices=("auto", "taper", "error"),
                   help="taper: carry the lines up to the band, fading them out between 0.85 and 0.95 of Nyquist; "
                        "error: refuse a speed at which a kept line is above Nyquist; auto (default): taper for a "
                        "case that carries its lines to the band (excitation.max_order = 0, the fault library), "
                        "error for one that caps them")
    p.add_argument("--spectrum", default="auto", choices=("auto", "exact", "modal"),
                   help="spectrum at each knot: exact solve, modal form, or auto (the cheaper for the profile)")
    p.add_argument("--float64", action="store_true", help="float64 samples (default float32)")
    p.add_argument("--no-measurement", action="store_true",
                   help="leave out the case's [measurement] section (its sensor mount, filters, interference, "
                        "converter step, noise and rate): an ideal acquisition")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _num(name: str, text, kind=float, minimum=None, strict=False, allow_none=False, maximum=None):
    from bkabem_core.synth.synthesizer import SynthError

    if text is None:
        if allow_none:
            return None
        raise SynthError(name, "is required")
    try:
        if isinstance(text, str) and "_" in text:          # kind("1_0") is 10: a typo is not a number
            raise ValueError(text)
        v = kind(text)
    except (TypeError, ValueError):
        raise SynthError(name, f"must be {'an integer' if kind is int else 'a number'} (got {text!r})") from None
    if kind is float and not math.isfinite(v):
        raise SynthError(name, f"must be finite (got {text!r})")
    if minimum is not None and (v <= minimum if strict else v < minimum):
        raise SynthError(name, f"must be {'>' if strict else '>='} {minimum:g} (got {text})")
    if maximum is not None and v > maximum:
        raise SynthError(name, f"must be <= {maximum:g} (got {text})")
    return v


def _settings(args) -> dict:
    """Validated settings from the Namespace (raises SynthError naming the option)."""
    from bkabem_core.synth.synthesizer import SynthError, parse_profile

    scenario = getattr(args, "scenario", None)
    if scenario is None:
        for opt in ("time_scale", "scenario_start"):
            if getattr(args, opt, None) is not None:
                raise SynthError("--" + opt.replace("_", "-"), "only with --scenario")
        if args.profile is None:
            raise SynthError("--profile", "is required (or --scenario)")
    elif getattr(args, "case", None) is not None:
        raise SynthError("--case", "give --case or --scenario, not both (the scenario names its case)")
    profile = parse_profile(args.profile) if args.profile is not None else None
    seconds = _num("--seconds", args.seconds, float, 0.0, strict=True, allow_none=True, maximum=MAX_SECONDS)
    if seconds is None and scenario is None:
        if profile.duration_s <= 0:
            raise SynthError("--seconds", "is required for a constant profile")
        if profile.duration_s > MAX_SECONDS:
            raise SynthError("--profile", f"lasts {profile.duration_s:g} s, more than {MAX_SECONDS:g} s of signal; "
                                          f"give --seconds to render its start")
        seconds = profile.duration_s
    out = Path(args.out)
    if out.suffix.lower() not in (".npz", ".csv"):
        raise SynthError("--out", f"must end in .npz or .csv (got {args.out!r})")
    if args.png is not None and not str(args.png).lower().endswith(".png"):
        raise SynthError("--png", f"must end in .png (got {args.png!r})")
    dens = {}
    for opt, q in (("noise_acc", "acceleration"), ("noise_disp", "displacement"), ("noise_vel", "velocity")):
        v = _num("--" + opt.replace("_", "-"), getattr(args, opt, None), float, 0.0, allow_none=True,
                 maximum=MAX_NOISE_DENSITY[q])
        if v is not None:
            dens[q] = v
    snr = _num("--snr-db", getattr(args, "snr_db", None), float, SNR_DB_RANGE[0], allow_none=True,
               maximum=SNR_DB_RANGE[1])
    if dens and snr is not None:
        raise SynthError("--snr-db", "give noise densities or --snr-db, not both")
    from bkabem_core.scenario.run import TIME_SCALE_RANGE

    return {
        "profile": profile, "seconds": seconds, "out": out, "scenario": scenario,
        "time_scale": _num("--time-scale", getattr(args, "time_scale", None), float, TIME_SCALE_RANGE[0],
                           allow_none=True, maximum=TIME_SCALE_RANGE[1]),
        "scenario_start": _num("--scenario-start", getattr(args, "scenario_start", None), float, 0.0, allow_none=True),
        "rate": _num("--rate", args.rate, float, 0.0, strict=True, allow_none=True),
        "chunk": _num("--chunk", args.chunk, float, 0.0, strict=True, maximum=MAX_CHUNK_S),
        "seed": _num("--seed", args.seed, int, 0),
        "slip": _num("--slip", args.slip, float, 0.0, allow_none=True),
        "noise_density": dens or None, "snr_db": snr, "noise_given": bool(dens) or snr is not None,
        "max_order": _num("--max-order", args.max_order, int, 1, allow_none=True),
        "quantities": [q.strip() for q in str(args.quantities).split(",") if q.strip()],
    }


def _rate(st: dict, case, args) -> float:
    """The sample rate [Hz]: ``--rate``, else the case's acquisition rate (``measurement.sample_rate_hz``, 25.6 kHz
    without one or with ``--no-measurement``)."""
    from bkabem_core.synth.measurement import DEFAULT_SAMPLE_RATE_HZ, sample_rate_of

    if st["rate"] is not None:
        return st["rate"]
    return DEFAULT_SAMPLE_RATE_HZ if getattr(args, "no_measurement", False) else sample_rate_of(case)


def _measurement_options(st: dict, args) -> dict:
    """The synthesiser's noise, slip and measurement arguments: the options given, the case's section for the
    rest."""
    out = {"measurement": not getattr(args, "no_measurement", False), "snr_db": st["snr_db"]}
    if st["noise_given"]:
        out["noise_density"] = st["noise_density"]
    if st["slip"] is not None:
        out["slip"] = st["slip"]
    return out


def _check_free_space(out: Path, n_bytes: int) -> None:
    """Refuse an output that cannot fit the free space of its file system (estimated: samples x their size; a CSV
    value ~16 characters), before any of it is written."""
    import shutil

    from bkabem_core.synth.synthesizer import SynthError

    try:
        free = shutil.disk_usage(out.parent if str(out.parent) else ".").free
    except OSError:
        return
    if n_bytes > free:
        raise SynthError("--out", f"{out} would take ~{n_bytes / 1e9:.3g} GB, more than the {free / 1e9:.3g} GB free "
                                  f"there (fewer --seconds, a lower --rate or fewer --quantities)")


def _noise_options(args) -> list[str]:
    return [f"--{o.replace('_', '-')}" for o in ("noise_acc", "noise_disp", "noise_vel", "snr_db")
            if getattr(args, o, None) is not None]


def _rename(err: SynthError) -> SynthError:
    """Library argument names -> CLI option names (a speed above what the sample rate can carry: ``--rate``)."""
    from bkabem_core.synth.synthesizer import SynthError

    names = {"sample_rate_hz": "--rate", "chunk_s": "--chunk", "seconds": "--seconds", "slip": "--slip",
             "seed": "--seed", "max_order": "--max-order", "quantities": "--quantities", "snr_db": "--snr-db",
             "band_limit": "--band-limit", "tones": "--rate"}
    arg = err.argument
    if arg in ("speed_hz", "initial_speed_hz") and "below twice" in err.reason:
        # a chunk's speed (from --profile or the scenario's [speed]) puts a kept line above the Nyquist frequency of
        # the sample rate: the rate the user typed is what to change (or the band limit)
        arg = "sample_rate_hz"
    if arg in names:
        return SynthError(names[arg], err.reason + (" (try --band-limit taper or --max-order)"
                                                    if "Nyquist" in err.reason or "twice" in err.reason else ""))
    if arg.startswith("profile"):
        return SynthError("--profile" + arg[len("profile"):], err.reason)
    if arg.startswith("noise_density."):
        return SynthError("--noise-" + {"acceleration": "acc", "displacement": "disp",
                                        "velocity": "vel"}.get(arg.split(".", 1)[1], "?"), err.reason)
    return err


class _NpzWriter:
    """Streams an .npz: the sample array is written chunk by chunk (Fortran order: sample-major bytes)."""

    def __init__(self, path: Path, n_channels: int, n_total: int, dtype):
        import numpy as np

        self.path = path
        self.zf = zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED, allowZip64=True)
        self.fh = self.zf.open("samples.npy", "w", force_zip64=True)
        header = {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)), "fortran_order": True,
                  "shape": (n_channels, n_total)}
        np.lib.format.write_array_header_2_0(self.fh, header)
        self.written = 0

    def write(self, chunk, state: int | None = None) -> None:
        import numpy as np

        block = np.ascontiguousarray(chunk.samples.T)                 # (n, C) sample-major
        self.fh.write(block.tobytes())
        self.written += block.shape[0]

    def finish(self, arrays: dict, speed_writer, metadata: dict) -> None:
        import numpy as np

        self.fh.close()
        with self.zf.open("speed_hz.npy", "w", force_zip64=True) as fh:
            np.lib.format.write_array_header_2_0(
                fh, {"descr": np.lib.format.dtype_to_descr(np.dtype(np.float32)), "fortran_order": False,
                     "shape": (self.written,)})
            for part in speed_writer():
                fh.write(part.astype(np.float32).tobytes())
        for name, arr in arrays.items():
            with self.zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asarray(arr), allow_pickle=False)
        with self.zf.open("metadata.npy", "w") as fh:
            np.lib.format.write_array(fh, np.array(json.dumps(metadata)), allow_pickle=False)
        self.zf.close()

    def abort(self) -> None:
        """After a failure: close without writing more (the command line removes the file)."""
        fp = self.zf.fp
        self.zf.fp = None                      # ZipFile.close/__del__ would flush again into the failed file
        try:
            if fp is not None:
                fp.close()
        except OSError:
            pass


def _chunk_speed(chunk) -> np.ndarray:
    """Shaft speed [Hz] per sample of a streamed chunk (linear from its first to its end speed)."""
    import numpy as np

    return chunk.shaft_speed_hz + (chunk.shaft_speed_end_hz - chunk.shaft_speed_hz) * (
        np.arange(chunk.n_samples) / chunk.n_samples)


class _CsvWriter:
    def __init__(self, path: Path, synth: Synthesizer, profile, metadata: dict, state_column: bool = False):
        self.fh = open(path, "w", newline="")
        self.profile = profile
        self.fs = synth.sample_rate_hz
        self.state_column = state_column
        cols = ["time_s", "speed_hz"] + [f"{n}_{_UNIT_SUFFIX[u]}" for n, u in zip(synth.channel_names, synth.units)]
        if state_column:
            cols.append("state")
        self.fh.write("# metadata: " + json.dumps(metadata) + "\n")
        self.fh.write(",".join(cols) + "\n")

    def write(self, chunk, state: int | None = None) -> None:
        import numpy as np

        t = chunk.time_s
        speed = self.profile.speed_hz(t) if self.profile is not None else _chunk_speed(chunk)
        cols = [t, speed, chunk.samples.T.astype(np.float64)]
        if self.state_column:
            cols.append(np.full(t.size, float(state)))
        np.savetxt(self.fh, np.column_stack(cols), fmt="%.9g", delimiter=",")

    def close(self) -> None:
        self.fh.close()

    def abort(self) -> None:
        try:
            self.fh.close()
        except OSError:
            pass


def _plot(path: Path, excerpt: np.ndarray, fs: float, synth: Synthesizer, speed_hz: float, title: str):
    """Waveform excerpt and its spectrum, with the fault frequencies of each defect marked and the model's largest
    lines named (:mod:`bkabem_core.analysis.plots`); returns the figure (closed)."""
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bkabem_core.analysis.plots import _mark_fault_lines, _name_largest, defects_of_case, fault_line_hz
    from bkabem_core.model.vocabulary import DIRECTIONS, LOCATIONS

    names = list(synth.channel_names)
    acc = next((i for i, n in enumerate(names) if n.endswith("acceleration")), 0)
    disp = next((i for i, n in enumerate(names) if n.endswith("displacement")), None)
    model = synth.model
    ff = model.bearing_multipliers[synth.channels[acc].bearing].at_speed(speed_hz)      # the channel's bearing
    bpfo = ff.bpfo
    defects = defects_of_case(model.case)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(11, 8))
    n_show = int(min(excerpt.shape[1], fs * (5.0 / bpfo if bpfo > 0 else 0.05)))
    t = np.arange(n_show) / fs * 1e3
    ax1.plot(t, excerpt[acc, -n_show:], lw=0.8, color="C0", label=f"{names[acc]} [{synth.units[acc]}]")
    ax1.set_xlabel("time in excerpt [ms]")
    ax1.set_ylabel(synth.units[acc], color="C0")
    if disp is not None:
        ax1b = ax1.twinx()
        ax1b.plot(t, excerpt[disp, -n_show:] * 1e6, lw=0.8, color="C1", label=f"{names[disp]} [um]")
        ax1b.set_ylabel("shaft relative displacement [um]", color="C1")
    ax1.set_title(f"{title}\nlast {n_show / fs * 1e3:.1f} ms ({n_show / fs * bpfo:.1f} ball passes)", fontsize=9)
    ax1.legend(loc="upper left", fontsize=8)
    x = excerpt[acc].astype(float)
    n = x.size
    win = np.hanning(n)
    spec = np.abs(np.fft.rfft((x - x.mean()) * win)) * 2 / win.sum()
    f = np.fft.rfftfreq(n, 1 / fs)
    ax2.semilogy(f, np.maximum(spec, 1e-12), lw=0.7, color="C0", label=f"{names[acc]} (Hann, last {n / fs:.2f} s)")
    lines = synth.frequency_hz(speed_hz)
    f_hi = min(fs / 2, 1.05 * float(lines.max())) if lines.size and lines.max() > 0 else fs / 2
    legend: dict = {}
    bearing = synth.channels[acc].bearing
    _mark_fault_lines(ax2, fault_line_hz(ff, speed_hz), [d for d in defects if d.bearing == bearing], f_hi, legend)
    sp = model.spectrum(speed_hz)                  # the model's lines at this channel, to name the largest peaks
    col = LOCATIONS.index(f"{bearing}_housing"), DIRECTIONS.index(synth.channels[acc].direction)
    _name_largest(ax2, sp.frequency_hz, np.abs(sp.acceleration[:, col[0], col[1]]), list(sp.labels), f_hi=f_hi)
    ax2.set_xlim(0, f_hi)
    ax2.set_ylim(max(1e-12, float(spec.max()) * 1e-5) if spec.size else 1e-12, float(spec.max()) * 8 if spec.size
                 else 1.0)
    ax2.set_xlabel(f"frequency [Hz]   (dashed: fault frequencies at {speed_hz:.2f} Hz shaft speed, a defect's line "
                   f"also at 2x and 3x; named: the model's largest lines)")
    ax2.set_ylabel(f"amplitude [{synth.units[acc]}]")
    ax2.legend(loc="upper right", fontsize=8)
    from matplotlib.lines import Line2D

    fig.legend(handles=[Line2D([], [], color=c, ls="--", label=k) for k, c in legend.items()], loc="lower center",
               ncol=max(1, len(legend)), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return fig


def _scenario_run(st, args):
    """(ScenarioRun, its chunk iterator, metadata, title) of ``--scenario`` (raises UsageError)."""
    import numpy as np

    from bkabem_core.scenario.run import ScenarioRun
    from bkabem_core.scenario.timeline import Scenario, ScenarioError
    from bkabem_core.synth.synthesizer import SynthError

    try:
        scenario = Scenario.load(st["scenario"])
    except ScenarioError as exc:
        raise UsageError(f"--scenario: {exc.reason}" if exc.key == "scenario" and not exc.source
                         else f"--scenario: {exc}") from None
    if scenario.has_speed and st["profile"] is not None:
        raise UsageError(f"--profile: scenario {scenario.name!r} has its own [speed] profile")
    if not scenario.has_speed and st["profile"] is None:
        raise UsageError(f"--profile: scenario {scenario.name!r} has no [speed] profile: give one")
    if st["profile"] is not None:
        top = st["profile"].max_speed_hz(st["seconds"] or 1e9)
        if top > scenario.case.max_speed_hz:
            raise UsageError(f"--profile: {top:g} Hz is above the case's operating.max_speed_hz "
                             f"({scenario.case.max_speed_hz:g} Hz)")
    scale = st["time_scale"] if st["time_scale"] is not None else 1.0
    start = st["scenario_start"] or 0.0
    if start >= scenario.duration_s and st["seconds"] is None:
        raise UsageError(f"--scenario-start: {start:g} s is at or after the scenario's end ({scenario.duration_s:g} s); "
                         f"give --seconds to render its last state")
    try:
        run = ScenarioRun(scenario, time_scale=scale, start_s=start, sample_rate_hz=_rate(st, scenario.case, args),
                          chunk_s=st["chunk"], speed=st["profile"], **_measurement_options(st, args),
                          quantities=st["quantities"], seed=st["seed"], max_order=st["max_order"],
                          band_limit=args.band_limit, spectrum=args.spectrum,
                          dtype=np.float64 if args.float64 else np.float32)
        seconds = st["seconds"] if st["seconds"] is not None else run.seconds_to_end()
        if seconds > MAX_SECONDS:
            raise SynthError("--seconds", f"the scenario takes {seconds:g} s of signal at --time-scale {scale:g}, more "
                                          f"than {MAX_SECONDS:g} s: raise --time-scale or give --seconds")
    except SynthError as exc:
        raise UsageError(str(_rename(exc))) from None
    st["seconds"] = seconds
    meta = {"scenario": scenario.to_dict(), "time_scale": scale, "scenario_start_s": start,
            "states_ground_truth": [scenario.ground_truth(state, state.start_s, None, scale)
                                    for state in scenario.states]}
    title = f"scenario {scenario.name} ({scenario.scenario_hash}), x{scale:g}"
    return run, run.chunks(seconds), meta, title


def synth_main(args) -> int:
    """The ``bkabem synth`` command for an argparse Namespace; returns the exit code."""
    import numpy as np

    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem
    from bkabem_core.synth.synthesizer import SynthError, Synthesizer

    try:
        st = _settings(args)
    except SynthError as exc:
        raise UsageError(str(_rename(exc))) from None
    t_start = time.perf_counter()
    run = None
    if st["scenario"] is not None:
        run, chunks, scen_meta, title = _scenario_run(st, args)
        synth, case = run.synth, run.scenario.case
        t_model = time.perf_counter() - t_start
    else:
        case = Case.load(getattr(args, "case", None))
        top = st["profile"].max_speed_hz(st["seconds"])
        if top > case.max_speed_hz:
            raise UsageError(f"--profile: {top:g} Hz is above the case's operating.max_speed_hz ({case.max_speed_hz:g} "
                             f"Hz; raise it in the case file if the machine runs faster)")
        model = BkaBem(case)
        t_model = time.perf_counter() - t_start
        try:
            synth = Synthesizer(model, sample_rate_hz=_rate(st, case, args), chunk_s=st["chunk"],
                                quantities=st["quantities"], **_measurement_options(st, args),
                                seed=st["seed"], max_order=st["max_order"], band_limit=args.band_limit,
                                spectrum=args.spectrum, dtype=np.float64 if args.float64 else np.float32)
            chunks = ((ch, None) for ch in synth.render(st["profile"], st["seconds"]))
        except SynthError as exc:
            raise UsageError(str(_rename(exc))) from None
        title = f"{case.name} ({synth.ground_truth()['case_hash']}): {st['profile'].spec}"
    fs = synth.sample_rate_hz
    n_total = int(round(st["seconds"] * fs))
    out = st["out"]
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"command": "bkabem synth", "profile": None if st["profile"] is None else st["profile"].to_dict(),
            "seconds": st["seconds"], "n_samples": n_total, "synthesizer": synth.info(),
            "ground_truth": synth.ground_truth(), "units": dict(zip(synth.channel_names, synth.units)),
            "sample_time": "sample i is at i / sample_rate_hz seconds; cage angle 0 at t = 0"}
    if run is not None:
        meta.update(scen_meta)
        meta["ground_truth"] = meta["states_ground_truth"][run.driver.applied.index]
    csv_mode = out.suffix.lower() == ".csv"
    _check_free_space(out, len(synth.channel_names) * n_total * (16 if csv_mode else np.dtype(synth.dtype).itemsize))
    with writing("--out", out):
        writer = _CsvWriter(out, synth, None if run is not None else st["profile"], meta, state_column=run is not None) \
            if csv_mode else _NpzWriter(out, len(synth.channel_names), n_total, synth.dtype)
    try:
        feats = {k: [] for k in FEATURE_NAMES}
        iso, first, speed, speed_end, states, scen_t, healthy = [], [], [], [], [], [], []
        iso_bearings: tuple = ()
        keep = int(min(n_total, fs * 1.0))                       # excerpt for the figure: the last second
        ring: list[np.ndarray] = []
        ring_n = 0
        bar = None
        if not args.no_progress and sys.stderr.isatty():
            from tqdm import tqdm
            bar = tqdm(total=n_total, unit="sample", unit_scale=True, desc="synth", file=sys.stderr)
        t0 = time.perf_counter()
        try:
            for ch, truth in chunks:
                if not np.all(np.isfinite(ch.samples)):        # the last check before anything is written
                    raise UsageError(f"samples {ch.first_sample_index}..: not finite (NaN or inf) - an option "
                                     f"({', '.join(_noise_options(args)) or 'the case'}) is outside what float32 "
                                     f"samples can hold")
                with writing("--out", out):
                    writer.write(ch, None if truth is None else truth["state_index"])
                first.append(ch.first_sample_index)
                speed.append(ch.shaft_speed_hz)
                speed_end.append(ch.shaft_speed_end_hz)
                if truth is not None:
                    states.append(truth["state_index"])
                    scen_t.append(truth["scenario_time_s"])
                    healthy.append(truth["healthy"])
                for k in FEATURE_NAMES:
                    feats[k].append(ch.features[k])
                iso_bearings = tuple(ch.features["iso10816_velocity_rms_mm_s"])
                iso.append([[v[d] for d in ISO_DIRECTIONS]
                            for v in ch.features["iso10816_velocity_rms_mm_s"].values()])
                if args.png:
                    ring.append(np.array(ch.samples))
                    ring_n += ch.n_samples
                    while ring and ring_n - ring[0].shape[1] >= keep:
                        ring_n -= ring.pop(0).shape[1]
                if bar is not None:
                    bar.update(ch.n_samples)
        except SynthError as exc:
            raise UsageError(str(_rename(exc))) from None
        finally:
            if bar is not None:
                bar.close()
        t_synth = time.perf_counter() - t0
        meta["timing_s"] = {"model": t_model, "synthesis": t_synth, "real_time_factor": st["seconds"] / t_synth}
        meta["synthesizer"]["spectrum"] = synth.spectrum_method
        if run is not None:
            meta["timing_s"]["state_models"] = dict(run.models.pool.build_times_s)
        if csv_mode:
            with writing("--out", out):
                writer.close()
        else:
            profile = st["profile"]

            def speeds():
                if run is not None:                    # streamed chunks: speed linear within each chunk
                    for i, f0, f1 in zip(first, speed, speed_end):
                        m = min(synth.chunk_samples, n_total - i)
                        yield f0 + (f1 - f0) * (np.arange(m) / m)
                    return
                for i in range(0, n_total, 1 << 16):
                    yield profile.speed_hz((i + np.arange(min(1 << 16, n_total - i))) / fs)

            arrays = {"chunk_first_sample": np.array(first, dtype=np.int64), "chunk_speed_hz": np.array(speed),
                      "iso10816_velocity_rms_mm_s": np.array(iso),
                      "iso10816_bearing": np.array(iso_bearings, dtype=str),
                      "iso10816_direction": np.array(ISO_DIRECTIONS, dtype=str)}
            meta["axes"] = _axes(synth, iso_bearings, run is not None)
            if run is not None:
                arrays.update({"chunk_state_index": np.array(states, dtype=np.int64),
                               "chunk_scenario_time_s": np.array(scen_t), "chunk_healthy": np.array(healthy)})
            arrays.update({f"features_{k}": np.array(v) for k, v in feats.items()})
            with writing("--out", out):
                writer.finish(arrays, speeds, meta)
    except BaseException:
        writer.abort()            # close quietly: no half-written file, no error at garbage collection
        raise
    if args.png:
        excerpt = np.concatenate(ring, axis=1)[:, -keep:] if ring else np.zeros((len(synth.channel_names), 1))
        n_ex = min(excerpt.shape[1], int(fs))
        if run is None:
            prof = st["profile"]
            for length in (1.0, 0.5, 0.25, 0.1, 0.05):              # a window where the speed is nearly steady
                n_ex = min(excerpt.shape[1], int(length * fs))
                sp = prof.speed_hz((n_total - np.arange(n_ex)) / fs)
                if sp.max() - sp.min() <= 0.01 * max(sp.mean(), 1e-9):
                    break
            mean_speed = float(prof.speed_hz((n_total - n_ex / 2) / fs))
        else:
            mean_speed = float(speed_end[-1]) if speed_end else 0.0
        excerpt = excerpt[:, -n_ex:]
        with writing("--png", args.png):
            _plot(Path(args.png), excerpt, fs, synth, mean_speed, f"{title}, {fs:g} Hz, seed {synth.seed}")
    print(f"wrote {out}: {len(synth.channel_names)} channels x {n_total} samples at {fs:g} Hz "
          f"({st['seconds']:g} s in {t_synth:.2f} s, {times_real_time(st['seconds'] / t_synth)} real time)"
          + (f", {len(set(states))} scenario states" if run is not None else "")
          + (f", figure {args.png}" if args.png else ""))
    return 0


def add_parser(sub):
    """Register ``bkabem synth`` on an argparse subparsers object."""
    p = sub.add_parser("synth", help="synthesise sensor waveforms under a speed profile, or of a scenario")
    add_synth_arguments(p, with_case=True)
    p.set_defaults(func=synth_main)
    return p


def main(argv=None) -> int:
    """Standalone entry: ``python -m bkabem_ros.cli.synth --profile ... --out ...`` = ``bkabem synth ...``."""
    from bkabem_ros.cli.base import subcommand_main

    return subcommand_main("synth", add_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
