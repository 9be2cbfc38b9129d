"""Shared fixtures: the embedded case, its BKA-BEM model and the fault library are made once for as long as the
code they are made from does not change (build/test-cache, ``cached_model``); ``cli`` runs a core command in this
process on the library's models, ``figures`` keeps the figures it draws."""

from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import pickle
import signal
from pathlib import Path

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")

# A suite started in the background of a non-interactive shell (`make test &`, a CI step's `cmd &`) inherits SIGINT
# ignored, and every process it starts would inherit that too: the tests that stop a command or a node with SIGINT
# (as Ctrl-C does) would then wait for a process that never hears it. A command started that way rightly keeps
# ignoring SIGINT; the tests need it delivered.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def case():
    from bkabem_core.model.case import Case

    return Case.load()


@pytest.fixture(scope="session")
def machine(model):
    """The default model's machine (FE rotor, bearings, housings)."""
    return model.machine


@pytest.fixture(scope="session")
def model(case, cached_model):
    """The default BKA-BEM model of the embedded case (quasi-static excitation of both bearings)."""
    return cached_model(case)


@pytest.fixture(scope="session")
def excitation(model):
    """The faulty (DE) bearing's excitation of the default model."""
    return model.excitations["de"]


@pytest.fixture(scope="session")
def four_dof_excitation(machine):
    """The paper's 4-DOF excitation of the DE bearing under its own load."""
    return machine.excitation("de", method="four_dof")


#: Where the fault library and the cached models are kept between runs, under a key of everything they are made
#: from (:func:`_library_key`)
LIBRARY_CACHE = Path(__file__).resolve().parents[1] / "build" / "test-cache"


@functools.cache
def _library_key() -> str:
    """The fault library's cache key: a hash of every file of ``bkabem_core`` its models could depend on (the code,
    the embedded cases and bearings, the kernels' sources and built modules) and of the Python, numpy and scipy
    versions. Any change to one of them makes a new library; nothing else can change it."""
    import sys

    import numpy
    import scipy

    root = Path(__file__).resolve().parents[1] / "bkabem_core"
    h = hashlib.sha256(f"{sys.version}|{numpy.__version__}|{scipy.__version__}".encode())
    for f in sorted(root.rglob("*")):
        if f.is_file() and f.suffix in (".py", ".toml", ".csv", ".json", ".c", ".h", ".so"):
            h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:20]


def _make_fault_library() -> dict:
    """The fault library's models, all of them at once and always in this order (a model made like the one before
    depends on which one that was)."""
    from bkabem_core.model.case import Case
    from bkabem_core.scenario.models import ModelPool

    pool = ModelPool()
    return {k: pool.get(Case.load(f"motor_6010_{k}")) for k in ("healthy", "inner", "ball", "outer")}


def _cached(name: str, make):
    """The object ``make()`` returns, pickled once into ``build/test-cache/<library key>-<name>.pickle`` and
    unpickled from there by every later caller, run or worker, while the library key holds (under a lock: one
    maker, the others wait asleep). Pickles of other keys are removed when a new one is written."""
    LIBRARY_CACHE.mkdir(parents=True, exist_ok=True)
    key = _library_key()
    path = LIBRARY_CACHE / f"{key}-{name}.pickle"
    with open(LIBRARY_CACHE / "cache.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not path.exists():
                part = path.with_name(path.name + f".{os.getpid()}")
                part.write_bytes(pickle.dumps(make(), protocol=pickle.HIGHEST_PROTOCOL))
                os.replace(part, path)
                for old in LIBRARY_CACHE.glob("*.pickle*"):
                    if not old.name.startswith(key + "-"):
                        old.unlink(missing_ok=True)
            return pickle.loads(path.read_bytes())
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def fault_library():
    """The fault library's models, one per kind (``motor_6010_<kind>``): kind -> BkaBem. They share one machine,
    each made like the one before, as a scenario's model pool makes them (bkabem_core.scenario.models).

    Made once and kept in ``build/test-cache`` under :func:`_library_key` (:func:`_cached`): the next run (either
    tier, any worker) unpickles it while nothing it is made from has changed. Every worker, the maker too, uses the
    unpickled copy: the same models, bit for bit, whichever run or worker made them (the pickle is the one the
    model helper process sends, bkabem_core.scenario.models)."""
    return _cached("fault_library", _make_fault_library)


@pytest.fixture(scope="session")
def cached_model():
    """``cached_model(case, like=None)``: ``BkaBem(case, like=like)``, made once for as long as the code does not
    change (:func:`_cached`, keyed by the case's hash and ``like``'s). For a test that needs a model of a case as
    its input; a test of how models are made calls BkaBem itself."""
    from bkabem_core.solve.harmonic import BkaBem

    def get(case, like=None):
        like_hash = "" if like is None else like.case.case_hash
        name = hashlib.sha256(f"{case.name}|{case.source}|{case.case_hash}|{like_hash}".encode()).hexdigest()[:20]
        return _cached(f"model-{name}", lambda: BkaBem(case, like=like))

    return get


@pytest.fixture(scope="session")
def classic_ball(fault_library, cached_model):
    """The fault library's ball defect with its pit kept on the contact track and no spin slip
    (``wander_revolutions = 0``, ``spin_slip = 0``): the quasi-static model's clean 2 x BSF comb, for the tests of
    what a ball defect's lines are (their intermittency: tests/unit/test_balltrack.py)."""
    from bkabem_core.model.case import Case

    case = Case.load("motor_6010_ball").with_overrides({"defects.0.wander_revolutions": 0.0,
                                                         "defects.0.spin_slip": 0.0})
    return cached_model(case, like=fault_library["ball"])


@pytest.fixture
def cli(monkeypatch, fault_library, capsys):
    """``cli(*argv) -> stdout`` of ``bkabem argv`` in this process, on the session's fault-library models."""
    from bkabem_ros.cli import core as core_cli
    from bkabem_ros.cli.main import main

    by_name = {f"motor_6010_{k}": m for k, m in fault_library.items()}
    monkeypatch.setattr(core_cli, "_model", lambda case, solver="modal": by_name[case.name])

    def run(*argv):
        capsys.readouterr()
        rc = main(list(argv))
        out = capsys.readouterr()
        assert rc == 0, out.err
        return out.out

    return run


@pytest.fixture
def figures(monkeypatch):
    """The figures the commands draw (the plotting functions return them): name -> [Figure]."""
    from bkabem_core.analysis import plots

    seen: dict[str, list] = {}
    for name in ("plot_spectrum", "plot_sweep", "plot_excitation"):
        real = getattr(plots, name)

        def wrapped(*a, _real=real, _name=name, **kw):
            fig = _real(*a, **kw)
            seen.setdefault(_name, []).append(fig)
            return fig

        monkeypatch.setattr(plots, name, wrapped)
    return seen
