"""What every attribute model shares: fit-data validation, tags and class scores.

An *attribute model* maps trials to per-attribute scores, ``X (n_trials, n_features) ->
(n_trials, n_attributes)``, and is fitted on ``(X, A)`` where ``A (n_trials, n_attributes)`` holds the
attribute row of each training trial's class. The training classes are the distinct rows of ``A``
(``np.unique(A, axis=0, return_inverse=True)``). A decision rule later compares the scores with a
class-attribute table given at predict time, so unseen classes need no refit.

Two kinds of score exist (class attribute ``score_kind``):

* ``"probability"``: per-attribute posteriors ``p(a_m = 1 | x)`` in [0, 1] (IAP, DAP);
* ``"embedding"``: a real vector in attribute space; ``default_rule`` names how it is compared with
  class rows: ``"cosine"`` (SAE) or ``"dot"`` (ALE, SJE, DeViSE).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl.models._eszsl import ZSLInputError

__all__ = [
    "EmbeddingAttributeModel",
    "attribute_model_tags",
    "cosine_scores",
    "dot_scores",
    "training_classes",
    "validate_class_attributes",
    "validate_fit_data",
]


def attribute_model_tags(tags):
    """Tags of a multi-output attribute model: ``y`` (= ``A``) is required and 2-D."""
    tags.target_tags.required = True
    tags.target_tags.multi_output = True
    tags.target_tags.single_output = False
    return tags


def validate_fit_data(est: BaseEstimator, X, y) -> tuple[np.ndarray, np.ndarray]:
    """Validate training features ``X`` (n, d) and attribute rows ``y`` = ``A`` (n, m).

    Both become finite float64; sets ``n_features_in_``. ``A`` must be 2-D (one attribute row per
    trial).
    """
    name = type(est).__name__
    if y is None:
        raise ValueError(f"{name} requires y to be passed, but the target y is None")
    X, A = validate_data(est, X, y, reset=True, dtype=np.float64, multi_output=True, y_numeric=True)
    A = np.asarray(A, dtype=np.float64)
    if A.ndim != 2:
        raise ZSLInputError(
            f"{name}: y must be a 2-D array (n_trials, n_attributes) of class attribute rows, "
            f"got shape {A.shape}"
        )
    return X, A


def training_classes(A: np.ndarray, est_name: str) -> tuple[np.ndarray, np.ndarray]:
    """Distinct attribute rows ``(z, m)`` of ``A`` (n, m) and each trial's row index ``(n,)``.

    At least two distinct rows are needed: one class cannot be told from another.
    """
    rows, index = np.unique(A, axis=0, return_inverse=True)
    if rows.shape[0] < 2:
        raise ZSLInputError(
            f"{est_name}: only one class (all training trials share one attribute row); at "
            "least 2 distinct class attribute rows are needed"
        )
    return rows, index.ravel()


def validate_class_attributes(S, n_attributes: int, est_name: str) -> np.ndarray:
    """A (k, m) class-attribute table as finite float64 with the fitted number of attributes."""
    S = np.asarray(S, dtype=np.float64)
    if S.ndim != 2 or S.shape[0] == 0 or S.shape[1] != n_attributes:
        raise ZSLInputError(
            f"{est_name}: class_attributes must be a (n_classes, {n_attributes}) array, "
            f"got shape {S.shape}"
        )
    if not np.isfinite(S).all():
        raise ZSLInputError(f"{est_name}: class_attributes holds non-finite values (NaN or inf)")
    return S


def dot_scores(E: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Compatibility ``E S^T``: (n, m) embeddings against (k, m) class rows -> (n, k)."""
    return E @ S.T


def cosine_scores(E: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Cosine similarity of (n, m) embeddings with (k, m) class rows -> (n, k), in [-1, 1].

    A zero vector (embedding or class row) has similarity 0 with everything.
    """
    En = np.linalg.norm(E, axis=1, keepdims=True)
    Sn = np.linalg.norm(S, axis=1, keepdims=True)
    return (E / np.where(En > 0, En, 1.0)) @ (S / np.where(Sn > 0, Sn, 1.0)).T


class EmbeddingAttributeModel(BaseEstimator):
    """Base of the linear embedding models: ``E = standardise(X) @ coef_.T``.

    Subclasses set ``coef_`` (n_attributes, n_features), ``scaler_`` (StandardScaler or None) and
    ``n_attributes_`` in ``fit``, and the class attribute ``default_rule``.
    """

    score_kind = "embedding"
    default_rule = "dot"

    def __sklearn_tags__(self):
        return attribute_model_tags(super().__sklearn_tags__())

    def _fit_scaler(self, X: np.ndarray) -> np.ndarray:
        """Fit ``scaler_`` on the training trials (if ``standardize``) and return scaled ``X``."""
        self.scaler_ = StandardScaler().fit(X) if self.standardize else None
        return X if self.scaler_ is None else self.scaler_.transform(X)

    def decision_function(self, X) -> np.ndarray:
        """Attribute-space embedding of each trial.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
            Features in the units they were fitted with (standardised inside if ``standardize``).

        Returns
        -------
        E : ndarray of shape (n_trials, n_attributes)
            Real scores, compared with class attribute rows by ``default_rule``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        if self.scaler_ is not None:
            X = self.scaler_.transform(X)
        return X @ self.coef_.T

    def predict(self, X) -> np.ndarray:
        """Same as :meth:`decision_function`: (n_trials, n_attributes) real scores."""
        return self.decision_function(X)

    def class_scores(self, X, class_attributes) -> np.ndarray:
        """Score every trial against every candidate class by ``default_rule``.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        class_attributes : array-like of shape (n_classes, n_attributes)
            Attribute rows of the candidate (typically unseen) classes.

        Returns
        -------
        scores : ndarray of shape (n_trials, n_classes)
            Larger means more compatible; ``argmax`` over axis 1 classifies.
        """
        E = self.decision_function(X)
        S = validate_class_attributes(class_attributes, self.n_attributes_, type(self).__name__)
        return cosine_scores(E, S) if self.default_rule == "cosine" else dot_scores(E, S)
