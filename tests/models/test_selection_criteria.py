"""The zero-shot searches' CV criteria and tie rule (tzsl.models.protocol; issue 41)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.special import log_softmax

from tzsl.models import ESZSL, ESZSLCV, CompatibilityRule, ZeroShotClassifier
from tzsl.models._selection_criteria import BETA_MAX
from tzsl.models.protocol import (
    TIE_TOLERANCE,
    best_within_tolerance,
    heldout_scores,
    neg_log_loss,
)


def brute_force_neg_log_loss(scores: np.ndarray, y: np.ndarray) -> float:
    """The criterion of one configuration, written out: centre, scale, then a bounded scalar search over beta."""
    z = scores - scores.mean(axis=1, keepdims=True)
    z = z / np.sqrt(np.mean(z**2))
    loss = lambda beta: -np.mean(log_softmax(beta * z, axis=1)[np.arange(y.size), y])  # noqa: E731
    found = minimize_scalar(loss, bounds=(0.0, BETA_MAX), method="bounded", options={"xatol": 1e-10})
    return -min(found.fun, loss(0.0), loss(BETA_MAX))


def test_the_criterion_is_the_best_temperature_log_loss():
    rng = np.random.default_rng(0)
    y = rng.integers(0, 4, 40)
    scores = rng.normal(size=(3, 40, 4)) + 1.5 * np.eye(4)[y] * np.array([0.0, 1.0, 3.0])[:, None, None]
    got = neg_log_loss(scores, y)
    want = [brute_force_neg_log_loss(s, y) for s in scores]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-8)
    assert got[0] < got[1] < got[2] <= 0  # more signal, less loss


def test_useless_or_reversed_scores_score_chance_and_the_scale_does_not_matter():
    rng = np.random.default_rng(1)
    y = rng.integers(0, 5, 60)
    reversed_scores = -np.eye(5)[y] + 0.1 * rng.normal(size=(60, 5))
    assert neg_log_loss(reversed_scores, y) == pytest.approx(-np.log(5))  # beta = 0: chance, never worse
    assert neg_log_loss(np.zeros((60, 5)), y) == pytest.approx(-np.log(5))
    s = rng.normal(size=(60, 5)) + np.eye(5)[y]
    shifted = 1e3 * s + rng.normal(size=(60, 1))  # a positive scale and a shift per trial change nothing
    assert neg_log_loss(shifted, y) == pytest.approx(neg_log_loss(s, y), abs=1e-10)


def test_a_last_bit_moves_the_criterion_by_about_a_last_bit_while_accuracy_jumps():
    rng = np.random.default_rng(2)
    y = np.array([0, 1])
    scores = np.array([[1.0, 1.0 + 1e-15], [0.0, 1.0]])  # trial 0 on a knife edge
    nudged = scores.copy()
    nudged[0, 1] -= 2e-15
    assert heldout_scores(scores, y, "accuracy") == 0.5 and heldout_scores(nudged, y, "accuracy") == 1.0
    assert abs(heldout_scores(scores, y, "neg_log_loss") - heldout_scores(nudged, y, "neg_log_loss")) < 1e-12
    big = rng.normal(size=(7, 7, 80, 6))
    y80 = rng.integers(0, 6, 80)
    wiggle = big * (1 + 1e-12 * rng.uniform(-1, 1, big.shape))
    assert np.max(np.abs(neg_log_loss(big, y80) - neg_log_loss(wiggle, y80))) < 1e-10


def test_balanced_accuracy_is_the_mean_per_class_accuracy():
    y = np.array([0, 0, 0, 1])
    scores = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]])
    assert heldout_scores(scores, y, "accuracy") == pytest.approx(0.75)
    assert heldout_scores(scores, y, "balanced_accuracy") == pytest.approx((2 / 3 + 1) / 2)
    with pytest.raises(ValueError, match="unknown scoring"):
        heldout_scores(scores, y, "f1")


def test_ties_go_to_the_preferred_configuration():
    gammas, lams = np.array([0.1, 1.0, 10.0]), np.array([1.0, 10.0])
    scores = np.array([[0.5, 0.7], [0.7 - TIE_TOLERANCE / 2, 0.6], [0.2, np.nan]])
    most_regularised = (gammas, lams)
    assert best_within_tolerance(scores, most_regularised) == (1, 0)  # gamma 1 ties with 0.1 and is larger
    assert best_within_tolerance(scores, (-gammas, -lams)) == (0, 1)  # preferring small values: gamma 0.1
    scores[1, 0] = 0.7 - 2 * TIE_TOLERANCE  # no longer tied: the best alone
    assert best_within_tolerance(scores, most_regularised) == (0, 1)
    flat = np.full((3, 2), -0.3)
    assert best_within_tolerance(flat, most_regularised) == (2, 1)  # a flat grid: the largest of both
    assert best_within_tolerance(flat, (-gammas, -lams)) == (0, 0)  # ... or the first of both
    assert best_within_tolerance(np.array([0.1, 0.4, 0.4]), (np.array([3.0, 1.0, 2.0]),)) == (2,)
    with pytest.raises(ValueError, match="preference keys"):
        best_within_tolerance(flat, (gammas,))


def test_accuracy_searches_choose_as_an_argmax_over_the_grid_did():
    """With accuracy (the default) only equal scores tie: the first of them in grid order, as np.argmax chose."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        scores = rng.integers(0, 6, size=(4, 3)) / 5  # accuracies of 5 trials: many exact ties
        first = np.unravel_index(np.argmax(scores), scores.shape)
        assert best_within_tolerance(scores, (-np.arange(4.0), -np.arange(3.0))) == first


