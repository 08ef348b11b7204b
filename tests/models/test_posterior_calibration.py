"""Posterior calibration where the truth is known (simulated data).

The generator draws classes with random 0/1 attribute rows; a trial of class z has one feature
per attribute, ``x_m ~ N(mu (2 a_m^z - 1), 1)``. Given the class, features are independent, so
DAP with the uniform prior over the *true* attribute posteriors ``p(a_m = 1 | x_m) =
sigmoid(2 mu x_m)`` is the Bayes posterior over the candidate classes: calibrated by
construction. The same model with the attribute log-odds multiplied by ``power`` gives the
Bayes posterior raised to ``power`` (over-confident for power > 1).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.special import expit
from sklearn.base import BaseEstimator, clone

from tzsl.evaluation import calibration_terms, expected_calibration_error
from tzsl.models import (
    ESZSL,
    AttributeClassifierBank,
    AttributeSVM,
    CalibratedZeroShotClassifier,
    CalibrationWarning,
    CompatibilityRule,
    DAPRule,
    ZeroShotClassifier,
    build_method,
    get_method,
)
from tzsl.models.calibration import (
    MAX_CALIBRATION_TRIALS,
    calibration_subsample,
    fit_temperature,
    pseudo_unseen_scores,
    tempered_proba,
)

MU = 0.8


class TrueAttributePosteriors(BaseEstimator):
    """The generator's exact attribute posteriors, log-odds times ``power`` (nothing to learn)."""

    score_kind = "probability"

    def __init__(self, *, power=1.0):
        self.power = power

    def fit(self, X, Y, groups=None):
        self.n_features_in_ = np.asarray(X).shape[1]
        self.n_trials_ = len(X)
        return self

    def predict_proba(self, X):
        return expit(self.power * 2.0 * MU * np.asarray(X, dtype=float))


def simulate(rng, n_classes, trials, n_attributes=8, rows=None):
    """Class rows (distinct), features, class of each trial."""
    if rows is None:
        rows = np.unique(rng.integers(0, 2, size=(4 * n_classes, n_attributes)), axis=0)
        rows = rows[rng.permutation(len(rows))[:n_classes]]
    y = np.repeat(np.arange(len(rows)), trials)
    X = MU * (2.0 * rows[y] - 1.0) + rng.standard_normal((len(y), rows.shape[1]))
    return rows.astype(float), X, y


def dap(power):
    return ZeroShotClassifier(attribute_model=TrueAttributePosteriors(power=power), decision_rule=DAPRule(prior="uni"))


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    rows, X, y = simulate(rng, 40, 20)
    train_rows, test_rows = rows[:30], rows[30:]
    train = y < 30
    _, X_test, y_test = simulate(rng, 10, 300, rows=test_rows)  # held-out trials of unseen classes
    return X[train], train_rows[y[train]], y[train], X_test, test_rows, y_test


def _ece(proba, y):
    t = calibration_terms(proba, y)
    return expected_calibration_error(t.confidence, t.correct)


def test_true_posterior_is_calibrated_and_a_sharpened_one_is_not(data):
    X, A, groups, X_test, K, y_test = data
    ece_true = _ece(dap(1.0).fit(X, A, groups).predict_proba(X_test, K), y_test)
    ece_over = _ece(dap(3.0).fit(X, A, groups).predict_proba(X_test, K), y_test)
    assert ece_true < 0.04
    assert ece_over > 0.15


def test_calibrator_detects_and_corrects_over_confidence(data):
    X, A, groups, X_test, K, y_test = data
    over = CalibratedZeroShotClassifier(estimator=dap(3.0), random_state=0).fit(X, A, groups)
    assert over.temperature_ == pytest.approx(3.0, rel=0.25)  # recovers the power from training classes
    assert over.calibration_info_["fitted"] and over.calibration_info_["n_folds"] == 3
    assert over.calibration_info_["log_loss_after"] < over.calibration_info_["log_loss_before"]
    assert _ece(over.predict_proba(X_test, K), y_test) < 0.04
    assert _ece(over.predict_proba_uncalibrated(X_test, K), y_test) > 0.15
    # a temperature keeps every ranking: predictions (and accuracy) unchanged
    np.testing.assert_array_equal(over.predict(X_test, K), dap(3.0).fit(X, A, groups).predict(X_test, K))
    # an already calibrated method keeps T near 1
    calibrated = CalibratedZeroShotClassifier(estimator=dap(1.0), random_state=0).fit(X, A, groups)
    assert calibrated.temperature_ == pytest.approx(1.0, rel=0.25)


