"""ESZSL and its class-grouped cross-validation."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, ClassifierMixin, clone
from sklearn.model_selection import GroupKFold, KFold
from sklearn.utils.estimator_checks import parametrize_with_checks
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError, TzslError
from tzsl.models import ESZSL, ESZSLCV
from tzsl.models._eszsl import ZSLInputError


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


def test_two_sample_case_worked_by_hand():
    # X = I, Y = [[1, -1], [-1, 1]], S = [[1], [0]]: Y S = [[1], [-1]], S^T S = 1, so
    # V = (I + I)^-1 [[1], [-1]] (1 + 1)^-1 = [[0.25], [-0.25]].
    model = ESZSL(gamma=1.0, lam=1.0, standardize=False)
    model.fit(np.eye(2), np.array([0, 1]), np.array([[1.0], [0.0]]))
    np.testing.assert_allclose(model.coef_, [[0.25], [-0.25]], atol=1e-12)


@pytest.mark.parametrize("shape", [(40, 6), (7, 25)], ids=["n>d", "d>n"])
def test_matches_explicit_linear_algebra(shape):
    rng = np.random.default_rng(1)
    X = rng.normal(size=shape)
    y = np.arange(shape[0]) % 4
    S = rng.normal(size=(4, 3))
    model = ESZSL(gamma=0.7, lam=2.5, standardize=False).fit(X, y, S)
    V = by_hand(X, y, S, 0.7, 2.5)
    np.testing.assert_allclose(model.coef_, V, rtol=1e-9, atol=1e-12)
    S_new = rng.normal(size=(5, 3))
    X_new = rng.normal(size=(9, shape[1]))
    np.testing.assert_allclose(model.decision_function(X_new, S_new), X_new @ V @ S_new.T, atol=1e-10)
    np.testing.assert_array_equal(model.predict(X_new, S_new), np.argmax(X_new @ V @ S_new.T, axis=1))


def test_standardize_uses_training_statistics_only():
    rng = np.random.default_rng(2)
    X = 5.0 + 3.0 * rng.normal(size=(30, 4))
    y = np.arange(30) % 3
    S = rng.normal(size=(3, 2))
    model = ESZSL(gamma=0.3, lam=0.4).fit(X, y, S)
    Z = (X - X.mean(axis=0)) / X.std(axis=0)
    np.testing.assert_allclose(model.coef_, by_hand(Z, y, S, 0.3, 0.4), rtol=1e-9)


def test_attribute_rows_follow_sorted_labels():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(30, 5))
    labels = np.array(["wool", "silk", "denim"])
    y = labels[np.arange(30) % 3]
    S_sorted = rng.normal(size=(3, 4))  # rows: denim, silk, wool
    model = ESZSL(standardize=False).fit(X, y, S_sorted)
    assert model.classes_.tolist() == ["denim", "silk", "wool"]
    y_int = np.searchsorted(model.classes_, y)
    np.testing.assert_allclose(model.coef_, by_hand(X, y_int, S_sorted, 1.0, 1.0), rtol=1e-9)


def test_duplicate_training_rows_error_names_classes_or_merge():
    rng = np.random.default_rng(4)
    X = rng.normal(size=(40, 5))
    y = np.arange(40) % 4
    S = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.0, 1.0]])  # classes 1 and 3 identical
    with pytest.raises(ZSLInputError, match=r"\{1, 3\}"):
        ESZSL().fit(X, y, S)
    merged = ESZSL(duplicate_attributes="merge", standardize=False).fit(X, y, S)
    y_merged = np.where(y == 3, 1, y)
    np.testing.assert_allclose(merged.coef_, by_hand(X, y_merged, S[:3], 1.0, 1.0), rtol=1e-9)


def test_learns_a_synthetic_zero_shot_problem():
    X, y, A = zsl_problem()
    train = y < 8
    model = ESZSLCV().fit(X[train], y[train], A[:8])
    accuracy = np.mean(model.predict(X[~train], A[8:]) == y[~train] - 8)
    assert accuracy > 0.6  # chance is 0.25


# ------------------------------------------------------------------------------------------ CV


def test_cv_grid_scores_equal_brute_force_refits():
    X, y, A = zsl_problem(n_classes=8, per_class=10, seed=5)
    gammas, lams = (0.01, 1.0, 100.0), (0.1, 10.0)
    cv = GroupKFold(n_splits=3)
    model = ESZSLCV(gammas=gammas, lams=lams, cv=cv, scoring="balanced_accuracy").fit(X, y, A)
    assert model.cv_scores_.shape == (3, 2, 3)
    for f, (tr, va) in enumerate(cv.split(X, y, groups=y)):
        val_classes = np.unique(y[va])
        y_local = np.searchsorted(val_classes, y[va])
        for i, g in enumerate(gammas):
            for j, lam in enumerate(lams):
                fold_model = ESZSL(gamma=g, lam=lam).fit(X[tr], y[tr], A[np.unique(y[tr])])
                pred = fold_model.predict(X[va], A[val_classes])
                per_class = [np.mean(pred[y_local == c] == c) for c in range(val_classes.size)]
                assert model.cv_scores_[i, j, f] == pytest.approx(np.mean(per_class))
    best = np.unravel_index(np.argmax(model.mean_cv_scores_), (3, 2))
    assert (model.best_gamma_, model.best_lam_) == (gammas[best[0]], lams[best[1]])
    refit = ESZSL(gamma=model.best_gamma_, lam=model.best_lam_).fit(X, y, A)
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
    model = ESZSLCV(cv=splitter).fit(X[train], y[train], A[:8])
    assert splitter.seen_n_samples == train.sum()
    assert splitter.seen_groups.tolist() == list(range(8))
    held_out = np.concatenate(model.cv_val_classes_)
    assert sorted(held_out.tolist()) == list(range(8))  # every training class once, no others
    assert all(len(v) >= 2 for v in model.cv_val_classes_)
    # tuning depends on training classes only: test-class samples have no way in
    X_test_changed = X.copy()
    X_test_changed[~train] += 100.0
    again = ESZSLCV(cv=GroupKFold(n_splits=4)).fit(X_test_changed[train], y[train], A[:8])
    np.testing.assert_array_equal(again.cv_scores_, model.cv_scores_)


@pytest.mark.filterwarnings("ignore:The groups parameter is ignored by KFold")
def test_cv_rejects_folds_that_split_a_class():
    X, y, A = zsl_problem(n_classes=6, per_class=6, seed=7)
    with pytest.raises(ZSLInputError, match="whole classes"):
        ESZSLCV(cv=KFold(n_splits=3, shuffle=True, random_state=0)).fit(X, y, A)


def test_cv_needs_two_classes_per_side():
    X, y, A = zsl_problem(n_classes=3, per_class=6, seed=8)
    with pytest.raises(ZSLInputError, match="at least 4 training classes"):
        ESZSLCV().fit(X, y, A)
    X, y, A = zsl_problem(n_classes=6, per_class=6, seed=8)
    with pytest.raises(ZSLInputError, match="at least 2"):
        ESZSLCV(cv=6).fit(X, y, A)  # one class per validation fold


def test_cv_merge_keeps_identical_classes_in_one_fold():
    X, y, A = zsl_problem(n_classes=8, per_class=8, seed=9)
    A[5] = A[2]
    model = ESZSLCV(cv=3, duplicate_attributes="merge").fit(X, y, A)
    for held in model.cv_val_classes_:
        assert (2 in held) == (5 in held)


# ----------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_features_rejected(value):
    X, y, A = zsl_problem(n_classes=4, per_class=3)
    X[2, 1] = value
    with pytest.raises(ZSLInputError, match="NaN|infinity") as info:
        ESZSL().fit(X, y, A)
    assert isinstance(info.value, TzslError) and isinstance(info.value, ValueError)


def test_bad_attribute_tables_rejected():
    X, y, A = zsl_problem(n_classes=4, per_class=3)
    bad = A.copy()
    bad[2, 3] = np.nan
    with pytest.raises(ZSLInputError, match="row 2 attribute 3"):
        ESZSL().fit(X, y, bad)
    with pytest.raises(ZSLInputError, match="3 rows but y has 4 classes"):
        ESZSL().fit(X, y, A[:3])
    model = ESZSL().fit(X, y, A)
    with pytest.raises(ZSLInputError, match="9 attributes .* fitted with 10"):
        model.predict(X, A[:, :9])
    with pytest.raises(ZSLInputError, match="identical attribute rows \\(rows 0, 2\\)"):
        model.predict(X, A[[0, 1, 0]])
    with pytest.raises(ZSLInputError, match="features"):
        model.predict(X[:, :5], A)
    with pytest.raises(ZSLInputError, match="one class"):
        ESZSL().fit(X, np.zeros(len(X)), A[:1])


@pytest.mark.parametrize("params", [{"gamma": 0.0}, {"lam": -1.0}, {"gamma": "big"}])
def test_bad_regularisers_rejected(params):
    X, y, A = zsl_problem(n_classes=4, per_class=3)
    with pytest.raises(ConfigError):
        ESZSL(**params).fit(X, y, A)


def test_bad_cv_settings_rejected():
    X, y, A = zsl_problem(n_classes=6, per_class=3)
    with pytest.raises(ConfigError, match="gammas"):
        ESZSLCV(gammas=()).fit(X, y, A)
    with pytest.raises(ConfigError, match="scoring"):
        ESZSLCV(scoring="f1").fit(X, y, A)
    with pytest.raises(ConfigError, match="duplicate_attributes"):
        ESZSLCV(duplicate_attributes="keep").fit(X, y, A)


# ------------------------------------------------------------------------ scikit-learn contract


@pytest.mark.parametrize("estimator", [ESZSL(gamma=0.5, lam=3.0), ESZSLCV(gammas=(1.0, 2.0), cv=3)])
def test_params_round_trip_and_clone(estimator):
    params = estimator.get_params()
    cloned = clone(estimator)
    assert cloned.get_params() == params
    cloned.set_params(standardize=False)
    assert cloned.standardize is False and estimator.standardize is True
    X, y, A = zsl_problem(n_classes=8, per_class=5)
    fitted = clone(estimator).fit(X, y, A)
    assert fitted.get_params() == params  # fit changes no parameter
    check_is_fitted(fitted)


class SupervisedAdapter(ClassifierMixin, BaseEstimator):
    """Test-only wrapper: a zero-shot estimator with one-hot attributes is a plain classifier.

    ``check_estimator`` cannot call ``fit(X, y, class_attributes)``; with the identity matrix as
    the attribute table the zero-shot model becomes an ordinary classifier, which lets the
    scikit-learn checks exercise the wrapped model's validation, determinism and invariances.
    """

    def __init__(self, estimator=None):
        self.estimator = estimator

    def fit(self, X, y):
        self.estimator_ = clone(self.estimator)
        n_classes = len(np.unique(np.asarray(y))) if y is not None else 1
        self.estimator_.fit(X, y, np.eye(n_classes))
        self.classes_ = self.estimator_.classes_
        self.n_features_in_ = self.estimator_.n_features_in_
        return self

    def decision_function(self, X):
        check_is_fitted(self)
        scores = self.estimator_.decision_function(X, np.eye(len(self.classes_)))
        return scores[:, 1] - scores[:, 0] if len(self.classes_) == 2 else scores

    def predict(self, X):
        check_is_fitted(self)
        return self.classes_[self.estimator_.predict(X, np.eye(len(self.classes_)))]


# ESZSLCV is not run through these checks: their datasets have 2-3 classes, and class-grouped
# CV needs at least 4 (2 held out, 2 trained on). It shares ESZSL's validation and prediction code
# (one base class); its own behaviour is covered by the CV tests above.
@parametrize_with_checks([SupervisedAdapter(ESZSL())])
def test_sklearn_checks_through_supervised_adapter(estimator, check):
    check(estimator)
