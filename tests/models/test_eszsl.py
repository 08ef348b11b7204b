"""ESZSL and its class-grouped cross-validation."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.model_selection import GroupKFold, KFold
from sklearn.utils._param_validation import InvalidParameterError
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError, DataFileError, TzslError
from tzsl.models import (
    ESZSL,
    ESZSLCV,
    CompatibilityRule,
    ZeroShotClassifier,
    ZSLInputError,
)
from tzsl.models.protocol import attribute_rows, training_classes


def zsl_problem(n_classes=12, n_attributes=10, n_features=30, per_class=20, noise=0.5, seed=0):
    """Binary class attributes encoded linearly in the features, plus Gaussian noise."""
    rng = np.random.default_rng(seed)
    while True:
        A = rng.integers(0, 2, (n_classes, n_attributes)).astype(float)
        if len(np.unique(A, axis=0)) == n_classes:
            break
    mixing = rng.normal(size=(n_attributes, n_features))
    y = np.repeat(np.arange(n_classes), per_class)
    X = A[y] @ mixing + noise * rng.normal(size=(y.size, n_features))
    return X, y, A


def by_hand(X, y, S, gamma, lam):
    """The ESZSL closed form, written out with an explicit {-1, 1} indicator matrix Y."""
    classes = np.unique(y)
    Y = np.where(y[:, None] == classes[None, :], 1.0, -1.0)
    left = np.linalg.solve(X.T @ X + gamma * np.eye(X.shape[1]), X.T @ Y @ S)
    return np.linalg.solve(S.T @ S + lam * np.eye(S.shape[1]), left.T).T


def zsl(model, X, y, S):
    """``model`` inside a ZeroShotClassifier, fitted on labelled trials and one row per class."""
    clf = ZeroShotClassifier(attribute_model=model, decision_rule=CompatibilityRule())
    return clf.fit(X, attribute_rows(y, S), y)


def test_two_sample_case_worked_by_hand():
    # X = I, Y = [[1, -1], [-1, 1]], S = [[1], [0]]: Y S = [[1], [-1]], S^T S = 1, so
    # V = (I + I)^-1 [[1], [-1]] (1 + 1)^-1 = [[0.25], [-0.25]].
    model = ESZSL(gamma=1.0, lam=1.0, standardize=False)
    model.fit(np.eye(2), np.array([[1.0], [0.0]]))
    np.testing.assert_allclose(model.coef_, [[0.25], [-0.25]], atol=1e-12)
    np.testing.assert_allclose(model.decision_function(np.eye(2)), [[0.25], [-0.25]], atol=1e-12)


@pytest.mark.parametrize("shape", [(40, 6), (7, 25)], ids=["n>d", "d>n"])
def test_matches_explicit_linear_algebra(shape):
    rng = np.random.default_rng(1)
    X = rng.normal(size=shape)
    y = np.arange(shape[0]) % 4
    S = rng.normal(size=(4, 3))
    clf = zsl(ESZSL(gamma=0.7, lam=2.5, standardize=False), X, y, S)
    V = by_hand(X, y, S, 0.7, 2.5)
    np.testing.assert_allclose(clf.attribute_model_.coef_, V, rtol=1e-9, atol=1e-12)
    S_new = rng.normal(size=(5, 3))
    X_new = rng.normal(size=(9, shape[1]))
    np.testing.assert_allclose(clf.decision_function(X_new, S_new), X_new @ V @ S_new.T, atol=1e-10)
    np.testing.assert_array_equal(clf.predict(X_new, S_new), np.argmax(X_new @ V @ S_new.T, axis=1))


def test_standardize_uses_training_statistics_only():
    rng = np.random.default_rng(2)
    X = 5.0 + 3.0 * rng.normal(size=(30, 4))
    y = np.arange(30) % 3
    S = rng.normal(size=(3, 2))
    model = zsl(ESZSL(gamma=0.3, lam=0.4), X, y, S).attribute_model_
    Z = (X - X.mean(axis=0)) / X.std(axis=0)
    np.testing.assert_allclose(model.coef_, by_hand(Z, y, S, 0.3, 0.4), rtol=1e-9)


def test_classes_follow_sorted_groups_when_groups_are_classes():
    rng = np.random.default_rng(3)
    labels = np.array(["wool", "silk", "denim"])
    y = labels[np.arange(30) % 3]
    S_sorted = rng.normal(size=(3, 4))  # rows: denim, silk, wool
    Y = attribute_rows(y, S_sorted)
    rows, idx = training_classes(Y, "test", groups=y)
    np.testing.assert_array_equal(rows, S_sorted)
    np.testing.assert_array_equal(rows[idx], Y)
    rows_lex, idx_lex = training_classes(Y, "test")  # no groups: np.unique order
    np.testing.assert_array_equal(rows_lex, np.unique(S_sorted, axis=0))
    np.testing.assert_array_equal(rows_lex[idx_lex], Y)
    # two groups sharing a row are one class: np.unique order
    y2 = np.where(y == "wool", "silk", y)
    Y2 = attribute_rows(y2, S_sorted[:2])
    rows2, _ = training_classes(np.vstack([Y2]), "test", groups=np.where(np.arange(30) < 15, y2, "x"))
    np.testing.assert_array_equal(rows2, np.unique(S_sorted[:2], axis=0))


def test_shared_attribute_rows_are_one_class():
    rng = np.random.default_rng(4)
    X = rng.normal(size=(40, 5))
    y = np.arange(40) % 4
    S = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.0, 1.0]])  # classes 1 and 3 identical
    merged = ESZSL(standardize=False).fit(X, S[y])
    y_merged = np.where(y == 3, 1, y)
    order = np.array([1, 0, 2])  # np.unique rows: (0, 1), (1, 0), (1, 1)
    np.testing.assert_allclose(merged.coef_, by_hand(X, order[y_merged], S[[1, 0, 2]], 1.0, 1.0), rtol=1e-9)


def test_learns_a_synthetic_zero_shot_problem():
    X, y, A = zsl_problem()
    train = y < 8
    clf = zsl(ESZSLCV(), X[train], y[train], A[:8])
    accuracy = np.mean(clf.predict(X[~train], A[8:]) == y[~train] - 8)
    assert accuracy > 0.6  # chance is 0.25


def test_same_numbers_as_the_labelled_closed_form():
    """The protocol fit (attribute rows + groups) gives the old fit(X, y, S)'s V bit for bit."""
    X, y, A = zsl_problem(n_classes=8, per_class=6, seed=11)
    names = np.array([f"obj{(5 * c) % 8}" for c in range(8)])
    S = A[np.argsort(names)]  # one row per class in sorted label order
    model = ESZSL(gamma=0.3, lam=2.0).fit(X, attribute_rows(names[y], S), names[y])
    Z = (X - X.mean(axis=0)) / X.std(axis=0)
    np.testing.assert_allclose(model.coef_, by_hand(Z, np.searchsorted(np.sort(names), names[y]), S, 0.3, 2.0),
                               rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------------------------------ CV


def test_cv_grid_scores_equal_brute_force_refits():
    X, y, A = zsl_problem(n_classes=8, per_class=10, seed=5)
    gammas, lams = (0.01, 1.0, 100.0), (0.1, 10.0)
    cv = GroupKFold(n_splits=3)
    model = ESZSLCV(gammas=gammas, lams=lams, cv=cv, scoring="balanced_accuracy", grid_extensions=0).fit(X, A[y], y)
    assert model.cv_scores_.shape == (3, 2, 3)
    for f, (tr, va) in enumerate(cv.split(X, y, groups=y)):
        val_classes = np.unique(y[va])
        y_local = np.searchsorted(val_classes, y[va])
        for i, g in enumerate(gammas):
            for j, lam in enumerate(lams):
                fold_model = zsl(ESZSL(gamma=g, lam=lam), X[tr], y[tr], A[np.unique(y[tr])])
                pred = fold_model.predict(X[va], A[val_classes])
                per_class = [np.mean(pred[y_local == c] == c) for c in range(val_classes.size)]
                assert model.cv_scores_[i, j, f] == pytest.approx(np.mean(per_class))
    best = np.unravel_index(np.argmax(model.mean_cv_scores_), (3, 2))  # ties: the first in grid order
    assert (model.best_gamma_, model.best_lam_) == (gammas[best[0]], lams[best[1]])
    refit = ESZSL(gamma=model.best_gamma_, lam=model.best_lam_).fit(X, A[y], y)
    np.testing.assert_allclose(model.coef_, refit.coef_)


class _RecordingGroupKFold(GroupKFold):
    """GroupKFold that remembers which groups and samples it was shown."""

    def split(self, X, y=None, groups=None):
        self.seen_n_samples = len(X)
        self.seen_groups = np.unique(groups)
        return super().split(X, y, groups)


def test_cv_only_holds_out_training_classes():
    X, y, A = zsl_problem(seed=6)
    train = y < 8
    splitter = _RecordingGroupKFold(n_splits=4)
    model = ESZSLCV(cv=splitter).fit(X[train], A[y[train]], y[train])
    assert splitter.seen_n_samples == train.sum()
    assert splitter.seen_groups.tolist() == list(range(8))
    held_out = np.concatenate(model.cv_val_classes_)
    assert sorted(held_out.tolist()) == list(range(8))  # every training class once, no others
    assert all(len(v) >= 2 for v in model.cv_val_classes_)
    # tuning depends on training classes only: test-class samples have no way in
    X_test_changed = X.copy()
    X_test_changed[~train] += 100.0
    again = ESZSLCV(cv=GroupKFold(n_splits=4)).fit(X_test_changed[train], A[y[train]], y[train])
    np.testing.assert_array_equal(again.cv_scores_, model.cv_scores_)


@pytest.mark.filterwarnings("ignore:The groups parameter is ignored by KFold")
def test_cv_rejects_folds_that_split_a_class():
    X, y, A = zsl_problem(n_classes=6, per_class=6, seed=7)
    with pytest.raises(ZSLInputError, match="whole classes"):
        ESZSLCV(cv=KFold(n_splits=3, shuffle=True, random_state=0)).fit(X, A[y], y)


def test_cv_needs_two_classes_per_side():
    X, y, A = zsl_problem(n_classes=3, per_class=6, seed=8)
    with pytest.raises(ZSLInputError, match="at least 4 training classes"):
        ESZSLCV().fit(X, A[y], y)
    X, y, A = zsl_problem(n_classes=6, per_class=6, seed=8)
    with pytest.raises(ZSLInputError, match="at least 2"):
        ESZSLCV(cv=6).fit(X, A[y], y)  # one class per validation fold


def test_cv_merge_keeps_identical_classes_in_one_fold():
    X, y, A = zsl_problem(n_classes=8, per_class=8, seed=9)
    A[5] = A[2]
    model = ESZSLCV(cv=3).fit(X, A[y], y)
    shared = np.flatnonzero((model.class_attributes_ == A[2]).all(axis=1))
    assert shared.size == 1  # classes 2 and 5 are one class, so always held out together
    assert sum(shared[0] in held for held in model.cv_val_classes_) == 1


# ----------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_features_rejected(value):
    X, y, A = zsl_problem(n_classes=4, per_class=3)
    X[2, 1] = value
    with pytest.raises(ZSLInputError, match="NaN|infinity") as info:
        ESZSL().fit(X, A[y])
    assert isinstance(info.value, TzslError) and isinstance(info.value, ValueError)


def test_bad_attribute_tables_rejected():
    X, y, A = zsl_problem(n_classes=4, per_class=3)
    bad = A.copy()
    bad[2, 3] = np.nan
    with pytest.raises(ZSLInputError, match="NaN"):
        ESZSL().fit(X, bad[y])
    with pytest.raises(ZSLInputError, match="3 rows but y has 4 classes"):
        attribute_rows(y, A[:3])
    clf = zsl(ESZSL(), X, y, A)
    with pytest.raises(DataFileError, match="9 attribute columns"):
        clf.predict(X, A[:, :9])
    with pytest.raises(ZSLInputError, match="features"):
        clf.predict(X[:, :5], A)
    with pytest.raises(ZSLInputError, match="one class"):
        ESZSL().fit(X, np.tile(A[:1], (len(X), 1)))


@pytest.mark.parametrize("params", [{"gamma": 0.0}, {"lam": -1.0}, {"gamma": "big"}])
def test_bad_regularisers_rejected(params):
    X, y, A = zsl_problem(n_classes=4, per_class=3)
    with pytest.raises(InvalidParameterError) as info:
        ESZSL(**params).fit(X, A[y])
    assert isinstance(info.value, ConfigError)  # the CLI prints it in one line


def test_bad_cv_settings_rejected():
    X, y, A = zsl_problem(n_classes=6, per_class=3)
    with pytest.raises(InvalidParameterError, match="gammas"):
        ESZSLCV(gammas=()).fit(X, A[y])
    with pytest.raises(InvalidParameterError, match="scoring"):
        ESZSLCV(scoring="f1").fit(X, A[y])
    with pytest.raises(InvalidParameterError, match="cv"):
        ESZSLCV(cv=1).fit(X, A[y])


def test_keyword_only_init():
    with pytest.raises(TypeError):
        ESZSL(1.0, 1.0)  # the parameters are keyword-only


# ------------------------------------------------------------------------ scikit-learn contract


@pytest.mark.parametrize("estimator", [ESZSL(gamma=0.5, lam=3.0), ESZSLCV(gammas=(1.0, 2.0), cv=3)])
def test_params_round_trip_and_clone(estimator):
    params = estimator.get_params()
    cloned = clone(estimator)
    assert cloned.get_params() == params
    cloned.set_params(standardize=False)
    assert cloned.standardize is False and estimator.standardize is True
    X, y, A = zsl_problem(n_classes=8, per_class=5)
    fitted = clone(estimator).fit(X, A[y])
    assert fitted.get_params() == params  # fit changes no parameter
    check_is_fitted(fitted)
# check_estimator: tests/models/test_estimator_checks.py runs it on every estimator of all_estimators().
