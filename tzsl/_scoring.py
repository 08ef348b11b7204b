"""Predict-time arithmetic of the zero-shot models in numpy alone (importing it never imports scikit-learn).

The estimators of :mod:`tzsl.models` and the load-once predictor of :mod:`tzsl.inference` share
these functions, so a bundle whose model is a linear map (ESZSL, SAE, ALE, SJE, DeViSE: stored as
arrays, :mod:`tzsl.inference.model_bundles`) ranks classes exactly as its estimator does, without
importing scikit-learn (most of a cold process's start):

* :func:`linear_embedding`: standardise and map features to attribute space;
* :func:`compatibility_scores`, :func:`squared_distances`, :func:`cosine_similarities`: class
  scores of the decision rules (:class:`tzsl.models.CompatibilityRule`,
  :class:`tzsl.models.NearestAttributeRule`);
* :func:`softmax_rows`, :func:`tempered_proba`: class posteriors (with a calibrator's temperature);
* :func:`sc_mdap`: multi-grasp decision fusion (DAP paper section 5.7.3).
"""

from __future__ import annotations

from numbers import Integral

import numpy as np

from tzsl.exceptions import ConfigError

__all__ = ["compatibility_scores", "cosine_similarities", "linear_embedding", "sc_mdap", "softmax_rows",
           "squared_distances", "tempered_proba"]


def linear_embedding(X: np.ndarray, weights: np.ndarray, mean: np.ndarray | None = None,
                     scale: np.ndarray | None = None) -> np.ndarray:
    """Attribute-space scores of a linear embedding, ``((X - mean) / scale) @ weights``.

    Parameters
    ----------
    X : ndarray of shape (n_trials, n_features)
        Features in the units the model was fitted with (float64).
    weights : ndarray of shape (n_features, n_attributes)
    mean, scale : ndarray of shape (n_features,), optional
        The standardisation fitted on the training trials (a
        :class:`~sklearn.preprocessing.StandardScaler`'s ``mean_`` and ``scale_``, applied the
        same way); None: the features are used as they are.

    Returns
    -------
    ndarray of shape (n_trials, n_attributes)
    """
    if mean is not None:
        X = (X - mean) / scale
    return X @ weights


def compatibility_scores(F: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Bilinear compatibility ``F K^T`` of attribute-space scores with class rows.

    Parameters
    ----------
    F : ndarray of shape (n_trials, n_attributes)
    K : ndarray of shape (n_classes, n_attributes)

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
    """
    return F @ K.T


def squared_distances(F: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Squared Euclidean distances between rows, ``||f_i - l_c||^2``.

    Parameters
    ----------
    F : ndarray of shape (n, m)
    L : ndarray of shape (k, m)

    Returns
    -------
    ndarray of shape (n, k)
    """
    return (F**2).sum(axis=1)[:, None] - 2.0 * F @ L.T + (L**2).sum(axis=1)[None, :]


def cosine_similarities(F: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Cosine similarity of estimated attribute vectors with class rows.

    Parameters
    ----------
    F : ndarray of shape (n_trials, n_attributes)
    K : ndarray of shape (n_classes, n_attributes)

    Returns
    -------
    ndarray of shape (n_trials, n_classes), values in [-1, 1]
        An all-zero vector (either side) has similarity 0 to everything.
    """
    nf = np.linalg.norm(F, axis=1, keepdims=True)
    nk = np.linalg.norm(K, axis=1, keepdims=True)
    return (F / np.where(nf > 0, nf, 1.0)) @ (K / np.where(nk > 0, nk, 1.0)).T


def softmax_rows(scores: np.ndarray) -> np.ndarray:
    """Softmax along the last axis (the classes), shifted by the row maximum; rows sum to 1.

    The same arithmetic as ``scipy.special.softmax(scores, axis=-1)``.
    """
    shifted = np.exp(scores - np.max(scores, axis=-1, keepdims=True))
    return shifted / np.sum(shifted, axis=-1, keepdims=True)


def tempered_proba(scores, temperature: float) -> np.ndarray:
    """``softmax(scores / temperature)`` over the classes.

    Parameters
    ----------
    scores : array-like of shape (n_trials, n_classes)
        Class scores (larger is better; DAP: log-posteriors up to a per-trial constant).
    temperature : float > 0

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
        Rows sum to 1.
    """
    return softmax_rows(np.asarray(scores, dtype=np.float64) / float(temperature))


def sc_mdap(decisions: np.ndarray, k_equal: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SC-MDAP: stop at the first class decided ``k_equal`` times.

    Parameters
    ----------
    decisions : array-like of int, shape (..., T)
        Per-grasp class decisions (class indices >= 0, e.g. LDAP argmax), in grasp order.
    k_equal : int
        Number of equal classifications required (``k`` in the paper); ``k_equal = 1`` returns
        the first grasp's decision.

    Returns
    -------
    decision : ndarray of int, shape (...,)
        The class that first reached ``k_equal`` decisions; for undecided sequences the most
        frequent class (ties: the class reaching that count earliest).
    n_used : ndarray of int, shape (...,)
        Grasps used: position (1-based) of the grasp that completed ``k_equal`` decisions, or
        ``T`` when undecided.
    decided : ndarray of bool, shape (...,)
        Whether some class reached ``k_equal`` within the ``T`` grasps.
    """
    d = np.asarray(decisions)
    if d.ndim < 1 or d.shape[-1] < 1:
        raise ConfigError(f"decisions must have shape (..., T) with T >= 1, got {d.shape}")
    if not np.issubdtype(d.dtype, np.integer) or (d < 0).any():
        raise ConfigError("decisions must be non-negative integer class indices")
    if not isinstance(k_equal, Integral) or k_equal < 1:
        raise ConfigError(f"k_equal must be a positive integer, got {k_equal!r}")
    lead, T = d.shape[:-1], d.shape[-1]
    flat = d.reshape(-1, T)
    n = flat.shape[0]
    n_classes = int(flat.max()) + 1
    counts = np.zeros((n, T, n_classes), dtype=np.int64)
    counts[np.arange(n)[:, None], np.arange(T)[None, :], flat] = 1
    counts = counts.cumsum(axis=1)  # votes of every class after grasp t
    own = np.take_along_axis(counts, flat[..., None], axis=2)[..., 0]  # votes of the grasp's class
    hit = own == k_equal  # grasp t gives its class its k-th vote
    decided = hit.any(axis=1)
    first = np.argmax(hit, axis=1)
    decision = flat[np.arange(n), first]
    n_used = first + 1
    if not decided.all():
        und = ~decided
        final = counts[und, -1]  # (n_und, n_classes)
        top = final.max(axis=1)
        # grasp at which each class reached the top count (T if never)
        reached = counts[und] == top[:, None, None]
        when = np.where(reached.any(axis=1), np.argmax(reached, axis=1), T)
        when = np.where(final == top[:, None], when, T + 1)
        decision[und] = np.argmin(when, axis=1)
        n_used[und] = T
    return decision.reshape(lead), n_used.reshape(lead), decided.reshape(lead)
