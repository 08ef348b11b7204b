"""Decision rules and the ZeroShotClassifier protocol (attribute model + rule)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator, clone
from sklearn.utils._param_validation import InvalidParameterError

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models import (
    ESZSL,
    CompatibilityRule,
    DAPRule,
    NearestAttributeRule,
    ZeroShotClassifier,
)
from tzsl.models.dap import attribute_prior, break_ties, dap_log_scores, fuse_attribute_posteriors

RNG = np.random.default_rng(0)
P3 = RNG.uniform(0.02, 0.98, size=(40, 2, 6))  # (trials, sensors, attributes)
K = np.unique(RNG.integers(0, 2, size=(7, 6)), axis=0).astype(float)
A_TRAIN = RNG.integers(0, 2, size=(30, 6))
A_TRAIN[:2] = [[0] * 6, [1] * 6]  # both values of every attribute
G_TRAIN = np.repeat(np.arange(10), 3)


class FixedPosteriors(BaseEstimator):
    """Probability attribute model returning stored posteriors (a test double)."""

    score_kind = "probability"

    def __init__(self, *, P=None):
        self.P = P

    def fit(self, X, A, groups=None):
        self.fitted_ = True
        return self

    def predict_proba(self, X):
        return self.P[: len(X)]


@pytest.mark.parametrize("fusion", ["avg", "max"])
@pytest.mark.parametrize("prior", ["uni", "train", "test"])
def test_dap_rule_is_the_dap_functions(fusion, prior):
    rule = DAPRule(fusion=fusion, prior=prior).fit(A_TRAIN, G_TRAIN)
    present, absent = fuse_attribute_posteriors(P3, fusion)
    pr = attribute_prior(prior, train_attributes=A_TRAIN, class_attributes=K, groups=G_TRAIN)
    expected = dap_log_scores(present, K, pr, P_absent=absent)
    np.testing.assert_array_equal(rule.decision_function(P3, K), expected)
    np.testing.assert_array_equal(rule.predict(P3, K, random_state=0), break_ties(expected, 0))
    np.testing.assert_allclose(rule.predict_proba(P3, K).sum(axis=1), 1.0)


def test_several_rules_on_scores_computed_once():
    clf = ZeroShotClassifier(attribute_model=FixedPosteriors(P=P3), decision_rule=DAPRule(), random_state=0)
    clf.fit(np.zeros((30, 2, 3)), A_TRAIN, G_TRAIN)
    scores = clf.attribute_scores(np.zeros((40, 2, 3)))
    for fusion in ("avg", "max"):
        for prior in ("uni", "train", "test"):
            rule = DAPRule(fusion=fusion, prior=prior)
            direct = clone(rule).fit(A_TRAIN, G_TRAIN).decision_function(P3, K)
            np.testing.assert_array_equal(clf.decision_function_from_scores(scores, K, decision_rule=rule), direct)
    # default rule = the fitted one; default table = training classes
    np.testing.assert_array_equal(clf.predict(np.zeros((40, 2, 3)), K), clf.predict_from_scores(scores, K))
    assert clf.decision_function(np.zeros((40, 2, 3))).shape == (40, len(np.unique(A_TRAIN, axis=0)))


def test_ties_are_broken_at_random_but_seeded():
    P = np.full((500, 1, 2), 0.5)
    Kt = np.array([[1.0, 0.0], [0.0, 1.0]])
    clf = ZeroShotClassifier(attribute_model=FixedPosteriors(P=P), decision_rule=DAPRule(prior="uni"), random_state=3)
    clf.fit(np.zeros((2, 1, 1)), Kt)
    picks = clf.predict(np.zeros((500, 1, 1)), Kt)
    assert 150 < picks.sum() < 350  # both classes win ties
    np.testing.assert_array_equal(picks, clf.predict(np.zeros((500, 1, 1)), Kt))


def test_compatibility_and_nearest_rules():
    F = RNG.normal(size=(20, 6))
    comp = CompatibilityRule().fit(K)
    np.testing.assert_allclose(comp.decision_function(F, K), F @ K.T)
    near = NearestAttributeRule().fit(K)
    d = ((F[:, None, :] - K[None]) ** 2).sum(-1)
    np.testing.assert_allclose(near.decision_function(F, K), -d, atol=1e-10)
    cos = NearestAttributeRule(metric="cosine").fit(K)
    Kn = K / np.maximum(np.linalg.norm(K, axis=1, keepdims=True), 1e-300)
    Kn[np.linalg.norm(K, axis=1) == 0] = 0.0
    np.testing.assert_allclose(cos.decision_function(F, K), (F / np.linalg.norm(F, axis=1, keepdims=True)) @ Kn.T)


def test_rule_and_model_must_agree_and_params_are_validated():
    with pytest.raises(ConfigError, match="reads"):
        ZeroShotClassifier(attribute_model=ESZSL(), decision_rule=DAPRule()).fit(RNG.normal(size=(30, 4)), A_TRAIN)
    with pytest.raises(InvalidParameterError, match="attribute_model"):
        ZeroShotClassifier().fit(np.zeros((3, 2)), np.eye(3))
    with pytest.raises(InvalidParameterError, match="fusion"):
        DAPRule(fusion="median").fit(A_TRAIN)
    with pytest.raises(InvalidParameterError, match="metric"):
        NearestAttributeRule(metric="l1").fit(A_TRAIN)
    rule = DAPRule().fit(A_TRAIN)
    with pytest.raises(DataFileError, match="not 0 or 1"):
        rule.decision_function(P3, K * 2)
    with pytest.raises(DataFileError, match="5 attribute columns"):
        rule.decision_function(P3, K[:, :5])
    with pytest.raises(TypeError):
        DAPRule("max")  # keyword-only


def test_unseen_classes_need_no_refit():
    X = RNG.normal(size=(120, 6)) + 0.0
    y = np.repeat(np.arange(6), 20)
    rows = np.array([[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 1], [1, 1, 0, 0], [0, 1, 1, 0], [1, 0, 1, 0]], float)
    W = RNG.normal(size=(4, 6)) * 3
    X = rows[y] @ W + 0.3 * RNG.normal(size=(120, 6))
    train = y < 4
    clf = ZeroShotClassifier(attribute_model=ESZSL(), decision_rule=CompatibilityRule()).fit(X[train], rows[y[train]])
    acc = np.mean(clf.predict(X[~train], rows[4:]) == y[~train] - 4)
    assert acc > 0.8  # chance 0.5
