"""Bootstrap intervals: point values, coverage, pairing, sizing and the table helpers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import tzsl.evaluation._intervals as intervals_module
from tzsl.evaluation import (
    bootstrap_accuracy,
    bootstrap_accuracy_columns,
    paired_difference_interval,
    paired_differences_table,
    per_class_mean_accuracy,
    splits_for_paired_interval,
    trial_accuracy,
)
from tzsl.exceptions import TzslError


def _simulate(rng, n_splits=5, n_classes=10, p=0.4, spread=0.2, unequal_trials=True):
    """Per-trial correctness: each class has its own accuracy around p (objects differ)."""
    rows = []
    for s in range(n_splits):
        for c in range(n_classes):
            p_class = np.clip(p + spread * rng.standard_normal(), 0, 1)
            n = rng.integers(5, 15) if unequal_trials else 10
            rows += [(f"s{s}", f"c{s}-{c}", t, float(rng.random() < p_class)) for t in range(n)]
    return pd.DataFrame(rows, columns=["split", "class", "trial", "correct"])


def test_point_value_is_the_mean_over_splits_of_the_split_metric():
    df = _simulate(np.random.default_rng(0))
    pred = np.where(df["correct"] == 1, df["class"], "wrong")
    df = df.assign(pred=pred)
    trial = np.mean([trial_accuracy(g["class"], g["pred"]) for _, g in df.groupby("split")])
    pcma = np.mean([per_class_mean_accuracy(g["class"], g["pred"]) for _, g in df.groupby("split")])
    a = bootstrap_accuracy(df["correct"], classes=df["class"], splits=df["split"], n_boot=200)
    b = bootstrap_accuracy(df["correct"], classes=df["class"], splits=df["split"], metric="class_mean", n_boot=200)
    assert a.mean == pytest.approx(trial) and b.mean == pytest.approx(pcma)
    assert a.mean != pytest.approx(b.mean)  # unequal trial counts: the two metrics differ
    assert a.ci95_low < a.mean < a.ci95_high and b.ci95_low < b.mean < b.ci95_high


def test_seeded_and_reproducible():
    df = _simulate(np.random.default_rng(1))
    args = dict(classes=df["class"], splits=df["split"], n_boot=300)
    assert bootstrap_accuracy(df["correct"], random_state=3, **args) == bootstrap_accuracy(
        df["correct"], random_state=3, **args)
    assert bootstrap_accuracy(df["correct"], random_state=3, **args) != bootstrap_accuracy(
        df["correct"], random_state=4, **args)


def test_chunked_replicates_agree_with_one_chunk(monkeypatch):
    df = _simulate(np.random.default_rng(2))
    one = bootstrap_accuracy(df["correct"], classes=df["class"], splits=df["split"], n_boot=4000)
    monkeypatch.setattr(intervals_module, "CHUNK_CELLS", 500)  # 10 replicates per chunk
    many = bootstrap_accuracy(df["correct"], classes=df["class"], splits=df["split"], n_boot=4000)
    assert many.mean == one.mean
    assert many.ci95_low == pytest.approx(one.ci95_low, abs=0.01)
    assert many.ci95_high == pytest.approx(one.ci95_high, abs=0.01)


def test_coverage_of_the_true_accuracy_is_near_95_percent():
    """Draw 150 studies from a known population (p = 0.4); the interval covers p in most."""
    rng = np.random.default_rng(5)
    hits = 0
    n_studies = 150
    for k in range(n_studies):
        df = _simulate(rng, n_splits=8, n_classes=10, p=0.4, spread=0.2, unequal_trials=False)
        iv = bootstrap_accuracy(df["correct"], classes=df["class"], splits=df["split"], n_boot=400,
                                random_state=k)
        hits += iv.ci95_low <= 0.4 <= iv.ci95_high
    assert 0.85 <= hits / n_studies <= 0.99


def test_interval_narrows_with_more_splits():
    rng = np.random.default_rng(6)
    small, large = _simulate(rng, n_splits=4), _simulate(rng, n_splits=40)
    w = [iv.ci95_high - iv.ci95_low for iv in (
        bootstrap_accuracy(d["correct"], classes=d["class"], splits=d["split"], n_boot=500) for d in (small, large))]
    assert w[1] < w[0] / 2


def test_columns_agree_with_one_column_at_a_time():
    df = _simulate(np.random.default_rng(5))
    other = np.clip(df["correct"].to_numpy() + 0.5 * (df["trial"].to_numpy() % 2), 0, 1)
    args = dict(classes=df["class"], splits=df["split"], n_boot=500, random_state=7)
    mean, low, high = bootstrap_accuracy_columns(np.column_stack([df["correct"], other]), **args)
    for j, col in enumerate((df["correct"].to_numpy(), other)):
        one = bootstrap_accuracy(col, **args)  # same seed, same replicates: the same interval
        assert (mean[j], low[j], high[j]) == pytest.approx(tuple(one))
    assert mean[1] > mean[0] and (low <= mean).all() and (mean <= high).all()


def test_paired_difference_keeps_the_pairing():
    rng = np.random.default_rng(7)
    df = _simulate(rng, n_splits=6, spread=0.3)
    # method B = method A with 8% of trials flipped to correct: a small, consistent gain that
    # is hidden by the class-to-class spread when the two are bootstrapped separately
    better = np.maximum(df["correct"].to_numpy(), (rng.random(len(df)) < 0.08).astype(float))
    args = dict(classes=df["class"], splits=df["split"], n_boot=1000)
    diff = paired_difference_interval(better, df["correct"], **args)
    a, b = bootstrap_accuracy(better, **args), bootstrap_accuracy(df["correct"], **args)
    assert diff.mean == pytest.approx(a.mean - b.mean)
    assert diff.ci95_low > 0  # the gain is detected
    assert a.ci95_low < b.ci95_high  # ... although the two separate intervals overlap
    same = paired_difference_interval(df["correct"], df["correct"], **args)
    assert same == (0.0, 0.0, 0.0)


def test_splits_needed_for_a_005_interval():
    # sd 0.08 (PHAC-2 split-to-split spread): (1.96 * 0.08 / 0.05)^2 = 9.83 -> 10 splits
    d = np.array([0.0, 1, -1, 2, -2]) / np.std([0, 1, -1, 2, -2], ddof=1)
    assert np.std(d * 0.08, ddof=1) == pytest.approx(0.08)
    assert splits_for_paired_interval(d * 0.08) == 10
    assert splits_for_paired_interval([0.1, 0.1, 0.1]) == 2
    with pytest.raises(TzslError, match="at least 2"):
        splits_for_paired_interval([0.1])


def test_paired_differences_table():
    rng = np.random.default_rng(9)
    base = _simulate(rng, p=0.4)
    good = base.assign(correct=np.maximum(base["correct"], (rng.random(len(base)) < 0.3).astype(float)))
    trials = pd.concat([base.assign(method="dap-avg"), good.assign(method="better"), base.assign(method="same")])
    table = paired_differences_table(trials, reference="dap-avg", n_boot=500)
    assert table["method"].tolist() == ["better", "same"]
    assert table.loc[0, "ci95_low"] > 0 and table.loc[1, "difference"] == 0
    assert set(table["n_splits"]) == {5} and set(table["n_trials"]) == {len(base)}
    with pytest.raises(TzslError, match="not scored on the same trials"):
        paired_differences_table(trials.iloc[:-1], reference="dap-avg", n_boot=10)


@pytest.mark.parametrize("kwargs, message", [
    ({"metric": "auc"}, "metric must be one of"),
    ({"n_boot": 0}, "n_boot must be a positive integer"),
])
def test_bad_arguments(kwargs, message):
    with pytest.raises(TzslError, match=message):
        bootstrap_accuracy([1, 0], classes=["a", "b"], **kwargs)


def test_bad_correctness_values():
    with pytest.raises(TzslError, match=r"values in \[0, 1\]"):
        bootstrap_accuracy([2, 0], classes=["a", "b"])
    with pytest.raises(TzslError, match="one entry per trial"):
        bootstrap_accuracy([1, 0], classes=["a"])
