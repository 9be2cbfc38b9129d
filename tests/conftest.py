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
import weakref
from pathlib import Path

import pytest

from bkabem_core import PIPELINE

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
#: from (:func:`_library_key`): ``build/test-cache``, or the folder ``BKABEM_TEST_CACHE`` names (bench/bench_startup.py
#: times the unit tier with an empty one)
LIBRARY_CACHE = Path(os.environ.get("BKABEM_TEST_CACHE") or
                     Path(__file__).resolve().parents[1] / "build" / "test-cache")

#: What a cached object's content can come from, for an object whose maker is not known: all of bkabem_core
WHOLE_LIBRARY = PIPELINE[-1]


@functools.cache
def _library_key(floor: str) -> str:
    """The cache key of an object made by the code of ``bkabem_core`` up to the package ``floor`` of the pipeline
    (``bkabem_core.PIPELINE``; a package imports only the ones before it, tests/unit/test_layout.py holds that): a
    hash of every file of those packages, of what any package may read (the embedded cases and bearings, the
    kernels' sources and built modules, the top-level modules) and of the Python, numpy and scipy versions. A
    change to one of them makes new objects; a change above ``floor`` (a synthesiser's, a data set's) cannot
    change what the code below it makes, and keeps them."""
    import sys

    import numpy
    import scipy

    root = Path(__file__).resolve().parents[1] / "bkabem_core"
    below = set(PIPELINE[:PIPELINE.index(floor) + 1]) | {"embedded", "kernels"}
    h = hashlib.sha256(f"{floor}|{sys.version}|{numpy.__version__}|{scipy.__version__}".encode())
    for f in sorted(root.rglob("*")):
        rel = f.relative_to(root)
        if f.is_file() and f.suffix in (".py", ".toml", ".csv", ".json", ".c", ".h", ".so") and \
                (len(rel.parts) == 1 or rel.parts[0] in below):
            h.update(str(rel).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:20]


#: id -> (a weak reference to the object, the floor its content comes from) of the objects :func:`_cached` returned
_FLOORS: dict[int, tuple[weakref.ref, str]] = {}


def _floor_of(obj) -> str:
    """The pipeline package up to which the code that made ``obj`` reaches (:data:`WHOLE_LIBRARY` when unknown)."""
    kept = _FLOORS.get(id(obj))
    return kept[1] if kept is not None and kept[0]() is obj else WHOLE_LIBRARY


