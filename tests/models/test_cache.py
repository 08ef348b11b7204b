"""tzsl/_fit_store.py (public: tzsl.fit_store): the fit store (keys, hits, warnings, counts), seed spawning,
backends."""

from __future__ import annotations

import warnings
from pathlib import Path

import joblib
import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LogisticRegression

import tzsl
from tzsl._fit_store import FitStore, array_digest, fit_clone, parallel_context, spawn_seeds
from tzsl._profile import profiling
from tzsl.cache import CACHE_DIR_ENV
from tzsl.exceptions import ConfigError
from tzsl.fit_store import FITS_FOLDER, code_sources, fit_cached, fit_store_counts, resolve_store
from tzsl.models import AttributeClassifierBank, AttributeSVM


# ---------------------------------------------------------------------------- resolve_store
def test_resolve_store_none_without_env_does_not_store(monkeypatch):
    monkeypatch.delenv(CACHE_DIR_ENV, raising=False)
    assert not resolve_store(None).enabled


def test_resolve_store_none_uses_the_env_folder(monkeypatch, tmp_path):
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "cache"))
    assert resolve_store(None).folder == tmp_path / "cache" / FITS_FOLDER


def test_resolve_store_empty_env_means_no_store(monkeypatch):
    monkeypatch.setenv(CACHE_DIR_ENV, "")
    assert not resolve_store(None).enabled


def test_resolve_store_path_and_memory(tmp_path):
    assert resolve_store(tmp_path).folder == tmp_path / FITS_FOLDER
    assert resolve_store(str(tmp_path / "x")).folder == tmp_path / "x" / FITS_FOLDER
    assert resolve_store(joblib.Memory(str(tmp_path), verbose=0)).folder == tmp_path / FITS_FOLDER
    assert not resolve_store(joblib.Memory(None, verbose=0)).enabled


def test_resolve_store_rejects_other_types():
    with pytest.raises(ConfigError, match="memory must be None, False, a folder path or a joblib.Memory, got int"):
        resolve_store(3)


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


# ---------------------------------------------------------------------------- the fit store
@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(80, 4))
    y = (X[:, 0] + 0.5 * rng.normal(size=80) > 0).astype(int)
    return X, y


class CountingLR(LogisticRegression):
    """LogisticRegression counting its fits (module level, so it pickles)."""

    calls = 0

    def fit(self, X, y, sample_weight=None):
        type(self).calls += 1
        return super().fit(X, y, sample_weight)


def test_a_stored_fit_is_identical_to_a_fresh_one_and_is_not_refitted(tmp_path, data):
    X, y = data
    store = FitStore(tmp_path)
    CountingLR.calls = 0
    estimator = CountingLR(C=0.5)
    first = fit_cached(estimator, X, y, store=store)
    again = fit_cached(CountingLR(C=0.5), X.copy(), y.copy(), store=store)  # equal template, equal data
    assert CountingLR.calls == 1
    fresh = fit_clone(estimator, X, y)
    assert again is not first  # read back from disk
    np.testing.assert_array_equal(again.coef_, fresh.coef_)
    np.testing.assert_array_equal(again.predict_proba(X), fresh.predict_proba(X))
    assert not hasattr(estimator, "coef_")  # the template stays unfitted
    assert len(list(tmp_path.rglob("*.pkl"))) == 1


def test_the_key_is_parameters_data_and_code_not_labels_or_parallelism(tmp_path, data):
    X, y = data
    store = FitStore(tmp_path)
    d = (array_digest(X), array_digest(y))
    base = store.key(AttributeSVM(C_range=(1.0, 10.0)), *d)
    assert base == store.key(AttributeSVM(C_range=(1.0, 10.0), name="hard (sensor 0)"), *d)  # a label
    assert base == store.key(AttributeClassifierBank(estimator=AttributeSVM(C_range=(1.0, 10.0)), n_jobs=1).estimator,
                             *d)
    bank = AttributeClassifierBank(estimator=AttributeSVM(), n_jobs=1)
    assert store.key(bank, *d) == store.key(bank.set_params(n_jobs=4, progress=True), *d)
    assert base != store.key(AttributeSVM(C_range=(1.0, 100.0)), *d)  # a parameter
    assert base != store.key(AttributeSVM(C_range=(1.0, 10.0), random_state=1), *d)  # a seed
    X2 = X.copy()
    X2[0, 0] += 1e-12
    assert base != store.key(AttributeSVM(C_range=(1.0, 10.0)), array_digest(X2), d[1])  # the data
    assert base != store.key(AttributeSVM(C_range=(1.0, 10.0)), d[0], array_digest(y.astype(float)))  # its dtype
    groups = np.repeat(np.arange(8), 10)
    assert (store.key(AttributeSVM(), *d, array_digest(groups))
            != store.key(AttributeSVM(), *d, array_digest(groups % 4)))


