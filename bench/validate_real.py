"""The twin held against measured records: every CWRU record of a folder beside the twin at its condition.

    .venv/bin/python bench/validate_real.py DATA_DIR [--twin CASE] [--seeds N] [--out DIR] [--json F]

DATA_DIR holds CWRU drive-end records as NumPy files (``1797_IR_7_DE12.npz``: keys ``DE``, ``FE`` in g; CWRU
Bearing Data Center, https://engineering.case.edu/bearingdatacenter). The project keeps no copy of them: the
folder is an argument. For each record, the twin (``--twin``: ``cwru_rig`` by default, or the fault
library ``motor_6010``; ``bench/realdata/twin.py``) is rendered at the record's speed (estimated from its
spectrum), load, fault kind, position and size, at the record's sample rate and length, with ``--seeds`` seeds,
and both go through the same textbook diagnostics (``bench/realdata/diagnostics.py``): RMS, kurtosis, crest
factor, band energies, the squared-envelope spectrum (fault line, harmonics, 1x, FTF, sidebands over the floor)
and the no-training verdict.

Writes ``DIR/validation_real.md`` (default DIR: docs/) with the tables and the targets per record, figures in
``DIR/img/validation_real_*.png``, and with ``--json`` the numbers. The block of ``bench/sim2real.py`` in the
page is kept. Exit code 2 with one line for a bad argument or folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
for p in (str(ROOT), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

from realdata import report  # noqa: E402
from realdata.diagnostics import (  # noqa: E402
    BROAD_BANDS,
    KIND_LINE,
    decimate,
    diagnose,
    estimate_speed,
    moments,
    null_levels,
)
from realdata.records import CWRU_6203, EFFECTIVE_6205, KINDS, RecordError, scan  # noqa: E402
from realdata.twin import LIBRARY, Condition, check_twin, default_twin, synthesize  # noqa: E402

FS = 12000.0
RMS_FACTOR = 2.0
LINE_DB = 10.0
SHAPE_DB = 10.0
THRESHOLD_DB = 10.0
#: Bands of the healthy record's shape check: up to 5 kHz (above it the two acquisitions' anti-alias filters
#: differ: CWRU's rolls off from 5.4 kHz).
SHAPE_BANDS = [i for i, (lo, hi) in enumerate(BROAD_BANDS) if hi <= 5000.0]


def norm_verdict(v: str) -> str:
    """``ambiguous(b/a)`` and ``ambiguous(a/b)`` are the same miss."""
    if v.startswith("ambiguous("):
        return "ambiguous(" + "/".join(sorted(v[10:-1].split("/"))) + ")"
    return v


def summary_of(d: dict) -> dict:
    """The JSON part of a :func:`diagnose` result (no arrays)."""
    return {k: v for k, v in d.items() if k not in ("psd_f", "psd")} | {
        "ses": {b: {k: v for k, v in s.items() if k not in ("f", "S")} for b, s in d["ses"].items()}}


def analyse(x: np.ndarray, fs: float, fr: float, mult: dict, extra=(), mains_hz: float = 60.0) -> dict:
    """Diagnostics at 12 kHz (a 48 kHz signal decimated as the measured one is), time-domain statistics at the
    signal's own rate."""
    d = diagnose(decimate(x, fs, FS), FS, fr, mult, extra_mults=extra, mains_hz=mains_hz, keep_spectra=True)
    d["native"] = moments(x)
    return d


def null_percentiles(d: dict, fr: float, mult: dict, mains_hz: float) -> dict:
    """Median, 95th and 99th percentiles [dB over floor] of the line measure at 300 frequencies where no line is
    expected (2-4 kHz SES): the false-alarm level of a line level on this signal."""
    s = d["ses"]["fixed"]
    v = null_levels(s["f"], s["S"], s["floor"], fr, [mult], mains_hz)
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "p99": float(np.percentile(v, 99))}


def shape_db(bands_db: list) -> np.ndarray:
    """Band energies relative to their sum over :data:`SHAPE_BANDS` [dB]."""
    e = np.array([bands_db[i] for i in SHAPE_BANDS])
    return e - 10 * np.log10(np.sum(10 ** (e / 10)))


def mean_over(xs):
    xs = [x for x in xs if x is not None]
    return float(np.mean(xs)) if xs else None


