"""The attribute-embedding model with the fabric paper's C + lambda R loss."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import check_grad
from scipy.special import expit
from sklearn.base import clone
from sklearn.utils._param_validation import InvalidParameterError
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError, TzslError
from tzsl.models import EmbeddingZSL, NearestAttributeRule, ZeroShotClassifier, ZSLInputError
from tzsl.models.embedding._embedding import _glorot_init, _layer_shapes, _loss_and_grad, loss_weights
from tzsl.models.protocol import attribute_rows


def zsl(model, X, y, S):
    """``model`` inside a ZeroShotClassifier (nearest attribute row), fitted on labelled trials."""
    clf = ZeroShotClassifier(attribute_model=model, decision_rule=NearestAttributeRule())
    return clf.fit(X, attribute_rows(y, S), y)


def zsl_problem(n_classes=12, n_attributes=10, n_features=30, per_class=20, noise=0.5, seed=0):
    """Binary class attributes encoded linearly in the features, plus Gaussian noise."""
    rng = np.random.default_rng(seed)
    while True:
        A = rng.integers(0, 2, (n_classes, n_attributes)).astype(float)
        if len(np.unique(A, axis=0)) == n_classes:
            break
    y = np.repeat(np.arange(n_classes), per_class)
    X = A[y] @ rng.normal(size=(n_attributes, n_features))
    return X + noise * rng.normal(size=X.shape), y, A


def _loss_problem(hidden_units, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(15, 6))
    y = rng.integers(0, 4, 15)
    L = rng.integers(0, 2, (4, 3)).astype(float)
    shapes = _layer_shapes(6, 3, hidden_units)
    theta = _glorot_init(shapes, np.random.RandomState(seed))
    theta += 0.3 * rng.normal(size=theta.size)  # non-zero biases too
    return theta, shapes, X, y, L


# ------------------------------------------------------------------------------------ the loss


def test_lambda_mapping_of_the_paper():
    assert loss_weights(0) == (1.0, 0.0)  # classification term only
    assert loss_weights(0.1) == (1.0, 0.1)
    assert loss_weights(10) == (1.0, 10.0)
    assert loss_weights("inf") == (0.0, 1.0)  # regression term only (limit of L / lambda)
    assert loss_weights(np.inf) == (0.0, 1.0)
    for bad in (-0.1, np.nan, "large", None, True):
        with pytest.raises(ConfigError):
            loss_weights(bad)


@pytest.mark.parametrize("hidden_units", [None, 5])
@pytest.mark.parametrize("lam", [0, 0.1, 10, "inf"])
def test_loss_value_matches_the_paper_formula(lam, hidden_units):
    theta, shapes, X, y, L = _loss_problem(hidden_units)
    alpha = 0.05
    params = []
    start = 0
    for shape in shapes:
        size = int(np.prod(shape))
        params.append(theta[start : start + size].reshape(shape))
        start += size
    if hidden_units is None:
        F = expit(X @ params[0].T + params[1])
    else:
        F = expit(np.tanh(X @ params[0].T + params[1]) @ params[2].T + params[3])
    C = R = 0.0
    for i in range(len(X)):  # sample by sample, as the paper writes it
        o = np.array([-np.sum((F[i] - L[c]) ** 2) for c in range(len(L))])
        C += -np.log(np.exp(o[y[i]]) / np.exp(o).sum())
        R += np.sum((F[i] - L[y[i]]) ** 2)
    data_term = R if lam == "inf" else C + lam * R
    decay = 0.5 * alpha * sum(np.sum(W**2) for W in params[0::2])
    w_c, w_r = loss_weights(lam)
    loss, _ = _loss_and_grad(theta, shapes, X, y, L, w_c, w_r, alpha)
    assert loss == pytest.approx(data_term / len(X) + decay, rel=1e-10)


@pytest.mark.parametrize("hidden_units", [None, 5])
@pytest.mark.parametrize("lam", [0, 0.1, 10, "inf"])
def test_gradient_matches_finite_differences(lam, hidden_units):
    theta, shapes, X, y, L = _loss_problem(hidden_units, seed=1)
    w_c, w_r = loss_weights(lam)
    args = (shapes, X, y, L, w_c, w_r, 0.01)
    grad = _loss_and_grad(theta, *args)[1]
    error = check_grad(
        lambda t: _loss_and_grad(t, *args)[0], lambda t: _loss_and_grad(t, *args)[1], theta
    )
    assert error / np.linalg.norm(grad) < 1e-5


# ---------------------------------------------------------------------------------- the model


def test_learns_a_synthetic_zero_shot_problem():
    X, y, A = zsl_problem()
    train = y < 8
    for lam in (1.0, "inf"):
        model = zsl(EmbeddingZSL(lam=lam, random_state=0), X[train], y[train], A[:8])
        accuracy = np.mean(model.predict(X[~train], A[8:]) == y[~train] - 8)
        assert accuracy > 0.5, lam  # chance is 0.25


def test_hidden_layer_model_learns_too():
    X, y, A = zsl_problem(seed=1)
    train = y < 8
    model = zsl(EmbeddingZSL(lam=0.1, hidden_units=16, random_state=0), X[train], y[train], A[:8])
    assert [W.shape for W in model.attribute_model_.coefs_] == [(16, 30), (16,), (10, 16), (10,)]
    assert np.mean(model.predict(X[~train], A[8:]) == y[~train] - 8) > 0.45


def test_seeded_fits_are_identical_and_seeds_matter():
    X, y, A = zsl_problem(n_classes=8, per_class=8, seed=2)
    a = EmbeddingZSL(random_state=3, max_iter=60).fit(X, A[y], y)
    b = EmbeddingZSL(random_state=3, max_iter=60).fit(X, A[y], y)
    c = EmbeddingZSL(random_state=4, max_iter=60).fit(X, A[y], y)
    for wa, wb in zip(a.coefs_, b.coefs_, strict=True):
        np.testing.assert_array_equal(wa, wb)
    np.testing.assert_array_equal(a.validation_classes_, b.validation_classes_)
    assert not np.allclose(a.coefs_[0], c.coefs_[0])


def test_early_stopping_holds_out_whole_training_classes():
    X, y, A = zsl_problem(n_classes=10, per_class=8, seed=3)
    model = EmbeddingZSL(validation_fraction=0.3, n_iter_no_change=5, random_state=0)
    model.fit(X, A[y], y)
    assert len(model.validation_classes_) == 3
    assert set(model.validation_classes_) <= set(range(10))
    losses = model.validation_losses_
    assert model.best_iteration_ == int(np.argmin(losses)) + 1
    assert len(losses) - model.best_iteration_ <= 5 or len(losses) == model.max_iter
    assert model.n_iter_ <= model.best_iteration_  # final refit on all classes


def test_without_early_stopping_runs_to_convergence_or_warns():
    X, y, A = zsl_problem(n_classes=4, per_class=6, seed=4)
    from sklearn.exceptions import ConvergenceWarning

    with pytest.warns(ConvergenceWarning, match="max_iter=2"):
        EmbeddingZSL(early_stopping=False, max_iter=2, random_state=0).fit(X, A[y], y)
    model = EmbeddingZSL(early_stopping=False, random_state=0).fit(X, A[y], y)
    assert model.validation_classes_ is None and model.n_iter_ < model.max_iter


def test_predict_is_the_nearest_attribute_vector():
    X, y, A = zsl_problem(n_classes=6, per_class=6, seed=5)
    model = zsl(EmbeddingZSL(lam=0.1, random_state=0), X[y < 4], y[y < 4], A[:4])
    F = model.attribute_model_.transform(X)
    assert F.shape == (len(X), A.shape[1]) and np.all((F > 0) & (F < 1))
    distances = ((F[:, None, :] - A[None, 4:, :]) ** 2).sum(axis=-1)
    np.testing.assert_array_equal(model.predict(X, A[4:]), np.argmin(distances, axis=1))
    proba = model.predict_proba(X, A[4:])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    np.testing.assert_array_equal(np.argmax(proba, axis=1), model.predict(X, A[4:]))


def test_shared_attribute_rows_are_one_class():
    X, y, A = zsl_problem(n_classes=6, per_class=6, seed=6)
    A[4] = A[1]
    model = EmbeddingZSL(random_state=0).fit(X, A[y], y)
    assert model.class_attributes_.shape == (5, A.shape[1])


# ----------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "params",
    [
        {"lam": -1},
        {"lam": "huge"},
        {"hidden_units": 0},
        {"max_iter": 0},
        {"alpha": -1e-3},
        {"validation_fraction": 1.5},
    ],
)
def test_bad_parameters_rejected(params):
    X, y, A = zsl_problem(n_classes=5, per_class=3)
    with pytest.raises(InvalidParameterError) as info:
        EmbeddingZSL(**params).fit(X, A[y])
    assert isinstance(info.value, ConfigError)


def test_bad_arrays_rejected():
    X, y, A = zsl_problem(n_classes=5, per_class=3)
    X_bad = X.copy()
    X_bad[0, 0] = np.nan
    with pytest.raises(ZSLInputError, match="NaN") as info:
        EmbeddingZSL().fit(X_bad, A[y])
    assert isinstance(info.value, TzslError)
    A_bad = A.copy()
    A_bad[1, 2] = np.inf
    with pytest.raises(ZSLInputError, match="infinity"):
        EmbeddingZSL().fit(X, A_bad[y])
    with pytest.raises(ZSLInputError, match="fewer than 2 to train on"):
        EmbeddingZSL(validation_fraction=0.5).fit(X[y < 2], A[y[y < 2]])


# ------------------------------------------------------------------------ scikit-learn contract


def test_params_round_trip_and_clone():
    model = EmbeddingZSL(lam="inf", hidden_units=8, alpha=0.1, random_state=7)
    params = model.get_params()
    assert clone(model).get_params() == params
    changed = clone(model).set_params(lam=0.1)
    assert changed.lam == 0.1 and model.lam == "inf"
    X, y, A = zsl_problem(n_classes=6, per_class=4)
    fitted = clone(model).set_params(max_iter=10).fit(X, A[y])
    check_is_fitted(fitted)
    assert fitted.lam == "inf"
# check_estimator: tests/models/test_estimator_checks.py runs it on every estimator of all_estimators().
