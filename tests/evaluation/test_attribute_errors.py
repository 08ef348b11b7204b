"""within_object_error_correlation on constructed errors whose correlation between attributes is known."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.evaluation import within_object_error_correlation
from tzsl.exceptions import TzslError


def object_errors(rho: float, n_objects=4000, m=6, trials=1, seed=0):
    """Errors ``0.5 + 0.1 * (sqrt(rho) u_o + sqrt(1 - rho) v_om)`` as posteriors of attributes that are all 0.

    ``u_o`` is shared by every attribute of object ``o``: the population correlation of two attributes'
    error rates across objects is exactly ``rho``.
    """
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n_objects, 1))
    v = rng.normal(size=(n_objects, m))
    rate = np.clip(0.5 + 0.1 * (np.sqrt(rho) * u + np.sqrt(1 - rho) * v), 0.0, 1.0)
    groups = np.repeat(np.arange(n_objects), trials)
    return np.zeros((groups.size, m)), rate[groups], groups


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.7, 1.0])
def test_recovers_the_constructed_correlation(rho):
    A, P, g = object_errors(rho)
    assert within_object_error_correlation(A, P, g) == pytest.approx(rho, abs=0.03)


def test_object_means_remove_trial_noise_that_the_trial_level_keeps():
    """Every trial of an object errs with its object's probabilities (0/1 errors): the object rates share
    one effect across attributes; single trials add independent noise, so their correlation is lower."""
    rng = np.random.default_rng(1)
    n_obj, trials, m = 400, 20, 5
    difficulty = rng.uniform(0.05, 0.6, size=n_obj)  # one per object, shared by every attribute
    g = np.repeat(np.arange(n_obj), trials)
    A = rng.integers(0, 2, size=(n_obj, m))[g]
    wrong = rng.random(size=A.shape) < difficulty[g, None]
    pred = np.where(wrong, 1 - A, A)
    by_object = within_object_error_correlation(A, pred, g)
    by_trial = within_object_error_correlation(A, pred, g, level="trial")
    var_d, mean_d = 0.55**2 / 12, 0.325  # uniform(0.05, 0.6)
    binomial = (mean_d - (var_d + mean_d**2)) / trials  # mean within-object variance of an object's error rate
    assert by_object == pytest.approx(var_d / (var_d + binomial), abs=0.05)
    assert by_trial == pytest.approx(var_d / (mean_d * (1 - mean_d)), abs=0.03)
    sign_flip = within_object_error_correlation(A, pred, rng.permutation(g))  # objects mixed up: no sharing
    assert abs(sign_flip) < 0.15


def test_errors_that_avoid_each_other_give_a_negative_correlation():
    g = np.arange(100)
    A = np.zeros((100, 2))
    P = np.column_stack([g % 2, 1 - g % 2]).astype(float)  # each object wrong on exactly one of the two
    assert within_object_error_correlation(A, P, g) == pytest.approx(-1.0)


def test_undefined_cases_are_nan_and_bad_input_is_refused():
    A = np.zeros((4, 3))
    assert np.isnan(within_object_error_correlation(A, A, np.zeros(4)))  # one object
    assert np.isnan(within_object_error_correlation(A, A, np.arange(4)))  # no error varies
    with pytest.raises(TzslError, match="must be"):
        within_object_error_correlation(A, A[:, :2], np.arange(4))
    with pytest.raises(TzslError, match=r"\[0, 1\]"):
        within_object_error_correlation(A, A + 2.0, np.arange(4))
    with pytest.raises(TzslError, match="level"):
        within_object_error_correlation(A, A, np.arange(4), level="pair")
