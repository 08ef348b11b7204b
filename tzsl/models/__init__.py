"""Zero-shot models as scikit-learn estimators."""

from tzsl.models._attribute_svm import AttributeClassifierBank, AttributeSVM, AttributeTrainingError
from tzsl.models._dap import (
    DAPClassifier,
    attribute_prior,
    break_ties,
    check_class_attributes,
    dap_accuracy_over_subsets,
    dap_log_scores,
    fuse_attribute_posteriors,
)
from tzsl.models._embedding import EmbeddingZSL
from tzsl.models._deep import DeepAttributeEmbedding, load_deep_bundle, save_deep_bundle
from tzsl.models._hand_dap import FUSIONS as HAND_FUSIONS
from tzsl.models._hand_dap import HandDAPClassifier, NoContactError, fuse_grasp_posteriors
from tzsl.models._multigrasp import (
    attribute_distance_matrix,
    df_mdap,
    df_mdap_log_scores,
    sample_grasp_sequences,
    sc_mdap,
)
from tzsl.models._multilabel import MultiLabelAttributeClassifier
from tzsl.models._eszsl import ESZSL, ESZSLCV

__all__: list[str] = [
    "DeepAttributeEmbedding",
    "load_deep_bundle",
    "save_deep_bundle",
    "HAND_FUSIONS",
    "HandDAPClassifier",
    "NoContactError",
    "fuse_grasp_posteriors",
    "attribute_distance_matrix",
    "df_mdap",
    "df_mdap_log_scores",
    "sample_grasp_sequences",
    "sc_mdap",
    "AttributeClassifierBank",
    "AttributeSVM",
    "AttributeTrainingError",
    "DAPClassifier",
    "MultiLabelAttributeClassifier",
    "attribute_prior",
    "check_class_attributes",
    "dap_accuracy_over_subsets",
    "break_ties",
    "dap_log_scores",
    "fuse_attribute_posteriors",
    "ESZSL", "ESZSLCV", "EmbeddingZSL"]
