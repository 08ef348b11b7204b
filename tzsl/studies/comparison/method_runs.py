"""Registry methods inside a study: one timed fit-and-predict for any method of ``tzsl methods``.

A study lists methods as ``{"name": registry name, **parameters}`` (the experiment file's
``methods.compare``, checked at load time). Every study kind fits them the same way, through
:func:`fit_predict`:

* input shape from the registry (:attr:`tzsl.models.Method.input_ndim`): per-sensor methods get
  ``(n_trials, n_sensors, n_features)``, the others the sensors side by side
  ``(n_trials, n_sensors * n_features)``; a 2-D study input is one sensor for a per-sensor method;
* seed: a method whose estimator takes ``random_state`` gets the study's seed for that fit,
  unless the entry sets ``random_state`` itself; deterministic methods get none;
* fit on the training trials with their attribute rows (:func:`tzsl.models.protocol.attribute_rows`),
  predict the test trials among the test classes' attribute rows (zero-shot).

Every study then scores its methods the same way (:func:`method_summary`): one row per method of
``<study>_method_comparison.csv`` with the trial accuracy, its two-level bootstrap 95% interval
(splits, then test classes with their trials), the paper's number where the paper has one, chance,
the fit time, and the paired difference to the paper's method of that study on the same trials;
where the trials carry posterior columns, the calibration of the class posteriors (ECE and Brier
score, calibrated and uncalibrated, with intervals: :mod:`tzsl.studies.comparison.calibration`).
``tzsl evidence`` stacks the studies' tables into ``method_comparison.csv``
(:func:`combine_comparisons`), with a row saying why for every registered method a study cannot
run (its input differs: grasps, frame sequences).
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
import pandas as pd

from tzsl._profile import timed
from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, bootstrap_accuracy, paired_differences_table
from tzsl.exceptions import SplitError
from tzsl.fit_store import fit_cached
from tzsl.models import available_methods, get_method
from tzsl.models.protocol import attribute_rows
from tzsl.studies.comparison.calibration import CALIBRATION_COLUMNS, add_calibration, method_posteriors
from tzsl.studies.config import method_label, registered_method

__all__ = [
    "COMPARISON_COLUMNS",
    "COMPARISON_FILE",
    "FEW_CLASSES",
    "MethodFit",
    "combine_comparisons",
    "comparison_file",
    "comparison_trials",
    "fit_predict",
    "grid_edge_share",
    "method_input",
    "method_label",
    "method_summary",
    "split_masks",
    "study_estimator",
    "takes_seed",
]

#: ``tzsl evidence``' table of every method x study.
COMPARISON_FILE = "method_comparison.csv"

#: Columns of every study's method comparison (and of :data:`COMPARISON_FILE`).
COMPARISON_COLUMNS = [
    "study", "data", "purpose", "split_kind", "method", "accuracy", "ci95_low", "ci95_high", "paper_accuracy",
    "chance", "fit_seconds", "share_at_grid_edge", "difference", "difference_ci95_low", "difference_ci95_high",
    "reference", "n_splits", "n_trials", "sd_over_splits", "sd_over_refit_seeds", "note", *CALIBRATION_COLUMNS,
]


def split_masks(features: FeatureSet, split: Split) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks (n_trials,) of the split's training and test trials; unknown objects raise SplitError."""
    objects = features.objects
    unknown = (set(split.train_objects) | set(split.test_objects)) - set(objects)
    if unknown:
        raise SplitError(f"split {split.name}: objects without trials: {sorted(unknown)}")
    return np.isin(objects, split.train_objects), np.isin(objects, split.test_objects)


def comparison_file(study: str) -> str:
    """File of one study's comparison: ``<study>_method_comparison.csv``."""
    return f"{study}_{COMPARISON_FILE}"


def takes_seed(spec: dict) -> bool:
    """Whether the study seeds this entry: the method takes ``random_state`` (its estimator, its attribute
    model, or the calibrator that deals its pseudo-unseen folds) and the entry sets none."""
    return "random_state" not in spec and "random_state" in get_method(spec["name"]).parameters()


