"""Direct Attribute Prediction (DAP) with sensor fusion, in log space and vectorised.

The functions here are the DAP arithmetic; :class:`tzsl.models.DAPRule` is the decision rule
that applies them inside :class:`tzsl.models.ZeroShotClassifier`. The predict-time part (checks,
priors, fusion, log-scores) is written in :mod:`tzsl._scoring`, in numpy alone, so that a DAP
bundle stored as arrays ranks classes with the same functions without importing scikit-learn;
it is re-exported here.

Equations refer to the DAP paper (``haptic_zsl_dap``):

* (3) ``p(z | x) ∝ prod_m p(a_m = a^z_m | x) / p(a_m = a^z_m)`` (uniform class prior); here as
  ``log p(z | x) = sum_m [log p(a_m = a^z_m | x) - log p(a_m = a^z_m)] + const``.
* (4) ``z(x) = argmax_z p(z | x)``.
* (5) MAXDAP: ``p(a_m = a^z_m | x) = max_b p(a_m = a^z_m | x_b)``. The maximum is taken over the
  posterior *of the value the class asks for*: for a class with ``a^z_m = 1`` it is
  ``max_b p(a_m = 1 | x_b)``, for ``a^z_m = 0`` it is ``max_b p(a_m = 0 | x_b) = 1 - min_b p(a_m = 1 | x_b)``.
  So the fused pair is not normalised, exactly as the paper writes it.
* (6) AVGDAP: ``p(a_m = a^z_m | x) = mean_b p(a_m = a^z_m | x_b)`` (normalised, value-independent).

Fusion is over attribute posteriors across sensors *before* DAP (the paper: "attributes posteriors
p(a|x_b1) and p(a|x_b2) must be combined to infer p(a|x)"), not over class posteriors.

Attribute priors ``p(a_m = 1)`` (§4.5): ``"train"`` = mean over training objects of their attribute
rows, ``"test"`` = mean over the test classes' rows of the class-attribute table, ``"uni"`` = 0.5.
"""

from __future__ import annotations

import numpy as np

from tzsl._parallel import one_blas_thread
from tzsl._scoring import (  # numpy alone, shared with the load-once predictor (tzsl.inference)
    DEFAULT_EPS,
    attribute_prior,
    check_attribute_posteriors,
    check_class_attributes,
    dap_attribute_terms,
    dap_log_scores,
    fuse_attribute_posteriors,
)
from tzsl.exceptions import ConfigError

__all__ = [
    "attribute_prior",
    "break_ties",
    "check_attribute_posteriors",
    "check_class_attributes",
    "dap_accuracy_over_subsets",
    "dap_log_scores",
    "fuse_attribute_posteriors",
]

def break_ties(scores, random_state=None) -> np.ndarray:
    """Row-wise argmax with exact ties broken uniformly at random (seeded).

    ``np.argmax`` always returns the first of tied classes, so a class listed early in the
    class table would win every tie. Here each of the tied classes is equally likely, so tied
    evidence is scored at its expected accuracy over many trials.

    Parameters
    ----------
    scores : array-like of shape (n, k)
    random_state : int, Generator or None

    Returns
    -------
    ndarray of shape (n,), int
    """
    scores = np.asarray(scores, dtype=float)
    top = scores == scores.max(axis=1, keepdims=True)
    if (top.sum(axis=1) == 1).all():
        return scores.argmax(axis=1)
    rng = np.random.default_rng(random_state)
    return np.where(top, rng.random(scores.shape) + 1.0, 0.0).argmax(axis=1)


def dap_accuracy_over_subsets(
    P, K, y, subsets, *, fusion: str = "avg", prior="uni", eps: float = DEFAULT_EPS, chunk: int = 256,
    per_trial: bool = False,
) -> np.ndarray:
    """DAP trial accuracy for many attribute subsets at once (paper §4.7, Fig. 4).

    Parameters
    ----------
    P : array-like of shape (n_trials, n_sensors, n_attributes) or (n_trials, n_attributes)
        Attribute posteriors ``p(a_m = 1 | x_s)`` of the test trials.
    K : array-like of shape (n_classes, n_attributes)
        Test classes' attribute table.
    y : array-like of shape (n_trials,)
        True class of each trial as a row index into ``K``.
    subsets : array-like of shape (n_subsets, n_attributes) bool, or (n_subsets, j) int
        Attribute subsets as masks or as column indices.
    fusion : {"avg", "max"}
    prior : {"uni", "test"} or array-like of shape (n_attributes,)
        ``"train"`` needs training rows: pass the array from :func:`attribute_prior`.
    eps : float
    chunk : int
        Subsets scored per numpy pass (bounds memory at ``chunk * n_trials * n_classes`` floats).
    per_trial : bool, default False
        Return every trial's outcome instead of the accuracy (for bootstrap intervals).

    Returns
    -------
    ndarray of shape (n_subsets,), or (n_subsets, n_trials) with ``per_trial``
        Fraction of trials whose argmax class equals ``y`` (with ``per_trial``: 1.0 where the
        trial's argmax class equals ``y``, else 0.0).
    """
    present, absent = fuse_attribute_posteriors(P, fusion)
    m = present.shape[1]
    K = check_class_attributes(K, m)
    y = np.asarray(y)
    if y.shape != (present.shape[0],) or y.min() < 0 or y.max() >= K.shape[0]:
        raise ConfigError(f"y must hold {present.shape[0]} row indices into the {K.shape[0]}-row class table")
    pr = attribute_prior(prior, class_attributes=K) if isinstance(prior, str) else attribute_prior(prior)
    if pr.shape != (m,):
        raise ConfigError(f"prior has {pr.size} entries for {m} attributes")
    subsets = np.asarray(subsets)
    if subsets.dtype == bool:
        if subsets.ndim != 2 or subsets.shape[1] != m:
            raise ConfigError(f"subset masks must have shape (n_subsets, {m}), got {subsets.shape}")
        mask = subsets.astype(float)
    else:
        if subsets.ndim != 2 or subsets.min() < 0 or subsets.max() >= m:
            raise ConfigError(f"subset indices must be (n_subsets, j) with values in [0, {m})")
        mask = np.zeros((subsets.shape[0], m))
        np.put_along_axis(mask, subsets.astype(np.intp), 1.0, axis=1)
    T = dap_attribute_terms(present, absent, K, pr, eps)  # (n, k, m)
    out = np.empty((mask.shape[0], len(y)) if per_trial else mask.shape[0])
    # one BLAS thread: the products are small, and on 2 cores threaded BLAS spent 5 times the CPU (and
    # wall) time of one thread on the PHAC-2 sweep; the outcomes no longer depend on the machine's cores
    with one_blas_thread():
        for start in range(0, mask.shape[0], chunk):
            S = np.einsum("nkm,rm->rnk", T, mask[start : start + chunk], optimize=True)
            hits = S.argmax(axis=2) == y[None, :]
            out[start : start + chunk] = hits if per_trial else hits.mean(axis=1)
    return out
