"""The least-squares fit of a time-domain record at the model's line frequencies (the TDSM validation's first step):
the normal equations where the record resolves every line, the SVD's minimum-norm split where it does not."""

from __future__ import annotations

import numpy as np
import pytest

from bkabem_core.reference import validation
from bkabem_core.reference.validation import _fit_lines

FS = 2000.0


def _columns(duration_s: float, frequency_hz: np.ndarray) -> np.ndarray:
    t = np.arange(int(duration_s * FS)) / FS
    ph = 2 * np.pi * np.outer(t, frequency_hz)
    return np.hstack([np.ones((t.size, 1)), np.cos(ph), -np.sin(ph)])


def _record(a: np.ndarray, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return a @ rng.normal(size=(a.shape[1], 3)) + 0.01 * rng.normal(size=(a.shape[0], 3))


def test_resolved_lines_take_the_normal_equations_with_the_least_squares_solution(monkeypatch):
    """300 lines and a pair 0.4 Hz apart in a 1 s record: resolved (condition of the columns ~3e3), so the fit does
    not call the SVD least squares and lands on its solution to 1e-8 of the largest coefficient."""
    rng = np.random.default_rng(0)
    a = _columns(1.0, np.concatenate([rng.uniform(5.0, 900.0, 300), [100.0, 100.4]]))
    y = _record(a)
    want, *_ = np.linalg.lstsq(a, y, rcond=None)

    def refused(*args, **kw):
        raise AssertionError("the SVD path was taken for resolved lines")

    monkeypatch.setattr(validation.np.linalg, "lstsq", refused)
    got = _fit_lines(a, y)
    assert np.abs(got - want).max() <= 1e-8 * np.abs(want).max()


@pytest.mark.parametrize("frequency_hz", [[100.0, 100.0001, 250.0], [100.0, 100.0, 250.0]], ids=["close", "equal"])
def test_lines_the_record_cannot_tell_apart_get_the_minimum_norm_split(frequency_hz):
    """A 0.3 s record and two lines 1e-4 Hz apart (the columns' condition ~4e4, the Gram matrix's past 1e8) or the
    same line twice (singular): the fit is numpy's SVD least squares, bit for bit. (Two lines 0.01 Hz apart are
    still resolved in a noiseless 0.3 s record: condition ~370.)"""
    a = _columns(0.3, np.array(frequency_hz))
    y = _record(a)
    want, *_ = np.linalg.lstsq(a, y, rcond=None)
    assert np.array_equal(_fit_lines(a, y), want)
