"""Sim to real: a classifier fitted on a labelled data set of the twin alone, scored on measured CWRU records.

    .venv/bin/python bench/sim2real.py DATA_DIR [--twin CASE] [--seeds N] [--segment-s S] [--workers W]
                                       [--work DIR] [--out DIR] [--json F]

1. The twin's data set, made by the product's ``bkabem dataset`` command: every fault kind (healthy, inner race,
   ball, outer race at 3, 6 and 12 o'clock), CWRU's pit sizes (0.007-0.028 in; 0.021 in at most for the outer
   race, as CWRU has them), its four loads (0-3 hp at 1797, 1772, 1750, 1730 rpm), slip 1 % and 2 % (a rig twin:
   ``rig_slips``: the rig case's measured jitter and three times it), ``--seeds``
   seeds each (the healthy machine more often, so that each class has about as many runs; a rig twin's race pits
   alternate over them between the ends of :data:`PIT_SPREADS`; its seeded bearings roll as rough as their make's
   on the rig, ``twin_run``), 12 kHz, ``--segment-s``
   seconds; each run is the twin of its condition as ``bench/realdata/twin.py`` (``twin_run``) maps it. The runs
   are grouped into grid specs (written beside the data set, ``DIR/specs/``).
2. Textbook features of the DE channel (``bench/realdata/classify.py``: envelope line levels at each fault
   frequency in the fixed 2-4 kHz band and in the kurtogram's band, harmonic sums, kurtosis, crest factor, RMS,
   band-energy shares) and two transparent models fitted on the twin alone: a class-balanced multinomial logistic
   regression and a nearest-centroid rule, in numpy.
3. Scored on the measured records (the first ``--segment-s`` seconds of each, at 12 kHz): accuracy per class
   (healthy / inner / ball / outer), overall, the confusion matrix; and the no-training textbook verdict's
   accuracy on the twin's runs against the measured records (a realistic twin is about as hard as the real thing).

Writes its block of ``DIR/validation_real.md`` (default docs/; the rest of the page is ``validate_real.py``'s),
``DIR/img/sim2real_confusion.png`` and, with ``--json``, the numbers. Exit code 2 with one line for a bad argument.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
for p in (str(ROOT), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

from realdata import report  # noqa: E402
from realdata.classify import (  # noqa: E402
    CLASSES,
    FEATURE_FAMILIES,
    FEATURE_NAMES,
    FEATURE_SETS,
    LogisticRegression,
    NearestCentroid,
    confusion,
    features,
    grouped_folds,
    per_class_accuracy,
)
from realdata.diagnostics import G, decimate, diagnose, estimate_speed  # noqa: E402
from realdata.records import EFFECTIVE_6205, LOAD_HP_OF_RPM, RecordError, scan  # noqa: E402
from realdata.twin import (  # noqa: E402
    CHANNELS,
    LIBRARY,
    SEEDED_ROUGHNESS_DB,
    Condition,
    base_case_ref,
    case_toml,
    check_twin,
    default_twin,
    label_mains_hz,
    label_multipliers,
    rig_slips,
    twin_run,
)

FS = 12000.0
RPM_OF_LOAD = {hp: rpm for rpm, hp in LOAD_HP_OF_RPM.items()}
SIZES = {"inner": (7, 14, 21, 28), "ball": (7, 14, 21, 28), "outer": (7, 14, 21)}
POSITIONS = (3, 6, 12)
SLIPS = (0.01, 0.02)
#: A race pit's strike spread over the replicates of its conditions (the key ``strike_spread``, docs/synthesis.md):
#: single pits of one size strike more or less evenly than the law's middle (1) by about a factor 1.5 either way on
#: the CWRU rig (``bench/impact_spread.py``), so a race condition's runs alternate between the two ends of that range
PIT_SPREADS = (round(1.0 / 1.5, 3), 1.5)
#: Refits of each model on resampled twin runs (with replacement), to show how much its score on the measured
#: records depends on the draw of the twin's data set.
REFITS = 20


# --------------------------------------------------------------------------- the data set
def conditions(loads=(0, 1, 2, 3)) -> list[Condition]:
    """Every condition of the training set (module docstring)."""
    out = []
    for hp in loads:
        out.append(Condition("healthy", 0, hp))
        for kind in ("inner", "ball"):
            out += [Condition(kind, s, hp) for s in SIZES[kind]]
        out += [Condition("outer", s, hp, pos) for s in SIZES["outer"] for pos in POSITIONS]
    return out


def slips_of(twin: str) -> tuple:
    """The slips of ``twin``'s training set: the fault library's :data:`SLIPS`, a rig's ``rig_slips``."""
    return SLIPS if twin == LIBRARY else rig_slips(twin)


