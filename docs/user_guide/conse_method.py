"""ConSE as a tzsl method: one file, public imports only (docs/user_guide/extending.md, "A method").

Norouzi, Mikolov, Bengio, Singer, Shlens, Frome, Corrado and Dean, "Zero-shot learning by convex
combination of semantic embeddings", ICLR 2014. A classifier trained on the seen classes gives
``p(y | x)``; ConSE embeds a trial as the convex combination of the attribute rows of its ``T`` most
probable seen classes, weighted by those probabilities, and a decision rule compares that vector with
the unseen classes' rows (the paper: cosine similarity). In tzsl terms ConSE is an *attribute model*
with ``score_kind = "embedding"`` plus :class:`tzsl.models.NearestAttributeRule` with ``metric="cosine"``.

tests/models/test_method_authoring.py imports this file, registers it, fits it through
:func:`tzsl.models.build_method` and through a zero-shot study, and checks that it imports no private
name of tzsl; the user guide shows this file as it is.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval  # scikit-learn's parameter vocabulary, as its estimators use
from sklearn.utils.validation import check_is_fitted

from tzsl.models import NearestAttributeRule
from tzsl.models.base import (
    ValidatedParamsMixin,
    attribute_model_tags,
    register_method,
    training_classes,
    validate_features,
    validate_features_and_rows,
)

CONSE_PAPER = ("Norouzi et al. (2014): Zero-shot learning by convex combination of semantic embeddings. "
               "ICLR")


class ConSE(ValidatedParamsMixin, BaseEstimator):
    """ConSE attribute model: seen-class posteriors -> convex combination of their attribute rows.

    A multinomial logistic regression on standardised features gives each trial's posterior over the
    training classes (the distinct rows of ``Y``); the trial's attribute-space vector is
    ``f(x) = sum_t p(y_t | x) a(y_t) / sum_t p(y_t | x)`` over its ``n_top`` most probable training
    classes ``y_t`` with attribute rows ``a(y_t)``.

    Parameters
    ----------
    n_top : int >= 1, default=10
        ``T``: how many of the most probable training classes are combined (all when there are fewer).
    C : float > 0, default=1.0
        Inverse L2 regularisation of the logistic regression.

    Attributes
    ----------
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        The training classes' attribute rows, in the order of the classifier's classes.
    classifier_ : sklearn.pipeline.Pipeline
        The fitted scaler and logistic regression.
    n_attributes_ : int
    n_features_in_ : int
    """

    #: What :meth:`decision_function` returns: a vector in attribute space (read by the decision rule).
    score_kind = "embedding"

    _parameter_constraints: dict = {
        "n_top": [Interval(Integral, 1, None, closed="left")],
        "C": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(self, *, n_top=10, C=1.0):
        self.n_top = n_top
        self.C = C

    def __sklearn_tags__(self):
        return attribute_model_tags(super().__sklearn_tags__())

    def fit(self, X, Y, groups=None):
        """Fit the seen-class classifier.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        Y : array-like of shape (n_trials, n_attributes)
            Attribute row of each training trial's class; 1-D means one attribute.
        groups : array-like of shape (n_trials,), optional
            Object of each trial (orders the training classes when the objects are the classes).

        Returns
        -------
        self
        """
        self._validate_params()
        X, Y = validate_features_and_rows(self, X, Y)
        self.class_attributes_, y = training_classes(Y, type(self).__name__, groups)
        self.classifier_ = make_pipeline(StandardScaler(), LogisticRegression(C=self.C, max_iter=1000)).fit(X, y)
        self.n_attributes_ = Y.shape[1]
        return self

    def decision_function(self, X) -> np.ndarray:
        """Attribute-space vector of each trial: the posterior-weighted mean of its top training classes' rows.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)

        Returns
        -------
        ndarray of shape (n_trials, n_attributes)
            Convex combinations of training rows (in the rows' units), compared with class rows by the rule.
        """
        check_is_fitted(self)
        X = validate_features(self, X, reset=False)
        P = self.classifier_.predict_proba(X)  # (n_trials, n_train_classes), columns in class order
        T = min(self.n_top, P.shape[1])
        top = np.argsort(-P, axis=1, kind="stable")[:, :T]
        weights = np.take_along_axis(P, top, axis=1)
        weights /= weights.sum(axis=1, keepdims=True)
        return np.einsum("nt,ntm->nm", weights, self.class_attributes_[top])

    def predict(self, X) -> np.ndarray:
        """Same as :meth:`decision_function`: (n_trials, n_attributes) real scores."""
        return self.decision_function(X)


def register_conse(name: str = "conse") -> None:
    """Register ConSE under ``name``: the one line a method needs (cosine similarity, as in the paper)."""
    register_method(name, family="embedding", paper=CONSE_PAPER, attribute_model=ConSE,
                    decision_rule=NearestAttributeRule, preset={"metric": "cosine"},
                    description="seen-class posteriors -> convex combination of their attribute rows, cosine "
                                "nearest class")
