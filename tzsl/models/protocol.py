"""The zero-shot protocol's shared pieces: training inputs and class scores.

Every zero-shot estimator of :mod:`tzsl.models` fits ``fit(X, A, groups)`` on attribute rows
``A`` (:func:`attribute_rows` builds them from labels and a class-attribute table); its training
classes are the distinct rows (:func:`training_classes`), and its internal cross-validation
deals whole classes into folds (:func:`class_grouped_folds`, at least :data:`MIN_CV_CLASSES`
classes). An attribute model declares what its scores are (:func:`score_kind`); the decision
rules compare them with class rows (:func:`compatibility_scores`, :func:`squared_distances`,
:func:`cosine_similarities`; the linear models' scores are :func:`linear_embedding`) and the score ensemble puts
its members on one scale (:func:`zscore_rows`). A search over regularisers scores each configuration on
the held-out classes with :func:`heldout_scores` (by default accuracy; the smooth :func:`neg_log_loss`
on request) and keeps its preferred one among those within :data:`TIE_TOLERANCE` of the best
(:func:`best_within_tolerance`).
"""

from tzsl._scoring import compatibility_scores, cosine_similarities, linear_embedding, squared_distances
from tzsl.models._selection_criteria import (
    DEFAULT_SCORING,
    LAST_BIT_NOTE,
    SCORINGS,
    TIE_TOLERANCE,
    best_within_tolerance,
    heldout_scores,
    moves_with_last_bit,
    neg_log_loss,
)
from tzsl.models._zero_shot import score_kind, zscore_rows
from tzsl.models._zsl_input import MIN_CV_CLASSES, attribute_rows, class_grouped_folds, training_classes

__all__ = [
    "DEFAULT_SCORING",
    "LAST_BIT_NOTE",
    "MIN_CV_CLASSES",
    "SCORINGS",
    "TIE_TOLERANCE",
    "attribute_rows",
    "class_grouped_folds",
    "compatibility_scores",
    "best_within_tolerance",
    "cosine_similarities",
    "heldout_scores",
    "linear_embedding",
    "moves_with_last_bit",
    "neg_log_loss",
    "score_kind",
    "squared_distances",
    "training_classes",
    "zscore_rows",
]
