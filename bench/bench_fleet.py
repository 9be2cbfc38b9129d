"""Fleet capacity of one host: machines -> CPU -> publish lateness, this checkout and others, in one run.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_fleet.py --machines 16,32,48,64,100,128 --repeats 3 \\
        --seconds 15 --baseline DIR [--variants before,after] [--monitor] [--json F] [--png F]

Each run: ``bkabem fleet --machines N --processes 2 --seconds 100000 --ros-args -r speed:=/bench/speed`` (25.6 kHz,
8 channels per machine: DE/NDE x acceleration/displacement x vertical/horizontal, 0.1 s chunks, default
``sensor_data`` QoS) with every machine at 25 Hz from one ``bkabem speed --namespace /bench --rate 2`` (all speed
topics remapped onto one). When every machine logged "streaming from t0", 2 s more, then the CPU of the fleet's
processes is read from /proc over ``--seconds`` (split per thread: the Python thread that runs the executor and the
Fast DDS threads), then SIGINT; the machines' exit statistics (``FLEETSTATS``) give the publish lateness of every
chunk of the whole run (start included): time the chunk's four waveform messages were handed to DDS minus the time
its last sample was due. "on time" = max lateness of every machine < one chunk period (100 ms).

Variants: ``before`` = the fleet of the checkout ``--baseline DIR`` (run with ``PYTHONPATH=DIR``; copy the built
``bkabem_core/*.so`` there), ``mid`` = likewise the checkout ``--mid DIR``, ``after`` = this checkout, ``after-single`` = this checkout with ``--executor single``; a ``-rt`` suffix (``before-rt``, ``after-rt``) runs the
fleet under ``chrt -f 10`` (SCHED_FIFO priority 10, as a dedicated streaming host would: other load on the
machine then delays it less).
A size that does not start within 300 s (a saturated host) is recorded as not on time and the run goes on.
Runs are interleaved (repeat, N, variant) so that the machine's other load hits all variants alike; the load
average is recorded per run. ``--monitor`` adds one subscriber process on the same host that reads every waveform
stream (``tests/integration/fleet_monitor.py``, reliable) and reports gaps; its CPU is counted separately.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_node import CLK_TCK, REPO, Proc, bkabem, ros_env, tree_pids  # noqa: E402

CHUNK_MS = 100.0


def thread_cpu(pids) -> dict:
    """CPU seconds per thread class over the processes: 'python' (each process's main thread: the interpreter
    running the executor, callbacks, synthesis, message building, rclpy publish down into Fast DDS's write),
    'dds' (threads Fast DDS names dds.*: receive, events, shared memory) and 'other' (the EventsExecutor's timer
    thread, rcl logging ...)."""
    out = {"python": 0.0, "dds": 0.0, "other": 0.0}
    for p in pids:
        try:
            tasks = os.listdir(f"/proc/{p}/task")
        except OSError:
            continue
        for t in tasks:
            try:
                with open(f"/proc/{p}/task/{t}/stat") as fh:
                    raw = fh.read()
            except OSError:
                continue
            comm = raw[raw.index("(") + 1:raw.rindex(")")]
            f = raw.rsplit(")", 1)[1].split()
            sec = (int(f[11]) + int(f[12])) / CLK_TCK
            key = "dds" if comm.startswith("dds.") else ("python" if t == str(p) else "other")
            out[key] += sec
    return out


def loopback_bytes() -> int:
    """Bytes received on the loopback interface so far (/proc/net/dev): what the fleet's data costs on UDP; data
    that Fast DDS moves through shared memory does not show here."""
    with open("/proc/net/dev") as fh:
        for ln in fh:
            name, _, rest = ln.partition(":")
            if name.strip() == "lo":
                return int(rest.split()[0])
    return 0


def one_run(n: int, variant: str, seconds: float, baseline: str | None, monitor: bool, mid: str | None = None) -> dict:
    env = ros_env()
    prefix = ["chrt", "-f", "10"] if variant.endswith("-rt") else []
    variant_code = variant[:-3] if variant.endswith("-rt") else variant
    env.pop("PYTHONUNBUFFERED")   # the baseline writes FLEETSTATS with sys.stdout.write: unbuffered, two workers' lines
    #                               could interleave mid-line; block-buffered + its flush() is one write per line
    cwd = str(REPO)
    extra = []
    if variant_code in ("before", "mid"):
        env["PYTHONPATH"] = cwd = baseline if variant_code == "before" else mid
    elif variant_code == "after-single":
        extra = ["--executor", "single"]
    speed = Proc(bkabem("speed", "--namespace", "/bench", "--profile", "constant:25", "--rate", "2"), ros_env_copy(env))
    if monitor:
        extra += ["--qos", "reliable"]
    fleet = subprocess.Popen(prefix + bkabem("fleet", "--machines", str(n), "--processes", "2", "--prefix", "bm_",
                                    "--seconds", "100000", *extra, "--ros-args", "-r", "speed:=/bench/speed"),
                             env=env, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    lines: list[str] = []
    import threading

    th = threading.Thread(target=lambda: [lines.append(ln.rstrip("\n")) for ln in fleet.stdout], daemon=True)
    th.start()
    t_start = time.monotonic()
    while sum("streaming from t0" in ln for ln in list(lines)) < n:
        if fleet.poll() is not None or time.monotonic() - t_start > 300:
            raise RuntimeError(f"fleet of {n} did not start:\n" + "\n".join(lines[-20:]))
        time.sleep(0.2)
    startup_s = time.monotonic() - t_start
    mon = None
    if monitor:
        names = ",".join(f"bm_{i:0{max(2, len(str(n - 1)))}d}" for i in range(n))
        mon = subprocess.Popen([sys.executable, str(REPO / "tests" / "integration" / "fleet_monitor.py"), "--machines", names,
                                "--seconds", str(seconds + 4), "--settle", "2"], env=env, cwd=str(REPO),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(4.0)
    else:
        time.sleep(2.0)
    pids = tree_pids(fleet.pid)
    c0, m0, w0 = thread_cpu(pids), thread_cpu([mon.pid]) if mon else None, time.monotonic()
    lo0 = loopback_bytes()
    load0 = os.getloadavg()[0]
    time.sleep(seconds)
    c1, m1, w1 = thread_cpu(tree_pids(fleet.pid)), thread_cpu([mon.pid]) if mon else None, time.monotonic()
    lo_rate = (loopback_bytes() - lo0) / (w1 - w0)
    mon_out = None
    if mon is not None:
        out, err = mon.communicate(timeout=120)
        mon_out = json.loads(out.strip().splitlines()[-1]) if out.strip() else {"error": err[-500:]}
    fleet.send_signal(signal.SIGINT)
    fleet.wait(120)
    th.join(5)
    speed.stop()
    # a statistics line is one write, but rcl's "Failed to publish log message to rosout: " (stderr, no newline,
    # merged into the same pipe) can stand in front of it: take the JSON after the marker wherever it starts
    stats = [json.loads(ln[ln.index("FLEETSTATS {") + len("FLEETSTATS "):]) for ln in lines if "FLEETSTATS {" in ln]
    if len(stats) != n:
        res_lost = [ln[:200] for ln in lines if "FLEETSTATS" in ln and "FLEETSTATS {" not in ln]
        print(f"warning: {len(stats)} of {n} statistics lines read; cut lines: {res_lost[:3]}; fleet exit "
              f"{fleet.returncode}; last lines:\n" + "\n".join(ln[:200] for ln in lines[-15:]), file=sys.stderr)
    wall = w1 - w0
    cpu = {k: round(100 * (c1[k] - c0[k]) / wall, 1) for k in c0}
    res = {"variant": variant, "machines": n, "reported": len(stats), "startup_s": round(startup_s, 1),
           "cpu_pct_of_one_core": round(sum(cpu.values()), 1), "cpu_split_pct": cpu,
           "load_average_1min": round((load0 + os.getloadavg()[0]) / 2, 2),
           "loopback_MB_per_s": round(lo_rate / 1e6, 2)}
    if stats:
        res.update({
            "lateness_ms_p50_median": round(statistics.median(s["lateness_ms_p50"] for s in stats), 2),
            "lateness_ms_p99_worst": round(max(s["lateness_ms_p99"] for s in stats), 1),
            "lateness_ms_max_worst": round(max(s["lateness_ms_max"] for s in stats), 1),
            "chunks": sum(s["chunks"] for s in stats), "reanchors": sum(s["reanchors"] for s in stats),
            "late_chunks": sum(s.get("late_chunks", 0) for s in stats),
            # chunk number (0 = first) of the worst chunk of the worst machine: start-up or steady state
            "worst_chunk": max(stats, key=lambda s: s["lateness_ms_max"]).get("lateness_max_chunk"),
            "speed_ok": all(s["speed_messages"] > 0 for s in stats)})
        res["on_time"] = (len(stats) == n and res["lateness_ms_max_worst"] < CHUNK_MS and res["reanchors"] == 0)
    else:
        res["on_time"] = False
    if mon_out is not None:
        st = mon_out.get("streams", {})
        res["monitor"] = {"cpu_pct": round(100 * sum(m1[k] - m0[k] for k in m0) / wall, 1),
                          "streams": len(st), "missing": len(mon_out.get("missing_topics", [])),
                          "gaps": sum(s["gaps"] for s in st.values()), "received": mon_out.get("received"),
                          "error": mon_out.get("error")}
    return res


def ros_env_copy(env: dict) -> dict:
    e = dict(env)
    e.pop("PYTHONPATH", None)
    return e


def med_split(rs: list[dict], key: str):
    vals = [r["cpu_split_pct"][key] for r in rs if r["cpu_split_pct"].get(key) is not None]
    return round(statistics.median(vals), 1) if vals else None


def summarize(rows: list[dict]) -> list[dict]:
    out = []
    keys = sorted({(r["variant"], r["machines"]) for r in rows}, key=lambda k: (k[0], k[1]))
    for v, n in keys:
        rs = [r for r in rows if r["variant"] == v and r["machines"] == n]

        def med(key):
            vals = [r[key] for r in rs if r.get(key) is not None]
            return round(statistics.median(vals), 2) if vals else None

        out.append({"variant": v, "machines": n, "runs": len(rs), "cpu_pct_median": med("cpu_pct_of_one_core"),
                    "cpu_python_pct_median": med_split(rs, "python"), "cpu_dds_pct_median": med_split(rs, "dds"),
                    "lateness_p50_median": med("lateness_ms_p50_median"),
                    "lateness_p99_worst_median": med("lateness_ms_p99_worst"),
                    "lateness_max_worst_median": med("lateness_ms_max_worst"),
                    "lateness_max_worst_all": max((r.get("lateness_ms_max_worst") or float("inf")) for r in rs),
                    "on_time_runs": sum(bool(r["on_time"]) for r in rs),
                    "load_median": med("load_average_1min")})
    return out


def markdown(summary: list[dict]) -> str:
    """The summary as a Markdown table (one row per variant and size)."""
    def f(v, nd=1):
        return "–" if v is None else f"{v:.{nd}f}"

    out = ["| variant | machines | runs | CPU, % of one core (Python thread / Fast DDS) | lateness p50 / p99 worst / "
           "max worst [ms] (median of runs) | max of all runs [ms] | on time | load (1 min) |",
           "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for s in sorted(summary, key=lambda s: (s["machines"], s["variant"])):
        out.append(f"| {s['variant']} | {s['machines']} | {s['runs']} | {f(s['cpu_pct_median'])} "
                   f"({f(s['cpu_python_pct_median'])} / {f(s['cpu_dds_pct_median'])}) | "
                   f"{f(s['lateness_p50_median'], 2)} / {f(s['lateness_p99_worst_median'])} / "
                   f"{f(s['lateness_max_worst_median'])} | {f(s['lateness_max_worst_all'])} | "
                   f"{s['on_time_runs']} of {s['runs']} | {f(s['load_median'], 1)} |")
    return "\n".join(out)


def plot(summary: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    styles = {"before": ("tab:red", "o", "--baseline checkout"),
              "mid": ("tab:orange", "^", "--mid checkout"),
              "after": ("tab:blue", "s", "this checkout"),
              "after-single": ("tab:gray", "^", "this checkout, --executor single"),
              "before-rt": ("salmon", "v", "--baseline checkout, chrt -f 10"),
              "mid-rt": ("gold", "<", "--mid checkout, chrt -f 10"),
              "after-rt": ("tab:cyan", "D", "this checkout, chrt -f 10")}
    for v, (c, mk, label) in styles.items():
        rs = sorted((s for s in summary if s["variant"] == v), key=lambda s: s["machines"])
        if not rs:
            continue
        x = [s["machines"] for s in rs]
        a1.plot(x, [s["cpu_pct_median"] for s in rs], marker=mk, color=c, label=label)
        a2.plot(x, [s["lateness_max_worst_median"] for s in rs], marker=mk, color=c, label=label)
        a2.plot(x, [s["lateness_p99_worst_median"] for s in rs], marker=mk, color=c, ls=":", alpha=0.7)
    a1.axhline(200, color="k", lw=0.8, ls="--")
    a1.text(0.98, 200, "2 cores", fontsize=8, ha="right", va="bottom", transform=a1.get_yaxis_transform())
    a1.set_xlabel("machines on one host (25.6 kHz x 8 channels, 0.1 s chunks)")
    a1.set_ylabel("CPU of the fleet [% of one core]")
    a1.set_title("CPU (median of runs)")
    a2.axhline(CHUNK_MS, color="k", lw=0.8, ls="--")
    a2.text(2, CHUNK_MS * 1.1, "one chunk period: later = not on time", fontsize=8)
    a2.set_yscale("log")
    a2.set_xlabel("machines on one host")
    a2.set_ylabel("publish lateness of the worst machine [ms]")
    a2.set_title("max (solid) and p99 (dotted), median of runs")
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.set_xlim(left=0)
    a1.set_ylim(0, 215)
    a1.legend(fontsize=7, loc="center left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machines", default="16,32,48,64,100,128")
    ap.add_argument("--variants", default="before,after")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--baseline", default=None, help="checkout of the previous main (variant 'before')")
    ap.add_argument("--mid", default=None, help="another checkout (variant 'mid', e.g. the branch before a change)")
    ap.add_argument("--monitor", action="store_true", help="one subscriber reading every stream on this host")
    ap.add_argument("--json", default=None)
    ap.add_argument("--png", default=None)
    ap.add_argument("--from-json", default=None, help="only summarise/plot the rows of earlier --json files "
                                                      "(comma list)")
    ap.add_argument("--markdown", action="store_true", help="print the summary as a Markdown table")
    args = ap.parse_args()
    if args.from_json:
        rows = [r for f in args.from_json.split(",") for r in json.loads(Path(f).read_text())["runs"]]
    else:
        variants = [v for v in args.variants.split(",") if v]
        if any(v.startswith("before") for v in variants) and not args.baseline:
            ap.error("variant 'before' needs --baseline DIR")
        if any(v.startswith("mid") for v in variants) and not args.mid:
            ap.error("variant 'mid' needs --mid DIR")
        rows = []
        for r in range(args.repeats):
            for n in [int(x) for x in args.machines.split(",") if x]:
                for v in variants:
                    try:
                        res = one_run(n, v, args.seconds, args.baseline, args.monitor, args.mid)
                    except RuntimeError as exc:      # did not start (saturated host): a failed size, not a crash
                        print(f"warning: {v} with {n} machines: {exc}", file=sys.stderr, flush=True)
                        res = {"variant": v, "machines": n, "reported": 0, "on_time": False, "error": str(exc)[:300],
                               "cpu_pct_of_one_core": None, "cpu_split_pct": {"python": None, "dds": None},
                               "load_average_1min": round(os.getloadavg()[0], 2)}
                    res["repeat"] = r
                    rows.append(res)
                    print(json.dumps(res), flush=True)
                    if args.json:
                        Path(args.json).write_text(json.dumps({"runs": rows, "summary": summarize(rows)}, indent=1))
    summary = summarize(rows)
    for s in summary:
        print("SUMMARY " + json.dumps(s), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"runs": rows, "summary": summary}, indent=1))
    if args.markdown:
        print(markdown(summary))
    if args.png:
        plot(summary, args.png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
