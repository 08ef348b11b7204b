"""The vectorised bootstraps equal a plain per-replicate loop on the same random draws (issue 22, item 3).

Each reference below draws the same random numbers as the implementation (same generator,
same calls, same order: one chunk, since the inputs are small), then builds every replicate
trial by trial in Python: which splits were drawn, which classes within them, which trials
those classes bring, and the statistic of that sample. The draw counts must match exactly
(same draws); the statistics to 1e-12 (the loop sums in another order). That the cells are
numbered as the former pandas ``groupby(["split", "class"]).ngroup()`` numbered them, so that
every replicate is drawn from the same cells as before, is checked too.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tzsl.evaluation import (
    DEFAULT_N_BINS,
    bootstrap_accuracy_columns,
    bootstrap_cell_weights,
    bootstrap_trial_weights,
    calibration_intervals,
    cluster_cells,
    expected_calibration_error,
)
from tzsl.exceptions import TzslError


def _structure(classes, splits):
    """Sorted split labels and, per split, its sorted class labels."""
    labels = sorted(set(splits.tolist()))
    return labels, [sorted(set(classes[splits == s].tolist())) for s in labels]


def _reference_samples(classes, splits, n_boot, seed):
    """Per replicate, the trial indices it holds (with repeats), and its (split, class) draw counts."""
    labels, class_lists = _structure(classes, splits)
    n_splits, max_classes = len(labels), max(len(c) for c in class_lists)
    rng = np.random.default_rng(seed)
    drawn = rng.integers(0, n_splits, size=(n_boot, n_splits))
    u = rng.random((n_boot, n_splits, max_classes))
    held, counts = [], []
    for r in range(n_boot):
        trials, count = [], {}
        for j in range(n_splits):
            k = drawn[r, j]
            names = class_lists[k]
            picked = [names[min(int(u[r, j, i] * len(names)), max_classes - 1)] for i in range(len(names))]
            blocks = [np.flatnonzero((splits == labels[k]) & (classes == c)) for c in picked]
            trials.append(blocks)
            for c in picked:
                count[(labels[k], c)] = count.get((labels[k], c), 0) + 1
        held.append(trials)
        counts.append(count)
    return held, counts


def _reference_accuracy(correct, held, metric):
    """(n_boot, n_methods) replicates from the held samples."""
    reps = []
    for trials in held:
        per_split = []
        for blocks in trials:
            if metric == "trial":
                per_split.append(correct[np.concatenate(blocks)].mean(axis=0))
            else:
                per_split.append(np.mean([correct[b].mean(axis=0) for b in blocks], axis=0))
        reps.append(np.mean(per_split, axis=0))
    return np.array(reps)


def _reference_calibration(confidence, correct, brier, held):
    """Bias-corrected ECE and plain Brier intervals, replicate by replicate and bin by bin."""
    n = len(confidence)
    n_bins = min(DEFAULT_N_BINS, n)
    bins = np.empty(n, dtype=int)
    bins[np.argsort(confidence, kind="stable")] = (np.arange(n) * n_bins) // n
    ece, brier_reps = [], []
    for trials in held:
        idx = np.concatenate([b for blocks in trials for b in blocks])
        gap = sum(abs((correct[idx] - confidence[idx])[bins[idx] == j].sum()) for j in range(n_bins))
        ece.append(gap / idx.size)
        brier_reps.append(brier[idx].mean())
    ece = np.array(ece)
    point = expected_calibration_error(confidence, correct)
    low, high = np.clip(np.quantile(ece - (ece.mean() - point), [0.025, 0.975]), 0.0, None)
    return (low, high), tuple(np.quantile(brier_reps, [0.025, 0.975]))


def _data(draw_seed: int, n: int, n_classes: int, n_splits: int, string_labels: bool):
    rng = np.random.default_rng(draw_seed)
    classes = rng.integers(0, n_classes, n)
    splits = rng.integers(0, n_splits, n)
    if string_labels:
        classes, splits = np.array([f"obj{c}" for c in classes]), np.array([f"split{s}" for s in splits])
    return rng, classes, splits


_CASES = dict(seed=st.integers(0, 10_000), n=st.integers(1, 60), n_classes=st.integers(1, 6),
              n_splits=st.integers(1, 4), string_labels=st.booleans())
_N_BOOT = 25


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(metric=st.sampled_from(["trial", "class_mean"]), **_CASES)
def test_accuracy_replicates_equal_the_loop(seed, n, n_classes, n_splits, string_labels, metric):
    rng, classes, splits = _data(seed, n, n_classes, n_splits, string_labels)
    correct = np.column_stack([(rng.random(n) < 0.5).astype(float), rng.random(n)])  # fractions are allowed too
    held, _ = _reference_samples(classes, splits, _N_BOOT, seed)
    reps = _reference_accuracy(correct, held, metric)
    _, low, high = bootstrap_accuracy_columns(correct, classes=classes, splits=splits, metric=metric,
                                              n_boot=_N_BOOT, random_state=seed)
    np.testing.assert_allclose(low, np.quantile(reps, 0.025, axis=0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(high, np.quantile(reps, 0.975, axis=0), rtol=0, atol=1e-12)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(**_CASES)
def test_cell_counts_are_the_loops_draws_exactly(seed, n, n_classes, n_splits, string_labels):
    _, classes, splits = _data(seed, n, n_classes, n_splits, string_labels)
    _, counts = _reference_samples(classes, splits, _N_BOOT, seed)
    labels, class_lists = _structure(classes, splits)
    cells = [(s, c) for s, names in zip(labels, class_lists, strict=True) for c in names]  # split, then class order
    expected = np.array([[count.get(key, 0) for key in cells] for count in counts], dtype=float)
    w = np.vstack(list(bootstrap_cell_weights(classes, splits, n_boot=_N_BOOT, random_state=seed)))
    np.testing.assert_array_equal(w, expected)
    cell = cluster_cells(classes, splits)[0]
    trial_w = np.vstack(list(bootstrap_trial_weights(classes, splits, n_boot=_N_BOOT, random_state=seed)))
    np.testing.assert_array_equal(trial_w, expected[:, cell])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(**_CASES)
def test_calibration_intervals_equal_the_loop(seed, n, n_classes, n_splits, string_labels):
    rng, classes, splits = _data(seed, n, n_classes, n_splits, string_labels)
    confidence, correct, brier = rng.random(n), (rng.random(n) < 0.5).astype(float), 2 * rng.random(n)
    held, _ = _reference_samples(classes, splits, _N_BOOT, seed)
    (ece_low, ece_high), (brier_low, brier_high) = _reference_calibration(confidence, correct, brier, held)
    out = calibration_intervals(confidence, correct, brier, classes=classes, splits=splits, n_boot=_N_BOOT,
                                random_state=seed)
    assert out["ece"].mean == expected_calibration_error(confidence, correct)
    np.testing.assert_allclose([out["ece"].ci95_low, out["ece"].ci95_high], [ece_low, ece_high], rtol=0, atol=1e-12)
    np.testing.assert_allclose([out["brier"].ci95_low, out["brier"].ci95_high], [brier_low, brier_high],
                               rtol=0, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 80), string_labels=st.booleans())
def test_cells_are_numbered_as_the_pandas_groupby_numbered_them(seed, n, string_labels):
    _, classes, splits = _data(seed, n, 7, 5, string_labels)
    frame = pd.DataFrame({"split": splits, "class": classes})
    expected = frame.groupby(["split", "class"], sort=True).ngroup().to_numpy()
    cell, split_of_cell, position, n_classes = cluster_cells(classes, splits)
    np.testing.assert_array_equal(cell, expected)
    np.testing.assert_array_equal(split_of_cell[cell], pd.factorize(splits, sort=True)[0])
    assert position.min() == 0 and (position < n_classes[split_of_cell]).all()


def test_cluster_cells_sorts_by_split_then_class():
    classes = np.array(["b", "a", "b", "c", "a"])
    splits = np.array([2, 1, 1, 2, 2])
    cell, split_of_cell, position, n_classes = cluster_cells(classes, splits)
    # cells: (1, a) (1, b) (2, a) (2, b) (2, c)
    assert cell.tolist() == [3, 0, 1, 4, 2]
    assert split_of_cell.tolist() == [0, 0, 1, 1, 1]
    assert position.tolist() == [0, 1, 0, 1, 2]
    assert n_classes.tolist() == [2, 3]
    assert cluster_cells(classes)[0].tolist() == [1, 0, 1, 2, 0]  # one split


def test_cluster_cells_refuses_missing_labels_and_mismatched_lengths():
    with pytest.raises(TzslError, match="missing"):
        cluster_cells(np.array(["a", None], dtype=object), np.array([0, 0]))
    with pytest.raises(TzslError, match="one entry per trial"):
        cluster_cells(np.array(["a", "b"]), np.array([0]))
    with pytest.raises(TzslError, match="one entry per trial"):
        calibration_intervals([0.5, 0.6], [1, 0], [0.1, 0.2], classes=["a"], splits=None)
