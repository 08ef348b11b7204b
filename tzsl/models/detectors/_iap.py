"""IAP: indirect attribute prediction.

Lampert, Nickisch and Harmeling, "Learning To Detect Unseen Object Classes by Between-Class
Attribute Transfer", CVPR 2009 (and TPAMI 2014). A probabilistic multi-class classifier over the
TRAINING classes ``z_1 .. z_K`` gives ``p(z_k | x)``; the class-attribute table ``A_k,m`` (0/1)
turns those into attribute posteriors

    p(a_m = 1 | x) = sum_k p(z_k | x) A_k,m                  (paper, section 3.2, "IAP")

which a DAP-style decision rule then maps to unseen classes. Here the training classes are the
distinct attribute rows of the fit ``A``; the classifier is any scikit-learn classifier with
``predict_proba`` (composed, not re-implemented).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, _fit_context, clone
from sklearn.linear_model import LogisticRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import HasMethods
from sklearn.utils.validation import check_is_fitted, validate_data

from tzsl._scoring import valid_probabilities
from tzsl.models._attribute_model_base import attribute_model_tags
from tzsl.models._zsl_input import training_classes, validate_features_and_rows

__all__ = ["IAP", "default_iap_classifier"]


def default_iap_classifier():
    """Standardise, then multinomial logistic regression (L2, C=1): IAP's default classifier."""
    return make_pipeline(StandardScaler(), LogisticRegression(C=1.0, max_iter=2000))


class IAP(BaseEstimator):
    """Indirect attribute prediction (Lampert, Nickisch and Harmeling, CVPR 2009).

    An attribute model: ``fit(X, A)`` trains ``classifier`` to recognise the training classes
    (distinct rows of ``A``); ``predict_proba(X)`` returns ``p(a_m = 1 | x) = sum_k p(z_k | x)
    A_k,m``.

    Parameters
    ----------
    classifier : estimator with ``fit`` and ``predict_proba``, or None, default=None
        Multi-class classifier over the training classes; cloned in ``fit``. None means
        :func:`default_iap_classifier` (StandardScaler + LogisticRegression).
    classifier_groups : bool, default=False
        Pass ``fit``'s ``groups`` to ``classifier.fit``: for a classifier that selects its
        hyper-parameters by grouped cross-validation, e.g.
        ``GridSearchCV(..., cv=GroupKFold())``, so that held-out folds are whole objects.

    Attributes
    ----------
    classifier_ : estimator
        The fitted clone; its classes are the indices ``0 .. K-1`` of ``class_attributes_``.
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        Distinct training attribute rows, one per training class.
    n_attributes_, n_features_in_ : int

    Notes
    -----
    ``score_kind = "probability"``. With attribute values in [0, 1] (0/1 labels, or fractions
    such as annotator agreement) the output is a probability; with other real attribute values it
    is the posterior mean ``E[a_m | x]`` (and ``predict``'s 0.5 threshold has no special meaning).
    """

    score_kind = "probability"

    _parameter_constraints: dict = {
        "classifier": [HasMethods(["fit", "predict_proba"]), None],
        "classifier_groups": ["boolean"],
    }

    def __init__(self, *, classifier=None, classifier_groups: bool = False):
        self.classifier = classifier
        self.classifier_groups = classifier_groups

    def __sklearn_tags__(self):
        return attribute_model_tags(super().__sklearn_tags__())

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y, groups=None):
        """Fit the class classifier on the training classes (distinct rows of ``A``).

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)
        y : array-like of shape (n_trials, n_attributes)
            ``A``: the attribute row of each trial's class; the distinct rows are the training
            classes. 0/1 (or in [0, 1]) for the output to be probabilities.
        groups : array-like of shape (n_trials,) or None
            Object id per trial. Passed on as ``classifier.fit(X, z, groups=groups)`` if
            ``classifier_groups``, else unused.

        Returns
        -------
        self : IAP
        """
        X, A = validate_features_and_rows(self, X, y)
        self.class_attributes_, z = training_classes(A, "IAP")
        clf = default_iap_classifier() if self.classifier is None else clone(self.classifier)
        if self.classifier_groups:
            self.classifier_ = clf.fit(X, z, groups=groups)
        else:
            self.classifier_ = clf.fit(X, z)
        self.n_attributes_ = A.shape[1]
        return self

    def predict_proba(self, X) -> np.ndarray:
        """Attribute posteriors ``p(a_m = 1 | x)``.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features)

        Returns
        -------
        P : ndarray of shape (n_trials, n_attributes)
            ``P = p(z | x) @ class_attributes_``; in [0, 1] for attributes in [0, 1] (the product's
            rounding past 1 in the last bit clipped back; keeping posteriors away from 0 and 1
            is the decision rule's job).
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        class_posteriors = self.classifier_.predict_proba(X)  # (n, K), columns in classes_ order
        rows = self.class_attributes_[np.asarray(self.classifier_.classes_, dtype=int)]
        if ((rows >= 0) & (rows <= 1)).all():
            return valid_probabilities(class_posteriors @ rows)
        return class_posteriors @ rows  # real-valued attributes: a posterior mean, not a probability

    def predict(self, X) -> np.ndarray:
        """Attribute decisions ``p(a_m = 1 | x) >= 0.5`` as an (n_trials, n_attributes) 0/1 int array."""
        return (self.predict_proba(X) >= 0.5).astype(int)
