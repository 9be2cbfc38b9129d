"""The tables of BENCHMARKS.md: a row (case, quantity, value, target) and, per benchmark step, the reader that
turns the step's JSON into rows. Used by bench/run_all.py, which runs the steps and writes the page."""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass


# --------------------------------------------------------------------------- rows and targets
@dataclass
class Target:
    """A bound an issue set: ``value <op> bound`` (op one of <=, <, >=, ==)."""

    op: str
    bound: float
    text: str

    def met(self, value) -> bool | None:
        if value is None or (isinstance(value, float) and not math.isfinite(value)):
            return None
        return {"<=": value <= self.bound, "<": value < self.bound, ">=": value >= self.bound,
                "==": value == self.bound}[self.op]


def le(bound, text):
    return Target("<=", bound, text)


def lt(bound, text):
    return Target("<", bound, text)


def ge(bound, text):
    return Target(">=", bound, text)


def eq(bound, text):
    return Target("==", bound, text)


def row(case: str, quantity: str, value, fmt: str, unit: str = "", target: Target | None = None, note: str = ""):
    """One table row; ``value`` a number (or None), shown as ``fmt.format(value)``, its unit and ``note``."""
    if value is not None:
        value = float(value)
    out = {"case": case, "quantity": quantity, "value": value, "fmt": fmt, "unit": unit, "note": note}
    if target is not None:
        out["target"] = target.text
        m = target.met(value)
        out["met"] = None if m is None else bool(m)
    return out


def shown(r: dict) -> str:
    """The value column of a row: number, unit (``1200x``, ``4.7 x real time``, ``0.8 s``) and note."""
    if "shown" in r:                                           # a row of an older record
        return r["shown"]
    unit = r.get("unit", "")
    sep = "" if unit.startswith("x") and " " not in unit[:2] else " "
    text = "—" if r["value"] is None else r["fmt"].format(r["value"]) + (f"{sep}{unit}" if unit else "")
    return text + (f" ({r['note']})" if r.get("note") else "")


def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


# --------------------------------------------------------------------------- readers: JSON -> rows
def read_core(d, _args):
    r = [row("electric_motor_6010 (outer race, 50 BPFO orders)", "one-time preparation (machine, excitations, "
             "modal basis, line modes)", d["preparation_s_median"], "{:.2f}", "s", le(2.0, "<= 2 s"),
             note=f"excitation {d['preparation_stages_s']['excitation']:.2f} s, solver set-up "
                  f"{d['preparation_stages_s']['solver_setup']:.2f} s"),
         row("electric_motor_6010", "model for another defect of the same machine (`like=`)",
             1e3 * d["like_preparation_s_median"], "{:.0f}", "ms"),
         row("electric_motor_6010", f"spectrum at a new speed, {d['orders']} orders x 8 outputs (median)",
             d["spectrum_modal_ms_median"], "{:.3f}", "ms", le(1.0, "<= 1 ms"),
             note=f"p90 {d['spectrum_modal_ms_p90']:.3f} ms"),
         row("electric_motor_6010", f"the same by the exact block solve of the {d['ndof']}-DOF FE (reference)",
             d["spectrum_block_ms_median"], "{:.1f}", "ms"),
         row("electric_motor_6010", "the same by dense LAPACK (reference)", d["spectrum_direct_ms_median"],
             "{:.0f}", "ms"),
         row("electric_motor_6010", "sweep of 1000 speeds", d["sweep_1000_s_median"], "{:.3f}", "s",
             le(1.0, "<= 1 s")),
         row("electric_motor_6010", "improved method (`HillCorrection`) at a new speed (median)",
             d["hill_ms_median"], "{:.2f}", "ms", le(1.0, "<= 1 ms"),
             note=f"p90 {d['hill_ms_p90']:.2f} ms; its preparation {1e3 * d['hill_preparation_s_median']:.0f} ms")]
    return r