def runs_of(conds: list[Condition], twin: str, seeds: int, segment_s: float) -> dict:
    """``{(base, overrides JSON): [(run parameters, replicates, condition)]}``; the healthy condition (one per
    load against 3-9 per fault kind) gets proportionally more replicates."""
    per_kind = Counter(c.kind for c in conds)
    top = max(per_kind.values())
    slips = slips_of(twin)
    groups = defaultdict(list)
    for c in conds:
        reps = seeds * max(1, round(top / per_kind[c.kind] / 2)) if c.kind == "healthy" else seeds
        base, overrides, params = twin_run(c, twin, RPM_OF_LOAD[c.load_hp] / 60.0)
        for i, slip in enumerate(slips):
            p = dict(params, slip=slip, duration_s=float(segment_s), sample_rate_hz=FS, quantities=["acceleration"])
            if c.kind not in ("inner", "outer") or twin == LIBRARY:
                groups[(base, json.dumps(overrides, sort_keys=True))].append((p, reps, c))
                continue
            n = len(PIT_SPREADS)                    # the replicates over the spreads, the odd one by the slip
            for k, spread in enumerate(PIT_SPREADS):
                r = reps // n + (1 if (k - i) % n < reps % n else 0)
                if r:
                    groups[(base, json.dumps(overrides, sort_keys=True))].append((dict(p, strike_spread=spread), r, c))
    return groups


def _canon(v) -> str:
    return json.dumps(v, sort_keys=True)


def factorise(points: list[tuple[dict, int]]) -> list[tuple[dict, dict, int]]:
    """Grid specs covering ``points`` (run parameters, replicates) exactly: ``[(fixed, grid lists, replicates)]``.

    Points with other keys or another fault kind go to other specs. A set of points is one grid when the points of
    its varying keys are the full Cartesian product of their values, each with the same replicate count; otherwise
    it is split by one varying key and each part tried again: the key whose split gives the fewest specs (a key that
    varies with another, such as a seeded bearing's roughness with its pit size, splits the set into few grids; the
    first key alone could split it into one spec per point). Each spec is one ``bkabem dataset`` process.
    """
    shapes = list(dict.fromkeys((tuple(sorted(p)), _canon(p.get("fault"))) for p, _ in points))
    if len(shapes) > 1:                             # other keys or another fault kind: apart first
        return [g for s in shapes for g in factorise([(p, r) for p, r in points
                                                      if (tuple(sorted(p)), _canon(p.get("fault"))) == s])]
    merged: dict[str, list] = {}
    for p, r in points:
        k = _canon(p)
        if k in merged:
            merged[k][1] += r
        else:
            merged[k] = [p, r]
    pts = list(merged.values())
    keys = list(pts[0][0])
    values = {k: list(dict.fromkeys(_canon(p[k]) for p, _ in pts)) for k in keys}
    varying = [k for k in keys if len(values[k]) > 1]
    size = int(np.prod([len(values[k]) for k in varying])) if varying else 1
    if len(pts) == size and len({r for _, r in pts}) == 1:
        fixed = {k: pts[0][0][k] for k in keys if k not in varying}
        grid = {k: [json.loads(v) for v in values[k]] for k in varying}
        return [(fixed, grid, pts[0][1])]
    best = None
    for k in varying:
        out = []
        for v in values[k]:
            out += factorise([(p, r) for p, r in pts if _canon(p[k]) == v])
        if best is None or len(out) < len(best):
            best = out
    return best


