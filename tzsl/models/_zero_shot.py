"""The one zero-shot classifier: an attribute model composed with a decision rule.

Every zero-shot method of tzsl that learns attributes from features is a
:class:`ZeroShotClassifier`:

* the **attribute model** is an ordinary multi-output scikit-learn estimator. ``fit(X, A,
  groups=None)`` takes the trials' features ``X`` (n, d) (the PHAC-2 sensor bank: (n, s, d)),
  each trial's class attribute row ``A`` (n, m) and optionally each trial's object (``groups``,
  for grouped tuning). Models that need training classes take the distinct rows of ``A``. Its
  class attribute ``score_kind`` says what it outputs: ``"probability"`` models give
  ``predict_proba(X)`` = ``p(a_m = 1 | x)`` of shape (n, m) or (n, s, m) (AttributeSVM bank,
  classifier chain); ``"embedding"`` models give ``decision_function(X)`` = attribute-space
  scores (n, m) (ESZSL's ``x V``, the lambda embedding's estimated attribute vector).
* the **decision rule** (:mod:`tzsl.models.rules._decision`) maps those scores and a class-attribute
  table given at predict time to class scores; priors, fusion and tie-breaking live there.

Studies that apply several rules to the same attribute scores (the DAP tables: max/avg fusion x
uni/train/test prior) call :meth:`ZeroShotClassifier.attribute_scores` once and then the
``*_from_scores`` methods with ``decision_rule=...``.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.utils._param_validation import HasMethods
from sklearn.utils.validation import check_is_fitted

from tzsl.exceptions import ConfigError
from tzsl.models._attribute_model_base import attribute_table_tags
from tzsl.models._validation import ValidatedParamsMixin
from tzsl.models.rules import SCORE_KINDS

__all__ = ["ZeroShotClassifier", "score_kind", "zscore_rows"]


def score_kind(attribute_model) -> str:
    """The ``score_kind`` an attribute model declares: ``"probability"`` or ``"embedding"``.

    Raises
    ------
    ConfigError
        The model declares none or an unknown one.
    """
    kind = getattr(attribute_model, "score_kind", None)
    if kind not in SCORE_KINDS:
        raise ConfigError(
            f"{type(attribute_model).__name__} is not a tzsl attribute model: it needs a class attribute "
            f"score_kind in {SCORE_KINDS} (got {kind!r})"
        )
    return kind


def zscore_rows(S: np.ndarray) -> np.ndarray:
    """Each row z-scored across its columns (a constant row becomes 0).

    Parameters
    ----------
    S : ndarray of shape (n_trials, n_classes)

    Returns
    -------
    ndarray of shape (n_trials, n_classes)
    """
    S = np.asarray(S, dtype=np.float64)
    sd = S.std(axis=1, keepdims=True)
    return (S - S.mean(axis=1, keepdims=True)) / np.where(sd > 0, sd, 1.0)


class ZeroShotClassifier(ValidatedParamsMixin, BaseEstimator):
    """Attribute model + decision rule: recognise classes never seen in training.

    Parameters
    ----------
    attribute_model : estimator
        ``fit(X, A, groups=None)``; ``predict_proba(X)`` (``score_kind = "probability"``) or
        ``decision_function(X)`` (``score_kind = "embedding"``). Cloned in :meth:`fit`.
    decision_rule : decision rule
        A :class:`tzsl.models.DecisionRule` whose ``accepts`` holds the model's ``score_kind``
        (e.g. :class:`~tzsl.models.DAPRule` for probabilities,
        :class:`~tzsl.models.CompatibilityRule` / :class:`~tzsl.models.NearestAttributeRule`
        for embeddings). Cloned and fitted on the training attribute rows in :meth:`fit`.
    random_state : int, RandomState instance or None, default=None
        Seeds the breaking of exact ties in :meth:`predict`.

    Attributes
    ----------
    attribute_model_ : fitted attribute model
    decision_rule_ : fitted decision rule
    class_attributes_ : ndarray of shape (n_train_classes, n_attributes)
        Distinct training attribute rows; the default candidate classes.
    train_attributes_ : ndarray of shape (n_trials, n_attributes)
        The training rows ``A`` (rules given to the ``*_from_scores`` methods are fitted on them).
    train_groups_ : ndarray of shape (n_trials,) or None
    n_attributes_ : int
    n_features_in_ : int
        When the attribute model has it.
    """

    _parameter_constraints: dict = {
        "attribute_model": [HasMethods(["fit"])],
        "decision_rule": [HasMethods(["fit", "decision_function", "predict"])],
        "random_state": ["random_state"],
    }

    def __init__(self, *, attribute_model=None, decision_rule=None, random_state=None):
        self.attribute_model = attribute_model
        self.decision_rule = decision_rule
        self.random_state = random_state

    def __sklearn_tags__(self):
        return attribute_table_tags(super().__sklearn_tags__())

    def _check_compatible(self, rule) -> None:
        kind = score_kind(self.attribute_model)
        if kind not in getattr(rule, "accepts", ()):
            raise ConfigError(
                f"{type(rule).__name__} reads {getattr(rule, 'accepts', ())} scores, but "
                f"{type(self.attribute_model).__name__} gives {kind!r} scores"
            )

    def fit(self, X, Y, groups=None):
        """Fit the attribute model and the decision rule on training trials.

        Parameters
        ----------
        X : array-like of shape (n_trials, n_features) or (n_trials, n_sensors, n_features)
            Features, as the attribute model takes them.
        Y : array-like of shape (n_trials, n_attributes)
            The protocol's ``A``: attribute row of each trial's (training) class (named ``Y``
            as scikit-learn names a multi-output target); 1-D means one attribute.
        groups : array-like of shape (n_trials,), optional
            Object of each trial (grouped tuning, one ``train`` prior row per object, class
            order; see :func:`tzsl.models.protocol.training_classes`).

        Returns
        -------
        self
        """
        self._validate_params()
        self._check_compatible(self.decision_rule)
        if Y is None:
            raise ValueError(f"{type(self).__name__} requires y to be passed, but the target y is None")
        A = np.asarray(Y)
        if A.ndim == 1:
            A = A.reshape(-1, 1)
        model = clone(self.attribute_model).fit(X, A, groups=groups)
        self.attribute_model_ = model
        self.decision_rule_ = clone(self.decision_rule).fit(A, groups)
        self.train_attributes_ = np.asarray(A, dtype=np.float64)
        self.train_groups_ = None if groups is None else np.asarray(groups)
        self.class_attributes_ = np.unique(self.train_attributes_, axis=0)
        self.n_attributes_ = self.train_attributes_.shape[1]
        if hasattr(model, "n_features_in_"):
            self.n_features_in_ = model.n_features_in_
        return self

    # ------------------------------------------------------------------ attribute scores
    def attribute_scores(self, X) -> np.ndarray:
        """The attribute model's output for ``X``.

        Returns
        -------
        ndarray of shape (n_trials, n_attributes) or (n_trials, n_sensors, n_attributes)
            Posteriors ``p(a_m = 1 | x)`` or attribute-space scores (see ``score_kind``).
        """
        check_is_fitted(self)
        if score_kind(self.attribute_model_) == "probability":
            return self.attribute_model_.predict_proba(X)
        return self.attribute_model_.decision_function(X)

    def _rule(self, decision_rule):
        if decision_rule is None:
            return self.decision_rule_
        self._check_compatible(decision_rule)
        return clone(decision_rule).fit(self.train_attributes_, self.train_groups_)

    def _table(self, class_attributes):
        return self.class_attributes_ if class_attributes is None else class_attributes

    # ------------------------------------------------------------------ from precomputed scores
    def decision_function_from_scores(self, scores, class_attributes=None, *, decision_rule=None) -> np.ndarray:
        """Class scores from :meth:`attribute_scores`, optionally under another rule.

        Parameters
        ----------
        scores : ndarray
            Output of :meth:`attribute_scores`.
        class_attributes : array-like of shape (n_classes, n_attributes), optional
            Candidate classes; default: the training classes.
        decision_rule : decision rule, optional
            Used instead of the fitted one (fitted here on the training rows).

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
        """
        check_is_fitted(self)
        return self._rule(decision_rule).decision_function(scores, self._table(class_attributes))

    def predict_proba_from_scores(self, scores, class_attributes=None, *, decision_rule=None) -> np.ndarray:
        """Class posteriors (rows sum to 1) from :meth:`attribute_scores`; shape (n_trials, n_classes)."""
        check_is_fitted(self)
        return self._rule(decision_rule).predict_proba(scores, self._table(class_attributes))

    def predict_from_scores(self, scores, class_attributes=None, *, decision_rule=None) -> np.ndarray:
        """Best class per trial (row index into the table, seeded tie-breaking); shape (n_trials,)."""
        check_is_fitted(self)
        rule = self._rule(decision_rule)
        return rule.predict(scores, self._table(class_attributes), random_state=self.random_state)

    # ------------------------------------------------------------------ from features
    def decision_function(self, X, class_attributes=None) -> np.ndarray:
        """Class scores of the trials against ``class_attributes`` (default: training classes).

        Parameters
        ----------
        X : array-like
            Features, as for :meth:`fit`.
        class_attributes : array-like of shape (n_classes, n_attributes), optional
            Candidate (typically unseen) classes, one attribute row each.

        Returns
        -------
        ndarray of shape (n_trials, n_classes)
            Larger is better (DAP: log-posteriors up to a per-trial constant).
        """
        return self.decision_function_from_scores(self.attribute_scores(X), class_attributes)

    def predict_proba(self, X, class_attributes=None) -> np.ndarray:
        """Class posteriors over ``class_attributes`` (softmax of the class scores); (n_trials, n_classes)."""
        return self.predict_proba_from_scores(self.attribute_scores(X), class_attributes)

    def predict(self, X, class_attributes=None) -> np.ndarray:
        """Best class per trial as a row index into ``class_attributes`` (default: training classes).

        Exact ties are broken uniformly at random, seeded by ``random_state``.

        Returns
        -------
        ndarray of shape (n_trials,), int
        """
        return self.predict_from_scores(self.attribute_scores(X), class_attributes)
