"""Bundles store the calibrator; ``tzsl predict`` (and --json) report calibrated posteriors (simulated data)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from scipy.special import softmax

from tzsl.cli import cli
from tzsl.datasets import FeatureSet, write_feature_table
from tzsl.exceptions import ModelBundleError
from tzsl.inference.bundle import load_bundle, save_bundle
from tzsl.inference.bundle_kinds import ZERO_SHOT_KIND
from tzsl.inference.predict import read_class_table
from tzsl.inference.recogniser import predict_grasps
from tzsl.inference.zero_shot_bundles import load_predictor, save_model_bundle, save_zero_shot_bundle
from tzsl.models import CalibratedZeroShotClassifier, build_method

ATTRIBUTES = ["hard", "soft", "rough", "cold"]


def _features(seed: int, rows: pd.DataFrame, n_trials: int) -> FeatureSet:
    """One-sensor trials whose 6 features are a noisy linear image of the object's attribute row."""
    rng = np.random.default_rng(seed)
    objects = [o for o in rows.index for _ in range(n_trials)]
    mix = np.random.default_rng(99).normal(size=(len(ATTRIBUTES), 6))
    X = rows.loc[objects].to_numpy(float) @ mix + rng.normal(0, 1.0, (len(objects), 6))
    trials = pd.DataFrame({"trial_id": [f"{o}_{i % n_trials}" for i, o in enumerate(objects)],
                           "object_id": [list(rows.index).index(o) for o in objects], "object_name": objects,
                           "trial_index": [i % n_trials for i in range(len(objects))]})
    return FeatureSet(X=X[:, None, :], trials=trials, sensors=("finger_0",),
                      feature_names=tuple(f"f{i}" for i in range(6)), attributes=rows, dataset="simulated")


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    root = tmp_path_factory.mktemp("calibrated")
    rng = np.random.default_rng(0)
    rows = pd.DataFrame(np.unique(rng.integers(0, 2, (40, 4)), axis=0)[:14], columns=ATTRIBUTES,
                        index=pd.Index([f"o{i}" for i in range(14)], name="object_name"))
    train = _features(0, rows.iloc[:10], 8)
    clf = build_method("eszsl", gammas=(0.5,), lams=(2.0,), random_state=0)
    assert isinstance(clf, CalibratedZeroShotClassifier)
    clf.fit(train.X[:, 0], train.trial_attributes(), train.objects)
    path = save_zero_shot_bundle(root / "eszsl.tzsl", clf, train, method="eszsl", ndim=2)
    test = _features(1, rows.iloc[10:], 3)
    write_feature_table(test, root / "test.npz")
    classes = root / "classes.csv"
    rows.iloc[10:].rename_axis("class").reset_index().to_csv(classes, index=False)
    return root, clf, test, path, classes


def test_bundle_stores_the_calibrator_and_predict_uses_it(bundle):
    root, clf, test, path, classes = bundle
    payload, _ = load_bundle(path)
    assert payload["calibration"]["temperature"] == pytest.approx(clf.temperature_)
    predictor = load_predictor(path)
    report = predictor.calibration_report()
    assert report["calibrated"] and report["method"] == "temperature" and report["n_folds"] == 3
    assert report["n_classes"] == 10 and "training objects" in report["fitted_on"]
    assert "calibrated (temperature" in predictor.describe()
    K = read_class_table(classes, predictor.attribute_names)
    pred = predict_grasps(predictor, K, [root / "test.npz"])
    np.testing.assert_allclose(pred.grasp_posteriors, clf.predict_proba(test.X[:, 0], K.to_numpy(float)))
    assert clf.temperature_ != pytest.approx(1.0, abs=1e-3)  # the test would not tell the two apart otherwise
    assert not np.allclose(pred.grasp_posteriors, clf.predict_proba_uncalibrated(test.X[:, 0], K.to_numpy(float)))
    df = predict_grasps(predictor, K, [root / "test.npz"], mode="df")
    assert df.final_posteriors.shape == (4,) and df.final_posteriors.sum() == pytest.approx(1.0)


def test_old_bundle_without_calibrator_loads_and_says_uncalibrated(bundle, tmp_path):
    root, clf, test, path, classes = bundle
    _, meta = load_bundle(path)
    old = save_model_bundle(tmp_path / "old.tzsl", clf.estimator_, clf.estimator_.decision_rule_, method="eszsl",
                            attribute_names=meta["attribute_names"], input_schema=meta["input"])
    predictor = load_predictor(old)
    assert predictor.calibration is None and not predictor.calibration_report()["calibrated"]
    assert "uncalibrated" in predictor.calibration_report()["reason"] and "uncalibrated" in predictor.describe()
    K = read_class_table(classes, predictor.attribute_names)
    pred = predict_grasps(predictor, K, [root / "test.npz"])
    np.testing.assert_allclose(pred.grasp_posteriors,
                               softmax(clf.decision_function(test.X[:, 0], K.to_numpy(float)), axis=1))


@pytest.mark.parametrize("stored", ["arrays", "estimator"])
def test_bad_calibration_payload_is_refused(bundle, tmp_path, stored):
    _, clf, _, path, _ = bundle
    payload, meta = load_bundle(path)
    meta.pop("bundle")
    assert meta and set(payload) == {"linear", "rule", "estimator", "calibration"}  # ESZSL: stored as arrays
    if stored == "arrays":
        bad = {**payload, "calibration": {"temperature": np.asarray(-1.0)}}
    else:  # the skops layout of every other model
        bad = {"model": clf.estimator_, "decision_rule": clf.estimator_.decision_rule_,
               "calibration": {"temperature": -1.0}}
    save_bundle(tmp_path / "bad.tzsl", bad, kind=ZERO_SHOT_KIND, metadata=meta)
    with pytest.raises(ModelBundleError, match="positive temperature"):
        load_predictor(tmp_path / "bad.tzsl")


def test_predict_json_reports_calibrated_probabilities_and_the_fit(bundle):
    root, clf, test, path, classes = bundle
    result = CliRunner().invoke(cli, ["predict", "--model", str(path), "--classes", str(classes), "--json",
                                      "--top", "0", str(root / "test.npz")])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["calibration"]["calibrated"] and report["calibration"]["temperature"] == pytest.approx(
        clf.temperature_)
    assert report["calibration"]["n_folds"] == 3 and report["model"]["method"] == "eszsl"
    first = report["grasps"][0]["ranking"]
    assert len(first) == 4 and sum(r["probability"] for r in first) == pytest.approx(1.0)
    K = pd.read_csv(classes, index_col=0).to_numpy(float)
    expected = clf.predict_proba(test.X[:1, 0], K)[0]
    assert first[0]["probability"] == pytest.approx(expected.max())
