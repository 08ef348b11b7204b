"""The detectors' training helpers under their name before the rooms (issue 43): :mod:`tzsl.models.detectors`.

Kept so that code written against ``tzsl.models.attribute_training`` keeps importing; every name here is
the same object as in :mod:`tzsl.models.detectors`, where it is documented. New code imports from there.
"""

from tzsl.models.detectors import (
    AUTO_CANDIDATES,
    AUTO_MAX_EXACT_TRIALS,
    DETECTORS,
    GRIDS,
    MAX_GRID_EXTENSIONS,
    MAX_TUNE_TRIALS,
    SEARCHES,
    SOLVERS,
    STUDY_DETECTOR,
    balanced_object_draws,
    choose_detector,
    default_preprocessor,
    detector_template,
    fit_platt,
    fit_platt_many,
    gamma_grid,
    object_balanced_weights,
)

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