def checks(rec, meas: dict, twins: list[dict]) -> dict:
    """The targets for one record (DE channel)."""
    m_rms = meas["native"]["rms"]
    t_rms = mean_over([t["native"]["rms"] for t in twins])
    c = {"rms_ratio": t_rms / m_rms, "rms": bool(1 / RMS_FACTOR <= t_rms / m_rms <= RMS_FACTOR)}
    verdicts = [norm_verdict(t["ses"]["fixed"]["verdict"]) for t in twins]
    c["twin_verdict"] = Counter(verdicts).most_common(1)[0][0]      # a tie: the first seed's
    c["twin_verdicts"] = verdicts
    c["measured_verdict"] = norm_verdict(meas["ses"]["fixed"]["verdict"])
    if rec.kind == "healthy":
        worst = max(max(t["ses"]["fixed"]["levels"][k] for k in ("BPFO", "BPFI", "2BSF")) for t in twins)
        c["twin_strongest_fault_line_db"] = worst
        c["rms_12k_ratio"] = mean_over([t["rms"] for t in twins]) / meas["rms"]
        c["no_line"] = bool(worst < THRESHOLD_DB)
        d = np.mean([shape_db(t["bands_db"]) for t in twins], axis=0) - shape_db(meas["bands_db"])
        c["shape_diff_db"] = [float(v) for v in d]
        c["shape"] = bool(np.max(np.abs(d)) <= SHAPE_DB)
        c["all"] = c["rms"] and c["no_line"] and c["shape"]
    else:
        line = KIND_LINE[rec.kind]
        m_line = meas["ses"]["fixed"]["levels"][line]
        t_line = mean_over([t["ses"]["fixed"]["levels"][line] for t in twins])
        c["line_diff_db"] = t_line - m_line
        c["line"] = bool(abs(t_line - m_line) <= LINE_DB)
        c["verdict"] = c["twin_verdict"] == c["measured_verdict"]
        c["all"] = c["rms"] and c["line"] and c["verdict"]
    return c


def run(args) -> dict:
    from tqdm import tqdm

    records = scan(args.data_dir)
    if args.records:
        records = [r for r in records if any(s in r.name for s in args.records.split(","))]
        if not records:
            raise RecordError(f"--records {args.records!r}: no record of {args.data_dir} matches")
    out = {"twin": args.twin, "seeds": args.seeds, "records": []}
    spectra = {}
    t0 = time.perf_counter()
    bar = tqdm(total=len(records) * (1 + args.seeds), unit="signal", desc="validate_real", dynamic_ncols=True)
    for rec in records:
        bar.set_postfix_str(rec.name)
        raw = rec.load()
        fs = rec.sample_rate_hz
        fr, n_cand = estimate_speed({k: decimate(v, fs, FS) for k, v in raw.items()}, FS, rec.speed_hz_nominal)
        meas = {ch: analyse(x, fs, fr, EFFECTIVE_6205, extra=(CWRU_6203,) if ch == "FE" else ())
                for ch, x in raw.items()}
        bar.update(1)
        cond = Condition.of(rec)
        n = len(raw["DE"])
        twins = []
        for seed in range(1, args.seeds + 1):
            sig = synthesize(cond, args.twin, seed, fr, fs, n / fs)
            twins.append({ch: analyse(sig[ch], fs, fr, sig["mult"], mains_hz=sig["mains_hz"])
                          for ch in ("DE", "FE")} | {"seed": seed, "mult": sig["mult"], "mains_hz": sig["mains_hz"]})
            bar.update(1)
        c = checks(rec, meas["DE"], [t["DE"] for t in twins])
        if rec.kind == "healthy":
            c["null_db"] = {"measured": null_percentiles(meas["DE"], fr, EFFECTIVE_6205, 60.0),
                            "twin": null_percentiles(twins[0]["DE"], fr, twins[0]["mult"], twins[0]["mains_hz"])}
        fe = None
        if "FE" in meas:
            fe = checks(rec, meas["FE"], [t["FE"] for t in twins])
        out["records"].append({
            "record": rec.name, "label": rec.label, "kind": rec.kind, "size_mils": rec.size_mils,
            "load_hp": rec.load_hp, "position_oclock": rec.position_oclock, "sample_rate_hz": fs,
            "duration_s": n / fs, "speed_hz": fr, "speed_candidates": n_cand, "source_file": rec.source_file,
            "measured": {ch: summary_of(d) for ch, d in meas.items()},
            "twin": [{"seed": t["seed"], "mult": t["mult"], **{ch: summary_of(t[ch]) for ch in ("DE", "FE")}}
                     for t in twins],
            "checks": c, "checks_fe": fe})
        spectra[rec.name] = (meas["DE"], twins[0]["DE"], twins[0]["mult"], fr)
    bar.close()
    out["wall_s"] = time.perf_counter() - t0
    out["summary"] = summarise(out["records"])
    out["transmission_shape"] = transmission_shape(out["records"])
    return out, spectra


