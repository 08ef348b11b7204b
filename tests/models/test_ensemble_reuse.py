"""One fit per configuration (issue 43 item 4): a score-ensemble member configured as a compared method (same
method, parameters, seed and training rows) is that method's fit, on all training trials and in every calibration
fold, read back from the fit store; a member configured otherwise is fitted on its own; either way the ensemble
predicts what it predicts with every member fitted separately. Fits are counted by a counting attribute model."""

from __future__ import annotations

import numpy as np
import pytest

from tests.models.test_score_ensemble import make_zsl, split
from tzsl.cache import CACHE_DIR_ENV
from tzsl.models import ESZSLCV, CompatibilityRule, ScoreEnsembleZSL, build_method, register_method, unregister_method

#: Name of the counting method registered by the fixture.
COUNTING = "test-counting-eszsl"


class CountingESZSL(ESZSLCV):
    """ESZSL with its number of fits in this process (the class attribute ``fits``)."""

    fits = 0

    def fit(self, X, A, groups=None):
        type(self).fits += 1
        return super().fit(X, A, groups)


@pytest.fixture
def counting(monkeypatch, tmp_path):
    """The counting method registered, an empty fit store, the count at 0."""
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "cache"))
    register_method(COUNTING, family="compatibility", paper="test only", attribute_model=CountingESZSL,
                    decision_rule=CompatibilityRule, description="test")
    CountingESZSL.fits = 0
    yield
    unregister_method(COUNTING)


@pytest.fixture(scope="module")
def data():
    """``split``'s arrays, the attribute rows as float64: as a study gives them to every method (the ensemble
    reads its input as float64, and the fit store keys a fit on its arrays' dtypes too)."""
    X, rows, objects = make_zsl(n_objects=14, seed=3)
    X_tr, A_tr, g_tr, X_te, K, y = split(X, rows, objects)
    return X_tr, A_tr.astype(np.float64), g_tr, X_te, K.astype(np.float64), y


def test_a_member_configured_as_a_compared_method_is_fitted_once(counting, data):
    X_tr, A_tr, g_tr, X_te, K, _ = data
    flat = X_tr.reshape(len(X_tr), -1)
    compared = build_method(COUNTING, random_state=5).fit(flat, A_tr, g_tr)  # calibrated: the fit + 3 folds
    fits = CountingESZSL.fits
    assert fits == 1 + compared.calibration_info_["n_folds"]
    same = ScoreEnsembleZSL(methods=(COUNTING,), random_state=5).fit(X_tr, A_tr, g_tr)
    assert CountingESZSL.fits == fits  # the member is the compared method's fit, read back
    other = ScoreEnsembleZSL(methods=({"name": COUNTING, "lams": (0.1, 1.0)},), random_state=5).fit(X_tr, A_tr, g_tr)
    assert CountingESZSL.fits == fits + 1  # another configuration: fitted on its own
    ScoreEnsembleZSL(methods=(COUNTING,), random_state=6).fit(X_tr, A_tr, g_tr)
    assert CountingESZSL.fits == fits + 2  # another seed: another fit
    flat_te = X_te.reshape(len(X_te), -1)
    np.testing.assert_array_equal(same.estimators_[0].decision_function(flat_te, K),
                                  compared.estimator_.decision_function(flat_te, K))
    assert other.estimators_[0].attribute_model_.lams == (0.1, 1.0)


def test_the_calibration_folds_of_a_pinned_ensemble_are_the_compared_method_s(counting, data):
    X_tr, A_tr, g_tr, *_ = data
    build_method(COUNTING, random_state=5).fit(X_tr.reshape(len(X_tr), -1), A_tr, g_tr)
    fits = CountingESZSL.fits
    ensemble = build_method("ensemble", methods=(COUNTING,), random_state=5).fit(X_tr, A_tr, g_tr)
    assert ensemble.calibration_info_["fitted"] and ensemble.estimator_.pin_members
    assert CountingESZSL.fits == fits  # the member and each fold's refit of it: the compared method's fits
    build_method("ensemble", methods=(COUNTING,), pin_members=False, random_state=5).fit(X_tr, A_tr, g_tr)
    assert CountingESZSL.fits == fits + ensemble.calibration_info_["n_folds"]  # searching folds: fits of their own


def test_reuse_changes_no_prediction(counting, data, monkeypatch):
    """The ensemble with its members read back predicts, scores and calibrates as with every fit made anew."""
    X_tr, A_tr, g_tr, X_te, K, y = data
    members = (COUNTING, "sae")
    for name in members:  # the compared methods first, as a study fits them
        build_method(name, random_state=2).fit(X_tr.reshape(len(X_tr), -1), A_tr, g_tr)
    reused = build_method("ensemble", methods=members, random_state=2).fit(X_tr, A_tr, g_tr)
    monkeypatch.setenv(CACHE_DIR_ENV, "")  # no fit store: every fit made here
    fits = CountingESZSL.fits
    fresh = build_method("ensemble", methods=members, random_state=2).fit(X_tr, A_tr, g_tr)
    assert CountingESZSL.fits > fits
    np.testing.assert_array_equal(reused.predict(X_te, K), fresh.predict(X_te, K))
    np.testing.assert_array_equal(reused.decision_function(X_te, K), fresh.decision_function(X_te, K))
    assert reused.temperature_ == fresh.temperature_
    assert (reused.predict(X_te, K) == y).mean() >= 0.75


def test_the_default_members_are_the_registered_methods_with_the_ensemble_s_seed():
    from tzsl.models.ensemble import DEFAULT_MEMBERS

    assert DEFAULT_MEMBERS == ("dap-avg", "eszsl", "sae") and ScoreEnsembleZSL().pin_members
    X, rows, objects = make_zsl(n_objects=12, seed=1)
    members = ScoreEnsembleZSL(methods=("eszsl", {"name": "sae", "random_state": 9}), random_state=4).fit(
        X, rows[objects], objects).estimators_
    assert [m.random_state for m in members] == [4, 9]  # the ensemble's seed; an entry's own wins
