"""Held-out scores of pseudo-unseen training classes: the zero-shot protocol's own cross-validation.

A zero-shot method is judged on classes it never saw. To choose or calibrate something on the training
classes alone, :func:`pseudo_unseen_scores` deals the training classes (distinct attribute rows) into
class-grouped folds, refits the method on the other classes and scores each fold's held-out
(*pseudo-unseen*) classes among themselves, as a test trial is scored among the test classes. A 0/1
attribute that fewer than :data:`MIN_FOLD_CLASSES` of a fold's training classes have (or lack) cannot be
learnt there, so that fold leaves it out on both sides. Above ``max_trials`` training trials the folds are
dealt on a seeded subsample in which every (class, object) keeps its share (:func:`calibration_subsample`).

Two users read it: the temperature of :class:`tzsl.models.CalibratedZeroShotClassifier` (public home of
these names: :mod:`tzsl.models.calibration`) and ``detector="auto"``'s choice of an attribute bank's
detector family (:func:`tzsl.models.detectors.choose_detector`). It sits in the package core, below both.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from sklearn.base import clone
from sklearn.utils import check_random_state

from tzsl._fit_store import fit_cached
from tzsl.models._zsl_input import GridEdgeWarning, ZSLInputError, class_grouped_folds, share_of_objects

__all__ = ["MAX_CALIBRATION_TRIALS", "MIN_FOLD_CLASSES", "PER_CLASSIFIER_PARAMS", "calibration_subsample",
           "on_attributes", "pseudo_unseen_scores"]

#: Key of ``selected_params()`` holding an attribute bank's per-classifier hyper-parameters, which
#: ``calibration_refit="search"`` leaves out.
PER_CLASSIFIER_PARAMS = "estimator_params"

#: A fold keeps a 0/1 attribute when at least this many of its training classes have it and lack it.
MIN_FOLD_CLASSES = 2

#: Default ``calibration_max_trials``: training trials the pseudo-unseen folds are dealt on (a larger
#: training set is subsampled, every class and object keeping its share). With 3 folds each fold
#: refits the method on about two thirds of them, so the cost of calibration stops growing with
#: the data set; the temperature is one scalar, well determined by this many held-out trials. A
#: fold refit of a large-data attribute bank then costs little more than its fixed part (the
#: hyper-parameter search of each attribute model), so the three folds cost less than the final
#: fit of a large data set (``make bench-scale`` measures the whole run).
MAX_CALIBRATION_TRIALS = 1_000


def _class_codes(Y: np.ndarray) -> np.ndarray:
    """Index of each trial's distinct attribute row (its training class)."""
    return np.unique(Y, axis=0, return_inverse=True)[1].ravel()


def calibration_subsample(codes: np.ndarray, groups, max_trials: int | None, rng) -> np.ndarray:
    """Sorted indices of about ``max_trials`` trials, every (class, object) keeping its share (all if fewer).

    Parameters
    ----------
    codes : int ndarray of shape (n_trials,)
        Training class of each trial.
    groups : array-like of shape (n_trials,) or None
        Object of each trial (None: the class is the stratum).
    max_trials : int or None
        The bound; None: no bound.
    rng : numpy.random.RandomState
        Draws the trials (used only when ``n_trials > max_trials``).

    Returns
    -------
    int ndarray of shape (n_kept,)
        Each (class, object) keeps ``max(1, floor(count * max_trials / n_trials))`` of its trials,
        chosen at random, so ``n_kept <= max_trials`` plus one per (class, object) whose share
        rounds to zero; every class and object stays.
    """
    n = codes.size
    if max_trials is None or n <= max_trials:
        return np.arange(n)
    strata = codes if groups is None else np.unique(
        np.column_stack([codes, np.unique(np.asarray(groups), return_inverse=True)[1].ravel()]),
        axis=0, return_inverse=True)[1].ravel()
    return share_of_objects(strata, max_trials, rng)


