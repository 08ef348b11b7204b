"""The one class-grouped fold builder of zero-shot tuning (ESZSLCV, SAECV, select_embedding_alpha)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.model_selection import GroupKFold

from tzsl.evaluation import select_embedding_alpha
from tzsl.models import ESZSLCV, SAECV, ZSLInputError
from tzsl.models.protocol import class_grouped_folds


def merged_problem(seed=0, per_class=10, n_classes=20, n_merged=8, n_attributes=12, n_features=20):
    """Simulated 20-material dataset: the first ``n_merged`` classes share one attribute row.

    Returns X (n, d), labels y (n,), the class table S (n_classes, m) and each trial's row A (n, m).
    """
    rng = np.random.default_rng(seed)
    while True:
        S = rng.integers(0, 2, (n_classes, n_attributes)).astype(float)
        S[:n_merged] = S[0]
        if len(np.unique(S, axis=0)) == n_classes - n_merged + 1:
            break
    y = np.repeat(np.arange(n_classes), per_class)
    X = S[y] @ rng.normal(size=(n_attributes, n_features)) + 0.5 * rng.normal(size=(y.size, n_features))
    return X, y, S, S[y]


def _check_folds(folds, groups):
    n = groups.size
    val = np.concatenate([va for _, va in folds])
    assert np.array_equal(np.sort(val), np.arange(n))  # every sample validated exactly once
    for tr, va in folds:
        assert np.intersect1d(tr, va).size == 0 and tr.size + va.size == n
        g_tr, g_va = np.unique(groups[tr]), np.unique(groups[va])
        assert np.intersect1d(g_tr, g_va).size == 0  # whole groups
        assert g_va.size >= 2 and g_tr.size >= 2


def test_issue_case_groupkfold_fails_and_the_builder_does_not():
    X, y, S, A = merged_problem()
    _, rows = np.unique(A, axis=0, return_inverse=True)
    rows = rows.ravel()
    # the case of the issue: GroupKFold balances samples, so the merged row (8 classes) is alone
    old = list(GroupKFold(n_splits=5).split(X, rows, rows))
    assert min(np.unique(rows[va]).size for _, va in old) == 1
    folds = class_grouped_folds(rows, 5, "test")
    assert len(folds) == 5
    _check_folds(folds, rows)
    merged_row = rows[0]
    holding = [va for _, va in folds if merged_row in rows[va]]
    assert len(holding) == 1 and np.unique(rows[holding[0]]).size >= 2


def test_all_three_tuners_fit_the_issue_case():
    X, y, S, A = merged_problem()
    eszsl = ESZSLCV().fit(X, A, y)
    assert eszsl.cv_scores_.shape[-1] == 5
    assert all(len(v) >= 2 for v in eszsl.cv_val_classes_)
    sae = SAECV(lams=(0.1, 10.0)).fit(X, A)
    assert sae.cv_scores_.shape == (sae.lams_.size, 5)
    alpha, scores = select_embedding_alpha(X, y, S, lam=0.1, alphas=(1.0, 0.01), random_state=0, max_iter=50)
    assert scores.shape == (2, 5) and alpha in (1.0, 0.01)


@pytest.mark.parametrize("seed", range(30))
def test_folds_always_fittable(seed):
    rng = np.random.default_rng(seed)
    n_groups = int(rng.integers(4, 30))
    sizes = rng.integers(1, 40, n_groups)
    sizes[0] *= 20  # one heavy (merged) group
    groups = rng.permutation(np.repeat(np.arange(n_groups) * 3 + 7, sizes))
    n_splits = int(rng.integers(2, 12))
    folds = class_grouped_folds(groups, n_splits, "test")
    assert len(folds) == min(n_splits, n_groups // 2)
    _check_folds(folds, groups)
    per_fold = [np.unique(groups[va]).size for _, va in folds]
    assert max(per_fold) - min(per_fold) <= 1
    again = class_grouped_folds(groups, n_splits, "test")
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(folds, again, strict=True))  # deterministic


def test_too_few_groups_and_strict_fold_count_say_why():
    with pytest.raises(ZSLInputError, match=r"^who: .*at least 4 training classes.*got 3$"):
        class_grouped_folds(np.repeat([0, 1, 2], 5), 2, "who")
    with pytest.raises(ZSLInputError, match="use at most 3 folds"):
        class_grouped_folds(np.repeat(np.arange(6), 5), 4, "who", strict=True)
    assert len(class_grouped_folds(np.repeat(np.arange(6), 5), 4, "who")) == 3  # capped
