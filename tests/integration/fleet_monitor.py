"""A monitoring subscriber for fleet tests and benchmarks: every waveform stream of every machine, checked gap-free.

    python tests/integration/fleet_monitor.py --machines machine_00,machine_01,... [--discover] --seconds S [--settle S]
        [--qos reliable|sensor_data] [--executor events|single]

Subscribes to the four waveform topics (``/<machine>/vibration/{de,nde}/{acceleration,displacement}``) of each
machine named, as a monitoring pipeline would (its own code here, not bkabem's: the test must not check the
fleet with the fleet's own helpers). With ``--discover`` it first waits until the graph shows all those topics
with type ``bkabem_msgs/msg/VibrationWaveform`` (under a Fast DDS discovery server that needs
``ROS_SUPER_CLIENT=TRUE``: a plain client only learns the endpoints it matches) and prints how long that took.

For each stream it keeps ``first_sample_index`` and ``samples_per_channel`` of every message received after
the settle time (first ``--settle`` s after the subscriptions matched are not judged: a volatile subscriber
joins a stream mid-way) and prints one JSON object on the last line:

- ``streams``: per topic ``count``, ``first``, ``last``, ``gaps`` (missing chunks between consecutive messages),
  ``repeats`` (an index seen again or going back), ``machine_ids`` (the ``machine_id`` fields seen);
- ``missing_topics``: topics that never delivered a message; ``discovered_s``: graph discovery time or null;
- ``received``: messages in total; ``seconds``: the judged window.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time


def waveform_topics(machine: str) -> list[str]:
    return [f"/{machine}/vibration/{b}/{q}" for b in ("de", "nde") for q in ("acceleration", "displacement")]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machines", required=True, help="comma list of machine names (namespaces without '/')")
    ap.add_argument("--seconds", type=float, required=True, help="judged window after the settle time")
    ap.add_argument("--settle", type=float, default=2.0)
    ap.add_argument("--discover", action="store_true", help="wait for the topics on the graph first")
    ap.add_argument("--discover-timeout", type=float, default=60.0)
    ap.add_argument("--qos", choices=("reliable", "sensor_data"), default="reliable")
    ap.add_argument("--executor", choices=("events", "single"), default="events")
    args = ap.parse_args(argv)

    import rclpy
    from bkabem_msgs.msg import VibrationWaveform
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import deserialize_message

    machines = [m for m in args.machines.split(",") if m]
    topics = [t for m in machines for t in waveform_topics(m)]
    rclpy.init()
    node = rclpy.create_node("fleet_monitor")
    discovered_s = None
    t0 = time.monotonic()
    if args.discover:
        want = set(topics)
        while True:
            have = {name for name, types in node.get_topic_names_and_types()
                    if "bkabem_msgs/msg/VibrationWaveform" in types}
            if want <= have:
                discovered_s = time.monotonic() - t0
                break
            if time.monotonic() - t0 > args.discover_timeout:
                print(json.dumps({"error": "discovery timeout", "missing": sorted(want - have)[:20],
                                  "seen": len(want & have)}))
                return 1
            time.sleep(0.1)
    rel = ReliabilityPolicy.RELIABLE if args.qos == "reliable" else ReliabilityPolicy.BEST_EFFORT
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=rel)
    lock = threading.Lock()
    judging = {"on": False}
    recs: dict[str, list] = {t: [] for t in topics}
    ids: dict[str, set] = {t: set() for t in topics}
    received = [0]

    def make_cb(topic):
        def cb(raw):
            msg = deserialize_message(raw, VibrationWaveform)
            with lock:
                received[0] += 1
                if judging["on"]:
                    recs[topic].append((int(msg.first_sample_index), int(msg.samples_per_channel)))
                    ids[topic].add(msg.machine_id)
        return cb

    subs = [node.create_subscription(VibrationWaveform, t, make_cb(t), qos, raw=True) for t in topics]
    if args.executor == "events":
        from rclpy.experimental import EventsExecutor

        ex = EventsExecutor()
    else:
        ex = SingleThreadedExecutor()
    ex.add_node(node)
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            ex.spin_once(timeout_sec=0.1)

    th = threading.Thread(target=spin, daemon=True)
    th.start()
    t_match = time.monotonic()
    while any(node.count_publishers(t) == 0 for t in topics) and time.monotonic() - t_match < args.discover_timeout:
        time.sleep(0.05)
    time.sleep(args.settle)
    with lock:
        judging["on"] = True
    t_judge = time.monotonic()
    time.sleep(args.seconds)
    with lock:
        judging["on"] = False
    window = time.monotonic() - t_judge
    stop.set()
    th.join(5)
    streams = {}
    for t in topics:
        r = recs[t]
        gaps = repeats = 0
        for (i0, n0), (i1, _n1) in zip(r, r[1:]):
            if i1 <= i0:
                repeats += 1
            elif i1 != i0 + n0:
                gaps += (i1 - i0) // max(n0, 1) - 1
        streams[t] = {"count": len(r), "first": r[0][0] if r else None, "last": r[-1][0] if r else None,
                      "gaps": gaps, "repeats": repeats, "machine_ids": sorted(ids[t])}
    out = {"streams": streams, "missing_topics": [t for t in topics if not recs[t]], "discovered_s": discovered_s,
           "received": received[0], "seconds": round(window, 3), "subscriptions": len(subs)}
    for s in subs:
        node.destroy_subscription(s)
    ex.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    print(json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
