"""Bootstrap 95% intervals for zero-shot accuracies, single and paired.

What is resampled (two-level cluster bootstrap, percentile interval)
--------------------------------------------------------------------
A zero-shot accuracy reported over several splits is the mean over splits of a per-split
accuracy. Its uncertainty has two sources: which objects happened to be test objects
(the split-to-split spread) and which trials those objects gave. Each bootstrap
replicate therefore

1. draws ``n_splits`` splits **with replacement** from the splits evaluated;
2. within every drawn split, draws as many test classes (objects) as the split has,
   **with replacement**, each drawn class bringing **all its test trials** unchanged
   (trials of one object are not independent, so they are resampled as a block);
3. recomputes the per-split accuracy on that sample - per-trial accuracy (correct trials
   / trials) or per-class mean accuracy (mean over the drawn classes of each class's
   accuracy) - and averages it over the drawn splits.

The interval is the 2.5 and 97.5 percentiles of ``n_boot`` replicates (default 2000); the
point value is the plain mean over splits of the per-split accuracy, as in the tables.
With few splits (5) the split level under-covers a little (a bootstrap from 5 values
cannot see rarer splits): the interval describes the splits and objects at hand.

A **paired difference** (method A minus method B, on the same splits and the same test
trials) uses the same drawn splits and classes for both methods in every replicate, so
the difference keeps its pairing and the interval reflects only how the methods differ
on the same trials. :func:`splits_for_paired_interval` sizes a comparison: from pilot
per-split differences with standard deviation ``sd``, ``n = ceil((1.96 sd / h)^2)``
splits give an interval of half-width about ``h`` (by default 0.05) on the mean difference.

Everything is seeded (``random_state``) and vectorised with numpy; replicates are drawn
in chunks so memory stays bounded (about ``CHUNK_CELLS`` cells per chunk).
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np
import pandas as pd

from tzsl._profile import timed
from tzsl.exceptions import TzslError

__all__ = [
    "Interval",
    "bootstrap_accuracy",
    "bootstrap_accuracy_columns",
    "bootstrap_cell_weights",
    "bootstrap_trial_weights",
    "cluster_cells",
    "paired_difference_interval",
    "paired_differences_table",
    "splits_for_paired_interval",
]

#: Bootstrap replicates drawn when not told otherwise.
DEFAULT_N_BOOT = 2000

#: Upper bound on (replicates x splits x classes x methods) cells held at once.
CHUNK_CELLS = 2_000_000

Metric = Literal["trial", "class_mean"]
METRICS: tuple[str, ...] = ("trial", "class_mean")


class Interval(NamedTuple):
    """A point value and its bootstrap 95% interval (fractions in [0, 1], or differences)."""

    mean: float
    ci95_low: float
    ci95_high: float


def cluster_cells(classes, splits=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The bootstrap's clusters: one cell per (split, class), numbered by split, then class.

    Parameters
    ----------
    classes : array-like of shape (n_trials,)
        True class (test object) of each trial (sortable labels, not missing).
    splits : array-like of shape (n_trials,), optional
        Split of each trial; None: one split.

    Returns
    -------
    cell : int ndarray of shape (n_trials,)
        Cell of each trial, in ``0 .. n_cells - 1`` (sorted by split label, then class label).
    split_of_cell : int ndarray of shape (n_cells,)
        Split (position among the sorted split labels) of each cell.
    position : int ndarray of shape (n_cells,)
        Position of each cell among its split's cells.
    n_classes : int ndarray of shape (n_splits,)
        Cells (classes) of each split.
    """
    classes = np.asarray(classes)
    n = classes.shape[0] if classes.ndim else 0
    splits = np.zeros(n, dtype=int) if splits is None else np.asarray(splits)
    for name, v in (("classes", classes), ("splits", splits)):
        if v.shape != (n,):
            raise TzslError(f"{name} must have one entry per trial ({n}), got shape {v.shape}")
    split_code, class_code = pd.factorize(splits, sort=True)[0], pd.factorize(classes, sort=True)[0]
    if (split_code < 0).any() or (class_code < 0).any():
        raise TzslError("classes and splits must not be missing")
    n_labels = int(class_code.max()) + 1 if n else 1
    keys, cell = np.unique(split_code.astype(np.int64) * n_labels + class_code, return_inverse=True)
    split_of_cell = keys // n_labels
    n_classes = np.bincount(split_of_cell)
    position = np.arange(keys.size) - (np.cumsum(n_classes) - n_classes)[split_of_cell]
    return cell.ravel(), split_of_cell, position, n_classes


