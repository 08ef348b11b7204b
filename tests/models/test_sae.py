"""SAE, the semantic autoencoder (Kodirov et al. CVPR 2017), closed form."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from sklearn.utils._param_validation import InvalidParameterError

from tzsl.models import (
    NearestAttributeRule,
    ZeroShotClassifier,
    ZSLInputError,
    build_method,
)
from tzsl.models.embedding._sae import SAE, SAECV, sylvester_solution
from tzsl.models.protocol import class_grouped_folds, cosine_similarities


def sylvester_residual(A, X, W, lam):
    """Relative residual of ``A^T A W + lam W X^T X = (1 + lam) A^T X``."""
    rhs = (1 + lam) * A.T @ X
    lhs = A.T @ A @ W + lam * W @ (X.T @ X)
    return np.linalg.norm(lhs - rhs) / np.linalg.norm(rhs)


@pytest.mark.parametrize("lam", [0.01, 1.0, 300.0])
def test_closed_form_solves_the_sylvester_equation(lam):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(60, 7))
    A = rng.normal(size=(60, 4))
    W = sylvester_solution(A, X, lam)
    assert W.shape == (4, 7)
    assert sylvester_residual(A, X, W, lam) < 1e-8
    reference = scipy.linalg.solve_sylvester(A.T @ A, lam * X.T @ X, (1 + lam) * A.T @ X)
    np.testing.assert_allclose(W, reference, rtol=1e-7, atol=1e-10)


def test_fitted_encoder_satisfies_its_equation_on_standardised_features(zero_shot_problem):
    # 16 training classes, 10 attributes: A^T A is full rank; the fitted coef_ is the encoder W
    p = zero_shot_problem(seed=3)
    model = SAE(lam=2.0).fit(p.X_train, p.A_train)
    Xs = (p.X_train - p.X_train.mean(axis=0)) / p.X_train.std(axis=0)
    assert sylvester_residual(p.A_train, Xs, model.coef_, 2.0) < 1e-8


def test_rank_deficient_problem_gets_the_minimum_norm_solution():
    # 3 distinct rows in 5 attributes and a zero feature column: A^T A and X^T X are both singular,
    # solve_sylvester's problem is singular, yet the equation has solutions; we return the one
    # with no component in the joint null directions.
    rng = np.random.default_rng(1)
    rows = rng.integers(0, 2, (3, 5)).astype(float)
    A = rows[np.arange(30) % 3]
    X = np.column_stack([rng.normal(size=(30, 4)), np.zeros(30)])
    W = sylvester_solution(A, X, 1.0)
    assert np.isfinite(W).all()
    assert sylvester_residual(A, X, W, 1.0) < 1e-8
    np.testing.assert_allclose(W[:, -1], 0.0, atol=1e-12)  # zero feature: decoder-free direction
    null = scipy.linalg.null_space(A)  # attribute directions no training row has
    np.testing.assert_allclose(null.T @ W, 0.0, atol=1e-10)


def test_recognises_unseen_classes(zero_shot_problem):
    accuracies = []
    for seed in range(3):
        p = zero_shot_problem(seed=seed)
        method = ZeroShotClassifier(attribute_model=SAE(), decision_rule=NearestAttributeRule(metric="cosine"))
        pred = method.fit(p.X_train, p.A_train).predict(p.X_test, p.S_test)
        accuracies.append(np.mean(pred == p.y_test))
    assert p.chance == 0.125
    assert np.mean(accuracies) >= 0.8, accuracies


def test_predict_is_the_projection_and_the_sae_method_scores_cosines(zero_shot_problem):
    p = zero_shot_problem(seed=4)
    model = SAE(lam=0.5).fit(p.X_train, p.A_train)
    E = model.predict(p.X_test)
    Xs = model.scaler_.transform(p.X_test)
    np.testing.assert_allclose(E, Xs @ model.coef_.T)
    np.testing.assert_allclose(model.decision_function(p.X_test), E)
    cos = np.array([[e @ s / np.linalg.norm(e) / np.linalg.norm(s) for s in p.S_test] for e in E])
    method = build_method("sae", lams=(0.5,), n_splits=2).fit(p.X_train, p.A_train)
    np.testing.assert_allclose(method.decision_function(p.X_test, p.S_test), cos, atol=1e-12)
    assert model.score_kind == "embedding"
    np.testing.assert_array_equal(model.class_attributes_, np.unique(p.A_train, axis=0))


def test_without_standardisation_uses_raw_features():
    rng = np.random.default_rng(2)
    X = 3.0 + rng.normal(size=(40, 6))
    A = rng.integers(0, 2, (4, 3)).astype(float)[np.arange(40) % 4]
    model = SAE(lam=0.7, standardize=False).fit(X, A)
    assert model.scaler_ is None
    np.testing.assert_allclose(model.coef_, sylvester_solution(A, X, 0.7))


@pytest.mark.parametrize(
    "params", [{"lam": 0.0}, {"lam": -1.0}, {"lam": "big"}, {"standardize": "yes"}]
)
def test_bad_parameters_raise_invalid_parameter_error(params):
    X = np.random.default_rng(0).normal(size=(10, 3))
    A = np.eye(2)[np.arange(10) % 2]
    with pytest.raises(InvalidParameterError):
        SAE(**params).fit(X, A)


def test_bad_targets_raise_one_line_errors():
    X = np.random.default_rng(0).normal(size=(10, 3))
    with pytest.raises(ZSLInputError, match="one class"):
        SAE().fit(X, np.ones((10, 4)))
    with pytest.raises(ZSLInputError, match="X, Y"):
        SAE().fit(X, np.ones((9, 4)))


def held_out_accuracy_by_hand(X, A, lams, n_splits):
    """Class-held-out CV written with plain SAE fits: (n_lams, n_splits) accuracies."""
    rows, cls = np.unique(A, axis=0, return_inverse=True)
    cls = cls.ravel()
    out = []
    for train, held_out in class_grouped_folds(cls, n_splits, "by hand"):
        held = np.unique(cls[held_out])
        truth = np.searchsorted(held, cls[held_out])
        fold = []
        for lam in lams:
            model = SAE(lam=lam).fit(X[train], A[train])
            scores = cosine_similarities(model.decision_function(X[held_out]), rows[held])
            fold.append(np.mean(scores.argmax(axis=1) == truth))
        out.append(fold)
    return np.array(out).T


def test_cv_scores_equal_plain_sae_fits_on_held_out_classes(zero_shot_problem):
    p = zero_shot_problem(seed=5, noise=3.0)
    lams = (0.01, 1.0, 100.0)
    model = SAECV(lams=lams, n_splits=4).fit(p.X_train, p.A_train)  # scoring="accuracy", the default
    expected = held_out_accuracy_by_hand(p.X_train, p.A_train, lams, 4)
    np.testing.assert_allclose(model.cv_scores_, expected)
    best = int(np.argmax(expected.mean(axis=1)))  # ties (within 1e-6) keep the smallest lam: argmax's first
    assert model.best_lam_ == lams[best]
    assert model.best_score_ == pytest.approx(expected.mean(axis=1)[best])
    refit = SAE(lam=model.best_lam_).fit(p.X_train, p.A_train)
    np.testing.assert_allclose(model.coef_, refit.coef_)
    np.testing.assert_allclose(model.decision_function(p.X_test), refit.decision_function(p.X_test))


def test_cv_recognises_unseen_classes(zero_shot_problem):
    accuracies = []
    for seed in range(3):
        p = zero_shot_problem(seed=seed)
        model = SAECV().fit(p.X_train, p.A_train)
        scores = cosine_similarities(model.decision_function(p.X_test), p.S_test)
        accuracies.append(np.mean(np.argmax(scores, axis=1) == p.y_test))
    assert np.mean(accuracies) >= 0.8, accuracies


def test_cv_with_few_classes_holds_out_one_class_against_all_rows():
    rng = np.random.default_rng(0)
    rows = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    A = rows[np.arange(30) % 3]
    X = A @ rng.normal(size=(2, 4)) + 0.1 * rng.normal(size=(30, 4))
    model = SAECV(lams=(0.1, 10.0), grid_extensions=0).fit(X, A)
    assert model.cv_scores_.shape == (2, 3)  # leave-one-class-out
    assert np.all((model.cv_scores_ >= 0) & (model.cv_scores_ <= 1))
    smooth = SAECV(lams=(0.1, 10.0), grid_extensions=0, scoring="neg_log_loss").fit(X, A)
    # minus a log-loss among all 3 rows: 0 at best, chance (-log 3) at worst
    assert np.all((smooth.cv_scores_ >= -np.log(3) - 1e-12) & (smooth.cv_scores_ <= 0))


@pytest.mark.parametrize(
    "params", [{"lams": []}, {"lams": [1.0, 0.0]}, {"lams": [np.nan]}, {"lams": "x"}, {"n_splits": 1}]
)
def test_cv_bad_parameters_raise_invalid_parameter_error(params):
    X = np.random.default_rng(0).normal(size=(16, 3))
    A = np.eye(4)[np.arange(16) % 4]
    with pytest.raises(InvalidParameterError):
        SAECV(**params).fit(X, A)