def test_the_code_in_a_key_covers_every_model_feature_and_evaluation_source_sub_packages_included():
    # a fit's key named only the packages' top-level files, so an edit of an estimator in a sub-package
    # (tzsl/models/detectors/, ...) read back fits made by the old code
    root = Path(tzsl.__file__).resolve().parent
    sources = set(code_sources())
    every = {path for package in ("models", "features", "evaluation") for path in (root / package).rglob("*.py")}
    assert every <= sources
    assert root / "models" / "detectors" / "_scalable_attribute.py" in sources
    assert root / "models" / "ensemble" / "_score_ensemble.py" in sources


def test_a_generator_instance_is_never_stored(tmp_path, data):
    X, y = data
    store = FitStore(tmp_path)
    assert store.key(AttributeSVM(random_state=np.random.RandomState(0)), array_digest(X)) is None
    before = fit_store_counts().get("unstorable", 0)
    fit_cached(LogisticRegression(random_state=np.random.RandomState(0)), X, y, store=store)
    assert fit_store_counts()["unstorable"] == before + 1
    assert not list(tmp_path.rglob("*.pkl"))


class WarningLR(LogisticRegression):
    def fit(self, X, y, sample_weight=None):
        warnings.warn("did not converge", ConvergenceWarning, stacklevel=2)
        return super().fit(X, y, sample_weight)


def test_the_warnings_of_a_fit_are_raised_again_when_it_is_read_back(tmp_path, data):
    X, y = data
    store = FitStore(tmp_path)
    for _ in range(2):  # computed, then read back
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fit_cached(WarningLR(), X, y, store=store)
        assert [str(w.message) for w in caught if w.category is ConvergenceWarning] == ["did not converge"]


def test_counts_hits_misses_and_repeats_in_the_profile(tmp_path, data):
    X, y = data
    store = FitStore(tmp_path)
    with profiling("test") as profile:
        fit_cached(LogisticRegression(C=0.3), X, y, store=store)
        fit_cached(LogisticRegression(C=0.3), X, y, store=store)
        fit_cached(LogisticRegression(C=0.3), X, y, store=FitStore(None))
    counts = {r["stage"]: r["calls"] for r in profile.rows() if r["stage"].startswith("fit_store.")}
    assert counts == {"fit_store.miss": 1, "fit_store.hit": 1, "fit_store.repeat": 1, "fit_store.off": 1}


def test_a_damaged_entry_is_refitted_loudly(tmp_path, data):
    X, y = data
    store = FitStore(tmp_path)
    fit_cached(LogisticRegression(), X, y, store=store)
    (entry,) = tmp_path.rglob("*.pkl")
    entry.write_bytes(b"not a pickle")
    with pytest.warns(UserWarning, match="unreadable fit-store entry"):
        model = fit_cached(LogisticRegression(), X, y, store=store)
    assert hasattr(model, "coef_")
    assert joblib.load(entry)["estimator"].coef_.shape == model.coef_.shape  # overwritten


def test_bank_fits_only_what_the_store_lacks_and_labels_its_fits(tmp_path):
    rng = np.random.default_rng(1)
    X = rng.normal(size=(60, 2, 3))
    g = np.repeat(np.arange(12), 5)
    A = np.stack([(np.arange(12) % 2)[g], (np.arange(12) // 6)[g]], axis=1)
    tiny = {"n_C": 1, "n_gamma": 1, "n_draws": 1, "cv": 3}
    before = fit_store_counts()
    first = AttributeClassifierBank(estimator=AttributeSVM(**tiny), attribute_names=["a", "b"], memory=tmp_path,
                                    random_state=0).fit(X, A, g)
    second = AttributeClassifierBank(estimator=AttributeSVM(**tiny), attribute_names=["x", "y"], memory=tmp_path,
                                     random_state=0, n_jobs=2).fit(X, A, g)  # other labels, other n_jobs: same fits
    after = fit_store_counts()
    assert after.get("miss", 0) - before.get("miss", 0) == 4
    assert after.get("hit", 0) - before.get("hit", 0) == 4
    np.testing.assert_array_equal(first.predict_proba(X), second.predict_proba(X))
    assert second.estimators_[1][0].name == "y (sensor 0)"  # the asking bank's label, not the stored one


def test_parallel_context_validates_backend():
    with parallel_context("loky"), parallel_context("threading"):
        pass
    with pytest.raises(ConfigError, match="backend must be one of"):
        parallel_context("mpi")