def _cells(correct: np.ndarray, classes, splits) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per (split, class) sums, padded to the largest split.

    Returns
    -------
    n_correct : ndarray, shape (n_splits, max_classes, n_methods)
        Sum of ``correct`` over each cell's trials (0 in padding).
    n_trials : ndarray, shape (n_splits, max_classes)
        Trials per cell (1 in padding, to keep divisions finite; padding is masked).
    n_classes : int ndarray, shape (n_splits,)
    """
    n = correct.shape[0]
    if np.shape(classes) != (n,):
        raise TzslError(f"classes must have one entry per trial ({n}), got shape {np.shape(classes)}")
    cell, split_of_cell, position, n_classes = cluster_cells(classes, splits)
    n_cells = split_of_cell.size
    sums = np.zeros((n_cells, correct.shape[1]))
    np.add.at(sums, cell, correct)
    counts = np.bincount(cell, minlength=n_cells)
    n_correct = np.zeros((len(n_classes), n_classes.max(), correct.shape[1]))
    n_trials = np.ones((len(n_classes), n_classes.max()))
    n_correct[split_of_cell, position] = sums
    n_trials[split_of_cell, position] = counts
    return n_correct, n_trials, n_classes


def _split_accuracy(n_correct, n_trials, valid, n_classes, metric: str) -> np.ndarray:
    """Per-split accuracy from (..., classes, methods) cells; returns (..., methods)."""
    if metric == "trial":
        return (n_correct * valid[..., None]).sum(-2) / (n_trials * valid).sum(-1)[..., None]
    acc = n_correct / n_trials[..., None]
    return (acc * valid[..., None]).sum(-2) / n_classes[..., None]


def _check_correct(correct, n_methods: int | None = None) -> np.ndarray:
    c = np.asarray(correct, dtype=float)
    if c.ndim == 1:
        c = c[:, None]
    if c.ndim != 2 or c.shape[0] == 0:
        raise TzslError(f"correct must be 1-d or 2-d (n_trials, n_methods) and non-empty, got shape {c.shape}")
    if n_methods is not None and c.shape[1] != n_methods:
        raise TzslError(f"expected {n_methods} method column(s), got {c.shape[1]}")
    if not np.isfinite(c).all() or (c < 0).any() or (c > 1).any():
        raise TzslError("correct must hold values in [0, 1] (1 = trial recognised), without NaN")
    return c


def _draw(rng: np.random.Generator, n_classes: np.ndarray, b: int):
    """One chunk of ``b`` two-level draws (module docstring): splits, then classes within them.

    Returns
    -------
    drawn : int ndarray of shape (b, n_splits)
        Split drawn at each position.
    nc : int ndarray of shape (b, n_splits)
        Classes of each drawn split.
    pick : int ndarray of shape (b, n_splits, max_classes)
        Class position drawn in each slot (slots past ``nc`` are padding).
    ok : bool ndarray of shape (b, n_splits, max_classes)
        Which slots are real draws.
    """
    n_splits, max_classes = len(n_classes), int(n_classes.max())
    drawn = rng.integers(0, n_splits, size=(b, n_splits))  # (b, S) split draws
    nc = n_classes[drawn]  # (b, S)
    pick = np.minimum((rng.random((b, n_splits, max_classes)) * nc[..., None]).astype(int), max_classes - 1)
    ok = np.arange(max_classes) < nc[..., None]  # (b, S, C)
    return drawn, nc, pick, ok


def bootstrap_cell_weights(classes, splits=None, *, n_boot: int = DEFAULT_N_BOOT,
                           random_state: int | np.random.Generator | None = 0):
    """The two-level bootstrap of this module as draw counts of its (split, class) cells.

    Replicate ``r`` draws cell ``k`` (a test class of a split, :func:`cluster_cells`)
    ``w[r, k]`` times: how often its split was drawn times how often its class was drawn
    within it; every trial of the cell counts that many times. A statistic that is a sum over
    trials (the calibration error's per-bin sums, the Brier score) is then ``w`` times the
    per-cell sums: one matrix product for all replicates, whatever the number of trials. The
    draws (and their chunks) are those of :func:`bootstrap_trial_weights` with the same seed.

    Parameters
    ----------
    classes : array-like of shape (n_trials,)
        True class (test object) of each trial.
    splits : array-like of shape (n_trials,), optional
        Split of each trial; None: one split.
    n_boot : int, default 2000
    random_state : int, Generator or None, default 0

    Yields
    ------
    ndarray of shape (b, n_cells), float
        Draw counts of ``b`` replicates (``n_boot`` rows in all), cells numbered as
        :func:`cluster_cells` numbers them.
    """
    if not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise TzslError(f"n_boot must be a positive integer, got {n_boot!r}")
    _, split_of_cell, position, n_classes = cluster_cells(classes, splits)
    n_splits, max_classes = len(n_classes), int(n_classes.max())
    rng = np.random.default_rng(random_state)
    # the chunk of the per-trial weights (bootstrap_trial_weights), so both draw the same numbers
    chunk = max(1, CHUNK_CELLS // max(len(np.asarray(classes)), n_splits * max_classes))
    flat_cell = split_of_cell * max_classes + position  # each cell's slot in (split, class position)
    for start in range(0, n_boot, chunk):
        b = min(chunk, n_boot - start)
        drawn, _, pick, ok = _draw(rng, n_classes, b)
        slot = (np.arange(b)[:, None, None] * n_splits + drawn[..., None]) * max_classes + pick
        counts = np.bincount(slot[ok], minlength=b * n_splits * max_classes).reshape(b, -1)
        yield counts[:, flat_cell].astype(float)


def bootstrap_trial_weights(classes, splits=None, *, n_boot: int = DEFAULT_N_BOOT,
                            random_state: int | np.random.Generator | None = 0):
    """The two-level bootstrap of this module as per-trial weights, for statistics that are not means.

    Replicate ``r`` counts trial ``i`` ``w[r, i]`` times: how often its split was drawn times
    how often its class was drawn within it (its class brings all its trials, module
    docstring). A statistic that is not a mean over splits of a per-split accuracy (the
    expected calibration error pools trials into bins) is recomputed on each replicate from
    these weights; the draws are those of :func:`bootstrap_accuracy` with the same seed. Sums
    over trials are cheaper from :func:`bootstrap_cell_weights` (these weights are its counts,
    each repeated for the trials of its cell).

    Parameters
    ----------
    classes : array-like of shape (n_trials,)
        True class (test object) of each trial.
    splits : array-like of shape (n_trials,), optional
        Split of each trial; None: one split.
    n_boot : int, default 2000
    random_state : int, Generator or None, default 0

    Yields
    ------
    ndarray of shape (b, n_trials), float
        Weights of ``b`` replicates (chunks of at most about ``CHUNK_CELLS`` cells; ``n_boot``
        rows in all).
    """
    cell = cluster_cells(classes, splits)[0]
    for counts in bootstrap_cell_weights(classes, splits, n_boot=n_boot, random_state=random_state):
        yield counts[:, cell]


def _replicates(correct: np.ndarray, classes, splits, metric: str, n_boot: int, random_state
                ) -> tuple[np.ndarray, np.ndarray]:
    """Point values (n_methods,) and bootstrap replicates (n_boot, n_methods)."""
    if metric not in METRICS:
        raise TzslError(f"metric must be one of {METRICS}, got {metric!r}")
    if not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise TzslError(f"n_boot must be a positive integer, got {n_boot!r}")
    n_correct, n_trials, n_classes = _cells(correct, classes, splits)
    n_splits, max_classes, n_methods = n_correct.shape
    valid = np.arange(max_classes) < n_classes[:, None]
    point = _split_accuracy(n_correct, n_trials, valid, n_classes, metric).mean(axis=0)
    rng = np.random.default_rng(random_state)
    chunk = max(1, CHUNK_CELLS // (n_splits * max_classes * n_methods))
    out = np.empty((n_boot, n_methods))
    for start in range(0, n_boot, chunk):
        b = min(chunk, n_boot - start)
        drawn, nc, pick, ok = _draw(rng, n_classes, b)
        rows = drawn[..., None]
        per_split = _split_accuracy(n_correct[rows, pick], n_trials[rows, pick], ok, nc, metric)
        out[start:start + b] = per_split.mean(axis=1)
    return point, out


def _interval(point: float, reps: np.ndarray) -> Interval:
    low, high = np.quantile(reps, [0.025, 0.975])
    return Interval(float(point), float(low), float(high))


@timed("bootstrap")
def bootstrap_accuracy(
    correct,
    *,
    classes,
    splits=None,
    metric: Metric = "trial",
    n_boot: int = DEFAULT_N_BOOT,
    random_state: int | np.random.Generator | None = 0,
) -> Interval:
    """Mean accuracy over splits with its two-level bootstrap 95% interval (module docstring).

    Parameters
    ----------
    correct : array-like of shape (n_trials,)
        1 where the trial's class was recognised, else 0 (fractions in [0, 1] allowed, e.g. the
        share of control permutations that got the trial right).
    classes : array-like of shape (n_trials,)
        True class (test object) of each trial.
    splits : array-like of shape (n_trials,), optional
        Split of each trial; None: one split (only classes are resampled).
    metric : {"trial", "class_mean"}, default "trial"
        Per-trial accuracy or per-class mean accuracy within each split.
    n_boot : int, default 2000
    random_state : int, Generator or None, default 0

    Returns
    -------
    Interval
        ``(mean, ci95_low, ci95_high)``.
    """
    c = _check_correct(correct, 1)
    point, reps = _replicates(c, classes, splits, metric, n_boot, random_state)
    return _interval(point[0], reps[:, 0])


@timed("bootstrap")
def bootstrap_accuracy_columns(
    correct,
    *,
    classes,
    splits=None,
    metric: Metric = "trial",
    n_boot: int = DEFAULT_N_BOOT,
    random_state: int | np.random.Generator | None = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`bootstrap_accuracy` for many columns at once, every column on the same replicates.

    Parameters
    ----------
    correct : array-like of shape (n_trials, n_columns)
        Per-trial correctness (fractions in [0, 1] allowed) of each column (method, step, budget).
    classes, splits, metric, n_boot, random_state
        As in :func:`bootstrap_accuracy`.

    Returns
    -------
    mean, ci95_low, ci95_high : ndarray of shape (n_columns,)
    """
    c = _check_correct(correct)
    point, reps = _replicates(c, classes, splits, metric, n_boot, random_state)
    low, high = np.quantile(reps, [0.025, 0.975], axis=0)
    return point, low, high