def test_under_confidence_is_sharpened(data):
    X, A, groups, X_test, K, y_test = data
    under = CalibratedZeroShotClassifier(estimator=dap(0.4), random_state=0).fit(X, A, groups)
    assert under.temperature_ < 0.6
    assert _ece(under.predict_proba(X_test, K), y_test) < _ece(under.predict_proba_uncalibrated(X_test, K), y_test)


def test_folds_hold_out_classes_and_are_seeded(data):
    X, A, groups, *_ = data
    seen = []

    def score(fitted, Xv, K):
        seen.append(K)
        return fitted.decision_function(Xv, K)

    folds = pseudo_unseen_scores(dap(1.0), X, A, groups, n_folds=3, random_state=1, score=score)
    assert len(folds) == 3 and sum(len(y) for _, y, _ in folds) == len(X)
    assert sum(len(k) for k in seen) == 30  # every training class held out once
    again = pseudo_unseen_scores(dap(1.0), X, A, groups, n_folds=3, random_state=1)
    other = pseudo_unseen_scores(dap(1.0), X, A, groups, n_folds=3, random_state=2)
    assert all(np.array_equal(a[1], b[1]) for a, b in zip(folds, again, strict=True))
    assert all(d == 0 for _, _, d in folds)
    assert not all(len(a[1]) == len(b[1]) and np.array_equal(a[1], b[1]) for a, b in zip(folds, other, strict=True))


def test_fit_temperature_recovers_a_known_power():
    rng = np.random.default_rng(3)
    logits = 2.0 * rng.standard_normal((4000, 6))
    y = (rng.random((4000, 1)) > np.cumsum(tempered_proba(logits, 1.0), axis=1)).sum(axis=1)
    assert fit_temperature([2.5 * logits], [y]) == pytest.approx(2.5, rel=0.1)


def test_too_few_classes_warns_and_records_why():
    rng = np.random.default_rng(4)
    rows, X, y = simulate(rng, 3, 10)
    with pytest.warns(CalibrationWarning, match="3 training classes are too few"):
        est = CalibratedZeroShotClassifier(estimator=dap(1.0)).fit(X, rows[y], y)
    assert est.temperature_ == 1.0 and not est.calibration_info_["fitted"]
    assert "at least 4" in est.calibration_info_["reason"]
    # 5 classes with 0/1 attributes: a fold trains on 3, where no attribute is had and lacked by 2
    rows5, X5, y5 = simulate(rng, 5, 10)
    with pytest.warns(CalibrationWarning, match="leave no attribute"):
        est5 = CalibratedZeroShotClassifier(estimator=dap(1.0)).fit(X5, rows5[y5], y5)
    assert not est5.calibration_info_["fitted"]


def test_turned_off_costs_no_fit_and_is_the_method(data):
    X, A, groups, X_test, K, _ = data
    off = CalibratedZeroShotClassifier(estimator=dap(3.0), calibration="none").fit(X, A, groups)
    assert off.calibration_info_["method"] == "none" and off.temperature_ == 1.0
    np.testing.assert_allclose(off.predict_proba(X_test, K), off.predict_proba_uncalibrated(X_test, K))


def test_registry_builds_calibrated_methods_unless_turned_off():
    assert isinstance(build_method("eszsl"), CalibratedZeroShotClassifier)
    assert isinstance(build_method("ensemble"), CalibratedZeroShotClassifier)
    assert isinstance(build_method("eszsl", calibration="none"), ZeroShotClassifier)
    assert get_method("dap-avg").parameters()["calibration"] == "temperature"
    assert "calibration" not in get_method("hand-dap").parameters()  # its own estimator, not calibrated here
    est = build_method("sae", calibration_folds=2, random_state=5)
    assert est.calibration_folds == 2 and est.random_state == 5
    assert isinstance(clone(est), CalibratedZeroShotClassifier)


