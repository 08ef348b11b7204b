"""Fitting one fabric zero-shot run, and every method of the fabric study side by side.

:func:`run_job` is one fit of the fabric study (:mod:`tzsl.studies.fabric.study`): the embedding
model at one lambda (weight decay by class-grouped CV), ESZSL, or a registry method of
``[methods] compare``, on the training groups of one split only.

:func:`fabric_comparison` turns the study's fits into ``fabric_method_comparison.csv``, one
block per data condition (``study = fabric-<condition>``), scored like every study's comparison
(:func:`tzsl.studies.comparison.method_runs.method_summary`): the splits are (config, seed) pairs, the
bootstrap clusters are fabrics (a fabric's images are not independent), and a deterministic
method's predictions count for every seed, so each method is paired with the reference on the
same test samples. The reference is the paper's method, the embedding ``C + lambda R`` at the
paper's best lambda 0.1. The paper's numbers belong to GelSight videos, a CNN+LSTM and config 1
only; beside the depth-image rows they are for orientation (the note says so).
"""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pandas as pd
from sklearn.exceptions import ConvergenceWarning

from tzsl._parallel import one_blas_thread
from tzsl.datasets import FabricSplit
from tzsl.evaluation import per_class_mean_accuracy, select_embedding_alpha, trial_accuracy
from tzsl.exceptions import ConfigError
from tzsl.fit_store import fit_cached, fit_store_counts
from tzsl.models import build_method
from tzsl.models.protocol import LAST_BIT_NOTE, attribute_rows, moves_with_last_bit
from tzsl.studies.comparison.method_runs import (
    comparison_file,
    comparison_trials,
    method_input,
    method_summary,
    study_estimator,
)
from tzsl.studies.fabric.samples import FabricSamples
from tzsl.studies.fabric.tables import ESZSL_METHOD
from tzsl.studies.outputs.failures import ERROR_COLUMN, attempt

__all__ = ["COMPARISON_TABLE", "REFERENCE_LAMBDA", "ZeroShotRun", "fabric_comparison", "run_job", "zero_shot_run",
           "zero_shot_runs"]

#: Table key (file stem) of the study's comparison.
COMPARISON_TABLE = comparison_file("fabric")[: -len(".csv")]
#: Lambda of the reference row (the paper's best on average, Table 1); the first lambda run if absent.
REFERENCE_LAMBDA = "0.1"


class _Predictor(Protocol):
    """A fitted zero-shot model: ``predict(X, class_attributes)`` -> row indices of ``class_attributes``."""

    def predict(self, X: np.ndarray, class_attributes: np.ndarray, /) -> Any: ...


@dataclass(frozen=True)
class ZeroShotRun:
    """One zero-shot fit and its predictions.

    Attributes
    ----------
    model : object
        The fitted model (``predict(X, class_attributes)`` -> row indices).
    train_classes : ndarray (k_train,)
        Groups whose samples and attribute rows were given to ``fit`` (sorted).
    test_classes : ndarray (k_test,)
        Candidate groups at prediction time (the split's test groups).
    y_true, y_pred : ndarray (n_test,)
        True and predicted group of every test sample.
    """

    model: object
    train_classes: np.ndarray
    test_classes: np.ndarray
    y_true: np.ndarray
    y_pred: np.ndarray

    @property
    def accuracy(self) -> float:
        """Fraction of test samples recognised."""
        return trial_accuracy(self.y_true, self.y_pred)

    @property
    def per_class_mean_accuracy(self) -> float:
        """Mean over test groups of each group's accuracy."""
        return per_class_mean_accuracy(self.y_true, self.y_pred)