def study_estimator(spec: dict, seed: int | None):
    """An unfitted estimator of the method entry ``spec``, seeded with ``seed`` where it is random
    (a calibratable method is built calibrated unless the entry says ``calibration = "none"``)."""
    params = {k: v for k, v in spec.items() if k != "name"}
    if seed is not None and takes_seed(spec):
        params["random_state"] = int(seed)
    return get_method(spec["name"]).build(**params)


def method_input(spec: dict, X: np.ndarray) -> np.ndarray:
    """``X`` shaped for the method: 3-D ``(n, sensors, features)`` or 2-D ``(n, sensors * features)``."""
    X = np.asarray(X)
    if get_method(spec["name"]).input_ndim == 3:
        return X if X.ndim == 3 else X[:, None, :]
    return X.reshape(X.shape[0], -1)


class MethodFit(NamedTuple):
    """One fit of one method: the fitted estimator, predicted test rows, wall-clock fit seconds, and the
    test trials' calibrated and uncalibrated class posteriors (None without ``predict_proba``)."""

    model: object
    predicted: np.ndarray
    fit_seconds: float
    proba: np.ndarray | None = None
    proba_uncalibrated: np.ndarray | None = None


@timed("fit")
def fit_predict(spec: dict, X_train: np.ndarray, classes_train: np.ndarray, class_rows: np.ndarray,
                X_test: np.ndarray, test_rows: np.ndarray, seed: int | None = None) -> MethodFit:
    """Fit the method on training trials; predict test trials among the test classes.

    Parameters
    ----------
    spec : dict
        ``{"name": registry name, **parameters}``.
    X_train : ndarray of shape (n_train, d) or (n_train, n_sensors, d)
    classes_train : ndarray of shape (n_train,)
        Training class (object or group) of each trial; also the CV groups.
    class_rows : ndarray of shape (n_train_classes, m)
        Attribute rows of ``np.unique(classes_train)``, in that order.
    X_test : ndarray of shape (n_test, ...) like ``X_train``
    test_rows : ndarray of shape (n_test_classes, m)
        The candidate (test) classes' attribute rows.
    seed : int or None

    Returns
    -------
    MethodFit
        ``predicted``: row of ``test_rows`` of every test trial, shape (n_test,).
    """
    start = time.perf_counter()  # small when the fit store holds the fit
    model = fit_cached(study_estimator(spec, seed), method_input(spec, X_train),
                       attribute_rows(classes_train, class_rows), classes_train)
    seconds = time.perf_counter() - start
    X_in = method_input(spec, X_test)
    return MethodFit(model, np.asarray(model.predict(X_in, test_rows)), seconds,
                     *method_posteriors(model, X_in, test_rows))


# --------------------------------------------------------------------------- scoring, shared by every study


def grid_edge_share(model) -> float:
    """Share of a fitted model's hyper-parameter searches whose chosen value sits at a grid edge.

    Reads ``at_grid_edge_`` (ESZSLCV, SAECV: one search) or an attribute bank's ``grid_edge_hits_``
    (one search per (attribute, sensor) fit; a fit counts once however many of its parameters
    are at an edge), looking through ``attribute_model_`` and ``estimator_`` wrappers.

    Returns
    -------
    float
        In [0, 1]; NaN when the model records no grid search.
    """
    for inner in ("attribute_model_", "estimator_"):
        if hasattr(model, inner):
            return grid_edge_share(getattr(model, inner))
    if hasattr(model, "at_grid_edge_"):
        return float(model.at_grid_edge_)
    if hasattr(model, "grid_edge_hits_") and hasattr(model, "estimators_"):
        n_fits = sum(len(per) for per in model.estimators_)
        hit = {(h["attribute"], h["sensor"]) for h in model.grid_edge_hits_}
        return len(hit) / n_fits if n_fits else float("nan")
    return float("nan")


