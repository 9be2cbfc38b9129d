"""Regenerate BENCHMARKS.md: run each area's benchmark scripts with short settings, read their JSON, write the tables.

    .venv/bin/python bench/run_all.py                        # every default area (~7 min on 2 quiet cores, 10-20 busy)
    .venv/bin/python bench/run_all.py --areas core,synthesis # re-measure these areas, keep the others' records
    .venv/bin/python bench/run_all.py --list                 # the areas, their steps and commands
    .venv/bin/python bench/run_all.py --render               # rewrite BENCHMARKS.md from bench/records.json only
    .venv/bin/python bench/run_all.py --areas realism --data-dir DIR   # the twin against measured CWRU records
    make bench [AREAS=core,synthesis]

A *step* is one benchmark command (a script of ``bench/`` or a ``bkabem`` command) with the settings below, run as
its own process with ``OPENBLAS_NUM_THREADS=1``, ROS 2 on loopback and its output in ``bench/results/`` (the raw JSON
and the log of every step; not kept in git). Its JSON becomes rows (case, quantity, value, target) by the step's
reader in this file. The rows of every step, with the command, the machine (CPU model and cores from
/proc/cpuinfo), the load average, the date and the code's commit, are kept in ``bench/records.json`` (in git), so
that re-measuring some areas leaves the others' rows as they were. BENCHMARKS.md is
``bench/BENCHMARKS.template.md`` with each ``{{area:NAME}}`` replaced by that area's table.

A step that fails is recorded as failed (its rows are dropped, the table says so, the exit code is 1); the run
goes on with the next step. Targets are the ones the project's issues set; "met" compares the value with it.

The realism area needs measured records the project does not keep (CWRU's drive-end records as NumPy files):
``--data-dir DIR`` or ``$BKABEM_CWRU_DIR``; without one its steps are not run, and a measurement made before keeps
its rows.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
RECORDS = HERE / "records.json"
TEMPLATE = HERE / "BENCHMARKS.template.md"
OUTPUT = ROOT / "BENCHMARKS.md"
KINDS = ("healthy", "outer", "inner", "ball")


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
        out.append(row(case, "a new speed: `response` / `spectrum` (median of 200 speeds)", r["spectrum_ms"],
                       "{:.2f}", "ms", le(1.0, "<= 1 ms"), note=f"response {r['response_ms']:.2f} ms"))
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
    u = d.get("unit_tier")
    if u:
        out.append(row("`make unit` (the fast tier, pytest-xdist)", "wall time", u["wall_s"], "{:.0f}", "s",
                       le(60.0, "<= 60 s"), note=u["summary"]))
    return out


def read_suite(d, _args):
    s = d["suite"]
    return [row("`pytest` (tests/unit, then tests/integration)", "wall time of the whole suite", s["wall_s"],
                "{:.0f}", "s", le(480.0, "<= 8 min"), note=s["summary"])]


def read_validate_real(d, _args):
    s = d["summary"]
    case = f"{s['records']} CWRU drive-end records against the twin `{d['twin']}` ({d['seeds']} seed)"
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


# --------------------------------------------------------------------------- steps and areas
PY = "{python}"
BK = "{bkabem}"
DATA = "{data}"
#: The folder of measured CWRU records for the realism area (or ``--data-dir``); the project keeps no copy.
DATA_ENV = "BKABEM_CWRU_DIR"


@dataclass
class Step:
    """One benchmark command. ``argv`` items ``{python}``, ``{json}`` and ``{data}`` (the measured-data folder) are
    filled in; ``output`` says where its JSON comes from: "file" (the ``{json}`` path), "stdout" (the whole output)
    or "stdouts" (several commands). A step that ``needs_data`` runs only when a data folder is given."""

    name: str
    argv: list | list[list]
    read: Callable
    estimate_s: float
    output: str = "file"
    areas: tuple = ()
    needs_data: bool = False


STEPS = [
    Step("core", [PY, "bench/bench_core.py", "--repeats", "3", "--json", "{json}"], read_core, 15),
    Step("preparation", [PY, "bench/bench_preparation.py", "--repeat", "1", "--improved", "--json", "{json}"],
         read_preparation, 60),
    Step("tdsm", [PY, "bench/bench_tdsm.py", "--steps", "3000", "--repeats", "3", "--json", "{json}"], read_tdsm,
         50),
    Step("validate", [[BK, "validate", "--speed-hz", str(f), "--duration", "0.2", "--json"]
                      for f in (15, 30, 50)], read_validate, 50, output="stdouts"),
    Step("synth", [PY, "bench/bench_synth.py", "--seconds", "10", "--repeat", "3", "--json", "{json}"], read_synth,
         30),
    Step("faults", [PY, "bench/bench_faults.py", "--repeat", "3", "--seconds", "5", "--json", "{json}"],
         read_faults, 120),
    Step("dataset", [PY, "bench/bench_dataset.py", "--repeat", "3", "--runs", "5", "--seconds", "10", "--json",
                     "{json}"], read_dataset, 45),
    Step("floor", [PY, "bench/bench_floor.py", "--repeat", "7", "--machines", "12", "--json", "{json}"],
         read_floor, 10),
    Step("node", [PY, "bench/bench_node.py", "--seconds", "20", "--rates", "25600,51200", "--json", "{json}"],
         read_node, 70),
    Step("fleet", [PY, "bench/bench_fleet.py", "--machines", "32,100", "--variants", "after", "--repeats", "1",
                   "--seconds", "10", "--json", "{json}"], read_fleet, 150),
    Step("speed_jumps", [PY, "bench/bench_speed_jumps.py", "--repeats", "1", "--json", "{json}"], read_speed_jumps,
         45),
    Step("record", [PY, "bench/bench_record.py", "--seconds", "10", "--node-seconds", "10", "--repeats", "1",
                    "--json", "{json}"], read_record, 70),
    Step("rerun", [PY, "bench/bench_rerun.py", "--seconds", "10", "--repeats", "3", "--json", "{json}"], read_rerun,
         40),
    Step("model_switch", [PY, "bench/bench_model_switch.py", "--repeat", "1", "--json", "{json}"],
         read_model_switch, 25),
    Step("scenario", [PY, "bench/bench_scenario.py", "--repeat", "1", "--json", "{json}"], read_scenario, 30),
    Step("machine", [PY, "bench/bench_machine.py", "--repeat", "3", "--json", "{json}"], read_machine, 60),
    Step("startup", [PY, "bench/bench_startup.py", "--repeat", "5", "--unit-tier", "--json", "{json}"],
         read_startup, 120),
    Step("suite", [PY, "bench/bench_startup.py", "--repeat", "0", "--suite", "--json", "{json}"], read_suite, 900),
    Step("validate_real", [PY, "bench/validate_real.py", DATA, "--seeds", "1", "--out", "bench/results/realism",
                           "--json", "{json}"], read_validate_real, 60, needs_data=True),
    Step("sim2real", [PY, "bench/sim2real.py", DATA, "--seeds", "1", "--out", "bench/results/realism", "--json",
                      "{json}"], read_sim2real, 150, needs_data=True),
]

#: area -> (title, steps whose rows it shows, in this order). Areas marked optional run only when named.
AREAS = {
    "core": ("Core: preparation and spectrum speed", ["core"]),
    "excitation": ("Excitation and preparation per defect kind", ["preparation"]),
    "tdsm": ("TDSM and validation", ["tdsm", "validate"]),
    "synthesis": ("Synthesis per kind and channel count", ["synth", "faults", "dataset:synth"]),
    "dataset": ("Data-set path", ["dataset", "floor"]),
    "node": ("Node and fleet", ["node", "fleet", "speed_jumps"]),
    "recording": ("Recording and Rerun", ["record", "rerun"]),
    "switches": ("Model switches and scenarios", ["model_switch", "scenario"]),
    "machine": ("Any machine: catalogue machines in the compact form", ["machine"]),
    "startup": ("Start-up time and the fast test tier", ["startup"]),
    "realism": ("Realism: the twin against measured CWRU records (only with a data folder)",
                ["validate_real", "sim2real"]),
    "suite": ("The whole test suite (optional: only with --areas suite)", ["suite"]),
}
OPTIONAL = {"suite"}
READERS = {"dataset:synth": read_dataset_synth}


def step_by_name(name: str) -> Step:
    return next(s for s in STEPS if s.name == name)


def steps_of(areas) -> list[Step]:
    names = []
    for a in areas:
        for ref in AREAS[a][1]:
            n = ref.split(":")[0]
            if n not in names:
                names.append(n)
    return [s for s in STEPS if s.name in names]


# --------------------------------------------------------------------------- the machine
def machine() -> dict:
    info = {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
            "python": platform.python_version()}
    try:
        text = Path("/proc/cpuinfo").read_text()
        for line in text.splitlines():
            if line.startswith("model name"):
                info["cpu"] = line.split(":", 1)[1].strip()
                break
        flags = next((ln.split(":", 1)[1].split() for ln in text.splitlines() if ln.startswith("flags")), [])
        info["simd"] = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "SSE"
        mem = next(ln for ln in Path("/proc/meminfo").read_text().splitlines() if ln.startswith("MemTotal"))
        info["memory_gb"] = round(int(mem.split()[1]) / 2 ** 20)
    except (OSError, StopIteration):
        pass
    try:
        import numpy

        info["numpy"] = numpy.__version__
    except ImportError:
        pass
    return info


def commit() -> str:
    """The code's commit, ``-dirty`` if tracked files differ from it (the run's own outputs left aside)."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                             timeout=10).stdout.strip()
        changed = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".",
                                  ":!BENCHMARKS.md", ":!bench/records.json"], cwd=ROOT, capture_output=True,
                                 text=True, timeout=10).stdout.strip()
        return (rev or "unknown") + ("-dirty" if changed else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def shown_command(argv: list) -> str:
    """The command as a user types it from the repository (``.venv/bin/python``, ``F.json`` for the output)."""
    def one(a):
        parts = []
        for x in a:
            if x == PY:
                parts.append(".venv/bin/python")
            elif x == BK:
                parts.append(".venv/bin/bkabem")
            elif x == "{json}":
                parts.append("F.json")
            elif x == DATA:
                parts.append("DATA_DIR")
            else:
                parts.append(x)
        return shlex.join(parts)
    if argv and isinstance(argv[0], list):
        return "; ".join(one(a) for a in argv)
    return one(argv)


# --------------------------------------------------------------------------- running
def run_step(step: Step, bar, env: dict, data_dir: str | None = None) -> dict:
    """Run one step; returns its record (rows, command, machine, load, time, commit, or the error)."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "logs").mkdir(exist_ok=True)
    jpath = RESULTS / f"{step.name}.json"
    jpath.unlink(missing_ok=True)
    log = RESULTS / "logs" / f"{step.name}.log"
    cmds = step.argv if isinstance(step.argv[0], list) else [step.argv]
    rec = {"step": step.name, "command": shown_command(step.argv), "machine": machine(), "commit": commit(),
           "date": _dt.date.today().isoformat(), "load": [round(os.getloadavg()[0], 2)]}
    t_start = time.monotonic()
    done = 0.0
    outputs = []
    error = None
    with open(log, "w") as lf:
        for cmd in cmds:
            fill = {PY: sys.executable, BK: str(Path(sys.executable).parent / "bkabem"), "{json}": str(jpath),
                    DATA: str(data_dir)}
            argv = [fill.get(x, x) for x in cmd]
            lf.write(f"$ {shlex.join(argv)}\n")
            lf.flush()
            out = tempfile.TemporaryFile(mode="w+")
            p = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=out if step.output != "file" else lf,
                                 stderr=lf, text=True)
            while p.poll() is None:
                time.sleep(0.5)
                elapsed = time.monotonic() - t_start
                want = min(elapsed, step.estimate_s * 0.98)
                if want > done:
                    bar.update(want - done)
                    done = want
            if step.output != "file":
                out.seek(0)
                text = out.read()
                lf.write(text)
                outputs.append(text)
            out.close()
            if p.returncode != 0:
                error = f"exit {p.returncode}"
                break
    bar.update(step.estimate_s - done)
    rec["duration_s"] = round(time.monotonic() - t_start, 1)
    rec["load"].append(round(os.getloadavg()[0], 2))
    if error is None:
        try:
            if step.output == "file":
                data = json.loads(jpath.read_text())
            else:
                data = [json.loads(t) for t in outputs]
                if step.output == "stdout":
                    data = data[0]
                jpath.write_text(json.dumps(data, indent=1))
            rec["data_file"] = str(jpath.relative_to(ROOT))
            rec["rows"] = {}
            for area, (_title, refs) in AREAS.items():
                for ref in refs:
                    if ref.split(":")[0] == step.name:
                        rec["rows"][ref] = READERS.get(ref, step.read)(data, None)
        except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError, StopIteration) as exc:
            error = f"its output could not be read: {type(exc).__name__}: {exc}"
    if error is not None:
        tail = [ln for ln in log.read_text(errors="replace").splitlines() if ln.strip()][-3:]
        rec["error"] = error + (f"; last lines of {log.relative_to(ROOT)}: " + " | ".join(t[:200] for t in tail)
                                if tail else "")
        rec.pop("rows", None)
    return rec


def environment() -> dict:
    env = dict(os.environ)
    env.update({"OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                "ROS_LOG_DIR": tempfile.mkdtemp(prefix="bkabem_bench_ros_log_")})
    env.pop("PYTHONPATH", None)
    return env


# --------------------------------------------------------------------------- rendering
def render_area(area: str, records: dict) -> str:
    title, refs = AREAS[area]
    rows, notes, tags = [], [], {}
    for ref in refs:
        name = ref.split(":")[0]
        rec = records.get(name)
        if rec is None:
            notes.append(f"- `{name}`: not measured yet (`.venv/bin/python bench/run_all.py --areas {area}`).")
            continue
        tag = tags.setdefault(name, f"[{len(tags) + 1}]")
        if "error" in rec:
            rows.append({"case": f"step `{name}`", "quantity": "failed", "value": None, "fmt": "", "note": rec["error"],
                         "by": tag})
        elif "not_run" in rec:
            rows.append({"case": f"step `{name}`", "quantity": rec["not_run"], "value": None, "fmt": "", "by": tag})
        else:
            rows += [dict(r, by=tag) for r in rec["rows"].get(ref, [])]
    for name, tag in tags.items():
        rec = records[name]
        if "not_run" in rec:
            notes.append(f"- {tag} `{rec['command']}`: {rec['not_run']}")
            continue
        m = rec["machine"]
        mach = f"{m.get('cpu')}, {m.get('cores')} cores" + (f" ({m['simd']})" if m.get("simd") else "") + \
               (f", {m['memory_gb']} GB" if m.get("memory_gb") else "")
        soft = f"Python {m.get('python')}" + (f", numpy {m['numpy']}" if m.get("numpy") else "")
        notes.append(f"- {tag} `{rec['command']}` — {mach}; {soft}; load average {rec['load'][0]:.1f} → "
                     f"{rec['load'][-1]:.1f}; {rec['date']}, code {rec['commit']}, {rec['duration_s']:.0f} s")
    out = ["| case | quantity | value | target | met | by |", "|---|---|---|---|---|---|"]
    for r in rows:
        met = {True: "yes", False: "**no**", None: ""}[r.get("met")] if "target" in r else ""
        out.append(f"| {r['case']} | {r['quantity']} | {shown(r)} | {r.get('target', '')} | {met} | {r['by']} |")
    return "\n".join(out) + "\n\n" + "\n".join(notes)


def render(records: dict) -> str:
    text = TEMPLATE.read_text()
    for area in AREAS:
        key = "{{area:%s}}" % area
        if key in text:
            text = text.replace(key, render_area(area, records))
    return text


def load_records() -> dict:
    return json.loads(RECORDS.read_text()) if RECORDS.exists() else {}


def save_records(records: dict) -> None:
    RECORDS.write_text(json.dumps({k: records[k] for k in sorted(records)}, indent=1, ensure_ascii=False) + "\n")


# --------------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--areas", default=None,
                    help=f"comma-separated areas to measure (default: all but {', '.join(sorted(OPTIONAL))}); "
                         f"one of {', '.join(AREAS)}")
    ap.add_argument("--list", action="store_true", help="list the areas, steps and commands, and stop")
    ap.add_argument("--render", action="store_true", help="only rewrite BENCHMARKS.md from bench/records.json")
    ap.add_argument("--data-dir", default=os.environ.get(DATA_ENV) or None,
                    help=f"folder of measured CWRU records for the realism area (default: ${DATA_ENV}); without "
                         "one its steps are not run")
    args = ap.parse_args(argv)
    if args.data_dir and not Path(args.data_dir).is_dir():
        print(f"run_all: --data-dir: {args.data_dir}: not a folder", file=sys.stderr)
        return 2
    areas = [a for a in AREAS if a not in OPTIONAL] if args.areas is None else \
        [a.strip() for a in args.areas.split(",") if a.strip()]
    unknown = [a for a in areas if a not in AREAS]
    if unknown:
        print(f"run_all: --areas: unknown area {unknown[0]!r}; the areas are {', '.join(AREAS)}", file=sys.stderr)
        return 2
    steps = steps_of(areas)
    if args.list:
        for a, (title, refs) in AREAS.items():
            print(f"{a:11s} {title}" + ("  [optional]" if a in OPTIONAL else ""))
            for ref in refs:
                s = step_by_name(ref.split(":")[0])
                print(f"    {s.name:13s} ~{s.estimate_s:4.0f} s  {shown_command(s.argv)}")
        return 0
    records = load_records()
    failed = []
    if not args.render:
        from tqdm import tqdm

        if not args.data_dir:
            for s in [s for s in steps if s.needs_data]:
                steps.remove(s)
                if s.name not in records or "not_run" in records[s.name]:   # a measurement made before stays
                    records[s.name] = {"step": s.name, "command": shown_command(s.argv),
                                       "not_run": f"not run: no data folder (--data-dir or ${DATA_ENV})"}
                print(f"{s.name}: not run: no data folder (--data-dir or ${DATA_ENV})")
        total = sum(s.estimate_s for s in steps)
        print(f"bench/run_all.py: {len(steps)} steps of {', '.join(areas)}, about {total / 60:.0f} min on 2 cores; "
              f"logs and raw JSON in {RESULTS.relative_to(ROOT)}/", flush=True)
        env = environment()
        with tqdm(total=total, unit="s", bar_format="{desc:<13} {percentage:3.0f}%|{bar}| {elapsed} < ~{remaining}",
                  dynamic_ncols=True) as bar:
            for s in steps:
                bar.set_description_str(s.name)
                rec = run_step(s, bar, env, args.data_dir)
                records[s.name] = rec
                save_records(records)                 # a step's record is kept even if a later one hangs
                if "error" in rec:
                    failed.append(s.name)
                    tqdm.write(f"{s.name}: FAILED: {rec['error']}")
                else:
                    tqdm.write(f"{s.name}: {sum(len(r) for r in rec['rows'].values())} rows in "
                               f"{rec['duration_s']:.0f} s")
    OUTPUT.write_text(render(records))
    print(f"wrote {OUTPUT.relative_to(ROOT)}" + (f"; failed steps: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
