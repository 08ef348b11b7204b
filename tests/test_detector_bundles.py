"""DAP models stored as arrays (:mod:`tzsl.inference.detector_bundles`) against the fitted estimators.

SIMULATED data: 8 objects (every 0/1 row of 3 attributes), 4 trials each, 2 sensors of 6 features
(a noisy linear image of the object's attributes). Every detector family an attribute bank fits is
exported to arrays and must give the estimator's posteriors, and the stored DAP rule its class
scores, to 1e-12 on random inputs far from the training data.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from tzsl.features import VariancePCA
from tzsl.inference.detector_bundles import detector_payload, read_detector_payload
from tzsl.models import AttributeClassifierBank, AttributeSVM, DAPRule, ZeroShotClassifier

ROWS = np.array([[1, 0, 0], [0, 1, 0], [1, 0, 1], [0, 1, 1], [1, 1, 0], [0, 0, 1], [1, 1, 1], [0, 0, 0]])
BANKS = {
    "rbf-svm": {"estimator": AttributeSVM(cv=2)},
    "rbf-svm bagging, whitened PCA": {"estimator": AttributeSVM(cv=2, undersampling="bagging",
                                                                preprocessor=VariancePCA(whiten=True))},
    "rbf-svm approximate (Nystroem)": {"estimator": AttributeSVM(cv=2), "solver": "approximate"},
    "logistic": {"detector": "logistic"},
    "linear-svm": {"detector": "linear-svm"},
    "logistic-c1": {"detector": "logistic-c1"},  # the generic default's detectors (tzsl.models.choices.DEFAULT_METHOD)
}


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    objects = np.repeat(np.arange(len(ROWS)), 4)
    A = ROWS[objects]
    X = np.stack([A @ rng.normal(0, 1, (3, 6)) * 2 + rng.normal(0, 0.5, (len(A), 6)) for _ in range(2)], axis=1)
    return X, A, objects, rng.normal(0, 3, (60, 2, 6))


@pytest.mark.parametrize("bank", list(BANKS))
def test_detector_arrays_give_the_estimators_posteriors(data, bank):
    X, A, objects, new = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # grid edges of a tiny data set
        zsl = ZeroShotClassifier(attribute_model=AttributeClassifierBank(random_state=0, **BANKS[bank]),
                                 decision_rule=DAPRule()).fit(X, A, objects)
    payload = detector_payload(zsl, zsl.decision_rule_)
    assert payload is not None, f"{bank}: not exported"
    arrays, _, _ = read_detector_payload(payload, 3, "test")
    expected = zsl.attribute_scores(np.concatenate([X, new]))
    np.testing.assert_allclose(arrays.attribute_scores(np.concatenate([X, new])), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("fusion", ["avg", "max"])
@pytest.mark.parametrize("prior", ["uni", "train", "test", [0.2, 0.5, 0.9]])
def test_stored_dap_rule_gives_the_rules_class_scores(data, fusion, prior):
    X, A, objects, new = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        zsl = ZeroShotClassifier(attribute_model=AttributeClassifierBank(detector="logistic", random_state=0),
                                 decision_rule=DAPRule(fusion=fusion, prior=prior)).fit(X, A, objects)
    _, rule, _ = read_detector_payload(detector_payload(zsl, zsl.decision_rule_), 3, "test")
    P = zsl.attribute_scores(new)
    K = ROWS[[0, 3, 5, 6]]
    np.testing.assert_array_equal(rule.decision_function(P, K), zsl.decision_rule_.decision_function(P, K))


def test_other_models_are_not_detector_arrays(data):
    from tzsl.models import ESZSL, CompatibilityRule

    X, A, objects, _ = data
    zsl = ZeroShotClassifier(attribute_model=ESZSL(), decision_rule=CompatibilityRule()).fit(
        X.reshape(len(X), -1), A, objects)
    assert detector_payload(zsl, zsl.decision_rule_) is None
