"""Stacked and sparse attribute detectors on PHAC-2 (issue 32, item 2): two hypotheses, one decision rule.

Hypotheses (stated before any run on selection splits)
------------------------------------------------------
H_stack, "leave-one-object-out stacking of detectors": DAP reads attribute ``a`` from ``a``'s
detector alone. Attributes co-occur across objects (hard and squishy, smooth and rough), so the
other attributes' detectors carry evidence about ``a``; and a second stage trained on *held-out*
detector logits (each training object scored by detectors that never saw it) sees the errors an
unseen object's logits have, not the in-sample ones. A second stage per attribute, predicting ``a``
from the vector of ALL attributes' held-out fused logits of the ``dap-avg-logistic-c1`` detectors,
then DAP over its posteriors (method ``stack``), beats ``dap-avg-logistic-c1``.

H_sparse: an L1 logistic detector (method ``sparse``) in place of the L2 ``logistic-c1`` one: a
detector that reads fewer features may encode less of the training objects' identity, so its
errors on an unseen object come less together, and DAP (AVG fusion, uniform prior) over it beats
``dap-avg-logistic-c1``.

Choices fixed before measuring
------------------------------
* Reference and first stage: the registered ``dap-avg-logistic-c1``
  (:func:`~tzsl.studies.zero_shot.methods.fit_predict_split`, bare, the study's seed
  ``study seed + split index``); its predictions are the reference. Its held-out and test fused
  logits, the error-structure measures and the fold construction are those of
  ``phac2_correlated_dap.py`` (imported, not copied): :func:`held_out_logits` (10 object-grouped
  folds of the training objects), :func:`fused_logits` (logit of the AVG-fused posterior, clipped
  to ``[1e-6, 1 - 1e-6]``), :func:`class_means`, :func:`residuals`, :func:`error_structure`; its
  per-split cache ``<split>.npz`` (``S_oof``) is read when present in ``--out``.
* ``stack``: for each attribute ``a`` of the split, ``LogisticRegression`` (L2, intercept,
  ``class_weight="balanced"`` so that its posterior is for a 50% attribute prior, as the detectors'
  and DAP's uniform prior are; lbfgs) of ``a`` on the raw held-out logits ``S_oof`` (n_train, m) of
  all ``m`` attributes, ``a``'s own included; a missing held-out logit (an attribute not fitted in
  a fold) is 0 (no evidence). Raw logits, not z-scored: they share one scale, and a confident
  detector's larger spread should cost less penalty. ``C`` is one value per split for all
  attributes from ``STACK_C_GRID = (0.01, 0.1, 1.0)``, the one with the lowest mean over attributes
  of the class-balanced log-loss of the stage's out-of-fold posteriors in 5 object-grouped folds of
  the training objects (:func:`tzsl.models.protocol.class_grouped_folds`; an attribute present or
  absent in fewer than 2 trials of a fold's training part is left out of that fold); ties go to
  the smaller ``C``. The stage is refitted on all training trials at that ``C`` and applied to
  the test trials' fused logits of the final detectors. DAP: ``sum_a log p(a = K[c, a] | x)``
  (uniform prior, :class:`tzsl.models.DAPRule`), ties broken with the split's seed.
* ``stack-own`` (diagnostic, never adopted): the same stage with ``a``'s own logit as its only
  input, a per-attribute recalibration on held-out logits; ``stack`` minus ``stack-own`` is what
  the other attributes add.
* ``sparse``: :class:`SparseLogisticAttribute` per (attribute, sensor) in an
  :class:`~tzsl.models.AttributeClassifierBank` (``solver="exact"``, ``random_state`` = the split's
  seed): z-scored features, ``LogisticRegression(l1_ratio=1, solver="liblinear",
  class_weight="balanced")`` (L1), ``C`` from ``SPARSE_C_GRID = (0.01, 0.03, 0.1, 0.3, 1.0)`` by 5
  object-grouped stratified folds (``StratifiedGroupKFold``, at most the rarer class's number of
  objects) of the detector's training trials, lowest class-balanced log-loss of the out-of-fold
  posteriors, ties to the smaller ``C``; the posterior is the refitted model's own. DAP as above
  (AVG fusion, uniform prior). Its held-out logits (for the error structure only) come from the
  same 10 folds with each detector's ``C`` pinned at its full-training choice.

Decision rule (fixed before running on selection splits)
--------------------------------------------------------
As ``phac2_correlated_dap.py``'s: on the selection splits (20 random splits, ``--purpose select
--seed 0``, and the 5 challenging splits) the criterion of a method is the mean of its random-split
accuracy and its challenging-split accuracy (each the mean over splits,
:func:`tzsl.evaluation.bootstrap_accuracy`'s point). ``stack`` (H_stack) is adopted if its criterion
is higher than ``dap-avg-logistic-c1``'s; ``sparse`` (H_sparse) by the same rule; if both pass, the
higher criterion is adopted. Only an adopted method is run once on confirmation splits
(``--purpose confirm --seed 32 --n-random 50`` and every challenging split, ``--references``
adding ``dap-avg`` and ``eszsl``, paired intervals). Nothing is registered by this script.

Outcome: on the selection splits neither ``stack`` nor ``sparse`` passed the rule (both below
``dap-avg-logistic-c1`` on random and challenging splits; ``stack-own`` too), so neither was run on
confirmation splits nor registered; the numbers are in the issue's record, not typed here. The
stage's ``C`` was the grid's smallest value on every selection split (an edge of the fixed grid):
a smaller one was not tried, since the rule fixed the grid before the run.

Measurements
------------
(a) per method (``c1``: the reference's detectors, ``stack``, ``stack-own``, ``sparse``), the error
structure of its held-out training logits (``oof_``) and test logits (``test_``, residuals against
the class means of its held-out logits) as ``phac2_correlated_dap.py``'s ``error_structure.csv``
(``between_share``, ``obj_corr``, ``obj_abs_corr``, ``obj_err_corr``, ``within_corr``,
``error_dispersion``), and ``test_error_corr01`` (:func:`tzsl.evaluation.within_object_error_correlation`);
the chosen ``C`` values and the sparse detectors' mean number of nonzero coefficients.
(b) per-trial correctness of every method; ``summary.csv`` (accuracy [two-level bootstrap 95%
interval] per kind and method, paired difference to each reference), ``decision.csv``.

Per-split held-out logits of the reference's detectors are cached in ``--out`` (``<split>.npz``, the
correlated-DAP script's format); one BLAS thread keeps the many small fits from spinning a second core::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice -n 5 python experiments/benchmarks/phac2_stacked_detectors.py \
        --out /tmp/lever32b-select --purpose select --seed 0 --n-random 20
"""

