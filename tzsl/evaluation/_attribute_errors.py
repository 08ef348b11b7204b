"""Whether an object's attributes are mispredicted together: the within-object correlation of attribute errors.

DAP multiplies one posterior per attribute, so its accuracy depends not only on how often each
attribute is wrong but on whether the errors of one test object pile up on it together. With
errors independent across attributes, per-attribute balanced accuracies of 0.7 would let DAP
recognise most objects; when an unseen object's attributes are mispredicted together (its
features resemble one training object, whose attributes are then predicted as a block), the
object is lost however good the average attribute is.

:func:`within_object_error_correlation` measures that sharing: each object's error rate on each
attribute, then the correlation between attributes of those rates across objects, pooled over
attribute pairs (the correlation of the attribute-error "item scores" of psychometrics).
"""

from __future__ import annotations

import numpy as np

from tzsl.exceptions import TzslError

__all__ = ["within_object_error_correlation"]


def within_object_error_correlation(A_true, A_pred, groups, *, level: str = "object") -> float:
    """Pooled correlation, across objects, of different attributes' error rates on the same object.

    For object ``o`` and attribute ``m`` let ``r[o, m]`` be the mean over the object's trials of
    the error ``|A_pred - A_true|`` (the 0/1 error for 0/1 predictions, ``1 - p(true value)`` for
    posteriors). With ``C`` the covariance matrix of the columns of ``r`` over objects (each object
    once; with ``level="trial"`` over trials, ``r`` the trials' own errors), the result is

        rho = sum_{m != m'} C[m, m'] / sum_{m != m'} sqrt(C[m, m] C[m', m'])

    the average inter-attribute correlation with each pair weighted by its spread. 0: errors fall
    on objects independently across attributes; 1: an object that is mispredicted on one attribute
    is equally mispredicted on all (every attribute's error rate moves with one object effect);
    negative: errors avoid each other. Attributes whose error rate is the same on every object
    carry no information and drop out of both sums.

    Parameters
    ----------
    A_true : array-like of shape (n_trials, n_attributes)
        True 0/1 attributes of each trial (its object's row).
    A_pred : array-like of shape (n_trials, n_attributes)
        Predicted 0/1 attributes or posteriors ``p(a_m = 1 | x)`` in [0, 1].
    groups : array-like of shape (n_trials,)
        Object of each trial.
    level : {"object", "trial"}, default="object"
        ``"object"``: the units are objects (their mean errors), so the result says whether some
        objects are mispredicted on many attributes at once and others on few. ``"trial"``: the
        units are trials, so it also counts errors that co-occur within one trial.

    Returns
    -------
    float
        In [-1, 1]; NaN when fewer than 2 objects, or fewer than 2 attributes whose error rate
        varies over objects.

    Raises
    ------
    TzslError
        Shapes disagree, or values outside [0, 1] / non-finite.
    """
    T = np.asarray(A_true, dtype=np.float64)
    P = np.asarray(A_pred, dtype=np.float64)
    g = np.asarray(groups).ravel()
    if T.ndim != 2 or T.shape != P.shape or g.shape != (T.shape[0],):
        raise TzslError(f"A_true {T.shape}, A_pred {P.shape} and groups {g.shape} must be (n, m), (n, m) and (n,)")
    if level not in ("object", "trial"):
        raise TzslError(f"level must be 'object' or 'trial', got {level!r}")
    for name, M in (("A_true", T), ("A_pred", P)):
        if not (np.isfinite(M).all() and (M >= 0).all() and (M <= 1).all()):
            raise TzslError(f"{name} must hold values in [0, 1]")
    _, codes = np.unique(g, return_inverse=True)
    codes = codes.ravel()
    n_objects = int(codes.max()) + 1 if codes.size else 0
    if n_objects < 2:
        return float("nan")
    errors = np.abs(P - T)
    if level == "trial":
        rates = errors
    else:
        rates = np.zeros((n_objects, T.shape[1]))
        np.add.at(rates, codes, errors)
        rates /= np.bincount(codes, minlength=n_objects)[:, None]
    C = np.cov(rates, rowvar=False)
    C = np.atleast_2d(C)
    sd = np.sqrt(np.clip(np.diag(C), 0.0, None))
    off = ~np.eye(C.shape[0], dtype=bool)
    denominator = (np.outer(sd, sd)[off]).sum()
    if np.count_nonzero(sd > 0) < 2 or denominator <= 0:
        return float("nan")
    return float(C[off].sum() / denominator)