def summarise(rows: list[dict]) -> dict:
    faults = [r for r in rows if r["kind"] != "healthy"]
    s = {"records": len(rows), "fault_records": len(faults)}
    for key in ("rms", "line", "verdict", "all"):
        pool = rows if key in ("rms", "all") else faults
        s[f"{key}_met"] = sum(bool(r["checks"].get(key)) for r in pool)
        s[f"{key}_of"] = len(pool)
        s[f"{key}_fraction"] = s[f"{key}_met"] / len(pool) if pool else None
    healthy = [r for r in rows if r["kind"] == "healthy"]
    if healthy:
        h = healthy[0]["checks"]
        s["healthy"] = {k: h[k] for k in ("rms", "rms_ratio", "rms_12k_ratio", "no_line", "null_db",
                                          "twin_strongest_fault_line_db", "shape",
                                          "shape_diff_db", "all")}
    right = {"measured": 0, "twin": 0}
    for r in rows:
        right["measured"] += r["checks"]["measured_verdict"] == r["kind"]
        right["twin"] += r["checks"]["twin_verdict"] == r["kind"]
    s["verdict_right_measured"], s["verdict_right_twin"] = right["measured"], right["twin"]
    return s


# --------------------------------------------------------------------------- the page
def ses_db(d: dict) -> tuple:
    s = d["ses"]["fixed"]
    return s["f"], 20 * np.log10(np.maximum(s["S"], 1e-30) / s["floor"])


def kind_lines(kind: str, mult: dict, fr: float) -> dict:
    if kind == "healthy":
        return {"1x": fr}
    m = {"outer": mult["bpfo"], "inner": mult["bpfi"], "ball": 2 * mult["bsf"]}[kind]
    return {"1x": fr, "h1": m * fr, "h2": 2 * m * fr, "h3": 3 * m * fr}


def record_rows(rows: list[dict], ch: str) -> list[list]:
    out = []
    for r in rows:
        m = r["measured"].get(ch)
        if m is None:
            continue
        ts = [t[ch] for t in r["twin"]]
        c = r["checks"] if ch == "DE" else r["checks_fe"]
        kl = KIND_LINE.get(r["kind"])

        def pair(get, spec="{:.0f}"):
            return f"{report.fmt(get(m), spec)} / {report.fmt(mean_over([get(t) for t in ts]), spec)}"

        def lvl(name, band="fixed"):
            return lambda d: d["ses"][band]["levels"][name]

        kb = f"{m['kurtogram']['f_lo'] / 1e3:.1f}-{m['kurtogram']['f_hi'] / 1e3:.1f} / " + \
            f"{ts[0]['kurtogram']['f_lo'] / 1e3:.1f}-{ts[0]['kurtogram']['f_hi'] / 1e3:.1f}"
        side = {"outer": ("BPFO-1x", "BPFO+1x"), "inner": ("BPFI-1x", "BPFI+1x"), "ball": ("2BSF-FTF", "2BSF+FTF")}
        sb = side.get(r["kind"])
        out.append([r["label"], f"{r['speed_hz']:.3f}", pair(lambda d: d["native"]["rms"], "{:.3f}"),
                    pair(lambda d: d["native"]["kurtosis"], "{:.1f}"), pair(lambda d: d["native"]["crest"], "{:.1f}"),
                    pair(lambda d: d["band_spread"], "{:.1f}"), kb, pair(lvl(kl)) if kl else "-",
                    pair(lvl(kl, "kurtogram")) if kl else "-",
                    pair(lvl(f"{kl}_h2")) if kl else "-", pair(lvl("1x")), pair(lvl("FTF")),
                    pair(lambda d: max(d["ses"]["fixed"]["levels"][s] for s in sb)) if sb else "-",
                    f"{c['measured_verdict']} / {c['twin_verdict']}",
                    report.mark(c["rms"]), report.mark(c.get("line")), report.mark(c.get("verdict")
                                                                                  if r["kind"] != "healthy"
                                                                                  else c.get("no_line"))])
    return out


