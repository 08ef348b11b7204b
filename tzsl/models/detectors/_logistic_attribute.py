"""z-score + L2 logistic regression: the default per-(attribute, sensor) classifier of the per-EP models.

Its posteriors come straight from a log-loss fit (no separate Platt cross-validation), it has no
hyper-parameter grid and a fit takes milliseconds (:class:`tzsl.models.PerEPAttributeModel`).
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, _fit_context
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl._parallel import one_blas_thread

__all__ = ["LogisticAttribute"]


class LogisticAttribute(ClassifierMixin, BaseEstimator):
    """z-score + L2 logistic regression for one attribute and one sensor.

    ``fit(X, y, groups=None)`` accepts (and ignores) the object groups that
    :class:`tzsl.models.AttributeClassifierBank` passes to every classifier.

    Parameters
    ----------
    C : float, default=1.0
        Inverse L2 strength (on z-scored features).
    class_weight : {"balanced"}, dict or None, default="balanced"
        ``"balanced"`` gives posteriors for a 50% attribute prior (as the DAP study's balanced Platt map).
    max_iter : int, default=1000

    Attributes
    ----------
    classes_ : ndarray of shape (2,)
    pipeline_ : fitted Pipeline
    n_iter_ : ndarray of shape (1,)
    n_features_in_ : int
    """

    _parameter_constraints: dict = {
        "C": [Interval(Real, 0, None, closed="neither")],
        "class_weight": [dict, StrOptions({"balanced"}), None],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(self, *, C=1.0, class_weight="balanced", max_iter=1000):
        self.C = C
        self.class_weight = class_weight
        self.max_iter = max_iter

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, groups=None):
        """Fit on trials ``X`` of shape (n, d) with labels ``y`` of shape (n,); ``groups`` is unused."""
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        lr = LogisticRegression(C=self.C, class_weight=self.class_weight, max_iter=self.max_iter,
                                solver="newton-cholesky")  # exact L2 fit, faster than lbfgs on ~50 columns
        with one_blas_thread():  # a small dense problem: extra BLAS threads only spin (tzsl._parallel.one_blas_thread)
            self.pipeline_ = make_pipeline(StandardScaler(), lr).fit(X, y)
        self.classes_ = self.pipeline_.classes_
        self.n_iter_ = self.pipeline_[-1].n_iter_
        return self

    def predict_proba(self, X) -> np.ndarray:
        """Posteriors of shape (n, n_classes), columns ordered as ``classes_``."""
        check_is_fitted(self)
        return self.pipeline_.predict_proba(validate_data(self, X, dtype=np.float64, reset=False))

    def decision_function(self, X) -> np.ndarray:
        """Logit(s) of the fitted logistic regression."""
        check_is_fitted(self)
        return self.pipeline_.decision_function(validate_data(self, X, dtype=np.float64, reset=False))

    def predict(self, X) -> np.ndarray:
        """Most probable class, shape (n,)."""
        check_is_fitted(self)
        return self.classes_[self.predict_proba(X).argmax(axis=1)]
