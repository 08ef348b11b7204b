"""Repeated group partitions of the fabric study: zero-shot over many train/test group splits.

The paper's split tests 3 groups (2 after its zero-shot variant), so every interval of the fixed
split covers chance. This module enumerates every partition of the fabric groups into test
groups (at least ``min_test``) and training groups (the rest) that is a fair zero-shot split,
fits on each, and aggregates over partitions.

Rules of a valid partition (:func:`group_partitions`)
------------------------------------------------------
1. ``both_signs`` (default on): every attribute has a positive and a negative training group
   (otherwise the attribute cannot be learned from the training groups).
2. Zero-shot: no test group's attribute row equals a training group's row (a test group on a
   row seen in training is not recognised zero-shot; a8 has groups 3, 4, 5 on one row).
3. Distinguishable: the test groups' rows differ pairwise on the attributes that vary among the
   training groups (identical rows, or rows differing only on attributes constant in training,
   cannot be told apart by any model). Such partitions are **excluded**, never merged.
4. Trainable: at least :data:`~tzsl.models.protocol.MIN_CV_CLASSES` distinct training rows (the
   class-grouped cross-validation of every method's model selection needs them).

:func:`partition_census` counts the valid partitions per number of test groups with and
without rule 1. On a8 no partition with 3 or more test groups satisfies rules 1-3: attribute 7
is positive only in group 1 and attribute 6 only in group 2, so both train; attribute 3 is
positive only in groups 3-5, so one of them trains and the other two cannot be tested; that
leaves test groups within {0, 6, 7}, and attribute 4 is positive only in 0, 6, 7. Without rule
1, a8 has 2 partitions with 4 test groups, both failing rule 4 (training rows: 2 distinct).
a12 without rule 1 has partitions with 4 test groups that pass rules 2-4 (the census says how
many); with rule 1 none has more than 3.

Interval (:func:`partition_summary`)
------------------------------------
:func:`tzsl.evaluation.bootstrap_accuracy` with the partitions as splits and the **test groups**
as the resampled clusters (each group brings all its samples). The group, not the fabric, is
the unit: a zero-shot claim is about new groups, a group's samples share one attribute row and
one prediction target, and which groups are tested dominates the spread. Partitions reuse the
same 8 groups, so the interval describes these groups, not groups in general. Beside it: chance
(mean over partitions of ``1 / n_test_groups``) and the majority baseline (always predict the
largest test group of the partition), bootstrapped the same way.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from tzsl.datasets import FabricSplit
from tzsl.evaluation import bootstrap_accuracy
from tzsl.exceptions import ConfigError
from tzsl.models.protocol import MIN_CV_CLASSES
from tzsl.studies.fabric.methods import run_job
from tzsl.studies.fabric.samples import FabricSamples
from tzsl.studies.fabric.tables import ESZSL_METHOD

__all__ = ["PARTITION_COLUMNS", "group_partitions", "partition_census", "partition_outcomes", "partition_summary",
           "run_partitions"]

#: Columns of :func:`partition_summary`.
PARTITION_COLUMNS = ("condition", "method", "metric", "n_partitions", "n_failed", "n_test_groups", "accuracy",
                     "ci95_low", "ci95_high", "chance", "majority_baseline", "majority_ci95_low",
                     "majority_ci95_high", "unit")


def _valid(A: np.ndarray, test: tuple[int, ...], both_signs: bool) -> bool:
    train = np.setdiff1d(np.arange(A.shape[0]), test)
    if train.size == 0:
        return False
    A_tr, A_te = A[train], A[list(test)]
    varies = A_tr.max(axis=0) > A_tr.min(axis=0)
    if both_signs and not varies.all():
        return False
    if len({tuple(r) for r in A_tr}) < MIN_CV_CLASSES:
        return False
    if (A_te[:, None, :] == A_tr[None, :, :]).all(axis=2).any():  # a test row seen in training
        return False
    informative = A_te[:, varies]
    return len({tuple(r) for r in informative}) == len(test)


def group_partitions(attribute_matrix, *, min_test: int = 4, both_signs: bool = True,
                     max_partitions: int | None = None, random_state: int = 0) -> list[FabricSplit]:
    """Every valid partition of the groups with at least ``min_test`` test groups (module docstring).

    Parameters
    ----------
    attribute_matrix : array-like of shape (n_groups, n_attributes)
        Group x attribute matrix (row g = group g).
    min_test : int, default 4
        Fewest test groups; at least one group always trains.
    both_signs : bool, default True
        Require every attribute to have a positive and a negative training group.
    max_partitions : int or None
        Keep a random sample of this many (seeded by ``random_state``); None: all.
    random_state : int, default 0

    Returns
    -------
    list of FabricSplit
        ``config`` is the partition's index (0, 1, ...), in the order of enumeration
        (fewest test groups first, then lexicographic).
    """
    A = np.asarray(attribute_matrix, dtype=np.float64)
    if A.ndim != 2:
        raise ConfigError(f"attribute matrix must be 2-D; got shape {A.shape}")
    n = A.shape[0]
    if isinstance(min_test, bool) or not isinstance(min_test, (int, np.integer)) or not 2 <= min_test < n:
        raise ConfigError(f"min_test must be an integer in [2, {n - 1}]; got {min_test!r}")
    tests = [t for k in range(int(min_test), n) for t in itertools.combinations(range(n), k)
             if _valid(A, t, both_signs)]
    if max_partitions is not None and len(tests) > max_partitions:
        keep = np.sort(np.random.default_rng(random_state).choice(len(tests), max_partitions, replace=False))
        tests = [tests[i] for i in keep]
    return [FabricSplit(config=i, train_groups=tuple(int(g) for g in np.setdiff1d(np.arange(n), t)),
                        test_groups=tuple(int(g) for g in t)) for i, t in enumerate(tests)]


def partition_census(attribute_matrix) -> pd.DataFrame:
    """Number of valid partitions per number of test groups, with and without the both-signs rule.

    Returns
    -------
    DataFrame
        Columns ``n_test_groups``, ``both_signs`` (bool), ``n_partitions``; one row per
        (n_test_groups in 2 .. n_groups - 1, rule).
    """
    A = np.asarray(attribute_matrix, dtype=np.float64)
    n = A.shape[0]
    rows = []
    for both in (True, False):
        counts = pd.Series([len(s.test_groups) for s in group_partitions(A, min_test=2, both_signs=both)],
                           dtype=int).value_counts()
        rows += [{"n_test_groups": k, "both_signs": both, "n_partitions": int(counts.get(k, 0))}
                 for k in range(2, n)]
    return pd.DataFrame(rows)


def partition_summary(outcomes: pd.DataFrame, *, n_boot: int = 2000, random_state: int = 0) -> pd.DataFrame:
    """Accuracy over partitions with its group-cluster bootstrap interval, chance and the majority baseline.

    Parameters
    ----------
    outcomes : DataFrame
        One row per test sample per fit: ``condition``, ``method``, ``partition`` (int),
        ``y_true``, ``y_pred`` (group ids), ``n_test_groups`` (of the partition). A random
        method's seeds are separate methods or averaged by the caller.
    n_boot, random_state
        Bootstrap replicates and seed (:func:`tzsl.evaluation.bootstrap_accuracy`).

    Returns
    -------
    DataFrame
        :data:`PARTITION_COLUMNS`, one row per (condition, method). ``accuracy`` is the mean
        over partitions of the per-sample accuracy; ``n_test_groups`` the smallest one.
    """
    rows = []
    for (condition, method), d in outcomes.groupby(["condition", "method"], sort=False):
        y, part = d["y_true"].to_numpy(), d["partition"].to_numpy()
        correct = (y == d["y_pred"].to_numpy()).astype(float)
        # majority baseline: always predict the partition's largest test group
        sizes = d.groupby(["partition", "y_true"]).size()
        majority = sizes.groupby(level=0).idxmax().map(lambda t: t[1])
        base = (y == majority.reindex(part).to_numpy()).astype(float)
        per_part = d.groupby("partition")["n_test_groups"].first()
        for metric in ("class_mean", "trial"):
            acc, maj = (bootstrap_accuracy(c, classes=y, splits=part, metric=metric, n_boot=n_boot,
                                           random_state=random_state) for c in (correct, base))
            rows.append({"condition": condition, "method": method, "metric": metric, "n_partitions": int(per_part.size),
                     "n_failed": int(d["n_failed"].iloc[0]) if "n_failed" in d else 0,
                     "n_test_groups": int(per_part.min()), "accuracy": acc.mean, "ci95_low": acc.ci95_low,
                     "ci95_high": acc.ci95_high, "chance": float((1.0 / per_part).mean()),
                     "majority_baseline": maj.mean, "majority_ci95_low": maj.ci95_low,
                     "majority_ci95_high": maj.ci95_high, "unit": "test group (cluster), partitions (splits)"})
    return pd.DataFrame(rows, columns=list(PARTITION_COLUMNS))


def partition_outcomes(runs: Sequence[dict], meta: Sequence[dict]) -> pd.DataFrame:
    """Per-sample outcomes of partition fits for :func:`partition_summary`.

    Parameters
    ----------
    runs : sequence of dict
        Rows of :func:`tzsl.studies.fabric.methods.run_job` (``method``, ``_y`` = (y_true,
        y_pred) of the test samples; absent when the fit failed).
    meta : sequence of dict
        Per run: ``condition``, ``partition``, ``n_test_groups``.

    Returns
    -------
    DataFrame
        One row per test sample per successful fit (meta columns, ``method``, ``y_true``,
        ``y_pred``) and ``n_failed``: failed fits of the same (condition, method).
    """
    frames: list[pd.DataFrame] = []
    failed: dict[tuple[Any, Any], int] = {}
    for r, m in zip(runs, meta, strict=True):
        key = (m["condition"], r["method"])
        failed[key] = failed.get(key, 0) + int("_y" not in r)
        if "_y" in r:
            y_true, y_pred = r["_y"]
            frames.append(pd.DataFrame({**m, "method": r["method"], "y_true": y_true, "y_pred": y_pred}))
    if not frames:
        return pd.DataFrame(columns=[*(meta[0] if meta else {}), "method", "y_true", "y_pred", "n_failed"])
    out = pd.concat(frames, ignore_index=True)
    out["n_failed"] = [failed[k] for k in zip(out["condition"], out["method"], strict=True)]
    return out


def run_partitions(samples: Sequence[FabricSamples], attribute_matrix, *, min_test: int = 4,
                   both_signs: bool = True, max_partitions: int | None = None, random_state: int = 0,
                   max_iter: int = 500, n_jobs: int | None = 1) -> tuple[pd.DataFrame, list[FabricSplit]]:
    """ESZSL (class-grouped CV, deterministic) on every valid partition, per data condition.

    Parameters
    ----------
    samples : sequence of FabricSamples
        The study's data conditions (``X`` (n, d), ``groups`` (n,)).
    attribute_matrix : array-like of shape (n_groups, n_attributes)
    min_test, both_signs, max_partitions, random_state
        :func:`group_partitions`.
    max_iter : int
        Passed to :func:`~tzsl.studies.fabric.methods.run_job` (unused by ESZSL).
    n_jobs : int or None
        joblib workers over fits.

    Returns
    -------
    summary : DataFrame
        :func:`partition_summary` (empty with :data:`PARTITION_COLUMNS` when no partition is valid).
    partitions : list of FabricSplit
    """
    A = np.asarray(attribute_matrix, dtype=np.float64)
    parts = group_partitions(A, min_test=min_test, both_signs=both_signs, max_partitions=max_partitions,
                             random_state=random_state)
    if not parts:
        return pd.DataFrame(columns=list(PARTITION_COLUMNS)), parts
    # one fit per (condition, partition): every partition has its own training groups, nothing to share
    jobs = [(s, p) for s in samples for p in parts]
    runs = [rows[0] for rows in Parallel(n_jobs=n_jobs)(
        delayed(run_job)(s.X, s.groups, A, [p], ESZSL_METHOD, None, None, (), max_iter) for s, p in jobs)]
    meta = [{"condition": s.condition, "partition": p.config, "n_test_groups": len(p.test_groups)} for s, p in jobs]
    outcomes = partition_outcomes(runs, meta)
    if outcomes.empty:
        return pd.DataFrame(columns=list(PARTITION_COLUMNS)), parts
    return partition_summary(outcomes, random_state=random_state), parts
