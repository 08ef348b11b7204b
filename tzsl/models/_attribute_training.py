"""What an attribute classifier's training shares, exact (RBF-SVM) or approximate (Nystroem).

Option names, the training error, the default preprocessor, class-balanced under-sampling of whole
objects, balanced sample weights, Platt scaling and the grid-edge record, used by
:class:`~tzsl.models.AttributeSVM`, :class:`~tzsl.models.ScalableAttributeClassifier` and
:class:`~tzsl.models.AttributeClassifierBank`.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit, log_expit
from sklearn.base import BaseEstimator

from tzsl.exceptions import SplitError
from tzsl.features import VariancePCA

__all__ = [
    "AUTO_MAX_EXACT_TRIALS",
    "PLATT_WEIGHTING",
    "SCORING",
    "SOLVERS",
    "UNDERSAMPLING",
    "AttributeTrainingError",
    "GRIDS",
    "GridEdgeWarning",
    "balanced_object_draws",
    "balanced_sample_weights",
    "default_preprocessor",
    "fit_platt",
    "gamma_grid",
    "grid_edges",
]

UNDERSAMPLING = ("select", "bagging", "none")
SOLVERS = ("exact", "approximate", "auto")
AUTO_MAX_EXACT_TRIALS = 3000
SCORING = ("log_loss", "balanced_accuracy")
PLATT_WEIGHTING = ("balanced", "empirical")
#: ``grid`` options: the paper's log-spaced ``gamma`` grid, or that grid with lower decades added.
GRIDS = ("paper", "extended")
#: Decades of ``gamma`` that ``grid="extended"`` adds below the low end of ``gamma_range``.
EXTENDED_GAMMA_DECADES = 2


class GridEdgeWarning(UserWarning):
    """A tuned hyper-parameter was chosen at the low or high end of its grid (the optimum may lie outside)."""


def grid_edges(chosen: dict[str, tuple[np.ndarray, int]]) -> list[tuple[str, float, str]]:
    """``(name, value, "low" | "high")`` for each chosen grid index at an end of a grid of >= 2 points."""
    edges = []
    for name, (grid, i) in chosen.items():
        if grid.size >= 2 and i in (0, grid.size - 1):
            edges.append((name, float(grid[i]), "low" if i == 0 else "high"))
    return edges


def gamma_grid(gamma_range, n_gamma: int, grid: str) -> np.ndarray:
    """The ``gamma`` values an RBF attribute classifier tunes over, ascending.

    Parameters
    ----------
    gamma_range : (float, float)
        Ends of the paper's log-spaced grid (``(0.01, 1.0)``: DAP paper section 4.4).
    n_gamma : int
        Points of that grid.
    grid : {"paper", "extended"}
        ``"paper"``: ``np.geomspace(*gamma_range, n_gamma)``. ``"extended"``: the same points
        plus ``gamma_range[0] * 10**-k`` for ``k = 1 .. EXTENDED_GAMMA_DECADES`` (0.001 and
        0.0001 for the paper's range): on PHAC-2 most grouped-CV choices sit on the paper's low
        edge 0.01, and with about 25 z-scored PCA components (squared distances of order 50)
        ``gamma = 1e-4`` is close to a linear kernel, so the extended grid spans linear to local.

    Returns
    -------
    ndarray of shape (n_gamma,) or (n_gamma + EXTENDED_GAMMA_DECADES,)
        In units of squared preprocessed features^-1.
    """
    paper = np.geomspace(float(gamma_range[0]), float(gamma_range[1]), int(n_gamma))
    if grid == "paper":
        return paper
    low = float(gamma_range[0]) * 10.0 ** -np.arange(EXTENDED_GAMMA_DECADES, 0, -1)
    return np.concatenate([low, paper])


class AttributeTrainingError(SplitError, ValueError):
    """An attribute cannot be learned from the training objects of a split.

    A :class:`tzsl.exceptions.SplitError` (and a ``ValueError``, as scikit-learn expects of
    estimators given unusable targets).
    """


def default_preprocessor() -> BaseEstimator:
    """Z-score then PCA keeping 95% of the variance, capped at 25 components (DAP paper §4.3).

    Returns
    -------
    tzsl.features.VariancePCA
        ``VariancePCA(variance=0.95, max_components=25)``, unfitted.
    """
    return VariancePCA(variance=0.95, max_components=25)


def fit_platt(
    scores: np.ndarray, y: np.ndarray, sample_weight: np.ndarray | None = None
) -> tuple[float, float]:
    """Fit Platt's sigmoid ``p(y = 1 | s) = expit(a * s + b)``.

    Uses Platt's (1999) smoothed targets ``(N+ + 1) / (N+ + 2)`` and ``1 / (N- + 2)``, which keep
    the fit finite on separable scores. The slope is constrained to ``a >= 0``.

    Parameters
    ----------
    scores : ndarray of shape (n,)
        Classifier scores (SVM decision values, unitless).
    y : ndarray of shape (n,)
        0/1 labels.
    sample_weight : ndarray of shape (n,), optional
        Non-negative weights.

    Returns
    -------
    a, b : float
        Slope and intercept of the logit.
    """
    s = np.asarray(scores, dtype=float)
    y = np.asarray(y).astype(bool)
    w = np.ones_like(s) if sample_weight is None else np.asarray(sample_weight, dtype=float)
    n_pos, n_neg = int(y.sum()), int((~y).sum())
    t = np.where(y, (n_pos + 1.0) / (n_pos + 2.0), 1.0 / (n_neg + 2.0))
    scale = float(np.std(s)) or 1.0
    u = s / scale  # conditioning only; undone below
    w_pos, w_neg = w[y].sum(), w[~y].sum()
    x0 = np.array([0.0, np.log((w_pos + 1.0) / (w_neg + 1.0))])

    def loss(theta: np.ndarray) -> tuple[float, np.ndarray]:
        z = theta[0] * u + theta[1]
        nll = -(w * (t * log_expit(z) + (1.0 - t) * log_expit(-z))).sum()
        r = w * (expit(z) - t)
        return float(nll), np.array([(r * u).sum(), r.sum()])

    # a >= 0: the map must increase with the score. Without it, leave-one-object-out scores of
    # near-constant models (large gamma) are perfectly *anti*-correlated with the label (holding
    # out a positive object shifts the intercept down), and a negative slope would "win" the CV.
    res = minimize(loss, x0, jac=True, method="L-BFGS-B", bounds=[(0.0, None), (None, None)])
    return float(res.x[0] / scale), float(res.x[1])


def balanced_sample_weights(y: np.ndarray) -> np.ndarray:
    y = y.astype(bool)
    w = np.empty(y.shape, dtype=float)
    w[y] = 0.5 / max(int(y.sum()), 1)
    w[~y] = 0.5 / max(int((~y).sum()), 1)
    return w * y.size


def balanced_object_draws(yb: np.ndarray, groups: np.ndarray, n_draws: int,
                          rng: np.random.RandomState) -> tuple[list[np.ndarray], np.ndarray]:
    """Class-balanced under-sampling draws that drop whole objects of the majority class.

    Parameters
    ----------
    yb : ndarray of bool, shape (n_trials,)
    groups : ndarray of shape (n_trials,)
        Object of each trial.
    n_draws : int
        Random draws; 0 means no under-sampling (one draw keeping every trial).
    rng : numpy.random.RandomState

    Returns
    -------
    draws : list of ndarray of bool, shape (n_trials,)
        Kept trials of each distinct draw (duplicates merged).
    weights : ndarray of shape (n_distinct_draws,)
        Fraction of the ``n_draws`` draws equal to each distinct draw.
    """
    n = yb.size
    if n_draws == 0:
        return [np.ones(n, dtype=bool)], np.ones(1)
    minority = yb.sum() * 2 <= n  # True: positives are the minority
    major = yb != minority
    # groups holding only majority trials can be dropped whole
    g_all, g_inv = np.unique(groups, return_inverse=True)
    has_minor = np.bincount(g_inv, weights=(~major).astype(float), minlength=g_all.size) > 0
    droppable = np.flatnonzero(~has_minor)
    size = np.bincount(g_inv, minlength=g_all.size)
    n_minor = int((~major).sum())
    # majority trials inside mixed groups are always kept
    kept_major_fixed = int(np.bincount(g_inv, weights=major.astype(float), minlength=g_all.size)[has_minor].sum())
    need = n_minor - kept_major_fixed
    draws = []
    for _ in range(n_draws):
        order = droppable[rng.permutation(droppable.size)]
        csum = np.cumsum(size[order])
        k = int(np.searchsorted(csum, need)) + 1 if need > 0 else 0
        k = min(k, order.size)
        keep_group = has_minor.copy()
        keep_group[order[:k]] = True
        draws.append(keep_group[g_inv])
    uniq, inverse = np.unique(np.array(draws), axis=0, return_inverse=True)
    weights = np.bincount(inverse.ravel(), minlength=len(uniq)).astype(float)
    return list(uniq), weights / weights.sum()
