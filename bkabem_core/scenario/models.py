"""Models of a machine's states, made once and reusing each other's decompositions, inline or in a helper process.

A scenario (:mod:`bkabem_core.scenario.timeline`) is one machine in many states: the same FE, other defects. A state's model
is ``BkaBem(case, like=model_of_a_previous_state)``: the FE, its modal basis and the line modes of every line the
previous model had are reused, only the excitation and the new lines' modes are computed (measured on the fault
library's motor: an outer-race dent grown by 20 % in 0.05-0.3 s, an inner-race or ball defect grown in 0.3-2 s,
against 3-13 s from nothing; BENCHMARKS.md, "Scenarios").

:class:`ModelPool`
    Inline: :meth:`ModelPool.get` builds (or returns) the model of a case, blocking. For offline rendering and data
    sets.
:class:`ModelHelper`
    A helper process with its own :class:`ModelPool` prepares models while the caller goes on (a streaming node
    must never wait seconds for a model); the finished model comes back pickled, and :meth:`ModelHelper.take`
    unpickles it (~20 ms for 50 MB) when the caller chooses (the node: in its warm-up thread,
    :class:`bkabem_core.scenario.run.BackgroundModels`). The helper runs at a lower CPU priority (nice 10) so
    that it never takes the cores from a real-time stream. One per process can be shared (:meth:`shared`).

No ROS here. Units: none of their own (the models are SI).
"""

from __future__ import annotations

import os
import pickle
import shutil
import struct
import subprocess
import sys
import threading
import time
from collections import OrderedDict

from bkabem_core.fe.machine import Machine
from bkabem_core.model.case import Case
from bkabem_core.solve.harmonic import BkaBem

#: Models a pool keeps (each holds its line modes: ~10-50 MB for the fault library's motor).
POOL_SIZE = 4
#: CPU priority of the helper process (nice value; a real-time stream keeps its cores)
NICE = 10
_HEADER = struct.Struct("<Q")


class ModelPool:
    """BKA-BEM models by case hash, each made like the most recent model of the same FE (module docstring).

    Parameters
    ----------
    size : int
        Models kept (least recently used dropped first).
    """

    def __init__(self, size: int = POOL_SIZE):
        self.size = int(size)
        self._models: OrderedDict[str, BkaBem] = OrderedDict()
        self.build_times_s: dict[str, float] = {}

    def __contains__(self, case_hash: str) -> bool:
        return case_hash in self._models

    def put(self, model: BkaBem) -> None:
        """Keep ``model`` (made elsewhere) as the model of its case and as a source of decompositions."""
        key = model.case.case_hash
        self._models[key] = model
        self._models.move_to_end(key)
        while len(self._models) > self.size:
            self._models.popitem(last=False)

    def like_of(self, case: Case) -> BkaBem | None:
        """The most recently used model whose FE is that of ``case`` (None: there is none)."""
        key = Machine.fe_key(case)
        for model in reversed(self._models.values()):
            if Machine.fe_key(model.case) == key:
                return model
        return None

    def get(self, case: Case) -> BkaBem:
        """The model of ``case``: kept, or made now like :meth:`like_of` (blocking: seconds for a new line set)."""
        key = case.case_hash                # the SHA-256 of the whole case: once a call
        model = self._models.get(key)
        if model is None:
            t0 = time.perf_counter()
            model = BkaBem(case, like=self.like_of(case))
            self.build_times_s[key] = time.perf_counter() - t0
            self.put(model)
        else:
            self._models.move_to_end(key)
        return model