def _cached(name: str, make, floor: str = WHOLE_LIBRARY):
    """The object ``make()`` returns, pickled once into ``build/test-cache/<floor>-<key>-<name>.pickle`` and
    unpickled from there by every later caller, run or worker, while the key of ``floor`` (:func:`_library_key`:
    the code up to that package made it) holds (under a lock: one maker, the others wait asleep). Pickles of the
    same floor under another key are removed when a new one is written."""
    LIBRARY_CACHE.mkdir(parents=True, exist_ok=True)
    key = _library_key(floor)
    path = LIBRARY_CACHE / f"{floor}-{key}-{name}.pickle"
    with open(LIBRARY_CACHE / "cache.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not path.exists():
                part = path.with_name(path.name + f".{os.getpid()}")
                part.write_bytes(pickle.dumps(make(), protocol=pickle.HIGHEST_PROTOCOL))
                os.replace(part, path)
                for old in LIBRARY_CACHE.glob("*.pickle*"):
                    if not old.name.startswith(f"{floor}-{key}-") and (
                            old.name.startswith(f"{floor}-") or old.name.split("-")[0] not in PIPELINE):
                        old.unlink(missing_ok=True)
            obj = pickle.loads(path.read_bytes())
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
    for part in obj.values() if isinstance(obj, dict) else obj if isinstance(obj, (list, tuple)) else (obj,):
        if hasattr(type(part), "__weakref__"):                     # (the models; what a model may be made like)
            _FLOORS[id(part)] = (weakref.ref(part), floor)
    return obj


def _make_fault_library() -> dict:
    """The fault library's models, all of them at once and always in this order (a model made like the one before
    depends on which one that was)."""
    from bkabem_core.model.case import Case
    from bkabem_core.scenario.models import ModelPool

    pool = ModelPool()
    return {k: pool.get(Case.load(f"motor_6010_{k}")) for k in ("healthy", "inner", "ball", "outer")}


@pytest.fixture(scope="session")
def fault_library():
    """The fault library's models, one per kind (``motor_6010_<kind>``): kind -> BkaBem. They share one machine,
    each made like the one before, as a scenario's model pool makes them (bkabem_core.scenario.models).

    Made once and kept in ``build/test-cache`` under :func:`_library_key` (:func:`_cached`): the next run (either
    tier, any worker) unpickles it while nothing it is made from has changed. Every worker, the maker too, uses the
    unpickled copy: the same models, bit for bit, whichever run or worker made them (the pickle is the one the
    model helper process sends, bkabem_core.scenario.models)."""
    return _cached("fault_library", _make_fault_library, floor="scenario")


@pytest.fixture(scope="session")
def cached_model():
    """``cached_model(case, like=None)``: ``BkaBem(case, like=like)``, made once for as long as the code that makes
    it does not change (:func:`_cached`, keyed by the case's hash and ``like``'s): the packages up to ``solve``, or
    up to those that made ``like`` (a fault-library model: ``scenario``; one of unknown making: all of them). For
    a test that needs a model of a case as its input; a test of how models are made calls BkaBem itself."""
    from bkabem_core.solve.harmonic import BkaBem

    def get(case, like=None):
        like_hash = "" if like is None else like.case.case_hash
        name = hashlib.sha256(f"{case.name}|{case.source}|{case.case_hash}|{like_hash}".encode()).hexdigest()[:20]
        floor = "solve" if like is None else max("solve", _floor_of(like), key=PIPELINE.index)
        return _cached(f"model-{name}", lambda: BkaBem(case, like=like), floor=floor)

    return get


@pytest.fixture(scope="session")
def cached_pool():
    """``cached_pool(*scenarios)``: a scenario's model pool (bkabem_core.scenario.models) already holding the model
    of every state of ``scenarios``, made by one pool in that order (each like the one before, as a run makes
    them), once for as long as the code up to ``scenario`` does not change (:func:`_cached`). For a test of what a
    run does with its models; a test of how a pool makes them uses a ModelPool of its own."""
    from bkabem_core.scenario.models import ModelPool

    def get(*scenarios, size: int = 64) -> ModelPool:
        cases = [state.case for sc in scenarios for state in sc.states]
        name = hashlib.sha256("|".join(c.case_hash for c in cases).encode()).hexdigest()[:20]

        def make():
            pool = ModelPool(size=len(cases))
            return [pool.get(c) for c in cases]

        pool = ModelPool(size=size)
        for model in _cached(f"pool-{name}", make, floor="scenario"):
            pool.put(model)
        return pool

    return get


@pytest.fixture(scope="session")
def kind_validation():
    """``kind_validation(kind)``: the TDSM of the fault library's ``kind`` machine (``motor_6010_<kind>``, its
    lines to 50 x BPFO, which the reference's record resolves; no machine baseline) at 30 Hz, 0.3 s recorded after
    0.5 s of settling, fitted at the lines and compared with plain BKA-BEM and the improved method
    (bkabem_core.reference.validation.validate_lines): (plain model, improved method, LineValidation). Made once
    for as long as the code up to ``reference`` does not change (:func:`_cached`): tests/integration/
    test_faults_tdsm.py holds the plain method to it, tests/integration/test_hill.py the improved one."""
    from bkabem_core.model.case import Case
    from bkabem_core.reference.validation import validate_lines
    from bkabem_core.solve.harmonic import BkaBem
    from bkabem_core.solve.improved import HillCorrection

    def get(kind: str):
        case = Case.load(f"motor_6010_{kind}").with_overrides({"excitation.max_order": 50})

        def make():
            plain = BkaBem(case, baseline=False)
            improved = HillCorrection(plain)
            return plain, improved, validate_lines(case, 30.0, duration_s=0.3, settle_s=0.5, plain=plain,
                                                   improved=improved)

        return _cached(f"kind-validation-{kind}", make, floor="reference")

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
