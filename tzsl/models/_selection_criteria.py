"""Cross-validation criteria and the tie rule of tzsl's zero-shot model selection (issue 41).

A choice a published number depends on (ESZSL's two ridges, SAE's ``lam``, the embedding model's weight
decay) is made on held-out training classes. Counting correct trials, as these searches once did, is a
coarse, discrete score: a last-bit difference in one trial's scores (another CPU's BLAS kernels, another
thread count) flips that trial, the count, and then the chosen regulariser, and a published accuracy
moved by 0.2 between two machines. The default criterion here is smooth instead:

``neg_log_loss``
    Minus the mean log-loss of the held-out trials under ``softmax(beta * z)`` over the held-out classes,
    where ``z`` are the trial's class scores centred per trial and divided by their root mean square over
    the fold (so that the criterion does not depend on the scale of a method's scores), and ``beta`` in
    ``[0, BETA_MAX]`` minimises that loss (one scalar per fold and configuration: the best a temperature
    can do). ``beta = 0`` is chance (``-log n_classes``): a configuration whose scores rank the true class
    below the others scores chance, not worse. The loss is a continuous function of the scores, so a last
    bit moves it by about a last bit.

The tie rule: configurations whose mean criterion lies within :data:`TIE_TOLERANCE` of the best count as
tied, and the most regularised of them is chosen (the largest value of the first regulariser, then of the
second). The tolerance is far above what a last bit moves a smooth criterion (about 1e-12 relative) and
far below a difference worth choosing on; it also settles the flat directions of a grid, where stronger
regularisation only rescales the scores (ESZSL with a large ``gamma``), without leaving the choice to
rounding. ``accuracy`` and ``balanced_accuracy`` stay available with the same tie rule.

Chosen on selection splits (docs/user_guide/choices.md#choices-a-last-bit-cannot-flip).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.special import logsumexp

__all__ = ["BETA_MAX", "DEFAULT_SCORING", "SCORINGS", "TIE_TOLERANCE", "heldout_scores", "most_regularised_best",
           "neg_log_loss"]

#: Criteria of the zero-shot searches (higher is better).
SCORINGS = ("neg_log_loss", "accuracy", "balanced_accuracy")
#: The criterion used unless a search is told otherwise.
DEFAULT_SCORING = "neg_log_loss"
#: Mean CV criteria closer to the best than this are ties, settled by :func:`most_regularised_best`.
TIE_TOLERANCE = 1e-6
#: Largest inverse temperature of :func:`neg_log_loss`, in units of the fold's score spread: a class ahead by
#: one spread is then at odds of e^10 (about 22,000 to 1). Where every configuration separates the held-out
#: classes (a small, easy fold) the loss at this cap still ranks them by their margins instead of all being 0.
BETA_MAX = 10.0
#: Bisection steps of :func:`neg_log_loss` (``BETA_MAX / 2**60`` is below 1e-16).
_BISECTION_STEPS = 60


def neg_log_loss(scores: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Minus the held-out log-loss at the best inverse temperature, for a batch of configurations.

    Parameters
    ----------
    scores : ndarray of shape (..., n_trials, n_classes)
        Class scores of the held-out trials among the held-out classes, one leading index per
        configuration (any number of leading axes).
    y : int ndarray of shape (n_trials,)
        Column of each trial's true class.

    Returns
    -------
    ndarray of shape scores.shape[:-2]
        ``-min_beta mean_i [logsumexp_c(beta z_ic) - beta z_iy]`` (nats per trial; 0 is perfect and
        ``-log n_classes`` is chance), ``beta`` in ``[0, BETA_MAX]``.
    """
    s = np.asarray(scores, dtype=np.float64)
    y = np.asarray(y, dtype=np.intp)
    z = s - s.mean(axis=-1, keepdims=True)
    spread = np.sqrt(np.mean(z**2, axis=(-2, -1), keepdims=True))
    z = z / np.where(spread > 0, spread, 1.0)
    z_true = np.take_along_axis(z, np.broadcast_to(y[:, None], z.shape[:-1] + (1,)), axis=-1)[..., 0]

    def slope(beta: np.ndarray) -> np.ndarray:
        """d loss / d beta: mean over trials of the softmax-expected score minus the true class's."""
        b = beta[..., None, None]
        p = np.exp(b * z - logsumexp(b * z, axis=-1, keepdims=True))
        return np.mean(np.sum(p * z, axis=-1) - z_true, axis=-1)

    # the loss is convex in beta: bisection on its slope finds the minimiser in [0, BETA_MAX]
    low = np.zeros(z.shape[:-2])
    high = np.full(z.shape[:-2], BETA_MAX)
    for _ in range(_BISECTION_STEPS):
        mid = 0.5 * (low + high)
        falling = slope(mid) < 0
        low, high = np.where(falling, mid, low), np.where(falling, high, mid)
    beta = 0.5 * (low + high)[..., None, None]
    loss = np.mean(logsumexp(beta * z, axis=-1) - beta[..., 0] * z_true, axis=-1)
    return -loss


def heldout_scores(scores: np.ndarray, y: np.ndarray, scoring: str) -> np.ndarray:
    """The CV criterion (higher is better) of each configuration on one fold's held-out trials.

    Parameters
    ----------
    scores : ndarray of shape (..., n_trials, n_classes)
        Class scores, as for :func:`neg_log_loss`.
    y : int ndarray of shape (n_trials,)
        Column of each trial's true class.
    scoring : {"neg_log_loss", "accuracy", "balanced_accuracy"}
        The criterion (:data:`SCORINGS`); accuracy counts the argmax (first of tied classes).

    Returns
    -------
    ndarray of shape scores.shape[:-2]
    """
    y = np.asarray(y, dtype=np.intp)
    if scoring == "neg_log_loss":
        return neg_log_loss(scores, y)
    correct = np.argmax(scores, axis=-1) == y
    if scoring == "accuracy":
        return correct.mean(axis=-1)
    if scoring == "balanced_accuracy":
        present = np.unique(y)
        per_class = [correct[..., y == c].mean(axis=-1) for c in present]
        return np.mean(per_class, axis=0)
    raise ValueError(f"unknown scoring {scoring!r}; expected one of {SCORINGS}")


def most_regularised_best(mean_scores: np.ndarray, regularisers: Sequence[np.ndarray],
                          tolerance: float = TIE_TOLERANCE) -> tuple[int, ...]:
    """Grid index of the most regularised configuration among those tied with the best.

    Parameters
    ----------
    mean_scores : ndarray of shape (n_1, ..., n_k)
        Mean CV criterion of each configuration (higher is better); NaN where not scored.
    regularisers : sequence of k ndarrays, the j-th of shape (n_j,)
        The value of each axis's regulariser (larger = more regularised).
    tolerance : float, default=TIE_TOLERANCE
        Configurations within this of the best are tied.

    Returns
    -------
    tuple of k int
        Among the tied configurations, the one with the largest first regulariser, then the largest
        second, and so on.
    """
    scores = np.asarray(mean_scores, dtype=np.float64)
    if scores.ndim != len(regularisers):
        raise ValueError(f"{scores.ndim}-d scores need {scores.ndim} regularisers, got {len(regularisers)}")
    tied = np.argwhere(scores >= np.nanmax(scores) - tolerance)  # (n_tied, k), NaN never ties
    keys = [np.asarray(grid, dtype=np.float64)[tied[:, axis]] for axis, grid in enumerate(regularisers)]
    first = np.lexsort([-key for key in reversed(keys)])[0]  # lexsort's last key is the primary one
    return tuple(int(i) for i in tied[first])
