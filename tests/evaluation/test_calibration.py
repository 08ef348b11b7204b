"""Calibration metrics: ECE (equal-mass bins), Brier score, reliability table, bootstrap intervals.

The truth is known by construction: labels drawn from the posteriors themselves are calibrated
(simulated data); the same posteriors sharpened by a power are over-confident.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import tzsl.evaluation._calibration as calibration_module
from tzsl.evaluation import (
    add_calibration_columns,
    bootstrap_accuracy,
    bootstrap_trial_weights,
    brier_score,
    calibration_columns,
    calibration_intervals,
    calibration_terms,
    equal_mass_bins,
    expected_calibration_error,
    expected_ece_if_calibrated,
    reliability_table,
)
from tzsl.exceptions import TzslError


def _calibrated(rng, n_splits=5, n_classes=10, trials=20, concentration=0.3):
    """Simulated posteriors and labels drawn from them: calibrated by construction."""
    P, y, cls, spl = [], [], [], []
    for s in range(n_splits):
        logits = rng.standard_normal((n_classes, n_classes)) / concentration
        for c in range(n_classes):  # each class (object) has its own posterior shape
            p = np.exp(logits[c] + 0.3 * rng.standard_normal((trials, n_classes)))
            p /= p.sum(axis=1, keepdims=True)
            u = rng.random((trials, 1))
            P.append(p)
            y.append((u > np.cumsum(p, axis=1)).sum(axis=1))
            cls += [f"s{s}c{c}"] * trials
            spl += [f"s{s}"] * trials
    return np.vstack(P), np.concatenate(y), np.array(cls), np.array(spl)


def _sharpen(P, power):
    Q = P**power
    return Q / Q.sum(axis=1, keepdims=True)


def test_calibrated_posteriors_have_small_ece_and_sharpened_ones_large():
    P, y, cls, spl = _calibrated(np.random.default_rng(0))
    t = calibration_terms(P, y)
    over = calibration_terms(_sharpen(P, 4.0), y)
    assert expected_calibration_error(t.confidence, t.correct) < 0.04
    assert expected_calibration_error(over.confidence, over.correct) > 0.12
    iv = calibration_intervals(t.confidence, t.correct, t.brier, classes=cls, splits=spl, n_boot=300)
    assert iv["ece"].ci95_low <= iv["ece"].mean <= iv["ece"].ci95_high
    assert iv["brier"].ci95_low < iv["brier"].mean < iv["brier"].ci95_high
    # a calibrated posterior has a lower expected Brier score than its sharpened version
    assert brier_score(P, y) < brier_score(_sharpen(P, 4.0), y)


def test_ece_if_calibrated_matches_the_ece_of_calibrated_draws_and_shrinks_with_trials():
    """The reference is the ECE that calibrated outcomes show: simulated calibrated labels land
    near it, an over-confident posterior far above it, and more trials lower it."""
    rng = np.random.default_rng(1)
    c = rng.uniform(0.1, 0.9, 500)
    measured = [expected_calibration_error(c, rng.random(c.size) < c) for _ in range(200)]
    reference = expected_ece_if_calibrated(c, n_draws=2000, random_state=2)
    assert reference == pytest.approx(np.mean(measured), rel=0.1)
    assert expected_calibration_error(c, rng.random(c.size) < c**3) > 2 * reference
    assert expected_ece_if_calibrated(np.tile(c, 20)) < reference / 3


def test_terms_and_brier_by_hand():
    P = np.array([[0.7, 0.2, 0.1], [0.5, 0.5, 0.0]])
    t = calibration_terms(P, np.array([1, 0]), predicted=np.array([0, 1]))
    assert t.confidence.tolist() == [0.7, 0.5]
    assert t.correct.tolist() == [0.0, 0.0]
    assert t.brier == pytest.approx([0.49 + 0.64 + 0.01, 0.25 + 0.25])
    assert brier_score(P, np.array([0, 0])) == pytest.approx(((0.09 + 0.04 + 0.01) + 0.5) / 2)


def test_equal_mass_bins_and_reliability_table():
    c = np.linspace(0.1, 1.0, 25)
    bins = equal_mass_bins(c[::-1], 5)
    assert np.bincount(bins).tolist() == [5] * 5 and bins[0] == 4  # the most confident trial is in the top bin
    correct = (np.arange(25) % 2).astype(float)
    table = reliability_table(c, correct, n_bins=5)
    assert table["n_trials"].sum() == 25 and table["confidence"].is_monotonic_increasing
    ece = expected_calibration_error(c, correct, n_bins=5)
    gaps = (table["accuracy"] - table["confidence"]).abs() * table["n_trials"] / 25
    assert ece == pytest.approx(gaps.sum())
    assert len(equal_mass_bins(c[:3], 10)) == 3 and equal_mass_bins(c[:3], 10).max() == 2


def test_trial_weights_are_the_accuracy_bootstraps_draws():
    """One split: the weighted mean of correctness is the accuracy bootstrap's replicate."""
    rng = np.random.default_rng(3)
    cls = np.repeat([f"c{i}" for i in range(8)], rng.integers(3, 9, size=8))
    correct = (rng.random(len(cls)) < 0.4).astype(float)
    w = np.vstack(list(bootstrap_trial_weights(cls, n_boot=500, random_state=7)))
    assert w.shape == (500, len(cls))
    # every class's trials share a weight; weights sum to the trials of the drawn classes
    for c in np.unique(cls):
        assert (w[:, cls == c] == w[:, cls == c][:, :1]).all()
    assert np.allclose(w.reshape(500, -1).sum(axis=1) > 0, True)
    reps = w @ correct / w.sum(axis=1)
    iv = bootstrap_accuracy(correct, classes=cls, n_boot=500, random_state=7)
    assert np.quantile(reps, 0.025) == pytest.approx(iv.ci95_low)
    assert np.quantile(reps, 0.975) == pytest.approx(iv.ci95_high)


