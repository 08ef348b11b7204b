"""Chance, trivial baselines and the shuffled-rows negative control."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.evaluation import (
    attribute_baselines,
    bootstrap_accuracy,
    chance_accuracy,
    majority_class_accuracy,
    shuffled_attribute_rows,
    shuffled_rows_control,
)
from tzsl.exceptions import TzslError


def test_chance_and_majority():
    y = ["a"] * 6 + ["b"] * 2 + ["c"] * 2
    assert chance_accuracy(y) == pytest.approx(1 / 3) and chance_accuracy(4) == 0.25
    assert majority_class_accuracy(y) == pytest.approx(0.6)
    assert majority_class_accuracy(["a", "b"]) == 0.5


def test_attribute_baselines():
    # 3 attributes over 8 samples; attribute 0 is mostly 1 (6/8), 1 balanced, 2 constant 0
    T = np.array([[1, 0, 0], [1, 1, 0], [1, 0, 0], [1, 1, 0], [1, 0, 0], [1, 1, 0], [0, 0, 0], [0, 1, 0]])
    P = np.array([[1, 0, 0], [1, 1, 0], [0, 0, 0], [1, 1, 1], [1, 0, 0], [1, 0, 0], [0, 0, 0], [1, 1, 0]])
    table = attribute_baselines(T, P, attributes=["hard", "soft", "nice"])
    assert list(table.index) == ["hard", "soft", "nice", "mean"]
    assert table.loc["hard", "majority_accuracy"] == 0.75  # always predicting 1
    assert table.loc["hard", "accuracy"] == 0.75  # plain accuracy no better than the baseline...
    assert table.loc["hard", "balanced_accuracy"] == pytest.approx((5 / 6 + 1 / 2) / 2)  # ... balanced is
    assert table.loc["hard", "majority_balanced_accuracy"] == 0.5
    assert np.isnan(table.loc["nice", "balanced_accuracy"]) and table.loc["nice", "majority_accuracy"] == 1.0
    # majority taken from training rows: training says attribute 0 is mostly absent
    trained = attribute_baselines(T, P, A_train=[[0, 1, 0], [0, 1, 0], [1, 0, 1]])
    assert trained.loc["a0", "majority_accuracy"] == 0.25
    assert trained.loc["a1", "majority_accuracy"] == 0.5


def test_shuffled_rows_really_change_and_keep_the_rows():
    K = pd.DataFrame([[1, 0], [0, 1], [1, 1]], index=["x", "y", "z"], columns=["p", "q"])
    for seed in range(20):
        S = shuffled_attribute_rows(K, random_state=seed)
        assert (S.index == K.index).all() and (S.columns == K.columns).all()
        assert (S.to_numpy() != K.to_numpy()).any()
        assert sorted(map(tuple, S.to_numpy())) == sorted(map(tuple, K.to_numpy()))
    assert shuffled_attribute_rows(K, random_state=1).equals(shuffled_attribute_rows(K, random_state=1))
    with pytest.raises(TzslError, match="at least 2 different class rows"):
        shuffled_attribute_rows(pd.DataFrame([[1, 0], [1, 0]]), random_state=0)


def _log_likelihood_scores(P):
    """DAP-style scores of each class row: sum of log p(attribute value | trial)."""
    def score(table):
        K = table.to_numpy(dtype=float)
        return np.log(P) @ K.T + np.log(1 - P) @ (1 - K).T
    return score


def test_negative_control_covers_chance_while_the_real_assignment_is_above_it():
    """Synthetic study: 8 splits x 10 test classes x 10 trials, informative posteriors."""
    rng = np.random.default_rng(0)
    n_splits, n_classes, n_trials, n_attr = 8, 10, 10, 12
    rows = []
    for s in range(n_splits):
        K = pd.DataFrame(rng.integers(0, 2, (n_classes, n_attr)), index=[f"s{s}c{c}" for c in range(n_classes)])
        while K.duplicated().any():
            K = pd.DataFrame(rng.integers(0, 2, (n_classes, n_attr)), index=K.index)
        y = np.repeat(K.index.to_numpy(), n_trials)
        truth = K.loc[y].to_numpy(dtype=float)
        P = np.clip(0.5 + (truth - 0.5) * rng.uniform(0.0, 0.5, truth.shape) + 0.25 * rng.standard_normal(truth.shape),
                    0.02, 0.98)
        score = _log_likelihood_scores(P)
        real = (K.index.to_numpy()[np.argmax(score(K), axis=1)] == y).astype(float)
        control = shuffled_rows_control(score, K, y, n_permutations=50, random_state=s)
        rows.append(pd.DataFrame({"split": s, "class": y, "real": real, "control": control}))
    df = pd.concat(rows)
    chance = 1 / n_classes
    real = bootstrap_accuracy(df["real"], classes=df["class"], splits=df["split"], n_boot=1000)
    ctrl = bootstrap_accuracy(df["control"], classes=df["class"], splits=df["split"], n_boot=1000)
    print(f"real {real}, control {ctrl}, chance {chance}")
    assert real.ci95_low > 2 * chance
    assert ctrl.ci95_low <= chance <= ctrl.ci95_high
    assert abs(ctrl.mean - chance) < 0.03


def test_control_input_checks():
    K = pd.DataFrame([[1, 0], [0, 1]], index=["x", "y"])
    with pytest.raises(TzslError, match="not in the class-attribute table"):
        shuffled_rows_control(lambda t: np.zeros((1, 2)), K, ["ghost"])
    with pytest.raises(TzslError, match="returned shape"):
        shuffled_rows_control(lambda t: np.zeros((1, 3)), K, ["x"], n_permutations=1)
