"""The fast stratified object-grouped folds are scikit-learn's StratifiedGroupKFold folds, fold for fold."""

import warnings

import numpy as np
import pytest
from sklearn.model_selection import StratifiedGroupKFold

from tzsl.models.detectors._grouped_folds import stratified_group_fold_masks


def _sklearn(y, groups, n_splits, seed):
    splitter = StratifiedGroupKFold(n_splits=n_splits, shuffle=True, random_state=seed)
    masks = []
    for _, test in splitter.split(np.zeros((y.size, 1)), y, groups):
        m = np.zeros(y.size, dtype=bool)
        m[test] = True
        masks.append(m)
    return masks


def _random_problem(rng):
    """Objects of a few trials each, most with one class (as attribute data: an object has it or not)."""
    n_objects = int(rng.integers(4, 40))
    trials = rng.integers(1, 12, n_objects)
    has = rng.random(n_objects) < rng.uniform(0.1, 0.9)
    groups = np.repeat(rng.permutation(n_objects * 3)[:n_objects], trials)
    y = np.repeat(has, trials)
    flip = rng.random(y.size) < 0.05  # a few mixed objects
    return np.where(flip, ~y, y), groups


@pytest.mark.parametrize("seed", range(3))
def test_same_folds_as_sklearn(seed):
    rng = np.random.default_rng(seed)
    checked = 0
    for _ in range(100):
        y, groups = _random_problem(rng)
        n_min = min(np.unique(groups[y]).size, np.unique(groups[~y]).size)
        if n_min < 2:
            continue
        n_splits = int(rng.integers(2, min(n_min, 10) + 1))
        fold_seed = int(rng.integers(2**31 - 1))
        ours = stratified_group_fold_masks(y, groups, n_splits, fold_seed)
        theirs = _sklearn(y, groups, n_splits, fold_seed)
        assert len(ours) == len(theirs) == n_splits
        for a, b in zip(ours, theirs, strict=True):
            np.testing.assert_array_equal(a, b)
        checked += 1
    assert checked > 30


def test_string_groups_and_many_classes_match_sklearn():
    rng = np.random.default_rng(7)
    groups = np.repeat(np.array([f"object {i}" for i in range(30)]), 5)
    y = np.repeat(rng.integers(0, 3, 30), 5)
    for fold_seed in range(20):
        for a, b in zip(stratified_group_fold_masks(y, groups, 4, fold_seed), _sklearn(y, groups, 4, fold_seed),
                        strict=True):
            np.testing.assert_array_equal(a, b)


def test_too_many_folds_is_sklearn_error():
    y = np.array([0, 0, 1, 1, 0, 1])
    groups = np.array([0, 0, 1, 1, 2, 2])
    with pytest.raises(ValueError, match="n_splits"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stratified_group_fold_masks(y, groups, 4, 0)
