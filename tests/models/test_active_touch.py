"""Active touch: per-EP attribute models, sequential posterior, information-gain policy, stopping rule."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sklearn.utils._param_validation import InvalidParameterError

from tzsl.exceptions import ConfigError
from tzsl.models.active_touch import binned_confusion
from tzsl.models.active_touch._per_ep import (
    LogisticAttribute,
    PerEPAttributeModel,
    ep_column_blocks,
    expected_information_gain,
    outcome_log_likelihoods,
    run_policy,
    sequential_log_posterior,
    stop_reasons,
)
from tzsl.models.active_touch._suggest import suggest_next_ep
from tzsl.models.dap import dap_log_scores, fuse_attribute_posteriors

EPS = ("noise_a", "info", "noise_b")
SECONDS = {"noise_a": 1.0, "info": 2.0, "noise_b": 3.0}
N_FEAT = 4


def _synthetic(n_objects=30, n_trials=5, n_attributes=6, seed=0):
    """EP ``info`` carries the attributes (plus noise); ``noise_a`` / ``noise_b`` are pure noise.

    Returns X (n, 2, 3 * N_FEAT), A (n, m), groups (n,), object attribute table (n_objects, m), blocks.
    """
    rng = np.random.default_rng(seed)
    K = (rng.random((n_objects, n_attributes)) < 0.5).astype(int)
    K[:4] = np.eye(4, n_attributes, dtype=int)  # every attribute has both values on several objects
    K[4:8] = 1 - K[:4]
    groups = np.repeat(np.arange(n_objects), n_trials)
    A = K[groups]
    n = groups.size
    X = rng.normal(size=(n, 2, len(EPS) * N_FEAT))
    info = slice(N_FEAT, 2 * N_FEAT)
    signal = np.zeros((n, N_FEAT))
    signal[:, : min(N_FEAT, n_attributes)] = 3.0 * (A[:, :N_FEAT] - 0.5)
    X[:, :, info] += signal[:, None, :] + 0.0
    # attributes beyond N_FEAT: add them to the same columns with another sign pattern
    X[:, :, info][:, :, 0] += 3.0 * (A[:, 4] - 0.5)[:, None] if n_attributes > 4 else 0.0
    names = [f"{ep}:f{j}" for ep in EPS for j in range(N_FEAT)]
    return X, A, groups, K, ep_column_blocks(names)


@pytest.fixture(scope="module")
def fitted():
    X, A, groups, K, blocks = _synthetic()
    train = groups >= 8  # objects 0..7 are the unseen test classes
    model = PerEPAttributeModel(ep_columns=blocks, ep_seconds=SECONDS, cv=4, random_state=0)
    model.fit(X[train], A[train], groups[train])
    return model, X[~train], groups[~train], K[:8]


def test_ep_column_blocks_and_errors():
    blocks = ep_column_blocks(["hold:a", "hold:b", "squeeze:a"])
    assert list(blocks) == ["hold", "squeeze"]
    np.testing.assert_array_equal(blocks["hold"], [0, 1])
    with pytest.raises(ConfigError, match="no '<ep>:' prefix"):
        ep_column_blocks(["hold:a", "plain"])
    with pytest.raises(ConfigError, match="no feature columns"):
        ep_column_blocks(["hold:a"], eps=["hold", "squeeze"])


def test_logistic_attribute_validates_its_parameters():  # check_estimator: tests/models/test_estimator_checks.py
    with pytest.raises(InvalidParameterError):
        LogisticAttribute(C=-1.0).fit(np.zeros((4, 2)), [0, 1, 0, 1])


def test_parameters_are_validated():
    X, A, groups, _, blocks = _synthetic(n_objects=12)
    with pytest.raises(InvalidParameterError):
        PerEPAttributeModel(ep_columns=blocks, update="bogus").fit(X, A, groups)
    with pytest.raises(ConfigError, match="ep_columns is required"):
        PerEPAttributeModel().fit(X, A, groups)
    with pytest.raises(ConfigError, match="no duration"):
        PerEPAttributeModel(ep_columns=blocks).fit(X, A, groups)  # default PHAC-2 seconds lack these EPs


def test_confusion_shapes_and_informative_ep(fitted):
    model, *_ = fitted
    assert model.eps_ == EPS
    assert model.confusion_.shape == (3, 6, 2, model.n_bins)
    np.testing.assert_allclose(model.confusion_.sum(axis=3), 1.0)
    # out-of-fold posteriors separate the attribute values on the informative EP only
    oof = model.oof_posteriors_
    A = model.banks_["info"].n_attributes_
    assert A == 6
    assert np.isfinite(oof).mean() > 0.9


def test_policy_picks_the_informative_ep_first(fitted):
    model, X_test, _, K = fitted
    S = model.ep_log_scores(model.predict_proba(X_test), K)
    L = model.outcome_log_likelihoods(K, n_samples=128, random_state=0)
    res = run_policy(S, L, model.ep_seconds_, policy="active")
    assert (res["order"][:, 0] == EPS.index("info")).all()
    g0 = expected_information_gain(sequential_log_posterior(S, np.zeros(3, bool)), L)
    assert (g0[:, 1] > g0[:, [0, 2]].max(axis=1)).all()
    # the informative EP alone recognises the unseen objects far above chance (1/8)
    y = np.repeat(np.arange(8), 5)
    assert (S[:, 1].argmax(axis=1) == y).mean() > 0.6


def test_information_gain_is_nonnegative_and_zero_when_uninformative():
    rng = np.random.default_rng(1)
    m, B, Z = 5, 6, 7
    C = rng.dirichlet(np.ones(B), size=(3, m, 2))
    C[1, :, 1] = C[1, :, 0]  # EP 1: same outcome distribution whatever the attribute value
    K = rng.integers(0, 2, size=(Z, m))
    L = outcome_log_likelihoods(C, K, n_samples=2000, random_state=0)
    beliefs = np.log(rng.dirichlet(np.ones(Z), size=20))
    g = expected_information_gain(beliefs, L)
    np.testing.assert_allclose(g[:, 1], 0.0, atol=1e-12)
    assert (g[:, [0, 2]] > 0).all()
    H = -(np.exp(beliefs) * beliefs).sum(axis=1) / np.log(2)
    assert (g <= H[:, None] + 1e-9).all()


def test_sequential_posterior_equals_batch_combination(fitted):
    model, X_test, _, K = fitted
    P = model.predict_proba(X_test)
    S = model.ep_log_scores(P, K)
    # per-EP scores are the DAP log-scores of that EP's fused posteriors
    present, absent = fuse_attribute_posteriors(P[:, 2], "avg")
    np.testing.assert_allclose(S[:, 2], dap_log_scores(present, K, model.dap_prior(), P_absent=absent))
    batch = S.sum(axis=1)
    batch = batch - np.log(np.exp(batch - batch.max(axis=1, keepdims=True)).sum(axis=1, keepdims=True)) - \
        batch.max(axis=1, keepdims=True)
    res = run_policy(S, None, model.ep_seconds_, policy=(2, 0, 1))
    np.testing.assert_allclose(sequential_log_posterior(S, np.ones(3, bool)), batch, atol=1e-10)
    np.testing.assert_array_equal(res["final"], batch.argmax(axis=1))
    np.testing.assert_allclose(res["top_probability"][:, -1], np.exp(batch.max(axis=1)))
    # step by step: after EPs 2 and 0
    two = sequential_log_posterior(S, np.array([True, False, True]))
    np.testing.assert_allclose(res["top_probability"][:, 2], np.exp(two.max(axis=1)))


def test_confusion_update_is_sequentially_consistent(fitted):
    model, X_test, _, K = fitted
    from sklearn.base import clone

    m2 = clone(model).set_params(update="confusion")
    m2.__dict__.update({k: v for k, v in model.__dict__.items() if k.endswith("_")})
    S = m2.ep_log_scores(m2.predict_proba(X_test), K)
    assert S.shape == (X_test.shape[0], 3, K.shape[0])
    np.testing.assert_allclose(sequential_log_posterior(S, np.ones(3, bool)),
                               sequential_log_posterior(S.sum(axis=1, keepdims=True), np.ones(1, bool)))


def test_stopping_rule_threshold_and_budgets(fitted):
    model, X_test, _, K = fitted
    S = model.ep_log_scores(model.predict_proba(X_test), K)
    L = model.outcome_log_likelihoods(K, n_samples=64, random_state=0)
    res = run_policy(S, L, model.ep_seconds_, policy="active", threshold=0.6)
    k = res["n_eps_used"]
    top = res["top_probability"]
    rows = np.arange(k.size)
    stopped = res["stop_reason"] == "threshold"
    assert (top[rows, k][stopped] >= 0.6).all()
    # before stopping the threshold was not reached
    for i in range(k.size):
        assert (top[i, 1:k[i]] < 0.6).all()
    assert set(res["stop_reason"]) <= {"threshold", "no_ep_left"}
    assert (k[res["stop_reason"] == "no_ep_left"] == 3).all()
    res = run_policy(S, L, model.ep_seconds_, policy="active", max_eps=2)
    assert (res["n_eps_used"] == 2).all() and (res["stop_reason"] == "max_eps").all()
    res = run_policy(S, L, model.ep_seconds_, policy="active", max_seconds=3.5)
    assert (res["seconds_used"] <= 3.5).all() and (res["n_eps_used"] >= 1).all()
    r = stop_reasons(np.log([[0.95, 0.05], [0.5, 0.5]]), [1, 1], [0, 0], [1, np.inf], threshold=0.9)
    assert list(r) == ["threshold", "no_ep_left"]


class _Spy(LogisticAttribute):
    """Records the trial ids (feature 0 of the block) of every fit."""

    seen: list = []

    def fit(self, X, y, groups=None):
        _Spy.seen.append(np.unique(np.asarray(X)[:, 0]))
        return super().fit(X, y, groups)


def test_confusion_cross_validation_uses_training_objects_only(monkeypatch):
    monkeypatch.delenv("TZSL_CACHE_DIR", raising=False)
    X, A, groups, _, blocks = _synthetic()
    X[:, :, [0, N_FEAT, 2 * N_FEAT]] = groups[:, None, None]  # feature 0 of each block = object id
    train = groups >= 8
    _Spy.seen.clear()
    model = PerEPAttributeModel(ep_columns=blocks, estimator=_Spy(), ep_seconds=SECONDS, cv=3, random_state=0)
    model.fit(X[train], A[train], groups[train])
    seen = np.unique(np.concatenate(_Spy.seen))
    assert set(seen) <= set(range(8, 30))  # no test object ever reaches a fit
    fit_sets = {tuple(s) for s in _Spy.seen}
    assert len(fit_sets) == 4  # the full fit + 3 folds, each fold leaving training objects out
    assert all(len(s) < 22 for s in fit_sets if len(s) != 22)
    np.testing.assert_array_equal(model.oof_groups_, groups[train])


def test_suggest_next_ep_is_json_and_follows_the_rule(fitted):
    model, X_test, _, K = fitted
    names = [f"obj{i}" for i in range(K.shape[0])]
    out = suggest_next_ep(model, K, {}, class_names=names, threshold=0.99)
    json.dumps(out)
    assert not out["decided"] and out["next_ep"] == "info"
    np.testing.assert_allclose([r["probability"] for r in out["ranking"]], 1.0 / K.shape[0])
    assert out["expected_gain_bits"] == max(c["expected_gain_bits"] for c in out["candidates"])
    block = X_test[0][:, model.ep_columns["info"]]
    out = suggest_next_ep(model, K, {"info": block}, class_names=names, threshold=0.0)
    assert out["decided"] and out["stop_reason"] == "threshold" and out["next_ep"] is None
    assert out["decision"] == out["ranking"][0]["class"] and out["seconds_used"] == 2.0
    out = suggest_next_ep(model, K, {"info": block}, threshold=1.01, max_seconds=3.5)
    assert [c["ep"] for c in out["candidates"]] == ["noise_a"]
    with pytest.raises(ConfigError, match="unknown EP"):
        suggest_next_ep(model, K, {"tap": block})


def test_binned_confusion_counts_held_out_posteriors_per_action():
    P = np.array([[[0.95, np.nan], [0.05, 0.5], [0.96, 0.5]],
                  [[np.nan, np.nan], [np.nan, np.nan], [np.nan, np.nan]]])  # (2 actions, 3 samples, 2 attributes)
    A = np.array([[1, 0], [0, 1], [1, 1]])
    C = binned_confusion(P, A, n_bins=2, smoothing=1.0)
    assert C.shape == (2, 2, 2, 2)
    np.testing.assert_allclose(C.sum(axis=3), 1.0)
    np.testing.assert_allclose(C[0, 0, 1], [1 / 4, 3 / 4])  # two present samples, both in the high bin
    np.testing.assert_allclose(C[0, 0, 0], [2 / 3, 1 / 3])  # one absent sample in the low bin
    np.testing.assert_allclose(C[1], 0.5)  # an action never observed: the uniform prior counts only
