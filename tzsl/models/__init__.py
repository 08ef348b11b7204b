"""Zero-shot models as scikit-learn estimators."""

from tzsl.models._attribute_svm import AttributeClassifierBank, AttributeSVM, AttributeTrainingError
from tzsl.models._dap import (
    DAPClassifier,
    attribute_prior,
    check_class_attributes,
    dap_accuracy_over_subsets,
    dap_log_scores,
    fuse_attribute_posteriors,
)
from tzsl.models._embedding import EmbeddingZSL
from tzsl.models._multilabel import MultiLabelAttributeClassifier
from tzsl.models._eszsl import ESZSL, ESZSLCV

__all__: list[str] = [
    "AttributeClassifierBank",
    "AttributeSVM",
    "AttributeTrainingError",
    "DAPClassifier",
    "MultiLabelAttributeClassifier",
    "attribute_prior",
    "check_class_attributes",
    "dap_accuracy_over_subsets",
    "dap_log_scores",
    "fuse_attribute_posteriors",
    "ESZSL", "ESZSLCV", "EmbeddingZSL"]
