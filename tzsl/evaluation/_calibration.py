"""Whether class posteriors mean what they say: expected calibration error, Brier score, reliability.

A robot that stops exploring once the top posterior reaches 0.9 needs trials decided at 0.9 to
be right about 90% of the time. Three views of that, on the test objects:

* **ECE** (top-label expected calibration error, equal-mass bins): trials sorted by their top
  posterior (confidence) and cut into ``n_bins`` bins of equal size; the mean over bins, weighted
  by their share of trials, of ``|accuracy - mean confidence|``. 0 is perfect.
* **Brier score** (multi-class): the mean over trials of ``sum_k (p_k - [k = true class])^2``,
  between 0 (certain and right) and 2 (certain and wrong); it rewards sharp and calibrated
  posteriors alike.
* **Reliability table**: per bin, mean confidence against accuracy (the reliability diagram).

Intervals resample like accuracy's (:func:`tzsl.evaluation.bootstrap_accuracy`): splits, then
test classes within each drawn split, each class bringing all its trials; the bins are fixed by
the point estimate's confidences, so a replicate reweights trials, it does not re-bin them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tzsl._profile import timed
from tzsl.evaluation._intervals import DEFAULT_N_BOOT, Interval
from tzsl.exceptions import TzslError

__all__ = ["DEFAULT_N_BINS", "brier_terms", "calibration_intervals", "expected_calibration_error",
           "reliability_table", "top_label"]

#: Equal-mass bins of the ECE and the reliability table.
DEFAULT_N_BINS = 10


def _check(proba, y) -> tuple[np.ndarray, np.ndarray]:
    P = np.asarray(proba, dtype=float)
    y = np.asarray(y)
    if P.ndim != 2 or y.shape != (P.shape[0],) or P.shape[0] == 0:
        raise TzslError(f"proba must be (n_trials, n_classes) and y (n_trials,); got {P.shape} and {y.shape}")
    if not np.isfinite(P).all() or (P < -1e-9).any() or not np.allclose(P.sum(axis=1), 1.0, atol=1e-6):
        raise TzslError("proba rows must be finite probabilities summing to 1")
    if y.min() < 0 or y.max() >= P.shape[1]:
        raise TzslError(f"y must index the {P.shape[1]} class columns")
    return P, y.astype(int)


def top_label(proba, y) -> tuple[np.ndarray, np.ndarray]:
    """Confidence (top posterior) and correctness (argmax == y) of every trial, shapes (n_trials,)."""
    P, y = _check(proba, y)
    return P.max(axis=1), (P.argmax(axis=1) == y).astype(float)


def brier_terms(proba, y) -> np.ndarray:
    """Each trial's multi-class Brier term ``sum_k (p_k - [k = y])^2``, shape (n_trials,), in [0, 2]."""
    P, y = _check(proba, y)
    onehot = np.zeros_like(P)
    onehot[np.arange(len(y)), y] = 1.0
    return ((P - onehot) ** 2).sum(axis=1)


def _bins(confidence: np.ndarray, n_bins: int) -> np.ndarray:
    """Equal-mass bin of every trial (ties kept together by a stable sort), shape (n_trials,)."""
    order = np.argsort(confidence, kind="stable")
    bins = np.empty(len(confidence), dtype=int)
    bins[order] = (np.arange(len(confidence)) * min(n_bins, len(confidence))) // len(confidence)
    return bins


def _weighted_ece(confidence, correct, bins, weights) -> np.ndarray:
    """ECE under trial weights ``weights`` (n_rep, n_trials); returns (n_rep,)."""
    n_bins = int(bins.max()) + 1
    onehot = np.zeros((len(bins), n_bins))
    onehot[np.arange(len(bins)), bins] = 1.0
    mass = weights @ onehot  # (n_rep, n_bins)
    conf = (weights * confidence) @ onehot
    acc = (weights * correct) @ onehot
    total = mass.sum(axis=1)
    gap = np.abs(acc - conf)  # = mass * |accuracy - confidence| per bin
    return gap.sum(axis=1) / np.where(total > 0, total, 1.0)


