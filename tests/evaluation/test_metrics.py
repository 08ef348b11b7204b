"""Metrics against hand-computed values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.evaluation import (
    gzsl_scores,
    per_attribute_balanced_accuracy,
    per_class_accuracy,
    per_class_mean_accuracy,
    summarise_over_splits,
    trial_accuracy,
)
from tzsl.exceptions import TzslError

# class a: 4 trials, 3 right; class b: 2 trials, 0 right; class c: 2 trials, 2 right
Y_TRUE = np.array(["a", "a", "a", "a", "b", "b", "c", "c"])
Y_PRED = np.array(["a", "a", "a", "c", "a", "c", "c", "c"])


def test_trial_and_per_class_accuracy():
    assert trial_accuracy(Y_TRUE, Y_PRED) == pytest.approx(5 / 8)
    assert per_class_mean_accuracy(Y_TRUE, Y_PRED) == pytest.approx((3 / 4 + 0 + 1) / 3)
    pc = per_class_accuracy(Y_TRUE, Y_PRED)
    assert pc.to_dict() == pytest.approx({"a": 0.75, "b": 0.0, "c": 1.0})
    # a class only predicted (never true) does not count
    assert per_class_mean_accuracy([1, 1, 2], [1, 3, 2]) == pytest.approx((0.5 + 1) / 2)
    # integer labels vs their string forms compare equal
    assert trial_accuracy([1, 2], ["1", "3"]) == 0.5


@pytest.mark.parametrize(
    "y_true, y_pred, match",
    [
        ([1, 2], [1], "y_true has 2 labels but y_pred has 1"),
        ([], [], "no samples"),
        ([[1, 2]], [[1, 2]], "must be 1-d"),
        ([1.0, np.nan], [1.0, 1.0], "y_true contains NaN"),
    ],
)
def test_label_validation(y_true, y_pred, match):
    with pytest.raises(TzslError, match=match):
        trial_accuracy(y_true, y_pred)


def test_per_attribute_balanced_accuracy():
    A_true = np.array([[1, 0, 1], [1, 1, 1], [0, 0, 1], [0, 1, 1]])
    A_pred = np.array([[1, 0, 0], [0, 1, 1], [0, 1, 1], [1, 1, 0]])
    # att0: TPR 1/2, TNR 1/2 -> 0.5; att1: TPR 2/2, TNR 1/2 -> 0.75; att2: no negative -> NaN
    out = per_attribute_balanced_accuracy(A_true, A_pred)
    assert out.shape == (3,)
    np.testing.assert_allclose(out[:2], [0.5, 0.75])
    assert np.isnan(out[2])
    # agrees with sklearn where defined
    from sklearn.metrics import balanced_accuracy_score

    assert out[1] == pytest.approx(balanced_accuracy_score(A_true[:, 1], A_pred[:, 1]))
    # booleans accepted; an attribute absent from every sample is NaN too
    out2 = per_attribute_balanced_accuracy(np.zeros((3, 1), bool), np.ones((3, 1), bool))
    assert np.isnan(out2[0])


def test_per_attribute_balanced_accuracy_validation():
    with pytest.raises(TzslError, match=r"A_pred must hold only 0/1 .* row 0, attribute column 1 is 0.7"):
        per_attribute_balanced_accuracy([[1, 0]], [[1, 0.7]])
    with pytest.raises(TzslError, match="shape"):
        per_attribute_balanced_accuracy(np.zeros((2, 3)), np.zeros((2, 2)))
    with pytest.raises(TzslError, match="A_true must hold only 0/1"):
        per_attribute_balanced_accuracy([[np.nan]], [[1]])


def test_gzsl_scores():
    # seen classes s1, s2; unseen u1, u2; predictions over all four
    y_true = ["s1", "s1", "s2", "s2", "u1", "u1", "u1", "u2"]
    y_pred = ["s1", "u1", "s2", "s2", "u1", "s1", "u1", "u1"]
    out = gzsl_scores(y_true, y_pred, seen_classes=["s1", "s2"], unseen_classes=["u1", "u2"])
    seen = (1 / 2 + 2 / 2) / 2  # 0.75
    unseen = (2 / 3 + 0 / 1) / 2  # 1/3
    assert out["seen"] == pytest.approx(seen)
    assert out["unseen"] == pytest.approx(unseen)
    assert out["harmonic"] == pytest.approx(2 * seen * unseen / (seen + unseen))
    zero = gzsl_scores([1, 2], [2, 1], seen_classes=[1], unseen_classes=[2])
    assert zero == {"seen": 0.0, "unseen": 0.0, "harmonic": 0.0}


def test_gzsl_validation():
    with pytest.raises(TzslError, match=r"\['b'\] are both seen and unseen"):
        gzsl_scores(["a", "b"], ["a", "b"], ["a", "b"], ["b"])
    with pytest.raises(TzslError, match=r"\['c'\] are neither seen nor unseen"):
        gzsl_scores(["a", "c"], ["a", "c"], ["a"], ["b"])
    with pytest.raises(TzslError, match="no sample of a unseen class"):
        gzsl_scores(["a", "a"], ["a", "b"], ["a"], ["b"])


def test_summarise_over_splits():
    df = pd.DataFrame(
        {
            "split": ["random-1", "random-2", "random-3"],
            "method": ["AVGDAP"] * 3,
            "accuracy": [0.3, 0.4, 0.5],
            "att_hard": [0.6, np.nan, 0.8],
        }
    )
    out = summarise_over_splits(df)
    assert list(out.index) == ["random-1", "random-2", "random-3", "mean", "std"]
    assert out.loc["mean", "accuracy"] == pytest.approx(0.4)
    assert out.loc["std", "accuracy"] == pytest.approx(0.1)  # sample std (ddof=1)
    assert out.loc["mean", "att_hard"] == pytest.approx(0.7)  # NaN skipped
    assert out.loc["std", "att_hard"] == pytest.approx(np.std([0.6, 0.8], ddof=1))
    assert pd.isna(out.loc["mean", "method"])
    pop = summarise_over_splits(df, ddof=0)
    assert pop.loc["std", "accuracy"] == pytest.approx(np.std([0.3, 0.4, 0.5]))
    with pytest.raises(TzslError, match="clash"):
        summarise_over_splits(pd.DataFrame({"split": ["mean"], "acc": [1.0]}))
    with pytest.raises(TzslError, match="no numeric column"):
        summarise_over_splits(pd.DataFrame({"split": ["a"], "m": ["x"]}))


def test_summarise_over_splits_by_groups():
    """With ``by``: mean and std rows per group (over seeds here), keys kept, columns ordered."""
    df = pd.DataFrame(
        {
            "method": ["DAP", "ESZSL", "DAP", "ESZSL", "DAP", "ESZSL"],
            "seed": [0, 0, 1, 1, 2, 2],
            "accuracy": [0.2, 0.5, 0.4, 0.5, 0.6, 0.8],
            "note": ["x"] * 6,
            "n_test": [10, 10, 10, 10, 10, 10],
        }
    )
    out = summarise_over_splits(df, split_column="seed", by=["method"])
    assert list(out.columns) == ["seed", "method", "accuracy", "note", "n_test"]
    assert list(out["seed"]) == [0, 0, 1, 1, 2, 2, "mean", "mean", "std", "std"]
    assert list(out["method"].iloc[6:]) == ["DAP", "ESZSL", "DAP", "ESZSL"]  # order of appearance
    summary = out.iloc[6:].set_index(["seed", "method"])
    assert summary.loc[("mean", "DAP"), "accuracy"] == pytest.approx(0.4)
    assert summary.loc[("mean", "ESZSL"), "accuracy"] == pytest.approx(0.6)
    assert summary.loc[("std", "DAP"), "accuracy"] == pytest.approx(0.2)  # ddof=1
    assert summary.loc[("std", "ESZSL"), "accuracy"] == pytest.approx(np.std([0.5, 0.5, 0.8], ddof=1))
    assert summary.loc[("std", "DAP"), "n_test"] == 0.0
    assert out["note"].iloc[6:].isna().all()  # non-numeric columns stay empty
    pop = summarise_over_splits(df, split_column="seed", by=["method"], ddof=0)
    assert pop.iloc[8]["accuracy"] == pytest.approx(np.std([0.2, 0.4, 0.6]))
    one = summarise_over_splits(df[df["seed"] == 0], split_column="seed", by=["method"])
    assert one.iloc[-2:]["accuracy"].isna().all()  # std of one seed is undefined
    with pytest.raises(TzslError, match="no column"):
        summarise_over_splits(df, split_column="seed", by=["kind"])
    with pytest.raises(TzslError, match="clash"):
        summarise_over_splits(df.assign(seed="std"), split_column="seed", by=["method"])
