"""Intervals and baselines beside every accuracy a study writes: one helper for every table.

A study builds its per-split (or per-seed) rows as before and, while doing so, records each
accuracy's per-trial outcomes in an :class:`Outcomes` collector (which trials, their true
class, right or wrong). :func:`add_trust_columns` then adds, to the finished table:

``<col>_ci95_low``, ``<col>_ci95_high`` (``ci95_low``, ``ci95_high`` when the table reports a single accuracy column)
    The bootstrap 95% interval of :func:`tzsl.evaluation.bootstrap_accuracy` (percentile, 2000
    replicates, seeded). On a per-split (per-seed) row: within that split, over its **test
    classes** (each class brings all its test trials). On the ``mean`` row: two-level, over
    the **splits** (seeds) with replacement and, within each drawn split, over its test
    classes. Rows pooling several splits (the negative ``control`` row) use the two-level
    bootstrap over the splits they pool. ``std`` rows have none.
``chance``
    ``1 / number of test classes`` of the row's split (on pooled rows the mean over splits).
``majority``
    Only when test classes have unequal trial counts somewhere in the table: per-trial
    accuracy of always answering the test class with the most trials
    (:func:`tzsl.evaluation.majority_class_accuracy`); its per-class mean accuracy is chance.

Every table therefore writes intervals and baselines the same way; the column docs above are
what :data:`INTERVAL_DOC` repeats in the report.
"""

from __future__ import annotations

import warnings
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from tzsl.evaluation._baselines import chance_accuracy, majority_class_accuracy
from tzsl.evaluation._intervals import bootstrap_accuracy, cluster_cells
from tzsl.exceptions import TzslError

__all__ = ["INTERVAL_DOC", "Outcomes", "add_trust_columns", "attribute_intervals", "interval_columns"]

#: One sentence for reports and column docs: which bootstrap the ci95 columns come from.
INTERVAL_DOC = (
    "ci95_low/ci95_high: 95% percentile bootstrap interval (2000 replicates); per-split rows resample the "
    "split's test classes (each with all its trials), the mean row resamples splits (seeds) with replacement "
    "and test classes within each; chance = 1/number of test classes; majority (where test classes have "
    "unequal trial counts) = always answering the most frequent test class"
)

#: Labels of summary rows: ``mean`` gets the two-level interval, ``std`` none.
MEAN_ROW, STD_ROW = "mean", "std"


@dataclass
class _Record:
    label: Hashable
    keys: tuple
    column: str
    metric: str
    classes: np.ndarray
    correct: np.ndarray
    inner: np.ndarray | None  # per-trial split labels of a pooled row (None: one split)


@dataclass
class Outcomes:
    """Per-trial outcomes of a table's accuracy columns, collected while its rows are built.

    Parameters
    ----------
    split_column : str
        Column of the table naming the split (seed) of a row; summary rows are ``mean`` / ``std``.
    by : sequence of str
        Further key columns of the table (e.g. ``("method",)``); ``add`` takes their values.
    """

    split_column: str = "split"
    by: Sequence[str] = ()
    records: list[_Record] = field(default_factory=list)

    def add(self, split: Hashable, column: str, classes, correct, *, metric: str = "trial",
            inner_splits=None, **keys) -> None:
        """Record the outcomes behind one cell: row ``split`` (and ``keys``), accuracy ``column``.

        Parameters
        ----------
        split : hashable
            Value of ``split_column`` of the row (a split label, a seed, or a pooled row such as
            ``"control"``).
        column : str
            Accuracy column of the table.
        classes : array-like of shape (n_trials,)
            True test class of each trial.
        correct : array-like of shape (n_trials,)
            1 if recognised, 0 if not (fractions in [0, 1] allowed: the control's share of
            permutations that got the trial right).
        metric : {"trial", "class_mean"}
            How the column averages trials within a split.
        inner_splits : array-like of shape (n_trials,), optional
            For a row pooling several splits: each trial's split (two-level interval; such a
            row does not enter the ``mean`` row).
        **keys
            Values of the ``by`` columns.
        """
        missing = [b for b in self.by if b not in keys]
        if missing:
            raise TzslError(f"outcomes of {column!r}: missing key(s) {missing}")
        classes, correct = np.asarray(classes), np.asarray(correct, dtype=float)
        if classes.shape != correct.shape or classes.ndim != 1:
            raise TzslError(f"outcomes of {column!r}: classes {classes.shape} and correct {correct.shape} differ")
        inner = None if inner_splits is None else np.asarray(inner_splits)
        self.records.append(_Record(split, tuple(keys[b] for b in self.by), column, metric, classes, correct, inner))


