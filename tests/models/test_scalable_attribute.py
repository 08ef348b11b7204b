"""ScalableAttributeClassifier (Nystroem + warm-started logistic path) and the bank's solver choice."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from sklearn.base import clone

from tzsl.models import AttributeClassifierBank, AttributeSVM, ScalableAttributeClassifier

sys.path.insert(0, str(Path(__file__).parent))
from test_attribute_svm import make_problem

SMALL = dict(n_gamma=2, n_C=2, n_components=32)

def balanced_accuracy(p: np.ndarray, y: np.ndarray) -> float:
    y = y.astype(bool)
    return 0.5 * ((p[y] >= 0.5).mean() + (p[~y] < 0.5).mean())


def test_learns_with_calibrated_posteriors_and_grouped_cv():
    X, A, g = make_problem(n_objects=40, trials=10, seed=3)
    tr = g < 28
    m = ScalableAttributeClassifier(random_state=0).fit(X[tr, 0], A[tr, 2], g[tr])
    p = m.predict_proba(X[~tr, 0])
    np.testing.assert_allclose(p.sum(1), 1.0)
    assert balanced_accuracy(p[:, 1], A[~tr, 2]) > 0.8  # chance is 0.5
    assert m.cv_scores_.shape == (1, 4, 5) and m.platt_[0] >= 0
    assert m.oof_scores_.shape == (int(tr.sum()),)
    assert m.coef_.shape == (m.feature_map_.components_.shape[0],) and m.coef_.size <= 256


def test_no_test_object_influences_the_fit():
    X, A, g = make_problem(n_objects=20, trials=5, seed=1)
    tr = g < 15
    X2 = X.copy()
    X2[~tr] = 100.0
    a = ScalableAttributeClassifier(**SMALL, random_state=0).fit(X[tr, 0], A[tr, 0], g[tr])
    b = ScalableAttributeClassifier(**SMALL, random_state=0).fit(X2[tr, 0], A[tr, 0], g[tr])
    np.testing.assert_array_equal(a.oof_scores_, b.oof_scores_)
    assert (a.C_, a.gamma_, a.platt_) == (b.C_, b.gamma_, b.platt_)


def test_block_size_does_not_change_the_model():
    X, A, g = make_problem(n_objects=20, trials=5, seed=2)
    a = ScalableAttributeClassifier(**SMALL, block_size=7, random_state=0).fit(X[:, 0], A[:, 1], g)
    b = ScalableAttributeClassifier(**SMALL, block_size=10_000, random_state=0).fit(X[:, 0], A[:, 1], g)
    np.testing.assert_allclose(a.predict_proba(X[:, 0]), b.predict_proba(X[:, 0]), rtol=0, atol=1e-10)


def test_bad_parameters_raise_sklearn_errors():
    from sklearn.utils._param_validation import InvalidParameterError

    X, A, g = make_problem()
    with pytest.raises(InvalidParameterError, match="undersampling"):
        ScalableAttributeClassifier(undersampling="bagging").fit(X[:, 0], A[:, 0], g)


@pytest.mark.parametrize(("solver", "limit", "expected"), [
    ("auto", 10_000, "exact"), ("auto", 10, "approximate"), ("exact", 10, "exact"),
    ("approximate", 10_000, "approximate"),
])
def test_bank_solver_choice_is_recorded(solver, limit, expected, capsys):
    X, A, g = make_problem(n_attributes=1, n_sensors=1)
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=2, n_gamma=2, n_draws=1, cv=3), memory=None,
                                   random_state=0, solver=solver, max_exact_trials=limit, progress=True)
    bank.fit(X, A, g)
    choice = bank.solver_choice_
    assert choice["solver"] == expected and choice["n_trials"] == X.shape[0]
    assert solver in choice["reason"]
    model_type = AttributeSVM if expected == "exact" else ScalableAttributeClassifier
    assert isinstance(bank.estimators_[0][0], model_type)
    captured = capsys.readouterr()
    assert f"attribute models: {expected}" in captured.out + captured.err
    assert bank.predict_proba(X).shape == (X.shape[0], 1, 1)


def test_search_on_a_subset_then_refit_on_all_trials():
    X, A, g = make_problem(n_objects=40, trials=10, seed=3)
    tr = g < 28
    full = ScalableAttributeClassifier(**SMALL, random_state=0).fit(X[tr, 0], A[tr, 2], g[tr])
    same = ScalableAttributeClassifier(**SMALL, max_tune_trials=int(tr.sum()), random_state=0).fit(
        X[tr, 0], A[tr, 2], g[tr])
    np.testing.assert_array_equal(full.coef_, same.coef_)  # no subset below the cap: unchanged
    m = ScalableAttributeClassifier(**SMALL, max_tune_trials=100, random_state=0).fit(X[tr, 0], A[tr, 2], g[tr])
    tune = m.tune_index_
    assert 80 <= tune.size <= 100 and m.oof_scores_.shape == tune.shape  # floor(share) per object
    assert set(g[tr][tune]) == set(g[tr])  # every object keeps trials in the search
    assert m.coef_.shape == (m.feature_map_.components_.shape[0],)  # the search's feature map, refitted
    assert balanced_accuracy(m.predict_proba(X[~tr, 0])[:, 1], A[~tr, 2]) > 0.8  # chance is 0.5


@pytest.mark.parametrize("solver", ["exact", "approximate"])
def test_bank_codes_object_names_without_changing_a_fit(solver):
    X, A, g = make_problem(n_attributes=1, n_sensors=1)
    names = np.array([f"object-{v:03d}" for v in g], dtype=object)  # sorted like the integers
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=2, n_gamma=2, n_draws=2, cv=3), memory=None,
                                   random_state=0, solver=solver).fit(X, A, names)
    fitted = bank.estimators_[0][0]
    direct = clone(fitted).fit(X[:, 0], A[:, 0], names)  # same seed, the names themselves
    np.testing.assert_array_equal(fitted.predict_proba(X[:, 0]), direct.predict_proba(X[:, 0]))


def test_refit_uses_at_most_about_max_fit_trials_and_nothing_changes_below_it():
    X, A, g = make_problem(n_objects=40, trials=10, seed=3)
    tr = g < 28
    args = (X[tr, 0], A[tr, 2], g[tr])
    common = dict(**SMALL, max_tune_trials=100, random_state=0)
    uncapped = ScalableAttributeClassifier(**common, max_fit_trials=None).fit(*args)
    above = ScalableAttributeClassifier(**common, max_fit_trials=10_000).fit(*args)
    np.testing.assert_array_equal(uncapped.coef_, above.coef_)  # the draw is below the cap: unchanged
    assert uncapped.n_fit_trials_ > 40
    capped = ScalableAttributeClassifier(**common, max_fit_trials=40).fit(*args)
    assert 25 <= capped.n_fit_trials_ <= 40  # floor(share) per object, at least one each
    np.testing.assert_array_equal(capped.oof_scores_, uncapped.oof_scores_)  # the same search
    assert not np.array_equal(capped.coef_, uncapped.coef_)
    assert balanced_accuracy(capped.predict_proba(X[~tr, 0])[:, 1], A[~tr, 2]) > 0.8  # chance is 0.5


def test_scores_fold_the_feature_map_into_the_weights():
    X, A, g = make_problem(n_objects=20, trials=5, seed=2)
    m = ScalableAttributeClassifier(**SMALL, block_size=7, random_state=0).fit(X[:, 0], A[:, 1], g)
    Z = m.preprocessor_.transform(X[:, 0])
    explicit = m.feature_map_.transform(Z) @ m.coef_ + m.intercept_  # (n, n_components) features first
    np.testing.assert_allclose(m.svm_score(X[:, 0]), explicit, rtol=0, atol=1e-10)


def test_a_reused_preprocessor_gives_the_same_model_as_a_fresh_one():
    from tzsl.models.detectors import _scalable_attribute

    X, A, g = make_problem(n_objects=20, trials=5, seed=4)
    _scalable_attribute._PREPROCESSOR_MEMO.clear()
    ScalableAttributeClassifier(**SMALL, random_state=0).fit(X[:, 0], A[:, 0], g)  # fits the preprocessor
    assert len(_scalable_attribute._PREPROCESSOR_MEMO) == 1
    reused = ScalableAttributeClassifier(**SMALL, random_state=0).fit(X[:, 0], A[:, 1], g)
    assert len(_scalable_attribute._PREPROCESSOR_MEMO) == 1  # same features: no second fit
    _scalable_attribute._PREPROCESSOR_MEMO.clear()
    fresh = ScalableAttributeClassifier(**SMALL, random_state=0).fit(X[:, 0], A[:, 1], g)
    np.testing.assert_array_equal(reused.predict_proba(X[:, 0]), fresh.predict_proba(X[:, 0]))
    ScalableAttributeClassifier(**SMALL, random_state=0).fit(X[:, 1], A[:, 1], g)  # other features: a new fit
    assert len(_scalable_attribute._PREPROCESSOR_MEMO) == 2


@pytest.mark.parametrize("solver", ["exact", "approximate"])
def test_bank_predicts_large_inputs_in_parallel_with_the_same_bits(solver, monkeypatch):
    from tzsl.models.detectors import _attribute_bank

    X, A, g = make_problem(n_attributes=2, n_sensors=2)
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=2, n_gamma=2, n_draws=1, cv=3), memory=None,
                                   random_state=0, solver=solver, n_jobs=2).fit(X, A, g)
    one_by_one = bank.predict_proba(X)  # below PARALLEL_PREDICT_TRIALS: in this process
    monkeypatch.setattr(_attribute_bank, "PARALLEL_PREDICT_TRIALS", 10)
    parallel = bank.predict_proba(X)  # on two worker processes
    np.testing.assert_array_equal(parallel, one_by_one)


@pytest.mark.slow
def test_a_fit_inside_a_dask_task_equals_the_local_fit():
    """In a Dask task joblib's context reaches scikit-learn's n_jobs=None (Nystroem's kernel would be
    computed in chunks, which rounds differently): the fit must not follow it."""
    distributed = pytest.importorskip("distributed")
    import joblib
    from joblib import Parallel, delayed

    from tzsl._fit_store import fit_clone

    X, A, g = make_problem(n_objects=30, trials=20, n_features=30, seed=5)
    model = ScalableAttributeClassifier(n_gamma=2, n_C=2, n_components=128, max_tune_trials=300, max_fit_trials=400,
                                        random_state=0)
    local = fit_clone(model, X[:, 0], A[:, 1], g)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster), joblib.parallel_backend("dask"):
        remote = Parallel(n_jobs=2)(delayed(fit_clone)(model, X[:, 0], A[:, 1], g) for _ in range(2))
    for fitted in remote:
        np.testing.assert_array_equal(fitted.oof_scores_, local.oof_scores_)
        np.testing.assert_array_equal(fitted.coef_, local.coef_)


def test_default_search_uses_at_most_max_tune_trials():
    """Above MAX_TUNE_TRIALS training trials the default search runs on a subset of about that many
    (every object keeping trials) and the chosen model is refitted on its whole draw."""
    from tzsl.models.attribute_training import MAX_TUNE_TRIALS

    assert ScalableAttributeClassifier().max_tune_trials == MAX_TUNE_TRIALS
    trials = MAX_TUNE_TRIALS // 40 + 10
    X, A, g = make_problem(n_objects=40, trials=trials, n_sensors=1, seed=4)
    m = ScalableAttributeClassifier(**SMALL, n_draws=1, random_state=0).fit(X[:, 0], A[:, 0], g)
    assert X.shape[0] > MAX_TUNE_TRIALS >= m.tune_index_.size > 0.9 * MAX_TUNE_TRIALS
    assert set(g[m.tune_index_]) == set(g)
    assert m.n_fit_trials_ % trials == 0  # refitted on whole objects of the draw, not the search's share of them


@pytest.mark.parametrize("positives", [40, 110, 150])
def test_precomputed_balanced_weights_fit_like_class_weight_balanced(positives):
    """The path passes ``balanced_class_weights`` as sample weights instead of ``class_weight="balanced"``:
    the same floats as scikit-learn's, so the same coefficients bit for bit, on unbalanced classes too."""
    from sklearn.linear_model import LogisticRegression

    from tzsl.models.detectors._scalable_attribute import balanced_class_weights

    rng = np.random.default_rng(positives)
    F = rng.normal(size=(190, 12))
    y = np.zeros(190, dtype=np.int8)
    y[rng.choice(190, positives, replace=False)] = 1
    F[y == 1, :3] += 0.7
    reference = LogisticRegression(class_weight="balanced", C=3.0, tol=1e-4).fit(F, y)
    fitted = LogisticRegression(class_weight=None, C=3.0, tol=1e-4).fit(F, y, sample_weight=balanced_class_weights(y))
    np.testing.assert_array_equal(fitted.coef_, reference.coef_)
    np.testing.assert_array_equal(fitted.intercept_, reference.intercept_)
    counts = np.bincount(y)
    assert balanced_class_weights(y)[y == 1][0] == 190 / (2 * counts[1])