def read_preparation(d, _args):
    out = []
    for name, runs in d.items():
        rs = runs["this"]
        lines = rs[0]["lines"]
        single = name != "inner+ball"
        case = f"{name} ({lines} lines)"
        wall = med(x["wall_s"] for x in rs)
        exc = med(x["parts"].get("excitation") for x in rs)
        setup = med(x["parts"].get("solver_setup") for x in rs)
        out.append(row(case, "excitation of every bearing (quasi-static solutions, lines)", exc, "{:.2f}", "s"))
        out.append(row(case, "preparation `BkaBem(case)` (excitation, FE, modal basis, line modes)", wall,
                       "{:.2f}", "s", le(2.0, "<= 2 s per defect kind") if single else None,
                       note=f"solver set-up {setup:.2f} s" + ("" if single else "; two moving defects at once")))
        out.append(row(case, "new speed `response([f])` (median of 200)", med(x["new_speed_us"] for x in rs),
                       "{:.0f}", "us", le(1000.0, "<= 1 ms")))
        hills = [x["hill"] for x in rs if x.get("hill") and "preparation_s" in x["hill"]]
        if hills:
            method = hills[0]["method"]
            out.append(row(case, f"improved method ({method} form) at a new speed (median of 5)",
                           med(h["spectrum_ms"] for h in hills), "{:.1f}", "ms",
                           le(1.0, "<= 1 ms") if method == "orders" else None,
                           note=f"its preparation {med(h['preparation_s'] for h in hills):.2f} s"))
    return out


def read_tdsm(d, _args):
    out = []
    for r in d["runs"]:
        ms = statistics.median(r["ms_per_step"])
        out.append(row(f"electric_motor_6010 at {r['speed_hz']:g} Hz", f"TDSM step, {r['scheme']} scheme "
                       f"({r['ndof']} DOF, step {r['step_s'] * 1e6:.2f} us)", ms, "{:.3f}", "ms",
                       le(0.1, "<= 0.1 ms per step"), note=f"Newton iterations {r['newton']:.2f} a step"))
    for h in d["hbm"]:
        out.append(row(f"electric_motor_6010 at {h['speed_hz']:g} Hz", "periodic steady state by harmonic "
                       "balance, nonlinear (`hbm`)", h["hbm_s"], "{:.2f}", "s",
                       note=f"linearised `parametric` {h['parametric_s']:.2f} s; {h['iterations']} Newton steps"))
    return out


def read_validate(docs, _args):
    """Rows from ``bkabem validate --json`` at several speeds: accuracy of the five largest lines, cost."""
    def per(d, key):
        return [d[loc][di][key] for loc in ("de_rotor", "de_housing", "nde_rotor", "nde_housing")
                for di in ("vertical", "horizontal")]

    plain = [v for d in docs for k in ("max_abs_error_db_largest", "max_abs_error_db_largest_acceleration")
             for v in per(d, k)]
    hill = [v for d in docs for k in ("improved_max_abs_error_db_largest",
                                      "improved_max_abs_error_db_largest_acceleration") for v in per(d, k)]
    speeds = ", ".join(f"{d['speed_hz']:g}" for d in docs)
    case = f"electric_motor_6010 at {speeds} Hz"
    ratio = [d["speed_ratio"] for d in docs]
    return [
        row(case, "plain BKA-BEM against the TDSM: worst error of the 5 largest lines per location and direction, "
            "median over speeds, locations, directions, displacement and acceleration", statistics.median(plain),
            "{:.2f}", "dB", le(3.0, "<= 3 dB")),
        row(case, "plain BKA-BEM: worst of them", max(plain), "{:.2f}", "dB", le(5.0, "<= 5 dB")),
        row(case, "improved method: worst of them", max(hill), "{:.2f}", "dB", le(1.0, "<= 1 dB")),
        row(case, "improved method at a new speed (median over the speeds)",
            1e3 * statistics.median(d["wall_time_s"]["hill_spectrum"] for d in docs), "{:.2f}", "ms",
            le(1.0, "<= 1 ms")),
        row(case, "TDSM run against the plain spectrum of the same run (smallest over the speeds)", min(ratio),
            "{:,.0f}", "x", ge(1000.0, ">= 1000x"),
            note=f"TDSM {statistics.median(d['wall_time_s']['tdsm'] for d in docs):.1f} s a run, median"),
    ]