def comparison_trials(method: str, split, classes: np.ndarray, correct: np.ndarray,
                      **posteriors: np.ndarray) -> pd.DataFrame:
    """One row per test trial of one method on one split: method, split, class, trial, correct (0/1).

    ``classes`` (n_trials,): the true class (object, fabric, grasped object) of each trial, the
    bootstrap's cluster; ``trial`` is the position within the split (the pairing key);
    ``posteriors``: per-trial calibration columns
    (:func:`tzsl.studies.comparison.calibration.posterior_columns`).
    """
    classes = np.asarray(classes)
    return pd.DataFrame({"method": method, "split": str(split), "class": classes,
                         "trial": np.arange(len(classes)), "correct": np.asarray(correct, dtype=float),
                         **posteriors})


def method_summary(trials: pd.DataFrame, fit_seconds: dict[str, list[float]], chance: float, reference: str,
                   *, study: str, data: str = "real", paper: dict[str, float] | None = None,
                   notes: dict[str, str] | None = None,
                   grid_edge: dict[str, list[float]] | None = None, purpose: str = "",
                   split_kind: str = "") -> pd.DataFrame:
    """One row per method: accuracy with its 95% interval, fit time, paired difference to ``reference``.

    Parameters
    ----------
    trials : DataFrame
        :func:`comparison_trials` rows of every method; every method scored on the reference's
        trials (same splits, same trial positions).
    fit_seconds : dict
        Wall-clock seconds of every fit, per method (NaN: not timed).
    chance : float
        Mean over splits of 1 / number of test classes.
    reference : str
        The paper's method of the study (subtracted in ``difference``).
    study : str
        Study label (``phac2-random``, ``fabric-depth-sequence``, ``hand``, ...).
    data : str
        ``"real"`` or ``"simulated"``.
    paper : dict, optional
        The paper's accuracy per method, where it reports one.
    notes : dict, optional
        A note per method (e.g. where the paper's number comes from).
    grid_edge : dict, optional
        :func:`grid_edge_share` of every fit, per method; ``share_at_grid_edge`` is their mean
        (NaN: no grid search recorded).
    purpose : str, optional
        ``"select"`` or ``"confirm"``: what the splits are for (:data:`tzsl.evaluation.PURPOSES`);
        empty for studies whose splits have no purpose.
    split_kind : str
        How the test classes were chosen (``random``, ``challenging``, ``groups``: held-out fabric
        groups, ``paper``: the paper's test objects), the ``split_kind`` column.

    Returns
    -------
    DataFrame
        :data:`COMPARISON_COLUMNS`: accuracy is the mean over splits of the per-split trial
        accuracy; ci95_low/high its two-level bootstrap interval (splits, then classes with
        their trials); difference = method minus ``reference`` on the same trials, with its
        paired interval; fit_seconds the mean per fit; ``sd_over_splits`` the standard deviation
        (ddof 1) of the per-split accuracy; ``sd_over_refit_seeds`` NaN here (the PHAC-2 study
        fills it from its refits: :func:`tzsl.studies.zero_shot.spread.add_refit_spread`).
    """
    paper, notes, grid_edge = paper or {}, notes or {}, grid_edge or {}
    rows = []
    for method, t in trials.groupby("method", sort=False):
        iv = bootstrap_accuracy(t["correct"].to_numpy(), classes=t["class"].to_numpy(), splits=t["split"].to_numpy())
        seconds = [s for s in fit_seconds.get(method, []) if s is not None]
        per_split = t.groupby("split", sort=False)["correct"].mean()
        rows.append({"study": study, "data": data, "purpose": purpose, "split_kind": split_kind, "method": method,
                     "accuracy": iv.mean,
                     "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high, "paper_accuracy": paper.get(method, np.nan),
                     "chance": chance, "fit_seconds": float(np.mean(seconds)) if seconds else np.nan,
                     "share_at_grid_edge": _mean_or_nan(grid_edge.get(method, [])),
                     "n_splits": t["split"].nunique(), "n_trials": len(t),
                     "sd_over_splits": float(per_split.std(ddof=1)) if len(per_split) > 1 else np.nan,
                     "sd_over_refit_seeds": np.nan, "note": notes.get(method, "")})
    table = pd.DataFrame(rows)
    diffs = _paired_differences(trials, reference).rename(
        columns={"ci95_low": "difference_ci95_low", "ci95_high": "difference_ci95_high"})
    table = table.merge(diffs[["method", "difference", "difference_ci95_low", "difference_ci95_high"]],
                        on="method", how="left")
    table["reference"] = reference
    return add_calibration(table, trials)[COMPARISON_COLUMNS]


