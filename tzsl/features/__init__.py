"""Feature extraction as scikit-learn transformers."""

from tzsl.features._attribute_filter import check_attribute_table, filter_attributes
from tzsl.features._baseline import (
    PHAC2_EP_NAMES,
    BaselineRemover,
    check_raw_trial,
    ep_masks,
    remove_baseline,
)
from tzsl.features._builtin_feature_sets import (
    depth_image_descriptors,
    descriptor_memory,
    descriptor_params,
    fabric_depth_feature_set,
    fabric_group_table,
    files_digest,
    simulated_grasp_feature_set,
)
from tzsl.features._dataset_features import DEFAULT_MIN_OBJECTS, dataset_features, load_features
from tzsl.features._feature_sets import penn_feature_set, raw_feature_set
from tzsl.features._grasp_features import (
    CLOSING_JOINTS,
    MATERIAL_FEATURES,
    GraspFeatures,
    detect_contacts,
    grasp_features,
    pack_grasp_features,
    unpack_grasp_features,
)
from tzsl.features._keyframes import KeyFrames, KeyFrameSelector, frame_differences, key_frame_indices
from tzsl.features._kinesthetic import KinestheticFeatures, kinesthetic_ep_features
from tzsl.features._pca import VariancePCA
from tzsl.features._penn_columns import (
    PENN_DROPPED_COLUMNS,
    PENN_FEATURES_PER_EP,
    PennColumnSelector,
    select_penn_columns,
)
from tzsl.features._raw_features import RawTrialFeatures
from tzsl.features._rocket_features import (
    DEFAULT_ROCKET_KERNELS,
    ROCKET_INSTALL_HINT,
    SIGNAL_TRANSFORMS,
    RocketFeatures,
)
from tzsl.features._signal_features import (
    load_plain_dataset,
    plain_feature_set,
    raw_trial_signals,
    split_signal_features,
)
from tzsl.features._signal_stats import (
    DEFAULT_SIGNAL_STATISTICS,
    SIGNAL_STATISTICS,
    SignalStatistics,
    subtract_baseline,
)
from tzsl.features._texture import TextureDescriptor, texture_feature_names
from tzsl.features._time_average import BIOTAC_CHANNELS, BiotacTimeAverage, biotac_ep_means

__all__: list[str] = [
    "DEFAULT_MIN_OBJECTS",
    "depth_image_descriptors",
    "descriptor_memory",
    "descriptor_params",
    "fabric_depth_feature_set",
    "fabric_group_table",
    "files_digest",
    "simulated_grasp_feature_set",
    "dataset_features",
    "load_features",
    "CLOSING_JOINTS",
    "MATERIAL_FEATURES",
    "GraspFeatures",
    "detect_contacts",
    "grasp_features",
    "pack_grasp_features",
    "unpack_grasp_features",
    "BIOTAC_CHANNELS",
    "PENN_DROPPED_COLUMNS",
    "PENN_FEATURES_PER_EP",
    "PHAC2_EP_NAMES",
    "BaselineRemover",
    "BiotacTimeAverage",
    "KinestheticFeatures",
    "PennColumnSelector",
    "RawTrialFeatures",
    "VariancePCA",
    "biotac_ep_means",
    "check_attribute_table",
    "check_raw_trial",
    "ep_masks",
    "filter_attributes",
    "kinesthetic_ep_features",
    "penn_feature_set",
    "raw_feature_set",
    "remove_baseline",
    "select_penn_columns",
    "KeyFrames",
    "KeyFrameSelector",
    "frame_differences",
    "key_frame_indices",
    "TextureDescriptor",
    "texture_feature_names",
    "DEFAULT_SIGNAL_STATISTICS",
    "SIGNAL_STATISTICS",
    "SignalStatistics",
    "subtract_baseline",
    "load_plain_dataset",
    "plain_feature_set",
    "raw_trial_signals",
    "split_signal_features",
    "DEFAULT_ROCKET_KERNELS",
    "ROCKET_INSTALL_HINT",
    "SIGNAL_TRANSFORMS",
    "RocketFeatures",
]
