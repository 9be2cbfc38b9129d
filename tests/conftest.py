"""Shared fixtures: the embedded case, its BKA-BEM model and the fault library are built once per test session
(the fault library once per run: xdist's workers share one); ``cli`` runs a core command in this process on the
library's models, ``figures`` keeps the figures it draws."""

from __future__ import annotations

import fcntl
import os
import pickle
import signal

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
def machine(case):
    from bkabem_core.fe.machine import Machine

    return Machine(case)


@pytest.fixture(scope="session")
def model(case, machine):
    """The default BKA-BEM model of the embedded case (quasi-static excitation of both bearings)."""
    from bkabem_core.solve.harmonic import BkaBem

    return BkaBem(case, machine=machine)


@pytest.fixture(scope="session")
def excitation(model):
    """The faulty (DE) bearing's excitation of the default model."""
    return model.excitations["de"]


@pytest.fixture(scope="session")
def four_dof_excitation(machine):
    """The paper's 4-DOF excitation of the DE bearing under its own load."""
    return machine.excitation("de", method="four_dof")


#: The fault library of an xdist run, pickled once for all its workers (in the run's shared temporary folder)
FAULT_LIBRARY_PICKLE = "fault_library.pickle"


def _make_fault_library() -> dict:
    """The fault library's models, all of them at once and always in this order (a model made like the one before
    depends on which one that was)."""
    from bkabem_core.model.case import Case
    from bkabem_core.scenario.models import ModelPool

    pool = ModelPool()
    return {k: pool.get(Case.load(f"motor_6010_{k}")) for k in ("healthy", "inner", "ball", "outer")}


@pytest.fixture(scope="session")
def fault_library(tmp_path_factory):
    """The fault library's models, one per kind (``motor_6010_<kind>``): kind -> BkaBem. They share one machine,
    each made like the one before, as a scenario's model pool makes them (bkabem_core.scenario.models).

    Under xdist the first worker to ask makes the library and pickles it into the run's shared temporary folder;
    the others wait on a lock (asleep: the maker's line-mode threads get the cores) and unpickle it. Every worker,
    the maker too, uses the unpickled copy: the same models, bit for bit, whichever worker made them and whatever
    it ran before (the pickle is the one the model helper process sends, bkabem_core.scenario.models)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        return _make_fault_library()
    shared = tmp_path_factory.getbasetemp().parent
    path = shared / FAULT_LIBRARY_PICKLE
    with open(shared / (FAULT_LIBRARY_PICKLE + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not path.exists():
                part = path.with_name(path.name + f".{os.getpid()}")
                part.write_bytes(pickle.dumps(_make_fault_library(), protocol=pickle.HIGHEST_PROTOCOL))
                os.replace(part, path)
            return pickle.loads(path.read_bytes())
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def pytest_sessionfinish(session):
    """The controller of an xdist run removes the fault library's pickle (hundreds of MB) once its workers are
    done (a worker cannot know whether another one still has to read it)."""
    config = session.config
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    (config._tmp_path_factory.getbasetemp() / FAULT_LIBRARY_PICKLE).unlink(missing_ok=True)


@pytest.fixture(scope="session")
def classic_ball(fault_library):
    """The fault library's ball defect with its pit kept on the contact track and no spin slip
    (``wander_revolutions = 0``, ``spin_slip = 0``): the quasi-static model's clean 2 x BSF comb, for the tests of
    what a ball defect's lines are (their intermittency: tests/unit/test_balltrack.py)."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem

    case = Case.load("motor_6010_ball").with_overrides({"defects.0.wander_revolutions": 0.0,
                                                         "defects.0.spin_slip": 0.0})
    return BkaBem(case, like=fault_library["ball"])


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