def write_specs(groups: dict, folder: Path) -> list[tuple[Path, int]]:
    """One grid spec per factor of each group, in ``folder``: ``[(path, runs)]``."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    i = 0
    for (base, overrides), pts in groups.items():
        ref = base_case_ref(base, json.loads(overrides), folder)
        for fixed, grid, reps in factorise([(p, r) for p, r, _ in pts]):
            i += 1
            spec = {"dataset": {"name": f"sim2real_{i:02d}", "schema_version": 1, "case": ref, "sampling": "grid",
                                "seed": 1000 + i, "replicates": reps},
                    "run": fixed, "output": {"compression": "none", "mcap": False}}
            if grid:
                spec["grid"] = grid
            path = folder / f"sim2real_{i:02d}.toml"
            path.write_text("# bkabem data-set spec written by bench/sim2real.py\n" + case_toml(spec))
            n = reps * int(np.prod([len(v) for v in grid.values()])) if grid else reps
            out.append((path, n))
    return out


def render(specs: list[tuple[Path, int]], sets: Path, workers: int) -> list[Path]:
    """``bkabem dataset SPEC --out sets/NAME`` for each spec (resumed if already there); the data-set folders."""
    from tqdm import tqdm

    exe = Path(sys.executable).parent / "bkabem"
    cmd0 = [str(exe)] if exe.exists() else [sys.executable, "-m", "bkabem_ros"]
    out = []
    with tqdm(total=sum(n for _, n in specs), unit="run", desc="bkabem dataset", dynamic_ncols=True) as bar:
        for path, n in specs:
            dest = sets / path.stem
            p = subprocess.run(cmd0 + ["dataset", str(path), "--out", str(dest), "--workers", str(workers),
                                       "--no-progress"], capture_output=True, text=True)
            if p.returncode != 0:
                raise RuntimeError(f"bkabem dataset {path.name}: exit {p.returncode}: "
                                   f"{(p.stderr or p.stdout).strip().splitlines()[-1:]}")
            out.append(dest)
            bar.update(n)
    return out


# --------------------------------------------------------------------------- features
def _twin_features(args) -> tuple:
    path, row = args
    import pyarrow.parquet as pq

    x = pq.read_table(path, columns=[CHANNELS["DE"]]).column(0).to_numpy().astype(np.float64) / G
    d = diagnose(x, float(row["sample_rate_hz"]), float(row["shaft_hz"]), label_multipliers(row),
                 mains_hz=label_mains_hz(row))
    return features(d), d["ses"]["fixed"]["verdict"], d["ses"]["kurtogram"]["verdict"]


def twin_table(sets: list[Path], workers: int) -> dict:
    """Features, labels, condition groups and verdicts of every run of the data sets."""
    import pyarrow.parquet as pq
    from tqdm import tqdm

    jobs = []
    for s in sets:
        for row in pq.read_table(s / "labels.parquet").to_pylist():
            jobs.append((str(s / row["file"]), row))
    with ProcessPoolExecutor(max_workers=workers) as ex:
        res = list(tqdm(ex.map(_twin_features, jobs, chunksize=4), total=len(jobs), unit="run", desc="twin features",
                        dynamic_ncols=True))
    y = np.array([CLASSES.index(r["fault"]) for _, r in jobs])
    # the runs whose condition the measured records have: outer race at 6 o'clock, 0 or 1 hp
    speeds = {round(RPM_OF_LOAD[hp] / 60.0, 2) for hp in (0, 1)}
    like = np.array([round(r["shaft_hz"], 2) in speeds
                     and (r["fault"] != "outer" or abs((r.get("d0_angle_deg") or 0.0) + 90.0) < 1e-6)
                     for _, r in jobs])
    groups = [(r["fault"], r.get("d0_length_m"), r.get("d0_angle_deg"), round(r["shaft_hz"], 2)) for _, r in jobs]
    return {"X": np.array([f for f, _, _ in res]), "y": y, "groups": groups, "like_measured": like,
            "verdict_fixed": [v for _, v, _ in res], "verdict_kurtogram": [v for _, _, v in res]}


def _measured_features(args) -> tuple:
    rec, segment_s = args
    raw = rec.load()
    ch = {k: decimate(v, rec.sample_rate_hz, FS) for k, v in raw.items()}
    fr, _ = estimate_speed(ch, FS, rec.speed_hz_nominal)
    x = ch["DE"][: int(round(segment_s * FS))]
    d = diagnose(x, FS, fr, EFFECTIVE_6205)
    return features(d), d["ses"]["fixed"]["verdict"], d["ses"]["kurtogram"]["verdict"], fr


def measured_table(data_dir, segment_s: float, workers: int) -> dict:
    from tqdm import tqdm

    recs = scan(data_dir)
    short = [r.name for r in recs if r.duration_s() < segment_s - 1e-6]
    if short:
        raise RecordError(f"--segment-s {segment_s:g}: longer than record(s) {', '.join(short)}")
    with ProcessPoolExecutor(max_workers=workers) as ex:
        res = list(tqdm(ex.map(_measured_features, [(r, segment_s) for r in recs]), total=len(recs), unit="record",
                        desc="measured features", dynamic_ncols=True))
    return {"records": recs, "X": np.array([f for f, *_ in res]), "y": np.array([CLASSES.index(r.kind) for r in recs]),
            "verdict_fixed": [v for _, v, _, _ in res], "verdict_kurtogram": [v for _, _, v, _ in res],
            "speed_hz": [fr for *_, fr in res]}


# --------------------------------------------------------------------------- scoring
def scores(y: np.ndarray, pred: np.ndarray) -> dict:
    m = confusion(y, pred)
    per = dict(zip(CLASSES, per_class_accuracy(m)))
    return {"accuracy": float(np.mean(y == pred)), "per_class": per,
            "balanced": float(np.mean([v for v in per.values() if v is not None])), "confusion": m.tolist()}


def verdict_scores(y: np.ndarray, verdicts: list[str], keep=None) -> dict:
    """Share of right verdicts (the verdict names the kind; ambiguous is wrong), overall, per class and balanced
    (the mean over the classes), over the samples ``keep`` (default all)."""
    keep = np.ones(len(y), bool) if keep is None else np.asarray(keep)
    right = np.array([v == CLASSES[t] for t, v in zip(y, verdicts)])[keep]
    y = y[keep]
    per = {c: (float(right[y == i].mean()) if np.any(y == i) else None) for i, c in enumerate(CLASSES)}
    return {"accuracy": float(right.mean()), "per_class": per, "n": int(keep.sum()),
            "balanced": float(np.mean([v for v in per.values() if v is not None]))}




def held_out(make, X: np.ndarray, y: np.ndarray, folds: list) -> np.ndarray:
    """Each sample's label predicted by a model ``make()`` fitted on the other folds (``folds``: index arrays)."""
    pred = np.empty_like(y)
    for test in folds:
        train = np.setdiff1d(np.arange(len(y)), test)
        pred[test] = make().fit(X[train], y[train]).predict(X[test])
    return pred


