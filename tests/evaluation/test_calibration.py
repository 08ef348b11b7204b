"""Calibration of class posteriors (issue 21, item 1): measured where the truth is known.

The posteriors here are SIMULATED: classes drawn from the posterior itself are calibrated by
construction; raising it to a power makes it over-confident on purpose.
"""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.evaluation import (
    brier_terms,
    calibration_intervals,
    expected_calibration_error,
    reliability_table,
    top_label,
)
from tzsl.exceptions import TzslError


def _calibrated(n: int = 3000, k: int = 6, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    logits = 2.0 * rng.normal(size=(n, k))
    P = np.exp(logits - logits.max(axis=1, keepdims=True))
    P /= P.sum(axis=1, keepdims=True)
    y = (rng.random(n)[:, None] > np.cumsum(P, axis=1)).sum(axis=1)  # y ~ P: calibrated by construction
    return P, np.minimum(y, k - 1)


def _sharpen(P: np.ndarray, power: float) -> np.ndarray:
    Q = P**power
    return Q / Q.sum(axis=1, keepdims=True)


def test_calibrated_posteriors_have_a_small_ece_and_sharpened_ones_a_large_one():
    P, y = _calibrated()
    confidence, correct = top_label(P, y)
    ece = expected_calibration_error(confidence, correct)
    over = expected_calibration_error(*top_label(_sharpen(P, 3.0), y))
    assert ece < 0.04 < 0.15 < over  # the over-confident posterior is detected
    table = reliability_table(*top_label(_sharpen(P, 3.0), y))
    assert len(table) == 10 and (table["confidence"] > table["accuracy"]).all()  # every bin over-confident
    assert table["n_trials"].sum() == len(y)


def test_brier_terms_are_zero_for_certain_right_and_two_for_certain_wrong():
    P = np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]])
    np.testing.assert_allclose(brier_terms(P, np.array([0, 0, 0])), [0.0, 2.0, 0.5])
    with pytest.raises(TzslError, match="summing to 1"):
        brier_terms(np.array([[0.7, 0.7]]), np.array([0]))


def test_intervals_cover_the_point_and_separate_calibrated_from_overconfident():
    P, y = _calibrated(n=1200)
    splits, classes = np.arange(len(y)) % 4, y
    good = calibration_intervals(*top_label(P, y), brier_terms(P, y), classes, splits, n_boot=300)
    bad_P = _sharpen(P, 3.0)
    bad = calibration_intervals(*top_label(bad_P, y), brier_terms(bad_P, y), classes, splits, n_boot=300)
    for iv in (*good.values(), *bad.values()):
        assert iv.ci95_low <= iv.ci95_high
    assert good["brier"].ci95_low <= good["brier"].mean <= good["brier"].ci95_high
    assert good["ece"].ci95_high < bad["ece"].ci95_low and good["brier"].mean < bad["brier"].mean
