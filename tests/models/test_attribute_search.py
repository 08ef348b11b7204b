"""Successive halving of the attribute SVM's grid search (issue 22, item 3)."""

from __future__ import annotations

import numpy as np
import pytest

import tzsl.models.detectors._attribute_svm as svm_module
from tests.models.test_attribute_svm import make_problem
from tzsl.exceptions import ConfigError
from tzsl.models import AttributeClassifierBank, AttributeSVM
from tzsl.models._validation import ParameterError
from tzsl.models.attribute_training import gamma_grid
from tzsl.models.detectors._attribute_search import halving_rounds, successive_halving
from tzsl.studies.config import load_experiment
from tzsl.studies.zero_shot.study import attribute_estimator


def test_rounds_multiply_the_folds_and_end_with_all_of_them():
    assert halving_rounds(5) == [1, 3, 5]
    assert halving_rounds(2) == [1, 2]
    assert halving_rounds(20) == [1, 3, 9, 20]
    assert halving_rounds(9, factor=2) == [1, 2, 4, 8, 9]


def test_the_driver_keeps_a_third_and_finishes_the_survivors():
    shape, folds = (2, 3, 3), [5, 3]
    fitted: dict[tuple, set] = {}
    outside: set = set()

    def fit(di, gi, cis, fold_range, with_outside):
        for ci in cis:
            fitted.setdefault((di, gi, ci), set()).update(fold_range)
            if with_outside:
                outside.add((di, gi, ci))

    def score(di, cells, n_seen):  # configuration (1, 2, 0) is best, then by flat index
        return np.array([[0.0 if (di, gi, ci) == (1, 2, 0) else 1.0 + ci, 0.0]
                         for gi, ci in zip(*np.nonzero(cells), strict=True)])

    alive = successive_halving(shape, folds, fit, score)
    assert alive[1, 2, 0] and alive.sum() == 3  # 18 -> 6 -> 3 (never fewer than the factor)
    for key in zip(*np.nonzero(alive), strict=True):
        assert fitted[key] == set(range(folds[key[0]])) and key in outside
    assert len(fitted) == 18 and all(len(v) >= 1 for v in fitted.values())
    assert sum(len(v) for v in fitted.values()) < 18 * 4  # fewer fold fits than the full grid


@pytest.mark.parametrize("params", [dict(n_C=3, n_gamma=3, n_draws=3, cv=5), dict(n_C=2, n_gamma=2, n_draws=2, cv=None),
                                    dict(n_C=3, n_gamma=2, n_draws=1, cv=3, undersampling="none"),
                                    dict(n_C=3, n_gamma=3, n_draws=2, cv=4, scoring="balanced_accuracy")])
def test_survivors_are_scored_exactly_as_the_grid_scores_them(params):
    X, A, g = make_problem(n_objects=24, n_attributes=6, seed=5)
    agree = 0
    for j in range(A.shape[1]):
        grid = AttributeSVM(**params, search="grid", random_state=j).fit(X[:, 0], A[:, j], g)
        halving = AttributeSVM(**params, search="halving", random_state=j).fit(X[:, 0], A[:, j], g)
        kept = np.isfinite(halving.cv_scores_)
        assert 1 <= kept.sum() < kept.size
        np.testing.assert_array_equal(halving.cv_scores_[kept], grid.cv_scores_[kept])
        gammas = gamma_grid(grid.gamma_range, grid.n_gamma, grid.grid)
        Cs = np.geomspace(*grid.C_range, grid.n_C)
        best = (max(grid.draw_, 0), int(np.argmin(abs(gammas - grid.gamma_))), int(np.argmin(abs(Cs - grid.C_))))
        if kept[best]:  # the grid's choice survived: halving must make it too
            agree += 1
            assert (halving.C_, halving.gamma_, halving.draw_, halving.platt_) == (grid.C_, grid.gamma_, grid.draw_,
                                                                                  grid.platt_)
            np.testing.assert_array_equal(halving.predict_proba(X[:, 0]), grid.predict_proba(X[:, 0]))
    assert agree >= 1  # the comparison above ran


def test_a_grid_of_at_most_factor_configurations_is_searched_whole():
    alive = successive_halving((1, 3, 1), [5], lambda *args: None, lambda di, cells, n: np.zeros((cells.sum(), 2)))
    assert alive.all()


