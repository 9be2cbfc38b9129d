"""A faulty bearing rolls rougher: a defect's ``roughness_db`` raises its bearing's broadband floor.

Oracle, written here from the floor's definition: the floor's PSD is ``S_F^2 sum_i g_i^2 |T_ci|^2`` over the four
force pairs (de vertical, de horizontal, nde vertical, nde horizontal), with ``g = 10^(roughness_db / 20)`` on the
pairs of the defect's bearing and 1 on the others; ``T`` the transfer of the machine without the key (the floor's
transfer does not depend on the defects). Against the frames' periodogram, and through the public API a case
without the key (or with 0) renders the samples it rendered before.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from bkabem_core.dataset.spec import DatasetSpec
from bkabem_core.model.case import Case, CaseError
from bkabem_core.synth.synthesizer import Synthesizer

FS = 25600.0


def _sound(case: Case) -> Case:
    """``case`` with its defect's ``roughness_db`` key taken out (the fault library's cases give 15 dB)."""
    raw = copy.deepcopy(case.raw)
    for d in raw["defects"]:
        d.pop("roughness_db", None)
    return Case.from_dict(raw)


@pytest.fixture(scope="module")
def ball(cached_model, fault_library):
    """The fault library's ball defect without the key: a bearing as rough as the case's floor (made like the
    library's: the same lines)."""
    return cached_model(_sound(Case.load("motor_6010_ball")), like=fault_library["ball"])


def _synth(model, seed=7):
    return Synthesizer(model, sample_rate_hz=FS, chunk_s=0.1, seed=seed, features=False, quantities=["acceleration"])


def _samples(s, n=4):
    return np.concatenate([s.next_chunk(25.0).samples for _ in range(n)], axis=1)


@pytest.mark.parametrize("bearing_db", [("de", 20.0), ("nde", 6.0)])
def test_the_faulty_bearings_pairs_are_raised_and_the_others_not(cached_model, ball, bearing_db):
    bearing, db = bearing_db
    case = Case.load("motor_6010_ball").with_overrides({"defects.0.bearing": bearing, "defects.0.roughness_db": db})
    plain = _synth(cached_model(Case.load("motor_6010_ball").with_overrides({"defects.0.bearing": bearing,
                                                                             "defects.0.roughness_db": 0.0}),
                                like=ball)).floor
    rough = _synth(cached_model(case, like=ball)).floor
    g = np.array([10 ** (db / 20) if b == bearing else 1.0 for b in ("de", "de", "nde", "nde")])
    want = plain.density ** 2 * np.sum(g[None, None, :] ** 2 * np.abs(plain.transfer) ** 2, axis=2)
    np.testing.assert_allclose(rough.psd(), want, rtol=1e-5)
    # the frames are samples of that process: their periodogram over 4 frames x 256 lines is psd() within the
    # spread of 1024 exponential ordinates (~3 %; 6 sigma 20 %)
    x = rough.frames * rough.scale.astype(np.float64)
    n = rough.frame_length
    pxx = (2.0 / (FS * n)) * np.mean(np.abs(np.fft.rfft(x, axis=1)[:, 1:n // 2]) ** 2, axis=0)
    nb = (pxx.shape[0] // 256) * 256
    got = pxx[:nb].reshape(-1, 256, pxx.shape[1]).mean(axis=1)
    ref = want[:nb].reshape(-1, 256, pxx.shape[1]).mean(axis=1)
    live = ref > 1e-6 * ref.max(axis=0)
    assert np.all(np.abs(got[live] / ref[live] - 1.0) < 0.2)
    # the defect's own bearing gains the most: its vertical acceleration's floor rises by nearly the full amount
    names = _synth(cached_model(case, like=ball)).channel_names
    c = names.index(f"{bearing}_vertical_acceleration")
    rise = 10 * np.log10(rough.psd()[:, c].sum() / plain.psd()[:, c].sum())
    assert db - 3.0 < rise <= db + 1e-6, rise


def test_zero_roughness_renders_the_samples_of_a_case_without_the_key(cached_model, ball):
    zero = cached_model(Case.load("motor_6010_ball").with_overrides({"defects.0.roughness_db": 0.0}), like=ball)
    assert np.array_equal(_samples(_synth(zero)), _samples(_synth(ball)))
    rough = cached_model(Case.load("motor_6010_ball").with_overrides({"defects.0.roughness_db": 10.0}), like=ball)
    assert not np.array_equal(_samples(_synth(rough)), _samples(_synth(ball)))


def test_the_ground_truth_and_a_data_set_run_carry_it():
    case = Case.load("motor_6010_outer").with_overrides({"defects.0.roughness_db": 12.0})
    assert case.ground_truth()["defects"][0]["roughness_db"] == 12.0
    spec = DatasetSpec({"dataset": {"name": "r", "schema_version": 1, "case": "motor_6010_healthy",
                                    "sampling": "grid"},
                        "run": {"fault": "inner", "bearing": "de", "length_m": 1e-3, "depth_m": 2e-5,
                                "roughness_db": 9.0, "speed_hz": 25.0, "duration_s": 1.0, "seed": 1}},
                       source="test")
    assert spec.runs[0].params["roughness_db"] == 9.0


@pytest.mark.parametrize("value", [-1.0, 61.0, True, "loud"])
def test_a_bad_roughness_is_refused_by_name(value):
    with pytest.raises(CaseError) as e:
        Case.load("motor_6010_inner").with_overrides({"defects.0.roughness_db": value})
    assert "roughness_db" in str(e.value)
