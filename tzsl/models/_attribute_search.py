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
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from sklearn.svm import _libsvm  # noqa: PLC2701 - see svc_fit_decision

from tzsl.models._attribute_training import AttributeTrainingError

__all__ = ["HALVING_FACTOR", "HALVING_KERNEL_BYTES", "SEARCHES", "UNIT_WEIGHT", "balanced_class_weight", "halving_rounds",
           "successive_halving", "svc_fit_decision"]

#: ``search`` options of :class:`~tzsl.models.AttributeSVM`.
SEARCHES = ("grid", "halving")
#: Survivors are divided, and folds multiplied, by this much per round of ``search="halving"``.
HALVING_FACTOR = 3
#: Most bytes of RBF kernels ``search="halving"`` keeps between its rounds (above it, each round recomputes them).
HALVING_KERNEL_BYTES = 256 * 2**20
#: Class weights (class 0, class 1) when classes are not balanced by weight.
UNIT_WEIGHT = np.ones(2)
_EMPTY = np.empty(0)


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
    score: Callable[[int, int, np.ndarray, int], np.ndarray],
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
    score : callable ``score(draw, gamma_index, C_indices, n_seen) -> (k, 2)``
        (criterion, tie-break) of those configurations on the trials of their draw's first
        ``n_seen`` folds (lower is better).
    factor : int, default HALVING_FACTOR

    Returns
    -------
    bool ndarray of shape ``shape``
        The survivors, whose out-of-fold scores cover every training trial. Ties keep the
        earliest configuration in (draw, gamma, C) order.
    """
    alive = np.ones(shape, dtype=bool)
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
                if cis.size == 0:
                    continue
                if target > seen[di] or (final and last):
                    fit(di, gi, cis, range(seen[di], target), final)
                if not final:
                    crit[di, gi, cis] = np.nan_to_num(score(di, gi, cis, target), nan=np.inf)
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
