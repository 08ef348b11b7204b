"""Calibration folds refit the attribute classifiers with the final fit's chosen hyper-parameters (issue 33).

``calibration_refit="pinned"`` (the default) gives each fold's (attribute, sensor) classifier the
``C`` / ``gamma`` the final fit chose for it (one-point grids, one draw), read through the bank's
``selected_params()`` (``estimator_params``); ``"search"`` searches the grids again, as before.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from sklearn.base import clone

from tzsl.exceptions import ConfigError
from tzsl.models import (
    AttributeClassifierBank,
    AttributeSVM,
    CalibratedZeroShotClassifier,
    DAPRule,
    LinearAttribute,
    ScalableAttributeClassifier,
    ScoreEnsembleZSL,
    ZeroShotClassifier,
)
from tzsl.models._pseudo_unseen import on_attributes
from tzsl.models.calibration import pseudo_unseen_scores, selected_params
from tzsl.models.detectors._attribute_bank import chosen_settings


def _data(seed=3, n_classes=12, trials=12, n_attributes=5):
    rng = np.random.default_rng(seed)
    rows = np.unique(rng.integers(0, 2, size=(6 * n_classes, n_attributes)), axis=0)
    rows = rows[rng.permutation(len(rows))[:n_classes]].astype(float)
    y = np.repeat(np.arange(n_classes), trials)
    X = 0.8 * (2 * rows[y] - 1) + rng.standard_normal((len(y), n_attributes))
    return rows, X[:, None, :], y


def _dap():
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=3, n_gamma=2, cv=3),
                                   attribute_names=[f"a{j}" for j in range(5)], random_state=0)
    return ZeroShotClassifier(attribute_model=bank, decision_rule=DAPRule(prior="uni"))


def _fold_settings(estimator, X, rows, y, refit):
    """(attribute name, C grid size, gamma grid size, C_, gamma_) of every fold's classifiers, and the final ones."""
    seen = []

    def score(fitted, Xv, K):
        bank = fitted.attribute_model_
        for name, row in zip(bank.attribute_names, bank.estimators_, strict=True):
            seen.append((name, row[0].C_grid_.size, row[0].gamma_grid_.size, row[0].C_, row[0].gamma_))
        return fitted.decision_function(Xv, K)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = CalibratedZeroShotClassifier(estimator=estimator, calibration_refit=refit, random_state=0)
        est.fit(X, rows[y], y)
        template = clone(estimator).set_params(
            **{f"attribute_model__{k}": v for k, v in
               selected_params(est.estimator_.attribute_model_, refit).items()})
        pseudo_unseen_scores(template, X, rows[y], y, random_state=0, score=score)
    bank = est.estimator_.attribute_model_
    final = {name: (row[0].C_, row[0].gamma_) for name, row in zip(bank.attribute_names, bank.estimators_, strict=True)}
    return seen, final, est


def test_pinned_folds_refit_each_classifier_with_its_chosen_c_and_gamma():
    rows, X, y = _data()
    seen, final, est = _fold_settings(_dap(), X, rows, y, "pinned")
    assert seen and all((c, g) == (1, 1) for _, c, g, _, _ in seen)  # one-point grids: no search
    assert all((C, gamma) == final[name] for name, _, _, C, gamma in seen)  # each attribute's own choice
    assert "estimator_params=<chosen hyper-parameters of 5 attribute classifiers>" in est.calibration_info_["pinned"]


def test_search_folds_search_the_grid_again():
    rows, X, y = _data()
    seen, _, est = _fold_settings(_dap(), X, rows, y, "search")
    assert seen and all((c, g) == (3, 4) for _, c, g, _, _ in seen)  # the extended grid: 2 + 2 gammas
    assert "estimator_params" not in est.calibration_info_["pinned"]


def test_pinned_and_search_give_the_same_predictions():
    """The temperature keeps the ranking: the refit choice changes posteriors, never predictions."""
    rows, X, y = _data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fits = {refit: CalibratedZeroShotClassifier(estimator=_dap(), calibration_refit=refit,
                                                    random_state=0).fit(X, rows[y], y)
                for refit in ("pinned", "search")}
    np.testing.assert_array_equal(fits["pinned"].predict(X, rows), fits["search"].predict(X, rows))
    for est in fits.values():
        assert est.calibration_info_["fitted"] and np.isfinite(est.temperature_)


