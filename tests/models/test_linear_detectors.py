"""Linear and object-robust attribute detectors (issue 32): LinearAttribute, its C grid widened at the
edge, object-balanced and group-robust weights, the bank's ``detector`` families and ``"auto"``."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

import tzsl.models.detectors._linear_attribute as linear_module
from tzsl.exceptions import ConfigError
from tzsl.models import (
    AttributeClassifierBank,
    AttributeSVM,
    LinearAttribute,
    LogisticAttribute,
    MultiLabelAttributeClassifier,
    build_method,
    get_method,
)
from tzsl.models.attribute_training import DETECTORS, detector_template, object_balanced_weights
from tzsl.models.detectors._attribute_training import balanced_sample_weights
from tzsl.models.detectors._linear_attribute import robust_object_weights


def linear_objects(seed=0, n_obj=24, trials=5, d=6, noise=1.0):
    """One attribute = sign of a linear function of each object's centre; trials scatter around it."""
    rng = np.random.default_rng(seed)
    w = rng.normal(size=d)
    centres = rng.normal(size=(n_obj, d)) * 2.0
    y_obj = (centres @ w > np.median(centres @ w)).astype(int)
    groups = np.repeat(np.arange(n_obj), trials)
    return centres[groups] + noise * rng.normal(size=(groups.size, d)), y_obj[groups], groups


def bank_problem(seed=0, n_obj=12, trials=4, m=3, s=2, d=5):
    """(X (n, s, d), A (n, m), groups, rows (n_obj, m)): attributes linear in the object's features."""
    rng = np.random.default_rng(seed)
    rows = np.array([[i >> k & 1 for k in range(m)] for i in range(n_obj)]) % 2
    W = rng.normal(size=(m, d)) * 2.0
    groups = np.repeat(np.arange(n_obj), trials)
    X = (rows[groups] @ W)[:, None, :] + rng.normal(size=(groups.size, s, d))
    return X, rows[groups], groups, rows


@pytest.mark.parametrize("loss", ["log_loss", "squared_hinge"])
@pytest.mark.parametrize("weighting", ["class", "object", "robust"])
def test_linear_detector_learns_held_out_objects(loss, weighting):
    X, y, g = linear_objects()
    train = g < 18
    model = LinearAttribute(loss=loss, weighting=weighting, random_state=0).fit(X[train], y[train], g[train])
    P = model.predict_proba(X[~train])
    assert P.shape == (int((~train).sum()), 2) and np.all((P >= 0) & (P <= 1))
    np.testing.assert_allclose(P.sum(axis=1), 1.0)
    assert np.mean(model.predict(X[~train]) == y[~train]) > 0.7  # chance: 0.5
    assert model.C_ in model.C_grid_ and model.cv_scores_.shape == model.C_grid_.shape
    assert model.platt_[0] >= 0 and model.oof_scores_.shape == (int(train.sum()),)


def test_c_grid_is_widened_at_its_chosen_end_and_only_new_points_are_fitted(monkeypatch):
    """Pure noise: the grouped-CV optimum is the strongest regularisation, far below a grid starting at C = 1."""
    rng = np.random.default_rng(3)
    g = np.repeat(np.arange(20), 4)
    X, y = rng.normal(size=(g.size, 30)), (np.arange(20) % 2)[g]
    fits = []
    real_fit = linear_module._linear_fit
    monkeypatch.setattr(linear_module, "_linear_fit", lambda *a: fits.append(a[1]) or real_fit(*a))
    fixed = LinearAttribute(C_range=(1.0, 100.0), n_C=3, max_grid_extensions=0, cv=3, random_state=0).fit(X, y, g)
    assert fixed.C_grid_.size == 3 and fixed.grid_edges_ == [("C", 1.0, "low")]
    fits.clear()
    wide = LinearAttribute(C_range=(1.0, 100.0), n_C=3, max_grid_extensions=2, cv=3, random_state=0).fit(X, y, g)
    np.testing.assert_allclose(wide.C_grid_, [0.01, 0.1, 1.0, 10.0, 100.0])
    assert wide.C_ < 1.0
    assert len(fits) == 3 * wide.C_grid_.size + 1  # each C once per fold (none refitted), then the final fit


def test_c_grid_stops_widening_once_the_choice_is_interior():
    X, y, g = linear_objects(noise=0.5)
    model = LinearAttribute(C_range=(1e-4, 1e4), n_C=9, random_state=0).fit(X, y, g)
    if model.grid_edges_ == []:
        assert model.C_grid_[0] < model.C_ < model.C_grid_[-1]
    assert model.C_grid_.size <= 9 + 2 * linear_module.MAX_GRID_EXTENSIONS