def interval_columns(column: str, single: bool) -> tuple[str, str]:
    """Names of the interval columns of ``column`` (plain ``ci95_low``/``ci95_high`` when ``single``)."""
    return ("ci95_low", "ci95_high") if single else (f"{column}_ci95_low", f"{column}_ci95_high")


def _row_mask(table: pd.DataFrame, split_column: str, by: Sequence[str], label, keys: tuple) -> np.ndarray:
    mask = table[split_column].astype(str).to_numpy() == str(label)
    for b, k in zip(by, keys, strict=True):
        mask &= table[b].astype(str).to_numpy() == str(k)
    return mask


def add_trust_columns(table: pd.DataFrame, outcomes: Outcomes, *, n_boot: int = 2000,
                      random_state: int = 0, baselines: bool = True, per_split_rows: bool = True) -> pd.DataFrame:
    """``table`` with interval columns per recorded accuracy column, and ``chance`` / ``majority``.

    See the module docstring for what each column means. Interval columns follow their
    accuracy column (``ci95_low``/``ci95_high`` if a single column was recorded, else
    ``<col>_ci95_low``/``<col>_ci95_high``); ``chance`` (replacing an existing column's values)
    and ``majority`` are computed from the recorded classes of the first column.

    Parameters
    ----------
    table : DataFrame
        With ``outcomes.split_column`` and ``outcomes.by`` as columns.
    outcomes : Outcomes
    n_boot, random_state
        Bootstrap replicates and seed (:func:`tzsl.evaluation.bootstrap_accuracy`).
    baselines : bool
        Add ``chance`` / ``majority`` (False for tables whose classes are not the test classes).
    per_split_rows : bool
        False for tables holding only the ``mean`` rows (no per-split intervals are computed).

    Returns
    -------
    DataFrame
        A copy with the new columns (NaN on rows without outcomes, e.g. ``std``).
    """
    sc, by = outcomes.split_column, list(outcomes.by)
    missing = [c for c in (sc, *by) if c not in table.columns]
    if missing:
        raise TzslError(f"table lacks key column(s) {missing}")
    out = table.copy()
    columns = list(dict.fromkeys(r.column for r in outcomes.records))
    single = len(columns) == 1
    for column in columns:
        low_name, high_name = interval_columns(column, single)
        low, high = np.full(len(out), np.nan), np.full(len(out), np.nan)
        recs = [r for r in outcomes.records if r.column == column]
        for keys in dict.fromkeys(r.keys for r in recs):
            group = [r for r in recs if r.keys == keys]
            for r in group if per_split_rows else [r for r in group if r.inner is not None]:
                iv = bootstrap_accuracy(r.correct, classes=r.classes, splits=r.inner, metric=r.metric,
                                        n_boot=n_boot, random_state=random_state)
                mask = _row_mask(out, sc, by, r.label, keys)
                low[mask], high[mask] = iv.ci95_low, iv.ci95_high
            per_split = [r for r in group if r.inner is None]
            if len(per_split) > 0:
                iv = bootstrap_accuracy(
                    np.concatenate([r.correct for r in per_split]),
                    classes=np.concatenate([r.classes for r in per_split]),
                    splits=np.concatenate([np.full(len(r.correct), i) for i, r in enumerate(per_split)]),
                    metric=per_split[0].metric, n_boot=n_boot, random_state=random_state)
                mask = _row_mask(out, sc, by, MEAN_ROW, keys)
                low[mask], high[mask] = iv.ci95_low, iv.ci95_high
        position = out.columns.get_loc(column) + 1 if column in out.columns else len(out.columns)
        for offset, (name, values) in enumerate(((low_name, low), (high_name, high))):
            out = out.drop(columns=name, errors="ignore")
            out.insert(min(position + offset, len(out.columns)), name, values)
    if baselines and columns:
        out = _add_baselines(out, outcomes, columns[0])
    return out


