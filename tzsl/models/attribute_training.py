"""What training an attribute classifier shares, exact (RBF-SVM) or approximate (Nystroem).

Used by :class:`tzsl.models.AttributeSVM`, :class:`tzsl.models.ScalableAttributeClassifier`
and :class:`tzsl.models.AttributeClassifierBank`: the option values (:data:`GRIDS`,
:data:`SOLVERS`, :data:`SEARCHES`, :data:`AUTO_MAX_EXACT_TRIALS`, :data:`MAX_GRID_EXTENSIONS`,
:data:`MAX_TUNE_TRIALS`: the approximate model's search subset), the gamma grid
(:func:`gamma_grid`), the default preprocessor, class-balanced draws of whole objects
(:func:`balanced_object_draws`), object-balanced trial weights (:func:`object_balanced_weights`),
Platt scaling (:func:`fit_platt`, :func:`fit_platt_many`), and the detector families of an
attribute bank (:data:`DETECTORS`, :data:`AUTO_CANDIDATES`, :data:`STUDY_DETECTOR`, :func:`detector_template`,
:func:`choose_detector`: ``detector="auto"``'s choice on pseudo-unseen training classes).
"""

from tzsl.models._attribute_search import MAX_GRID_EXTENSIONS, SEARCHES
from tzsl.models._attribute_training import (
    AUTO_MAX_EXACT_TRIALS,
    GRIDS,
    SOLVERS,
    balanced_object_draws,
    default_preprocessor,
    fit_platt,
    fit_platt_many,
    gamma_grid,
    object_balanced_weights,
)
from tzsl.models._detectors import AUTO_CANDIDATES, DETECTORS, STUDY_DETECTOR, choose_detector, detector_template
from tzsl.models._scalable_attribute import MAX_TUNE_TRIALS

__all__ = [
    "AUTO_CANDIDATES",
    "AUTO_MAX_EXACT_TRIALS",
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