def read_synth(d, _args):
    info = d["info"]
    case = f"electric_motor_6010 (BPFO orders), {info['channels']} ch, {info['sample_rate_hz'] / 1e3:g} kHz"
    out = []
    for r in d["results"]:
        name = r["scenario"]
        target = ge(1000.0, ">= 1000x") if name.startswith("stream/modal: new speed every chunk, no features") \
            else None
        out.append(row(case, f"synthesis, {name} [x real time]", r["rtf_wall"], "{:.0f}", "x", target,
                       note=f"CPU time {r['rtf_cpu']:.0f}x"))
    mem = info.get("memory_mb")
    if mem:
        out.append(row(case, "memory peak of a 20-s run with slip and noise (tracemalloc)", mem["20s"], "{:.1f}",
                       "MB", note=f"{mem['2s']:.1f} MB for 2 s: bounded by the chunk"))
    return out


def read_faults(d, _args):
    out = []
    for r in d:
        case = f"{r['case']} ({r['lines']} lines), 8 ch, 51.2 kHz"
        q = "synthesis, new speed every 0.1-s chunk, features on"
        out.append(row(case, q + " [x real time]", r["synthesis_plain_rt"], "{:.0f}", "x", ge(1000.0, ">= 1000x")))
        out.append(row(case, q + ", slip 1 % + sensor noise [x real time]", r["synthesis_slip_noise_rt"], "{:.0f}",
                       "x", ge(1000.0, ">= 1000x")))
    return out


def read_dataset_synth(d, _args):
    out = []
    for r in d["rows"]:
        case = f"motor_6010_{r['kind']}, {r['config']}"
        out.append(row(case, "synthesis alone, 10-s runs at 25.6 kHz, 1-s chunks, constant speed [x real time]",
                       r["synth_x"], "{:.0f}", "x"))
    return out


def read_dataset(d, _args):
    out = []
    for r in d["rows"]:
        case = f"motor_6010_{r['kind']}, {r['config']}"
        out.append(row(case, "whole path per core: synthesis + Parquet + fsync + labels [x real time]", r["whole_x"],
                       "{:.0f}", "x", ge(500.0, ">= 500x per core"),
                       note=f"{r['run_wall_ms']:.1f} ms a 10-s run; CPU time {r['whole_cpu_x']:.0f}x"))
        out.append(row(case, "writing alone, a 10-s run", r["write_ms"], "{:.1f}", "ms",
                       note=f"run set-up {r['setup_ms']:.1f} ms"))
    e = d.get("end_to_end")
    if e:
        out.append(row(f"dataset_example ({e['runs']} runs, {e['signal_s']:g} s of signal, {e['workers']} workers)",
                       "`bkabem dataset` end to end, models made afresh", e["wall_s"], "{:.1f}", "s",
                       note=f"models {e['model_worker_s']:.1f} s, synthesis + writing {e['render_worker_s']:.2f} s "
                            f"of worker time"))
    return out


def read_floor(d, _args):
    out = []
    for r in d["rows"]:
        case = f"motor_6010_healthy, {r['set']} ({r['channels']} ch, 25.6 kHz)"
        out.append(row(case, "broadband floor: frames of a new seed", r["frames_ms"], "{:.1f}", "ms",
                       note=f"the transfer, once per model and channel set: {r['transfer_ms']:.0f} ms"))
    m = d.get("machines")
    if m:
        out.append(row(f"{m['machines']} synthesisers of one model (8 ch)", "per machine: time and traced memory",
                       m["ms_each"], "{:.0f}", "ms", note=f"{m['mb_each']:.1f} MB"))
    w = d.get("swing")
    if w:
        out.append(row("cwru_rig, healthy (12 kHz x 4 ch)", "synthesis with the floor swinging over the turn / without "
                       "(same run, alternated)", w["cost_ratio"], "{:.2f}", "x the time",
                       note=f"{w['x_real_time_swing']:.0f} / {w['x_real_time_stationary']:.0f} x real time"))
    return out