def zero_shot_run(
    fit_model: Callable[[np.ndarray, np.ndarray, np.ndarray], _Predictor],
    X: np.ndarray,
    groups: np.ndarray,
    attribute_matrix: np.ndarray,
    split: FabricSplit,
) -> ZeroShotRun:
    """Fit on the training groups of ``split`` only; recognise test samples among the test groups.

    Parameters
    ----------
    fit_model : callable
        ``fit_model(X_train, y_train, S_train) -> fitted model``: ``X_train`` (n_train, d) and
        ``y_train`` (n_train,) are the training-group samples, ``S_train`` (k_train, m) the
        attribute rows of ``np.unique(y_train)``. Test samples and test attribute rows are never
        passed to it.
    X : ndarray of shape (n_samples, d)
    groups : ndarray of shape (n_samples,), int
        Group of every sample.
    attribute_matrix : ndarray of shape (n_groups, m)
        Group x attribute matrix (row g = group g).
    split : FabricSplit

    Returns
    -------
    ZeroShotRun

    Raises
    ------
    ConfigError
        No training or no test sample.
    """
    return zero_shot_runs(fit_model, X, groups, attribute_matrix, [split])[0]


def zero_shot_runs(
    fit_model: Callable[[np.ndarray, np.ndarray, np.ndarray], _Predictor],
    X: np.ndarray,
    groups: np.ndarray,
    attribute_matrix: np.ndarray,
    splits: Sequence[FabricSplit],
) -> list[ZeroShotRun]:
    """:func:`zero_shot_run` for splits with the same training groups: one fit, one prediction per split.

    The paper's split and its zero-shot variant train on the same groups and differ in the test
    groups only (:func:`~tzsl.studies.fabric.tables.fabric_protocols`); their fit is the same
    computation, so it is done once and each split's test samples are recognised among its own
    test groups.

    Parameters
    ----------
    fit_model, X, groups, attribute_matrix
        As in :func:`zero_shot_run`.
    splits : sequence of FabricSplit
        Non-empty; all with the same ``train_groups``.

    Returns
    -------
    list of ZeroShotRun
        One per split, in order; all share one fitted ``model``.

    Raises
    ------
    ConfigError
        Splits with different training groups; a split without training or test samples.
    """
    if not splits or len({tuple(sp.train_groups) for sp in splits}) != 1:
        raise ConfigError(f"zero_shot_runs needs splits with one set of training groups; got "
                          f"{[list(sp.train_groups) for sp in splits]}")
    X = np.asarray(X)
    groups = np.asarray(groups)
    A = np.asarray(attribute_matrix, dtype=np.float64)
    tests = []
    for split in splits:
        train, test = split.is_train(groups), split.is_test(groups)
        if not train.any() or not test.any():
            raise ConfigError(
                f"fabric config {split.config}: {int(train.sum())} training and {int(test.sum())} test "
                f"samples (train groups {list(split.train_groups)}, test groups {list(split.test_groups)}); "
                "both must be non-empty"
            )
        tests.append(test)
    train_classes = np.unique(groups[train])
    model = fit_model(X[train], groups[train], A[train_classes])
    runs = []
    for split, test in zip(splits, tests, strict=True):
        test_classes = np.asarray(split.test_groups)
        rows = model.predict(X[test], A[test_classes])
        runs.append(ZeroShotRun(model=model, train_classes=train_classes, test_classes=test_classes,
                                y_true=groups[test], y_pred=test_classes[np.asarray(rows)]))
    return runs


class _ShapedInput:
    """A fitted registry method that reshapes the study's 2-D samples for its own input (``predict``)."""

    def __init__(self, model, spec: dict) -> None:
        self.model, self.spec = model, spec

    def predict(self, X, class_attributes):
        return self.model.predict(method_input(self.spec, X), class_attributes)