def band_rows(rows: list[dict]) -> list[list]:
    out = []
    for kind in KINDS:
        rs = [r for r in rows if r["kind"] == kind]
        if not rs:
            continue
        m = np.median([r["measured"]["DE"]["bands_db"] for r in rs], axis=0)
        t = np.median([np.mean([tw["DE"]["bands_db"] for tw in r["twin"]], axis=0) for r in rs], axis=0)
        out.append([f"{kind} (n = {len(rs)})"] + [f"{a:.0f} / {b:.0f}" for a, b in zip(m, t)])
    return out


def transmission_shape(rows: list[dict]) -> dict:
    """How the twin's spectrum is shaped against the rig's below the housing's band: for each race-fault record
    (whose strikes excite the structure at every frequency), the twin's energy less the record's in each broad band
    below 2 kHz, relative to the same difference in 2-4 kHz [dB], the median over the records and its range.
    Negative: the twin carries less there than the rig does, for the same energy in the band the envelope reads."""
    races = [r for r in rows if r["kind"] in ("inner", "outer")]
    if not races:
        return {}
    ref = [i for i, (lo, hi) in enumerate(BROAD_BANDS) if lo >= 2000.0 and hi <= 4000.0]
    low = [i for i, (lo, hi) in enumerate(BROAD_BANDS) if hi <= 2000.0]
    diffs = []
    for r in races:
        m = np.asarray(r["measured"]["DE"]["bands_db"], dtype=float)
        t = np.mean([tw["DE"]["bands_db"] for tw in r["twin"]], axis=0)
        d = t - m
        e_m = 10 * np.log10(np.sum(10 ** (m[ref] / 10))), 10 * np.log10(np.sum(10 ** (t[ref] / 10)))
        diffs.append(d[low] - (e_m[1] - e_m[0]))
    diffs = np.array(diffs)
    return {"bands": [BROAD_BANDS[i] for i in low], "median_db": np.median(diffs, axis=0).tolist(),
            "min_db": diffs.min(axis=0).tolist(), "max_db": diffs.max(axis=0).tolist(), "records": len(races)}