def _synthetic():
    spec = importlib.util.spec_from_file_location("eszsl_tests", Path(__file__).with_name("test_eszsl.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.zsl_problem(n_classes=10, per_class=15, noise=2.0, seed=3)


def test_eszslcv_scores_its_grid_with_the_criterion_and_survives_a_last_bit():
    X, y, A = _synthetic()
    train = y < 7
    assert ESZSLCV().scoring == "accuracy"  # the default, chosen on selection splits (tzsl.models.protocol)
    model = ESZSLCV(gammas=(0.01, 1.0, 100.0), lams=(0.1, 10.0), grid_extensions=0, scoring="neg_log_loss")
    model.fit(X[train], A[y[train]], y[train])
    assert np.all(model.mean_cv_scores_ <= 0)
    # one cell by hand: the fold's fit, its compatibility scores among the held-out classes, the criterion
    folds = model._folds(X[train], y[train])
    tr, va = folds[0]
    val_rows = np.unique(y[train][va])
    fold = ESZSL(gamma=1.0, lam=10.0).fit(X[train][tr], A[y[train][tr]], y[train][tr])
    compat = fold.decision_function(X[train][va]) @ A[val_rows].T
    want = brute_force_neg_log_loss(compat, np.searchsorted(val_rows, y[train][va]))
    assert model.cv_scores_[1, 1, 0] == pytest.approx(want, abs=1e-8)

    rng = np.random.default_rng(4)
    wiggled = X * (1 + 1e-12 * rng.uniform(-1, 1, X.shape))
    again = ESZSLCV(scoring="neg_log_loss").fit(wiggled[train], A[y[train]], y[train])
    first = ESZSLCV(scoring="neg_log_loss").fit(X[train], A[y[train]], y[train])
    assert (again.best_gamma_, again.best_lam_) == (first.best_gamma_, first.best_lam_)
    clf = ZeroShotClassifier(attribute_model=ESZSLCV(scoring="neg_log_loss"), decision_rule=CompatibilityRule())
    clf_wiggled = ZeroShotClassifier(attribute_model=ESZSLCV(scoring="neg_log_loss"),
                                     decision_rule=CompatibilityRule())
    clf.fit(X[train], A[y[train]], y[train])
    clf_wiggled.fit(wiggled[train], A[y[train]], y[train])
    np.testing.assert_array_equal(clf.predict(X[~train], A[7:]), clf_wiggled.predict(wiggled[~train], A[7:]))
