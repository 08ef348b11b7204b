"""tzsl/models/_cache.py: where fits are cached, seed spawning, cached fits equal fresh ones."""

from __future__ import annotations

import joblib
import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

from tzsl.exceptions import ConfigError
from tzsl.models._cache import CACHE_ENV, fit_clone, parallel_context, resolve_memory, spawn_seeds


# ---------------------------------------------------------------------------- resolve_memory
def test_resolve_memory_none_without_env_does_not_cache(monkeypatch):
    monkeypatch.delenv(CACHE_ENV, raising=False)
    memory = resolve_memory(None)
    assert isinstance(memory, joblib.Memory)
    assert memory.location is None


def test_resolve_memory_none_uses_the_env_folder(monkeypatch, tmp_path):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    assert resolve_memory(None).location == str(tmp_path / "cache")


def test_resolve_memory_empty_env_means_no_cache(monkeypatch):
    monkeypatch.setenv(CACHE_ENV, "")
    assert resolve_memory(None).location is None


def test_resolve_memory_path_and_memory(tmp_path):
    assert resolve_memory(tmp_path).location == str(tmp_path)
    assert resolve_memory(str(tmp_path / "x")).location == str(tmp_path / "x")
    given = joblib.Memory(str(tmp_path), verbose=0)
    assert resolve_memory(given) is given


def test_resolve_memory_rejects_other_types():
    with pytest.raises(ConfigError, match="memory must be None, a folder path or a joblib.Memory, got int"):
        resolve_memory(3)


# ---------------------------------------------------------------------------- spawn_seeds
def test_spawn_seeds_is_deterministic_and_distinct():
    a = spawn_seeds(0, 50)
    assert a == spawn_seeds(0, 50)
    assert a == spawn_seeds(np.int64(0), 50)
    assert len(set(a)) == 50
    assert all(isinstance(s, int) and 0 <= s < 2**31 - 1 for s in a)
    assert a != spawn_seeds(1, 50)
    # the first seeds do not depend on how many are asked for
    assert spawn_seeds(0, 5) == a[:5]


def test_spawn_seeds_from_random_state_follows_its_state():
    assert spawn_seeds(np.random.RandomState(7), 4) == spawn_seeds(np.random.RandomState(7), 4)
    assert spawn_seeds(np.random.RandomState(7), 4) != spawn_seeds(np.random.RandomState(8), 4)


def test_spawn_seeds_none_draws_fresh_entropy():
    assert spawn_seeds(None, 8) != spawn_seeds(None, 8)  # 2**-248 chance of a false failure


# ---------------------------------------------------------------------------- cached fits
@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(80, 4))
    y = (X[:, 0] + 0.5 * rng.normal(size=80) > 0).astype(int)
    return X, y


def test_cache_hit_returns_a_model_identical_to_the_fresh_fit(tmp_path, data):
    X, y = data
    memory = resolve_memory(tmp_path)
    cached_fit = memory.cache(fit_clone)
    estimator = LogisticRegression(C=0.5)
    assert not cached_fit.check_call_in_cache(estimator, X, y, None)
    first = cached_fit(estimator, X, y, None)
    assert cached_fit.check_call_in_cache(estimator, X, y, None)
    again = cached_fit(LogisticRegression(C=0.5), X, y, None)  # an equal template hits too
    fresh = fit_clone(estimator, X, y, None)
    assert again is not first  # read back from disk, not the same object
    np.testing.assert_array_equal(again.coef_, fresh.coef_)
    np.testing.assert_array_equal(again.intercept_, fresh.intercept_)
    np.testing.assert_array_equal(again.predict_proba(X), fresh.predict_proba(X))
    assert not hasattr(estimator, "coef_")  # fit_clone leaves the template unfitted


def test_cache_misses_when_data_or_parameters_change(tmp_path, data):
    X, y = data
    cached_fit = resolve_memory(tmp_path).cache(fit_clone)
    base = cached_fit(LogisticRegression(C=0.5), X, y, None)
    assert not cached_fit.check_call_in_cache(LogisticRegression(C=5.0), X, y, None)
    X2 = X.copy()
    X2[0, 0] += 1.0
    assert not cached_fit.check_call_in_cache(LogisticRegression(C=0.5), X2, y, None)
    other = cached_fit(LogisticRegression(C=5.0), X, y, None)
    assert not np.array_equal(other.coef_, base.coef_)


def test_parallel_context_validates_backend():
    with parallel_context("loky"), parallel_context("threading"):
        pass
    with pytest.raises(ConfigError, match="backend must be one of"):
        parallel_context("mpi")
