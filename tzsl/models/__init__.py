"""Zero-shot models as scikit-learn estimators.

One protocol (:class:`ZeroShotClassifier` = attribute model + decision rule), the estimators,
a method registry (:func:`build_method`, :func:`available_methods`), :func:`all_estimators`,
the models' exceptions and warnings and :data:`INHERITED_CHOICES`. Helpers live in public
submodules, one per concept (as scikit-learn's ``sklearn.metrics.pairwise``):

* :mod:`tzsl.models.protocol`: attribute rows, training classes, class-grouped folds, score kinds;
* :mod:`tzsl.models.dap`: the DAP arithmetic (priors, fusion, log-scores, ties);
* :mod:`tzsl.models.multigrasp`: fusion over a hand's fingers and grasps (DF-/SC-MDAP);
* :mod:`tzsl.models.active_touch`: the next-EP policy, its posterior and stopping rule;
* :mod:`tzsl.models.calibration`: the temperature fitted on pseudo-unseen classes;
* :mod:`tzsl.models.attribute_training`: grids, solvers, searches, Platt scaling;
* :mod:`tzsl.models.embedding`: loss weights and the deep model's files;
* :mod:`tzsl.models.choices`: the inherited choices as records.

The fit store the estimators share is :mod:`tzsl.fit_store`.
"""

from tzsl.models import _builtin_methods  # noqa: F401  (registers the shipped methods)
from tzsl.models._active_touch import LogisticAttribute, PerEPAttributeModel
from tzsl.models._attribute_bank import AttributeClassifierBank
from tzsl.models._attribute_svm import AttributeSVM
from tzsl.models._attribute_training import AttributeTrainingError
from tzsl.models._choices import INHERITED_CHOICES
from tzsl.models._compatibility import ALE, SJE, DeViSE
from tzsl.models._decision import CompatibilityRule, DAPRule, DecisionRule, NearestAttributeRule
from tzsl.models._deep import DeepAttributeEmbedding
from tzsl.models._embedding import EmbeddingZSL
from tzsl.models._eszsl import ESZSL, ESZSLCV
from tzsl.models._hand_dap import HandDAPClassifier, NoContactError
from tzsl.models._iap import IAP
from tzsl.models._linear_attribute import LinearAttribute
from tzsl.models._multilabel import MultiLabelAttributeClassifier
from tzsl.models._posterior_calibration import CalibratedZeroShotClassifier, CalibrationWarning
from tzsl.models._registry import (
    FAMILIES,
    INPUT_KINDS,
    Method,
    all_estimators,
    available_methods,
    build_method,
    get_method,
    register_method,
    unregister_method,
)
from tzsl.models._sae import SAE, SAECV
from tzsl.models._scalable_attribute import ScalableAttributeClassifier
from tzsl.models._score_ensemble import ScoreEnsembleZSL
from tzsl.models._validation import ParameterError
from tzsl.models._zero_shot import ZeroShotClassifier
from tzsl.models._zsl_input import GridEdgeWarning, ZSLInputError

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
    "FAMILIES",
    "INPUT_KINDS",
    "Method",
    "all_estimators",
    "available_methods",
    "build_method",
    "get_method",
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
