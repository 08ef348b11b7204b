"""Probabilities cannot break a run (issue 31): rounding is clipped in one place, real faults name
the position and value in plain numbers, and every registered method's posteriors stay valid at the
edges (posteriors of exactly 0 and 1, a sum of products one ulp above 1)."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from sklearn.base import BaseEstimator

from tzsl._scoring import ROUNDING_TOLERANCE, class_posteriors, valid_probabilities
from tzsl.exceptions import ConfigError, TzslError
from tzsl.models import IAP, DAPRule, ZeroShotClassifier, available_methods, build_method, get_method
from tzsl.models.dap import check_attribute_posteriors

#: Class posteriors of one trial whose dot product with a row of ones is 1.0000000000000002 in float64.
ROUNDS_ABOVE_ONE = [0.46335848984461653, 0.3373961461805628, 0.1992453639748208]
NUMPY_REPR = re.compile(r"np\.\w+\(")


def test_rounding_outside_the_unit_interval_is_clipped():
    P = np.array([[1.0000000000000002, -1e-17], [0.5, 1.0]])
    out = valid_probabilities(P)
    assert out.max() == 1.0 and out.min() == 0.0 and out[1, 0] == 0.5
    inside = np.array([[0.0, 1.0], [0.25, 0.75]])
    assert valid_probabilities(inside) is not None and np.array_equal(valid_probabilities(inside), inside)


@pytest.mark.parametrize(("value", "shown"), [(1.5, "1.5"), (-0.25, "-0.25"), (np.nan, "nan"),
                                               (1 + 10 * ROUNDING_TOLERANCE, None)])
def test_a_real_fault_names_position_and_value_in_plain_numbers(value, shown):
    P = np.full((4, 2, 3), 0.5)
    P[2, 1, 0] = value
    with pytest.raises(ConfigError) as info:
        check_attribute_posteriors(P)
    message = str(info.value)
    assert "trial 2, sensor 1, attribute 0" in message and not NUMPY_REPR.search(message), message
    if shown is not None:
        assert f"found {shown} " in message


def test_class_posteriors_rows_sum_to_one_and_faults_are_named():
    S = np.array([[0.0, -np.inf, 2.0], [1e308, -1e308, 0.0]])
    P = class_posteriors(S)
    assert P.shape == (2, 3) and np.all((P >= 0) & (P <= 1))
    np.testing.assert_allclose(P.sum(axis=1), 1.0)
    np.testing.assert_allclose(class_posteriors(S[:1], 2.0)[0, [0, 2]], np.exp([0.0, 1.0]) / np.exp([0.0, 1.0]).sum())
    with pytest.raises(ConfigError, match=r"found nan at trial 1, class 2"):
        class_posteriors(np.array([[0.0, 1.0, 2.0], [0.0, 1.0, np.nan]]))
    with pytest.raises(ConfigError, match=r"trial 0 are -inf for every class"):
        class_posteriors(np.full((1, 3), -np.inf))


class FixedClassPosteriors(BaseEstimator):
    """A classifier whose class posteriors are :data:`ROUNDS_ABOVE_ONE` for every trial."""

    def fit(self, X, y):
        self.classes_ = np.unique(y)
        return self

    def predict_proba(self, X):
        return np.tile(ROUNDS_ABOVE_ONE, (len(X), 1))


def test_iap_sum_of_products_one_ulp_above_one_is_clipped_and_the_rule_ranks():
    """The BioTac dataset's failure: IAP's ``p(z | x) @ A`` gave 1.0000000000000002."""
    rows = np.array([[1, 0, 0], [1, 1, 0], [1, 0, 1]], dtype=float)  # attribute 0: every training class
    assert (np.array(ROUNDS_ABOVE_ONE)[None] @ rows)[0, 0] > 1.0  # the edge exists without clipping
    y = np.repeat(np.arange(3), 4)
    X = np.random.default_rng(0).normal(size=(12, 2))
    iap = IAP(classifier=FixedClassPosteriors()).fit(X, rows[y])
    P = iap.predict_proba(X)
    assert P.max() == 1.0 and P.min() >= 0.0
    clf = ZeroShotClassifier(attribute_model=IAP(classifier=FixedClassPosteriors()), decision_rule=DAPRule(prior="uni"))
    clf.fit(X, rows[y], y)
    unseen = np.array([[1, 1, 1], [0, 1, 1]], dtype=float)
    proba = clf.predict_proba(X, unseen)
    assert np.all((proba >= 0) & (proba <= 1)) and np.allclose(proba.sum(axis=1), 1.0)


def _feature_methods() -> list[str]:
    return [name for name in available_methods() if get_method(name).input_kind == "features"]


@pytest.mark.parametrize("name", _feature_methods())
def test_every_method_is_valid_on_perfectly_separable_attributes(name):
    """The edge of each registered method: features that are the attribute rows themselves (each
    attribute perfectly separable, so detectors answer exactly 0 or 1), a constant channel and a huge
    scale. The method ranks unseen classes with valid posteriors, or says in one line why it cannot."""
    rng = np.random.default_rng(7)
    n_classes, n_attributes, n_sensors = 10, 5, 2
    K = np.unique((rng.random((40, n_attributes)) < 0.5).astype(float), axis=0)[:n_classes]
    y = np.repeat(np.arange(len(K)), 3)
    X = np.repeat(K[y][:, None, :], n_sensors, axis=1) * 1e6
    X = np.concatenate([X, np.full((len(y), n_sensors, 1), 7.0)], axis=2)  # a constant channel
    train = y < len(K) - 3
    method = get_method(name)
    Xi = X if method.input_ndim == 3 else X.reshape(len(X), -1)
    clf = build_method(name, random_state=0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            clf.fit(Xi[train], K[y[train]], y[train])
    except TzslError as exc:  # refused: one line, plain numbers
        assert "\n" not in str(exc) and not NUMPY_REPR.search(str(exc)), str(exc)
        return
    unseen = K[len(K) - 3:]
    proba = clf.predict_proba(Xi[~train], unseen)
    assert proba.shape == ((~train).sum(), 3)
    assert np.all(np.isfinite(proba)) and np.all((proba >= 0) & (proba <= 1))
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-9)
    scores = getattr(clf, "estimator_", clf)
    if hasattr(scores, "attribute_scores") and getattr(scores.attribute_model_, "score_kind", "") == "probability":
        P = scores.attribute_scores(Xi[~train])
        assert np.all((P >= 0) & (P <= 1))
