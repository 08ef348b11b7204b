"""Registry methods inside a study: one timed fit-and-predict for any method of ``tzsl methods``.

A study lists methods as ``{"name": registry name, **parameters}`` (the experiment file's
``methods.compare``, checked at load time). Every study kind fits them the same way, through
:func:`fit_predict`:

* input shape from the registry (:attr:`tzsl.models.Method.input_ndim`): per-sensor methods get
  ``(n_trials, n_sensors, n_features)``, the others the sensors side by side
  ``(n_trials, n_sensors * n_features)``; a 2-D study input is one sensor for a per-sensor method;
* seed: a method whose estimator takes ``random_state`` gets the study's seed for that fit,
  unless the entry sets ``random_state`` itself; deterministic methods get none;
* fit on the training trials with their attribute rows (:func:`tzsl.models.attribute_rows`),
  predict the test trials among the test classes' attribute rows (zero-shot).
"""

from __future__ import annotations

import inspect
import time
from typing import NamedTuple

import numpy as np

from tzsl.experiments.config import method_label
from tzsl.models import attribute_rows, get_method

__all__ = ["MethodFit", "fit_predict", "method_input", "method_label", "study_estimator", "takes_seed"]


def takes_seed(spec: dict) -> bool:
    """Whether the study seeds this entry: its estimator takes ``random_state`` and the entry sets none."""
    method = get_method(spec["name"])
    first = method.estimator if method.estimator is not None else method.attribute_model
    return "random_state" not in spec and "random_state" in inspect.signature(first).parameters


def study_estimator(spec: dict, seed: int | None):
    """An unfitted estimator of the method entry ``spec``, seeded with ``seed`` where it is random."""
    params = {k: v for k, v in spec.items() if k != "name"}
    if seed is not None and takes_seed(spec):
        params["random_state"] = int(seed)
    return get_method(spec["name"]).build(**params)


def method_input(spec: dict, X: np.ndarray) -> np.ndarray:
    """``X`` shaped for the method: 3-D ``(n, sensors, features)`` or 2-D ``(n, sensors * features)``."""
    X = np.asarray(X)
    if get_method(spec["name"]).input_ndim == 3:
        return X if X.ndim == 3 else X[:, None, :]
    return X.reshape(X.shape[0], -1)


class MethodFit(NamedTuple):
    """One fit of one method: the fitted estimator, predicted test rows, wall-clock fit seconds."""

    model: object
    predicted: np.ndarray
    fit_seconds: float


def fit_predict(spec: dict, X_train: np.ndarray, classes_train: np.ndarray, class_rows: np.ndarray,
                X_test: np.ndarray, test_rows: np.ndarray, seed: int | None = None) -> MethodFit:
    """Fit the method on training trials; predict test trials among the test classes.

    Parameters
    ----------
    spec : dict
        ``{"name": registry name, **parameters}``.
    X_train : ndarray of shape (n_train, d) or (n_train, n_sensors, d)
    classes_train : ndarray of shape (n_train,)
        Training class (object or group) of each trial; also the CV groups.
    class_rows : ndarray of shape (n_train_classes, m)
        Attribute rows of ``np.unique(classes_train)``, in that order.
    X_test : ndarray of shape (n_test, ...) like ``X_train``
    test_rows : ndarray of shape (n_test_classes, m)
        The candidate (test) classes' attribute rows.
    seed : int or None

    Returns
    -------
    MethodFit
        ``predicted``: row of ``test_rows`` of every test trial, shape (n_test,).
    """
    model = study_estimator(spec, seed)
    start = time.perf_counter()
    model.fit(method_input(spec, X_train), attribute_rows(classes_train, class_rows), classes_train)
    seconds = time.perf_counter() - start
    return MethodFit(model, np.asarray(model.predict(method_input(spec, X_test), test_rows)), seconds)
