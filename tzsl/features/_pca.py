"""Z-scoring and PCA to a variance target with a cap (DAP paper section 4.3).

"The computed features were then normalized to have zero mean and standard deviation of
1. [...] This high dimension was reduced using Principal Component Analysis (PCA) to a
25-dimensional vector that justifies 95% of the variance."
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator, ClassNamePrefixFeaturesOutMixin, TransformerMixin
from sklearn.decomposition import PCA
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl.exceptions import ConfigError


class VariancePCA(ClassNamePrefixFeaturesOutMixin, TransformerMixin, BaseEstimator):
    """Standardise features, then keep the fewest principal components reaching a variance.

    ``fit`` z-scores every column (:class:`~sklearn.preprocessing.StandardScaler`:
    zero mean, unit population standard deviation; constant columns are only centred),
    runs a full-SVD PCA on the z-scores and keeps the smallest ``k`` whose cumulative
    explained-variance ratio is ``>= variance``, capped at ``max_components`` (and at
    ``min(n_samples, n_features)``). Deterministic: no random state is involved.

    Fit it on training objects only; apply it to each BioTac (sensor) separately, as the
    paper does (the BioTacs are not calibrated against each other).

    Parameters
    ----------
    variance : float in (0, 1], default 0.95
        Fraction of the (z-scored) total variance the kept components must explain.
    max_components : int >= 1 or None, default 25
        Upper bound on the number of components; ``None`` for no cap.
    whiten : bool, default False
        Scale the components to unit variance (see :class:`~sklearn.decomposition.PCA`).

    Attributes
    ----------
    scaler_ : StandardScaler
        The fitted z-scoring.
    pca_ : PCA
        The fitted PCA with ``n_components_`` components.
    n_components_ : int
        Number of kept components ``k``.
    explained_variance_ratio_ : ndarray of shape (n_components,)
        Share of the z-scored total variance explained by each kept component.
    reached_variance_ : float
        Sum of ``explained_variance_ratio_`` (below ``variance`` when the cap bites).
    n_features_in_ : int
        Number of input features.
    feature_names_in_ : ndarray of str
        Input column names, when fitted on a DataFrame with string column names.
    """

    def __init__(
        self, variance: float = 0.95, max_components: int | None = 25, whiten: bool = False
    ) -> None:
        self.variance = variance
        self.max_components = max_components
        self.whiten = whiten

    def _check_params(self) -> None:
        v = self.variance
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not 0.0 < v <= 1.0:
            raise ConfigError(f"variance must be a number in (0, 1], got {v!r}")
        m = self.max_components
        if m is not None and (isinstance(m, bool) or not isinstance(m, numbers.Integral) or m < 1):
            raise ConfigError(f"max_components must be a positive integer or None, got {m!r}")

    def fit(self, X, y=None) -> "VariancePCA":
        """Fit the z-scoring and the PCA.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features), n_samples >= 2
            Feature vectors (any units; z-scoring makes them comparable).
        y : ignored

        Returns
        -------
        self
        """
        self._check_params()
        X = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        self.scaler_ = StandardScaler().fit(X)
        Z = self.scaler_.transform(X)
        if not np.any(Z.var(axis=0) > 0):
            # Every column is constant: no direction carries variance.
            raise ValueError(
                "VariancePCA: the training features have no variance (every column is "
                "constant); PCA cannot choose components"
            )
        ratio = PCA(n_components=None, svd_solver="full").fit(Z).explained_variance_ratio_
        cumulative = np.cumsum(ratio)
        # smallest k with cumulative[k-1] >= variance (tolerate rounding of the last sum)
        k = int(np.searchsorted(cumulative, float(self.variance) - 1e-12, side="left")) + 1
        k = min(k, ratio.shape[0])
        if self.max_components is not None:
            k = min(k, int(self.max_components))
        self.pca_ = PCA(n_components=k, svd_solver="full", whiten=self.whiten).fit(Z)
        self.n_components_ = int(self.pca_.n_components_)
        self.explained_variance_ratio_ = self.pca_.explained_variance_ratio_.copy()
        self.reached_variance_ = float(self.explained_variance_ratio_.sum())
        self._n_features_out = self.n_components_
        return self

    def transform(self, X) -> np.ndarray:
        """Project onto the kept components.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features_in)

        Returns
        -------
        ndarray of float64, shape (n_samples, n_components)
            Principal-component scores of the z-scored features (unit variance per
            component when ``whiten``).
        """
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, reset=False)
        return self.pca_.transform(self.scaler_.transform(X))

    def inverse_transform(self, X) -> np.ndarray:
        """Map component scores back to the original feature space (units of the input).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_components)

        Returns
        -------
        ndarray of float64, shape (n_samples, n_features_in)
        """
        check_is_fitted(self)
        X = np.asarray(X, dtype=np.float64)
        return self.scaler_.inverse_transform(self.pca_.inverse_transform(X))