def expected_calibration_error(confidence, correct, n_bins: int = DEFAULT_N_BINS) -> float:
    """Top-label ECE with equal-mass bins (see the module docstring)."""
    confidence, correct = np.asarray(confidence, dtype=float), np.asarray(correct, dtype=float)
    return float(_weighted_ece(confidence, correct, _bins(confidence, n_bins), np.ones((1, len(confidence))))[0])


def reliability_table(confidence, correct, n_bins: int = DEFAULT_N_BINS) -> pd.DataFrame:
    """Per equal-mass bin: ``bin``, ``n_trials``, ``confidence`` (mean), ``accuracy``."""
    confidence, correct = np.asarray(confidence, dtype=float), np.asarray(correct, dtype=float)
    bins = _bins(confidence, n_bins)
    frame = pd.DataFrame({"bin": bins, "confidence": confidence, "accuracy": correct})
    table = frame.groupby("bin").agg(n_trials=("confidence", "size"), confidence=("confidence", "mean"),
                                     accuracy=("accuracy", "mean")).reset_index()
    return table


def _cluster_weights(classes, splits, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """Trial weights (n_boot, n_trials) of a two-level bootstrap: splits, then classes within them."""
    frame = pd.DataFrame({"split": np.asarray(splits), "class": np.asarray(classes)})
    split_code = pd.factorize(frame["split"], sort=True)[0]
    cell = frame.groupby(["split", "class"], sort=True).ngroup().to_numpy()
    n_splits = split_code.max() + 1
    cells_of = [np.unique(cell[split_code == s]) for s in range(n_splits)]
    weights = np.zeros((n_boot, cell.max() + 1))
    drawn = rng.integers(0, n_splits, size=(n_boot, n_splits))
    for k, cells in enumerate(cells_of):  # every draw of split k brings len(cells) classes, with replacement
        replicate = np.nonzero(drawn == k)[0]
        if replicate.size == 0:
            continue
        picks = cells[rng.integers(0, len(cells), size=(replicate.size, len(cells)))]
        np.add.at(weights, (np.repeat(replicate, len(cells)), picks.ravel()), 1.0)
    return weights[:, cell]


@timed("bootstrap")
def calibration_intervals(confidence, correct, brier, classes, splits=None, *, n_bins: int = DEFAULT_N_BINS,
                          n_boot: int = DEFAULT_N_BOOT, random_state: int | None = 0) -> dict[str, Interval]:
    """ECE and Brier score with 95% intervals over splits and test classes.

    Parameters
    ----------
    confidence, correct, brier : array-like of shape (n_trials,)
        :func:`top_label` and :func:`brier_terms` of every test trial.
    classes, splits : array-like of shape (n_trials,)
        Test class and split of every trial (the resampling clusters).
    n_bins, n_boot, random_state
        Equal-mass bins; bootstrap replicates and their seed.

    Returns
    -------
    dict
        ``{"ece": Interval, "brier": Interval}``.
    """
    confidence = np.asarray(confidence, dtype=float)
    correct = np.asarray(correct, dtype=float)
    brier = np.asarray(brier, dtype=float)
    n = len(confidence)
    if not (correct.shape == brier.shape == (n,)) or n == 0:
        raise TzslError("confidence, correct and brier need one value per trial")
    splits = np.zeros(n, dtype=int) if splits is None else np.asarray(splits)
    bins = _bins(confidence, n_bins)
    weights = _cluster_weights(classes, splits, n_boot, np.random.default_rng(random_state))
    ece_reps = _weighted_ece(confidence, correct, bins, weights)
    total = weights.sum(axis=1)
    brier_reps = (weights @ brier) / np.where(total > 0, total, 1.0)
    out = {}
    for name, point, reps in (("ece", expected_calibration_error(confidence, correct, n_bins), ece_reps),
                              ("brier", float(brier.mean()), brier_reps)):
        low, high = np.quantile(reps, [0.025, 0.975])
        out[name] = Interval(float(point), float(low), float(high))
    return out
