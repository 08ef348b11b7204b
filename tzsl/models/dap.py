"""Direct Attribute Prediction (DAP) arithmetic, in log space and vectorised.

Attribute priors, fusion of per-sensor attribute posteriors (MAXDAP, AVGDAP), DAP class
log-scores, tie breaking, input checks and accuracy over many class subsets at once.
:class:`tzsl.models.DAPRule` applies them inside :class:`tzsl.models.ZeroShotClassifier`.
"""

from tzsl.models._dap import (
    attribute_prior,
    break_ties,
    check_attribute_posteriors,
    check_class_attributes,
    dap_accuracy_over_subsets,
    dap_log_scores,
    fuse_attribute_posteriors,
)

__all__ = [
    "attribute_prior",
    "break_ties",
    "check_attribute_posteriors",
    "check_class_attributes",
    "dap_accuracy_over_subsets",
    "dap_log_scores",
    "fuse_attribute_posteriors",
]