def read_node(d, _args):
    out = []
    for r in d["node"]:
        rate = r["sample_rate_hz"]
        case = f"`bkabem node`, {rate / 1e3:g} kHz x 8 ch, {r['chunk_s']:g}-s chunks, {r['qos']} QoS"
        lat = r.get("publish_lateness_ms") or {}
        out.append(row(case, "node CPU", r["node_cpu_pct_of_one_core"], "{:.1f}", "% of one core",
                       le(15.0, "<= 15 % of one core")))
        out.append(row(case, f"lost chunks (of {r['messages_received']} messages received)", r["lost_chunks"],
                       "{:.0f}", "", eq(0, "0")))
        out.append(row(case, "publish lateness p99 (waveforms handed to DDS - last sample due)", lat.get("p99_ms"),
                       "{:.1f}", "ms", le(5.0, "<= 5 ms") if rate == 25600 else None,
                       note=f"p50 {lat.get('p50_ms', float('nan')):.1f}, max {lat.get('max_ms', float('nan')):.1f} "
                            f"ms; timer wake-up p99 {lat.get('start_p99_ms', float('nan')):.1f} ms"))
        out.append(row(case, "speed message -> first chunk at the new speed received (median)",
                       r["speed_to_new_speed_chunk_received_ms_median"], "{:.0f}", "ms",
                       note=f"the ramp begins in the signal {r['speed_to_ramp_start_in_signal_ms_median']} ms "
                            f"after the message"))
    return out


def read_fleet(d, _args):
    out = []
    for s in d["summary"]:
        case = f"`bkabem fleet --machines {s['machines']}`, 25.6 kHz x 8 ch each, one host"
        out.append(row(case, "CPU of the fleet's processes", s["cpu_pct_median"], "{:.0f}", "% of one core",
                       note=f"Python thread {s['cpu_python_pct_median']} %, Fast DDS threads "
                            f"{s['cpu_dds_pct_median']} %; load {s['load_median']}"))
        out.append(row(case, "worst chunk of the worst machine (publish lateness max)", s["lateness_max_worst_median"],
                       "{:.0f}", "ms", lt(100.0, "< 100 ms (one chunk) at >= 100 machines")
                       if s["machines"] >= 100 else None,
                       note=f"p99 {s['lateness_p99_worst_median']} ms; on time in {s['on_time_runs']} of "
                            f"{s['runs']} runs"))
    return out


def read_speed_jumps(d, _args):
    out = []
    for r in d:
        if r["version"] != "this":
            continue
        case = f"`bkabem node` 25.6 kHz, speed profile {r['profile']}"
        out.append(row(case, f"publish lateness max, {r['scenario']}", r["max_ms"], "{:.1f}", "ms",
                       lt(100.0, "< 100 ms (no chunk delayed past the next one)"),
                       note=f"p99 {r['p99_ms']:.1f} ms; {r['max_over_steady']:.1f}x steady"))
    return out


def read_record(d, _args):
    case = "51.2 kHz x 8 ch (node pattern), 0.1-s chunks"
    m, r = d["mcap_sink"], d["rerun_logger"]
    out = [row(case, "MCAP sink alone: CPU per second of data", m["cpu_percent_of_one_core"], "{:.1f}",
               "% of one core", note=f"{m['file_mb'] / m['data_s']:.2f} MB per recorded second"),
           row(case, "MCAP sink alone: messages lost", m["messages"] - m["in_file"] + m["index_gaps"], "{:.0f}", "",
               eq(0, "0")),
           row(case, "Rerun logger alone (set-up included): CPU per second of data", r["cpu_percent_of_one_core"],
               "{:.1f}", "% of one core")]
    node = d.get("node") or {}
    case = "`VibrationNode` at 51.2 kHz x 8 ch"
    if "node_cpu_percent_median" in node:
        runs = node.get("mcap", [])
        out += [row(case, "node CPU without recording", node["node_cpu_percent_median"], "{:.1f}", "% of one core"),
                row(case, "recording to MCAP adds", node["overhead_mcap_percent_of_one_core"], "{:.1f}",
                    "% of one core", le(5.0, "<= 5 % of one core"),
                    note="paired differences " + ", ".join(f"{x:.1f}" for x in node["overhead_mcap_paired"])),
                row(case, "MCAP + Rerun recording add", node["overhead_mcap_rerun_percent_of_one_core"], "{:.1f}",
                    "% of one core"),
                row(case, "messages published but not in the MCAP file, and index gaps",
                    sum(x["sink_messages"] - x["in_file"] + x.get("index_gaps", 0) for x in runs), "{:.0f}", "",
                    eq(0, "0"), note=f"{sum(x['in_file'] for x in runs)} messages recorded")]
    elif node.get("skipped"):
        out.append(row(case, "node with recording", None, "", note=node["skipped"]))
    return out


