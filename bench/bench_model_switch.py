"""Model switches on the node's path: what the chunk at a switch costs against an ordinary chunk.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_model_switch.py --repeat 3 [--json FILE]

Per pair of the fault library's cases (``motor_6010_healthy -> motor_6010_inner``, ``inner -> ball``, ``outer ->
inner``): a :class:`bkabem_ros.node.source.MachineSource` as the node makes it (25.6 kHz, the node's default chunk
of 0.1 s = 2560 samples, 8 channels, ``spectrum="exact"``, taper, no features, the case's broadband floor) streams
the first case at 25 Hz, one chunk per ``--period`` (the node's timer: 0.1 s); then ``set_case`` asks for the
second, which the real helper process makes (a fresh helper per run, so the model comes pickled as in the node),
and the stream goes on until the switch and ``--after`` chunks beyond. Timed per chunk: ``MachineSource.next_chunk``
(the scenario driver, the model hand-over, ``set_model`` and the synthesis; not the messages), in ms:

ordinary       median chunk of the first case before the request, and of the second case after the switch
while waiting  the worst chunk between the request and the switch (the helper, and the warm-up thread, running)
while warming  the worst chunk while the warm-up thread ran (new code only)
switch         the chunk at which the second case comes into the signal
ratio          switch / the larger ordinary median
warm           the warm-up in the node's warm thread (unpickling included), s: the work that left the switch chunk

``BKABEM_BENCH_ROOT=/path/to/a/checkout`` runs another checkout's code (e.g. main's, for the numbers before a change)
with this script. Prints one JSON line per run and a summary table (medians over ``--repeat``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(os.environ.get("BKABEM_BENCH_ROOT") or Path(__file__).resolve().parents[1]).resolve()
sys.path.insert(0, str(ROOT))
os.environ["PYTHONPATH"] = str(ROOT) + (os.pathsep + os.environ["PYTHONPATH"] if os.environ.get("PYTHONPATH") else "")

from bkabem_core.model.case import Case  # noqa: E402
from bkabem_core.scenario.models import ModelHelper  # noqa: E402
from bkabem_ros.node.source import MachineSource  # noqa: E402

PAIRS = (("healthy", "inner"), ("inner", "ball"), ("outer", "inner"))
FS = 25600.0
SPEED_HZ = 25.0


def run_pair(src: str, dst: str, period_s: float, before: int, after: int, timeout_s: float) -> dict:
    ModelHelper.shared().close()                 # a fresh helper: the model comes pickled, as in a node
    n = int(round(FS * 0.1))
    source = MachineSource(Case.load(f"motor_6010_{src}"), sample_rate_hz=FS, samples_per_chunk=n, seed=0, slip=0.0,
                           machine_id="bench", frames={"de": "de_link", "nde": "nde_link"})
    times, warming, index = [], [], 0
    t_next = time.perf_counter()

    def busy() -> bool:
        """Whether the node's warm thread is warming the coming model (new code only)."""
        d = source._next if source._next is not None else source.driver
        return bool(getattr(d.models, "_warming", None))

    def step():
        nonlocal index, t_next
        t_next += period_s
        pause = t_next - time.perf_counter()
        if pause > 0:
            time.sleep(pause)
        else:
            t_next = time.perf_counter()
        w = busy()
        t0 = time.perf_counter()
        source.next_chunk(index, SPEED_HZ)
        times.append(time.perf_counter() - t0)
        warming.append(w or busy())
        index += n

    for _ in range(before):
        step()
    i_request = len(times)
    source.set_case(Case.load(f"motor_6010_{dst}"), index, f"bench {src} -> {dst}")
    t_request = time.perf_counter()
    while source.switches == 0:
        if time.perf_counter() - t_request > timeout_s:
            raise SystemExit(f"{src} -> {dst}: no switch within {timeout_s:g} s")
        step()
    i_switch = len(times) - 1
    wait_s = time.perf_counter() - t_request
    for _ in range(after):
        step()
    warm_s = getattr(source.driver.models, "warm_times_s", {}).get(source.case.case_hash)   # (None before warming)
    ms = [1e3 * t for t in times]
    ord_a = statistics.median(ms[2:i_request])               # (the first chunks make the first knots)
    ord_b = statistics.median(ms[i_switch + 2:])
    waiting = ms[i_request:i_switch]
    during_warm = [t for t, w in zip(ms[i_request:i_switch], warming[i_request:i_switch]) if w]
    return {"pair": f"{src}->{dst}", "ordinary_a_ms": ord_a, "ordinary_b_ms": ord_b,
            "waiting_max_ms": max(waiting) if waiting else 0.0,
            "waiting_median_ms": statistics.median(waiting) if waiting else 0.0,
            "warming_max_ms": max(during_warm) if during_warm else None, "chunks_warming": len(during_warm),
            "switch_ms": ms[i_switch], "after_switch_ms": ms[i_switch + 1],
            "ratio": ms[i_switch] / max(ord_a, ord_b), "chunks_waiting": len(waiting), "wait_s": wait_s,
            "warm_s": warm_s,
            "root": str(ROOT)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--period", type=float, default=0.1, help="seconds between chunks (the node's timer)")
    ap.add_argument("--before", type=int, default=12, help="chunks before the request")
    ap.add_argument("--after", type=int, default=12, help="chunks after the switch")
    ap.add_argument("--timeout", type=float, default=120.0, help="longest wait for a model [s]")
    ap.add_argument("--pairs", default=",".join(f"{a}-{b}" for a, b in PAIRS),
                    help="comma-separated src-dst pairs of motor_6010_* cases")
    ap.add_argument("--json", default=None, help="also write every run's row here")
    args = ap.parse_args()
    pairs = [tuple(p.split("-")) for p in args.pairs.split(",") if p]
    rows = []
    for _ in range(args.repeat):
        for src, dst in pairs:
            row = run_pair(src, dst, args.period, args.before, args.after, args.timeout)
            print(json.dumps(row), flush=True)
            rows.append(row)
    ModelHelper.shared().close()
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    print(f"\n{ROOT}  load {os.getloadavg()[0]:.2f}  (medians of {args.repeat})")
    print(f"{'pair':16s} {'ord A':>8s} {'ord B':>8s} {'wait max':>9s} {'switch':>8s} {'next':>7s} {'ratio':>7s} "
          f"{'warm':>6s} {'warming max':>11s}")
    for src, dst in pairs:
        rs = [r for r in rows if r["pair"] == f"{src}->{dst}"]

        def med(k):
            return statistics.median(r[k] for r in rs)
        ws = [r["warm_s"] for r in rs if r["warm_s"] is not None]
        warm = f"{statistics.median(ws):.3f}" if ws else "-"
        wm = [r["warming_max_ms"] for r in rs if r["warming_max_ms"] is not None]
        warming = f"{max(wm):.1f}" if wm else "-"
        print(f"{src + '->' + dst:16s} {med('ordinary_a_ms'):8.3f} {med('ordinary_b_ms'):8.3f} "
              f"{med('waiting_max_ms'):9.3f} {med('switch_ms'):8.3f} {med('after_switch_ms'):7.3f} "
              f"{med('ratio'):7.2f} {warm:>6s} {warming:>11s}  (switch max {max(r['switch_ms'] for r in rs):.3f} ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
