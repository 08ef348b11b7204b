"""Dataset registry, data home and loaders (files -> arrays + a trial table).

Every public name is imported from its module on first use (PEP 562 ``__getattr__``), so code that
needs one reader (``tzsl predict`` reading a feature table) does not import the HDF5, MATLAB,
video and lab-format readers and their libraries (h5py, scipy.io, pydantic).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module of this package that defines it.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(["TactileDataset", "builtin_data_files", "dataset_names", "get_dataset", "register_dataset"],
                    "_builtin"),
    **dict.fromkeys(["FINGER_NAMES", "Grasp", "HandTable", "JOINT_NAMES", "grasp_from_arrays", "load_hand_table4",
        "read_grasps", "write_grasps"], "_grasps"),
    **dict.fromkeys(["SimulatedGrasps", "simulate_grasps"], "_hand_simulator"),
    **dict.fromkeys(["CACHE_DIR_ENV", "get_cache_dir"], "tzsl.cache"),  # the cache folder, decided in tzsl.cache
    **dict.fromkeys(["get_data_home"], "_home"),
    **dict.fromkeys(["iter_phac2_h5", "list_phac2_h5_trials", "load_phac2_h5",
        "require_eps", "write_phac2_h5"], "_phac2_h5"),
    **dict.fromkeys(["load_phac2_hold_mat", "load_phac2_labels", "parse_trial_id", "read_hold_mat",
        "read_phac2_labels_csv"], "_phac2_hold_mat"),
    **dict.fromkeys(["PENN_FEATURE_NAMES", "PennStaticData", "load_phac2_penn",
        "read_penn_static_pickles"], "_phac2_penn"),
    **dict.fromkeys(["fetch", "registered_files"], "_registry"),
    **dict.fromkeys(["safe_load_pickle"], "_safe_pickle"),
    **dict.fromkeys(["BiotacSignals", "FeatureSet", "PHAC2_EPS", "RawTrial", "TRIAL_COLUMNS"], "_types"),
    **dict.fromkeys(["feature_table_paths", "read_csv_table", "read_feature_table",
        "write_feature_table"], "_feature_table"),
    **dict.fromkeys(["PLAIN_FORMAT_HELP", "PlainDataset", "feature_set_to_plain", "read_plain_dataset",
        "write_plain_dataset"], "_plain"),
    **dict.fromkeys(["SPLITS_FILE"], "_tables"),
    **dict.fromkeys(["FABRIC_ATTRIBUTE_SETS", "FABRIC_ZSL_CONFIGS", "FabricData", "FabricSplit",
        "PAPER_ATTRIBUTE_NAMES", "fabric_zsl_split",
        "load_fabric", "read_depth_images", "read_fabric_groups"], "_fabric"),
    **dict.fromkeys(["load_gelsight_fabric_videos"], "_fabric_videos"),
    **dict.fromkeys(["PressRecord", "load_gelsight_press"], "_gelsight_press"),
    **dict.fromkeys(["avi_frame_count", "read_video"], "_video"),
    **dict.fromkeys(["synthetic_dataset_arrays", "write_synthetic_dataset"], "_synthetic"),
    **dict.fromkeys(["card_lines", "dataset_card"], "_card"),
    **dict.fromkeys(["LAB_FORMATS", "LAB_READERS", "convert_lab_dataset"], "_lab_formats"),
    **dict.fromkeys(["BagMapping", "Hdf5Mapping", "SeriesMapping", "load_lab_mapping"], "_lab_mapping"),
    **dict.fromkeys(["DEFAULT_FETCH_TIMEOUT_S", "FETCH_ATTEMPTS", "FETCH_STALL_S", "FETCH_TIMEOUT_ENV"], "_download"),
    **dict.fromkeys(["DEFAULT_FETCH_WORKERS", "FETCH_WORKERS_ENV", "MAX_FETCH_WORKERS"], "_transfer"),
    **dict.fromkeys(["FetchReport", "MIRROR_ENV", "REFERENCE_ONLY",
        "fetch_datasets", "fetch_missing", "registered_datasets"], "_fetch"),
    **dict.fromkeys(["SignalTable", "read_signal_table"], "_signal_cache"),
    **dict.fromkeys(["signal_from_arrays"], "_signal_files"),
    **dict.fromkeys(["Problem", "read_signal_file", "validate_dataset"], "_validate"),
}


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module if module.startswith("tzsl.") else f"{__name__}.{module}"), name)
    globals()[name] = value  # imported once
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "TactileDataset",
    "builtin_data_files",
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
    "DEFAULT_FETCH_WORKERS",
    "FETCH_WORKERS_ENV",
    "MAX_FETCH_WORKERS",
    "REFERENCE_ONLY",
    "FetchReport",
    "fetch_datasets",
    "fetch_missing",
    "registered_datasets",
    "dataset_card",
    "signal_from_arrays",
    "validate_dataset",
]