def read_rerun(d, _args):
    s = d["summary"]["this tree"]
    case = "51.2 kHz x 8 ch (node pattern) -> `.rrd`"
    return [row(case, "Rerun logging: CPU per second of data (set-up apart)", s["cpu_percent_median"], "{:.1f}",
                "% of one core", le(12.5, "<= 12.5 % (half the 25 % before)")),
            row(case, "file size per recorded second", s["mb_per_recorded_s"], "{:.2f}", "MB",
                note=f"{s['bytes_per_sample']:.1f} B a sample; after compaction "
                     f"{s.get('optimized_mb_per_recorded_s', float('nan')):.2f} MB"),
            row(case, "logger set-up (once per recording: the blueprint)", s["setup_cpu_ms"], "{:.0f}", "ms CPU"),
            row(case, "chunk compaction after closing (`rerun rrd optimize`)",
                1e3 * s.get("optimize_cpu_s_per_recorded_s", float("nan")), "{:.0f}", "ms CPU per recorded second")]


def read_model_switch(d, _args):
    out = []
    for pair in dict.fromkeys(r["pair"] for r in d):
        rs = [r for r in d if r["pair"] == pair]
        case = f"motor_6010 {pair.replace('->', ' -> ')}, node path (25.6 kHz x 8 ch, 0.1-s chunks)"
        ordinary = med(max(r["ordinary_a_ms"], r["ordinary_b_ms"]) for r in rs)
        out.append(row(case, "chunk at the model switch", med(r["switch_ms"] for r in rs), "{:.2f}", "ms",
                       note=f"ordinary chunk {ordinary:.2f} ms; worst chunk while the next model is made "
                            f"{med(r['waiting_max_ms'] for r in rs):.1f} ms"))
        out.append(row(case, "warm-up of the next model in the warm thread", med(r["warm_s"] for r in rs), "{:.2f}",
                       "s"))
    return out


def read_scenario(d, _args):
    out = []
    for r in d["rows"]:
        case = f"scenario state, DE {r['kind']} ({r['lines']} lines): {r['state_1']} -> {r['state_2']}"
        out.append(row(case, "model of the next state made like the previous one", r["like_s"], "{:.2f}", "s",
                       note=f"from nothing {r['from_nothing_s']:.2f} s"))
        out.append(row(case, "hand-over from the helper process (pickle + unpickle)",
                       r["pickle_s"] + r["unpickle_s"], "{:.3f}", "s", note=f"{r['model_mb']:.0f} MB"))
    f = d.get("run_to_failure")
    if f:
        out.append(row("`de_outer_run_to_failure` at x3600, 25.6 kHz x 8 ch, slip + noise",
                       f"offline `ScenarioRun`, {f['states']} states, models made inline", f["x_real_time"],
                       "{:.1f}", "x real time"))
    return out


def read_machine(d, _args):
    out = []
    for name, r in d.items():
        case = f"{name} ({r['lines']} lines, {r['dof']} DOF)"
        out.append(row(case, "preparation `BkaBem(case)` of a catalogue machine in the compact form (median)",
                       r["prep_s"], "{:.2f}", "s", le(2.0, "<= 2 s"), note=f"CPU {r['prep_cpu_s']:.2f} s"))
        # the target is for up to 300 lines; a rig twin carries every line up to its band (700-1400)
        few = r["lines"] <= 300
        out.append(row(case, "a new speed: `response` / `spectrum` (median of 200 speeds)", r["spectrum_ms"],
                       "{:.2f}", "ms", le(1.0, "<= 1 ms") if few else None,
                       note=f"response {r['response_ms']:.2f} ms" + ("" if few else "; the target is for <= 300 "
                                                                                    "lines")))
    return out