def _mean_or_nan(values: list[float]) -> float:
    """Mean of the finite values; NaN when there are none."""
    finite = [v for v in values if v is not None and np.isfinite(v)]
    return float(np.mean(finite)) if finite else float("nan")


#: Studies by the input their methods take; a registered method of another input kind is listed
#: as not run, with the reason.
_STUDY_INPUT = {"phac2": "features", "fabric": "features", "hand": "grasps"}
_WHY = {"grasps": "needs hand grasps (5 BioTacs + joint angles)",
        "frames": "needs frame sequences (the fabric-deep study: tzsl run fabric-deep)",
        "features": "needs feature vectors"}


#: Why the per-attribute SVM methods are not run on the fabric and hand training sets.
FEW_CLASSES = ("not run: its per-attribute classifiers are tuned by class-grouped CV and need >= 2 training "
               "classes with and without every attribute; here some attributes belong to one training class")


def combine_comparisons(tables: list[pd.DataFrame], reasons: dict[str, dict[str, str]] | None = None) -> pd.DataFrame:
    """Stack study comparisons into one table of every method x study (and split kind).

    A registered method missing from a study (split kind) gets a row without accuracy whose note says why:
    its input kind, ``reasons[study prefix][method]`` (e.g. ``{"fabric": {"dap": ...}}``),
    or "not run in this study"; a row of any DAP configuration (``dap-avg``, ``dap-max-logistic-c1``) is a
    run of ``dap`` (:func:`~tzsl.studies.config.registered_method`). Studies (and their split kinds) keep
    their order; within each, the rows run, then the rows not run.
    """
    reasons = reasons or {}
    parts = []
    for table in tables:
        for (study, split_kind), sub in table.groupby(["study", "split_kind"], sort=False):
            parts.append(sub)
            kind = _STUDY_INPUT.get(str(study).split("-")[0], "features")
            ran = {registered_method(str(m)) for m in sub["method"]}  # dap-max-logistic-c1: dap
            missing = []
            for name in available_methods():
                if name in ran:
                    continue
                own = get_method(name).input_kind
                usable = own == kind or (kind == "grasps" and own == "features")
                note = (reasons.get(str(study).split("-")[0], {}).get(name, "not run in this study") if usable
                        else f"not applicable: {_WHY[own]}")
                missing.append({"study": study, "data": sub["data"].iloc[0], "split_kind": split_kind,
                                "method": name, "note": note, "reference": sub["reference"].iloc[0]})
            if missing:
                parts.append(pd.DataFrame(missing))
    return pd.concat(parts, ignore_index=True).reindex(columns=COMPARISON_COLUMNS) if parts else pd.DataFrame(
        columns=COMPARISON_COLUMNS)


def _paired_differences(trials: pd.DataFrame, reference: str) -> pd.DataFrame:
    """Each method minus ``reference`` on the splits that method completed (a failed fit drops a split)."""
    parts = []
    for method in [m for m in trials["method"].unique() if m != reference]:
        splits = trials.loc[trials["method"] == method, "split"].unique()
        pair = trials[trials["method"].isin([method, reference]) & trials["split"].isin(splits)]
        parts.append(paired_differences_table(pair, reference=reference))
    columns = ["method", "difference", "ci95_low", "ci95_high"]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=columns)
