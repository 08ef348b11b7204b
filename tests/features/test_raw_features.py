"""Per-BioTac 104-d vectors from raw trials, and the real-data cross-check with Penn."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from tzsl.exceptions import DataFileError
from tzsl.features import RawTrialFeatures


def test_shape_names_and_hand_values(make_trial, four_ep):
    trials = [
        make_trial(four_ep()),
        make_trial(four_ep(pre=120, lengths=(7, 9, 11, 13)), trial_id="car_sponge_101_02"),
    ]
    est = RawTrialFeatures()
    X = est.fit_transform(trials)
    assert X.shape == (2, 2, 104)
    names = list(est.get_feature_names_out())
    assert len(names) == 104 and len(set(names)) == 104
    assert names[:4] == ["squeeze:pdc", "squeeze:pac", "squeeze:tac", "squeeze:tdc"]
    assert names[22] == "squeeze:e19" and names[23] == "hold:pdc" and names[91] == "fast_slide:e19"
    assert names[92:95] == ["squeeze:aperture_min", "squeeze:aperture_mean", "squeeze:tool_z_drop"]
    # After removing the baseline (first 100 rows, mean row 49.5) every channel of
    # finger f is (EP mean row - 49.5) times 1 (pdc, electrodes), 10 (pac), 2 (tdc), 0 (tac).
    d = np.array([104.5, 119.5, 144.5, 179.5]) - 49.5
    biotac = X[0, :, :92].reshape(2, 4, 23)
    for f in (0, 1):
        np.testing.assert_allclose(biotac[f, :, 0], d)
        np.testing.assert_allclose(biotac[f, :, 1], 10 * d)
        np.testing.assert_allclose(biotac[f, :, 2], 0.0)
        np.testing.assert_allclose(biotac[f, :, 3], 2 * d)
        np.testing.assert_allclose(biotac[f, :, 4:], np.repeat(d[:, None], 19, axis=1))
    # gripper block: same for both fingers; hold = rows 110..129
    np.testing.assert_array_equal(X[:, 0, 92:], X[:, 1, 92:])
    np.testing.assert_allclose(X[0, 0, 95:98], [0.08 - 0.0129, 0.08 - 0.01195, 0.019], rtol=1e-12)
    # second trial: squeeze rows 120..126 (mean 123) with the same baseline
    np.testing.assert_allclose(X[1, 0, 0], 123 - 49.5)


def test_hold_only_and_params(make_trial):
    trial = make_trial(["HOLD_FOR_10_SECONDS"] * 1000, tool_z=False)
    est = RawTrialFeatures(eps=("hold",))
    X = est.fit_transform([trial])
    assert X.shape == (1, 2, 26) and est.travel_ == "aperture"
    np.testing.assert_allclose(X[0, 0, 0], 499.5 - 49.5)
    assert clone(est).get_params() == {"eps": ("hold",), "baseline_rows": 100, "travel": "auto"}
    with pytest.raises(NotFittedError):
        RawTrialFeatures().transform([trial])


def test_bad_inputs_name_file_and_trial(make_trial, four_ep):
    good = make_trial(four_ep())
    est = RawTrialFeatures().fit([good])
    # fewer than 100 rows
    short = make_trial(four_ep(pre=20, lengths=(10, 10, 10, 10)), source="/d/short.h5")
    with pytest.raises(DataFileError, match=r"/d/short\.h5, trial car_sponge_101_01: .*65 rows"):
        est.transform([good, short])
    # an EP absent
    no_slide = make_trial(four_ep()[:130], trial_id="car_sponge_101_07")
    with pytest.raises(DataFileError) as err:
        est.transform([no_slide])
    assert "car_sponge_101_07" in str(err.value) and "'slow_slide'" in str(err.value)
    assert err.value.path == "/data/test.h5"
    # NaN in a signal, inf in the aperture
    nan_trial = make_trial(four_ep(), dtype=np.float64)
    electrodes = nan_trial.fingers[0].electrodes.copy()
    electrodes[150, 3] = np.nan
    nan_trial = dataclasses.replace(
        nan_trial, fingers=(dataclasses.replace(nan_trial.fingers[0], electrodes=electrodes),
                            nan_trial.fingers[1]))
    with pytest.raises(DataFileError, match="finger_0/electrodes holds NaN/inf"):
        est.transform([nan_trial])
    aperture = good.gripper_aperture.copy()
    aperture[-1] = -np.inf
    with pytest.raises(DataFileError, match="gripper_aperture holds NaN/inf"):
        est.transform([dataclasses.replace(good, gripper_aperture=aperture)])
    # a missing finger
    with pytest.raises(DataFileError, match="1 BioTacs; expected 2"):
        est.transform([make_trial(four_ep(), n_fingers=1)])
    # empty trial list
    with pytest.raises(DataFileError, match="no trials"):
        RawTrialFeatures().fit([])


@pytest.mark.realdata
def test_hold_mat_gripper_matches_penn_static_features(hold_trials, penn_data):
    """Real cross-check of two independent sources (PROVENANCE.md section 5)."""
    assert len(hold_trials) == 60
    est = RawTrialFeatures(eps=("hold",))
    X = est.fit_transform(hold_trials)
    assert X.shape == (60, 2, 26)
    names = list(est.get_feature_names_out())
    i_min, i_mean = names.index("hold:aperture_min"), names.index("hold:aperture_mean")
    rows = penn_data.trials["trial_id"].tolist()
    idx = [rows.index(t.trial_id) for t in hold_trials]
    hold = list(penn_data.eps).index("hold")
    penn = penn_data.X[idx, hold]
    for f in (0, 1):
        np.testing.assert_allclose(X[:, f, i_min], penn[:, 20], rtol=0, atol=1e-9)
        np.testing.assert_allclose(X[:, f, i_mean], penn[:, 21], rtol=0, atol=1e-9)
    assert np.isfinite(X).all()
    # BioTac averages relative to the first second of the hold are small but not all zero
    assert np.abs(X[:, :, :23]).max() > 0


def test_release_layout_hdf5_round_trip(make_trial, four_ep, tmp_path):
    """Trials written in the PHAC-2 release layout and read back give the same 104-d vectors."""
    from tzsl.datasets import load_phac2_h5, write_phac2_h5

    trials = [
        make_trial(four_ep(), trial_id="car_sponge_101_01"),
        make_trial(four_ep(pre=110, lengths=(12, 25, 31, 44)), trial_id="car_sponge_101_02"),
    ]
    path = write_phac2_h5(tmp_path / "phac2.h5", trials)
    back = load_phac2_h5(path)
    assert [t.trial_id for t in back] == ["car_sponge_101_01", "car_sponge_101_02"]
    est = RawTrialFeatures()
    X_back = est.fit_transform(back)
    assert est.travel_ == "tool_z"
    np.testing.assert_allclose(X_back, RawTrialFeatures().fit_transform(trials), rtol=0, atol=1e-12)
    # slow slide of trial 2: rows 147..177, tool_z = 1 - 0.001 r drops 30 mm
    names = list(est.get_feature_names_out())
    np.testing.assert_allclose(X_back[1, 0, names.index("slow_slide:tool_z_drop")], 0.030, rtol=1e-12)
