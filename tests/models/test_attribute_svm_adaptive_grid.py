"""AttributeSVM's grid="adaptive": a chosen grid end is widened one log step (up to a bound), an interior choice
is not."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

import tzsl.models.detectors._attribute_svm as svm_module
from tests.models.test_attribute_svm import TINY, make_problem
from tzsl.models import AttributeSVM
from tzsl.models._estimator_checks import check_instance
from tzsl.models.attribute_training import MAX_GRID_EXTENSIONS, gamma_grid
from tzsl.models.detectors._attribute_search import adaptive_grid_search, fill_grid_lines

START_GAMMAS = gamma_grid((0.01, 1.0), 3, "extended")
START_CS = np.array([1.0, 10.0, 100.0])


def linear_problem(seed=1, n_obj=24, trials=5, d=20):
    """Attribute = sign of a linear function spread over many raw features: the wider the kernel the better,
    so the grouped-CV optimum lies below the extended grid's lowest gamma (1e-4)."""
    rng = np.random.default_rng(seed)
    w = rng.normal(size=d)
    centres = rng.normal(size=(n_obj, d)) * 3.0
    y_obj = (centres @ w > np.median(centres @ w)).astype(int)
    groups = np.repeat(np.arange(n_obj), trials)
    return centres[groups] + rng.normal(size=(groups.size, d)), y_obj[groups], groups


