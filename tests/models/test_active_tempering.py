"""Tempered sequential posterior: truth-known synthetic evidence (independent vs duplicated EPs)."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.exceptions import ConfigError
from tzsl.models import (
    PerEPAttributeModel,
)
from tzsl.models.active_touch import (
    done_subset_index,
    ep_column_blocks,
    fit_posterior_exponents,
    run_policy,
    sequential_log_posterior,
)

N_CLASSES, DIM, SCALE = 6, 2, 1.8


def _gaussian_scores(n, *, duplicate: bool, seed: int):
    """Per-EP exact log-likelihoods of 3 EPs (SIMULATED): x_e = mu[z, e] + N(0, I), s_e(z') = -|x_e - mu[z', e]|^2 / 2.

    The scores are calibrated by construction and conditionally independent across EPs, except that
    with ``duplicate`` EP 1 observes exactly what EP 0 observes (the same noise): the product of EP 0
    and EP 1 then counts one observation twice, so its exact exponent is 1/2.
    """
    rng = np.random.default_rng(seed)
    mu = np.random.default_rng(123).normal(scale=SCALE, size=(N_CLASSES, 3, DIM))
    if duplicate:
        mu[:, 1] = mu[:, 0]
    y = rng.integers(0, N_CLASSES, n)
    noise = rng.normal(size=(n, 3, DIM))
    if duplicate:
        noise[:, 1] = noise[:, 0]
    x = mu[y] + noise  # (n, 3, DIM)
    S = -0.5 * ((x[:, :, None, :] - mu.transpose(1, 0, 2)[None]) ** 2).sum(axis=3)  # (n, 3, Z)
    return S, y


def _decided_accuracy(log_post, y, t):
    top = np.exp(log_post.max(axis=1))
    hit = top >= t
    return float((log_post.argmax(axis=1)[hit] == y[hit]).mean()), int(hit.sum())


def test_independent_calibrated_eps_keep_exponents_near_one():
    S, y = _gaussian_scores(4000, duplicate=False, seed=0)
    tau = fit_posterior_exponents(S, y, tempering="subset")
    assert tau.shape == (8,) and tau[0] == 1.0
    np.testing.assert_allclose(tau[1:], 1.0, atol=0.12)
    count = fit_posterior_exponents(S, y, tempering="count")
    np.testing.assert_allclose(count[1:], 1.0, atol=0.12)
    np.testing.assert_array_equal(fit_posterior_exponents(S, y, tempering="none"), np.ones(8))


def test_duplicated_eps_are_detected_and_the_tempered_posterior_keeps_its_promise():
    S, y = _gaussian_scores(4000, duplicate=True, seed=0)
    tau = fit_posterior_exponents(S, y, tempering="subset")
    pair = int(done_subset_index(np.array([True, True, False])))
    assert tau[pair] < 0.65  # exact 0.5: one observation counted twice
    assert tau[1] > 0.85 and tau[4] > 0.85  # each EP alone is calibrated
    assert tau[int(done_subset_index(np.array([True, False, True])))] > 0.85  # EP 0 and EP 2 are independent
    # held-out data: the untempered product over-claims, the tempered posterior keeps decided-at-t >= t - tol
    S_new, y_new = _gaussian_scores(4000, duplicate=True, seed=1)
    done = np.array([True, True, False])
    plain = sequential_log_posterior(S_new, done)
    tempered = sequential_log_posterior(S_new, done, tau)
    acc_plain, n_plain = _decided_accuracy(plain, y_new, 0.9)
    assert n_plain > 200 and acc_plain < 0.85  # the test can fail: the plain product is over-confident
    for t in (0.6, 0.7, 0.8, 0.9):
        acc, n = _decided_accuracy(tempered, y_new, t)
        assert n > 200 and acc >= t - 0.04, (t, acc, n)


def test_tempered_posterior_formula_and_policy():
    S, y = _gaussian_scores(50, duplicate=False, seed=2)
    tau = np.linspace(0.2, 1.6, 8)
    done = np.array([[True, False, True]] * 50)
    lp = sequential_log_posterior(S, done, tau)
    total = tau[5] * (S[:, 0] + S[:, 2])
    expected = total - np.log(np.exp(total).sum(axis=1, keepdims=True))
    np.testing.assert_allclose(lp, expected, atol=1e-10)
    res = run_policy(S, None, np.ones(3), policy=(0, 2, 1), exponents=tau)
    np.testing.assert_allclose(res["top_probability"][:, 2], np.exp(lp.max(axis=1)))
    with pytest.raises(ConfigError, match="exponents must have shape"):
        sequential_log_posterior(S, done, tau[:4])
    with pytest.raises(ConfigError, match="tempering must be one of"):
        fit_posterior_exponents(S, y, tempering="global")
    with pytest.raises(ConfigError, match="use tempering 'count'"):
        fit_posterior_exponents(np.zeros((2, 13, 3)), [0, 1], tempering="subset")


def test_padded_candidate_pools_are_respected():
    S, y = _gaussian_scores(600, duplicate=False, seed=3)
    valid = np.ones((600, N_CLASSES), dtype=bool)
    S_pad = np.concatenate([S, np.full((600, 3, 2), 50.0)], axis=2)  # two huge padded columns, never candidates
    valid_pad = np.column_stack([valid, np.zeros((600, 2), dtype=bool)])
    np.testing.assert_allclose(fit_posterior_exponents(S_pad, y, valid=valid_pad),
                               fit_posterior_exponents(S, y), rtol=1e-3)


def test_per_ep_model_detects_a_duplicated_ep(monkeypatch):
    """SIMULATED: EP ``copy`` has exactly the features of EP ``info``; EP ``other`` senses the attributes
    independently."""
    monkeypatch.delenv("TZSL_CACHE_DIR", raising=False)
    rng = np.random.default_rng(0)
    n_objects, n_trials, m = 40, 5, 6
    K = (rng.random((n_objects, m)) < 0.5).astype(int)
    groups = np.repeat(np.arange(n_objects), n_trials)
    A = K[groups]
    info = 1.2 * (A - 0.5)[:, None, :] + rng.normal(size=(groups.size, 2, m))
    other = 1.2 * (A - 0.5)[:, None, :] + rng.normal(size=(groups.size, 2, m))
    X = np.concatenate([info, info, other], axis=2)
    names = [f"{ep}:f{j}" for ep in ("info", "copy", "other") for j in range(m)]
    blocks = ep_column_blocks(names)
    seconds = {"info": 1.0, "copy": 1.0, "other": 1.0}
    model = PerEPAttributeModel(ep_columns=blocks, ep_seconds=seconds, cv=4, random_state=0).fit(X, A, groups)
    tau = model.exponents_
    single = tau[1]
    assert model.exponent([True, True, False]) < 0.75 * single  # the duplicated evidence is down-weighted
    assert model.exponent([True, False, True]) > model.exponent([True, True, False])
    S, y, valid = model.pseudo_unseen_scores(A)
    assert S.shape[:2] == (groups.size, 3) and valid[np.arange(y.size), y].all()
    assert model.tempering_trials_ == groups.size and valid.sum(axis=1).max() <= n_objects // 4 + 1
    plain = PerEPAttributeModel(ep_columns=blocks, ep_seconds=seconds, cv=4, tempering="none", random_state=0)
    np.testing.assert_array_equal(plain.fit(X, A, groups).exponents_, np.ones(8))