def run_job(
    samples_X: np.ndarray,
    groups: np.ndarray,
    A: np.ndarray,
    splits: Sequence[FabricSplit],
    method: str,
    lam,
    seed: int | None,
    alphas: tuple[float, ...],
    max_iter: int,
    spec: dict | None = None,
) -> list[dict]:
    """One fit (method x seed) on one condition, scored on each split; returns a runs-table row per split.

    ``splits`` share their training groups (:func:`zero_shot_runs`: one fit, one prediction per
    split; a failure is every split's). ``spec``: a registry method entry (``methods.compare``)
    fitted instead of the built-in ones. A row's ``correct`` (n_test,) marks the recognised test
    samples (for the comparison; not written to the runs table); ``fit_seconds`` times the fit with
    its model selection (the same fit for every split). The first row's ``_fit_store`` is
    ``(process id, this job's fit-store events)``, for the parent to count jobs run in workers.
    """
    info: dict = {}
    before = fit_store_counts()

    def fit_embedding(X_tr, y_tr, S_tr):
        alpha, scores = select_embedding_alpha(
            X_tr, y_tr, S_tr, lam=lam, alphas=alphas, random_state=seed, max_iter=max_iter
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            model = fit_cached(build_method(
                "embedding", lam=lam, alpha=alpha, early_stopping=False, max_iter=max_iter,
                random_state=seed, calibration="none",
            ), X_tr, attribute_rows(y_tr, S_tr), y_tr)
        info.update(
            alpha=alpha,
            cv_score=np.nan if scores is None else float(scores.mean(axis=1)[list(alphas).index(alpha)]),
            n_iter=model.attribute_model_.n_iter_,
            converged=not any(issubclass(w.category, ConvergenceWarning) for w in caught),
        )
        return model

    def fit_eszsl(X_tr, y_tr, S_tr):
        model = fit_cached(build_method("eszsl", calibration="none"), X_tr, attribute_rows(y_tr, S_tr), y_tr)
        cv = model.attribute_model_
        info.update(gamma=cv.best_gamma_, eszsl_lam=cv.best_lam_, cv_score=cv.best_score_)
        return model

    def fit_registry(X_tr, y_tr, S_tr):
        model = fit_cached(study_estimator(spec, seed), method_input(spec, X_tr), attribute_rows(y_tr, S_tr), y_tr)
        return _ShapedInput(model, spec)

    def timed(X_tr, y_tr, S_tr):  # the fit and its model selection, not the prediction
        start = time.perf_counter()
        model = chosen(X_tr, y_tr, S_tr)
        info.update(fit_seconds=time.perf_counter() - start)
        return model

    chosen = fit_registry if spec is not None else fit_eszsl if method == ESZSL_METHOD else fit_embedding
    with one_blas_thread():  # many small fits: one BLAS thread each, parallel over fits
        runs, error = attempt(zero_shot_runs, timed, samples_X, groups, A, splits)
    if runs is None:  # recorded in the runs table (NaN scores), reported at the end of the run
        rows = [{"method": method, "seed": seed, "accuracy": np.nan, "per_class_mean_accuracy": np.nan,
                 "n_train": int(split.is_train(groups).sum()), "n_test": int(split.is_test(groups).sum()),
                 "train_classes": "", "predicted_counts": "", **info, ERROR_COLUMN: error} for split in splits]
    else:
        rows = [_run_row(run, method, seed, split, groups, info) for run, split in zip(runs, splits, strict=True)]
    rows[0]["_fit_store"] = (os.getpid(), fit_store_counts(since=before))  # not a runs column
    return rows


def _run_row(run: ZeroShotRun, method: str, seed: int | None, split: FabricSplit, groups: np.ndarray,
             info: dict) -> dict:
    """The runs-table row of one scored split (see :func:`run_job`)."""
    pred = pd.Series(run.y_pred).value_counts().reindex(run.test_classes, fill_value=0)
    return {
        "method": method,
        "seed": seed,
        "accuracy": run.accuracy,
        "per_class_mean_accuracy": run.per_class_mean_accuracy,
        "n_train": int(split.is_train(groups).sum()),
        "n_test": int(run.y_true.size),
        "train_classes": " ".join(map(str, run.train_classes)),
        "predicted_counts": " ".join(f"{g}:{c}" for g, c in pred.items()),
        **info,
        ERROR_COLUMN: "",
        "correct": run.y_true == run.y_pred,
        "_y": (run.y_true, run.y_pred),  # per-sample outcomes for the intervals (not a runs column)
    }


# ---------------------------------------------------------------------------------------------
# the comparison
# ---------------------------------------------------------------------------------------------
#: Comparison labels of the built-in methods, whose searches (ESZSL's ridges, the weight decay) score held-out classes.
BUILTIN_LABELS = ("eszsl", "embedding_lam_")


def _label(method: str) -> str:
    """Comparison label of a runs-table method: ``lam_0.1`` -> ``embedding_lam_0.1``, ``ESZSL`` -> ``eszsl``."""
    if method == ESZSL_METHOD:
        return "eszsl"
    return f"embedding_{method}" if method.startswith("lam_") else method


def fabric_comparison(runs: pd.DataFrame, correct: list[np.ndarray], samples: Sequence[FabricSamples],
                      splits: dict[int, FabricSplit], seeds: Sequence[int], lam_labels: Sequence[str]) -> pd.DataFrame:
    """Every method of the fabric study on the same test samples, per data condition.

    Parameters
    ----------
    runs : DataFrame
        The runs table (condition, config, method, seed, ...), one row per fit.
    correct : list of ndarray
        Per run row, the recognised test samples (n_test,) in sample order.
    samples : sequence of FabricSamples
        The conditions run (their ``samples["fabric_id"]`` cluster the bootstrap).
    splits : dict
        Config -> FabricSplit.
    seeds : sequence of int
        The study's seeds; a deterministic method (seed missing) counts for each.
    lam_labels : sequence of str
        The lambdas run (labels); the reference is ``REFERENCE_LAMBDA`` when run, else the first.

    Returns
    -------
    DataFrame
        :data:`~tzsl.studies.comparison.method_runs.COMPARISON_COLUMNS`, one block per condition.
    """
    ref_lam = REFERENCE_LAMBDA if REFERENCE_LAMBDA in lam_labels else lam_labels[0]
    reference = f"embedding_lam_{ref_lam}"
    blocks = []
    for s in samples:
        fabric_ids = s.samples["fabric_id"].to_numpy()
        trials: list[pd.DataFrame] = []
        seconds: dict[str, list[float]] = {}
        for i in np.flatnonzero(runs["condition"].to_numpy() == s.condition):
            row = runs.iloc[i]
            clusters = fabric_ids[splits[int(row["config"])].is_test(s.groups)]
            label = _label(row["method"])
            run_seeds = seeds if pd.isna(row["seed"]) else [int(row["seed"])]
            for sd in run_seeds:
                trials.append(comparison_trials(label, f"config{int(row['config'])}-seed{sd}", clusters, correct[i]))
            seconds.setdefault(label, []).append(float(row.get("fit_seconds", np.nan)))
        chance = float(np.mean([1.0 / len(splits[c].test_groups) for c in sorted(set(runs["config"]))]))
        # the comparison runs on the zero-shot protocol; the paper's numbers are for its own split
        # (not zero-shot for config 1), so they stay in fabric_table1.csv's protocol = paper rows
        notes = {reference: "the paper's method (reference); the paper's numbers: fabric_table1.csv, protocol = paper"}
        if moves_with_last_bit():  # the built-in methods' searches score a count
            notes = {label: "; ".join(filter(None, (notes.get(label), LAST_BIT_NOTE)))
                     for label in {_label(m) for m in runs["method"]} if label.startswith(BUILTIN_LABELS)}
        blocks.append(method_summary(pd.concat(trials, ignore_index=True), seconds, chance, reference,
                                     study=f"fabric-{s.condition}", notes=notes, split_kind="groups"))
    return pd.concat(blocks, ignore_index=True)
