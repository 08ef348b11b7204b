"""What a new zero-shot method is built from: the contracts, their base classes, input checks and the registry.

Named as scikit-learn's :mod:`sklearn.base` (the base classes every estimator builds on), because that is
where a scikit-learn author looks first. Everything here is re-exported from the module that defines it
(its home is named in each entry's docstring); nothing is defined here, so there is one copy of each. A
method written against this module and :mod:`tzsl.models` imports no private name of tzsl
(docs/user_guide/extending.md, "A method", adds ConSE that way).

**An attribute model** maps trials to per-attribute scores; it is an ordinary multi-output scikit-learn
estimator (keyword-only ``__init__`` storing its parameters, ``_parameter_constraints`` checked by
:class:`ValidatedParamsMixin`, fitted attributes ending in ``_``), so ``check_estimator`` holds:

* class attribute ``score_kind``, one of :data:`SCORE_KINDS` (read by :func:`score_kind`):
  ``"probability"``: ``predict_proba(X)`` gives ``p(a_m = 1 | x)`` in [0, 1], shape (n_trials,
  n_attributes), or (n_trials, n_sensors, n_attributes) for per-sensor input; ``"embedding"``:
  ``decision_function(X)`` gives real attribute-space scores, shape (n_trials, n_attributes), in the units
  of the class-attribute rows they are compared with;
* ``fit(X, Y, groups=None)``: ``X`` (n_trials, n_features) (or (n_trials, n_sensors, n_features)),
  ``Y`` (n_trials, n_attributes) the attribute row of each training trial's class (1-D: one attribute),
  ``groups`` (n_trials,) the object of each trial, for grouped tuning; returns ``self``. The training
  classes are the distinct rows of ``Y`` (:func:`training_classes`); check the arrays with
  :func:`validate_features_and_rows` at fit and :func:`validate_features` at predict (bad input raises
  :class:`ZSLInputError`, a ``ValueError``);
* ``__sklearn_tags__`` returning :func:`attribute_model_tags` of its parent's (``y`` required, 2-D);
  an estimator fitted on an attribute table that is not itself an attribute model (a whole zero-shot
  method) uses :func:`attribute_table_tags`;
* optionally ``selected_params()``: the hyper-parameters it chose, as ``set_params`` keywords (a
  calibration fold then refits with them pinned).

A linear embedding ``standardise(X) @ coef_.T`` gets its predict side from :class:`EmbeddingAttributeModel`.

**A decision rule** (:class:`DecisionRule`) maps attribute scores and a class-attribute table ``K``
(n_classes, n_attributes), given at predict time so unseen classes need no refit, to class scores
(n_trials, n_classes), larger is better (DAP: log-posteriors; compatibility: dot products; nearest row:
minus squared distances or cosines). A new rule sets ``accepts`` (the score kinds it reads) and writes
``_class_scores(scores, K)``; ``fit(A, groups=None)``, ``predict_proba`` (softmax over the given classes)
and ``predict`` (row indices into ``K``, ties broken at random, seeded) come with the base.
:class:`ZeroShotClassifier` composes an attribute model with a rule.

**The registry**: :func:`register_method` makes a method a name that experiment files, ``--method``,
``tzsl methods`` and the studies read (its fields: :data:`FAMILIES`, :data:`INPUT_KINDS`,
:class:`Method`); :func:`build_method` builds it as the studies do, :func:`get_method` reads its entry
and :func:`unregister_method` removes a test's entry. Helpers for a method's own cross-validation over
training classes: :func:`class_grouped_folds` (at least :data:`MIN_CV_CLASSES` classes),
:func:`extend_at_edge` with :data:`DEFAULT_GRID_EXTENSIONS`, :class:`GridEdgeWarning`; argument checks
:func:`check_int`, :func:`check_positive`; class tables :func:`validate_class_table`,
:func:`check_no_duplicate_rows`, :func:`check_real_class_attributes`, :func:`encode_training_classes`,
:func:`attribute_rows`. The selection criteria shared by the CV models are in :mod:`tzsl.models.protocol`.
"""

from tzsl.models._attribute_model_base import EmbeddingAttributeModel, attribute_model_tags, attribute_table_tags
from tzsl.models._registry import (
    FAMILIES,
    INPUT_KINDS,
    Method,
    build_method,
    get_method,
    register_method,
    unregister_method,
)
from tzsl.models._validation import ParameterError, ValidatedParamsMixin
from tzsl.models._zero_shot import ZeroShotClassifier, score_kind
from tzsl.models._zsl_input import (
    DEFAULT_GRID_EXTENSIONS,
    MIN_CV_CLASSES,
    GridEdgeWarning,
    ZSLInputError,
    attribute_rows,
    check_int,
    check_no_duplicate_rows,
    check_positive,
    class_grouped_folds,
    encode_training_classes,
    extend_at_edge,
    training_classes,
    validate_class_table,
    validate_features,
    validate_features_and_rows,
)
from tzsl.models.rules import SCORE_KINDS, DecisionRule, check_real_class_attributes

__all__ = [
    # the attribute-model contract
    "SCORE_KINDS",
    "EmbeddingAttributeModel",
    "attribute_model_tags",
    "attribute_table_tags",
    "score_kind",
    # parameters and input checks
    "ValidatedParamsMixin",
    "ParameterError",
    "ZSLInputError",
    "GridEdgeWarning",
    "validate_features",
    "validate_features_and_rows",
    "training_classes",
    "attribute_rows",
    "validate_class_table",
    "check_no_duplicate_rows",
    "check_real_class_attributes",
    "encode_training_classes",
    "check_int",
    "check_positive",
    "class_grouped_folds",
    "MIN_CV_CLASSES",
    "extend_at_edge",
    "DEFAULT_GRID_EXTENSIONS",
    # the decision-rule contract and the composition
    "DecisionRule",
    "ZeroShotClassifier",
    # the registry
    "FAMILIES",
    "INPUT_KINDS",
    "Method",
    "build_method",
    "get_method",
    "register_method",
    "unregister_method",
]
