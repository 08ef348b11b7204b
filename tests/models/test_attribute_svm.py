"""AttributeSVM and AttributeClassifierBank: estimator contract, grouped tuning, leakage, caching, parallel."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl._fit_store import spawn_seeds
from tzsl.exceptions import ConfigError, SplitError
from tzsl.models import AttributeClassifierBank, AttributeSVM, AttributeTrainingError, GridEdgeWarning
from tzsl.models.attribute_training import fit_platt

TINY = dict(n_C=2, n_gamma=2, n_draws=2, cv=3)


def make_problem(n_objects=14, trials=4, n_sensors=2, n_features=5, n_attributes=3, seed=0):
    """Objects with 0/1 attribute rows; trial features = attribute-driven mean + noise.

    Returns X (n, s, d), A (n, m), groups (n,).
    """
    rng = np.random.default_rng(seed)
    rows = np.zeros((n_objects, n_attributes), dtype=int)
    for j in range(n_attributes):  # 4 positive objects each, different ones per attribute
        rows[rng.choice(n_objects, 4, replace=False), j] = 1
    W = rng.normal(size=(n_sensors, n_attributes, n_features)) * 2.0
    obj_mean = np.einsum("om,smd->osd", rows.astype(float), W) + rng.normal(size=(n_objects, n_sensors, n_features))
    groups = np.repeat(np.arange(n_objects), trials)
    X = obj_mean[groups] + 0.3 * rng.normal(size=(groups.size, n_sensors, n_features))
    return X, rows[groups], groups


def test_learns_and_gives_posteriors():
    X, A, g = make_problem()
    tr = g < 10
    m = AttributeSVM(**TINY, random_state=0).fit(X[tr, 0], A[tr, 0], g[tr])
    p = m.predict_proba(X[~tr, 0])
    assert p.shape == (int((~tr).sum()), 2)
    np.testing.assert_allclose(p.sum(1), 1.0)
    assert 1.0 <= m.C_ <= 100.0 and 1e-4 <= m.gamma_ <= 1.0
    assert m.platt_[0] >= 0
    # the model separates training objects out of fold better than chance
    oof_pred = m.oof_scores_ > 0
    y = A[tr, 0].astype(bool)
    assert 0.5 * (oof_pred[y].mean() + (~oof_pred[~y]).mean()) > 0.7
    np.testing.assert_array_equal(m.predict(X[~tr, 0]), (p[:, 1] >= 0.5).astype(int))


def test_undersampling_drops_whole_objects_and_balances():
    X, A, g = make_problem(n_objects=20)
    y = A[:, 0]
    m = AttributeSVM(**TINY, random_state=3)
    draws, w = m._draws(y.astype(bool), g, np.random.RandomState(0))
    assert np.isclose(w.sum(), 1.0)
    for keep in draws:
        for obj in np.unique(g):  # whole objects only
            assert len(set(keep[g == obj])) == 1
        assert keep[y == 1].all()  # the minority class is kept whole
        assert keep[y == 0].sum() == (y == 1).sum()  # equal trial counts here
    assert any(not np.array_equal(draws[0], d) for d in draws[1:])


@pytest.mark.parametrize("mode", ["select", "bagging", "none"])
def test_undersampling_modes(mode):
    X, A, g = make_problem()
    m = AttributeSVM(**TINY, undersampling=mode, random_state=0).fit(X[:, 0], A[:, 1], g)
    n_est = len(m.estimators_)
    if mode == "bagging":
        assert n_est == len(m.estimator_weights_) == len(m.train_features_)
        assert m.cv_scores_.shape[0] == 1  # tuned once, on the draw-averaged scores
        assert m.draw_ == -1
        np.testing.assert_allclose(m.estimator_weights_.sum(), 1.0)
    elif mode == "select":
        assert n_est == 1 and m.draw_ >= 0
    else:
        assert n_est == 1 and m.train_features_[0].shape[0] == X.shape[0]


def test_too_few_positive_objects_is_a_clear_error():
    X, A, g = make_problem()
    y = (g == 0).astype(int)  # present in a single object
    with pytest.raises(AttributeTrainingError, match=r"'porous'.*only 1 training object") as info:
        AttributeSVM(**TINY, name="porous").fit(X[:, 0], y, g)
    assert isinstance(info.value, SplitError)


def test_bad_parameters():
    X, A, g = make_problem()
    with pytest.raises(ConfigError, match="undersampling"):
        AttributeSVM(undersampling="smote").fit(X[:, 0], A[:, 0], g)
    with pytest.raises(ConfigError, match="groups"):
        AttributeSVM(**TINY).fit(X[:, 0], A[:, 0], g[:-1])


def test_platt_is_monotone_and_recovers_a_sigmoid():
    rng = np.random.default_rng(0)
    s = rng.normal(size=4000) * 2
    y = rng.uniform(size=s.size) < 1 / (1 + np.exp(-(1.5 * s - 0.5)))
    a, b = fit_platt(s, y)
    assert a == pytest.approx(1.5, rel=0.1) and b == pytest.approx(-0.5, abs=0.15)
    a, _ = fit_platt(s, ~y)  # anti-correlated scores: slope clamped at 0
    assert a == 0.0


def test_test_objects_never_influence_fitted_parameters():
    """Same training trials, different test trials (features and labels): identical fits."""
    X, A, g = make_problem(seed=1)
    tr = g < 10
    X2, A2 = X.copy(), A.copy()
    rng = np.random.default_rng(5)
    X2[~tr] = rng.normal(size=X2[~tr].shape) * 10
    A2[~tr] = 1 - A2[~tr]
    fits = []
    for XX, AA in ((X, A), (X2, A2)):
        bank = AttributeClassifierBank(estimator=AttributeSVM(**TINY), n_jobs=1, memory=None, random_state=0)
        bank.fit(XX[tr], AA[tr], g[tr])
        fits.append(bank)
    for row_a, row_b in zip(fits[0].estimators_, fits[1].estimators_, strict=True):
        for a, b in zip(row_a, row_b, strict=True):
            assert (a.C_, a.gamma_, a.draw_, a.platt_) == (b.C_, b.gamma_, b.draw_, b.platt_)
            np.testing.assert_array_equal(a.oof_scores_, b.oof_scores_)
            np.testing.assert_array_equal(a.cv_scores_, b.cv_scores_)
    np.testing.assert_array_equal(fits[0].predict_proba(X[~tr]), fits[1].predict_proba(X[~tr]))


def test_selected_draw_depends_only_on_training_objects():
    """The kept draw is a function of training data and seed: test rows are never passed in."""
    X, A, g = make_problem(seed=2, n_objects=16)
    tr = g < 12
    m1 = AttributeSVM(**{**TINY, "n_draws": 4}, search="grid", random_state=7).fit(X[tr, 1], A[tr, 2], g[tr])
    m2 = AttributeSVM(**{**TINY, "n_draws": 4}, search="grid", random_state=7).fit(X[tr, 1], A[tr, 2], g[tr])
    assert m1.draw_ == m2.draw_
    best = np.unravel_index(np.argmin(m1.cv_scores_), m1.cv_scores_.shape)
    assert m1.cv_scores_[best] == m1.cv_scores_[m1.draw_].min()


def test_seeds_are_deterministic_and_distinct():
    assert spawn_seeds(3, 5) == spawn_seeds(3, 5)
    assert len(set(spawn_seeds(3, 50))) == 50
    assert spawn_seeds(3, 5) != spawn_seeds(4, 5)


def test_bank_shapes_and_errors():
    X, A, g = make_problem()
    bank = AttributeClassifierBank(estimator=AttributeSVM(**TINY), attribute_names=["hard", "soft", "cool"],
                                   random_state=0)
    bank.fit(X, A, g)
    P = bank.predict_proba(X[:5])
    assert P.shape == (5, 2, 3) and np.all((P >= 0) & (P <= 1))
    A_bad = A.copy()
    A_bad[:, 1] = (g == 3).astype(int)
    with pytest.raises(AttributeTrainingError, match="'soft'.*only 1"):
        bank.fit(X, A_bad, g)
    A_nan = A.astype(float)
    A_nan[4, 2] = np.nan
    with pytest.raises(AttributeTrainingError, match="'cool'.*row 4"):
        bank.fit(X, A_nan, g)
    with pytest.raises(ConfigError, match="sensors"):
        bank.predict_proba(X[:, :1])


def test_bank_n_jobs_1_equals_2():
    X, A, g = make_problem()
    P1 = AttributeClassifierBank(estimator=AttributeSVM(**TINY), n_jobs=1, memory=None,
                                 random_state=0).fit(X, A, g).predict_proba(X)
    P2 = AttributeClassifierBank(estimator=AttributeSVM(**TINY), n_jobs=2, memory=None,
                                 random_state=0).fit(X, A, g).predict_proba(X)
    np.testing.assert_array_equal(P1, P2)


class CountingSVM(AttributeSVM):
    """AttributeSVM that counts its fits (module-level so joblib can hash it)."""

    calls = 0

    def fit(self, X, y, groups=None):
        type(self).calls += 1
        return super().fit(X, y, groups)


def test_bank_cache_avoids_refits(tmp_path):
    X, A, g = make_problem()
    CountingSVM.calls = 0
    bank = AttributeClassifierBank(estimator=CountingSVM(**TINY), n_jobs=1, memory=tmp_path, random_state=0)
    P1 = bank.fit(X, A, g).predict_proba(X)
    assert CountingSVM.calls == 6  # 3 attributes x 2 sensors
    P2 = bank.fit(X, A, g).predict_proba(X)
    assert CountingSVM.calls == 6  # all loaded from the cache
    np.testing.assert_array_equal(P1, P2)
    bank.set_params(random_state=1).fit(X, A, g)  # a parameter change refits
    assert CountingSVM.calls == 12


def test_cache_dir_from_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "envcache"))
    X, A, g = make_problem(n_attributes=1, n_sensors=1)
    AttributeClassifierBank(estimator=AttributeSVM(**TINY), random_state=0).fit(X, A, g)
    assert any((tmp_path / "envcache" / "fits").rglob("*.pkl"))


def test_dask_backend_needs_a_client():
    X, A, g = make_problem(n_attributes=1, n_sensors=1)
    with pytest.raises(ConfigError, match="Client"):
        AttributeClassifierBank(estimator=AttributeSVM(**TINY), backend="dask", memory=None).fit(X, A, g)


def test_dask_equals_loky():
    distributed = pytest.importorskip("distributed")
    X, A, g = make_problem(n_attributes=2)
    ref = AttributeClassifierBank(estimator=AttributeSVM(**TINY), n_jobs=2, memory=None, random_state=0)
    P_loky = ref.fit(X, A, g).predict_proba(X)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster):
            bank = AttributeClassifierBank(estimator=AttributeSVM(**TINY), backend="dask", memory=None, random_state=0)
            P_dask = bank.fit(X, A, g).predict_proba(X)
    np.testing.assert_array_equal(P_loky, P_dask)


class ReferenceSVCGrid(AttributeSVM):
    """The grid search as it was before libsvm was called directly: one ``SVC`` per fit (the reference)."""

    def _grid_oof(self, D, yb, groups, draws, fold_seed, Cs, gammas, cw, oof) -> None:
        from sklearn.svm import SVC

        for di, keep in enumerate(draws):
            idx = np.flatnonzero(keep)
            folds = self._folds(yb[idx], groups[idx], fold_seed)
            for gi, gamma in enumerate(gammas):
                K = np.exp(-gamma * D[:, idx])
                Kd = K[idx]
                for ci, C in enumerate(Cs):
                    svc = SVC(kernel="precomputed", C=C, class_weight=cw).fit(Kd, yb[idx])
                    oof[di, gi, ci] = svc.decision_function(K)
                for fold in folds:
                    tr = ~fold
                    Ktr, Kte = Kd[np.ix_(tr, tr)], Kd[np.ix_(fold, tr)]
                    for ci, C in enumerate(Cs):
                        svc = SVC(kernel="precomputed", C=C, class_weight=cw).fit(Ktr, yb[idx[tr]])
                        oof[di, gi, ci, idx[fold]] = svc.decision_function(Kte)


@pytest.mark.parametrize("params", [
    dict(TINY, n_gamma=3, n_C=3), dict(TINY, cv=None), dict(TINY, undersampling="bagging"),
    dict(TINY, undersampling="none"), dict(TINY, scoring="balanced_accuracy", n_draws=3), dict(TINY, grid="adaptive"),
])
def test_fast_grid_equals_svc_reference_bitwise(params):
    """The shared-kernel libsvm grid gives exactly the numbers of one SVC per fit."""
    X, A, g = make_problem(n_objects=18, seed=4)
    tr = g < 14
    for j in range(A.shape[1]):
        fast = AttributeSVM(**params, search="grid", random_state=j).fit(X[tr, 0], A[tr, j], g[tr])
        ref = ReferenceSVCGrid(**params, search="grid", random_state=j).fit(X[tr, 0], A[tr, j], g[tr])
        np.testing.assert_array_equal(fast.oof_scores_, ref.oof_scores_)
        np.testing.assert_array_equal(fast.cv_scores_, ref.cv_scores_)
        assert (fast.C_, fast.gamma_, fast.draw_, fast.platt_) == (ref.C_, ref.gamma_, ref.draw_, ref.platt_)
        np.testing.assert_array_equal(fast.predict_proba(X[~tr, 0]), ref.predict_proba(X[~tr, 0]))


def test_grid_edge_choices_are_recorded_and_warned_once_per_batch():
    X, A, g = make_problem()
    # a one-point C grid never counts as an edge; gamma far too large must sit on the low edge
    est = AttributeSVM(n_C=1, gamma_range=(30.0, 300.0), n_gamma=2, grid="paper", n_draws=1, cv=3)
    with pytest.warns(GridEdgeWarning) as record:
        bank = AttributeClassifierBank(estimator=est, attribute_names=["a", "b", "c"], memory=None,
                                       random_state=0).fit(X, A, g)
    assert len([w for w in record if issubclass(w.category, GridEdgeWarning)]) == 1
    hits = bank.grid_edge_hits_
    assert {h["parameter"] for h in hits} == {"gamma"}
    assert all(h["edge"] == "low" and h["value"] == 30.0 for h in hits)
    assert len(hits) == 6  # every (attribute, sensor)
    for h in hits:
        edges = bank.estimators_[["a", "b", "c"].index(h["attribute"])][h["sensor"]].grid_edges_
        assert ("gamma", 30.0, "low") in edges


def test_gamma_grids():
    from tzsl.models.attribute_training import GRIDS, gamma_grid

    assert GRIDS == ("paper", "extended", "adaptive")
    np.testing.assert_allclose(gamma_grid((0.01, 1.0), 3, "paper"), [0.01, 0.1, 1.0])
    np.testing.assert_allclose(gamma_grid((0.01, 1.0), 3, "extended"), [1e-4, 1e-3, 0.01, 0.1, 1.0])
    X, A, g = make_problem()
    paper = AttributeSVM(**TINY, grid="paper", search="grid", random_state=0).fit(X[:, 0], A[:, 0], g)
    extended = AttributeSVM(**TINY, grid="extended", search="grid", random_state=0).fit(X[:, 0], A[:, 0], g)
    assert paper.cv_scores_.shape[1] == 2 and extended.cv_scores_.shape[1] == 4
    assert paper.gamma_ >= 0.01
    # the paper's points are scored identically on both grids (same draws, folds and seeds)
    np.testing.assert_array_equal(extended.cv_scores_[:, 2:], paper.cv_scores_)
    with pytest.raises(ValueError, match="grid"):
        AttributeSVM(grid="wide").fit(X[:, 0], A[:, 0], g)


def test_extended_grid_leaves_the_low_edge_when_a_wide_kernel_fits_best():
    """Attribute = sign of a linear function spread over many features: a near-linear kernel wins."""
    rng = np.random.default_rng(1)
    n_obj, trials, d = 24, 5, 20
    w = rng.normal(size=d)
    centres = rng.normal(size=(n_obj, d)) * 3.0
    y_obj = (centres @ w > np.median(centres @ w)).astype(int)
    groups = np.repeat(np.arange(n_obj), trials)
    X = centres[groups] + rng.normal(size=(groups.size, d))
    params = dict(n_C=2, n_draws=1, cv=4, preprocessor=None, random_state=0)
    paper = AttributeSVM(grid="paper", search="grid", **params).fit(X, y_obj[groups], groups)
    extended = AttributeSVM(grid="extended", search="grid", **params).fit(X, y_obj[groups], groups)
    assert ("gamma", 0.01, "low") in paper.grid_edges_
    assert extended.gamma_ < 0.01
    assert extended.cv_scores_.min() <= paper.cv_scores_.min()


def test_undersampling_keeps_two_majority_objects_for_grouped_cv():
    """Few objects of many trials each (a fabric group's depth images): one majority object could already
    match the minority's trial count, which would leave object-grouped CV one fold; every draw keeps two."""
    from tzsl.models.attribute_training import balanced_object_draws

    groups = np.repeat(np.arange(5), [400, 400, 400, 100, 100])  # objects 0-2 negative, 3-4 positive
    yb = groups >= 3
    draws, _ = balanced_object_draws(yb, groups, 10, np.random.RandomState(0))
    for keep in draws:
        assert np.unique(groups[keep & ~yb]).size == 2 and np.unique(groups[keep & yb]).size == 2
    rng = np.random.default_rng(0)
    X = rng.normal(size=(groups.size, 3)) + yb[:, None]
    svm = AttributeSVM(n_C=1, n_gamma=1, n_draws=2, cv=5, random_state=0).fit(X, yb.astype(int), groups)
    assert svm.predict_proba(X[:5]).shape == (5, 2)


def test_balanced_draws_merge_equal_draws_in_row_order():
    from tzsl.models.attribute_training import balanced_object_draws

    rng = np.random.default_rng(7)
    for _ in range(30):
        groups = rng.integers(0, 12, size=60)
        yb = np.isin(groups, rng.choice(12, 4, replace=False))
        seed = int(rng.integers(1000))
        draws, weights = balanced_object_draws(yb, groups, 6, np.random.RandomState(seed))
        rows = np.array(draws)
        assert np.isclose(weights.sum(), 1.0) and len(draws) == weights.size
        assert np.unique(rows, axis=0).shape[0] == rows.shape[0]  # distinct
        np.testing.assert_array_equal(np.unique(rows, axis=0), rows)  # in np.unique's (lexicographic) order
        again, _ = balanced_object_draws(yb, groups, 6, np.random.RandomState(seed))
        np.testing.assert_array_equal(np.array(again), rows)