# --------------------------------------------------------------------------- the helper process
def _send(fh, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    fh.write(_HEADER.pack(len(data)))
    fh.write(data)
    fh.flush()


def _recv(fh):
    head = fh.read(_HEADER.size)
    if len(head) < _HEADER.size:
        return None
    (n,) = _HEADER.unpack(head)
    data = fh.read(n)
    if len(data) < n:
        return None
    return pickle.loads(data)


def _lower_priority() -> None:
    try:
        os.nice(NICE)
    except OSError:
        pass


def worker_main() -> int:
    """The helper process: read ``(tag, case raw, source)`` requests from stdin, answer ``(tag, ok, payload,
    seconds)`` on stdout, payload the pickled model or the error's one line. Ends when stdin closes."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)         # the parent decides when this ends (stdin closes)
    pool = ModelPool()
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    while True:
        req = _recv(inp)
        if req is None:
            return 0
        tag, raw, source = req
        t0 = time.perf_counter()
        try:
            model = pool.get(Case.from_dict(raw, source))
            payload, ok = pickle.dumps(model, protocol=pickle.HIGHEST_PROTOCOL), True
        except Exception as exc:  # noqa: BLE001 - reported to the parent, which keeps going
            payload, ok = f"{type(exc).__name__}: {exc}", False
        _send(out, (tag, ok, payload, time.perf_counter() - t0))


class ModelHelper:
    """Models prepared in a helper process (module docstring).

    ``request(case)`` queues a case (once per case hash); the helper makes its models one after the other.
    ``ready(case_hash)`` says whether one is back; ``take(case_hash)`` unpickles it (in the caller's thread, when the
    caller has time) and keeps it for further takes by other users of a shared instance until :meth:`drop`.
    ``failed(case_hash)`` gives the error of a case that could not be prepared. The helper starts with the first
    request and is restarted if it dies.
    """

    _shared: "ModelHelper | None" = None
    _shared_lock = threading.Lock()

    def __init__(self):
        self._lock = threading.Condition()
        self._proc: subprocess.Popen | None = None
        self._reader: threading.Thread | None = None
        self._outbox: list = []                                   # requests the sender thread writes to the helper
        self._pending: OrderedDict[str, float] = OrderedDict()   # case hash -> time requested
        self._bytes: dict[str, bytes] = {}
        self._models: dict[str, BkaBem] = {}
        self._errors: dict[str, str] = {}
        self.times_s: dict[str, float] = {}                      # case hash -> preparation time in the helper
        self.closed = False

    @classmethod
    def shared(cls) -> "ModelHelper":
        """One instance per process (the nodes of a fleet process share the helper and the models)."""
        with cls._shared_lock:
            if cls._shared is None or cls._shared.closed:
                cls._shared = cls()
            return cls._shared

    # -- the process --
    def _start(self) -> None:
        env = dict(os.environ)
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
        # niced before anything runs: its start-up (interpreter, numpy, scipy: ~1-3 s of CPU) must not take a core
        # from a real-time stream either. By nice(1), not a preexec_fn: that forces a fork of this process (page
        # tables of a streaming node's ~1 GB: ~20-30 ms in the caller's thread, measured in the chunk that asked
        # for the first model); without one, subprocess spawns by vfork (microseconds)
        cmd = [sys.executable, "-m", "bkabem_core.scenario.models"]
        nice = shutil.which("nice")
        self._proc = subprocess.Popen([nice, "-n", str(NICE)] + cmd if nice else cmd, stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env,
                                      preexec_fn=None if nice else _lower_priority)
        self._reader = threading.Thread(target=self._read, args=(self._proc,), daemon=True,
                                        name="bkabem-model-helper")
        self._reader.start()
        threading.Thread(target=self._write, args=(self._proc,), daemon=True, name="bkabem-model-requests").start()

    def _write(self, proc: subprocess.Popen) -> None:
        """Send the queued requests (a write blocks while the helper is busy: never in the caller's thread)."""
        while True:
            with self._lock:
                while not self._outbox and self._proc is proc:
                    self._lock.wait(1.0)
                if self._proc is not proc:
                    return
                key, raw, source = self._outbox.pop(0)
            try:
                _send(proc.stdin, (key, raw, source))
            except (BrokenPipeError, OSError, ValueError):
                with self._lock:
                    self._pending.pop(key, None)
                    self._errors[key] = "the model helper process ended"
                return

    def _read(self, proc: subprocess.Popen) -> None:
        while True:
            try:
                msg = _recv(proc.stdout)
            except Exception:  # noqa: BLE001 - a broken pipe ends the helper
                msg = None
            if msg is None:
                break
            tag, ok, payload, seconds = msg
            with self._lock:
                self._pending.pop(tag, None)
                self.times_s[tag] = seconds
                if ok:
                    self._bytes[tag] = payload
                else:
                    self._errors[tag] = payload
        with self._lock:                                 # the helper is gone: its open requests failed
            for tag in list(self._pending):
                self._errors[tag] = "the model helper process ended"
            self._pending.clear()

    def request(self, case: Case) -> None:
        """Queue the preparation of ``case``'s model (nothing if it is queued, ready or taken already)."""
        key = case.case_hash
        with self._lock:
            if self.closed:
                raise RuntimeError("ModelHelper is closed")
            if key in self._pending or key in self._bytes or key in self._models:
                return
            self._errors.pop(key, None)
            if self._proc is None or self._proc.poll() is not None:
                self._start()
            self._pending[key] = time.monotonic()
            self._outbox.append((key, case.raw, case.source))
            self._lock.notify_all()

    # -- results --
    def pending(self, case_hash: str) -> bool:
        with self._lock:
            return case_hash in self._pending

    @property
    def busy(self) -> bool:
        """Whether a requested model is still being made."""
        with self._lock:
            return bool(self._pending)

    def ready(self, case_hash: str) -> bool:
        with self._lock:
            return case_hash in self._bytes or case_hash in self._models

    def failed(self, case_hash: str) -> str | None:
        with self._lock:
            return self._errors.get(case_hash)

    def take(self, case_hash: str) -> BkaBem | None:
        """The model of the case if it is back (unpickled now, in this thread, on the first take), else None."""
        with self._lock:
            model = self._models.get(case_hash)
            data = None if model is not None else self._bytes.pop(case_hash, None)
        if model is None and data is not None:
            model = pickle.loads(data)
            with self._lock:
                self._models[case_hash] = model
        return model

    def drop(self, case_hash: str) -> None:
        """Forget a model (ready or taken); a running preparation of it still finishes."""
        with self._lock:
            self._bytes.pop(case_hash, None)
            self._models.pop(case_hash, None)

    def close(self) -> None:
        """Stop the helper (its running preparation is lost)."""
        with self._lock:
            self.closed = True
            proc, self._proc = self._proc, None
            self._outbox.clear()
            self._lock.notify_all()
        if proc is not None:
            try:
                proc.stdin.close()
            except OSError:
                pass
            try:
                proc.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


if __name__ == "__main__":
    sys.exit(worker_main())