def test_add_calibration_columns_per_method_and_variant():
    P, y, cls, spl = _calibrated(np.random.default_rng(1), n_splits=3)
    good, bad = calibration_terms(P, y), calibration_terms(_sharpen(P, 4.0), y)
    parts = []
    for name, t in (("a", good), ("b", bad)):
        parts.append(pd.DataFrame({"method": name, "class": cls, "split": spl, "correct": t.correct,
                                   "confidence": good.confidence, "brier": good.brier,
                                   "confidence_uncalibrated": t.confidence, "brier_uncalibrated": t.brier}))
    parts.append(pd.DataFrame({"method": "c", "class": cls, "split": spl, "correct": good.correct,
                               "confidence": np.nan, "brier": np.nan, "confidence_uncalibrated": np.nan,
                               "brier_uncalibrated": np.nan}))
    summary = pd.DataFrame({"method": ["a", "b", "c"]})
    out = add_calibration_columns(summary, pd.concat(parts), n_boot=200)
    assert set(calibration_columns("") + calibration_columns("_uncalibrated")) <= set(out.columns)
    assert out.loc[1, "ece_uncalibrated"] > 0.1 > out.loc[0, "ece_uncalibrated"]
    assert out.loc[2, ["ece", "brier_uncalibrated"]].isna().all()
    assert (out["ece_ci95_low"].iloc[:2] <= out["ece"].iloc[:2]).all()


def test_bad_input_is_refused():
    with pytest.raises(TzslError, match="sum"):
        calibration_terms(np.array([[0.5, 0.6]]), np.array([0]))
    with pytest.raises(TzslError, match="y_true"):
        calibration_terms(np.array([[0.5, 0.5]]), np.array([2]))
    with pytest.raises(TzslError, match="n_bins"):
        equal_mass_bins([0.5], 0)
    with pytest.raises(TzslError, match="confidence"):
        expected_calibration_error([1.5], [1])


def test_ece_interval_is_bias_corrected_and_covers_the_point():
    """Few objects: the raw replicates sit above the point; the corrected interval brackets it."""
    P, y, cls, spl = _calibrated(np.random.default_rng(4), n_splits=2, n_classes=10, trials=10)
    t = calibration_terms(_sharpen(P, 2.0), y)
    iv = calibration_intervals(t.confidence, t.correct, t.brier, classes=cls, splits=spl, n_boot=500)
    bins = equal_mass_bins(t.confidence)
    raw = np.concatenate([calibration_module._weighted_ece(t.confidence, t.correct, bins, 10, w)
                          for w in bootstrap_trial_weights(cls, spl, n_boot=500)])
    assert raw.mean() > iv["ece"].mean  # the upward bias the correction removes
    assert 0.0 <= iv["ece"].ci95_low <= iv["ece"].mean <= iv["ece"].ci95_high
    assert iv["ece"].ci95_high - iv["ece"].ci95_low == pytest.approx(
        np.quantile(raw, 0.975) - max(np.quantile(raw, 0.025), raw.mean() - iv["ece"].mean), rel=1e-6)
