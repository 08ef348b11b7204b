"""Shuffled stratified object-grouped folds: scikit-learn's ``StratifiedGroupKFold``, fold for fold, faster.

An attribute SVM draws its object-grouped folds once per under-sampling draw (three per fit, hundreds
of fits per study). ``StratifiedGroupKFold`` places each group with a Python loop over the folds
that calls ``np.std`` and ``np.isclose`` on tiny arrays: on PHAC-2 that loop was a sixth of an
attribute fit's time. :func:`stratified_group_fold_masks` runs the same greedy placement with the
criterion of every fold computed in one numpy pass: the same shuffle (the same ``RandomState``
calls), the same stable order of the groups, the same per-fold criterion (the same numpy
reductions in the same order, so the same floats) and the same tie rule, hence the same folds
(``tests/models/test_grouped_folds.py`` checks them against scikit-learn's on random inputs).
"""

from __future__ import annotations

import math

import numpy as np
from sklearn.model_selection import StratifiedGroupKFold
from sklearn.utils import check_random_state

__all__ = ["stratified_group_fold_masks"]

#: ``np.isclose`` defaults, the tie rule of ``StratifiedGroupKFold._find_best_fold``.
_RTOL, _ATOL = 1e-5, 1e-8


def _sklearn_masks(y: np.ndarray, groups: np.ndarray, n_splits: int, seed: int) -> list[np.ndarray]:
    """The held-out masks of scikit-learn's own ``StratifiedGroupKFold`` (its checks, warnings and errors)."""
    splitter = StratifiedGroupKFold(n_splits=n_splits, shuffle=True, random_state=seed)
    masks = []
    for _, test in splitter.split(np.zeros((y.size, 1)), y, groups):
        mask = np.zeros(y.size, dtype=bool)
        mask[test] = True
        masks.append(mask)
    return masks


def stratified_group_fold_masks(y: np.ndarray, groups: np.ndarray, n_splits: int, seed: int) -> list[np.ndarray]:
    """Held-out masks of ``StratifiedGroupKFold(n_splits, shuffle=True, random_state=seed).split(X, y, groups)``.

    Parameters
    ----------
    y : ndarray of shape (n_trials,)
        Class of each trial (two or more classes).
    groups : ndarray of shape (n_trials,)
        Group (object) of each trial.
    n_splits : int
        Folds (>= 2).
    seed : int
        Seed of the group shuffle.

    Returns
    -------
    list of ndarray of bool, shape (n_trials,)
        The held-out trials of each fold, in scikit-learn's fold order.
    """
    y = np.asarray(y).ravel()
    _, y_inv, y_cnt = np.unique(y, return_inverse=True, return_counts=True)
    _, groups_inv, groups_cnt = np.unique(groups, return_inverse=True, return_counts=True)
    groups_inv = groups_inv.ravel()
    n_groups, n_classes = groups_cnt.size, y_cnt.size
    if n_classes < 2 or n_splits > y_cnt.min() or n_splits > n_groups or n_splits > y.size:
        return _sklearn_masks(y, groups, n_splits, seed)  # its checks, warnings and errors
    counts = np.zeros((n_groups, n_classes))
    np.add.at(counts, (groups_inv, y_inv.ravel()), 1)  # whole counts: the same floats as += 1 per trial
    perm = np.arange(n_groups)
    check_random_state(seed).shuffle(perm)
    counts = counts[perm]
    inv_perm = np.empty_like(perm)
    inv_perm[perm] = np.arange(perm.size)
    groups_inv = inv_perm[groups_inv]
    order = np.argsort(-np.std(counts, axis=1), kind="stable")

    per_fold = np.zeros((n_splits, n_classes))
    fold_of_group = np.empty(n_groups, dtype=np.intp)
    eye = np.eye(n_splits)[:, :, None]  # (candidate fold, fold, 1)
    scale = y_cnt.reshape(1, 1, -1)
    for g in order:
        # every candidate at once: row c of `trial` is per_fold with the group added to fold c
        trial = per_fold[None, :, :] + eye * counts[g][None, None, :]
        evals = np.mean(np.std(trial / scale, axis=1), axis=1).tolist()  # Python floats: the same values
        sizes = np.sum(per_fold, axis=1).tolist()
        best, min_eval, min_size = -1, math.inf, math.inf
        for i, (e, s) in enumerate(zip(evals, sizes, strict=True)):
            close = math.isfinite(min_eval) and abs(e - min_eval) <= _ATOL + _RTOL * abs(min_eval)
            if e < min_eval or (close and s < min_size):
                best, min_eval, min_size = i, e, s
        per_fold[best] += counts[g]
        fold_of_group[g] = best
    trial_fold = fold_of_group[groups_inv]
    return [trial_fold == i for i in range(n_splits)]
