"""Shared fixtures: the embedded case and its BKA-BEM model are built once per test session."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")


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


@pytest.fixture(scope="session")
def fault_library():
    """The fault library's models, one per kind (``motor_6010_<kind>``): kind -> BkaBem."""
    from bkabem_core.model.case import Case
    from bkabem_core.solve.harmonic import BkaBem

    return {k: BkaBem(Case.load(f"motor_6010_{k}")) for k in ("outer", "inner", "ball", "healthy")}