@timed("bootstrap")
def paired_difference_interval(
    correct_a,
    correct_b,
    *,
    classes,
    splits=None,
    metric: Metric = "trial",
    n_boot: int = DEFAULT_N_BOOT,
    random_state: int | np.random.Generator | None = 0,
) -> Interval:
    """Accuracy of method A minus method B on the same trials, with a paired bootstrap interval.

    Both methods are scored on the same resampled splits and classes in every replicate
    (module docstring), so the interval is that of the paired difference.

    Parameters
    ----------
    correct_a, correct_b : array-like of shape (n_trials,)
        Per-trial correctness of the two methods on the same trials (same order).
    classes, splits, metric, n_boot, random_state
        As in :func:`bootstrap_accuracy`.

    Returns
    -------
    Interval
        ``(mean difference, ci95_low, ci95_high)``; an interval excluding 0 means the
        methods differ on these splits and objects.
    """
    a, b = np.asarray(correct_a, dtype=float), np.asarray(correct_b, dtype=float)
    if a.shape != b.shape or a.ndim != 1:
        raise TzslError(f"correct_a and correct_b must be 1-d of the same length, got {a.shape} and {b.shape}")
    c = _check_correct(np.column_stack([a, b]), 2)
    point, reps = _replicates(c, classes, splits, metric, n_boot, random_state)
    return _interval(point[0] - point[1], reps[:, 0] - reps[:, 1])