def _add_baselines(out: pd.DataFrame, outcomes: Outcomes, column: str) -> pd.DataFrame:
    """``chance`` and (where classes are unbalanced) ``majority`` per row, from ``column``'s records."""
    sc, by = outcomes.split_column, list(outcomes.by)
    chance, majority = np.full(len(out), np.nan), np.full(len(out), np.nan)
    unbalanced = False
    recs = [r for r in outcomes.records if r.column == column]
    for keys in dict.fromkeys(r.keys for r in recs):
        group = [r for r in recs if r.keys == keys]
        per_split = []
        for r in group:
            parts = [r.classes] if r.inner is None else [r.classes[r.inner == s] for s in pd.unique(r.inner)]
            c = float(np.mean([chance_accuracy(p) for p in parts]))
            m = float(np.mean([majority_class_accuracy(p) for p in parts]))
            unbalanced |= not np.isclose(c, m)
            mask = _row_mask(out, sc, by, r.label, keys)
            chance[mask], majority[mask] = c, m
            if r.inner is None:
                per_split.append((c, m))
        if per_split:
            mask = _row_mask(out, sc, by, MEAN_ROW, keys)
            chance[mask] = np.mean([p[0] for p in per_split])
            majority[mask] = np.mean([p[1] for p in per_split])
    if "chance" in out.columns:
        out["chance"] = np.where(np.isnan(chance), out["chance"].to_numpy(dtype=float), chance)
    else:
        out["chance"] = chance
    out = out.drop(columns="majority", errors="ignore")
    if unbalanced:
        out.insert(out.columns.get_loc("chance") + 1, "majority", majority)
    return out


def attribute_intervals(correct, truth, classes, splits, *, n_boot: int = 2000, random_state: int = 0,
                        chunk: int = 250) -> dict[str, np.ndarray]:
    """Two-level bootstrap intervals of per-attribute accuracy and balanced accuracy.

    Resampled as the accuracy intervals are (splits with replacement, test classes within
    each, every class with all its trials); per split, accuracy = correct / trials and
    balanced accuracy = (TPR + TNR) / 2 over the drawn trials (NaN where the drawn classes
    hold one value only), then averaged over the drawn splits skipping NaN; the ``mean``
    entries average the attributes in every replicate.

    Parameters
    ----------
    correct : array-like of shape (n_trials, n_attributes)
        1 where the trial's attribute was predicted right (fractions allowed: share of sensors).
    truth : array-like of shape (n_trials, n_attributes)
        True 0/1 attribute (its class's row).
    classes, splits : array-like of shape (n_trials,)

    Returns
    -------
    dict
        ``accuracy_low``, ``accuracy_high``, ``balanced_low``, ``balanced_high``: arrays of
        shape (n_attributes + 1,), the last entry for the mean over attributes.
    """
    correct, truth = np.asarray(correct, dtype=float), np.asarray(truth, dtype=float)
    cell, split_of, position, n_classes = cluster_cells(classes, splits)
    n_cells, m = split_of.size, correct.shape[1]
    S, C = len(n_classes), int(n_classes.max())
    sums, truths = np.zeros((n_cells, m)), np.zeros((n_cells, m))
    np.add.at(sums, cell, correct)
    truths[cell] = truth
    counts = np.bincount(cell, minlength=n_cells).astype(float)
    hit, pos, n = np.zeros((S, C, m)), np.zeros((S, C, m)), np.zeros((S, C))
    hit[split_of, position], pos[split_of, position], n[split_of, position] = sums, truths, counts
    rng = np.random.default_rng(random_state)
    acc_reps, bal_reps = np.empty((n_boot, m + 1)), np.empty((n_boot, m + 1))
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices: attribute undefined in a replicate
        for start in range(0, n_boot, chunk):
            b = min(chunk, n_boot - start)
            drawn = rng.integers(0, S, size=(b, S))
            nc = n_classes[drawn]
            pick = np.minimum((rng.random((b, S, C)) * nc[..., None]).astype(int), C - 1)
            ok = (np.arange(C) < nc[..., None])[..., None]  # (b, S, C, 1)
            rows = drawn[..., None]
            h = np.where(ok, hit[rows, pick], 0.0)
            p = np.where(ok, pos[rows, pick], 0.0)
            t = np.where(ok, n[rows, pick][..., None], 0.0) * np.isfinite(h)  # trials where the attribute exists
            p = np.where(np.isfinite(h), p, 0.0)
            h = np.nan_to_num(h)
            acc = h.sum(2) / t.sum(2)  # (b, S, m)
            tpr = (h * p).sum(2) / (t * p).sum(2)
            tnr = (h * (1 - p)).sum(2) / (t * (1 - p)).sum(2)
            bal = np.nanmean(np.where(np.isfinite(tpr) & np.isfinite(tnr), (tpr + tnr) / 2, np.nan), axis=1)
            acc = np.nanmean(acc, axis=1)
            acc_reps[start:start + b] = np.column_stack([acc, np.nanmean(acc, axis=1)])
            bal_reps[start:start + b] = np.column_stack([bal, np.nanmean(bal, axis=1)])
        acc_q = np.nanquantile(acc_reps, [0.025, 0.975], axis=0)
        bal_q = np.nanquantile(bal_reps, [0.025, 0.975], axis=0)
    return {"accuracy_low": acc_q[0], "accuracy_high": acc_q[1], "balanced_low": bal_q[0], "balanced_high": bal_q[1]}