def test_object_balanced_weights_count_every_object_equally():
    g = np.array([0, 0, 0, 0, 1, 2, 2, 3, 3, 3])
    yb = np.isin(g, [0, 1])
    w = object_balanced_weights(yb, g)
    totals = np.bincount(g, weights=w)
    np.testing.assert_allclose(totals[[0, 1]], totals[0])  # present objects equal
    np.testing.assert_allclose(totals[[2, 3]], totals[2])  # absent objects equal
    np.testing.assert_allclose([w[yb].sum(), w[~yb].sum()], [g.size / 2, g.size / 2])
    equal = np.repeat(np.arange(4), 3)
    np.testing.assert_allclose(object_balanced_weights(equal < 1, equal), balanced_sample_weights(equal < 1))


def test_robust_weights_move_toward_the_worst_fitted_object_and_keep_class_totals():
    X, y, g = linear_objects(n_obj=12, noise=0.3)
    outlier = g == 0  # one object with the other class's features: the fit cannot please it
    X = X.copy()
    X[outlier] = X[(y != y[outlier][0]) & (g != 0)][: outlier.sum()]
    Z, yb = StandardScaler().fit_transform(X), y == 1
    w0 = robust_object_weights("log_loss", 1.0, Z, yb, g, 0, 1.0, 0)
    np.testing.assert_allclose(w0, object_balanced_weights(yb, g))
    w = robust_object_weights("log_loss", 1.0, Z, yb, g, 5, 1.0, 0)
    np.testing.assert_allclose([w[yb].sum(), w[~yb].sum()], [w0[yb].sum(), w0[~yb].sum()])
    share = np.bincount(g, weights=w) / np.bincount(g, weights=w0)
    assert share[0] > 1.5 and share[0] > 2 * np.median(share)  # the fit is pulled toward the object it misfits


def test_linear_detector_refuses_a_single_object_class_and_bad_ranges():
    X, y, g = linear_objects(n_obj=6)
    y = (g == 0).astype(int)
    with pytest.raises(ValueError, match="only 1 training object.s. with label 1;"):  # 1, not np.int64(1)
        LinearAttribute().fit(X, y, g)
    with pytest.raises(ValueError, match="C_range"):
        LinearAttribute(C_range=(10.0, 1.0)).fit(X, y)


@pytest.mark.parametrize("detector", [d for d in DETECTORS if d not in ("rbf-svm", "auto")])
def test_bank_fits_the_linear_families(detector):
    X, A, g, rows = bank_problem()
    bank = AttributeClassifierBank(detector=detector, random_state=0, memory=False).fit(X, A, g)
    family = LogisticAttribute if detector == "logistic-c1" else LinearAttribute
    assert all(isinstance(est, family) for per in bank.estimators_ for est in per)
    assert bank.detector_ == detector and bank.detector_choice_ == {"detector": detector, "criterion": "given"}
    assert bank.solver_choice_["solver"] == "exact" and "linear" in bank.solver_choice_["reason"]
    P = bank.predict_proba(X)
    assert P.shape == (len(g), 2, A.shape[1])
    assert np.mean((P.mean(axis=1) >= 0.5) == A) > 0.8


def test_the_estimator_template_belongs_to_the_rbf_svm_family():
    assert isinstance(detector_template("rbf-svm"), AttributeSVM)
    given = AttributeSVM(n_C=2)
    assert detector_template("rbf-svm", given) is given
    with pytest.raises(ConfigError, match="leave it None"):
        detector_template("logistic", given)
    with pytest.raises(ConfigError, match="no template"):
        detector_template("auto")


def test_auto_records_its_choice_and_pins_it():
    X, A, g, rows = bank_problem(n_obj=12)
    bank = AttributeClassifierBank(detector="auto", detector_candidates=("logistic", "linear-svm"),
                                   random_state=0, memory=False).fit(X, A, g)
    choice = bank.detector_choice_
    assert set(choice["scores"]) == {"logistic", "linear-svm"} and choice["n_held_out_trials"] == len(g)
    best = max(choice["scores"], key=lambda c: (choice["scores"][c]["accuracy"],
                                                -choice["scores"][c]["attribute_log_loss"]))
    assert choice["detector"] == bank.detector_ == best
    assert all(0.0 <= v["accuracy"] <= 1.0 and v["attribute_log_loss"] > 0 for v in choice["scores"].values())
    chosen = bank.selected_params()
    assert {k: chosen[k] for k in ("solver", "detector", "estimator")} == {"solver": "exact", "detector": best,
                                                                          "estimator": None}
    # and each (attribute, sensor) model's chosen C, pinned as a one-point grid for calibration refits
    C = [[est.C_ for est in per_sensor] for per_sensor in bank.estimators_]
    assert [[params["C_range"] for params in row] for row in chosen["estimator_params"]] == [
        [(c, c) for c in row] for row in C]


