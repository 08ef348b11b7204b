"""A temperature for a zero-shot method's class posteriors, fitted on pseudo-unseen training classes.

Class posteriors built from attribute scores (DAP's product over attributes, softmaxes over
compatibility scores) are rarely frequencies. :class:`TemperatureCalibratedZSL` composes any
zero-shot estimator and returns ``softmax(log p / T)`` for its posterior ``p``: ``T > 1`` softens
an over-confident method, ``T < 1`` sharpens a timid one, and the ranking (so ``predict`` and
every accuracy) is unchanged.

``T`` is chosen on the training data only, as a zero-shot method meets its test classes:
class-grouped folds of the training classes (:func:`tzsl.models.class_grouped_folds`) each hold
some classes out; the method is refitted on the others and scores the held-out trials among the
held-out classes' attribute rows (pseudo-unseen classes). ``T`` minimises the log-loss of those
scores; the method is then refitted on every training trial. A fold leaves out the attributes
its training objects cannot teach (fewer than 2 positive or negative objects), as a split does.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.special import log_softmax, softmax
from sklearn.base import BaseEstimator, clone
from sklearn.utils._param_validation import HasMethods, Interval
from sklearn.utils.validation import check_is_fitted

from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models._zsl_input import class_grouped_folds, training_classes

__all__ = ["TemperatureCalibratedZSL", "fit_temperature"]

#: Floor of a posterior before its log (a method may give exact zeros).
_EPS = 1e-12


def fit_temperature(log_proba: list[np.ndarray], y: list[np.ndarray]) -> float:
    """The ``T`` minimising the mean log-loss of ``softmax(log_proba / T)``.

    Parameters
    ----------
    log_proba : list of ndarray, each (n_trials_f, n_classes_f)
        Log posteriors of held-out trials over their fold's candidate classes.
    y : list of ndarray, each (n_trials_f,)
        True column of every trial.

    Returns
    -------
    float
        ``T`` in [exp(-5), exp(5)] (searched on log T).
    """
    def loss(log_t: float) -> float:
        t = np.exp(log_t)
        total = sum(-log_softmax(lp / t, axis=1)[np.arange(len(yy)), yy].sum() for lp, yy in zip(log_proba, y))
        return float(total / sum(len(yy) for yy in y))

    return float(np.exp(minimize_scalar(loss, bounds=(-5.0, 5.0), method="bounded").x))


def _trainable_attributes(Y: np.ndarray, units: np.ndarray, minimum: int = 2) -> np.ndarray:
    """Attributes (mask, (n_attributes,)) with ``minimum`` positive and negative objects among ``units``.

    A fold that holds classes out can leave an attribute with one positive training object, which
    attribute classifiers tuned by object-grouped CV cannot fit: the fold leaves it out, as a
    split does (:func:`tzsl.evaluation.random_object_splits`).
    """
    _, first = np.unique(units, return_index=True)
    rows = Y[first]
    positives = rows.sum(axis=0)
    keep = (positives >= minimum) & (len(rows) - positives >= minimum)
    return keep if keep.any() else np.ones(Y.shape[1], dtype=bool)


class TemperatureCalibratedZSL(ValidatedParamsMixin, BaseEstimator):
    """A zero-shot estimator with tempered class posteriors (see the module docstring).

    Parameters
    ----------
    estimator : zero-shot estimator
        Fits ``(X, Y, groups)`` with ``Y`` the attribute row of each trial's class and predicts
        ``predict_proba(X, class_attributes)``, shape (n_trials, n_classes) (every method of
        :func:`tzsl.models.build_method`).
    n_folds : int, default=3
        Class-grouped folds of the training classes (at most half the classes).
    random_state : int, RandomState or None
        Kept for the estimator protocol; the folds are deterministic.

    Attributes
    ----------
    estimator_ : estimator
        Fitted on every training trial.
    temperature_ : float
        The fitted ``T``.
    n_pseudo_unseen_ : int
        Held-out (pseudo-unseen) training classes the temperature was fitted on, over all folds.
    """

    _parameter_constraints = {
        "estimator": [HasMethods(["fit", "predict_proba"])],
        "n_folds": [Interval(Integral, 2, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(self, *, estimator=None, n_folds: int = 3, random_state=None) -> None:
        self.estimator = estimator
        self.n_folds = n_folds
        self.random_state = random_state

    def fit(self, X, Y, groups=None) -> TemperatureCalibratedZSL:
        """Fit ``T`` on pseudo-unseen training classes, then the estimator on every trial.

        Parameters
        ----------
        X : array-like of shape (n_trials, ...)
            Whatever ``estimator`` takes.
        Y : array-like of shape (n_trials, n_attributes)
            Attribute row of each trial's class.
        groups : array-like of shape (n_trials,), optional
            Object or class of each trial (passed on to ``estimator``).
        """
        self._validate_params()
        X, Y = np.asarray(X), np.asarray(Y)
        groups = None if groups is None else np.asarray(groups)
        name = type(self).__name__
        S, y = training_classes(Y, name, groups)
        log_proba, truth, held_out = [], [], 0
        units = y if groups is None else groups  # the objects an attribute model counts positives over
        for train, val in class_grouped_folds(y, self.n_folds, name):
            classes = np.unique(y[val])
            keep = _trainable_attributes(Y[train], units[train])
            model = clone(self.estimator).fit(X[train], Y[train][:, keep], None if groups is None else groups[train])
            P = np.asarray(model.predict_proba(X[val], S[classes][:, keep]))
            log_proba.append(np.log(np.clip(P, _EPS, None)))
            truth.append(np.searchsorted(classes, y[val]))
            held_out += len(classes)
        self.temperature_ = fit_temperature(log_proba, truth)
        self.n_pseudo_unseen_ = held_out
        self.estimator_ = clone(self.estimator).fit(X, Y, groups)
        return self

    def predict_proba(self, X, class_attributes) -> np.ndarray:
        """``softmax(log p / T)`` of the estimator's posterior ``p``, shape (n_trials, n_classes)."""
        check_is_fitted(self, "estimator_")
        P = np.asarray(self.estimator_.predict_proba(X, class_attributes))
        return softmax(np.log(np.clip(P, _EPS, None)) / self.temperature_, axis=1)

    def predict(self, X, class_attributes) -> np.ndarray:
        """The estimator's prediction (a temperature does not change the ranking), shape (n_trials,)."""
        check_is_fitted(self, "estimator_")
        return self.estimator_.predict(X, class_attributes)
