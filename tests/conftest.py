"""Shared fixtures: the embedded case and its BKA-BEM model are built once per test session."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def case():
    from bkabem_core.case import Case

    return Case.load()


@pytest.fixture(scope="session")
def excitation(case):
    from bkabem_core.excitation import compute_excitation

    return compute_excitation(case.bearing(), case.four_dof_parameters())


@pytest.fixture(scope="session")
def model(case, excitation):
    from bkabem_core.harmonic import BkaBem

    return BkaBem(case, excitation=excitation)