def test_halving_fits_fewer_svms(monkeypatch):
    X, A, g = make_problem(n_objects=24, seed=5)
    calls = {"n": 0}
    real = svm_module.svc_fit_decision

    def counted(*args):
        calls["n"] += 1
        return real(*args)

    monkeypatch.setattr(svm_module, "svc_fit_decision", counted)
    params = dict(n_C=3, n_gamma=3, grid="paper", n_draws=3, cv=4, random_state=0)
    AttributeSVM(**params, search="grid").fit(X[:, 0], A[:, 0], g)
    grid_calls, calls["n"] = calls["n"], 0
    AttributeSVM(**params, search="halving").fit(X[:, 0], A[:, 0], g)
    assert grid_calls == 3 * 3 * 3 * 5  # (draws x gammas x C) x (4 folds + the draw's full model)
    assert calls["n"] <= grid_calls / 2


def _experiment(tmp_path, svm: str):
    path = tmp_path / "exp.toml"
    path.write_text(f"study = 'phac2-dap'\n[dataset]\nplain = 'd'\n[svm]\n{svm}\n")
    return load_experiment(path)


def test_halving_reaches_the_estimator_from_the_experiment_file(tmp_path):
    config = _experiment(tmp_path, "search = 'halving'").config
    assert attribute_estimator(config, seed=0).search == "halving"
    default = _experiment(tmp_path, "").config
    assert "search" not in default.svm.estimator_params()  # the default is not written out
    assert attribute_estimator(default, seed=0).search == AttributeSVM().search == "halving"
    with pytest.raises(ConfigError, match="svm.search: 'random'"):
        _experiment(tmp_path, "search = 'random'")


def test_halving_reaches_every_fit_of_a_bank():
    X, A, g = make_problem(n_attributes=2)
    bank = AttributeClassifierBank(estimator=AttributeSVM(n_C=2, n_gamma=2, n_draws=2, cv=3, search="halving"),
                                   memory=None, random_state=0).fit(X, A, g)
    for per_sensor in bank.estimators_:
        for est in per_sensor:
            assert est.search == "halving" and np.isnan(est.cv_scores_).any()


def test_halving_leaves_bagging_to_the_grid_and_refuses_unknown_values():
    X, A, g = make_problem()
    bagged = AttributeSVM(n_C=2, n_gamma=2, n_draws=2, cv=3, undersampling="bagging", search="halving",
                          random_state=0)
    assert np.isfinite(bagged.fit(X[:, 0], A[:, 0], g).cv_scores_).all()
    with pytest.raises(ParameterError, match="search"):
        AttributeSVM(search="random").fit(X[:, 0], A[:, 0], g)


def test_schema_offers_exactly_the_estimators_searches():
    from tzsl.models.attribute_training import SEARCHES
    from tzsl.studies.config._zero_shot import SvmSettings

    assert set(SvmSettings.model_fields["search"].annotation.__args__) == set(SEARCHES)


def test_halving_without_the_kernel_cache_gives_the_same_model(monkeypatch):
    X, A, g = make_problem(n_objects=20, seed=3)
    params = dict(n_C=3, n_gamma=3, n_draws=2, cv=4, search="halving", random_state=1)
    kept = AttributeSVM(**params).fit(X[:, 0], A[:, 0], g)
    monkeypatch.setattr(svm_module, "HALVING_KERNEL_BYTES", 0)  # recompute every kernel in every round
    recomputed = AttributeSVM(**params).fit(X[:, 0], A[:, 0], g)
    np.testing.assert_array_equal(kept.cv_scores_, recomputed.cv_scores_)
    assert (kept.C_, kept.gamma_, kept.draw_, kept.platt_) == (recomputed.C_, recomputed.gamma_, recomputed.draw_,
                                                                recomputed.platt_)



def test_halving_scores_outside_the_draw_with_the_chosen_svm():
    """Under-sampling leaves trials outside the chosen draw; their out-of-fold scores come from the SVM fitted
    on the whole draw (the kernel of the outside trials to the draw's trials), i.e. the final model's scores."""
    X, A, g = make_problem(n_objects=20, seed=6)
    model = AttributeSVM(n_C=3, n_gamma=3, n_draws=2, cv=4, search="halving", undersampling="select",
                         random_state=2).fit(X[:, 0], A[:, 0], g)
    assert model.gamma_ != model.gamma_grid_[0]  # a kernel of the wrong gamma would show
    Z = model.preprocessor_.transform(X[:, 0])
    in_draw = (np.abs(Z[:, None, :] - model.train_features_[0][None]).sum(axis=2) < 1e-12).any(axis=1)
    assert in_draw.any() and (~in_draw).any()
    np.testing.assert_allclose(model.oof_scores_[~in_draw], model.svm_score(X[~in_draw, 0]), rtol=1e-6, atol=1e-8)