def test_auto_refuses_too_few_training_classes_with_its_own_message():
    X, A, g, _ = bank_problem(n_obj=6, m=1)  # 2 distinct rows, each held by 3 objects
    with pytest.raises(ValueError, match="detector='auto' cannot choose"):
        AttributeClassifierBank(detector="auto", detector_candidates=("logistic",), memory=False).fit(X, A, g)


def test_auto_with_a_given_svm_template_can_choose_a_linear_family():
    """The estimator is the rbf-svm candidate's template: a linear choice fits without it (it once raised)."""
    X, A, g, _ = bank_problem(n_obj=12)
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=2, n_gamma=2, n_draws=1, cv=3), detector="auto",
                                   detector_candidates=("logistic",), random_state=0, memory=False).fit(X, A, g)
    assert bank.detector_ == "logistic" and isinstance(bank.estimators_[0][0], LinearAttribute)


def test_registered_linear_methods_build_and_run():
    X, A, g, rows = bank_problem(n_obj=12)
    for name, detector in (("dap-avg-logistic", "logistic"), ("dap-avg-linear-svm", "linear-svm"),
                           ("dap-avg-robust-logistic", "robust-logistic"), ("dap-avg-logistic-c1", "logistic-c1")):
        assert get_method(name).preset["detector"] == detector and "detector" not in get_method(name).parameters()
        model = build_method(name, random_state=0, memory=False, calibration="none").fit(X, A, g)
        assert model.attribute_model_.detector_ == detector
        assert np.mean(model.predict(X, rows) == g) > 0.5  # 12 classes: chance is 1/12
    assert get_method("dap-avg").parameters()["detector"] == "rbf-svm"  # the default family is unchanged


def test_calibrated_auto_method_pins_the_chosen_family_in_its_folds():
    X, A, g, _ = bank_problem(n_obj=12)
    model = build_method("dap-avg", detector="auto", detector_candidates=("logistic", "linear-svm"),
                         random_state=0, memory=False).fit(X, A, g)
    chosen = model.estimator_.attribute_model_.detector_
    assert f"detector={chosen}" in model.calibration_info_["pinned"]


def test_classifier_chain_takes_a_linear_detector():
    X, A, g, _ = bank_problem()
    chain = MultiLabelAttributeClassifier(detector="logistic", random_state=0, memory=False).fit(X, A, g)
    link = chain.estimators_[1][0]
    assert isinstance(link, LinearAttribute)
    assert isinstance(link.preprocessor.transformers[0][1], StandardScaler)  # z-score, not the SVM's PCA
    assert np.mean((chain.predict_proba(X).mean(axis=1) >= 0.5) == A) > 0.8


@parametrize_with_checks([LinearAttribute(loss="squared_hinge", cv=3, random_state=0)])
def test_linear_svm_detector_passes_check_estimator(estimator, check):
    """The estimator-check list holds the robust logistic detector; the linear SVM's own fit path here."""
    check(estimator)


def test_the_untuned_logistic_family_is_the_per_ep_models_classifier_and_takes_no_template():
    """``logistic-c1``: LogisticAttribute with its defaults (C = 1, class-balanced); an SVM template is refused."""
    template = detector_template("logistic-c1")
    assert isinstance(template, LogisticAttribute) and template.get_params() == LogisticAttribute().get_params()
    with pytest.raises(ConfigError, match="estimator is the template of detector='rbf-svm'"):
        detector_template("logistic-c1", AttributeSVM())
    X, A, g, _ = bank_problem()
    chain = MultiLabelAttributeClassifier(detector="logistic-c1", random_state=0, memory=False).fit(X, A, g)
    assert chain.predict_proba(X).shape == (len(g), 2, A.shape[1])


@pytest.mark.parametrize("detector", ["logistic", "logistic-c1"])
def test_linear_detectors_fit_with_one_blas_thread(detector, monkeypatch):
    """A detector's fit is a small dense problem: one BLAS thread (tzsl._parallel.one_blas_thread), whatever the
    caller's."""
    from sklearn.linear_model import LogisticRegression
    from threadpoolctl import threadpool_info, threadpool_limits

    seen: list[int] = []
    original = LogisticRegression.fit

    def counting_fit(self, *args, **kwargs):
        seen.extend(lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(LogisticRegression, "fit", counting_fit)
    rng = np.random.default_rng(0)
    X = rng.normal(size=(60, 4))
    y = (X[:, 0] + 0.5 * rng.normal(size=60) > 0).astype(int)
    with threadpool_limits(limits=2, user_api="blas"):
        detector_template(detector).fit(X, y, np.repeat(np.arange(12), 5))
    assert seen and set(seen) == {1}
