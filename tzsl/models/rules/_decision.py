"""Decision rules: attribute scores x a class-attribute table -> class scores, posteriors, ranking.

A zero-shot method is an *attribute model* (trials -> per-attribute scores, see
:class:`tzsl.models.ZeroShotClassifier`) plus one of these rules. The class-attribute table ``K``
(n_classes, n_attributes) arrives at predict time, so unseen classes need no refit. Fusion over
sensors, attribute priors and tie-breaking live here, once:

* :class:`DAPRule`: Direct Attribute Prediction (DAP paper eqs. 3-6) on attribute posteriors
  ``p(a_m = 1 | x)`` of shape (n, m) or per sensor (n, s, m), with AVGDAP/MAXDAP fusion over
  sensors and a ``uni``/``train``/``test`` (or explicit) attribute prior.
* :class:`CompatibilityRule`: bilinear compatibility ``score(x, z) = f(x) . a^z`` where
  ``f(x) = x W`` is a linear embedding into attribute space (ESZSL, ALE, SJE, DeViSE).
* :class:`NearestAttributeRule`: nearest class attribute vector to an estimated attribute
  vector ``f(x)`` (the fabric paper's lambda embedding, SAE), squared Euclidean or cosine.

The hand's single-grasp LDAP (:class:`tzsl.models.HandDAPClassifier`) fuses over fingers inside
its attribute layer (eqs. 7-10, :func:`tzsl.models.hand.fuse_grasp_posteriors`) and then applies DAP
through this rule with its prior (:meth:`~tzsl.models.HandDAPClassifier.dap_rule`): with ``prior=0.5``,
``hand.predict_log_scores(X, K)`` equals
``DAPRule(prior="uni").fit(A).decision_function(hand.predict_attribute_proba(X), K)``
(a 2-D posterior is one sensor, so ``fusion`` does not matter). Studies, DF-MDAP and the active-touch model
score their fused posteriors through the rule too; only the load-once predictor of a saved bundle
(:mod:`tzsl.inference`, without scikit-learn) calls the same arithmetic (:mod:`tzsl.models.dap`) directly.

Every rule has ``fit(A, groups=None)`` (training attribute rows; only the ``train`` prior uses
them), ``decision_function(scores, K)``, ``predict_proba(scores, K)`` (softmax over the given
classes) and ``predict(scores, K, random_state=None)`` (row indices into ``K``; exact ties
broken uniformly at random, seeded, by :func:`tzsl.models.dap.break_ties`).
"""

from __future__ import annotations

from numbers import Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted

from tzsl._scoring import class_posteriors, compatibility_scores, cosine_similarities, squared_distances
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models._dap import (
    DEFAULT_EPS,
    attribute_prior,
    break_ties,
    check_attribute_posteriors,
    check_class_attributes,
    dap_log_scores,
    fuse_attribute_posteriors,
)
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.value_lists import FUSIONS, PRIORS

__all__ = [
    "SCORE_KINDS",
    "CompatibilityRule",
    "DAPRule",
    "DecisionRule",
    "NearestAttributeRule",
    "check_real_class_attributes",
]

#: Kinds of attribute scores an attribute model can give (its ``score_kind`` class attribute).
SCORE_KINDS = ("probability", "embedding")


