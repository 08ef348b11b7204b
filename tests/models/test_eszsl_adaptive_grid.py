"""ESZSLCV's adaptive grid: a selected edge is extended one log step (up to a bound), an interior optimum is not."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.models import ESZSLCV
from tzsl.models._zsl_input import extend_at_edge


def problem(seed=0, n_classes=12, n_attributes=8, n_features=20, per_class=15, noise=0.3):
    rng = np.random.default_rng(seed)
    while True:
        A = rng.integers(0, 2, (n_classes, n_attributes)).astype(float)
        if len(np.unique(A, axis=0)) == n_classes:
            break
    y = np.repeat(np.arange(n_classes), per_class)
    X = A[y] @ rng.normal(size=(n_attributes, n_features)) + noise * rng.normal(size=(y.size, n_features))
    return X, A[y], y


def test_extend_at_edge_steps_one_log_step_beyond_the_selected_edge():
    grid = np.array([0.1, 1.0, 10.0])
    np.testing.assert_allclose(extend_at_edge(grid, 0), [0.01, 0.1, 1.0, 10.0])
    np.testing.assert_allclose(extend_at_edge(grid, 2), [0.1, 1.0, 10.0, 100.0])
    assert extend_at_edge(grid, 1) is None
    assert extend_at_edge(np.array([1.0]), 0) is None


def test_selected_edge_extends_the_grid_and_the_fit_matches_a_wider_fixed_grid():
    X, Y, groups = problem()
    # a grid of huge gammas only: the smallest (an edge) wins, so the grid must grow downwards
    grid = (1e4, 1e5, 1e6)
    fixed = ESZSLCV(gammas=grid, lams=(1.0,), grid_extensions=0).fit(X, Y, groups)
    assert fixed.best_gamma_ == 1e4 and fixed.at_grid_edge_
    adaptive = ESZSLCV(gammas=grid, lams=(1.0,), grid_extensions=3).fit(X, Y, groups)
    assert adaptive.gammas_.size > len(grid)
    assert adaptive.gammas_[0] < 1e4
    assert adaptive.best_gamma_ < 1e4
    assert adaptive.best_score_ >= fixed.best_score_
    assert adaptive.cv_scores_.shape[:2] == (adaptive.gammas_.size, adaptive.lams_.size)
    # the bound: at most 3 extra steps
    assert adaptive.gammas_.size <= len(grid) + 3
    wide = ESZSLCV(gammas=adaptive.gammas_, lams=(1.0,), grid_extensions=0).fit(X, Y, groups)
    assert wide.best_gamma_ == adaptive.best_gamma_
    np.testing.assert_allclose(wide.coef_, adaptive.coef_)


def test_interior_optimum_leaves_the_grid_unchanged():
    X, Y, groups = problem(seed=2, noise=3.0, per_class=6, n_features=40)
    wide = tuple(10.0 ** np.arange(-4, 7))
    first = ESZSLCV(gammas=wide, lams=wide, grid_extensions=0).fit(X, Y, groups)
    # the optimum is not the smallest value (ties go to the smaller), so a 3-point grid around it
    # holds it in the middle: the neighbour below scores strictly less, the one above no more
    assert first.best_gamma_ > wide[0] and first.best_lam_ > wide[0]
    gammas = (first.best_gamma_ / 10, first.best_gamma_, first.best_gamma_ * 10)
    lams = (first.best_lam_ / 10, first.best_lam_, first.best_lam_ * 10)
    model = ESZSLCV(gammas=gammas, lams=lams, grid_extensions=3).fit(X, Y, groups)
    np.testing.assert_allclose(model.gammas_, gammas)
    np.testing.assert_allclose(model.lams_, lams)
    assert not model.at_grid_edge_
    assert model.best_gamma_ == pytest.approx(first.best_gamma_)
    assert model.best_lam_ == pytest.approx(first.best_lam_)


def test_zero_extensions_keeps_the_edge_and_reports_it():
    X, Y, groups = problem()
    model = ESZSLCV(gammas=(1e4, 1e5), lams=(1.0, 2.0), grid_extensions=0).fit(X, Y, groups)
    np.testing.assert_array_equal(model.gammas_, (1e4, 1e5))
    assert model.at_grid_edge_


def test_sae_selected_edge_extends_and_interior_does_not():
    from tzsl.models import SAECV

    X, Y, groups = problem()
    fixed = SAECV(lams=(1e6, 1e7), grid_extensions=0).fit(X, Y, groups)
    assert fixed.at_grid_edge_ and fixed.best_lam_ == 1e6
    adaptive = SAECV(lams=(1e6, 1e7), grid_extensions=4).fit(X, Y, groups)
    assert adaptive.lams_.size > 2 and adaptive.best_lam_ < 1e6
    assert adaptive.best_score_ >= fixed.best_score_
    assert adaptive.cv_scores_.shape[0] == adaptive.lams_.size
    if not adaptive.at_grid_edge_:  # interior: rerunning on the final grid changes nothing
        again = SAECV(lams=adaptive.lams_, grid_extensions=4).fit(X, Y, groups)
        np.testing.assert_array_equal(again.lams_, adaptive.lams_)
        assert again.best_lam_ == adaptive.best_lam_


def test_grid_edge_share_reads_models_and_fills_the_comparison_column():
    import pandas as pd

    from tzsl.studies.comparison.method_runs import COMPARISON_COLUMNS, grid_edge_share, method_summary

    X, Y, groups = problem()
    at_edge = ESZSLCV(gammas=(1e4, 1e5), lams=(1.0,), grid_extensions=0).fit(X, Y, groups)
    assert grid_edge_share(at_edge) == 1.0
    assert np.isnan(grid_edge_share(object()))
    assert "share_at_grid_edge" in COMPARISON_COLUMNS
    rng = np.random.default_rng(0)
    trials = pd.concat([
        pd.DataFrame({"method": m, "split": np.repeat(["s0", "s1"], 10), "class": np.tile(np.arange(5), 4),
                      "trial": np.tile(np.arange(10), 2), "correct": rng.integers(0, 2, 20).astype(float)})
        for m in ("ref", "eszsl")
    ], ignore_index=True)
    table = method_summary(trials, {"ref": [1.0], "eszsl": [1.0]}, 0.2, "ref", study="t",
                           grid_edge={"eszsl": [1.0, 0.0, 0.0, 1.0]})
    share = table.set_index("method")["share_at_grid_edge"]
    assert share["eszsl"] == 0.5 and np.isnan(share["ref"])
