"""Generalised zero-shot (GZSL) protocol pieces: held-out seen-class trials, calibrated stacking.

:func:`holdout_trials` decides which trials of the training objects are held out as seen-class
test trials; :func:`stacked_predict` and :func:`choose_stacking_constant` are calibrated stacking
(Chao et al., ECCV 2016): a constant ``gamma`` subtracted from every seen class's score before
the argmax, chosen to maximise the harmonic mean of seen and unseen per-class mean accuracy
(:func:`tzsl.evaluation.gzsl_scores`) on labelled calibration data. The study that composes
them is :mod:`tzsl.studies.zero_shot.gzsl`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["choose_stacking_constant", "holdout_trials", "stacked_predict"]


def holdout_trials(objects: np.ndarray, holdout_objects: Sequence[str], fraction: float,
                   rng: np.random.Generator) -> np.ndarray:
    """Hold out ``round(fraction * n)`` random trials (1 .. n-1) of every object in ``holdout_objects``
    that has two trials or more (an object with one trial is kept whole: holding it out would leave
    its class no training trial from it).

    Parameters
    ----------
    objects : ndarray of shape (n_trials,)
        Object of every trial.
    holdout_objects : sequence of str
    fraction : float in (0, 1)
    rng : numpy Generator

    Returns
    -------
    ndarray of shape (n_trials,), bool
        True for held-out trials; none of an object with a single trial.
    """
    objects = np.asarray(objects)
    member = np.isin(objects, list(holdout_objects))
    _names, inverse, counts = np.unique(objects[member], return_inverse=True, return_counts=True)
    n_hold = np.clip(np.rint(fraction * counts).astype(int), 1, counts - 1)  # 0 for a single trial
    # random rank of every trial within its object: sort by (object, random key)
    keys = rng.random(inverse.size)
    order = np.lexsort((keys, inverse))
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.empty(inverse.size, dtype=int)
    rank[order] = np.arange(inverse.size) - np.repeat(starts, counts)
    out = np.zeros(objects.size, dtype=bool)
    out[np.flatnonzero(member)] = rank < n_hold[inverse]
    return out


def stacked_predict(scores: np.ndarray, seen: np.ndarray, gamma: float = 0.0) -> np.ndarray:
    """Argmax of ``scores - gamma * seen``: (n, n_classes) scores, (n_classes,) bool -> (n,) class."""
    return np.argmax(scores - gamma * seen[None, :].astype(float), axis=1)


def choose_stacking_constant(scores: np.ndarray, y: np.ndarray, seen: np.ndarray) -> float:
    """The calibrated-stacking constant maximising the harmonic mean on labelled data.

    With ``gamma`` subtracted from the seen classes, sample ``i`` is predicted as its best seen
    class while ``gamma < d_i = max_seen - max_unseen`` and as its best unseen class beyond, so
    the harmonic mean is piecewise constant in ``gamma`` with breaks at the ``d_i``. Every piece
    is scored at once (midpoints between sorted breaks, below the first and above the last);
    ties go to the ``gamma`` closest to 0.

    Parameters
    ----------
    scores : ndarray of shape (n, n_classes)
    y : ndarray of shape (n,), int
        True class of each sample (index into the columns of ``scores``).
    seen : ndarray of shape (n_classes,), bool

    Returns
    -------
    float
    """
    seen = np.asarray(seen, dtype=bool)
    y = np.asarray(y)
    best_seen = np.argmax(np.where(seen, scores, -np.inf), axis=1)
    best_unseen = np.argmax(np.where(seen, -np.inf, scores), axis=1)
    rows = np.arange(len(y))
    d = scores[rows, best_seen] - scores[rows, best_unseen]
    breaks = np.unique(d)
    candidates = np.concatenate([[breaks[0] - 1.0], (breaks[:-1] + breaks[1:]) / 2, [breaks[-1] + 1.0], [0.0]])
    correct = np.where(candidates[:, None] < d[None, :], best_seen == y, best_unseen == y)  # (g, n)
    # per-class mean accuracy of each group = sum of correct weighted by 1 / (class size * n classes)
    y_seen = seen[y]
    scores_by_group = []
    for mask in (y_seen, ~y_seen):
        classes, inv, counts = np.unique(y[mask], return_inverse=True, return_counts=True)
        w = 1.0 / (counts[inv] * len(classes))
        scores_by_group.append(correct[:, mask].astype(float) @ w)
    s, u = scores_by_group
    with np.errstate(invalid="ignore", divide="ignore"):
        h = np.where(s + u > 0, 2 * s * u / (s + u), 0.0)
    best = np.flatnonzero(np.isclose(h, h.max(), rtol=0, atol=1e-12))
    return float(candidates[best[np.argmin(np.abs(candidates[best]))]])
