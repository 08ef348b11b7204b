"""How an attribute SVM searches its (draw, gamma, C) grid: every cell, or successive halving.

Also the search's one fit: a precomputed-kernel C-SVC through libsvm directly (:func:`svc_fit_decision`).

``"grid"`` scores every configuration on the out-of-fold scores of all training trials.
``"halving"`` (successive halving, Jamieson and Talwalkar 2016; scikit-learn's
``HalvingGridSearchCV`` with the cross-validation folds as the resource) scores every
configuration on the first fold of its draw, keeps the best third (never fewer than ``factor``
configurations, so a grid of ``factor`` or fewer is searched whole), adds folds (``factor`` times
as many each round), and so on; the configurations left when every fold is in are scored exactly
as the full grid scores them, on all training trials, and the best is kept. When the full grid's
choice survives the earlier rounds the fitted model is the full grid's, bit for bit; the cheaper
search can only differ where it was pruned.

Rounds use folds of one draw only, so a configuration's partial criterion is computed on the
trials of the folds seen so far (its Platt sigmoid and the balanced weights fitted on those).

``grid="adaptive"`` (:func:`adaptive_grid_search`) runs either search again on a grown grid while
the choice sits at an end of the ``C`` or ``gamma`` grid; :func:`fill_grid_lines` lets the grid
search fit only the lines the grown grid adds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from sklearn.svm import _libsvm

from tzsl.models._zsl_input import extend_at_edge
from tzsl.models.detectors._attribute_training import AttributeTrainingError

__all__ = ["HALVING_FACTOR", "HALVING_KERNEL_BYTES", "MAX_GRID_EXTENSIONS", "SEARCHES", "UNIT_WEIGHT",
           "adaptive_grid_search", "balanced_class_weight", "fill_grid_lines", "halving_rounds", "successive_halving",
           "svc_fit_decision"]

#: ``search`` options of :class:`~tzsl.models.AttributeSVM`.
SEARCHES = ("grid", "halving")
#: Survivors are divided, and folds multiplied, by this much per round of ``search="halving"``.
HALVING_FACTOR = 3
#: Most bytes of RBF kernels ``search="halving"`` keeps between its rounds (above it, each round recomputes them).
HALVING_KERNEL_BYTES = 256 * 2**20
#: Class weights (class 0, class 1) when classes are not balanced by weight.
UNIT_WEIGHT = np.ones(2)
_EMPTY = np.empty(0)
#: Most log steps ``grid="adaptive"`` adds beyond each end (low, high) of the ``C`` grid and of the ``gamma`` grid.
MAX_GRID_EXTENSIONS = 3


def balanced_class_weight(y: np.ndarray) -> np.ndarray:
    """``class_weight="balanced"`` of ``SVC`` for 0/1 labels: ``n / (2 * count)``; shape (2,)."""
    counts = np.bincount(y.astype(np.intp), minlength=2)
    return y.size / (2 * counts.astype(np.float64))


def svc_fit_decision(K_train: np.ndarray, y: np.ndarray, C: float, class_weight: np.ndarray,
                     K_eval: np.ndarray) -> np.ndarray:
    """Fit a precomputed-kernel C-SVC and return its decision values on ``K_eval``.

    The same libsvm calls, with the same arguments, as ``SVC(kernel="precomputed", C=C,
    class_weight=...).fit(K_train, y).decision_function(K_eval)``, so the numbers are identical
    (``test_libsvm_path_equals_svc``), without ``SVC``'s per-call input validation, which dominated
    the time on the small (a few hundred trials) problems of the grid search.

    Parameters
    ----------
    K_train : ndarray of shape (n_train, n_train), C-contiguous
        Kernel between training trials.
    y : ndarray of shape (n_train,)
        Labels as float64 0.0 / 1.0 (both present).
    C : float
    class_weight : ndarray of shape (2,)
        Multipliers of ``C`` for class 0 and class 1.
    K_eval : ndarray of shape (n_eval, n_train)
        Kernel between evaluated and training trials.

    Returns
    -------
    ndarray of shape (n_eval,)
        Decision values, positive towards class 1.
    """
    support, sv, n_sv, dual_coef, intercept, prob_a, prob_b, status, _ = _libsvm.fit(
        K_train, y, svm_type=0, kernel="precomputed", C=float(C), class_weight=class_weight,
        sample_weight=_EMPTY, cache_size=200.0, tol=1e-3, shrinking=True, max_iter=-1, random_seed=0,
    )
    if status != 0:
        raise AttributeTrainingError("libsvm did not converge on a cross-validation fit")
    dec = _libsvm.decision_function(
        K_eval, support, sv, n_sv, dual_coef, intercept, prob_a, prob_b, svm_type=0, kernel="precomputed",
        cache_size=200.0,
    )
    return -dec.ravel()


def halving_rounds(n_folds: int, factor: int = HALVING_FACTOR) -> list[int]:
    """Folds seen after each round: ``1, factor, factor**2, ...`` capped at ``n_folds`` (last).

    Parameters
    ----------
    n_folds : int
        Cross-validation folds of a draw (>= 1).
    factor : int, default HALVING_FACTOR

    Returns
    -------
    list of int
        Increasing, ending with ``n_folds``.
    """
    rounds = [1]
    while rounds[-1] < n_folds:
        rounds.append(min(n_folds, rounds[-1] * factor))
    return rounds


def successive_halving(
    shape: tuple[int, int, int],
    n_folds: Sequence[int],
    fit: Callable[[int, int, np.ndarray, range, bool], None],
    score: Callable[[int, np.ndarray, int], np.ndarray],
    factor: int = HALVING_FACTOR,
) -> np.ndarray:
    """Run successive halving over a (draw, gamma, C) grid; the configurations fitted on every fold.

    Parameters
    ----------
    shape : (n_draws, n_gammas, n_C)
    n_folds : sequence of int, length n_draws
        Folds of each draw.
    fit : callable ``fit(draw, gamma_index, C_indices, folds, outside)``
        Fill the out-of-fold scores of those configurations on folds ``folds`` (a range of fold
        indices) and, if ``outside``, on the trials outside the draw.
    score : callable ``score(draw, cells, n_seen) -> (k, 2)``
        (criterion, tie-break) of the draw's configurations where ``cells`` (bool, shape
        (n_gammas, n_C)) is True, in row-major (gamma, C) order, on the trials of the draw's first
        ``n_seen`` folds (lower is better). One call per draw and round scores all of the draw's
        survivors together (one Platt solve for all of them: :func:`~tzsl.models.detectors.cv_criteria`).
    factor : int, default HALVING_FACTOR

    Returns
    -------
    bool ndarray of shape ``shape``
        The survivors, whose out-of-fold scores cover every training trial. Ties keep the
        earliest configuration in (draw, gamma, C) order.
    """
    alive: np.ndarray = np.ones(shape, dtype=bool)  # its shape changes: flat, then ``shape`` again
    schedules = [halving_rounds(f, factor) for f in n_folds]
    seen = np.zeros(shape[0], dtype=int)
    for step in range(max(len(s) for s in schedules)):
        final = all(step >= len(s) - 1 for s in schedules)
        crit = np.full(shape + (2,), np.inf)
        for di, schedule in enumerate(schedules):
            target = schedule[min(step, len(schedule) - 1)]
            last = step >= len(schedule) - 1
            for gi in range(shape[1]):
                cis = np.flatnonzero(alive[di, gi])
                if cis.size and (target > seen[di] or (final and last)):
                    fit(di, gi, cis, range(seen[di], target), final)
            if not final and alive[di].any():
                crit[di][alive[di]] = np.nan_to_num(score(di, alive[di], target), nan=np.inf)
            seen[di] = target
        if final:
            break
        n_alive = int(alive.sum())
        keep = max(min(factor, n_alive), math.ceil(n_alive / factor))  # never fewer than factor
        order = np.lexsort((np.arange(alive.size), crit[..., 1].ravel(), crit[..., 0].ravel()))
        alive = np.zeros(alive.size, dtype=bool)
        alive[order[:keep]] = True
        alive = alive.reshape(shape)
    return alive


def adaptive_grid_search(
    search: Callable[[np.ndarray, np.ndarray], tuple[object, tuple[int, int]]],
    Cs: np.ndarray,
    gammas: np.ndarray,
    max_extensions: int = MAX_GRID_EXTENSIONS,
) -> tuple[np.ndarray, np.ndarray, object]:
    """Search a (gamma, C) grid; while the choice sits at an end of a grid, widen that end and search again.

    The step beyond an end is the ratio of the grid's two outer values there
    (:func:`~tzsl.models._zsl_input.extend_at_edge`, as ``ESZSLCV`` and ``SAECV`` extend their
    grids), at most ``max_extensions`` times per end of each grid; a grid of one point, or whose
    two outer values are equal, is never widened. ``C`` and ``gamma`` at an end in the same
    search are widened together.

    Parameters
    ----------
    search : callable ``search(Cs, gammas) -> (result, (gamma_index, C_index))``
        One search over the grids (the caller keeps its folds and draws fixed between calls)
        and the grid position of its choice.
    Cs, gammas : ndarray of shape (n_C,), (n_gammas,)
        Increasing starting grids (> 0).
    max_extensions : int, default MAX_GRID_EXTENSIONS
        0 searches the starting grids once.

    Returns
    -------
    Cs, gammas : ndarray of shape (n_C + k_C,), (n_gammas + k_gamma,)
        The final grids: the starting ones with the points added at their ends.
    result
        What the last ``search`` returned.
    """
    left = dict.fromkeys([("C", "low"), ("C", "high"), ("gamma", "low"), ("gamma", "high")], int(max_extensions))
    while True:
        result, (gi, ci) = search(Cs, gammas)
        grown = {}
        for name, grid, i in (("C", Cs, ci), ("gamma", gammas, gi)):
            wider = extend_at_edge(grid, i)
            side = "low" if i == 0 else "high"
            if wider is None or left[name, side] == 0 or not (wider[0] < grid[0] or wider[-1] > grid[-1]):
                continue
            grown[name] = wider
            left[name, side] -= 1
        if not grown:
            return Cs, gammas, result
        Cs, gammas = grown.get("C", Cs), grown.get("gamma", gammas)


def fill_grid_lines(
    oof: np.ndarray,
    Cs: np.ndarray,
    gammas: np.ndarray,
    previous: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    compute: Callable[[np.ndarray, np.ndarray, np.ndarray], None],
) -> None:
    """Out-of-fold scores of a grid that may have grown at its ends: copy the known lines, fit the new ones.

    Parameters
    ----------
    oof : ndarray of shape (n_draws, n_gammas, n_C, n_train)
        Filled in place.
    Cs, gammas : ndarray of shape (n_C,), (n_gammas,)
        Increasing grids.
    previous : (Cs, gammas, oof) or None
        An earlier search of the same fit (same draws and folds): its grids, each the new grid
        without points added beyond its ends, and its ``oof``. None: every line is new.
    compute : callable ``compute(gammas, Cs, out)``
        Fills ``out`` of shape (n_draws, len(gammas), len(Cs), n_train) for those values.
    """
    if previous is None:
        compute(gammas, Cs, oof)
        return
    C_old, g_old, oof_old = previous
    g0, c0 = int(np.sum(gammas < g_old[0])), int(np.sum(Cs < C_old[0]))  # points added below each grid
    g_in, c_in = slice(g0, g0 + g_old.size), slice(c0, c0 + C_old.size)
    oof[:, g_in, c_in] = oof_old
    new_g = np.setdiff1d(np.arange(gammas.size), np.arange(gammas.size)[g_in])
    new_c = np.setdiff1d(np.arange(Cs.size), np.arange(Cs.size)[c_in])
    if new_g.size:  # new gamma lines, every C
        block = np.empty((oof.shape[0], new_g.size, Cs.size, oof.shape[3]))
        compute(gammas[new_g], Cs, block)
        oof[:, new_g] = block
    if new_c.size:  # new C lines of the known gammas
        block = np.empty((oof.shape[0], g_old.size, new_c.size, oof.shape[3]))
        compute(g_old, Cs[new_c], block)
        oof[:, g_in, new_c] = block