def evaluate(tw: dict, me: dict, l2: float) -> dict:
    """Both models on both feature sets: held-out conditions of the twin (5 grouped folds), then fitted on the
    whole twin set and scored on the measured records; the textbook verdict on both."""
    out = {"l2": l2, "models": {}}
    folds = grouped_folds(tw["groups"], 5)
    for fset, cols in FEATURE_SETS.items():
        Xt, Xm = tw["X"][:, cols], me["X"][:, cols]
        names = [FEATURE_NAMES[i] for i in cols]
        for name, make in (("logistic regression", lambda: LogisticRegression(l2)),
                           ("nearest centroid", NearestCentroid)):
            cv = held_out(make, Xt, tw["y"], folds)
            model = make().fit(Xt, tw["y"])
            pred = model.predict(Xm)
            rng = np.random.default_rng(7)
            boot = []
            for _ in range(REFITS):                 # the same model refitted on resampled twin runs
                i = rng.integers(0, len(tw["y"]), len(tw["y"]))
                boot.append(float(np.mean(make().fit(Xt[i], tw["y"][i]).predict(Xm) == me["y"])))
            r = {"features": fset, "model": name, "twin_cv": scores(tw["y"], cv), "measured": scores(me["y"], pred),
                 "predictions": pred.tolist(),
                 "refits": {"p10": float(np.percentile(boot, 10)), "median": float(np.median(boot)),
                            "p90": float(np.percentile(boot, 90))}}
            if isinstance(model, LogisticRegression):
                r["probabilities"] = model.proba(Xm).tolist()
                r["converged"] = model.converged
                r["weights"] = {c: dict(zip(names, model.W[:, i].round(3).tolist())) for i, c in enumerate(CLASSES)}
            out["models"][f"{name}, {fset}"] = r
    out["verdict"] = {band: {"twin": verdict_scores(tw["y"], tw[f"verdict_{band}"]),
                             "twin_like_measured": verdict_scores(tw["y"], tw[f"verdict_{band}"], tw["like_measured"]),
                             "measured": verdict_scores(me["y"], me[f"verdict_{band}"])}
                      for band in ("fixed", "kurtogram")}
    return out


