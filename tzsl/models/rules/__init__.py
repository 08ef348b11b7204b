"""Decision rules: attribute scores x a class-attribute table -> class scores, posteriors, ranking.

A zero-shot method is an attribute model plus one of these rules, composed by
:class:`tzsl.models.ZeroShotClassifier`; the class-attribute table arrives at predict time, so unseen
classes need no refit. The room of a new rule: subclass :class:`DecisionRule` (its contract is in its
docstring and in :mod:`tzsl.models.base`), set ``accepts`` to the :data:`SCORE_KINDS` it reads, and
write ``_class_scores``. Here: :class:`DAPRule` (Direct Attribute Prediction on attribute posteriors,
with sensor fusion and an attribute prior), :class:`CompatibilityRule` (bilinear compatibility of a
linear embedding) and :class:`NearestAttributeRule` (nearest class row, squared Euclidean or cosine),
and the check of a real-valued class table (:func:`check_real_class_attributes`). The rules are also at
the top of :mod:`tzsl.models`; DAP's arithmetic is :mod:`tzsl.models.dap`.
"""

from tzsl.models.rules._decision import (
    SCORE_KINDS,
    CompatibilityRule,
    DAPRule,
    DecisionRule,
    NearestAttributeRule,
    check_real_class_attributes,
)

__all__ = ["SCORE_KINDS", "CompatibilityRule", "DAPRule", "DecisionRule", "NearestAttributeRule",
           "check_real_class_attributes"]
