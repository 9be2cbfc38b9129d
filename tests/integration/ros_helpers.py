"""Helpers for tests that run real ROS 2 processes on loopback.

- :func:`ros_env`: environment for child processes and this one: a random ``ROS_DOMAIN_ID`` per test run,
  ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (no discovery traffic off the host), ``ROS_LOG_DIR`` in a
  temp dir, one BLAS thread. Tests also put their nodes in a random namespace, so two runs that draw the
  same domain still do not see each other's topics.
- :class:`Proc`: a ``bkabem`` child process whose stdout/stderr lines are collected by a thread
  (``wait_for`` a pattern, ``stop`` with a signal).
- :class:`Listener`: an rclpy node in this process with its own context and spin thread: subscribes,
  collects ``(receive_ns, msg)`` per topic, publishes, and sets/gets parameters of other nodes.

Deliberately no ``pytest.importorskip``: the set-up installs ROS, and a missing rclpy must fail the tests.
"""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def random_domain() -> int:
    """A random ``ROS_DOMAIN_ID`` in 1-200; under pytest-xdist each worker draws from its own share of the range
    (gw0 1-100, gw1 101-200 with two workers), so processes of two workers of one run never share a domain."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    count = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
    index = int(worker[2:]) % count if worker.startswith("gw") and worker[2:].isdigit() else 0
    width = 200 // count
    return 1 + index * width + random.SystemRandom().randrange(width)


_DOMAIN = random_domain()
_LOG_DIR = tempfile.mkdtemp(prefix="bkabem_ros_log_")


def ros_env(extra: dict | None = None) -> dict:
    """Environment for ROS child processes (and set in ``os.environ`` for this one by :func:`use_ros_env`)."""
    env = dict(os.environ)
    env.update({
        "ROS_DOMAIN_ID": str(_DOMAIN),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_LOG_DIR": _LOG_DIR,
        "OPENBLAS_NUM_THREADS": "1",
        "PYTHONUNBUFFERED": "1",
        "RCUTILS_COLORIZED_OUTPUT": "0",
    })
    env.pop("ROS_LOCALHOST_ONLY", None)
    if extra:
        env.update(extra)
    return env


def use_ros_env() -> None:
    """Apply :func:`ros_env` to this process (before ``rclpy.init``)."""
    for k, v in ros_env().items():
        if k.startswith(("ROS_", "RCUTILS_", "OPENBLAS_")):
            os.environ[k] = v


def unique_namespace(prefix: str = "t") -> str:
    return f"/{prefix}{os.getpid()}_{random.SystemRandom().randrange(1 << 30):x}"


def bkabem_cmd(*args: str) -> list[str]:
    """Command line of the ``bkabem`` CLI run by this interpreter."""
    return [sys.executable, "-m", "bkabem_ros", *args]


class Proc:
    """A child process with its output lines collected (stdout and stderr merged)."""

    def __init__(self, args: list[str], env: dict | None = None, name: str = ""):
        self.name = name or " ".join(args[3:5])
        self.lines: list[str] = []
        self._cond = threading.Condition()
        self.p = subprocess.Popen(args, env=env or ros_env(), cwd=str(REPO), stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True, bufsize=1)
        self._t = threading.Thread(target=self._read, daemon=True)
        self._t.start()

    def _read(self) -> None:
        for line in self.p.stdout:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    @property
    def text(self) -> str:
        with self._cond:
            return "\n".join(self.lines)

    def wait_for(self, pattern: str, timeout: float = 30.0, start: int = 0) -> re.Match:
        """First match of regex ``pattern`` in an output line (from line ``start``); AssertionError on timeout."""
        rx = re.compile(pattern)
        t_end = time.monotonic() + timeout
        i = start
        with self._cond:
            while True:
                while i < len(self.lines):
                    m = rx.search(self.lines[i])
                    if m:
                        return m
                    i += 1
                left = t_end - time.monotonic()
                if left <= 0 or (self.p.poll() is not None and i >= len(self.lines)):
                    raise AssertionError(f"{self.name}: no line matching {pattern!r} within {timeout} s "
                                         f"(rc={self.p.poll()}); output:\n{self.text[-4000:]}")
                self._cond.wait(min(left, 0.2))

    def stop(self, sig=signal.SIGINT, timeout: float = 15.0) -> int:
        if self.p.poll() is None:
            self.p.send_signal(sig)
            try:
                self.p.wait(timeout)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait(5)
                raise AssertionError(f"{self.name}: did not stop within {timeout} s after {sig!r}; "
                                     f"output:\n{self.text[-4000:]}") from None
        self._t.join(5)
        return self.p.returncode

    def kill(self) -> None:
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait(5)


class Listener:
    """An rclpy node in this process (own context, own spin thread) for subscribing and poking other nodes."""

    def __init__(self, name: str = "test_listener"):
        use_ros_env()
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.rclpy = rclpy
        self.context = Context()
        rclpy.init(context=self.context, domain_id=_DOMAIN)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.msgs: dict[str, list] = defaultdict(list)
        self._lock = threading.Lock()
        self._stop = False
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop and self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:  # noqa: BLE001 - shutdown races
                if self._stop:
                    return
                raise

    def subscribe(self, topic: str, msg_type, reliable: bool = False, depth: int = 1000):
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                         reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT)

        def cb(msg, info, _t=topic):
            # the middleware's reception time (system clock, ns): an arrival time that a pause of this Python
            # process (a garbage collection of the test session's large heap, the spin thread waiting for the GIL)
            # does not shift; the local clock where the middleware gives none
            t = info.get("received_timestamp") or time.time_ns()
            with self._lock:
                self.msgs[_t].append((t, msg))

        return self.node.create_subscription(msg_type, topic, cb, qos)

    def publisher(self, topic: str, msg_type, reliable: bool = True):
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT)
        return self.node.create_publisher(msg_type, topic, qos)

    def get(self, topic: str) -> list:
        with self._lock:
            return list(self.msgs[topic])

    def clear(self, topic: str | None = None) -> None:
        with self._lock:
            if topic is None:
                self.msgs.clear()
            else:
                self.msgs[topic] = []

    def wait_for(self, topic: str, predicate=lambda items: len(items) > 0, timeout: float = 20.0) -> list:
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            items = self.get(topic)
            if predicate(items):
                return items
            time.sleep(0.02)
        items = self.get(topic)
        raise AssertionError(f"{topic}: condition not met within {timeout} s ({len(items)} messages)")

    def publish_until(self, pub, msg, topic: str, predicate, timeout: float = 20.0, period: float = 0.1) -> list:
        """Publish ``msg`` every ``period`` s until ``predicate(items of topic)`` holds (the first messages
        after discovery can be lost on a best-effort subscription)."""
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            pub.publish(msg)
            t_next = time.monotonic() + period
            while time.monotonic() < t_next:
                items = self.get(topic)
                if predicate(items):
                    return items
                time.sleep(0.01)
        raise AssertionError(f"{topic}: condition not met within {timeout} s of publishing on {pub.topic_name}")

    def wait_subscribers(self, pub, n: int = 1, timeout: float = 15.0) -> None:
        t_end = time.monotonic() + timeout
        while pub.get_subscription_count() < n:
            if time.monotonic() > t_end:
                raise AssertionError(f"{pub.topic_name}: no subscriber within {timeout} s")
            time.sleep(0.02)

    def wait_publishers(self, topic: str, n: int = 1, timeout: float = 20.0) -> None:
        t_end = time.monotonic() + timeout
        while self.node.count_publishers(topic) < n:
            if time.monotonic() > t_end:
                raise AssertionError(f"{topic}: no publisher within {timeout} s")
            time.sleep(0.02)

    # -- parameters of another node
    def _param_client(self, node_name: str):
        from rclpy.parameter_client import AsyncParameterClient

        clients = self.__dict__.setdefault("_param_clients", {})
        if node_name not in clients:
            client = AsyncParameterClient(self.node, node_name)
            if not client.wait_for_services(timeout_sec=15.0):
                raise AssertionError(f"parameter services of {node_name} not available")
            clients[node_name] = client
        return clients[node_name]

    def _result(self, future, timeout: float = 15.0):
        t_end = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > t_end:
                raise AssertionError("parameter service call timed out")
            time.sleep(0.01)
        return future.result()

    def set_parameters(self, node_name: str, values: dict) -> list:
        """Set parameters of ``node_name``; returns the SetParametersResult list."""
        from rclpy.parameter import Parameter

        client = self._param_client(node_name)
        res = self._result(client.set_parameters([Parameter(k, value=v) for k, v in values.items()]))
        return list(res.results)

    def get_parameters(self, node_name: str, names: list[str]) -> dict:
        from rclpy.parameter import parameter_value_to_python

        client = self._param_client(node_name)
        res = self._result(client.get_parameters(names))
        return {n: parameter_value_to_python(v) for n, v in zip(names, res.values)}

    def close(self) -> None:
        self._stop = True
        self._thread.join(5)
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.try_shutdown(context=self.context)