def ablation(tw: dict, me: dict, l2: float, sets: dict = FEATURE_SETS, families: dict = FEATURE_FAMILIES) -> dict:
    """The logistic regression of each feature set refitted on the twin without one family of features at a time:
    ``{set: {family: {"measured", "balanced", "twin_cv"}}}`` (accuracy on the measured records, its balanced form,
    accuracy on the twin's held-out conditions), with ``"none"`` the set itself. A diagnosis of the twin, not a
    choice of features: a family whose absence raises the measured score is one the twin teaches differently from
    the rig."""
    folds = grouped_folds(tw["groups"], 5)
    out = {}
    for fset, cols in sets.items():
        out[fset] = {}
        for fam, drop in [("none", ())] + list(families.items()):
            keep = [i for i in cols if i not in drop]
            if drop and (len(keep) == len(cols) or not keep):
                continue
            Xt, Xm = tw["X"][:, keep], me["X"][:, keep]
            cv = held_out(lambda: LogisticRegression(l2), Xt, tw["y"], folds)
            s = scores(me["y"], LogisticRegression(l2).fit(Xt, tw["y"]).predict(Xm))
            out[fset][fam] = {"measured": s["accuracy"], "balanced": s["balanced"],
                              "twin_cv": float(np.mean(cv == tw["y"]))}
    return out


def ablation_lines(ab: dict, n_measured: int) -> list[str]:
    """The page's ablation table and its reading (the families that move the measured score by two records or more
    of ``n_measured``)."""
    step = 2.0 / n_measured - 1e-9
    sets = list(ab)
    fams = list(dict.fromkeys(f for s in sets for f in ab[s]))             # "none" first, then as ablated
    rows = []
    for f in fams:
        row = ["(none: the set as above)" if f == "none" else f]
        for s in sets:
            r = ab[s].get(f)
            row += ["" if r is None else f"{r['measured']:.2f}", "" if r is None else f"{r['balanced']:.2f}",
                    "" if r is None else f"{r['twin_cv']:.2f}"]
        rows.append(row)
    head = ["left out"] + [f"{s}: {w}" for s in sets for w in ("measured", "balanced", "twin")]
    said = []
    for s in sets:
        base = ab[s]["none"]["measured"]
        moved = {f: ab[s][f]["measured"] - base for f in fams[1:] if f in ab[s]}
        up = [f"{f} ({d:+.2f})" for f, d in moved.items() if d >= step]
        down = [f"{f} ({d:+.2f})" for f, d in moved.items() if d <= -step]
        said.append(f"with {s}, " + (f"the score on the measured records rises without {', '.join(up)}" if up
                                     else "no family's absence raises the score on the measured records")
                    + (f"; it falls without {', '.join(down)}" if down else ""))
    return [
        "**What the twin teaches differently from the rig** (an ablation: the logistic regression refitted without "
        "one family of features at a time; measured: overall on the "
        f"{n_measured} records; twin: its held-out conditions, 5 folds). This diagnoses the twin; the feature sets "
        "scored above stay what they are.",
        "",
        report.table(head, rows),
        "",
        f"Reading (a change of two records or more, {2.0 / n_measured:.2f}): " + ". And ".join(said) + ". A family "
        "whose absence helps is one whose levels the twin places differently from the rig for the same fault; the "
        "validation above gives its medians per kind (for instance FTF and 1x in the envelope).",
    ]


