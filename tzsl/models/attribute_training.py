"""What training an attribute classifier shares, exact (RBF-SVM) or approximate (Nystroem).

Used by :class:`tzsl.models.AttributeSVM`, :class:`tzsl.models.ScalableAttributeClassifier`
and :class:`tzsl.models.AttributeClassifierBank`: the option values (:data:`GRIDS`,
:data:`SOLVERS`, :data:`SEARCHES`, :data:`AUTO_MAX_EXACT_TRIALS`, :data:`MAX_GRID_EXTENSIONS`), the gamma grid
(:func:`gamma_grid`), the default preprocessor, class-balanced draws of whole objects
(:func:`balanced_object_draws`) and Platt scaling (:func:`fit_platt`, :func:`fit_platt_many`).
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
)

__all__ = [
    "AUTO_MAX_EXACT_TRIALS",
    "GRIDS",
    "MAX_GRID_EXTENSIONS",
    "SEARCHES",
    "SOLVERS",
    "balanced_object_draws",
    "default_preprocessor",
    "fit_platt",
    "fit_platt_many",
    "gamma_grid",
]
