"""The PHAC-2 DAP study on a small synthetic problem (fast) and its table logic."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tests.study_settings import study_settings
from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split
from tzsl.models.dap import dap_log_scores
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.papers.run_labels import StudyLabels
from tzsl.studies.zero_shot.study import (
    SplitPosteriors,
    attribute_bank,
    attribute_subsets,
    attribute_sweep,
    fit_split,
    run_zero_shot_tables,
    table1_fusion,
    table2_priors,
)

TINY_SVM = {"n_C": 2, "n_gamma": 2, "n_draws": 1, "cv": 3}


def synthetic_features(n_objects: int = 24, n_attributes: int = 6, trials: int = 4, seed: int = 0) -> FeatureSet:
    """Objects whose 2-sensor features encode their attribute rows plus noise."""
    rng = np.random.default_rng(seed)
    A = rng.integers(0, 2, size=(n_objects, n_attributes))
    A[: n_attributes, :] = np.eye(n_attributes, dtype=int)  # every attribute has positives
    A[n_attributes : 2 * n_attributes, :] = 1 - np.eye(n_attributes, dtype=int)
    names = [f"obj_{i:03d}" for i in range(n_objects)]
    W = rng.normal(size=(2, n_attributes, 5))
    X = np.einsum("om,smd->osd", A.astype(float), W)
    X = np.repeat(X, trials, axis=0) + 0.3 * rng.normal(size=(n_objects * trials, 2, 5))
    trial_table = pd.DataFrame({
        "trial_id": [f"{o}_{t + 1:02d}" for o in names for t in range(trials)],
        "object_id": np.repeat(np.arange(n_objects), trials),
        "object_name": np.repeat(names, trials),
        "trial_index": np.tile(np.arange(1, trials + 1), n_objects),
    })
    attrs = pd.DataFrame(A, index=pd.Index(names, name="object_name"), columns=[f"a{j}" for j in range(n_attributes)])
    return FeatureSet(X=X, trials=trial_table, sensors=("finger_0", "finger_1"),
                      feature_names=tuple(f"f{i}" for i in range(5)), attributes=attrs, dataset="synthetic")


def _config(**kw) -> ZeroShotSettings:
    base = dict(n_splits=2, n_test=5, progress=False, svm_params=dict(TINY_SVM), multilabel=False,
                sweep_min_attributes=3, sweep_max_subsets=20)
    base.update(kw)
    return study_settings(ZeroShotSettings, "phac2-dap", **base)


def test_paper_columns_only_on_the_papers_dataset_and_protocol(tmp_path):
    """A run labelled generic (any dataset but the paper's) carries no paper_* column (issue 20)."""
    tables = run_zero_shot_tables(synthetic_features(), ResultsDir(tmp_path), _config(n_test=8, sweep=True))
    for name in ("table1_fusion", "table2_priors", "attribute_accuracy"):
        assert not [c for c in tables[name].columns if c.startswith("paper")], name


def test_study_writes_every_table_with_paper_columns(tmp_path):
    features = synthetic_features()
    out = ResultsDir(tmp_path)
    # 8 test objects: the control never draws the identity, which moves it off chance by < 1/8!
    tables = run_zero_shot_tables(features, out, _config(n_test=8, sweep=True),
                                  labels=StudyLabels(study="phac2", paper=True))
    for name in ("table1_fusion", "table2_priors", "attribute_accuracy", "attribute_sweep"):
        assert (tmp_path / f"{name}.csv").exists()
    assert (tmp_path / "attribute_accuracy.png").exists() and (tmp_path / "attribute_sweep.png").exists()
    t1 = tables["table1_fusion"]
    assert list(t1["split"]) == ["1", "2", "mean", "std", "control"]
    assert {"maxdap", "avgdap", "paper_maxdap", "paper_avgdap", "chance", "avgdap_ci95_low",
            "avgdap_ci95_high", "maxdap_ci95_low", "avgdap_per_class_mean_ci95_high"} <= set(t1.columns)
    mean = t1[t1["split"] == "mean"].iloc[0]
    assert mean["avgdap_ci95_low"] <= mean["avgdap"] <= mean["avgdap_ci95_high"]
    # the negative control (rows shuffled among test objects) is at chance within its interval
    control = t1[t1["split"] == "control"].iloc[0]
    for column in ("maxdap", "avgdap", "avgdap_per_class_mean"):
        assert control[f"{column}_ci95_low"] <= control["chance"] <= control[f"{column}_ci95_high"], column
        assert control[column] < mean[column]
    assert control["chance"] == pytest.approx(1 / 8)
    assert "majority" not in t1.columns  # every test object has 4 trials: balanced, majority = chance
    assert pd.isna(t1.loc[t1["split"] == "std", "avgdap_ci95_low"]).all()
    # every split scored is written in the --splits format and reads back equal; the manifest lists its classes
    from tzsl.evaluation import read_splits_csv

    back = read_splits_csv(tmp_path / "splits.csv", features.attributes)
    assert [(b.name, b.train_objects, b.test_objects, b.kept_attributes) for b in back] == [
        (n, tuple(v["train"]), tuple(v["test"]), tuple(v["attributes"])) for n, v in out.splits.items()]
    assert len(back) == 2 and all(len(b.test_objects) == 8 for b in back)
    import json

    manifest = json.loads(out.write_manifest({}, data_files=[tmp_path / "table1_fusion.csv"]).read_text())
    assert manifest["splits"]["random-1"]["test"] == list(back[0].test_objects)
    assert len(manifest["data_files"][str(tmp_path / "table1_fusion.csv")]) == 64
    assert "splits.csv" in manifest["outputs"]
    att = tables["attribute_accuracy"]
    assert list(att.columns[:4]) == ["attribute", "balanced_accuracy", "balanced_accuracy_ci95_low",
                                     "balanced_accuracy_ci95_high"]
    assert {"majority", "majority_balanced_accuracy", "accuracy_ci95_low"} <= set(att.columns)
    assert (att["balanced_accuracy_ci95_low"] <= att["balanced_accuracy"] + 1e-12).all()
    assert (att["balanced_accuracy"] <= att["balanced_accuracy_ci95_high"] + 1e-12).all()
    per = tables["attribute_accuracy_per_split"]
    defined = per["balanced_accuracy"].notna()
    assert (per.loc[defined, "balanced_accuracy_ci95_low"] <= per.loc[defined, "balanced_accuracy"] + 1e-12).all()
    assert (per["accuracy_ci95_low"] <= per["accuracy"] + 1e-12).all() and "majority" in per.columns
    assert t1.loc[t1["split"] == "mean", "paper_avgdap"].item() == pytest.approx(0.39)
    # the attributes are linearly encoded: recognition must be far above chance (1/8)
    assert t1.loc[t1["split"] == "mean", "avgdap"].item() > 0.5
    t2 = tables["table2_priors"]
    assert {"uni", "test", "train", "paper_uni", "paper_test", "paper_train"} <= set(t2.columns)


def test_study_refuses_to_overwrite(tmp_path):
    features = synthetic_features()
    run_zero_shot_tables(features, ResultsDir(tmp_path), _config(n_splits=1))
    from tzsl.exceptions import ConfigError

    with pytest.raises(ConfigError, match="--force"):
        run_zero_shot_tables(features, ResultsDir(tmp_path), _config(n_splits=1))


def test_test_objects_do_not_influence_the_fit(monkeypatch):
    """Scrambling every test object's features changes nothing the model learnt."""
    monkeypatch.delenv("TZSL_CACHE_DIR")  # both fits must really run, not come from the cache
    features = synthetic_features()
    objects = list(features.attributes.index)
    split = Split(name="random-1", train_objects=tuple(objects[5:]), test_objects=tuple(objects[:5]),
                  attributes=tuple(features.attributes.columns))
    config = _config()
    first = fit_split(features, split, config, 0)
    test = np.isin(features.objects, split.test_objects)
    scrambled_X = features.X.copy()
    scrambled_X[test] = np.random.default_rng(1).normal(size=scrambled_X[test].shape) * 50
    scrambled = FeatureSet(X=scrambled_X, trials=features.trials, sensors=features.sensors,
                           feature_names=features.feature_names, attributes=features.attributes)
    second = fit_split(scrambled, split, config, 0)
    assert not np.allclose(first.P, second.P)  # the test inputs did change ...
    np.testing.assert_array_equal(first.train_prior, second.train_prior)
    # ... but the model fitted beside scrambled test objects scores the real test trials identically
    np.testing.assert_allclose(second.model.predict_proba(features.X[test]), first.P, rtol=0, atol=1e-12)


def _posteriors() -> SplitPosteriors:
    P = np.array([[[0.9, 0.2], [0.7, 0.4]],
                  [[0.1, 0.8], [0.3, 0.6]],
                  [[0.6, 0.6], [0.2, 0.9]]])  # (3 trials, 2 sensors, 2 attributes)
    K = np.array([[1, 0], [0, 1], [1, 1]])
    split = Split(name="random-1", train_objects=("x",), test_objects=("a", "b", "c"), attributes=("h", "s"))
    return SplitPosteriors(split=split, attributes=("h", "s"), P=P, K=K, y=np.array([0, 1, 2]),
                           train_prior=np.array([0.25, 0.5]))


def test_split_posteriors_score_matches_hand_computation():
    r = _posteriors()
    # AVGDAP, uni prior: fused p = mean over sensors
    fused = r.P.mean(axis=1)
    expected = dap_log_scores(fused, r.K, np.full(2, 0.5)).argmax(axis=1)
    np.testing.assert_array_equal(r.predict("avg", "uni"), expected)
    # trial 3: fused (0.4, 0.75) -> classes: [1,0]: 0.4*0.25, [0,1]: 0.6*0.75, [1,1]: 0.4*0.75 -> class 1
    assert r.predict("avg", "uni")[2] == 1
    # train prior 0.25 for attribute h makes class [1,1] win for trial 3: 0.4/0.25 * 0.75/0.5 = 2.4 > 0.6/0.75*1.5
    assert r.predict("avg", "train")[2] == 2
    t1 = table1_fusion([r])
    assert t1.loc[t1["split"] == "1", "avgdap"].item() == pytest.approx(r.accuracy("avg", "uni"))
    t2 = table2_priors([r])
    assert t2.loc[t2["split"] == "1", "train"].item() == pytest.approx(r.accuracy("avg", "train"))


def test_attribute_subsets_are_distinct_and_bounded():
    rng = np.random.default_rng(0)
    all_small = attribute_subsets(5, 3, 1000, rng)
    assert all_small.shape == (10, 3)
    many = attribute_subsets(19, 9, 1000, rng)
    assert many.shape == (1000, 9)
    assert len({tuple(r) for r in many.tolist()}) == 1000
    assert (np.diff(many, axis=1) > 0).all()


def test_sweep_full_set_equals_split_accuracy():
    r = _posteriors()
    sweep = attribute_sweep([r], min_attributes=1, max_subsets=10)
    full = sweep[(sweep["split"] == "1") & (sweep["n_attributes"] == 2)]
    assert full["accuracy_mean"].item() == pytest.approx(r.accuracy("avg", "uni"))
    assert set(sweep["split"]) == {"1", "mean"}
    assert (sweep["ci95_low"] <= sweep["accuracy_mean"] + 1e-9).all()
    assert (sweep["accuracy_mean"] <= sweep["ci95_high"] + 1e-9).all()
    assert sweep["chance"].eq(1 / 3).all()


def test_dask_cluster_gives_the_local_results():
    """The study's --backend dask path (a local Dask cluster of worker processes) equals loky."""
    pytest.importorskip("dask.distributed")
    from tzsl.studies.zero_shot.study import fit_splits, make_splits

    features = synthetic_features()
    local = _config(n_splits=1, cache=False, n_jobs=2)
    splits, _ = make_splits(features, "random", local)
    on_dask = fit_splits(features, splits, _config(n_splits=1, cache=False, n_jobs=2, backend="dask"))
    on_loky = fit_splits(features, splits, local)
    np.testing.assert_array_equal(on_dask[0].P, on_loky[0].P)
    assert on_dask[0].accuracy("avg", "uni") == on_loky[0].accuracy("avg", "uni")


def test_cache_false_turns_the_fit_store_off_even_with_a_cache_folder_set(tmp_path, monkeypatch):
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "cache"))
    assert attribute_bank(_config(cache=False), ["hard"], 0).memory is False
    assert attribute_bank(_config(), ["hard"], 0).memory == str(tmp_path / "cache")
