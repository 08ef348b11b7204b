"""The prediction side shared by the binary attribute classifiers that map a raw score to a
posterior with a Platt sigmoid (:class:`~tzsl.models.AttributeSVM`,
:class:`~tzsl.models.ScalableAttributeClassifier`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.special import expit
from sklearn.utils.validation import check_is_fitted

__all__ = ["PlattBinaryClassifierMixin"]


class PlattBinaryClassifierMixin:
    """``decision_function``, ``predict_proba`` and ``predict`` of a binary classifier from its
    raw score and Platt parameters.

    The class provides ``svm_score(X)`` (raw score, shape (n_trials,), positive towards
    ``classes_[1]``), and ``fit`` sets ``platt_ = (a, b)`` and ``classes_`` (2,). Put the mixin
    before :class:`~sklearn.base.ClassifierMixin` in the bases. ``name`` (an attribute name or
    None) labels messages.
    """

    if TYPE_CHECKING:  # what the class provides (declared, never set here)
        name: str | None
        platt_: tuple[float, float]
        classes_: np.ndarray

        def svm_score(self, X) -> np.ndarray: ...

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.classifier_tags.multi_class = False
        return tags

    def _label(self) -> str:
        return f"attribute {self.name!r}" if self.name is not None else "attribute"

    def decision_function(self, X) -> np.ndarray:
        """Logit of ``p(classes_[1] | x)`` (Platt-mapped score); shape (n_trials,)."""
        check_is_fitted(self)
        a, b = self.platt_
        return a * self.svm_score(X) + b

    def predict_proba(self, X) -> np.ndarray:
        """Posteriors, shape (n_trials, 2), columns ordered as ``classes_``."""
        p1 = expit(self.decision_function(X))
        return np.column_stack([1.0 - p1, p1])

    def predict(self, X) -> np.ndarray:
        """Class with posterior >= 0.5, shape (n_trials,)."""
        check_is_fitted(self)
        return self.classes_[(self.decision_function(X) >= 0).astype(int)]
