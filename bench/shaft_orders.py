"""How sharply the shaft modulates a race fault's impacts on the CWRU rig and in its twin: the shaft orders of the
squared envelope, and what the "FTF" line of a race-fault record is; and the same shaft orders where no race is
pitted (the healthy and ball-fault records).

    .venv/bin/python bench/shaft_orders.py DATA_DIR              # the table into docs/rigs.md, the figure
    .venv/bin/python bench/shaft_orders.py DATA_DIR --no-docs    # prints the table only
    .venv/bin/python bench/shaft_orders.py DATA_DIR --twin CASE --no-docs   # another twin: a case name or TOML

The figure: docs/img/shaft_orders.png.

DATA_DIR: the CWRU drive-end records as NumPy files (docs/validation_real.md says where they come from).

For each inner- and outer-race record of the drive-end bearing, and for the twin of its condition (``realdata.twin``:
the mapping of ``bench/validate_real.py``), the drive-end channel at 12 kHz, the squared-envelope spectrum (SES) of
2-4 kHz (``realdata.diagnostics.envelope_analysis``: the measure of docs/validation_real.md), and in it, in dB over
the SES floor:

- the shaft orders ``k f_r``, k = 1 .. ``ORDERS``;
- the fault line's lower shaft sidebands ``|F - k f_r|`` (F = BPFO or BPFI), k = 1 .. ``ORDERS``.

The healthy and ball-fault records get the shaft orders alone: there the 2-4 kHz band is the housing's response to
the bearing's rolling (and, for a ball fault, to the pit's strikes), and its shaft orders say how much that follows
the shaft angle without a race pit. Beside the healthy record the script sets what a noise that follows the twin's
own contacts reads alone (:func:`contact_swing`, :func:`swinging_noise`): the swing the twin's rolling noise has
(``bkabem_core/synth/rolling.py``), sized by the twin's loads, not fitted.

Why (McFadden & Smith, J. Sound Vib. 96 (1984); Randall & Antoni, MSSP 25 (2011), section 2): impacts whose strength
follows the shaft angle through a window ``w(theta)`` put ``|W_k|^2`` into the SES at ``k f_r`` and, around every
harmonic of F, into ``F +- k f_r``. A smooth window (a load zone that swings a little) has coefficients that fall
fast with k; a narrow or sharp one (a load that nearly vanishes once per turn, a pit that is struck only over part
of the turn) keeps them to high k. The orders' fall with k measures the window's sharpness, record by record, with
no model of it.

Noise or lines. A 1x in the squared envelope of a band comes either from a noise whose power swings once per turn
or from discrete lines in the band one shaft order apart (their beat). For the records without a race pit the
script also reads 1x after the band's discrete lines are clipped away (:func:`clip_lines`: the magnitude of the
whole record's spectrum clipped to twice its running median over ``CLIP_HZ``, the phase kept): a 1x that stays is the
noise's own.

The cage line. A record's "FTF" is read in a window of +-1 % around ``FTF = BPFO / Z``. With the 6205's measured
multipliers (BPFO 3.598 x, Z = 9), ``|BPFO - 4 f_r| = 0.402 f_r`` and ``|BPFI - 5 f_r|`` (the same number, since
BPFO + BPFI = Z f_r) lie 0.55 % from FTF = 0.3998 f_r: inside the window, and 0.07 Hz from it at 30 Hz, less than one
line of a 10-s record's spectrum. The script prints both readings (they come from the same line of the SES when the
two coincide), and the twin's, whose own bearing puts the two 4 % apart. What an uneven ball set would make is
read directly: the pass energies of ``bench/impact_spread.py`` folded over the Z balls (pass n is ball n mod Z for
either race), each ball's mean over the cage turns, their spread over the mean with the folding's own scatter (the
within-ball variance over the number of turns) removed. The shaft's modulation folds in too where Z passes come
back to nearly whole turns, so it is an upper bound of the balls' own differences.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from docs_blocks import replace_block  # noqa: E402
from impact_spread import pass_energies  # noqa: E402
from realdata.diagnostics import (  # noqa: E402
    TOL_BALL,
    TOL_RACE,
    decimate,
    envelope_analysis,
    estimate_speed,
    line_level,
    squared_envelope,
)
from realdata.records import EFFECTIVE_6205, race_record_main, scan  # noqa: E402

DOCS = ROOT / "docs" / "rigs.md"
FIGURE = ROOT / "docs" / "img" / "shaft_orders.png"
FS = 12000.0
BAND_HZ = (2000.0, 4000.0)
ORDERS = 6
#: Balls of the 6205 (the rig's drive-end bearing)
Z_6205 = 9
KEY = {"inner": "bpfi", "outer": "bpfo"}
#: Bins of the shaft angle for :func:`turn_profile`
TURN_BINS = 36
#: Width [Hz] of the running median a discrete line is clipped to (:func:`clip_lines`): many lines of a noise's
#: spectrum, several shaft orders
CLIP_HZ = 200.0


def clip_lines(x: np.ndarray, fs: float, factor: float = 2.0, width_hz: float = CLIP_HZ) -> np.ndarray:
    """``x`` with its discrete lines clipped away: the magnitude of its spectrum (one FFT of the whole signal) limited
    to ``factor`` times its running median over ``width_hz`` [Hz], the phase kept. A noise keeps its modulation (its
    spectrum has no line above that), lines one shaft order apart lose the beat they put into the envelope."""
    from scipy.ndimage import median_filter

    X = np.fft.rfft(x)
    a = np.abs(X)
    size = max(3, int(round(width_hz * x.size / fs)) | 1)
    limit = factor * median_filter(a, size=size, mode="nearest")
    return np.fft.irfft(X * np.minimum(1.0, limit / np.maximum(a, 1e-300)), x.size)


def levels(x: np.ndarray, fs: float, fr: float, mult: dict, kind: str, mains_hz: float = 60.0) -> dict:
    """The SES levels of a DE signal ``x`` [g] at ``fs`` [Hz], shaft speed ``fr`` [Hz], fault multipliers ``mult``
    [per shaft Hz] and fault ``kind`` [dB over the SES floor]: ``orders`` (k f_r), k = 1 .. ORDERS. For a race
    (inner, outer) also ``sidebands`` (|F - k f_r|, the same k), ``ftf`` (the cage line's window) and ``f4`` (a window
    of the same width at |BPFO - 4 f_r|), with the frequencies [Hz] each reading found; for any other kind ``turn``
    (:func:`turn_profile`)."""
    a = envelope_analysis(x, fs, BAND_HZ, fr, mult, mains_hz=mains_hz, keep_spectrum=True)
    f, S, floor = a["f"], a["S"], a["floor"]

    def db(f0: float, tol: float) -> tuple[float, float]:
        v, fp = line_level(f, S, f0, tol)
        return 20.0 * math.log10(v / floor), fp

    orders = [db(k * fr, TOL_RACE)[0] for k in range(1, ORDERS + 1)]
    if kind not in KEY:                                 # no race pit: the shaft orders, the turn's profile, and 1x
        c = envelope_analysis(clip_lines(x, fs), fs, BAND_HZ, fr, mult, mains_hz=mains_hz, keep_spectrum=True)
        clipped = 20.0 * math.log10(line_level(c["f"], c["S"], fr, TOL_RACE)[0] / c["floor"])
        return {"orders": orders, "turn": turn_profile(x, fs, fr), "x1_clipped": clipped}
    F = mult[KEY[kind]] * fr
    ftf, f_ftf = db(mult["ftf"] * fr, TOL_BALL)
    f4, f_f4 = db(abs(mult["bpfo"] - 4.0) * fr, TOL_BALL)
    return {"orders": orders,
            "sidebands": [db(abs(F - k * fr), TOL_RACE)[0] for k in range(1, ORDERS + 1)],
            "ftf": ftf, "ftf_hz": f_ftf, "f4": f4, "f4_hz": f_f4}


def turn_profile(x: np.ndarray, fs: float, fr: float, bins: int = TURN_BINS) -> float:
    """How much the power of the 2-4 kHz band follows the shaft angle: its squared envelope averaged in ``bins``
    bins of the angle (from a constant speed ``fr`` [Hz]), largest over smallest [-]. A stationary noise gives a
    little more than 1 (each bin's mean scatters); a load zone that the shaft swings, more."""
    env = squared_envelope(x, fs, *BAND_HZ)           # (its filter's ends cut: only turns the profile)
    b = np.floor((np.arange(env.size) / fs * fr) % 1.0 * bins).astype(int)
    prof = np.bincount(b, weights=env, minlength=bins) / np.bincount(b, minlength=bins)
    return float(prof.max() / prof.min())


def contact_swing(twin_case: str = "cwru_rig", location: str = "de", n: int = TURN_BINS) -> dict:
    """How much the twin's rolling noise, which follows the contacts' stiffness, swings over the turn: its
    ``location`` bearing under its static radial load, axial preload and the load that turns with the shaft
    (``Machine`` sites: ``radial_load_n``, ``axial_load_n``, ``rotating_load_n``), at ``n`` shaft angles, by the
    synthesiser's own law (:func:`bkabem_core.synth.rolling.contact_power`). Roughness
    and waviness excite each loaded contact through its stiffness, ``dQ/d delta = 1.5 K^(2/3) Q^(1/3)`` for a
    Hertzian point contact, so independent contacts give a noise power ``~ sum_i Q_i^(2/3)``. Returns the loads
    [N] and ``swing``, that sum's largest over its smallest [-]."""
    from bkabem_core.fe.machine import Machine
    from bkabem_core.model.case import Case
    from bkabem_core.synth.rolling import contact_power

    site = Machine(Case.load(twin_case), mesh=None).sites[location]
    power = contact_power(site, n)                      # the twin's own law (bkabem_core/synth/rolling.py)
    return {"weight_n": float(np.hypot(*site.radial_load_n)), "preload_n": float(site.axial_load_n),
            "turning_n": abs(complex(site.rotating_load_n)), "swing": float(power.max() / power.min())}


def swinging_noise(swing: float, seconds: float, fr: float, seeds: int = 4, fs: float = FS) -> dict:
    """A stationary noise whose power swings by ``swing`` (largest / smallest) once per turn, ``1 + m cos theta``,
    read as the records are: the mean over ``seeds`` of its 1x [dB over the SES floor] and :func:`turn_profile`."""
    m = (swing - 1.0) / (swing + 1.0)
    t = np.arange(int(round(seconds * fs))) / fs
    got = [levels(np.random.default_rng(s).standard_normal(t.size) * np.sqrt(1.0 + m * np.cos(2 * np.pi * fr * t)),
                  fs, fr, EFFECTIVE_6205, "healthy") for s in range(seeds)]
    return {"x1": float(np.mean([g["orders"][0] for g in got])), "turn": float(np.mean([g["turn"] for g in got]))}


def ball_spread(energies: np.ndarray, z: int) -> float:
    """The spread of the balls' mean pass energies over the mean energy [-] (module docstring): ``energies`` one
    per ball pass, ``z`` balls."""
    e = np.asarray(energies, dtype=float)
    turns = e.size // z
    per = e[:turns * z].reshape(turns, z)                 # a row per cage turn, a column per ball
    between = per.mean(axis=0).var(ddof=1) - per.var(axis=0, ddof=1).mean() / turns
    return math.sqrt(max(between, 0.0)) / float(per.mean())


def run(data_dir: Path, seeds: int, twin_case: str = "cwru_rig") -> list[dict]:
    from realdata.twin import Condition, synthesize
    from tqdm import tqdm

    records = [r for r in scan(data_dir) if r.fault_bearing in (None, "de")]
    rows = []
    for r in tqdm(records, unit="record", desc="shaft_orders", dynamic_ncols=True):
        ch = r.load()
        fr, _ = estimate_speed(ch, r.sample_rate_hz, r.speed_hz_nominal)
        x = decimate(ch["DE"], r.sample_rate_hz, FS)
        meas = levels(x, FS, fr, EFFECTIVE_6205, r.kind)
        race = r.kind in KEY
        if race:
            meas["balls"] = ball_spread(pass_energies(x, FS, EFFECTIVE_6205[KEY[r.kind]] * fr)[0], Z_6205)
        duration = ch["DE"].size / r.sample_rate_hz
        twins = []
        for seed in range(1, seeds + 1):
            out = synthesize(Condition.of(r), twin_case, seed, fr, FS, duration)
            twins.append(levels(out["DE"], FS, fr, out["mult"], r.kind, out["mains_hz"]))
        twin = {k: np.mean([t[k] for t in twins], axis=0).tolist() for k in ("orders", "sidebands")[:1 + race]}
        twin.update({k: float(np.mean([t[k] for t in twins])) for k in (("ftf", "f4") if race else ("turn", "x1_clipped"))})
        rows.append({"label": r.label, "kind": r.kind, "size": r.size_mils, "fr": fr, "measured": meas,
                     "twin": twin, "twin_mult": out["mult"], "seconds": duration})
    healthy = [row for row in rows if row["kind"] == "healthy"]
    if healthy:                                         # what a noise that follows the contacts would read there
        c = contact_swing(twin_case)
        healthy[0]["contacts"] = dict(c, **swinging_noise(c["swing"], healthy[0]["seconds"], healthy[0]["fr"]))
    return rows


def _cells(m: list[float], t: list[float]) -> str:
    return " | ".join(f"{a:.0f} / {b:.0f}" for a, b in zip(m, t))


def table(rows: list[dict], seeds: int, twin_case: str = "cwru_rig") -> str:
    ks = range(1, ORDERS + 1)
    rest = [r for r in rows if r["kind"] not in KEY]
    rows = [r for r in rows if r["kind"] in KEY]
    if not rows:                                        # no race-fault record: the other records' orders alone
        return _rest_table(rest, seeds, twin_case)
    out = [f"Each cell: measured / twin (`{twin_case}`, the mean over its seeds: {seeds}), dB over the floor of the\n"
           "2-4 kHz squared-envelope spectrum.", "",
           "Shaft orders `k f_r`:", "",
           "| record | " + " | ".join(f"{k}x" for k in ks) + " |", "|---|" + "---|" * ORDERS]
    for r in rows:
        out.append(f"| {r['label']} | {_cells(r['measured']['orders'], r['twin']['orders'])} |")
    out += ["", "The fault line's lower shaft sidebands `|F - k f_r|` (F = BPFI or BPFO):", "",
            "| record | " + " | ".join(f"F - {k}x" for k in ks) + " |", "|---|" + "---|" * ORDERS]
    for r in rows:
        out.append(f"| {r['label']} | {_cells(r['measured']['sidebands'], r['twin']['sidebands'])} |")
    out += ["", "Medians over the records, measured - twin [dB]:", "",
            "| kind | " + " | ".join(f"{k}x" for k in ks) + " | " + " | ".join(f"F - {k}x" for k in ks) + " |",
            "|---|" + "---|" * (2 * ORDERS)]
    for kind in ("inner", "outer", "healthy", "ball"):
        sel = [r for r in rows + rest if r["kind"] == kind]
        if not sel:
            continue
        d = {q: np.median([np.subtract(r["measured"][q], r["twin"][q]) for r in sel], axis=0)
             for q in ("orders", "sidebands") if q in sel[0]["twin"]}
        side = [f"{v:+.0f}" for v in d["sidebands"]] if "sidebands" in d else ["-"] * ORDERS
        out.append(f"| {kind} ({len(sel)}) | " + " | ".join([f"{v:+.0f}" for v in d["orders"]] + side) + " |")
    m = rows[0]["twin_mult"]
    apart = abs(abs(EFFECTIVE_6205["bpfo"] - 4.0) / EFFECTIVE_6205["ftf"] - 1.0)
    apart_t = abs(abs(m["bpfo"] - 4.0) / m["ftf"] - 1.0)
    same = sum(1 for r in rows if abs(r["measured"]["ftf_hz"] - r["measured"]["f4_hz"]) < 1e-9)
    out += ["", f"The cage line's window (+-{100 * TOL_BALL:.0f} %) and |BPFO - 4 f_r|: {100 * apart:.2f} % apart at "
            f"the 6205's measured multipliers, {100 * apart_t:.1f} % at the twin's. In {same} of {len(rows)} records "
            "both readings are the same line of the SES. Median over the records, measured / twin: "
            f"FTF {np.median([r['measured']['ftf'] for r in rows]):.0f} / "
            f"{np.median([r['twin']['ftf'] for r in rows]):.0f} dB, |BPFO - 4 f_r| "
            f"{np.median([r['measured']['f4'] for r in rows]):.0f} / {np.median([r['twin']['f4'] for r in rows]):.0f}"
            " dB.", "",
            f"The balls' own differences in the measured records (the pass energies folded over the {Z_6205} balls, an "
            "upper bound): " + ", ".join(f"{r['label']} {r['measured']['balls']:.2f}" for r in rows) + "."]
    if rest:
        out += ["", _rest_table(rest, seeds, twin_case, head=False)]
    return "\n".join(out)


def _rest_table(rest: list[dict], seeds: int, twin_case: str, head: bool = True) -> str:
    """The shaft orders of the records without a race pit (healthy, ball fault), measured / twin."""
    out = [f"Each cell: measured / twin (`{twin_case}`, the mean over its seeds: {seeds}), dB over the floor of the\n"
           "2-4 kHz squared-envelope spectrum.", ""] if head else []
    out += ["Shaft orders `k f_r` where no race is pitted (the healthy and ball-fault records), and the 2-4 kHz "
            f"band's power over the turn ({TURN_BINS} bins of the shaft angle, largest / smallest):", "",
            "| record | " + " | ".join(f"{k}x" for k in range(1, ORDERS + 1)) + " | over the turn | 1x, lines clipped |",
            "|---|" + "---|" * (ORDERS + 2)]
    for r in rest:
        out.append(f"| {r['label']} | {_cells(r['measured']['orders'], r['twin']['orders'])} | "
                   f"{r['measured']['turn']:.2f} / {r['twin']['turn']:.2f} | "
                   f"{r['measured']['x1_clipped']:.0f} / {r['twin']['x1_clipped']:.0f} |")
    for r in rest:
        if "contacts" in r:
            c = r["contacts"]
            out += ["", "The twin's rolling noise follows its drive-end contacts "
                    f"({c['weight_n']:.1f} N of weight, {c['preload_n']:.0f} N of preload, {c['turning_n']:.1f} N "
                    f"turning with the shaft; power ~ sum Q^(2/3)): it swings {c['swing']:.2f} : 1 over the turn. A "
                    f"noise that swings that much, alone, reads in a record as long as the {r['label']} one 1x "
                    f"{c['x1']:.0f} dB and {c['turn']:.2f} over the turn (the record: "
                    f"{r['measured']['orders'][0]:.0f} dB and {r['measured']['turn']:.2f}; the twin, whose band also "
                    "holds the input floor, which does not swing: the table)."]
    return "\n".join(out)


def figure(rows: list[dict], path: Path) -> None:
    """Two panels, per kind the median over its records (measured: filled, twin: open) against k: the shaft
    orders and the fault line's lower shaft sidebands [dB over the SES floor]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colour = {"inner": "tab:red", "outer": "tab:blue", "healthy": "tab:green", "ball": "tab:orange"}
    ks = np.arange(1, ORDERS + 1)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4), sharey=True)
    for ax, q, title in zip(axes, ("orders", "sidebands"), ("shaft orders k f_r", "fault line's sidebands F - k f_r")):
        for kind, c in colour.items():
            sel = [r for r in rows if r["kind"] == kind]
            if not sel or q not in sel[0]["twin"]:
                continue
            for w, style in (("measured", dict(marker="o", ls="-")), ("twin", dict(marker="o", ls="--", mfc="none"))):
                v = np.median([r[w][q] for r in sel], axis=0)
                what = f"{kind} race" if kind in KEY else kind
                ax.plot(ks, v, color=c, label=f"{what}, {w} ({len(sel)})", **style)
        ax.set_xticks(ks)
        ax.set_xlabel("k")
        ax.set_title(title + " (median over the records)", fontsize=10)
        ax.grid(True, color="0.9")
    axes[0].set_ylabel("2-4 kHz SES [dB over its floor]")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _write_docs(rows: list[dict], text: str, args) -> None:
    if args.twin == "cwru_rig":                     # the page holds the rig's own twin only
        DOCS.write_text(replace_block(DOCS.read_text(), "shaft_orders", text, "docs/rigs.md"))
        figure(rows, FIGURE)


def main(argv=None) -> int:
    return race_record_main("shaft_orders", __doc__.split("\n\n")[0], argv,
                            lambda a: run(a.data_dir, a.seeds, a.twin), lambda rows, a: table(rows, a.seeds, a.twin),
                            _write_docs, twin_option=True, reads="record")


if __name__ == "__main__":
    sys.exit(main())