def pseudo_unseen_scores(estimator, X, Y, groups=None, *, n_folds: int = 3, random_state=None,
                         score=None, max_trials: int | None = None) -> list[tuple[Any, np.ndarray, int]]:
    """Refit on training classes minus a held-out group; score the held-out classes among themselves.

    Parameters
    ----------
    estimator : unfitted zero-shot estimator
        ``fit(X, Y, groups)`` and ``decision_function(X, class_attributes)``; a clone is fitted per fold,
        through the fit store (:func:`tzsl.fit_store.fit_cached`: a fold fit another caller asked for with
        the same parameters and rows is read back).
    X : array-like of shape (n_trials, ...)
    Y : array-like of shape (n_trials, n_attributes)
        Attribute row of each training trial's class.
    groups : array-like of shape (n_trials,), optional
        Object of each trial (passed on to the method's own grouped tuning).
    n_folds : int, default 3
        Class-grouped folds (capped so each holds out >= 2 classes).
    random_state : int, RandomState or None
        Seeds which class goes to which fold.
    score : callable, optional
        ``score(fitted, X_held_out, K_held_out)``; default ``fitted.decision_function``. May
        return anything (e.g. scores under several decision rules).
    max_trials : int or None, default None
        Deal the folds on about this many trials (:func:`calibration_subsample`, seeded by
        ``random_state``) when there are more; None: on all of them.

    Returns
    -------
    list of (scores, y_true, n_dropped)
        Per fold: ``score``'s output for the held-out trials, the column (row of the held-out
        classes' table, ``np.unique`` order) of each trial's class, and how many 0/1 attributes
        the fold left out (module docstring; classes left with equal rows are merged).

    Raises
    ------
    ZSLInputError
        Fewer than 4 training classes.
    """
    X = np.asarray(X)
    Y = np.asarray(Y, dtype=np.float64)
    Y = Y.reshape(-1, 1) if Y.ndim == 1 else Y
    codes = _class_codes(Y)
    rng = check_random_state(random_state)
    relabel = rng.permutation(codes.max() + 1)  # seeded fold dealing
    g = None if groups is None else np.asarray(groups)
    kept = calibration_subsample(codes, g, max_trials, rng)  # drawn after the dealing: same folds below the bound
    if kept.size < codes.size:
        X, Y, codes, g = X[kept], Y[kept], codes[kept], None if g is None else g[kept]
    folds = class_grouped_folds(relabel[codes], n_folds, "posterior calibration (pseudo-unseen classes)")
    score = score or (lambda fitted, Xv, K: fitted.decision_function(Xv, K))
    out = []
    for train, held in folds:
        keep = _learnable_attributes(Y[train])
        if not keep.any():
            raise ZSLInputError("posterior calibration: a fold's training classes leave no attribute to learn")
        with warnings.catch_warnings():  # a fold's grid edges are not the user's: the final fit reports its own
            warnings.simplefilter("ignore", GridEdgeWarning)
            fitted = fit_cached(on_attributes(clone(estimator), keep), X[train], Y[train][:, keep],
                                None if g is None else g[train])
        K, y = np.unique(Y[held][:, keep], axis=0, return_inverse=True)
        out.append((score(fitted, X[held], K), y.ravel(), int((~keep).sum())))
    return out


#: Parameters holding one entry per attribute, cut with the attributes a fold leaves out.
_PER_ATTRIBUTE = ("attribute_names", PER_CLASSIFIER_PARAMS)


def _cut_to(params: dict, keep: np.ndarray) -> dict:
    """The per-attribute entries (:data:`_PER_ATTRIBUTE`) of ``params`` (names possibly nested with ``__``),
    each cut to the kept attributes."""
    return {key: [value for value, k in zip(values, keep, strict=True) if k] for key, values in params.items()
            if key.split("__")[-1] in _PER_ATTRIBUTE and values is not None and len(values) == len(keep)}


def on_attributes(estimator, keep: np.ndarray):
    """``estimator`` with every nested per-attribute parameter (:data:`_PER_ATTRIBUTE`) cut to the kept
    attributes, the entries of a score ensemble's members (``methods`` of dicts) included."""
    if keep.all():
        return estimator
    params = estimator.get_params(deep=True)
    cut = _cut_to(params, keep)
    if hasattr(estimator, "pinned_methods"):
        cut["methods"] = [{**entry, **_cut_to(entry, keep)} if isinstance(entry, dict) else entry
                          for entry in params["methods"]]
    return estimator.set_params(**cut)


def _learnable_attributes(Y: np.ndarray) -> np.ndarray:
    """Columns a fold can learn: not 0/1, or had and lacked by >= MIN_FOLD_CLASSES distinct rows; (m,) bool."""
    rows = np.unique(Y, axis=0)
    binary = np.isin(Y, (0.0, 1.0)).all(axis=0)
    positives = rows.sum(axis=0)
    return ~binary | ((positives >= MIN_FOLD_CLASSES) & (len(rows) - positives >= MIN_FOLD_CLASSES))
