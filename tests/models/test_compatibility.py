"""ALE, SJE and DeViSE: bilinear compatibility x^T W phi(y) trained by ranking losses."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.utils._param_validation import InvalidParameterError

from tzsl.models import CompatibilityRule, ZeroShotClassifier, build_method
from tzsl.models.embedding._compatibility import (
    ALE,
    SJE,
    DeViSE,
    ranking_loss_and_gradient,
    ranking_loss_weights,
)

MODELS = [ALE, SJE, DeViSE]
LOSS_OF = {ALE: "ale", SJE: "sje", DeViSE: "devise"}

def test_loss_weights_worked_by_hand():
    # sample 0: hinge terms 0.5 and 2.0 on classes 1 and 2 (class 0 true), class 3 not violating
    # sample 1: nothing violates
    hinge = np.array([[0.0, 0.5, 2.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    devise = ranking_loss_weights(hinge, "devise")
    np.testing.assert_array_equal(devise, [[0, 1, 1, 0], [0, 0, 0, 0]])
    np.testing.assert_array_equal(ranking_loss_weights(hinge, "sje"), [[0, 0, 1, 0], [0, 0, 0, 0]])
    # ALE: r = 2 violators, beta_2 = 1 + 1/2, weight beta_r / r = 0.75 on each
    ale = ranking_loss_weights(hinge, "ale")
    np.testing.assert_allclose(ale, [[0, 0.75, 0.75, 0], [0, 0, 0, 0]])
    with pytest.raises(ValueError, match="unknown ranking loss"):
        ranking_loss_weights(hinge, "warp")


def test_ale_weights_rank_one_violator_as_fully_as_sje():
    # r = 1: beta_1 / 1 = 1, the same as SJE's and DeViSE's single term
    hinge = np.array([[0.0, 0.0, 0.3]])
    for loss in ("ale", "sje", "devise"):
        np.testing.assert_allclose(ranking_loss_weights(hinge, loss), [[0, 0, 1]])


@pytest.mark.parametrize("loss", ["ale", "sje", "devise"])
def test_gradient_matches_finite_differences(loss):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(9, 5))
    Phi = rng.integers(0, 2, (4, 3)).astype(float) + 0.1 * rng.normal(size=(4, 3))
    y = np.arange(9) % 4
    W = 0.3 * rng.normal(size=(5, 3))
    value, grad = ranking_loss_and_gradient(W, X, y, Phi, loss)
    assert value > 0
    numeric = np.zeros_like(W)
    h = 1e-6
    for idx in np.ndindex(W.shape):  # loss is piecewise linear: central differences are exact
        Wp, Wm = W.copy(), W.copy()
        Wp[idx] += h
        Wm[idx] -= h
        up = ranking_loss_and_gradient(Wp, X, y, Phi, loss)[0]
        down = ranking_loss_and_gradient(Wm, X, y, Phi, loss)[0]
        numeric[idx] = (up - down) / (2 * h)
    np.testing.assert_allclose(grad, numeric, atol=1e-6)


@pytest.mark.parametrize("model_class", MODELS, ids=lambda c: c.__name__)
def test_recognises_unseen_classes(model_class, zero_shot_problem):
    accuracies = []
    for seed in range(3):
        p = zero_shot_problem(seed=seed)
        method = ZeroShotClassifier(attribute_model=model_class(random_state=seed), decision_rule=CompatibilityRule())
        pred = method.fit(p.X_train, p.A_train).predict(p.X_test, p.S_test)
        accuracies.append(np.mean(pred == p.y_test))
    assert np.mean(accuracies) >= 0.8, accuracies  # chance 0.125


@pytest.mark.parametrize("model_class", MODELS, ids=lambda c: c.__name__)
def test_ranking_loss_decreases(model_class, zero_shot_problem):
    p = zero_shot_problem(seed=1)
    model = model_class(random_state=0, n_epochs=20).fit(p.X_train, p.A_train)
    curve = model.loss_curve_
    assert curve.shape == (20,)
    assert curve[-1] < 0.25 * curve[0], curve
    assert curve[-5:].mean() < curve[:5].mean()
    # the final W ranks the training classes better than the initial one
    Xs = model.scaler_.transform(p.X_train)
    rows, cls = np.unique(p.A_train, axis=0, return_inverse=True)
    loss = LOSS_OF[model_class]
    final, _ = ranking_loss_and_gradient(model.coef_.T, Xs, cls.ravel(), rows, loss)
    initial, _ = ranking_loss_and_gradient(np.zeros_like(model.coef_.T), Xs, cls.ravel(), rows, loss)
    assert final < 0.25 * initial


@pytest.mark.parametrize("model_class", MODELS, ids=lambda c: c.__name__)
def test_same_random_state_same_model(model_class, zero_shot_problem):
    p = zero_shot_problem(seed=2)
    a = model_class(random_state=7, n_epochs=5).fit(p.X_train, p.A_train)
    b = model_class(random_state=7, n_epochs=5).fit(p.X_train, p.A_train)
    c = model_class(random_state=8, n_epochs=5).fit(p.X_train, p.A_train)
    np.testing.assert_array_equal(a.coef_, b.coef_)
    assert not np.allclose(a.coef_, c.coef_)


def test_the_three_losses_learn_different_models(zero_shot_problem):
    p = zero_shot_problem(seed=0)
    coefs = [m(random_state=0, n_epochs=5).fit(p.X_train, p.A_train).coef_ for m in MODELS]
    assert not np.allclose(coefs[0], coefs[1]) and not np.allclose(coefs[1], coefs[2])


@pytest.mark.parametrize("model_class", MODELS, ids=lambda c: c.__name__)
def test_scores_are_dot_products_with_class_rows(model_class, zero_shot_problem):
    p = zero_shot_problem(seed=0)
    model = model_class(random_state=0, n_epochs=3).fit(p.X_train, p.A_train)
    E = model.predict(p.X_test)
    np.testing.assert_allclose(E, model.scaler_.transform(p.X_test) @ model.coef_.T)
    np.testing.assert_allclose(model.decision_function(p.X_test), E)
    method = build_method(model_class.__name__.lower(), random_state=0, n_epochs=3).fit(p.X_train, p.A_train)
    np.testing.assert_allclose(method.decision_function(p.X_test, p.S_test), E @ p.S_test.T)
    assert model.score_kind == "embedding"
    assert model.coef_.shape == (p.S.shape[1], p.X.shape[1])


@pytest.mark.parametrize("model_class", MODELS, ids=lambda c: c.__name__)
@pytest.mark.parametrize(
    "params",
    [
        {"learning_rate": 0.0},
        {"n_epochs": 0},
        {"n_epochs": 2.5},
        {"batch_size": 0},
        {"alpha": -1.0},
        {"standardize": "no"},
        {"random_state": "seed"},
    ],
)
def test_bad_parameters_raise_invalid_parameter_error(model_class, params):
    X = np.random.default_rng(0).normal(size=(10, 3))
    A = np.eye(2)[np.arange(10) % 2]
    with pytest.raises(InvalidParameterError):
        model_class(**params).fit(X, A)