def differences(rows: list[dict], twin: str) -> list[str]:
    """Where the twin differs, per kind, from the medians of the numbers above."""
    out = []
    for kind in KINDS:
        rs = [r for r in rows if r["kind"] == kind]
        if not rs:
            continue

        def med(get, who):
            vals = [get(r["measured"]["DE"]) for r in rs] if who == "m" else \
                [mean_over([get(t["DE"]) for t in r["twin"]]) for r in rs]
            return float(np.median(vals))

        rms = (med(lambda d: d["native"]["rms"], "m"), med(lambda d: d["native"]["rms"], "t"))
        kurt = (med(lambda d: d["native"]["kurtosis"], "m"), med(lambda d: d["native"]["kurtosis"], "t"))
        one = (med(lambda d: d["ses"]["fixed"]["levels"]["1x"], "m"),
               med(lambda d: d["ses"]["fixed"]["levels"]["1x"], "t"))
        ftf = (med(lambda d: d["ses"]["fixed"]["levels"]["FTF"], "m"),
               med(lambda d: d["ses"]["fixed"]["levels"]["FTF"], "t"))
        spread = (med(lambda d: d["band_spread"], "m"), med(lambda d: d["band_spread"], "t"))
        text = (f"**{kind}** (medians, measured / twin): RMS {rms[0]:.3f} / {rms[1]:.3f} g, kurtosis {kurt[0]:.1f} / "
                f"{kurt[1]:.1f}, 2-4 kHz RMS max/min over 0.25 s {spread[0]:.1f} / {spread[1]:.1f}, 1x in the "
                f"envelope {one[0]:.0f} / {one[1]:.0f} dB, FTF {ftf[0]:.0f} / {ftf[1]:.0f} dB")
        if kind != "healthy":
            kl = KIND_LINE[kind]
            line = (med(lambda d: d["ses"]["fixed"]["levels"][kl], "m"),
                    med(lambda d: d["ses"]["fixed"]["levels"][kl], "t"))
            sizes = sorted({r["size_mils"] for r in rs})
            by_size_m = [float(np.median([r["measured"]["DE"]["ses"]["fixed"]["levels"][kl] for r in rs
                                          if r["size_mils"] == s])) for s in sizes]
            by_size_t = [float(np.median([mean_over([t["DE"]["ses"]["fixed"]["levels"][kl] for t in r["twin"]])
                                          for r in rs if r["size_mils"] == s])) for s in sizes]
            text += (f", {kl} {line[0]:.0f} / {line[1]:.0f} dB; by pit size ({', '.join(map(str, sizes))} mil): "
                     f"measured {', '.join(f'{v:.0f}' for v in by_size_m)} dB, twin "
                     f"{', '.join(f'{v:.0f}' for v in by_size_t)} dB")
            right_m = sum(r["checks"]["measured_verdict"] == kind for r in rs)
            right_t = sum(r["checks"]["twin_verdict"] == kind for r in rs)
            text += f"; textbook verdict right {right_m}/{len(rs)} measured, {right_t}/{len(rs)} twin."
        else:
            text += "."
        out.append("- " + text)
    shape = transmission_shape(rows)
    if shape:
        out.append(
            f"- **Below 2 kHz** (the {shape['records']} race-fault records, whose strikes excite the structure at every "
            "frequency: the twin's energy less the record's in each band, relative to the same difference in 2-4 kHz; "
            "median and range): " + ", ".join(
                f"{lo / 1e3:g}-{hi / 1e3:g} kHz {m:+.0f} dB ({a:+.0f} to {b:+.0f})"
                for (lo, hi), m, a, b in zip(shape["bands"], shape["median_db"], shape["min_db"], shape["max_db"]))
            + ". Where the twin matches the rig in the band the envelope reads, it carries that much less (or more) "
            "below it: the path from the bearing to the sensor below the housing's resonance.")
    if twin == LIBRARY:
        out.append(
            "- Why, for today's twin: `motor_6010` is another machine. Its bearing is a 6010 (14 balls: BPFO 6.06x, "
            "BPFI 7.94x, 2 x BSF 7.31x against the 6205's 3.60x, 5.40x and 4.71x), its defects are the library's "
            "2 mm x 50 um dents (1.5 mm on the ball) whatever the CWRU pit, the load does not enter, and its "
            "housings are lumped masses, so it has none of the rig's housing resonances at 2.8 and 3.35 kHz that "
            "CWRU's impacts ring in. Its outer race is a clean BPFO comb without the shaft-rate modulation the rig "
            "shows (1x in the envelope), its ball defect a clean 2 x BSF comb with FTF sidebands where the rig's "
            "ball faults barely show, and its fault level does not depend on the pit size at all, while the "
            "rig's does, and not monotonically. The twin's FE channel is the motor's NDE housing.")
    else:
        out.append(
            f"- Why, for today's twin: `{twin}` is the rig's machine and acquisition, calibrated once on the healthy "
            "record (docs/rigs.md), with the acquisition's input floor that gives the records' level between the "
            "lines from 100 Hz to the anti-alias filter; a seeded bearing rolls rougher than the healthy one by its "
            "make's `roughness_db` (SKF 15 dB, NTN 36 dB, read from the eight fault records whose signal is "
            "Gaussian, so those eight do not check it: `bench/rig_floor.py`), which is what lifts the ball records' "
            "level; each bearing's rolling noise follows the load on its balls, which the coupling's turning load "
            "swings once per turn (`bkabem_core/synth/rolling.py`: the healthy and ball records' 1x in the "
            "envelope, which on the rig stays when the lines are clipped away: `bench/shaft_orders.py`); a race pit's strikes vary in strength as much as the share of its load a "
            "ball loses over the pit, which is what the rig's records show and what bounds their envelope lines "
            "(`bench/impact_spread.py`). What it does not have yet, each measured there: the structure's response "
            "below 2 kHz (the line above: no mode of the twin's housings lies there, and the rig's race strikes "
            "carry more there, relative to 2-4 kHz, than the twin's); the lines below 2 kHz that "
            "come back from record to record (a BPFI family of the drive-end bearing, shaft orders); the "
            "strength of a race pit's strikes, which on the rig hardly depends on the pit's size (7-21 mil) while "
            "the twin's follows its pit's drop, so that over the seeded bearing's floor the twin's 7 mil strikes "
            "are 11-22 dB too weak and its 14 mil outer-race strikes too strong; the race records' shaft orders "
            "above 2x-3x in the envelope (a sharper once-per-turn modulation of the strikes; the race records' "
            "\"FTF\" line is one of them: `bench/shaft_orders.py`); and the character of single pits (the 14 mil "
            "outer-race record hides its fault under its bearing's floor, its twin does not).")
    return out