from __future__ import annotations

import time
from numbers import Integral, Real
from pathlib import Path

import numpy as np
import pandas as pd
from phac2_correlated_dap import (
    DETECTOR_METHOD,
    EPS,
    class_means,
    decision,
    error_structure,
    fused_logits,
    held_out_logits,
    lever_main,
    residuals,
)
from phac2_detectors_confirm import MEMBERS
from scipy.special import logit
from sklearn.base import BaseEstimator, ClassifierMixin, _fit_context, clone
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import log_loss
from sklearn.model_selection import StratifiedGroupKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval
from sklearn.utils.class_weight import compute_sample_weight
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl.evaluation import within_object_error_correlation
from tzsl.models import AttributeClassifierBank, DAPRule
from tzsl.models.protocol import class_grouped_folds
from tzsl.studies.zero_shot.methods import fit_predict_split
from tzsl.studies.zero_shot.study import split_masks

#: ``C`` grid of the stacking stage (one value per split, by object-grouped CV).
STACK_C_GRID = (0.01, 0.1, 1.0)
#: Object-grouped folds of the training objects that score the stage's grid.
STACK_FOLDS = 5
#: ``C`` grid of the sparse (L1) detector (per detector, by object-grouped CV).
SPARSE_C_GRID = (0.01, 0.03, 0.1, 0.3, 1.0)
#: Object-grouped stratified folds of a sparse detector's grid search.
SPARSE_FOLDS = 5
#: Methods the decision rule may adopt (stack-own is a diagnostic).
CANDIDATES = ("stack", "sparse")


def balanced_log_loss(y: np.ndarray, p: np.ndarray) -> float:
    """Class-balanced log-loss (nats) of posteriors ``p`` (n,) of 0/1 targets ``y`` (n,), clipped to
    ``[EPS, 1 - EPS]``."""
    return float(log_loss(y, np.clip(p, EPS, 1 - EPS), sample_weight=compute_sample_weight("balanced", y),
                          labels=[0, 1]))