def radial_problem(seed=1, n_obj=30, trials=4, noise=0.3):
    """Attribute = the object lies outside the median radius in 2-D: a local kernel of moderate width wins."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(n_obj, 2))
    r = np.linalg.norm(centres, axis=1)
    groups = np.repeat(np.arange(n_obj), trials)
    return centres[groups] + noise * rng.normal(size=(groups.size, 2)), (r > np.median(r)).astype(int)[groups], groups


LINEAR = dict(n_draws=1, cv=4, preprocessor=None, random_state=0)


class FullRecompute(AttributeSVM):
    """Every search of the adaptive grid fitted from scratch (nothing carried between searches): the reference."""

    def _search_oof(self, D, yb, groups, draws, fold_seed, Cs, gammas, cw, known):
        return super()._search_oof(D, yb, groups, draws, fold_seed, Cs, gammas, cw, {})


def test_driver_widens_a_chosen_end_by_the_outer_ratio_and_stops_at_the_bound():
    calls = []

    def always_low(Cs, gammas):
        calls.append((Cs.copy(), gammas.copy()))
        return None, (0, 0)

    Cs, gammas, _ = adaptive_grid_search(always_low, START_CS, START_GAMMAS, max_extensions=2)
    np.testing.assert_allclose(Cs, [0.01, 0.1, 1.0, 10.0, 100.0])
    np.testing.assert_allclose(gammas, [1e-6, 1e-5, 1e-4, 1e-3, 0.01, 0.1, 1.0])
    assert len(calls) == 3  # the start, then one search per step

    def interior(Cs, gammas):
        return None, (1, 1)

    Cs, gammas, _ = adaptive_grid_search(interior, START_CS, START_GAMMAS)
    assert Cs is START_CS and gammas is START_GAMMAS
    # equal outer values (C_range low == high): no step to take
    Cs, _, _ = adaptive_grid_search(always_low, np.ones(3), START_GAMMAS, max_extensions=3)
    np.testing.assert_array_equal(Cs, np.ones(3))


def test_grid_lines_of_a_grown_grid_are_copied_or_computed_once():
    computed = []

    def compute(gammas, Cs, out):
        computed.append((gammas.copy(), Cs.copy()))
        out[:] = gammas[None, :, None, None] * 1000.0 + Cs[None, None, :, None]

    g_old, C_old = np.array([1.0, 2.0]), np.array([10.0, 20.0])
    old = np.empty((1, 2, 2, 3))
    fill_grid_lines(old, C_old, g_old, None, compute)
    g_new, C_new = np.array([0.5, 1.0, 2.0]), np.array([10.0, 20.0, 40.0])
    new = np.empty((1, 3, 3, 3))
    fill_grid_lines(new, C_new, g_new, (C_old, g_old, old), compute)
    expected = np.broadcast_to(g_new[None, :, None, None] * 1000.0 + C_new[None, None, :, None], new.shape)
    np.testing.assert_array_equal(new, expected)
    assert len(computed) == 3  # the first grid, then the new gamma line (every C), then the new C line (old gammas)
    np.testing.assert_array_equal(computed[1][0], [0.5])
    np.testing.assert_array_equal(computed[2][0], g_old)
    np.testing.assert_array_equal(computed[2][1], [40.0])


@pytest.mark.parametrize("search", ["grid", "halving"])
def test_extends_beyond_the_low_gamma_edge_up_to_the_bound(search):
    X, y, g = linear_problem()
    extended = AttributeSVM(grid="extended", search=search, **LINEAR).fit(X, y, g)
    adaptive = AttributeSVM(grid="adaptive", search=search, **LINEAR).fit(X, y, g)
    assert extended.gamma_ == START_GAMMAS[0] and ("gamma", 1e-4, "low") in extended.grid_edges_
    assert adaptive.gamma_ < 1e-4  # found outside the starting grid
    assert np.nanmin(adaptive.cv_scores_) < np.nanmin(extended.cv_scores_)
    # three steps below 1e-4, then the bound: the low gamma end is recorded as exhausted
    assert adaptive.gamma_grid_.size == START_GAMMAS.size + MAX_GRID_EXTENSIONS
    np.testing.assert_allclose(adaptive.gamma_grid_[:4], [1e-7, 1e-6, 1e-5, 1e-4])
    assert adaptive.gamma_ == adaptive.gamma_grid_[0]
    assert [(p, e) for p, _, e in adaptive.grid_edges_] == [("gamma", "low")]
    assert adaptive.cv_scores_.shape[1:] == (adaptive.gamma_grid_.size, adaptive.C_grid_.size)


def test_the_bound_is_the_module_constant(monkeypatch):
    X, y, g = linear_problem()
    monkeypatch.setattr(svm_module, "MAX_GRID_EXTENSIONS", 1)
    model = AttributeSVM(grid="adaptive", search="grid", **LINEAR).fit(X, y, g)
    np.testing.assert_allclose(model.gamma_grid_, np.concatenate([[1e-5], START_GAMMAS]))
    assert ("gamma", model.gamma_grid_[0], "low") in model.grid_edges_


@pytest.mark.parametrize("search", ["grid", "halving"])
def test_an_interior_choice_is_not_extended(search):
    X, y, g = radial_problem()
    params = dict(search=search, undersampling="none", cv=4, C_range=(0.1, 1000.0), n_C=5, preprocessor=None,
                  random_state=0)
    extended = AttributeSVM(grid="extended", **params).fit(X, y, g)
    adaptive = AttributeSVM(grid="adaptive", **params).fit(X, y, g)
    assert extended.grid_edges_ == []  # the data put the choice inside both grids
    np.testing.assert_array_equal(adaptive.C_grid_, np.geomspace(0.1, 1000.0, 5))
    np.testing.assert_array_equal(adaptive.gamma_grid_, START_GAMMAS)
    np.testing.assert_array_equal(adaptive.cv_scores_, extended.cv_scores_)
    assert (adaptive.C_, adaptive.gamma_, adaptive.platt_) == (extended.C_, extended.gamma_, extended.platt_)


@pytest.mark.parametrize("search", ["grid", "halving"])
@pytest.mark.parametrize("undersampling", ["select", "bagging", "none"])
def test_reusing_earlier_fits_equals_searching_the_final_grid_afresh(search, undersampling):
    """Only new configurations are fitted on a grown grid; the numbers are those of a fresh search (same draws,
    folds), and a second fit with the same int seed repeats them."""
    X, A, g = make_problem(n_objects=18, seed=4)
    grown = 0
    for j in range(A.shape[1]):
        params = dict(TINY, grid="adaptive", search=search, undersampling=undersampling, random_state=j)
        model = AttributeSVM(**params).fit(X[:, 0], A[:, j], g)
        ref = FullRecompute(**params).fit(X[:, 0], A[:, j], g)
        again = AttributeSVM(**params).fit(X[:, 0], A[:, j], g)
        grown += model.C_grid_.size + model.gamma_grid_.size > 2 + 4
        for other in (ref, again):
            np.testing.assert_array_equal(model.C_grid_, other.C_grid_)
            np.testing.assert_array_equal(model.gamma_grid_, other.gamma_grid_)
            np.testing.assert_array_equal(model.cv_scores_, other.cv_scores_)
            np.testing.assert_array_equal(model.oof_scores_, other.oof_scores_)
            assert (model.C_, model.gamma_, model.draw_, model.platt_) == (other.C_, other.gamma_, other.draw_,
                                                                            other.platt_)
        np.testing.assert_array_equal(model.predict_proba(X[:, 0]), ref.predict_proba(X[:, 0]))
    assert grown  # some attribute's search did widen a grid


@parametrize_with_checks([check_instance("AttributeSVM", AttributeSVM).set_params(grid="adaptive")])
def test_adaptive_grid_passes_check_estimator(estimator, check):
    check(estimator)