def write_page(out_dir: Path, result: dict, spectra: dict, argv: list[str]) -> Path:
    img = out_dir / "img"
    img.mkdir(parents=True, exist_ok=True)
    rows = result["records"]
    twin = result["twin"]
    figs = []
    for kind in KINDS:
        rs = [r for r in rows if r["kind"] == kind]
        if not rs:
            continue
        rs = [r for r in rs if r["load_hp"] == min(x["load_hp"] for x in rs)]
        panels = []
        for r in rs:
            meas, tw, mult, fr = spectra[r["record"]]
            panels.append({"label": r["label"], "psd_f": meas["psd_f"], "psd_meas": meas["psd"],
                           "psd_twin": tw["psd"], "ses_meas": ses_db(meas), "ses_twin": ses_db(tw),
                           "lines_meas": kind_lines(kind, EFFECTIVE_6205, fr),
                           "lines_twin": kind_lines(kind, mult, fr)})
        name = f"validation_real_{kind}.png"
        report.kind_figure(img / name, kind, panels, twin)
        figs.append((kind, name))
    points = []
    for r in rows:
        kl = KIND_LINE.get(r["kind"])
        m = r["measured"]["DE"]
        ts = [t["DE"] for t in r["twin"]]
        points.append({"kind": r["kind"], "rms": (m["native"]["rms"], mean_over([t["native"]["rms"] for t in ts])),
                       "kurtosis": (m["native"]["kurtosis"], mean_over([t["native"]["kurtosis"] for t in ts])),
                       "line": None if kl is None else (m["ses"]["fixed"]["levels"][kl],
                                                        mean_over([t["ses"]["fixed"]["levels"][kl] for t in ts]))})
    report.summary_figure(img / "validation_real_summary.png", points, twin)
    s = result["summary"]
    page = out_dir / "validation_real.md"
    sim = report.sim2real_block(page)
    head = ["record", "1x [Hz]", "RMS [g]", "kurtosis", "crest", "2-4 kHz max/min", "kurtogram band [kHz]",
            "kind line 2-4 kHz [dB]", "kind line, kurtogram band", "its h2", "1x", "FTF", "sideband (larger)",
            "verdict", "RMS x2", "line 10 dB", "same verdict"]
    head_h = head[:-1] + ["same verdict / no line (healthy)"]
    h = s.get("healthy")
    lines = [
        "# Held against real measurements: the CWRU drive-end records and the twin",
        "",
        "<!-- Generated by bench/validate_real.py (and its sim2real block by bench/sim2real.py): edit the scripts, "
        "not this file. -->",
        "",
        f"**Today's twin: `{twin}`**" + (" (the fault library's 6010 motor; the CWRU rig's own twin, `cwru_rig`, "
                                         "is not in the product yet)." if twin == LIBRARY else "."),
        f"Code {report.code_version(ROOT)}; {len(rows)} records; {result['seeds']} seed(s) per record; "
        f"{result['wall_s']:.0f} s.",
        "",
        "<!-- docs-test: skip: DATA_DIR is the measured records' folder, which the project does not ship -->",
        "```sh",
        " ".join([".venv/bin/python bench/validate_real.py DATA_DIR", *argv]),
        "```",
        "",
        "DATA_DIR: the CWRU drive-end records as NumPy files (`1797_IR_7_DE12.npz`: keys `DE`, `FE` in g), from the "
        "Case Western Reserve University Bearing Data Center (https://engineering.case.edu/bearingdatacenter), e.g. "
        "the public NumPy conversion `srigas/CWRU_Bearing_NumPy`. The project keeps only short excerpts of four "
        "records for its tests (tests/fixtures/cwru/).",
        "",
        "## What is compared",
        "",
        "For each measured record, the twin at the same condition (`bench/realdata/twin.py`, `twin_run`: the one "
        "mapping from a record to the twin's case and run), rendered by the product's data-set renderer at the "
        "record's sample rate and length, at the record's shaft speed (estimated from its spectrum without a "
        "tachometer), DE = the twin's DE vertical housing acceleration, FE = its NDE one. Both go through the same "
        "textbook diagnostics, written in the bench (`bench/realdata/diagnostics.py`, Randall & Antoni 2011; "
        "Antoni's fast kurtogram): RMS, kurtosis and crest factor at the signal's own rate; everything else at "
        "12 kHz (the 48 kHz healthy record and its twin decimated alike): Welch PSD at 1 Hz and its energy by band; "
        "the squared-envelope spectrum (SES) of the fixed 2-4 kHz band and of the band the kurtogram picks (>= 1 kHz "
        "wide within 0.5-5.5 kHz); the level of each line over the SES floor (the median over 5-500 Hz outside the "
        "line windows; +-0.5 % for race lines and shaft orders, +-1 % for ball and cage lines); the no-training "
        "verdict (the fundamental of BPFO, BPFI or 2 x BSF reaching 10 dB and 3 dB above the other two; healthy "
        "if none reaches 10 dB). The measured records are read at the 6205's measured effective multipliers "
        "(BPFO 3.598x, BPFI 5.402x; FTF = BPFO / 9; 2 x BSF 4.7135x as CWRU publishes it), the twin at its own "
        "bearing's. Twin values are the mean over the seeds; its verdict the most frequent one.",
        "",
        "## Targets per record (DE channel)",
        "",
        report.table(["target", "met", "fraction"], [
            ["RMS within a factor 2 of the measurement", f"{s['rms_met']} of {s['rms_of']}",
             report.fmt(s["rms_fraction"], "{:.0%}")],
            ["the fault line's envelope level (2-4 kHz) within 10 dB", f"{s['line_met']} of {s['line_of']}",
             report.fmt(s["line_fraction"], "{:.0%}")],
            ["the same textbook verdict (including the same miss)", f"{s['verdict_met']} of {s['verdict_of']}",
             report.fmt(s["verdict_fraction"], "{:.0%}")],
            ["all of them (healthy: RMS, no fault line, band shape)", f"{s['all_met']} of {s['all_of']}",
             report.fmt(s["all_fraction"], "{:.0%}")],
            ["textbook verdict right (the record's own kind): measured / twin",
             f"{s['verdict_right_measured']} / {s['verdict_right_twin']} of {s['records']}", ""]]),
        "",
        "The target: each of the first three for >= 80 % of the records.",
        "",
    ]
    if h:
        lines += [
            "**The healthy record** (48 kHz): RMS twin / measured " + f"{h['rms_ratio']:.2f} ({report.mark(h['rms'])}; "
            f"{h['rms_12k_ratio']:.2f} over 0-6 kHz, both decimated to 12 kHz); the "
            f"twin's strongest fault line (BPFO, BPFI, 2 x BSF) {h['twin_strongest_fault_line_db']:.0f} dB over the "
            f"floor ({'none' if h['no_line'] else 'one'} above 10 dB: {report.mark(h['no_line'])}); band shape "
            "(each band's share of 0-5 kHz, twin - measured) " + ", ".join(
                f"{BROAD_BANDS[i][0] / 1e3:g}-{BROAD_BANDS[i][1] / 1e3:g} kHz {d:+.0f} dB"
                for i, d in zip(SHAPE_BANDS, h["shape_diff_db"])) + f" (within 10 dB: {report.mark(h['shape'])}). "
            "The line measure where no line is expected (300 random frequencies in 20-480 Hz, 2-4 kHz SES: its "
            "false-alarm level) reads, measured / twin: median "
            f"{h['null_db']['measured']['median']:.1f} / {h['null_db']['twin']['median']:.1f} dB, 95 % "
            f"{h['null_db']['measured']['p95']:.1f} / {h['null_db']['twin']['p95']:.1f} dB, 99 % "
            f"{h['null_db']['measured']['p99']:.1f} / {h['null_db']['twin']['p99']:.1f} dB over the floor.",
            ""]
    lines += [
        "## Where the twin differs, and why",
        "",
        *differences(rows, twin),
        "",
        "## Record by record, drive end",
        "",
        "Each cell: measured / twin. Levels in dB over the SES floor of the band; the kind line is BPFO (outer), "
        "BPFI (inner) or 2 x BSF (ball); the sideband column the larger of the kind line's +-1x (races) or "
        "+-FTF (ball) sidebands. 2-4 kHz max/min: the largest over the smallest RMS of the 2-4 kHz band in 0.25 s "
        "windows (about 1 for a steady signal; the twin's: the mean over its seeds).",
        "",
        report.table(head_h, record_rows(rows, "DE")),
        "",
        "## Fan end",
        "",
        "The same for the FE accelerometer (the twin's NDE housing); the 28 mil records have no FE channel.",
        "",
        report.table(head_h, record_rows(rows, "FE")),
        "",
        "## Energy by band, drive end",
        "",
        "Median over the records of each kind, dB re 1 g², measured / twin.",
        "",
        report.table(["kind"] + [f"{lo / 1e3:g}-{hi / 1e3:g} kHz" for lo, hi in BROAD_BANDS], band_rows(rows)),
        "",
        "## Figures",
        "",
        "![measured against twin: RMS, kurtosis, kind line](img/validation_real_summary.png)",
        "",
        "*Measured against twin, one dot per record (DE): RMS (grey: within a factor 2), kurtosis, the kind "
        "line's SES level (grey: within 10 dB).*",
        "",
    ]
    for kind, name in figs:
        lines += [f"![{kind}: PSD and SES, measured and twin](img/{name})", "",
                  f"*{kind}: DE PSD (measured black, twin orange) and the SES of 2-4 kHz of each, records at the "
                  "lowest load.*", ""]
    lines += [sim, ""]
    page.write_text("\n".join(lines))
    return page