def test_registry_method_is_calibrated_on_learned_attributes():
    """A learned method (ESZSL) on the generator: calibration lowers held-out log-loss and keeps accuracy."""
    rng = np.random.default_rng(7)
    rows, X, y = simulate(rng, 40, 15)
    _, X_test, y_test = simulate(rng, 10, 100, rows=rows[30:])
    train = y < 30
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = build_method("eszsl", random_state=0).fit(X[train], rows[y[train]], y[train])
    P, P0 = est.predict_proba(X_test, rows[30:]), est.predict_proba_uncalibrated(X_test, rows[30:])
    rows_ = np.arange(len(y_test))
    assert -np.log(P[rows_, y_test]).mean() < -np.log(P0[rows_, y_test]).mean()
    np.testing.assert_array_equal(P.argmax(axis=1), P0.argmax(axis=1))


def test_a_fold_leaves_out_an_attribute_its_training_classes_cannot_learn():
    """Attribute 0 belongs to 2 of 8 classes: a fold holding one of them out cannot learn it."""
    rng = np.random.default_rng(9)
    rows = np.column_stack([np.r_[1, 1, np.zeros(6)], np.unique(rng.integers(0, 2, (64, 6)), axis=0)[:8]])
    _, X, y = simulate(rng, 8, 10, rows=rows)
    seen = []

    def score(fitted, Xv, K):
        seen.append(K.shape[1])
        return fitted.decision_function(Xv, K)

    eszsl = ZeroShotClassifier(attribute_model=ESZSL(), decision_rule=CompatibilityRule())
    folds = pseudo_unseen_scores(eszsl, X, rows[y], y, n_folds=4, random_state=0, score=score)
    dropped = [d for _, _, d in folds]
    assert max(dropped) >= 1 and all(k == rows.shape[1] - d for k, d in zip(seen, dropped, strict=True))
    est = CalibratedZeroShotClassifier(estimator=eszsl, calibration_folds=4, random_state=0).fit(X, rows[y], y)
    assert est.calibration_info_["n_attributes_left_out"] == sum(dropped)


def test_folds_refit_with_the_final_fit_s_tuned_hyperparameters():
    """ESZSL's ridges are chosen once, on all training classes; the folds keep them (same score scale)."""
    rng = np.random.default_rng(11)
    rows, X, y = simulate(rng, 24, 10)
    est = build_method("eszsl", random_state=0).fit(X, rows[y], y)
    chosen = est.estimator_.attribute_model_
    assert est.calibration_info_["pinned"] == f"gammas=({chosen.best_gamma_},), lams=({chosen.best_lam_},)"
    assert est.estimator.attribute_model.gammas != (chosen.best_gamma_,)  # the parameter itself is untouched
    sae = build_method("sae", random_state=0).fit(X, rows[y], y)
    assert sae.calibration_info_["pinned"] == f"lams=({sae.estimator_.attribute_model_.best_lam_},)"


def test_calibration_subsample_is_bounded_stratified_and_seeded():
    """Above the bound: at most that many trials, every (class, object) keeps its share; seeded."""
    codes = np.repeat(np.arange(30), 40)  # 30 classes of 40 trials, two objects each
    groups = np.repeat(np.arange(60), 20)
    kept = calibration_subsample(codes, groups, 300, np.random.RandomState(0))
    assert kept.size <= 300 and np.all(np.diff(kept) > 0)
    assert np.array_equal(np.bincount(groups[kept], minlength=60), np.full(60, 5))  # 20 * 300 / 1200 each
    np.testing.assert_array_equal(kept, calibration_subsample(codes, groups, 300, np.random.RandomState(0)))
    assert not np.array_equal(kept, calibration_subsample(codes, groups, 300, np.random.RandomState(1)))
    # a class too small for its share keeps one trial; below the bound everything is kept
    uneven = np.r_[np.zeros(995, int), np.arange(1, 6)]
    assert np.array_equal(np.unique(uneven[calibration_subsample(uneven, None, 100, np.random.RandomState(0))]),
                          np.arange(6))
    np.testing.assert_array_equal(calibration_subsample(codes, groups, 1200, np.random.RandomState(0)),
                                  np.arange(1200))


