"""Loader output -> FeatureSet (Penn static and raw trials)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import TRIAL_COLUMNS, FeatureSet
from tzsl.exceptions import DataFileError
from tzsl.features import penn_feature_set, raw_feature_set

EPS = ("squeeze", "hold", "slow_slide", "fast_slide")


def _labels(objects, rows):
    return pd.DataFrame(rows, index=pd.Index(objects, name="object_name"),
                        columns=["hard", "soft", "rare"])


def test_raw_feature_set(make_trial, four_ep):
    trials = [
        make_trial(four_ep(), trial_id=f"{obj}_{k:02d}", object_name=obj, source=f"/d/{obj}.h5")
        for obj in ("foam_101", "block_701", "vase_702", "cup_703")
        for k in (1, 2)
    ]
    labels = _labels(
        ["foam_101", "block_701", "vase_702", "cup_703", "unused_999"],
        [[0, 1, 0], [1, 0, 1], [1, 0, 0], [1, 0, 0], [0, 1, 1]],
    )
    fs = raw_feature_set(trials, labels, min_objects=3)
    assert isinstance(fs, FeatureSet)
    assert fs.X.shape == (8, 2, 104) and fs.sensors == ("finger_0", "finger_1")
    assert len(fs.feature_names) == 104 and fs.feature_names[23] == "hold:pdc"
    assert list(fs.trials.columns[:4]) == list(TRIAL_COLUMNS)
    assert fs.trials["trial_id"].tolist()[:2] == ["foam_101_01", "foam_101_02"]
    assert fs.trials["object_id"].tolist()[::2] == [101, 701, 702, 703]
    assert fs.trials["source"].iloc[0] == "/d/foam_101.h5"
    # counted over the 4 objects with trials: hard 3 (kept), soft 1, rare 1 (the unused
    # object's positives do not count)
    assert list(fs.attributes.columns) == ["hard"]
    assert list(fs.attributes.index) == ["foam_101", "block_701", "vase_702", "cup_703"]
    assert fs.info["dropped_attributes"] == ["soft", "rare"]
    assert fs.info["travel"] == "tool_z" and fs.info["eps"] == list(EPS)
    assert fs.n_objects == 4 and fs.trial_attributes().shape == (8, 1)
    assert fs.dataset == "phac2-raw"


def test_raw_feature_set_errors(make_trial, four_ep):
    labels = _labels(["foam_101"], [[1, 0, 0]])
    orphan = make_trial(four_ep(), trial_id="vase_702_03", object_name="vase_702", source="/d/v.h5")
    with pytest.raises(DataFileError) as err:
        raw_feature_set([make_trial(four_ep(), object_name="foam_101", trial_id="foam_101_01"), orphan],
                        labels)
    msg = str(err.value)
    assert "/d/v.h5" in msg and "vase_702_03" in msg and "'vase_702' has no row" in msg
    twice = make_trial(four_ep(), object_name="foam_101", trial_id="foam_101_01")
    with pytest.raises(DataFileError, match="occurs twice"):
        raw_feature_set([twice, twice], labels)
    with pytest.raises(DataFileError, match="no trials"):
        raw_feature_set([], labels)
    bad_labels = labels.astype(float)
    bad_labels.iloc[0, 1] = 0.5
    with pytest.raises(DataFileError, match="attribute 'soft' of object 'foam_101' is 0.5"):
        raw_feature_set([twice], bad_labels)
    with pytest.raises(DataFileError, match="'squeeze'.*'slow_slide'.*'fast_slide'.* is absent"):
        raw_feature_set([make_trial(["HOLD_FOR_10_SECONDS"] * 200, object_name="foam_101",
                                    trial_id="foam_101_01")], labels)


def _fake_penn(n_objects=4, per=2):
    objects = [f"obj_{100 + i}" for i in range(n_objects)]
    trials = pd.DataFrame({
        "trial_id": [f"{o}_{k:02d}" for o in objects for k in range(1, per + 1)],
        "object_id": [100 + i for i in range(n_objects) for _ in range(per)],
        "object_name": [o for o in objects for _ in range(per)],
        "trial_index": [k for _ in objects for k in range(1, per + 1)],
    })
    X = np.arange(n_objects * per * 4 * 47, dtype=float).reshape(-1, 4, 47)
    labels = _labels(objects, [[1, 0, 0]] * (n_objects - 1) + [[0, 1, 1]])
    return SimpleNamespace(X=X, trials=trials, eps=EPS, labels=labels)


def test_penn_feature_set_synthetic():
    data = _fake_penn()
    fs = penn_feature_set(data, min_objects=2)
    assert fs.X.shape == (8, 2, 52) and fs.dataset == "phac2-penn"
    assert fs.X[3, 1, 13 + 2] == data.X[3, 1, 5]  # hold:pdc_max of finger 1
    assert list(fs.attributes.columns) == ["hard"] and fs.info["dropped_attributes"] == ["soft", "rare"]
    assert fs.info["penn_dropped_columns"] == list(range(23, 47))
    data.labels = data.labels.drop(index="obj_102")
    with pytest.raises(DataFileError, match="1 object\\(s\\) have trials but no row.*'obj_102'"):
        penn_feature_set(data)
    data = _fake_penn()
    data.trials = data.trials.drop(columns="trial_index")
    with pytest.raises(DataFileError, match="lacks the columns \\['trial_index'\\]"):
        penn_feature_set(data)


@pytest.mark.realdata
def test_penn_feature_set_real(penn_data):
    fs = penn_feature_set(penn_data)
    assert fs.X.shape == (600, 2, 52)
    assert fs.n_objects == 60 and fs.attributes.shape == (60, 19)
    assert fs.info["dropped_attributes"] == ["crinkly", "nice", "sticky", "thin", "unpleasant"]
    assert fs.feature_names[13 + 2] == "hold:pdc_max"
    assert np.isfinite(fs.X).all()


@pytest.mark.realdata
def test_raw_feature_set_real_hold(hold_trials, phac2_labels, penn_data):
    fs = raw_feature_set(hold_trials, phac2_labels, eps=("hold",), dataset="phac2-hold-mat")
    assert fs.X.shape == (60, 2, 26) and fs.n_objects == 6
    assert fs.info["travel"] == "aperture"
    # HOLD-only: 6 objects, so only adjectives of >= 3 of these 6 objects stay
    counts = phac2_labels.loc[fs.attributes.index].sum()
    assert set(fs.attributes.columns) == set(counts[counts >= 3].index)
    assert set(fs.info["dropped_attributes"]) == set(counts[counts < 3].index)
    # same trials, same gripper numbers as the Penn features (the cross-check through the set)
    penn = penn_feature_set(penn_data)
    pos = pd.Index(penn.trials["trial_id"]).get_indexer(fs.trials["trial_id"])
    assert (pos >= 0).all()
    for name, penn_name in (("hold:aperture_min", "hold:gripper_min"),
                            ("hold:aperture_mean", "hold:gripper_mean")):
        a = fs.X[:, 0, fs.feature_names.index(name)]
        b = penn.X[pos, 0, penn.feature_names.index(penn_name)]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
