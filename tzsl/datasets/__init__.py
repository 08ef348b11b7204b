"""Dataset registry, data home and loaders (files -> arrays + a trial table)."""

from tzsl.datasets._builtin import TactileDataset, dataset_names, get_dataset, register_dataset

from tzsl.datasets._grasps import (
    FINGER_NAMES,
    JOINT_NAMES,
    Grasp,
    HandTable,
    grasp_from_arrays,
    load_hand_table4,
    read_grasps,
    write_grasps,
)
from tzsl.datasets._hand_simulator import SimulatedGrasps, simulate_grasps
from tzsl.cache import CACHE_DIR_ENV, get_cache_dir  # the cache folder, decided in tzsl.cache
from tzsl.datasets._home import get_data_home
from tzsl.datasets._phac2_h5 import (
    iter_phac2_h5,
    list_phac2_h5_trials,
    load_phac2_h5,
    require_eps,
    write_phac2_h5,
)
from tzsl.datasets._phac2_hold_mat import (
    load_phac2_hold_mat,
    load_phac2_labels,
    parse_trial_id,
    read_hold_mat,
    read_phac2_labels_csv,
)
from tzsl.datasets._phac2_penn import (
    PENN_FEATURE_NAMES,
    PennStaticData,
    load_phac2_penn,
    read_penn_static_pickles,
)
from tzsl.datasets._registry import fetch, registered_files
from tzsl.datasets._safe_pickle import safe_load_pickle
from tzsl.datasets._types import PHAC2_EPS, TRIAL_COLUMNS, BiotacSignals, FeatureSet, RawTrial
from tzsl.datasets._feature_table import feature_table_paths, read_csv_table, read_feature_table, write_feature_table
from tzsl.datasets._plain import PLAIN_FORMAT_HELP
from tzsl.datasets._tables import SPLITS_FILE
from tzsl.datasets._fabric import (
    FABRIC_ATTRIBUTE_SETS,
    FABRIC_ZSL_CONFIGS,
    PAPER_ATTRIBUTE_NAMES,
    FabricData,
    FabricSplit,
    fabric_zsl_split,
    load_fabric,
    read_depth_images,
    read_fabric_groups,
)
from tzsl.datasets._fabric_videos import load_gelsight_fabric_videos
from tzsl.datasets._gelsight_press import PressRecord, load_gelsight_press
from tzsl.datasets._video import avi_frame_count, read_video
from tzsl.datasets._plain import PlainDataset, feature_set_to_plain, read_plain_dataset, write_plain_dataset
from tzsl.datasets._synthetic import synthetic_dataset_arrays, write_synthetic_dataset
from tzsl.datasets._card import card_lines, dataset_card
from tzsl.datasets._lab_formats import LAB_FORMATS, LAB_READERS, convert_lab_dataset
from tzsl.datasets._lab_mapping import BagMapping, Hdf5Mapping, SeriesMapping, load_lab_mapping
from tzsl.datasets._download import DEFAULT_FETCH_TIMEOUT_S, FETCH_ATTEMPTS, FETCH_STALL_S, FETCH_TIMEOUT_ENV
from tzsl.datasets._fetch import MIRROR_ENV, REFERENCE_ONLY, FetchReport, fetch_datasets, registered_datasets
from tzsl.datasets._signal_cache import SignalTable, read_signal_table
from tzsl.datasets._signal_files import signal_from_arrays
from tzsl.datasets._validate import Problem, read_signal_file, validate_dataset

__all__ = [
    "TactileDataset",
    "dataset_names",
    "get_dataset",
    "register_dataset",
    "FINGER_NAMES",
    "JOINT_NAMES",
    "Grasp",
    "HandTable",
    "load_hand_table4",
    "grasp_from_arrays",
    "read_grasps",
    "write_grasps",
    "SimulatedGrasps",
    "simulate_grasps",
    "synthetic_dataset_arrays",
    "write_synthetic_dataset",
    "PHAC2_EPS",
    "TRIAL_COLUMNS",
    "BiotacSignals",
    "FeatureSet",
    "RawTrial",
    "feature_table_paths",
    "read_csv_table",
    "read_feature_table",
    "write_feature_table",
    "get_data_home",
    "get_cache_dir",
    "CACHE_DIR_ENV",
    "SignalTable",
    "read_signal_table",
    "fetch",
    "registered_files",
    "safe_load_pickle",
    "PENN_FEATURE_NAMES",
    "PennStaticData",
    "load_phac2_penn",
    "read_penn_static_pickles",
    "load_phac2_hold_mat",
    "load_phac2_labels",
    "read_hold_mat",
    "read_phac2_labels_csv",
    "parse_trial_id",
    "load_phac2_h5",
    "iter_phac2_h5",
    "write_phac2_h5",
    "list_phac2_h5_trials",
    "require_eps",
    "FABRIC_ATTRIBUTE_SETS",
    "FABRIC_ZSL_CONFIGS",
    "PAPER_ATTRIBUTE_NAMES",
    "FabricData",
    "FabricSplit",
    "fabric_zsl_split",
    "load_fabric",
    "load_gelsight_fabric_videos",
    "read_depth_images",
    "read_fabric_groups",
    "PressRecord",
    "load_gelsight_press",
    "avi_frame_count",
    "read_video",
    "PLAIN_FORMAT_HELP",
    "PlainDataset",
    "feature_set_to_plain",
    "read_plain_dataset",
    "write_plain_dataset",
    "SPLITS_FILE",
    "Problem",
    "read_signal_file",
    "card_lines",
    "LAB_FORMATS",
    "LAB_READERS",
    "convert_lab_dataset",
    "BagMapping",
    "Hdf5Mapping",
    "SeriesMapping",
    "load_lab_mapping",
    "MIRROR_ENV",
    "DEFAULT_FETCH_TIMEOUT_S",
    "FETCH_ATTEMPTS",
    "FETCH_STALL_S",
    "FETCH_TIMEOUT_ENV",
    "REFERENCE_ONLY",
    "FetchReport",
    "fetch_datasets",
    "registered_datasets",
    "dataset_card",
    "signal_from_arrays",
    "validate_dataset",
]