def splits_for_paired_interval(per_split_differences, half_width: float = 0.05, z: float = 1.96) -> int:
    """Splits needed for a 95% interval of half-width ``half_width`` on a mean paired difference.

    ``n = ceil((z * sd / half_width)^2)`` with ``sd`` the sample standard deviation (ddof=1)
    of pilot per-split differences (method A minus method B on each split); at least 2.

    Parameters
    ----------
    per_split_differences : array-like of shape (n_pilot_splits,)
        At least 2 finite values.
    half_width : float, default 0.05
    z : float, default 1.96 (normal quantile of a 95% interval)

    Returns
    -------
    int
    """
    d = np.asarray(per_split_differences, dtype=float).ravel()
    if d.size < 2 or not np.isfinite(d).all():
        raise TzslError(f"need at least 2 finite pilot differences, got {d.tolist()}")
    if not half_width > 0:
        raise TzslError(f"half_width must be positive, got {half_width!r}")
    sd = float(np.std(d, ddof=1))
    return max(2, math.ceil((z * sd / half_width) ** 2))


def paired_differences_table(
    trials: pd.DataFrame,
    *,
    reference: str,
    method_column: str = "method",
    trial_column: str = "trial",
    correct: str = "correct",
    class_column: str = "class",
    split_column: str = "split",
    metric: Metric = "trial",
    n_boot: int = DEFAULT_N_BOOT,
    random_state: int | None = 0,
) -> pd.DataFrame:
    """Every method minus ``reference`` on the same splits and trials (``method_comparison.csv``).

    Parameters
    ----------
    trials : DataFrame
        One row per (method, test trial): columns ``method_column``, ``trial_column`` (a trial
        identifier unique within a split), ``correct``, ``class_column``, ``split_column``.
        Every method must have been scored on exactly the reference's trials.
    reference : str
        The method subtracted (e.g. DAP-AVG with uniform prior).

    Returns
    -------
    DataFrame
        One row per other method: ``method``, ``reference``, ``difference`` (mean over
        splits of the per-split accuracy difference), ``ci95_low``, ``ci95_high``,
        ``n_splits``, ``n_trials``.
    """
    need = [method_column, trial_column, correct, class_column, split_column]
    if [c for c in need if c not in trials.columns]:
        raise TzslError(f"trials table lacks column(s) {[c for c in need if c not in trials.columns]}")
    wide = trials.pivot_table(index=[split_column, class_column, trial_column], columns=method_column,
                              values=correct, aggfunc="first")
    if reference not in wide.columns:
        raise TzslError(f"reference method {reference!r} not in {list(wide.columns)}")
    rows = []
    for method in [m for m in wide.columns if m != reference]:
        pair = wide[[method, reference]]
        if pair.isna().any().any():
            raise TzslError(f"methods {method!r} and {reference!r} were not scored on the same trials")
        split_ids = pair.index.get_level_values(split_column).to_numpy()
        iv = paired_difference_interval(
            pair[method].to_numpy(), pair[reference].to_numpy(),
            classes=pair.index.get_level_values(class_column).to_numpy(), splits=split_ids,
            metric=metric, n_boot=n_boot, random_state=random_state,
        )
        rows.append({"method": method, "reference": reference, "difference": iv.mean,
                     "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high,
                     "n_splits": len(np.unique(split_ids)), "n_trials": len(pair)})
    return pd.DataFrame(rows, columns=["method", "reference", "difference", "ci95_low", "ci95_high",
                                       "n_splits", "n_trials"])