# --------------------------------------------------------------------------- the page block
def block(res: dict, me: dict, tw: dict, argv: list[str], img_name: str) -> str:
    ev = res["evaluation"]
    twin = res["twin"]
    counts = Counter(CLASSES[i] for i in tw["y"])
    primary, issue_set = list(FEATURE_SETS)
    lr = ev["models"][f"logistic regression, {primary}"]
    lr2 = ev["models"][f"logistic regression, {issue_set}"]
    pc = lambda r, c: report.fmt(r["per_class"][c], "{:.2f}")  # noqa: E731
    rows = []
    for name, r in ev["models"].items():
        b = r["refits"]
        rows.append([f"{name}: on the {len(me['y'])} measured records", *[pc(r["measured"], c) for c in CLASSES],
                     f"**{r['measured']['accuracy']:.2f}**", f"{r['measured']['balanced']:.2f}",
                     f"{b['p10']:.2f}-{b['p90']:.2f}"])
        rows.append([f"{name}: on the twin (5-fold, held-out conditions)", *[pc(r["twin_cv"], c) for c in CLASSES],
                     f"{r['twin_cv']['accuracy']:.2f}", f"{r['twin_cv']['balanced']:.2f}", ""])
    vrows = []
    who_text = {"twin": "on every twin run", "twin_like_measured": "on the twin runs of the records' conditions",
                "measured": "on the measured records"}
    for band, title in (("fixed", "2-4 kHz"), ("kurtogram", "kurtogram band")):
        for who in ("twin", "twin_like_measured", "measured"):
            v = ev["verdict"][band][who]
            vrows.append([f"textbook verdict, {title}, {who_text[who]} ({v['n']})", *[pc(v, c) for c in CLASSES],
                          f"{v['accuracy']:.2f}", f"{v['balanced']:.2f}", ""])
    m = np.array(lr["measured"]["confusion"])
    conf = report.table(["truth \\ predicted"] + list(CLASSES),
                        [[c] + [str(v) for v in m[i]] for i, c in enumerate(CLASSES)])
    per = []
    for i, rec in enumerate(me["records"]):
        per.append([rec.label, rec.kind] + [f"{CLASSES[r['predictions'][i]]} ({max(r['probabilities'][i]):.2f})"
                                            for r in (lr, lr2)] + [me["verdict_fixed"][i]])
    top = []
    for c in CLASSES:
        w = lr["weights"][c]
        best = sorted(w, key=lambda k: -abs(w[k]))[:3]
        top.append(f"{c}: " + ", ".join(f"{k} {w[k]:+.2f}" for k in best))
    n_of = Counter(CLASSES[i] for i in me["y"])
    acc = lr["measured"]["accuracy"]
    vt, vm = ev["verdict"]["fixed"]["twin_like_measured"], ev["verdict"]["fixed"]["measured"]
    chance = "below chance" if acc < 0.2 else "about chance" if acc < 0.45 else ""
    easier = [c for c in CLASSES if vt["per_class"][c] is not None and vm["per_class"][c] is not None
              and vt["per_class"][c] - vm["per_class"][c] >= 0.2]
    harder = [c for c in CLASSES if vt["per_class"][c] is not None and vm["per_class"][c] is not None
              and vm["per_class"][c] - vt["per_class"][c] >= 0.2]
    lines = [
        report.SIM2REAL_BEGIN,
        "## Sim-to-real: a classifier fitted on the twin alone, scored on the measurements",
        "",
        f"**Today's twin: `{twin}`.** Code {report.code_version(ROOT)}; {res['wall_s']:.0f} s "
        f"({res['render_s']:.0f} s for the data set).",
        "",
        "<!-- docs-test: skip: DATA_DIR is the measured records' folder, which the project does not ship -->",
        "```sh",
        " ".join([".venv/bin/python bench/sim2real.py DATA_DIR", *argv]),
        "```",
        "",
        f"**The twin's data set** (`bkabem dataset`, {len(res['specs'])} grid specs written by the script): "
        f"{len(tw['y'])} runs of {res['segment_s']:g} s at 12 kHz: "
        + ", ".join(f"{counts[c]} {c}" for c in CLASSES) + ". Every kind; the outer race at 3, 6 and 12 o'clock; "
        "CWRU's pit sizes (7-28 mil; 21 at most on the outer race); loads 0-3 hp at CWRU's nominal speeds "
        f"(1797-1730 rpm); slip {' and '.join(f'{100 * x:g} %' for x in slips_of(twin))}; {res['seeds']} seed(s) "
        "per condition and slip (the healthy machine "
        "more, so that each class has about as many runs)"
        + ("" if twin == LIBRARY else f"; a race pit's `strike_spread` {' and '.join(f'{x:g}' for x in PIT_SPREADS)} "
           "over those replicates (single pits differ from the law by about 1.5x either way on the rig); a seeded "
           "bearing's `roughness_db` its make's on the rig ("
           + ", ".join(f"{m} {db:g} dB" for m, db in SEEDED_ROUGHNESS_DB.items()) + ")")
        + "; each run the twin of its condition as `twin_run` "
        "maps it" + (" (the fault library: its own dents whatever the pit size, so the sizes are repeats with "
                     "other seeds)" if twin == LIBRARY else "") + ".",
        "",
        f"**Features** ({len(FEATURE_NAMES)}, DE channel, `bench/realdata/classify.py`): " + ", ".join(FEATURE_NAMES)
        + ". Line levels in dB over the SES floor at each signal's own bearing's fault frequencies (the twin's "
        "bearing from its labels, the rig's 6205 at its measured effective multipliers) and shaft speed (the "
        "twin's labelled, the record's estimated).",
        "",
        f"**Models** (numpy, fitted on the twin alone, standardized with the twin's statistics): a multinomial "
        f"logistic regression, L2 penalty {ev['l2']:g}, class-balanced, and a nearest-centroid rule. The measured "
        f"records are scored on their first {res['segment_s']:g} s (the healthy record is 5.08 s long).",
        "",
        report.table(["", *CLASSES, "overall", "balanced", f"refits, 10-90 % ({REFITS})"], rows + vrows),
        "",
        "Chance: 0.25. Overall: the share of right labels; balanced: the mean over the classes; refits: the overall "
        f"score of the same model refitted on {REFITS} resamples of the twin's runs (with replacement), 10th to 90th "
        "percentile: how much the score on the measured records depends on the draw of the twin's data set (the "
        "measured set "
        f"has {', '.join(f'{n_of[c]} {c}' for c in CLASSES)} records). The verdict rows: the no-training envelope "
        "verdict "
        "of the validation above (right when it names the kind; ambiguous counts as wrong) on every twin run, on "
        "the twin runs of the measured records' conditions (outer race at 6 o'clock, 0 and 1 hp) and on the "
        "measured records: a realistic twin is about as hard for it as the real thing.",
        "",
        f"Confusion matrix of the logistic regression (all features) on the {len(me['y'])} measured records (rows: "
        "truth):",
        "",
        conf,
        "",
        f"![confusion matrices](img/{img_name})",
        "",
        "*Confusion matrices of the logistic regression on the measured records (rows: truth, columns: predicted), "
        "with every feature and with the envelope set.*",
        "",
        "Largest standardized weights of the logistic regression (all features), per class: " + "; ".join(top) + ".",
        "",
        "**Reading.** " + (
            f"Fitted on `{twin}` alone, the classifier labels the measured records at {acc:.2f} overall "
            f"(chance 0.25; balanced {lr['measured']['balanced']:.2f}; {lr['refits']['p10']:.2f}-"
            f"{lr['refits']['p90']:.2f} over refits)"
            f"{f': {chance}' if chance else ''}, against "
            f"{lr['twin_cv']['accuracy']:.2f} on the twin's own held-out conditions: what it learns separates the "
            f"twin's classes, not the rig's. With the envelope feature set (envelope lines, kurtosis, crest factor: "
            f"no level, no spectral shape) it scores {lr2['measured']['accuracy']:.2f} (balanced "
            f"{lr2['measured']['balanced']:.2f}; {lr2['refits']['p10']:.2f}-{lr2['refits']['p90']:.2f} over refits). "
            "The textbook verdict (2-4 kHz) is right on "
            f"{vt['balanced']:.0%} (balanced) of the twin's runs at the records' conditions and on "
            f"{vm['balanced']:.0%} "
            "of the measured records"
            + (f"; the twin is easier for it in {', '.join(easier)}" if easier else "")
            + (f" and harder in {', '.join(harder)}" if harder else "")
            + (" (per class, by 0.2 or more)." if easier or harder else ": about as hard, class by class.")),
        "",
        "Per record (the logistic regression's label and probability with each feature set; the textbook verdict, "
        "2-4 kHz):",
        "",
        report.table(["record", "truth", f"logistic regression, {primary}", f"logistic regression, {issue_set}",
                      "textbook verdict"], per),
        "",
        *ablation_lines(ev["ablation"], len(me["y"])),
        report.SIM2REAL_END,
    ]
    return "\n".join(lines)


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
    ap.add_argument("--twin", default=None, help=f"the twin: {LIBRARY!r} or a case name or TOML path (default: "
                    f"cwru_rig if embedded, else {LIBRARY!r})")
    ap.add_argument("--seeds", type=int, default=2, help="runs per condition and slip (default 2)")
    ap.add_argument("--segment-s", type=float, default=5.0, help="seconds per run and per measured record (default "
                    "5: the healthy record's length)")
    ap.add_argument("--loads", default="0,1,2,3", help="loads [hp] of the training set (default 0,1,2,3)")
    ap.add_argument("--l2", type=float, default=0.01, help="L2 penalty of the logistic regression (default 0.01)")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="processes (default: every core)")
    ap.add_argument("--work", default=None, help="folder of the specs and the data set (kept; a rerun resumes "
                    "it); default: a temporary folder, removed")
    ap.add_argument("--out", default=str(ROOT / "docs"), help="folder of validation_real.md and img/ (default docs/)")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    args.twin = args.twin or default_twin()
    errors = []
    if not 1 <= args.seeds <= 20:
        errors.append(f"--seeds: must be 1..20 (got {args.seeds})")
    if not 1.0 <= args.segment_s <= 60.0:
        errors.append(f"--segment-s: must be 1..60 s (got {args.segment_s:g})")
    try:
        loads = tuple(int(v) for v in args.loads.split(","))
        if not loads or any(v not in RPM_OF_LOAD for v in loads):
            raise ValueError
    except ValueError:
        errors.append(f"--loads: comma-separated loads out of 0, 1, 2, 3 (got {args.loads!r})")
    if not 1 <= args.workers <= 64:
        errors.append(f"--workers: must be 1..64 (got {args.workers})")
    if not (args.l2 > 0 and np.isfinite(args.l2)):
        errors.append(f"--l2: must be > 0 (got {args.l2})")
    out_dir = Path(args.out)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError:
        pass
    if not out_dir.is_dir():
        errors.append(f"--out: {out_dir}: not a folder")
    bad = check_twin(args.twin)
    if bad:
        errors.append(f"--twin: {args.twin!r}: {bad}")
    if errors:
        print(f"sim2real: {errors[0]}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="bkabem_sim2real_"))
    try:
        try:
            scan(args.data_dir)
        except RecordError as exc:
            print(f"sim2real: DATA_DIR: {exc}", file=sys.stderr)
            return 2
        groups = runs_of(conditions(loads), args.twin, args.seeds, args.segment_s)
        specs = write_specs(groups, work / "specs")
        t1 = time.perf_counter()
        sets = render(specs, work / "sets", args.workers)
        render_s = time.perf_counter() - t1
        tw = twin_table(sets, args.workers)
        try:
            me = measured_table(args.data_dir, args.segment_s, args.workers)
        except RecordError as exc:
            print(f"sim2real: {exc}", file=sys.stderr)
            return 2
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)
    ev = evaluate(tw, me, args.l2)
    ev["ablation"] = ablation(tw, me, args.l2)
    res = {"twin": args.twin, "seeds": args.seeds, "segment_s": args.segment_s, "loads": list(loads),
           "specs": [p.name for p, _ in specs], "runs": int(len(tw["y"])),
           "runs_per_class": {c: int(np.sum(tw["y"] == i)) for i, c in enumerate(CLASSES)},
           "records": [r.name for r in me["records"]], "measured_speed_hz": me["speed_hz"],
           "evaluation": ev, "render_s": render_s, "wall_s": time.perf_counter() - t0}
    img = out_dir / "img"
    img.mkdir(exist_ok=True)
    name = "sim2real_confusion.png"
    report.confusion_figure(img / name, [
        (f"{fset} (fitted on {args.twin}): {r['measured']['accuracy']:.2f}", np.array(r["measured"]["confusion"]))
        for fset in FEATURE_SETS for r in [ev["models"][f"logistic regression, {fset}"]]], list(CLASSES))
    shown = shown_argv(argv, args.data_dir)
    report.replace_sim2real_block(out_dir / "validation_real.md", block(res, me, tw, shown, name))
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    primary, issue_set = list(FEATURE_SETS)
    lr = ev["models"][f"logistic regression, {primary}"]["measured"]
    print(f"sim2real: twin {args.twin}: {res['runs']} runs; on the {len(me['y'])} measured records logistic "
          f"regression {lr['accuracy']:.2f} (" + ", ".join(f"{c} {report.fmt(v, '{:.2f}')}" for c, v in
                                                         lr["per_class"].items())
          + f"), with the envelope features "
          f"{ev['models'][f'logistic regression, {issue_set}']['measured']['accuracy']:.2f}, nearest centroid "
          f"{ev['models'][f'nearest centroid, {primary}']['measured']['accuracy']:.2f}; textbook verdict "
          f"(balanced) twin {ev['verdict']['fixed']['twin_like_measured']['balanced']:.2f} at the records' "
          f"conditions, measured {ev['verdict']['fixed']['measured']['balanced']:.2f}; wrote "
          f"{out_dir / 'validation_real.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
