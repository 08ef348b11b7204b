"""Do the class posteriors mean what they say? Expected calibration error, Brier score, reliability.

A zero-shot method gives each test trial a posterior over the candidate (test) classes. Two
numbers check it against what happened on the test objects:

* **Expected calibration error (ECE)**, top-label: the trials are sorted by their *confidence*
  (the largest class probability) and cut into ``n_bins`` bins of equal size (equal mass: each
  bin holds the same number of trials, give or take one); in each bin the mean confidence is
  compared with the share of trials whose top class is right. ECE is the trial-weighted mean of
  ``|accuracy - confidence|`` over the bins: 0 when "0.8" is right 8 times in 10, up to 1.
  A calibrated posterior still shows a small positive ECE from the finite number of trials per
  bin (about ``0.8 sqrt(p (1 - p) / trials per bin)``).
* **Brier score**, multi-class: the mean over trials of ``sum_k (p_k - 1[k = true class])^2``,
  in [0, 2]; it rewards posteriors that are both calibrated and sharp (0 = certain and right).

Trials of several splits are pooled (each split's posterior is over its own test classes;
confidence, correctness and the per-trial Brier term do not depend on how many classes there
were). Intervals use the project's two-level bootstrap (:mod:`tzsl.evaluation._intervals`:
splits, then test classes with all their trials) through
:func:`~tzsl.evaluation.bootstrap_cell_weights`; the bins are those of the point estimate
(a resampled trial keeps its bin). A replicate is a row of cell counts (times each (split,
class) cell was drawn), and its per-bin sums and Brier total are that row times the per-cell
sums: one matrix product for all replicates, no (replicates, trials) matrix. ECE is an absolute
value, biased upward on small samples, and a replicate drawn with replacement repeats objects,
so the replicates sit above the point value (with 50 test objects the whole percentile range
can lie above it). The ECE interval is therefore bias-corrected: the replicates are shifted by
their mean minus the point value (the bootstrap estimate of that bias) before taking
percentiles, and clipped at 0. The Brier score is a mean and uses the plain percentile interval.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from tzsl.evaluation._intervals import DEFAULT_N_BOOT, Interval, bootstrap_cell_weights, cluster_cells
from tzsl.exceptions import TzslError

__all__ = [
    "CALIBRATION_METRICS",
    "DEFAULT_N_BINS",
    "VARIANTS",
    "CalibrationTerms",
    "add_calibration_columns",
    "brier_score",
    "calibration_columns",
    "calibration_intervals",
    "calibration_terms",
    "equal_mass_bins",
    "expected_calibration_error",
    "expected_ece_if_calibrated",
    "reliability_table",
]

#: Equal-mass bins of the expected calibration error and the reliability diagram.
DEFAULT_N_BINS = 10

#: Names of the calibration metrics, as columns of the method comparisons.
CALIBRATION_METRICS = ("ece", "brier")


class CalibrationTerms(NamedTuple):
    """What calibration needs of each trial, whatever its number of candidate classes.

    Attributes
    ----------
    confidence : ndarray of shape (n_trials,)
        Probability of the predicted (top) class.
    correct : ndarray of shape (n_trials,)
        1.0 where the predicted class is the true one, else 0.0.
    brier : ndarray of shape (n_trials,)
        ``sum_k (p_k - 1[k = true])^2`` of the trial, in [0, 2].
    """

    confidence: np.ndarray
    correct: np.ndarray
    brier: np.ndarray


def calibration_terms(proba, y_true, predicted=None) -> CalibrationTerms:
    """Per-trial confidence, correctness and Brier term of class posteriors.

    Parameters
    ----------
    proba : array-like of shape (n_trials, n_classes)
        Class posteriors (rows sum to 1).
    y_true : array-like of int, shape (n_trials,)
        Column of the true class of each trial.
    predicted : array-like of int, shape (n_trials,), optional
        The method's prediction (its tie-breaking); default: the argmax of ``proba``.

    Returns
    -------
    CalibrationTerms
    """
    P = np.asarray(proba, dtype=np.float64)
    y = np.asarray(y_true)
    if P.ndim != 2 or P.shape[0] == 0 or y.shape != (P.shape[0],):
        raise TzslError(f"proba must be (n_trials, n_classes) and y_true (n_trials,), got {P.shape} and {y.shape}")
    if not np.isfinite(P).all() or (P < 0).any() or not np.allclose(P.sum(axis=1), 1.0, atol=1e-6):
        raise TzslError("proba must hold finite non-negative rows summing to 1")
    if not np.issubdtype(y.dtype, np.integer) or (y < 0).any() or (y >= P.shape[1]).any():
        raise TzslError(f"y_true must be class columns in [0, {P.shape[1]})")
    pred = P.argmax(axis=1) if predicted is None else np.asarray(predicted, dtype=int)
    rows = np.arange(len(y))
    onehot = np.zeros_like(P)
    onehot[rows, y] = 1.0
    return CalibrationTerms(P[rows, pred], (pred == y).astype(float), ((P - onehot) ** 2).sum(axis=1))


def equal_mass_bins(confidence, n_bins: int = DEFAULT_N_BINS) -> np.ndarray:
    """Bin of each trial: trials sorted by confidence, cut into ``n_bins`` near-equal groups.

    Parameters
    ----------
    confidence : array-like of shape (n_trials,)
    n_bins : int, default 10
        At most the number of trials.

    Returns
    -------
    int ndarray of shape (n_trials,), values in [0, n_bins)
        Bin 0 holds the least confident trials. Ties keep their input order (stable sort).
    """
    c = np.asarray(confidence, dtype=float)
    if not isinstance(n_bins, (int, np.integer)) or n_bins < 1:
        raise TzslError(f"n_bins must be a positive integer, got {n_bins!r}")
    n_bins = min(int(n_bins), len(c))
    bins = np.empty(len(c), dtype=int)
    bins[np.argsort(c, kind="stable")] = (np.arange(len(c)) * n_bins) // max(len(c), 1)
    return bins


def _check_terms(confidence, correct) -> tuple[np.ndarray, np.ndarray]:
    c, k = np.asarray(confidence, dtype=float), np.asarray(correct, dtype=float)
    if c.ndim != 1 or c.shape != k.shape or c.size == 0:
        raise TzslError(f"confidence and correct must be 1-d of the same non-zero length, got {c.shape}, {k.shape}")
    if not (np.isfinite(c).all() and np.isfinite(k).all()) or (c < 0).any() or (c > 1).any():
        raise TzslError("confidence must lie in [0, 1] and correct be finite")
    return c, k


def _weighted_ece(confidence, correct, bins, n_bins, weights) -> np.ndarray:
    """ECE of each weight row; weights (r, n_trials) -> (r,)."""
    onehot = np.zeros((len(bins), n_bins))
    onehot[np.arange(len(bins)), bins] = 1.0
    gap = weights @ ((correct - confidence)[:, None] * onehot)  # (r, bins): summed accuracy - confidence
    return np.abs(gap).sum(axis=1) / weights.sum(axis=1)


def expected_calibration_error(confidence, correct, *, n_bins: int = DEFAULT_N_BINS) -> float:
    """Top-label expected calibration error with equal-mass bins (module docstring).

    Parameters
    ----------
    confidence : array-like of shape (n_trials,)
        Top-class probability of each trial (:func:`calibration_terms`).
    correct : array-like of shape (n_trials,)
        1 where the top class is right.
    n_bins : int, default 10

    Returns
    -------
    float in [0, 1]
    """
    c, k = _check_terms(confidence, correct)
    bins = equal_mass_bins(c, n_bins)
    return float(_weighted_ece(c, k, bins, int(bins.max()) + 1, np.ones((1, len(c))))[0])


def brier_score(proba, y_true) -> float:
    """Multi-class Brier score: mean over trials of ``sum_k (p_k - 1[k = true])^2``, in [0, 2].

    Parameters
    ----------
    proba : array-like of shape (n_trials, n_classes)
    y_true : array-like of int, shape (n_trials,)

    Returns
    -------
    float
    """
    return float(calibration_terms(proba, y_true).brier.mean())


def reliability_table(confidence, correct, *, n_bins: int = DEFAULT_N_BINS) -> pd.DataFrame:
    """The reliability diagram's points: per equal-mass bin, mean confidence against accuracy.

    Returns
    -------
    DataFrame
        One row per bin: ``bin``, ``confidence`` (mean top-class probability), ``accuracy``
        (share of right top classes), ``n_trials``, ``confidence_low`` / ``confidence_high``
        (the bin's range). A calibrated method's points lie on the diagonal.
    """
    c, k = _check_terms(confidence, correct)
    bins = equal_mass_bins(c, n_bins)
    frame = pd.DataFrame({"bin": bins, "c": c, "k": k}).groupby("bin", sort=True)
    return pd.DataFrame({"bin": frame["c"].mean().index, "confidence": frame["c"].mean().to_numpy(),
                         "accuracy": frame["k"].mean().to_numpy(), "n_trials": frame["c"].size().to_numpy(),
                         "confidence_low": frame["c"].min().to_numpy(), "confidence_high": frame["c"].max().to_numpy()})


def expected_ece_if_calibrated(confidence, *, n_bins: int = DEFAULT_N_BINS, n_draws: int = 1000,
                               random_state: int | np.random.Generator | None = 0) -> float:
    """The ECE a perfectly calibrated posterior with these confidences would show on this many trials.

    ECE is biased upwards on a finite sample: even when every trial is right with probability
    equal to its confidence, the per-bin accuracies scatter around the confidences. This draws
    ``correct ~ Bernoulli(confidence)`` ``n_draws`` times (one array operation) and returns the
    mean ECE with the same equal-mass bins: the value to compare a measured ECE with.

    Parameters
    ----------
    confidence : array-like of shape (n_trials,)
        Top-class probability of each trial, in [0, 1].
    n_bins : int, default 10
    n_draws : int, default 1000
    random_state : int, Generator or None, default 0

    Returns
    -------
    float
        Mean ECE over the draws.
    """
    c, _ = _check_terms(confidence, np.zeros(np.shape(confidence)))
    bins = equal_mass_bins(c, n_bins)
    onehot = np.zeros((c.size, int(bins.max()) + 1))
    onehot[np.arange(c.size), bins] = 1.0
    draws = np.random.default_rng(random_state).random((n_draws, c.size)) < c  # (n_draws, n_trials)
    gap = (draws - c) @ onehot  # (n_draws, n_bins): summed correct minus confidence per bin
    return float(np.abs(gap).sum(axis=1).mean() / c.size)


def calibration_intervals(
    confidence,
    correct,
    brier,
    *,
    classes,
    splits=None,
    n_bins: int = DEFAULT_N_BINS,
    n_boot: int = DEFAULT_N_BOOT,
    random_state: int | np.random.Generator | None = 0,
) -> dict[str, Interval]:
    """ECE and Brier score of pooled test trials with two-level bootstrap 95% intervals.

    Parameters
    ----------
    confidence, correct, brier : array-like of shape (n_trials,)
        :func:`calibration_terms` of every test trial (all splits).
    classes : array-like of shape (n_trials,)
        True class (test object) of each trial: the bootstrap's cluster.
    splits : array-like of shape (n_trials,), optional
        Split of each trial; None: one split.
    n_bins : int, default 10
    n_boot : int, default 2000
    random_state : int, Generator or None, default 0

    Returns
    -------
    dict
        ``{"ece": Interval, "brier": Interval}``: point value on the trials given, and the
        2.5 / 97.5 percentiles of the replicates (ECE: bias-corrected, module docstring).
    """
    c, k = _check_terms(confidence, correct)
    b = np.asarray(brier, dtype=float)
    if b.shape != c.shape or not np.isfinite(b).all():
        raise TzslError(f"brier must be finite with one value per trial ({c.size}), got shape {b.shape}")
    bins = equal_mass_bins(c, n_bins)
    n_used = int(bins.max()) + 1
    cell = cluster_cells(classes, splits)[0]
    if cell.size != c.size:
        raise TzslError(f"classes must have one entry per trial ({c.size}), got {cell.size}")
    n_cells = int(cell.max()) + 1
    # per-cell sums: (accuracy - confidence) per (cell, bin), trials and Brier terms per cell
    gap_sums = np.bincount(cell * n_used + bins, weights=k - c, minlength=n_cells * n_used).reshape(n_cells, n_used)
    trial_counts = np.bincount(cell, minlength=n_cells).astype(float)
    brier_sums = np.bincount(cell, weights=b, minlength=n_cells)
    ece, brr = [], []
    for w in bootstrap_cell_weights(classes, splits, n_boot=n_boot, random_state=random_state):
        total = w @ trial_counts
        ece.append(np.abs(w @ gap_sums).sum(axis=1) / total)
        brr.append(w @ brier_sums / total)
    point = float(_weighted_ece(c, k, bins, n_used, np.ones((1, c.size)))[0])
    reps = np.concatenate(ece)
    low, high = np.clip(np.quantile(reps - (reps.mean() - point), [0.025, 0.975]), 0.0, None)
    brier_low, brier_high = np.quantile(np.concatenate(brr), [0.025, 0.975])
    return {"ece": Interval(point, float(low), float(high)),
            "brier": Interval(float(b.mean()), float(brier_low), float(brier_high))}


#: Column suffixes of the calibrated posterior (what ``predict_proba`` returns) and of the raw one.
VARIANTS = ("", "_uncalibrated")


def calibration_columns(suffix: str = "") -> list[str]:
    """Columns :func:`add_calibration_columns` adds for one variant (``""`` or ``"_uncalibrated"``):
    ECE and Brier with their intervals, then ``ece<suffix>_if_calibrated``
    (:func:`expected_ece_if_calibrated`, what the ECE is compared with)."""
    return ([f"{m}{suffix}{end}" for m in CALIBRATION_METRICS for end in ("", "_ci95_low", "_ci95_high")]
            + [f"ece{suffix}_if_calibrated"])


def add_calibration_columns(
    summary: pd.DataFrame,
    trials: pd.DataFrame,
    *,
    by: str = "method",
    class_column: str = "class",
    split_column: str = "split",
    n_bins: int = DEFAULT_N_BINS,
    n_boot: int = DEFAULT_N_BOOT,
    random_state: int | None = 0,
) -> pd.DataFrame:
    """``summary`` with ECE and Brier columns (and intervals) per ``by`` group of a trials table.

    Parameters
    ----------
    summary : DataFrame
        One row per group, with column ``by``.
    trials : DataFrame
        One row per test trial with ``by``, ``class_column``, ``split_column``, ``correct`` and,
        per variant suffix in :data:`VARIANTS` that is present, ``confidence<suffix>`` and
        ``brier<suffix>`` (:func:`calibration_terms`); NaN where a method gives no posterior.
    by, class_column, split_column : str
    n_bins, n_boot, random_state
        As in :func:`calibration_intervals`; every group uses the same seed.

    Returns
    -------
    DataFrame
        A copy of ``summary`` with :func:`calibration_columns` of each variant present (NaN for
        a group without posteriors).
    """
    out = summary.copy()
    for suffix in VARIANTS:
        if f"confidence{suffix}" not in trials.columns:
            continue
        values: dict[object, list[float]] = {}
        for key, t in trials.groupby(by, sort=False):
            t = t[t[f"confidence{suffix}"].notna()]
            if t.empty:
                continue
            iv = calibration_intervals(t[f"confidence{suffix}"], t["correct"], t[f"brier{suffix}"],
                                       classes=t[class_column].to_numpy(), splits=t[split_column].to_numpy(),
                                       n_bins=n_bins, n_boot=n_boot, random_state=random_state)
            values[key] = [x for m in CALIBRATION_METRICS for x in iv[m]] + [
                expected_ece_if_calibrated(t[f"confidence{suffix}"], n_bins=n_bins, random_state=random_state)]
        for j, column in enumerate(calibration_columns(suffix)):
            out[column] = [values[k][j] if k in values else np.nan for k in out[by]]
    return out
