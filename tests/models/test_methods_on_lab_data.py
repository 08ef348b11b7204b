"""Every registered method on data as labs record it (issue 31): a property test.

Drawn datasets are SIMULATED (attribute rows at random, features a noisy linear image of the rows)
with the pathologies of real recordings: constant and near-constant channels, huge and tiny scales,
perfectly separable attributes (detectors answer exactly 0 and 1), one trial per class, identical
attribute rows among training classes, 8 to 100 classes. Each registered method (every method that
takes feature arrays) either ranks the unseen classes with valid posteriors, or refuses in one line
(a :class:`~tzsl.exceptions.TzslError`) with plain numbers: never an exception of another kind, a NaN
or a probability outside [0, 1].

A reduced draw runs in CI (:data:`CI_LIMITS`); ``make test-wide`` (``TZSL_WIDE_PROPERTY_TEST=1``) draws
the full range with more examples.
"""

from __future__ import annotations

import os
import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from tzsl.exceptions import TzslError
from tzsl.models import available_methods, build_method, get_method

WIDE_ENV = "TZSL_WIDE_PROPERTY_TEST"
WIDE = bool(os.environ.get(WIDE_ENV))
#: (max classes, max attributes, examples) of the CI draw and of the wide draw.
CI_LIMITS = (16, 8, 3)
WIDE_LIMITS = (100, 40, 40)
MAX_CLASSES, MAX_ATTRIBUTES, EXAMPLES = WIDE_LIMITS if WIDE else CI_LIMITS
NUMPY_REPR = re.compile(r"np\.\w+\(")


def feature_methods() -> list[str]:
    """Registered methods that take feature arrays (the hand's grasps and the video frames aside)."""
    return [name for name in available_methods() if get_method(name).input_kind == "features"]


def lab_like_dataset(n_classes: int, n_attributes: int, n_sensors: int, *, seed: int, trials_per_class: int,
                     scale_exponent: int, constant_channel: bool, near_constant_channel: bool, separable: bool,
                     identical_rows: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A SIMULATED dataset with the drawn pathologies.

    Returns
    -------
    X : ndarray of shape (n_trials, n_sensors, n_features)
    K : ndarray of shape (n_classes, n_attributes), 0/1
    y : ndarray of shape (n_trials,), class index
    n_unseen : int
        The last ``n_unseen`` classes are unseen; their rows differ from every training row.
    """
    rng = np.random.default_rng(seed)
    n_unseen = max(2, n_classes // 4)
    K = (rng.random((n_classes, n_attributes)) < 0.4).astype(float)
    n_train = n_classes - n_unseen
    for k in range(min(identical_rows, n_train // 2)):  # training classes sharing a row
        K[2 * k + 1] = K[2 * k]
    train_rows = {tuple(r) for r in K[:n_train]}
    for c in range(n_train, n_classes):  # zero-shot: an unseen row is no training row
        while tuple(K[c]) in train_rows:
            K[c] = (rng.random(n_attributes) < 0.5).astype(float)
    y = np.repeat(np.arange(n_classes), trials_per_class)
    n_features = 4
    W = rng.normal(size=(n_sensors, n_attributes, n_features))
    noise = 0.0 if separable else 0.5
    X = np.einsum("na,saf->nsf", K[y], W) + noise * rng.normal(size=(len(y), n_sensors, n_features))
    if separable:  # the attribute rows themselves: each attribute perfectly separable
        X = np.concatenate([X, np.repeat(K[y][:, None, :], n_sensors, axis=1)], axis=2)
    X = X * 10.0 ** scale_exponent
    extra = []
    if constant_channel:
        extra.append(np.full((len(y), n_sensors, 1), 42.0))
    if near_constant_channel:
        extra.append(1.0 + 1e-12 * rng.normal(size=(len(y), n_sensors, 1)))
    if extra:
        X = np.concatenate([X, *extra], axis=2)
    return X, K, y, n_unseen


def check_method(name: str, X: np.ndarray, K: np.ndarray, y: np.ndarray, n_unseen: int) -> None:
    """Fit ``name`` on the seen classes; its posteriors over the unseen classes must be valid."""
    method = get_method(name)
    Xi = X if method.input_ndim == 3 else X.reshape(len(X), -1)
    n_classes = len(K)
    train = y < n_classes - n_unseen
    clf = build_method(name, random_state=0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            clf.fit(Xi[train], K[y[train]], y[train])
            proba = clf.predict_proba(Xi[~train], K[-n_unseen:])
            predicted = clf.predict(Xi[~train], K[-n_unseen:])
    except TzslError as exc:  # a refusal: one line, plain numbers
        text = str(exc)
        assert text and "\n" not in text.strip() and not NUMPY_REPR.search(text), f"{name}: {text}"
        return
    assert proba.shape == ((~train).sum(), n_unseen), name
    assert np.all(np.isfinite(proba)) and np.all((proba >= 0) & (proba <= 1)), name
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-9, err_msg=name)
    assert predicted.shape == ((~train).sum(),) and set(np.unique(predicted)) <= set(range(n_unseen)), name


@pytest.mark.parametrize("name", feature_methods())
@settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(n_classes=st.integers(8, MAX_CLASSES), n_attributes=st.integers(3, MAX_ATTRIBUTES),
       n_sensors=st.integers(1, 3), seed=st.integers(0, 2**16), trials_per_class=st.integers(1, 4),
       scale_exponent=st.sampled_from([-6, 0, 6]), constant_channel=st.booleans(),
       near_constant_channel=st.booleans(), separable=st.booleans(), identical_rows=st.integers(0, 3))
@example(n_classes=8, n_attributes=3, n_sensors=1, seed=0, trials_per_class=1, scale_exponent=6,
         constant_channel=True, near_constant_channel=True, separable=True, identical_rows=3)
@example(n_classes=MAX_CLASSES, n_attributes=MAX_ATTRIBUTES, n_sensors=3, seed=1, trials_per_class=2,
         scale_exponent=-6, constant_channel=True, near_constant_channel=False, separable=False, identical_rows=1)
def test_every_method_ranks_unseen_classes_of_lab_like_data_or_refuses_in_one_line(
        name, n_classes, n_attributes, n_sensors, seed, trials_per_class, scale_exponent, constant_channel,
        near_constant_channel, separable, identical_rows):
    X, K, y, n_unseen = lab_like_dataset(
        n_classes, n_attributes, n_sensors, seed=seed, trials_per_class=trials_per_class,
        scale_exponent=scale_exponent, constant_channel=constant_channel,
        near_constant_channel=near_constant_channel, separable=separable, identical_rows=identical_rows)
    check_method(name, X, K, y, n_unseen)
