"""DAP: hand-computed cases, fusion rules (eqs. 5-6), priors, clipping, validation, subset sweep."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import BaseEstimator

from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models import (
    DAPRule,
    ZeroShotClassifier,
)
from tzsl.models.dap import (
    attribute_prior,
    check_class_attributes,
    dap_accuracy_over_subsets,
    dap_log_scores,
    fuse_attribute_posteriors,
)

K2 = np.array([[1, 0], [0, 1]])


def test_hand_computed_uniform_prior():
    # p(a1=1|x)=0.9, p(a2=1|x)=0.2; class 0 = (1, 0), class 1 = (0, 1); prior 0.5
    # class 0: 0.9 * 0.8 / (0.5 * 0.5) = 2.88 ; class 1: 0.1 * 0.2 / 0.25 = 0.08
    S = dap_log_scores(np.array([[0.9, 0.2]]), K2, np.full(2, 0.5))
    np.testing.assert_allclose(np.exp(S), [[2.88, 0.08]], rtol=1e-9)
    post = np.exp(S) / np.exp(S).sum()
    np.testing.assert_allclose(post, [[2.88 / 2.96, 0.08 / 2.96]])  # 0.97297..., 0.02703...


def test_hand_computed_non_uniform_prior():
    # prior p(a=1) = (0.8, 0.3): class 0 divides by 0.8 * 0.7 = 0.56, class 1 by 0.2 * 0.3 = 0.06
    # class 0: 0.72 / 0.56 = 1.285714... ; class 1: 0.02 / 0.06 = 0.3333...
    S = dap_log_scores(np.array([[0.9, 0.2]]), K2, np.array([0.8, 0.3]))
    np.testing.assert_allclose(np.exp(S), [[0.72 / 0.56, 0.02 / 0.06]], rtol=1e-9)


def test_prior_can_flip_the_decision():
    # p = (0.6, 0.6): uniform prior ties; a prior making attribute 1 common favours class 1
    P = np.array([[0.6, 0.6]])
    S = dap_log_scores(P, K2, np.array([0.9, 0.1]))
    assert S[0, 1] > S[0, 0]


def test_fusion_rules_eq5_eq6():
    # one trial, two sensors, one attribute: p(a=1|x_b1)=0.9, p(a=1|x_b2)=0.4
    P = np.array([[[0.9], [0.4]]])
    present, absent = fuse_attribute_posteriors(P, "avg")  # eq. (6)
    np.testing.assert_allclose([present[0, 0], absent[0, 0]], [0.65, 0.35])
    present, absent = fuse_attribute_posteriors(P, "max")  # eq. (5), per value
    np.testing.assert_allclose([present[0, 0], absent[0, 0]], [0.9, 0.6])
    K = np.array([[1], [0]])
    S = dap_log_scores(present, K, np.array([0.5]), P_absent=absent)
    np.testing.assert_allclose(np.exp(S), [[0.9 / 0.5, 0.6 / 0.5]])


def test_max_and_avg_agree_for_one_sensor():
    rng = np.random.default_rng(0)
    P = rng.uniform(size=(5, 1, 4))
    a = fuse_attribute_posteriors(P, "avg")
    m = fuse_attribute_posteriors(P, "max")
    np.testing.assert_allclose(a[0], m[0])
    np.testing.assert_allclose(a[1], m[1])


def test_unknown_fusion():
    with pytest.raises(ConfigError, match="fusion"):
        fuse_attribute_posteriors(np.full((1, 2, 2), 0.5), "median")


def test_priors_train_is_per_object_test_is_per_class():
    # object 7 has 3 trials with row (1, 0); object 9 has 1 trial with row (0, 0)
    A = np.array([[1, 0], [1, 0], [1, 0], [0, 0]])
    groups = np.array([7, 7, 7, 9])
    np.testing.assert_allclose(attribute_prior("train", train_attributes=A, groups=groups), [0.5, 0.0])
    np.testing.assert_allclose(attribute_prior("train", train_attributes=A), [0.75, 0.0])
    K = np.array([[1, 1], [0, 1], [0, 1], [0, 0]])
    np.testing.assert_allclose(attribute_prior("test", class_attributes=K), [0.25, 0.75])
    np.testing.assert_allclose(attribute_prior("uni", class_attributes=K), [0.5, 0.5])
    with pytest.raises(ConfigError, match="prior"):
        attribute_prior("bogus", class_attributes=K)


def test_clipping_keeps_scores_finite_and_exact():
    P = np.array([[0.0, 1.0]])
    S = dap_log_scores(P, K2, np.array([0.5, 1.0]), eps=0.01)
    assert np.isfinite(S).all()
    # class 0 = (1, 0): log(0.01) + log(0.01) - log(0.5) - log(0.01)
    expect0 = np.log(0.01) + np.log(0.01) - np.log(0.5) - np.log(0.01)
    # class 1 = (0, 1): log(0.99) + log(0.99) - log(0.5) - log(0.99)
    expect1 = np.log(0.99) + np.log(0.99) - np.log(0.5) - np.log(0.99)
    np.testing.assert_allclose(S[0], [expect0, expect1])


@pytest.mark.parametrize(
    ("K", "match"),
    [
        (np.array([[1, 0, 1], [0, 1, np.nan]]), r"row 1, column 2"),
        (np.array([[1, 0, 1], [0, 2, 1]]), r"value 2.* row 1, column 1"),
        (np.array([1, 0, 1]), "2-D"),
    ],
)
def test_class_table_validation(K, match):
    with pytest.raises(DataFileError, match=match):
        check_class_attributes(K)


def test_column_count_must_match():
    with pytest.raises(DataFileError, match="3 attribute columns.*predicts 2"):
        dap_log_scores(np.full((1, 2), 0.5), np.ones((2, 3)), np.full(2, 0.5))


def test_posteriors_out_of_range():
    with pytest.raises(ConfigError, match=r"\[0, 1\]"):
        dap_log_scores(np.array([[0.5, 1.5]]), K2, np.full(2, 0.5))


def _loop_accuracy(P, K, y, subset, fusion, prior):
    present, absent = fuse_attribute_posteriors(P[:, :, subset], fusion)
    pr = prior[subset]
    S = dap_log_scores(present, K[:, subset], pr, P_absent=absent)
    return (S.argmax(1) == y).mean()


@pytest.mark.parametrize("fusion", ["avg", "max"])
@pytest.mark.parametrize("prior_kind", ["uni", "test", "array"])
def test_subset_sweep_equals_loop(fusion, prior_kind):
    rng = np.random.default_rng(1)
    n, s, m, k = 40, 2, 9, 6
    P = rng.uniform(size=(n, s, m))
    K = rng.integers(0, 2, size=(k, m))
    y = rng.integers(0, k, size=n)
    prior_arr = rng.uniform(0.1, 0.9, size=m)
    prior = prior_arr if prior_kind == "array" else prior_kind
    full_prior = {"uni": np.full(m, 0.5), "test": K.mean(0), "array": prior_arr}[prior_kind]
    subsets = [np.sort(rng.choice(m, size=j, replace=False)) for j in (3, 5, 7) for _ in range(10)]
    masks = np.zeros((len(subsets), m), dtype=bool)
    for r, sub in enumerate(subsets):
        masks[r, sub] = True
    fast = dap_accuracy_over_subsets(P, K, y, masks, fusion=fusion, prior=prior, chunk=7)
    per_trial = dap_accuracy_over_subsets(P, K, y, masks, fusion=fusion, prior=prior, chunk=7, per_trial=True)
    assert per_trial.shape == (len(masks), len(y)) and set(np.unique(per_trial)) <= {0.0, 1.0}
    np.testing.assert_allclose(per_trial.mean(axis=1), fast)
    loop = np.array([_loop_accuracy(P, K, y, sub, fusion, full_prior) for sub in subsets])
    np.testing.assert_allclose(fast, loop)
    idx = np.array([sub for sub in subsets if sub.size == 5])
    np.testing.assert_allclose(
        dap_accuracy_over_subsets(P, K, y, idx, fusion=fusion, prior=prior), loop[10:20]
    )
    assert len(set(np.round(loop, 6))) > 1  # the check is not vacuous


class _FixedPosteriors(BaseEstimator):
    """Attribute model returning stored posteriors (a test double)."""

    score_kind = "probability"

    def __init__(self, P=None):
        self.P = P

    def fit(self, X, A, groups=None):
        self.fitted_ = True
        return self

    def predict_proba(self, X):
        return self.P[: len(X)]


def test_dap_classifier_uses_train_prior_and_normalises():
    P = np.array([[[0.9, 0.2], [0.7, 0.4]], [[0.1, 0.9], [0.3, 0.6]]])
    A = np.array([[1, 0], [1, 0], [1, 0], [0, 1]])
    groups = np.array([0, 0, 1, 2])  # objects: (1,0), (1,0), (0,1) -> prior (2/3, 1/3)
    X = np.zeros((2, 2, 3))
    dap = ZeroShotClassifier(attribute_model=_FixedPosteriors(P=P), decision_rule=DAPRule(fusion="avg", prior="train"))
    dap.fit(np.zeros((4, 2, 3)), A, groups)
    np.testing.assert_allclose(dap.decision_rule_.train_prior_, [2 / 3, 1 / 3])
    proba = dap.predict_proba(X, K2)
    np.testing.assert_allclose(proba.sum(1), 1.0)
    # hand: trial 0 avg posteriors (0.8, 0.3); class 0: 0.8*0.7/(2/3*2/3); class 1: 0.2*0.3/(1/3*1/3)
    c0, c1 = 0.8 * 0.7 / (4 / 9), 0.2 * 0.3 / (1 / 9)
    np.testing.assert_allclose(proba[0], [c0 / (c0 + c1), c1 / (c0 + c1)])
    np.testing.assert_array_equal(dap.predict(X, K2), [0, 1])
    with pytest.raises(DataFileError, match="3 attribute columns"):
        dap.predict(X, np.ones((2, 3)))


def test_mathematically_equal_scores_are_exact_ties():
    """LDAP-style p = 0.5 on the one attribute two classes differ in: the scores must be equal floats."""
    from tzsl.models._dap import dap_log_scores

    rng = np.random.default_rng(0)
    P = rng.uniform(0.05, 0.95, size=(50, 7))
    P[:, 3] = 0.5
    K = rng.integers(0, 2, size=(6, 7)).astype(float)
    K[1] = K[0]
    K[0, 3], K[1, 3] = 0.0, 1.0
    scores = dap_log_scores(P, K, np.full(7, 0.5))
    np.testing.assert_array_equal(scores[:, 0], scores[:, 1])


def test_break_ties_is_uniform_and_seeded():
    from tzsl.models._dap import break_ties

    scores = np.array([[1.0, 3.0, 3.0, 0.0]] * 4000)
    picks = break_ties(scores, 0)
    assert set(np.unique(picks)) == {1, 2}
    assert abs((picks == 1).mean() - 0.5) < 0.05  # not always the first tied class
    np.testing.assert_array_equal(picks, break_ties(scores, 0))
    np.testing.assert_array_equal(break_ties(np.array([[0.0, 2.0, 1.0]]), 5), [1])
