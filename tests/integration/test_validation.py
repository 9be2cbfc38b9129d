"""Reduced validation of BKA-BEM against the TDSM (seconds), the result format, and the variants.

The long validation (14 speeds, every location, displacement and acceleration) is
``python3 bench/validate_speeds.py``; its numbers are in docs/validation.md. Tolerances here, stated once, at the
default 30 Hz:

* plain BKA-BEM (the paper's method on the consistent machine): the five largest displacement orders of every
  location and direction within 3 dB of the TDSM (measured: <= 1.6 dB);
* the improved method (``hill``): within 0.3 dB of the TDSM, displacement and acceleration (measured: <= 0.15);
* the harmonic balance of the same nonlinear model (``hbm``): within 0.1 dB, complex amplitudes within 1 %: two
  independent solvers of one model must agree;
* the paper's own configuration on the same machine is 7-20 dB off (what consistency buys);
* frequency: the TDSM peaks sit at k x BPFO within 0.2 % (no sidebands, no drift).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from bkabem_core.model.vocabulary import LOCATIONS
from bkabem_core.reference.periodic import harmonic_balance
from bkabem_core.reference.tdsm import Tdsm
from bkabem_core.reference.validation import METHODS, make_method, plot_validation, validate
from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.solve.improved import HillCorrection

pytestmark = pytest.mark.tdsm

SPEED = 30.0


@pytest.fixture(scope="module")
def result(case, model):
    return validate(case, speed_hz=SPEED, duration_s=0.05, improvement="hill", extra=("hbm", "paper"),
                    progress=False, plain=model)


def test_plain_method_within_3_db_of_the_tdsm(result):
    err = result.max_error_db("plain")
    assert err.shape == (len(LOCATIONS), 2)
    assert err.max() < 3.0, err
    de = LOCATIONS.index("de_rotor")
    assert result.orders[result.largest_orders(de, 0)[0]] == 3       # 545 Hz dominates vertically at 30 Hz


def test_improved_method_within_0_3_db_of_the_tdsm(result):
    for q in ("displacement", "acceleration"):
        err = result.max_error_db("hill", q)
        assert err.max() < 0.3, (q, err)
    assert result.wall_time_s["hill_spectrum"] < 0.02


def test_harmonic_balance_agrees_with_tdsm(result):
    r = result
    for li in range(len(LOCATIONS)):
        for di in range(2):
            big = r.largest_orders(li, di)
            a, t = r.methods["hbm"][big, li, di], r.tdsm[big, li, di]
            assert np.max(np.abs(a - t) / np.abs(t)) < 0.01, (li, di)
    assert r.max_error_db("hbm").max() < 0.1
    assert r.wall_time_s["hbm_spectrum"] < r.wall_time_s["tdsm"]


def test_paper_configuration_is_far_off_on_the_same_machine(result):
    assert result.max_error_db("paper").min() > 3.0


def test_frequencies_and_steady_state(result):
    r = result
    de = LOCATIONS.index("de_rotor")
    for di in range(2):
        big = r.largest_orders(de, di)
        f_peak = r.tdsm_frequency_hz[big, de, di]
        assert np.all(np.abs(f_peak / r.frequency_hz[big] - 1.0) < 2e-3)
    info = r.tdsm_info
    assert info["settled"] and 0.05 < info["settle_s"] < 1.0       # damped: settles in a fraction of a second
    for loc in LOCATIONS:
        for d in ("vertical", "horizontal"):
            assert info["off_order_fraction"][loc][d] < 0.01
            assert info["half_vs_half_max_abs_db_largest"][loc][d] < 0.01


def test_json_fields(result):
    d = json.loads(json.dumps(result.to_dict()))
    assert d["speed_hz"] == SPEED and d["improvement"] == "hill"
    for loc in LOCATIONS:
        for direction in ("vertical", "horizontal"):
            e = d[loc][direction]
            for key in ("orders", "frequency_hz", "tdsm_amplitude_m", "bkabem_amplitude_m", "error_db",
                        "tdsm_frequency_hz", "dc_m", "largest_orders", "max_abs_error_db_largest",
                        "largest_orders_acceleration", "max_abs_error_db_largest_acceleration",
                        "improved_amplitude_m", "improved_error_db", "improved_max_abs_error_db_largest"):
                assert key in e, key
            assert len(e["largest_orders"]) == 5
    assert d["speed_ratio"] > 1000
    assert set(d["wall_time_s"]) >= {"tdsm", "plain_spectrum", "plain_preparation", "hill_spectrum"}


def test_plot(result, tmp_path):
    p = tmp_path / "v.png"
    plot_validation(result, str(p))
    assert p.stat().st_size > 20_000


def test_hill_correction_against_the_harmonic_balance_at_other_speeds(case, model):
    """The improved method is one Newton step of the harmonic balance from the quasi-static path: at a low and a
    high speed it lands within 0.2 dB of the converged harmonic balance (the five largest orders everywhere)."""
    hill = HillCorrection(model)
    for f in (12.0, 70.0):
        sol = harmonic_balance(Tdsm(case, f, machine=model.machine), n_orders=int(model.orders.max()))
        got = hill.spectrum(f).displacement
        for li in range(4):
            for di in range(2):
                ref = sol.complex_amplitude[model.orders - 1, li, di]
                big = np.argsort(np.abs(ref))[::-1][:5]
                assert np.max(np.abs(20 * np.log10(np.abs(got[big, li, di]) / np.abs(ref[big])))) < 0.2
        assert 0 < hill.last_iterations < 20


def test_methods_build(case, model):
    assert METHODS == ("plain", "hill", "paper", "four_dof", "hbm")
    paper = make_method("paper", case)
    assert paper.model.machine.sites["de"].source == "table"
    assert set(paper.model.excitations) == {"de"}
    assert paper.model.excitations["de"].method == "four_dof"
    assert paper.model.excitations["de"].radial_load_n == pytest.approx(82 * 9.80665)
    with pytest.raises(ValueError, match="method"):
        make_method("nope", case)


def test_interrupt_returns_partial_comparison(case, model, monkeypatch):
    from bkabem_core.reference.integrator import Integrator

    real = Integrator.advance
    calls = {"n": 0}

    def flaky(self, st, n_steps, **kw):
        calls["n"] += 1
        if calls["n"] == 2:                                 # the recording (after the fixed settle): 3 periods
            real(self, st, min(n_steps, 3 * self.steps_per_bpfo), **kw)
            st.interrupted = True
            return
        return real(self, st, n_steps, **kw)

    monkeypatch.setattr(Integrator, "advance", flaky)
    r = validate(case, speed_hz=SPEED, duration_s=0.2, improvement=None, settle_s=0.02, progress=False, plain=model)
    assert r.tdsm_info["interrupted"]
    assert r.tdsm_info["recorded_bpfo_periods"] >= 1


def test_bad_input(case, model):
    with pytest.raises(ValueError, match="speed_hz"):
        validate(case, speed_hz=-1.0, progress=False, plain=model)
    with pytest.raises(ValueError, match="improvement"):
        validate(case, improvement="magic", progress=False, plain=model)
    assert isinstance(model, BkaBem)