def test_folds_are_dealt_on_at_most_the_bound_and_recover_the_power(data):
    X, A, groups, X_test, K, y_test = data  # 600 training trials, 30 classes of 20
    sizes = []

    def score(fitted, Xv, K):
        sizes.append((fitted.attribute_model_.n_trials_, len(Xv)))
        return fitted.decision_function(Xv, K)

    folds = pseudo_unseen_scores(dap(3.0), X, A, groups, n_folds=3, random_state=0, score=score, max_trials=240)
    assert sum(held for _, held in sizes) == sum(len(y) for _, y, _ in folds) <= 240
    assert all(fit + held <= 240 for fit, held in sizes)
    est = CalibratedZeroShotClassifier(estimator=dap(3.0), calibration_max_trials=240, random_state=0)
    est.fit(X, A, groups)
    info = est.calibration_info_
    assert info["n_held_out_trials"] <= 240 and info["n_training_trials"] == len(X)
    assert est.temperature_ == pytest.approx(3.0, rel=0.3)
    assert _ece(est.predict_proba(X_test, K), y_test) < 0.06
    again = CalibratedZeroShotClassifier(estimator=dap(3.0), calibration_max_trials=240, random_state=0)
    assert again.fit(X, A, groups).temperature_ == est.temperature_  # seeded


def test_calibration_below_the_bound_is_unchanged():
    """Fewer training trials than the bound: the same folds and temperature as with no bound at all."""
    rng = np.random.default_rng(12)
    rows, X, y = simulate(rng, 24, 10)
    eszsl = ZeroShotClassifier(attribute_model=ESZSL(), decision_rule=CompatibilityRule())
    assert len(X) < MAX_CALIBRATION_TRIALS
    bounded = CalibratedZeroShotClassifier(estimator=eszsl, random_state=3).fit(X, rows[y], y)
    unbounded = CalibratedZeroShotClassifier(estimator=eszsl, calibration_max_trials=None,
                                             random_state=3).fit(X, rows[y], y)
    at_size = CalibratedZeroShotClassifier(estimator=eszsl, calibration_max_trials=len(X),
                                           random_state=3).fit(X, rows[y], y)
    assert bounded.calibration_info_ == unbounded.calibration_info_ == at_size.calibration_info_
    assert bounded.calibration_info_["n_held_out_trials"] == len(X)


def test_folds_keep_the_attribute_bank_s_solver():
    """A bank fitted approximately (above max_exact_trials) is refitted approximately on the smaller folds."""
    rng = np.random.default_rng(13)
    rows, X, y = simulate(rng, 12, 15, n_attributes=4)
    solvers = []

    def score(fitted, Xv, K):
        solvers.append(fitted.attribute_model_.solver_choice_["solver"])
        return fitted.decision_function(Xv, K)

    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=2, n_gamma=1), max_exact_trials=150, random_state=0)
    clf = ZeroShotClassifier(attribute_model=bank, decision_rule=DAPRule(prior="uni"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = CalibratedZeroShotClassifier(estimator=clf, random_state=0).fit(X[:, None, :], rows[y], y)
        assert est.estimator_.attribute_model_.solver_choice_["solver"] == "approximate"  # 180 > 150 trials
        assert est.calibration_info_["pinned"] == ("solver=approximate, estimator_params=<chosen hyper-parameters "
                                                   "of 4 attribute classifiers>")
        from tzsl.models.calibration._posterior_calibration import _pinned  # the template the folds refit

        template = _pinned(clone(clf), est.estimator_)
        pseudo_unseen_scores(template, X[:, None, :], rows[y], y, random_state=0, score=score)
    assert solvers == ["approximate"] * 3  # each fold trains on about 120 < 150 trials