def plain(v):
    """JSON form of numpy scalars."""
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return float(v)
    raise TypeError(f"{type(v).__name__} is not JSON")


def shown_argv(argv: list[str], data_dir: str) -> list[str]:
    """The command's options as the page shows them: without the data folder and the options that do not change
    the results (where the JSON and the work files go, how many processes)."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        if a in ("--json", "--work", "--workers"):
            skip = True
            continue
        if a != data_dir and not a.startswith(("--json=", "--work=", "--workers=")):
            out.append(a)
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data_dir", help="folder of CWRU records (.npz: DE, FE in g)")
    ap.add_argument("--twin", default=None, help=f"the twin: {LIBRARY!r} (the fault library) or a case name or TOML "
                    f"path (default: cwru_rig if embedded, else {LIBRARY!r})")
    ap.add_argument("--seeds", type=int, default=2, help="twin renders per record (default 2)")
    ap.add_argument("--records", default=None, help="only records whose name contains one of these (comma-separated)")
    ap.add_argument("--out", default=str(ROOT / "docs"), help="folder of validation_real.md and img/ (default docs/)")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    args.twin = args.twin or default_twin()
    if not 1 <= args.seeds <= 20:
        print(f"validate_real: --seeds: must be 1..20 (got {args.seeds})", file=sys.stderr)
        return 2
    bad = check_twin(args.twin)
    if bad:
        print(f"validate_real: --twin: {args.twin!r}: {bad}", file=sys.stderr)
        return 2
    out_dir = Path(args.out)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError:
        pass
    if not out_dir.is_dir():
        print(f"validate_real: --out: {out_dir}: not a folder", file=sys.stderr)
        return 2
    try:
        result, spectra = run(args)
    except RecordError as exc:
        print(f"validate_real: DATA_DIR: {exc}", file=sys.stderr)
        return 2
    shown = shown_argv(argv, args.data_dir)
    page = write_page(out_dir, result, spectra, shown)
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1, default=plain))
    s = result["summary"]
    print(f"validate_real: twin {args.twin}: RMS x2 {s['rms_met']}/{s['rms_of']}, line 10 dB "
          f"{s['line_met']}/{s['line_of']}, same verdict {s['verdict_met']}/{s['verdict_of']}, all "
          f"{s['all_met']}/{s['all_of']}; wrote {page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
