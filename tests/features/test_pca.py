"""Z-scoring + PCA to a variance target with a cap."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

from tzsl.exceptions import ConfigError
from tzsl.features import VariancePCA


@parametrize_with_checks([VariancePCA(), VariancePCA(variance=0.5, max_components=2, whiten=True)])
def test_sklearn_compatible(estimator, check):
    check(estimator)


def _low_rank(n=200, d=10, rank=3, noise=0.01, seed=0):
    rng = np.random.default_rng(seed)
    latent = rng.normal(size=(n, rank)) * np.array([5.0, 2.0, 1.0])[:rank]
    X = latent @ rng.normal(size=(rank, d)) + noise * rng.normal(size=(n, d))
    return X * rng.uniform(0.1, 100, size=d)  # columns in wildly different units


def _reference_k(X, variance):
    """Smallest k whose cumulative z-scored explained variance reaches ``variance``."""
    std = X.std(0)
    Z = (X - X.mean(0)) / np.where(std > 0, std, 1.0)
    s = np.linalg.svd(Z, compute_uv=False)
    ratio = np.cumsum(s**2) / np.sum(s**2)
    return int(np.argmax(ratio >= variance - 1e-12)) + 1, ratio


@pytest.mark.parametrize("variance", [0.5, 0.8, 0.95, 0.999])
def test_smallest_k_reaching_variance(variance):
    X = _low_rank(rank=3, noise=0.05)
    est = VariancePCA(variance=variance, max_components=None).fit(X)
    k, ratio = _reference_k(X, variance)
    assert est.n_components_ == k
    assert est.reached_variance_ >= variance - 1e-12
    if k > 1:
        assert ratio[k - 2] < variance  # one fewer would not reach it
    assert est.transform(X).shape == (200, k)


def test_rank_and_cap():
    X = _low_rank(rank=3, noise=0.0)
    assert VariancePCA(variance=1.0, max_components=None).fit(X).n_components_ == 3
    capped = VariancePCA(variance=1.0, max_components=2).fit(X)
    assert capped.n_components_ == 2 and capped.reached_variance_ < 1.0
    assert VariancePCA(variance=1.0, max_components=50).fit(X[:5]).n_components_ <= 5


def test_zscore_then_project():
    X = _low_rank(rank=3, noise=0.05)
    est = VariancePCA(variance=0.95).fit(X)
    T = est.transform(X)
    np.testing.assert_allclose(T.mean(0), 0, atol=1e-9)
    # scores are projections of the z-scores: variances equal the PCA eigenvalues
    np.testing.assert_allclose(T.var(0, ddof=1), est.pca_.explained_variance_, rtol=1e-9)
    np.testing.assert_allclose(est.scaler_.scale_, X.std(0))
    white = VariancePCA(variance=0.95, whiten=True).fit(X).transform(X)
    np.testing.assert_allclose(white.std(0, ddof=1), 1.0, rtol=1e-9)
    assert list(est.get_feature_names_out()) == [f"variancepca{i}" for i in range(est.n_components_)]


@pytest.mark.parametrize(
    "params", [{"variance": 0.0}, {"variance": 1.5}, {"variance": "95%"}, {"max_components": 0},
               {"max_components": 2.5}, {"max_components": True}]
)
def test_bad_params(params):
    with pytest.raises(ConfigError):
        VariancePCA(**params).fit(_low_rank())


def test_constant_features():
    with pytest.raises(ValueError, match="no variance"):
        VariancePCA().fit(np.ones((10, 4)))


@pytest.mark.realdata
def test_penn_per_finger_dimension(penn_data):
    """The paper's 95%-variance PCA of one BioTac's features (reported, and capped at 25)."""
    from tzsl.features import select_penn_columns

    X, _ = select_penn_columns(penn_data.X, penn_data.eps)
    for f in (0, 1):
        est = VariancePCA().fit(X[:, f])
        k, _ = _reference_k(X[:, f], 0.95)
        assert est.n_components_ == min(k, 25)
        assert 1 < est.n_components_ <= 25
