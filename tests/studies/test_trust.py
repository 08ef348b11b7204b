"""Intervals and baselines added to every accuracy table (tzsl.evaluation._trust) and the PHAC-2 table views."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.evaluation import (
    Outcomes,
    Split,
    add_trust_columns,
    attribute_intervals,
    bootstrap_accuracy,
    summarise_over_splits,
)
from tzsl.studies.zero_shot.study import SplitPosteriors, table3_challenging


def _two_splits(unbalanced: bool = False):
    rng = np.random.default_rng(0)
    outcomes, rows = Outcomes(), []
    for split in ("1", "2"):
        classes = np.repeat(np.arange(5), [12, 3, 3, 3, 3] if unbalanced else 6)
        correct = rng.random(len(classes)) < 0.6
        outcomes.add(split, "accuracy", classes, correct)
        rows.append({"split": split, "accuracy": correct.mean()})
    return outcomes, summarise_over_splits(pd.DataFrame(rows)).reset_index()


def test_single_column_gets_plain_interval_names_and_the_mean_row_is_two_level():
    outcomes, table = _two_splits()
    out = add_trust_columns(table, outcomes)
    assert list(out.columns) == ["split", "accuracy", "ci95_low", "ci95_high", "chance"]
    rec = outcomes.records
    one = bootstrap_accuracy(rec[0].correct, classes=rec[0].classes)
    row1 = out[out["split"] == "1"].iloc[0]
    assert (row1["ci95_low"], row1["ci95_high"]) == pytest.approx((one.ci95_low, one.ci95_high))
    both = bootstrap_accuracy(np.concatenate([r.correct for r in rec]),
                              classes=np.concatenate([r.classes for r in rec]), splits=np.repeat([0, 1], 30))
    mean = out[out["split"] == "mean"].iloc[0]
    assert (mean["ci95_low"], mean["ci95_high"]) == pytest.approx((both.ci95_low, both.ci95_high))
    assert mean["ci95_low"] < mean["accuracy"] < mean["ci95_high"]
    assert out["chance"].iloc[:3].tolist() == pytest.approx([0.2] * 3)
    assert out[out["split"] == "std"][["ci95_low", "ci95_high"]].isna().all().all()


def test_majority_column_only_where_classes_are_unbalanced():
    outcomes, table = _two_splits(unbalanced=True)
    out = add_trust_columns(table, outcomes)
    assert out.loc[out["split"] == "1", "majority"].item() == pytest.approx(12 / 24)
    assert out.loc[out["split"] == "mean", "majority"].item() == pytest.approx(0.5)
    outcomes, table = _two_splits()
    assert "majority" not in add_trust_columns(table, outcomes).columns


def test_attribute_intervals_bracket_the_point_and_balanced_is_near_half_for_a_majority_guess():
    rng = np.random.default_rng(1)
    classes = np.repeat(np.arange(10), 5)
    truth = np.repeat(rng.integers(0, 2, size=(10, 3)), 5, axis=0)
    truth[:5, :] = 1
    truth[5:10, :] = 0  # both values present in every attribute
    iv = attribute_intervals(np.ones_like(truth, dtype=float), truth, classes, np.zeros(50))
    assert iv["accuracy_low"] == pytest.approx(np.ones(4)) and iv["balanced_high"] == pytest.approx(np.ones(4))
    always_one = truth.astype(float)  # predicting 1 everywhere: right exactly on positives
    iv = attribute_intervals(always_one, truth, classes, np.zeros(50), n_boot=500)
    assert np.all(iv["balanced_low"] <= 0.5 + 1e-12) and np.all(iv["balanced_high"] >= 0.5 - 1e-12)


def _posteriors(name: str) -> SplitPosteriors:
    P = np.array([[[0.9, 0.2], [0.7, 0.4]], [[0.1, 0.8], [0.3, 0.6]], [[0.6, 0.6], [0.2, 0.9]]])
    split = Split(name=name, train_objects=("x",), test_objects=("a", "b", "c"), attributes=("h", "s"))
    return SplitPosteriors(split=split, attributes=("h", "s"), P=np.repeat(P, 2, axis=0),
                           K=np.array([[1, 0], [0, 1], [1, 1]]), y=np.repeat([0, 1, 2], 2),
                           train_prior=np.array([0.25, 0.5]))


def test_table3_has_both_fusions_intervals_control_and_paper_mean_only():
    t3 = table3_challenging([_posteriors("challenging-1"), _posteriors("challenging-2")], paper=True)
    assert list(t3["split"]) == ["1", "2", "mean", "std", "control"]
    assert {"maxdap", "avgdap", "maxdap_ci95_low", "avgdap_ci95_high", "chance"} <= set(t3.columns)
    assert not {"paper_n_objects", "paper_chance", "paper_maxdap"} & set(t3.columns)
    assert t3["paper_avgdap"].notna().tolist() == [False, False, True, False, False]
    assert t3.loc[t3["split"] == "mean", "paper_avgdap"].item() == pytest.approx(0.24)


def test_a_single_object_split_is_left_out_of_the_control():
    one = _posteriors("challenging-3")
    one = SplitPosteriors(split=Split(name="challenging-3", train_objects=("x",), test_objects=("a",),
                                      attributes=("h", "s")), attributes=("h", "s"), P=one.P[:2],
                          K=one.K[:1], y=np.zeros(2, dtype=int), train_prior=one.train_prior)
    t3 = table3_challenging([_posteriors("challenging-1"), one])
    assert t3.loc[t3["split"] == "3", "chance"].item() == 1.0
    assert t3.loc[t3["split"] == "control", "chance"].item() == pytest.approx(1 / 3)  # split 1 only
    assert list(table3_challenging([one])["split"]) == ["3", "mean", "std"]


def test_splits_written_to_a_results_folder_read_back_exactly_with_their_rule(tmp_path):
    import json

    from tests.studies.test_phac2_dap import synthetic_features
    from tzsl.evaluation import read_splits_csv
    from tzsl.studies.config import ZeroShotSettings
    from tzsl.studies.outputs.results_folder import ResultsDir
    from tzsl.studies.zero_shot.study import make_splits

    features = synthetic_features(n_objects=40, n_attributes=6, trials=2)
    config = ZeroShotSettings.of_preset("phac2-dap", splits={"n_splits": 2, "n_test": 5}, compute={"progress": False})
    splits = make_splits(features, "random", config)[0] + make_splits(features, "challenging", config)[0]
    out = ResultsDir(tmp_path)
    out.write_splits("splits.csv", splits)
    back = read_splits_csv(tmp_path / "splits.csv", features.attributes)  # reader default: the random rule
    assert [(s.name, s.train_objects, s.test_objects, s.kept_attributes, s.min_train_positives) for s in back] == [
        (s.name, s.train_objects, s.test_objects, s.kept_attributes, s.min_train_positives) for s in splits]
    assert {s.min_train_positives for s in back if s.kind == "challenging"} == {3}
    manifest = json.loads(out.write_manifest({}).read_text())
    assert set(manifest["splits"]) == {s.name for s in splits}
    assert manifest["splits"][splits[-1].name]["test"] == list(splits[-1].test_objects)
    assert "splits.csv" in manifest["outputs"]


@pytest.mark.parametrize("scored", [("avg", "uni", False, "trial"), ("max", "test", False, "trial"),
                                    ("avg", "train", False, "trial")])
def test_the_control_rescoring_columns_equals_rescoring_each_shuffled_table(scored):
    from tzsl.evaluation import shuffled_rows_control
    from tzsl.studies.zero_shot.tables import negative_control

    rng = np.random.default_rng(5)
    K = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 1, 1], [0, 0, 1]])  # rows 1 and 3 equal
    y = rng.integers(0, len(K), size=40)
    split = Split(name="random-1", train_objects=("x",), test_objects=tuple("abcde"), attributes=("h", "s", "t"))
    r = SplitPosteriors(split=split, attributes=("h", "s", "t"), P=rng.random((40, 2, 3)), K=K, y=y,
                        train_prior=np.array([0.3, 0.5, 0.6]))
    fusion, prior, multilabel, _ = scored
    direct = shuffled_rows_control(lambda t: r.scores(fusion, prior, multilabel, t.to_numpy()),
                                   pd.DataFrame(K), y, n_permutations=30, random_state=7)
    correct, classes, splits = negative_control([r], scored, seed=7, n_permutations=30)
    np.testing.assert_array_equal(correct, direct)
    assert 0 < correct.mean() < 1
