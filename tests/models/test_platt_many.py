"""Platt scaling of every grid configuration in one Newton solve (issue 22, item 3)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.special import expit, log_expit

from tzsl.models.attribute_training import fit_platt, fit_platt_many


def _targets(y: np.ndarray) -> np.ndarray:
    n_pos, n_neg = y.sum(), (~y).sum()
    return np.where(y, (n_pos + 1.0) / (n_pos + 2.0), 1.0 / (n_neg + 2.0))


def _scipy_platt(s: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """An independent per-problem fit: bounded L-BFGS-B run to a tight tolerance."""
    t, scale = _targets(y), s.std() or 1.0
    u = s / scale

    def loss(theta):
        z = theta[0] * u + theta[1]
        r = w * (expit(z) - t)
        return -(w * (t * log_expit(z) + (1 - t) * log_expit(-z))).sum(), np.array([(r * u).sum(), r.sum()])

    res = minimize(loss, [0.0, 0.0], jac=True, method="L-BFGS-B", bounds=[(0, None), (None, None)],
                   options={"ftol": 1e-15, "gtol": 1e-11, "maxiter": 10_000})
    return res.x[0] / scale, res.x[1]


def _problems(seed: int, n: int, k: int):
    rng = np.random.default_rng(seed)
    y = rng.random(n) < rng.uniform(0.2, 0.8)
    y[:2] = [True, False]
    signal = rng.normal(size=(k, 1))  # some rows anti-correlated: their slope is clamped at 0
    S = signal * y + rng.normal(size=(k, n)) * rng.uniform(0.05, 3.0, (k, 1)) + rng.normal(size=(k, 1))
    return S, y, rng.uniform(0.2, 2.0, n)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), n=st.integers(4, 300), k=st.integers(1, 30))
def test_all_rows_at_once_equal_one_fit_per_row(seed, n, k):
    S, y, w = _problems(seed, n, k)
    a, b = fit_platt_many(S, y, w)
    assert a.shape == b.shape == (k,) and (a >= 0).all()
    for i in range(k):
        a1, b1 = fit_platt(S[i], y, w)
        assert abs(a[i] - a1) <= 1e-6 * max(1.0, abs(a1)) and abs(b[i] - b1) <= 1e-6 * max(1.0, abs(b1))
        ra, rb = _scipy_platt(S[i], y, w)
        assert abs(a[i] - ra) <= 1e-6 * max(1.0, abs(ra)) and abs(b[i] - rb) <= 1e-6 * max(1.0, abs(rb))


def test_the_fit_is_the_optimum_its_gradient_vanishes():
    S, y, w = _problems(3, 200, 20)
    a, b = fit_platt_many(S, y, w)
    t = _targets(y)
    r = w * (expit(a[:, None] * S + b[:, None]) - t)
    grad_b = r.sum(axis=1)
    grad_a = (r * S).sum(axis=1)
    assert np.abs(grad_b).max() < 1e-6
    assert np.abs(grad_a[a > 0]).max() < 1e-6  # interior: zero; on the bound a = 0 the slope pushes outward
    assert (grad_a[a == 0] >= -1e-9).all()


def test_constant_scores_give_a_flat_sigmoid_at_the_mean_target():
    y = np.array([1, 0, 0, 1, 0], dtype=bool)
    a, b = fit_platt_many(np.full((2, 5), 0.7), y)
    np.testing.assert_array_equal(a, 0.0)
    mean_t = _targets(y).mean()
    np.testing.assert_allclose(expit(b), mean_t, rtol=1e-12)
