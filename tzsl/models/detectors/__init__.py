"""Attribute detectors: the attribute models whose scores are attribute posteriors (read by DAP).

A *detector* is one binary classifier per (attribute, sensor) giving ``p(a_m = 1 | x)``; an *attribute
bank* fits one per (attribute, sensor) and stacks them (``score_kind = "probability"``, read by
:class:`tzsl.models.DAPRule`). The room of a new detector or a new probability attribute model:

* the detectors: :class:`AttributeSVM` (the DAP paper's RBF-SVM with Platt posteriors),
  :class:`ScalableAttributeClassifier` (Nystroem + logistic, linear in trials),
  :class:`LinearAttribute`, :class:`LogisticAttribute` (the per-EP models' default);
* the attribute models built on them: :class:`AttributeClassifierBank`,
  :class:`MultiLabelAttributeClassifier` (a classifier chain) and :class:`IAP` (indirect attribute
  prediction: class posteriors turned into attribute posteriors);
* what training them shares, exact (RBF-SVM) or approximate (Nystroem): the option values
  (:data:`GRIDS`, :data:`SOLVERS`, :data:`SEARCHES`, :data:`AUTO_MAX_EXACT_TRIALS`,
  :data:`MAX_GRID_EXTENSIONS`, :data:`MAX_TUNE_TRIALS`: the approximate model's search subset), the gamma
  grid (:func:`gamma_grid`), the default preprocessor, class-balanced draws of whole objects
  (:func:`balanced_object_draws`), object-balanced trial weights (:func:`object_balanced_weights`), Platt
  scaling (:func:`fit_platt`, :func:`fit_platt_many`), the training error (:class:`AttributeTrainingError`);
* the detector families of an attribute bank (:data:`DETECTORS`, :data:`AUTO_CANDIDATES`,
  :data:`STUDY_DETECTOR`, :func:`detector_template`, :func:`choose_detector`: ``detector="auto"``'s
  choice on pseudo-unseen training classes).

The estimators are also at the top of :mod:`tzsl.models`; the training helpers were
:mod:`tzsl.models.attribute_training` before the rooms (that name still imports them).
"""


from tzsl.models.detectors._attribute_bank import AttributeClassifierBank
from tzsl.models.detectors._attribute_search import MAX_GRID_EXTENSIONS, SEARCHES
from tzsl.models.detectors._attribute_svm import AttributeSVM
from tzsl.models.detectors._attribute_training import (
    AUTO_MAX_EXACT_TRIALS,
    GRIDS,
    MIN_OBJECTS_PER_LABEL,
    SOLVERS,
    AttributeTrainingError,
    balanced_object_draws,
    default_preprocessor,
    fit_platt,
    fit_platt_many,
    gamma_grid,
    object_balanced_weights,
)
from tzsl.models.detectors._families import (
    AUTO_CANDIDATES,
    DETECTORS,
    STUDY_DETECTOR,
    choose_detector,
    detector_template,
)
from tzsl.models.detectors._iap import IAP
from tzsl.models.detectors._linear_attribute import LinearAttribute
from tzsl.models.detectors._logistic_attribute import LogisticAttribute
from tzsl.models.detectors._multilabel import MultiLabelAttributeClassifier
from tzsl.models.detectors._scalable_attribute import MAX_TUNE_TRIALS, ScalableAttributeClassifier

__all__ = [
    # detectors and the attribute models built on them
    "AttributeClassifierBank",
    "AttributeSVM",
    "IAP",
    "LinearAttribute",
    "LogisticAttribute",
    "MultiLabelAttributeClassifier",
    "ScalableAttributeClassifier",
    "AttributeTrainingError",
    # what training them shares, and the detector families
    "AUTO_CANDIDATES",
    "AUTO_MAX_EXACT_TRIALS",
    "MIN_OBJECTS_PER_LABEL",
    "DETECTORS",
    "GRIDS",
    "MAX_GRID_EXTENSIONS",
    "MAX_TUNE_TRIALS",
    "SEARCHES",
    "SOLVERS",
    "STUDY_DETECTOR",
    "balanced_object_draws",
    "choose_detector",
    "default_preprocessor",
    "detector_template",
    "fit_platt",
    "fit_platt_many",
    "gamma_grid",
    "object_balanced_weights",
]
