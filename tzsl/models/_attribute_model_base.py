"""What the attribute models of IAP, SAE and the compatibility models share: tags and the linear embedding.

An *attribute model* maps trials to per-attribute scores, ``X (n_trials, n_features) ->
(n_trials, n_attributes)``, and is fitted on ``(X, A)`` where ``A (n_trials, n_attributes)`` holds the
attribute row of each training trial's class. The training classes are the distinct rows of ``A``
(``np.unique(A, axis=0, return_inverse=True)``). A decision rule later compares the scores with a
class-attribute table given at predict time, so unseen classes need no refit.

Two kinds of score exist (class attribute ``score_kind``):

* ``"probability"``: per-attribute posteriors ``p(a_m = 1 | x)`` in [0, 1] (IAP, DAP);
* ``"embedding"``: a real vector in attribute space, compared with class rows by the method's
  decision rule (registered in :mod:`tzsl.models._builtin_methods`): cosine
  :class:`~tzsl.models.NearestAttributeRule` (SAE) or :class:`~tzsl.models.CompatibilityRule`
  (ALE, SJE, DeViSE).

Input checks and the training classes come from :mod:`tzsl.models._zsl_input`
(:func:`validate_features_and_rows`, :func:`training_classes`), shared with ESZSL and the
lambda embedding.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl._scoring import linear_embedding

__all__ = ["EmbeddingAttributeModel", "attribute_model_tags", "attribute_table_tags"]


def attribute_table_tags(tags):
    """Tags of an estimator fitted on an attribute table: ``y`` (= ``A``, one row per trial) is required
    and may be 2-D (the zero-shot classifiers, ESZSL, the calibrator, the ensemble)."""
    tags.target_tags.required = True
    tags.target_tags.multi_output = True
    return tags


def attribute_model_tags(tags):
    """Tags of a multi-output attribute model: ``y`` (= ``A``) is required and 2-D."""
    tags = attribute_table_tags(tags)
    tags.target_tags.single_output = False
    return tags


class EmbeddingAttributeModel(BaseEstimator):
    """Base of the linear embedding models: ``E = standardise(X) @ coef_.T``.

    Subclasses set ``coef_`` (n_attributes, n_features), ``scaler_`` (StandardScaler or None) and
    ``n_attributes_`` in ``fit``.
    """

    score_kind = "embedding"

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
            Real scores, compared with class attribute rows by the method's decision rule.
        """
        check_is_fitted(self)
        return linear_embedding(validate_data(self, X, reset=False, dtype=np.float64), **self.linear_map())

    def linear_map(self) -> dict[str, np.ndarray]:
        """The fitted map as arrays, so that ``decision_function(X) == linear_embedding(X, **linear_map())``.

        Returns
        -------
        dict
            ``weights`` (n_features, n_attributes) (``coef_.T``) and, when standardised, the
            scaler's ``mean`` and ``scale`` (n_features,).
        """
        check_is_fitted(self)
        scaler = {} if self.scaler_ is None else {"mean": self.scaler_.mean_, "scale": self.scaler_.scale_}
        return {"weights": self.coef_.T, **scaler}

    def predict(self, X) -> np.ndarray:
        """Same as :meth:`decision_function`: (n_trials, n_attributes) real scores."""
        return self.decision_function(X)