@pytest.mark.parametrize("model, expected", [
    (AttributeSVM(grid="adaptive", n_draws=3),
     {"C_range": (10.0, 10.0), "n_C": 1, "gamma_range": (0.1, 0.1), "n_gamma": 1, "grid": "paper", "n_draws": 1}),
    (ScalableAttributeClassifier(),
     {"C_range": (10.0, 10.0), "n_C": 1, "gamma_range": (0.1, 0.1), "n_gamma": 1, "n_draws": 1}),
    (LinearAttribute(), {"C_range": (10.0, 10.0), "n_C": 1, "max_grid_extensions": 0}),
])
def test_chosen_settings_follow_each_classifier_s_parameters(model, expected):
    model.C_, model.gamma_ = 10.0, 0.1  # as a fit leaves them (LinearAttribute has no gamma parameter)
    assert chosen_settings(model) == expected
    clone(model).set_params(**expected)  # valid keywords of that classifier


def test_chosen_settings_of_an_untuned_classifier_are_empty():
    assert chosen_settings(AttributeSVM()) == {}


def test_estimator_params_of_the_wrong_shape_is_a_config_error():
    rows, X, y = _data()
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=1, n_gamma=1), estimator_params=[[{}]] * 4)
    with pytest.raises(ConfigError, match="5 attributes x 1 sensors"):
        bank.fit(X, rows[y], y)


# --------------------------------------------------------------------------- the score ensemble (issue 33 item 4)
def _ensemble(pin_members=True):
    small_dap = {"name": "dap-avg", "estimator": AttributeSVM(n_C=3, n_gamma=2, cv=3)}
    return ScoreEnsembleZSL(methods=(small_dap, "eszsl", "sae"), pin_members=pin_members, random_state=0)


def _calibrated_ensembles(X, rows, y):
    """Calibrated ensembles: members pinned (the default), members searching, and refit="search" with pinning asked."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {name: CalibratedZeroShotClassifier(estimator=_ensemble(pin), calibration_refit=refit,
                                                   random_state=0).fit(X, rows[y], y)
                for name, pin, refit in (("pinned", True, "pinned"), ("search", False, "pinned"),
                                         ("refit-search", True, "search"))}


def test_ensemble_pins_each_member_s_choice_in_its_calibration_folds_when_asked():
    """pin_members=True (issue 33; the default since issue 43): the folds refit each member with its own choice;
    with False they search."""
    assert ScoreEnsembleZSL().pin_members is True  # chosen on selection splits (ensemble-calibration-refit)
    rows, X, y = _data()
    fits = _calibrated_ensembles(X, rows, y)
    info = fits["pinned"].calibration_info_["pinned"]
    assert "dap-avg: solver=exact, estimator_params=<chosen hyper-parameters of 5 attribute classifiers>" in info
    assert "eszsl: gammas=" in info and "sae: lams=" in info
    assert fits["search"].calibration_info_["pinned"] == fits["refit-search"].calibration_info_["pinned"] == ""
    assert fits["search"].temperature_ == fits["refit-search"].temperature_  # both: every member searches
    # the pinned entries are the members' registry parameters, and a refit from them searches nothing
    entries = fits["pinned"].estimator_.pinned_methods(selected_params)
    assert [e["name"] for e in entries] == ["dap-avg", "eszsl", "sae"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refit = ScoreEnsembleZSL(methods=entries, random_state=0).fit(X, rows[y], y)
    bank, fitted_bank = refit.estimators_[0].attribute_model_, fits["pinned"].estimator_.estimators_[0].attribute_model_
    assert all(est.C_grid_.size == 1 and est.gamma_grid_.size == 1 for row in bank.estimators_ for est in row)
    assert [est.C_ for row in bank.estimators_ for est in row] == [est.C_ for row in fitted_bank.estimators_
                                                                     for est in row]
    assert (refit.estimators_[1].attribute_model_.best_gamma_
            == fits["pinned"].estimator_.estimators_[1].attribute_model_.best_gamma_)


def test_ensemble_pinned_and_search_folds_give_the_same_predictions():
    rows, X, y = _data()
    fits = _calibrated_ensembles(X, rows, y)
    np.testing.assert_array_equal(fits["pinned"].predict(X, rows), fits["search"].predict(X, rows))
    for est in fits.values():
        assert est.calibration_info_["fitted"] and np.isfinite(est.temperature_)


def test_a_fold_that_leaves_out_an_attribute_cuts_the_ensemble_member_s_pinned_classifiers():
    rows, X, y = _data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = _ensemble().fit(X, rows[y], y)
    entries = fitted.pinned_methods(selected_params)
    assert "estimator_params" in entries[0]
    keep = np.array([True, False, True, True, True])
    cut = on_attributes(ScoreEnsembleZSL(methods=entries), keep).methods
    assert len(cut[0]["estimator_params"]) == 4
    assert cut[0]["estimator_params"] == [entries[0]["estimator_params"][j] for j in (0, 2, 3, 4)]
    assert cut[1:] == entries[1:]  # no per-attribute parameter: as they were