class SparseLogisticAttribute(ClassifierMixin, BaseEstimator):
    """z-score + class-balanced L1 logistic regression for one attribute and one sensor (H_sparse).

    Parameters
    ----------
    C_grid : tuple of float, default=SPARSE_C_GRID
        Candidate inverse L1 strengths (z-scored features); one value: no search.
    cv : int >= 2, default=SPARSE_FOLDS
        Object-grouped stratified folds of the search (at most the rarer class's number of objects).
    random_state : int or None, default=None
        Seed of liblinear.

    Attributes
    ----------
    C_ : float
        The chosen ``C``.
    cv_log_loss_ : ndarray of shape (len(C_grid),)
        Class-balanced log-loss of each ``C``'s out-of-fold posteriors (NaN without a search).
    n_nonzero_ : int
        Nonzero coefficients of the refitted model.
    classes_ : ndarray of shape (2,)
    pipeline_ : fitted Pipeline
    """

    _parameter_constraints: dict = {
        "C_grid": [tuple, list],
        "cv": [Interval(Integral, 2, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(self, *, C_grid=SPARSE_C_GRID, cv=SPARSE_FOLDS, random_state=None):
        self.C_grid = C_grid
        self.cv = cv
        self.random_state = random_state

    def _model(self, C: Real):
        return make_pipeline(StandardScaler(), LogisticRegression(l1_ratio=1, solver="liblinear", C=C,
                                                                  class_weight="balanced",
                                                                  random_state=self.random_state))

    def _grid_log_loss(self, X: np.ndarray, yb: np.ndarray, groups: np.ndarray) -> np.ndarray:
        """Balanced log-loss (len(C_grid),) of the pooled out-of-fold posteriors of each ``C``."""
        n_rare = min(np.unique(groups[yb == v]).size for v in (0, 1))
        if n_rare < 2:
            raise ValueError(f"choosing C needs 2 objects of each class, got {n_rare}")
        oof = np.full((len(self.C_grid), yb.size), np.nan)
        for fit_rows, held in StratifiedGroupKFold(n_splits=min(self.cv, n_rare)).split(X, yb, groups):
            if np.unique(yb[fit_rows]).size < 2:
                continue
            for j, C in enumerate(self.C_grid):
                oof[j, held] = self._model(C).fit(X[fit_rows], yb[fit_rows]).predict_proba(X[held])[:, 1]
        scored = ~np.isnan(oof[0])
        return np.array([balanced_log_loss(yb[scored], row[scored]) for row in oof])

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, groups=None):
        """Fit on trials ``X`` (n, d) with labels ``y`` (n,); ``groups`` (n,): objects, needed to search ``C``."""
        X, y = validate_data(self, X, y, dtype=np.float64)
        self.classes_ = np.unique(y)
        if self.classes_.size != 2:
            raise ValueError(f"need 2 classes, got {self.classes_.size}")
        yb = (y == self.classes_[1]).astype(int)
        if len(self.C_grid) > 1:
            if groups is None:
                raise ValueError("searching C needs the trials' objects (groups)")
            self.cv_log_loss_ = self._grid_log_loss(X, yb, np.asarray(groups))
            self.C_ = float(self.C_grid[int(np.argmin(self.cv_log_loss_))])  # first minimum: the smaller C
        else:
            self.cv_log_loss_ = np.full(1, np.nan)
            self.C_ = float(self.C_grid[0])
        self.pipeline_ = self._model(self.C_).fit(X, yb)
        self.n_nonzero_ = int(np.count_nonzero(self.pipeline_[-1].coef_))
        return self

    def predict_proba(self, X) -> np.ndarray:
        """Posteriors of shape (n, 2), columns ordered as ``classes_``."""
        check_is_fitted(self)
        return self.pipeline_.predict_proba(validate_data(self, X, dtype=np.float64, reset=False))

    def predict(self, X) -> np.ndarray:
        """Most probable class, shape (n,)."""
        return self.classes_[self.predict_proba(X).argmax(axis=1)]


def pinned(bank: AttributeClassifierBank) -> AttributeClassifierBank:
    """An unfitted clone of a fitted sparse bank with every detector's ``C`` fixed at its choice (no search)."""
    return clone(bank).set_params(estimator_params=[[{"C_grid": (est.C_,)} for est in per] for per in bank.estimators_])


def dap_predict(P: np.ndarray, A_train: np.ndarray, K: np.ndarray, seed: int) -> np.ndarray:
    """AVGDAP (uniform prior) class rows (n,) of posteriors ``P`` (n, s, m) or (n, m) among ``K`` (k, m), ties
    seeded."""
    return DAPRule(fusion="avg", prior="uni").fit(A_train).predict(P, K, random_state=seed)


def fit_stage(Z: np.ndarray, y: np.ndarray, C: float) -> LogisticRegression:
    """The stacking stage of one attribute: class-balanced L2 logistic regression on logits ``Z`` (n, p)."""
    return LogisticRegression(C=C, class_weight="balanced", max_iter=1000).fit(Z, y)


def stage_inputs(m: int, a: int, own: bool) -> list[int]:
    """Columns of the stage of attribute ``a``: its own logit (``own``) or all ``m``."""
    return [a] if own else list(range(m))


def stage_oof(Z: np.ndarray, A: np.ndarray, groups: np.ndarray, C: float, own: bool) -> np.ndarray:
    """Stage posteriors (n, m) of every training trial from stages fitted without its object (NaN: left out)."""
    P = np.full(A.shape, np.nan)
    for fit_rows, held in class_grouped_folds(groups, STACK_FOLDS, "stacking stage (objects)"):
        for a in range(A.shape[1]):
            y = A[fit_rows, a]
            if min((y == 1).sum(), (y == 0).sum()) < 2:
                continue
            cols = stage_inputs(A.shape[1], a, own)
            P[held, a] = fit_stage(Z[np.ix_(fit_rows, cols)], y, C).predict_proba(Z[np.ix_(held, cols)])[:, 1]
    return P


def mean_balanced_log_loss(P: np.ndarray, A: np.ndarray) -> float:
    """Mean over attributes of the balanced log-loss of the non-missing posteriors ``P`` (n, m) of ``A`` (n, m)."""
    losses = []
    for a in range(A.shape[1]):
        known = ~np.isnan(P[:, a])
        if np.unique(A[known, a]).size == 2:
            losses.append(balanced_log_loss(A[known, a], P[known, a]))
    return float(np.mean(losses))


def stacked(Z_train: np.ndarray, A: np.ndarray, groups: np.ndarray, Z_test: np.ndarray, own: bool) -> dict:
    """H_stack's stage: ``C`` from :data:`STACK_C_GRID` by grouped CV, refitted, applied to ``Z_test``.

    Returns ``{"C", "cv_log_loss" (len(grid),), "P_oof" (n_train, m) at the chosen C, "P_fit" (n_train, m)
    in-sample, "P_test" (n_test, m)}``.
    """
    oofs = [stage_oof(Z_train, A, groups, C, own) for C in STACK_C_GRID]
    losses = np.array([mean_balanced_log_loss(P, A) for P in oofs])
    j = int(np.argmin(losses))
    C = STACK_C_GRID[j]
    m = A.shape[1]
    P_fit, P_test = np.empty(A.shape), np.empty((Z_test.shape[0], m))
    for a in range(m):
        cols = stage_inputs(m, a, own)
        stage = fit_stage(Z_train[:, cols], A[:, a], C)
        P_fit[:, a] = stage.predict_proba(Z_train[:, cols])[:, 1]
        P_test[:, a] = stage.predict_proba(Z_test[:, cols])[:, 1]
    return {"C": C, "cv_log_loss": losses, "P_oof": oofs[j], "P_fit": P_fit, "P_test": P_test}


def to_logits(P: np.ndarray) -> np.ndarray:
    """Logits of posteriors clipped to ``[EPS, 1 - EPS]`` (NaN stays NaN)."""
    return logit(np.clip(P, EPS, 1 - EPS))


def structure(label: str, S_oof: np.ndarray, S_fit: np.ndarray, S_test: np.ndarray, A_train: np.ndarray,
              A_test: np.ndarray, g_train: np.ndarray, g_test: np.ndarray) -> dict[str, float]:
    """Measurement (a) of one method's held-out (n_train, m), in-sample and test (n_test, m) logits, keys
    ``<label>_...``."""
    mu, _ = class_means(S_oof, A_train, g_train, S_fit)
    oof = error_structure(S_oof, residuals(S_oof, A_train, mu), A_train, g_train)
    test = error_structure(S_test, residuals(S_test, A_test, mu), A_test, g_test)
    return {**{f"{label}_oof_{k}": v for k, v in oof.items()}, **{f"{label}_test_{k}": v for k, v in test.items()},
            f"{label}_test_error_corr01": within_object_error_correlation(A_test, (S_test >= 0).astype(int), g_test)}


def score_split(features, split, seed: int, references: bool, out: Path) -> tuple[pd.DataFrame, dict]:
    """One split: per-trial correctness of the reference, ``stack``, ``stack-own``, ``sparse`` (and references)."""
    train, test = split_masks(features, split)
    A = features.attributes.loc[features.objects, list(split.kept_attributes)].to_numpy(dtype=int)
    A_train, A_test, g_train, g_test = A[train], A[test], features.objects[train], features.objects[test]
    X_train, X_test = features.X[train], features.X[test]
    K = features.attributes.loc[list(split.test_objects), list(split.kept_attributes)].to_numpy(dtype=int)
    info: dict = {"split": split.name}
    start = time.process_time()
    fit, y = fit_predict_split({"name": DETECTOR_METHOD, "calibration": "none"}, features, split, seed)
    bank = fit.model.attribute_model_
    rows = [(DETECTOR_METHOD, fit.predicted == y)]
    info["c1_dap_agreement"] = float(np.mean(dap_predict(bank.predict_proba(X_test), A_train, K, seed)
                                             == fit.predicted))
    cache = out / f"{split.name}.npz"
    if cache.exists():
        S_oof = np.load(cache)["S_oof"]
    else:
        S_oof = held_out_logits(bank, X_train, A_train, g_train)
        np.savez(cache, S_oof=S_oof)
    S_fit, S_test = fused_logits(bank, X_train), fused_logits(bank, X_test)
    info.update(structure("c1", S_oof, S_fit, S_test, A_train, A_test, g_train, g_test))
    info["cpu_c1"] = time.process_time() - start

    start = time.process_time()
    for label, own in (("stack", False), ("stack-own", True)):
        st = stacked(np.nan_to_num(S_oof, nan=0.0), A_train, g_train, S_test, own)
        rows.append((label, dap_predict(st["P_test"], A_train, K, seed) == y))
        info[f"{label}_C"] = st["C"]
        info.update(structure(label, to_logits(st["P_oof"]), to_logits(st["P_fit"]), to_logits(st["P_test"]),
                              A_train, A_test, g_train, g_test))
    info["cpu_stack"] = time.process_time() - start

    start = time.process_time()
    sparse = AttributeClassifierBank(estimator=SparseLogisticAttribute(), solver="exact", memory=False,
                                     random_state=seed).fit(X_train, A_train, g_train)
    rows.append(("sparse", dap_predict(sparse.predict_proba(X_test), A_train, K, seed) == y))
    chosen_C = np.array([[est.C_ for est in per] for per in sparse.estimators_])
    info.update({"sparse_C_median": float(np.median(chosen_C)),
                 "sparse_C_at_low_end": float(np.mean(chosen_C == SPARSE_C_GRID[0])),
                 "sparse_C_at_high_end": float(np.mean(chosen_C == SPARSE_C_GRID[-1])),
                 "sparse_nonzero": float(np.mean([[est.n_nonzero_ for est in per] for per in sparse.estimators_]))})
    info.update(structure("sparse", held_out_logits(pinned(sparse), X_train, A_train, g_train),
                          fused_logits(sparse, X_train), fused_logits(sparse, X_test),
                          A_train, A_test, g_train, g_test))
    info["cpu_sparse"] = time.process_time() - start

    if references:
        for label in ("dap-avg", "eszsl"):
            member, truth = fit_predict_split(MEMBERS[label], features, split, seed)
            rows.append((label, member.predicted == truth))
    classes = np.asarray(split.test_objects)[y]
    table = pd.concat([pd.DataFrame({"method": label, "split": split.name, "class": classes, "trial": np.arange(len(y)),
                                     "correct": correct.astype(float)}) for label, correct in rows], ignore_index=True)
    return table, info


def adopted(result: pd.DataFrame) -> pd.DataFrame:
    """The decision rule of the module docstring (``phac2_correlated_dap.decision`` with this script's candidates)."""
    chosen = decision(result)
    chosen["adoptable"] = chosen["method"].isin(CANDIDATES) & chosen["beats_dap"]
    return chosen


def main() -> None:
    lever_main(__doc__, score_split,
               lambda info: (f"; between-share c1 {info['c1_test_between_share']:.2f}, stack "
                             f"{info['stack_test_between_share']:.2f}, sparse {info['sparse_test_between_share']:.2f};"
                             f" cpu c1 {info['cpu_c1']:.0f} s, stack {info['cpu_stack']:.0f} s, sparse "
                             f"{info['cpu_sparse']:.0f} s"),
               adopted)


if __name__ == "__main__":
    main()