def read_startup(d, _args):
    out = [row("`bkabem --help`", "start-up of the command line (fresh process, median)", d["help"]["median_s"],
               "{:.2f}", "s", le(0.3, "<= 0.3 s")),
           row("`from bkabem_core import Case, BkaBem, Synthesizer`", "library import (fresh process, median)",
               d["import"]["median_s"], "{:.2f}", "s"),
           row("`bkabem excitation --json`", "end to end (fresh process, median)", d["excitation"]["median_s"],
               "{:.2f}", "s"),
           row("`bkabem spectrum --speed-hz 25 --json`", "end to end: model prepared, one spectrum (median)",
               d["spectrum"]["median_s"], "{:.2f}", "s")]
    for key, what in (("unit_tier_cold", "wall time, every model made (after a change to the physics; a fresh "
                                         "clone)"),
                      ("unit_tier", "wall time, models from the test cache (after a change above `solve`)")):
        if key in d:
            out.append(row("`make unit` (the fast tier, pytest-xdist)", what, d[key]["wall_s"], "{:.0f}", "s",
                           le(60.0, "<= 60 s"), note=d[key]["summary"]))
    return out


def read_suite(d, _args):
    s = d["suite"]
    return [row("`make test`'s pytest runs (tests/unit, tests/integration, its serial tests)",
                "wall time of the whole suite", s["wall_s"],
                "{:.0f}", "s", le(480.0, "<= 8 min"), note=s["summary"].replace(" | ", "; "))]


def read_validate_real(d, _args):
    s = d["summary"]
    seeds = f"{d['seeds']} seed{'s' if d['seeds'] != 1 else ''}"
    case = f"{s['records']} CWRU drive-end records against the twin `{d['twin']}` ({seeds})"
    out = [row(case, f"records with the twin's {what} (DE)", s[f"{key}_fraction"], "{:.2f}", "",
               ge(0.8, ">= 0.80"), note=f"{s[f'{key}_met']} of {s[f'{key}_of']}")
           for key, what in (("rms", "RMS within a factor 2 of the measurement"),
                             ("line", "fault line's envelope level (2-4 kHz) within 10 dB"),
                             ("verdict", "textbook verdict the measurement's, the same miss included"))]
    h = s.get("healthy")
    if h:
        out.append(row(case, "the healthy record: RMS within a factor 2, no fault line above the floor, band shape "
                       "within 10 dB (all three)", 1.0 if h["all"] else 0.0, "{:.0f}", "", eq(1, "1 (all met)"),
                       note=f"RMS ratio {h['rms_ratio']:.2f}; strongest fault line "
                            f"{h['twin_strongest_fault_line_db']:.0f} dB; worst band "
                            f"{max(abs(v) for v in h['shape_diff_db']):.0f} dB"))
    out.append(row(case, "textbook verdict right (the record's kind), measured records", s["verdict_right_measured"],
                   "{:.0f}", f"of {s['records']}", note=f"twin: {s['verdict_right_twin']} of {s['records']}"))
    return out


def read_sim2real(d, _args):
    ev = d["evaluation"]
    models = ev["models"]
    first = next(iter(models))
    r = models[first]["measured"]
    case = f"classifier fitted on `{d['twin']}` alone ({d['runs']} runs), scored on {len(d['records'])} CWRU records"
    out = [row(case, f"accuracy over healthy / inner / ball / outer ({first})", r["accuracy"], "{:.2f}", "",
               ge(0.85, ">= 0.85 (chance 0.25)"), note=f"balanced {r['balanced']:.2f}")]
    for c, v in r["per_class"].items():
        out.append(row(case, f"accuracy on the {c} records", v, "{:.2f}", ""))
    for name, m in models.items():
        if name != first:
            out.append(row(case, f"accuracy ({name})", m["measured"]["accuracy"], "{:.2f}", "",
                           note=f"on the twin's held-out conditions {m['twin_cv']['accuracy']:.2f}"))
    v = ev["verdict"]["fixed"]
    out.append(row("textbook envelope verdict (2-4 kHz), no training", "right on the twin's runs at the records' "
                   "conditions (balanced over the classes)", v["twin_like_measured"]["balanced"], "{:.2f}", "",
                   note=f"on the measured records {v['measured']['balanced']:.2f}; a realistic twin is about as "
                        "hard as those"))
    return out
