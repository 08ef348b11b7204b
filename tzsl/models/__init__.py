"""Zero-shot models as scikit-learn estimators.

One protocol (:class:`ZeroShotClassifier` = attribute model + decision rule), the estimators,
a method registry (:func:`build_method`, :func:`available_methods`), :func:`all_estimators`,
the models' exceptions and warnings and :data:`INHERITED_CHOICES`.

The estimators live in subpackages by role, as scikit-learn's do (the room of a new method is found
by what it is); each room's ``__init__`` lists its estimators and helpers:

* :mod:`tzsl.models.detectors`: attribute detectors and the attribute models built on them (banks,
  the classifier chain, IAP), grids, solvers, searches, Platt scaling, detector families;
* :mod:`tzsl.models.rules`: the decision rules (DAP, compatibility, nearest attribute row);
* :mod:`tzsl.models.embedding`: embedding and compatibility methods (ESZSL, SAE, ALE/SJE/DeViSE,
  the lambda embedding) and, in :mod:`tzsl.models.embedding.deep`, the deep embedding;
* :mod:`tzsl.models.calibration`: the temperature fitted on pseudo-unseen classes;
* :mod:`tzsl.models.ensemble`: the score ensemble of registry methods;
* :mod:`tzsl.models.hand`: a robot hand's single- and multi-grasp DAP;
* :mod:`tzsl.models.active_touch`: the per-EP model, the next-EP policy, its posterior and stopping rule.

The package core, at this level: :mod:`tzsl.models.base` (what a method author builds on: the
contracts, input checks, tags helpers, the decision-rule base, ``register_method``),
:mod:`tzsl.models.protocol` (attribute rows, training classes, class-grouped folds, score kinds),
:mod:`tzsl.models.dap` (the DAP arithmetic every DAP rule and room shares) and
:mod:`tzsl.models.choices` (the inherited choices as records). :mod:`tzsl.models.attribute_training`
and :mod:`tzsl.models.multigrasp` are the old names of :mod:`~tzsl.models.detectors`' and
:mod:`~tzsl.models.hand`'s helpers, kept so that older code imports.

The fit store the estimators share is :mod:`tzsl.fit_store`.
"""

from tzsl.models import _builtin_methods  # noqa: F401  (registers the shipped methods)
from tzsl.models._choices import INHERITED_CHOICES
from tzsl.models._registry import (
    DAP_METHOD,
    FAMILIES,
    INPUT_KINDS,
    Method,
    all_estimators,
    available_methods,
    build_method,
    get_method,
    method_aliases,
    register_alias,
    register_method,
    unregister_method,
)
from tzsl.models._validation import ParameterError
from tzsl.models._zero_shot import ZeroShotClassifier
from tzsl.models._zsl_input import GridEdgeWarning, ZSLInputError
from tzsl.models.active_touch import PerEPAttributeModel
from tzsl.models.calibration import CalibratedZeroShotClassifier, CalibrationWarning
from tzsl.models.detectors import (
    IAP,
    AttributeClassifierBank,
    AttributeSVM,
    AttributeTrainingError,
    LinearAttribute,
    LogisticAttribute,
    MultiLabelAttributeClassifier,
    ScalableAttributeClassifier,
)
from tzsl.models.embedding import ALE, ESZSL, ESZSLCV, SAE, SAECV, SJE, DeepAttributeEmbedding, DeViSE, EmbeddingZSL
from tzsl.models.ensemble import ScoreEnsembleZSL
from tzsl.models.hand import HandDAPClassifier, NoContactError
from tzsl.models.rules import CompatibilityRule, DAPRule, DecisionRule, NearestAttributeRule

__all__: list[str] = [
    # the protocol and its decision rules
    "ZeroShotClassifier",
    "DecisionRule",
    "DAPRule",
    "CompatibilityRule",
    "NearestAttributeRule",
    # attribute models
    "AttributeSVM",
    "LinearAttribute",
    "AttributeClassifierBank",
    "ScalableAttributeClassifier",
    "MultiLabelAttributeClassifier",
    "HandDAPClassifier",
    "LogisticAttribute",
    "PerEPAttributeModel",
    # zero-shot estimators
    "ALE",
    "SJE",
    "DeViSE",
    "ESZSL",
    "ESZSLCV",
    "EmbeddingZSL",
    "DeepAttributeEmbedding",
    "IAP",
    "SAE",
    "SAECV",
    "ScoreEnsembleZSL",
    "CalibratedZeroShotClassifier",
    # the method registry
    "DAP_METHOD",
    "FAMILIES",
    "INPUT_KINDS",
    "Method",
    "all_estimators",
    "available_methods",
    "build_method",
    "get_method",
    "method_aliases",
    "register_alias",
    "register_method",
    "unregister_method",
    # exceptions and warnings
    "AttributeTrainingError",
    "CalibrationWarning",
    "GridEdgeWarning",
    "NoContactError",
    "ParameterError",
    "ZSLInputError",
    # the choices a user inherits
    "INHERITED_CHOICES",
]
