"""Probabilities that cannot break a run: the one place posteriors are made valid.

Floating-point arithmetic can push a probability a hair outside [0, 1]: IAP's
``p(z | x) @ A`` exceeds 1 in the last bit when an attribute is present in every likely class,
and a float32 network's softmax sums to 1 within float32's epsilon. Such rounding is not an error: every
producer of attribute posteriors and every decision rule passes its output through
:func:`valid_probabilities` (values within :data:`ROUNDING_TOLERANCE` of [0, 1] are clipped into it),
and class posteriors come from :func:`class_posteriors` (a softmax whose rows are checked and
renormalised). A value further out, or NaN, is a real fault: it raises a
:class:`~tzsl.exceptions.ConfigError` whose message names the array, the position and the value in
plain numbers (``trial 115, attribute 1: 1.5``), which a study records against its split and method.
"""

from __future__ import annotations

import numpy as np
from scipy.special import softmax

from tzsl.exceptions import ConfigError

__all__ = ["ROUNDING_TOLERANCE", "class_posteriors", "valid_probabilities"]

#: How far outside [0, 1] a probability may stray by rounding and still be clipped into it (float32's
#: machine epsilon is 1.2e-7; a float64 sum of products strays by a few 1e-16).
ROUNDING_TOLERANCE = 1e-6

#: Names of the axes of a posterior array, by its number of dimensions.
_AXES = {1: ("trial",), 2: ("trial", "attribute"), 3: ("trial", "sensor", "attribute")}


def _position(index: tuple[int, ...], axes: tuple[str, ...]) -> str:
    """``"trial 115, attribute 1"``: an array index in words, plain integers."""
    return ", ".join(f"{name} {int(i)}" for name, i in zip(axes, index))


def valid_probabilities(P, what: str = "attribute posteriors", *, axes: tuple[str, ...] | None = None) -> np.ndarray:
    """``P`` as float64 in [0, 1], rounding clipped; NaN or a real excursion raises.

    Parameters
    ----------
    P : array-like of shape (n_trials,), (n_trials, n_attributes) or (n_trials, n_sensors, n_attributes)
        Probabilities (unitless).
    what : str
        What ``P`` is, for the error message.
    axes : tuple of str, optional
        Names of ``P``'s axes for the error message; default ``trial[, sensor], attribute``.

    Returns
    -------
    ndarray of the shape of ``P``, float64
        ``P`` with values in ``[-ROUNDING_TOLERANCE, 0)`` set to 0 and in ``(1, 1 + ROUNDING_TOLERANCE]``
        set to 1. A new array only when something was clipped or converted.

    Raises
    ------
    ConfigError
        A NaN, or a value further than :data:`ROUNDING_TOLERANCE` outside [0, 1]; the message names
        the first such position and value in plain numbers.
    """
    P = np.asarray(P, dtype=np.float64)
    inside = (P >= 0.0) & (P <= 1.0)  # False for NaN
    if inside.all():
        return P
    near = (P >= -ROUNDING_TOLERANCE) & (P <= 1.0 + ROUNDING_TOLERANCE)
    if not near.all():
        index = tuple(int(i) for i in np.argwhere(~near)[0])
        names = axes if axes is not None else _AXES.get(P.ndim, tuple(f"axis {k}" for k in range(P.ndim)))
        value = float(P[index])
        raise ConfigError(f"{what} must lie in [0, 1]; found {value!r} at {_position(index, names)}")
    return np.clip(P, 0.0, 1.0)


def class_posteriors(scores, temperature: float = 1.0) -> np.ndarray:
    """``softmax(scores / temperature)`` over the classes: rows in [0, 1] that sum to 1.

    Parameters
    ----------
    scores : array-like of shape (n_trials, n_classes)
        Class scores, larger is better (DAP: log-posteriors up to a per-trial constant). ``-inf``
        is allowed (a class that cannot be) as long as each row has a finite score.
    temperature : float > 0
        Divides the scores (1: the method's own softmax).

    Returns
    -------
    ndarray of shape (n_trials, n_classes), float64
        Class posteriors; each row sums to 1 up to rounding.

    Raises
    ------
    ConfigError
        A NaN or ``+inf`` score, or a row without any finite score (the message names the trial and
        class in plain numbers).
    """
    S = np.asarray(scores, dtype=np.float64)
    if S.ndim != 2:
        raise ConfigError(f"class scores must have 2 dimensions (trials x classes), got shape {S.shape}")
    bad = np.isnan(S) | (S == np.inf)
    if bad.any():
        trial, cls = (int(i) for i in np.argwhere(bad)[0])
        raise ConfigError(f"class scores must be numbers or -inf; found {float(S[trial, cls])!r} at trial {trial}, "
                          f"class {cls}")
    if S.shape[1] and not np.isfinite(S).any(axis=1).all():
        trial = int(np.flatnonzero(~np.isfinite(S).any(axis=1))[0])
        raise ConfigError(f"class scores of trial {trial} are -inf for every class: no class can be ranked")
    with np.errstate(over="ignore"):  # scores a float range apart: exp underflows to 0, as it should
        P = softmax(S / float(temperature), axis=1)
    return valid_probabilities(P, "class posteriors", axes=("trial", "class"))