def check_real_class_attributes(K, n_attributes: int | None = None, what: str = "class-attribute table"):
    """A real-valued class-attribute table (n_classes, n_attributes) as finite float64.

    Raises
    ------
    DataFileError
        Not 2-D, empty, non-numeric, non-finite (naming row and column), or a column count
        different from ``n_attributes``.
    """
    try:
        K = np.asarray(K, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise DataFileError(None, f"{what} must be a numeric (classes x attributes) array: {exc}") from exc
    if K.ndim != 2 or K.shape[0] == 0 or K.shape[1] == 0:
        raise DataFileError(None, f"{what} must be a non-empty 2-D array (classes x attributes), got shape {K.shape}")
    bad = np.argwhere(~np.isfinite(K))
    if bad.size:
        r, c = bad[0]
        raise DataFileError(None, f"{what}: non-finite value {K[r, c]} at row {r}, column {c}")
    if n_attributes is not None and K.shape[1] != n_attributes:
        raise DataFileError(
            None, f"{what} has {K.shape[1]} attribute columns; the model knows {n_attributes} attributes"
        )
    return K


class DecisionRule(ValidatedParamsMixin, BaseEstimator):
    """Base of the decision rules; subclasses define ``accepts`` and ``_class_scores``.

    A rule reads an attribute model's scores for ``n_trials`` trials and a class-attribute table ``K``
    (n_classes, n_attributes) given at predict time, and gives class scores (n_trials, n_classes), larger
    is better. A subclass sets ``accepts`` (the ``score_kind`` values of :data:`SCORE_KINDS` it reads),
    ``binary_attributes`` (True when ``K`` must be 0/1), ``_parameter_constraints`` and
    ``_class_scores(scores, K) -> (n_trials, n_classes)``; it may override ``_fit_rows(A, groups)`` to keep
    something of the training rows and ``_check_scores`` for another score shape (DAP's per-sensor
    posteriors). ``fit``, ``decision_function``, ``predict_proba`` and ``predict`` are written here once.

    Attributes
    ----------
    n_attributes_ : int
        Attribute count of the training rows given to :meth:`fit`.
    """

    #: ``score_kind`` values of attribute models this rule can read.
    accepts: tuple[str, ...] = ()
    #: Whether class tables must be 0/1.
    binary_attributes: bool = False

    def _check_table(self, K, n_attributes=None, what="class-attribute table") -> np.ndarray:
        if self.binary_attributes:
            return check_class_attributes(K, n_attributes, what=what)
        return check_real_class_attributes(K, n_attributes, what=what)

    def fit(self, A, groups=None):
        """Remember what the rule needs from the training attribute rows.

        Parameters
        ----------
        A : array-like of shape (n_trials, n_attributes)
            Attribute row of each training trial's class.
        groups : array-like of shape (n_trials,), optional
            Object of each trial (the ``train`` prior counts each object once).

        Returns
        -------
        self
        """
        self._validate_params()
        A = np.asarray(A)
        A = self._check_table(A.reshape(-1, 1) if A.ndim == 1 else A, what="training attribute rows")
        self.n_attributes_ = A.shape[1]
        self._fit_rows(A, groups)
        return self

    def _fit_rows(self, A: np.ndarray, groups) -> None:
        """Hook for rules that keep something of the training rows."""

    def _class_scores(self, scores: np.ndarray, K: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _check_scores(self, scores) -> np.ndarray:
        S = np.asarray(scores, dtype=np.float64)
        if S.ndim != 2 or S.shape[1] != self.n_attributes_:
            raise ConfigError(
                f"{type(self).__name__}: attribute scores must have shape (n_trials, {self.n_attributes_}), "
                f"got {S.shape}"
            )
        if not np.isfinite(S).all():
            raise ConfigError(f"{type(self).__name__}: attribute scores hold NaN or infinite values")
        return S

    def decision_function(self, scores, class_attributes) -> np.ndarray:
        """Class scores; larger is better.

        Parameters
        ----------
        scores : array-like of shape (n_trials, n_attributes) (or (n_trials, n_sensors, n_attributes) for DAP)
            The attribute model's output for the trials.
        class_attributes : array-like of shape (n_classes, n_attributes)
            Candidate classes, one attribute row each.

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
        """
        check_is_fitted(self)
        K = self._check_table(class_attributes, self.n_attributes_)
        return self._class_scores(scores, K)

    def predict_proba(self, scores, class_attributes) -> np.ndarray:
        """Softmax of :meth:`decision_function` over the given classes; rows sum to 1."""
        return class_posteriors(self.decision_function(scores, class_attributes))

    def predict(self, scores, class_attributes, random_state=None) -> np.ndarray:
        """Best class per trial as a row index into ``class_attributes``; ties broken at random.

        Returns
        -------
        ndarray of shape (n_trials,), int
        """
        return break_ties(self.decision_function(scores, class_attributes), random_state)


class DAPRule(DecisionRule):
    """Direct Attribute Prediction over attribute posteriors (DAP paper eqs. 3-6, §4.5).

    Parameters
    ----------
    fusion : {"avg", "max"}, default="avg"
        AVGDAP (eq. 6) or MAXDAP (eq. 5) over sensors; no effect on 2-D posteriors.
    prior : {"uni", "train", "test"} or array-like of shape (n_attributes,), default="train"
        Attribute prior ``p(a_m = 1)``: 0.5, the mean row of the training objects, the mean row
        of the candidate classes, or given.
    eps : float in (0, 0.5), default=1e-6
        Probabilities are clipped to ``[eps, 1 - eps]`` in the log-space product.

    Attributes
    ----------
    train_prior_ : ndarray of shape (n_attributes,)
        Mean attribute row of the training objects (each object once when ``groups`` is given).
    n_attributes_ : int
    """

    accepts = ("probability",)
    binary_attributes = True
    _parameter_constraints: dict = {
        "fusion": [StrOptions(set(FUSIONS))],
        "prior": [StrOptions(set(PRIORS)), "array-like"],
        "eps": [Interval(Real, 0, 0.5, closed="neither")],
    }

    def __init__(self, *, fusion="avg", prior="train", eps=DEFAULT_EPS):
        self.fusion = fusion
        self.prior = prior
        self.eps = eps

    def _fit_rows(self, A, groups) -> None:
        self.train_prior_ = attribute_prior("train", train_attributes=A, groups=groups)

    def class_prior(self, class_attributes) -> np.ndarray:
        """The attribute prior ``p(a_m = 1)`` used against ``class_attributes``; shape (n_attributes,)."""
        check_is_fitted(self)
        K = check_class_attributes(class_attributes, self.n_attributes_)
        if isinstance(self.prior, str):
            if self.prior == "train":
                return self.train_prior_
            return attribute_prior(self.prior, class_attributes=K)
        pr = attribute_prior(self.prior)
        if pr.shape != (K.shape[1],):
            raise ConfigError(f"prior has {pr.size} entries for {K.shape[1]} attributes")
        return pr

    def _check_scores(self, scores) -> np.ndarray:
        P = check_attribute_posteriors(scores)
        if P.shape[-1] != self.n_attributes_:
            raise ConfigError(
                f"DAPRule: posteriors have {P.shape[-1]} attributes; the rule was fitted on {self.n_attributes_}"
            )
        return P

    def _class_scores(self, scores, K) -> np.ndarray:
        present, absent = fuse_attribute_posteriors(self._check_scores(scores), self.fusion)
        return dap_log_scores(present, K, self.class_prior(K), P_absent=absent, eps=self.eps)


class CompatibilityRule(DecisionRule):
    """Bilinear compatibility ``s(x, z) = f(x) @ a^z`` of a linear attribute embedding.

    ``f(x)`` is the attribute model's ``decision_function`` (ESZSL: ``x V``); class scores are
    ``f(X) K^T``. No parameters.
    """

    accepts = ("embedding",)
    _parameter_constraints: dict = {}

    def _class_scores(self, scores, K) -> np.ndarray:
        return compatibility_scores(self._check_scores(scores), K)


class NearestAttributeRule(DecisionRule):
    """Nearest class attribute vector to the estimated attribute vector ``f(x)``.

    Parameters
    ----------
    metric : {"sqeuclidean", "cosine"}, default="sqeuclidean"
        Class score ``-||f(x) - a^z||^2`` (the fabric paper's ``o_i(c)``, eq. 3), or the cosine
        similarity of ``f(x)`` and ``a^z`` (an all-zero vector has similarity 0 to everything).
    """

    accepts = ("embedding",)
    _parameter_constraints: dict = {"metric": [StrOptions({"sqeuclidean", "cosine"})]}

    def __init__(self, *, metric="sqeuclidean"):
        self.metric = metric

    def _class_scores(self, scores, K) -> np.ndarray:
        F = self._check_scores(scores)
        if self.metric == "sqeuclidean":
            return -squared_distances(F, K)
        return cosine_similarities(F, K)
