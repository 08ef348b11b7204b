"""``tzsl extract``: read a dataset, extract per-trial per-sensor features, summarise."""

from __future__ import annotations

import os

from tzsl._profile import timed
from tzsl.datasets import (
    FeatureSet,
    load_phac2_h5,
    load_phac2_hold_mat,
    load_phac2_labels,
    load_phac2_penn,
)
from tzsl.exceptions import ConfigError
from tzsl.features import penn_feature_set, raw_feature_set

#: Dataset names ``tzsl extract --dataset`` accepts.
DATASETS: tuple[str, ...] = ("phac2-penn", "phac2-h5", "phac2-hold-mat")


@timed("load")
def extract_features(
    dataset: str,
    data_dir: str | os.PathLike | None = None,
    path: str | os.PathLike | None = None,
    min_objects: int = 3,
) -> FeatureSet:
    """Features of one dataset.

    Parameters
    ----------
    dataset : {"phac2-penn", "phac2-h5", "phac2-hold-mat"}
        ``phac2-penn``: Penn static features (600 trials x 2 BioTacs x 52);
        ``phac2-h5``: the official raw HDF5 release at ``path`` (2 x 104 with 4 EPs);
        ``phac2-hold-mat``: the 60 raw HOLD-phase MATLAB trials (2 x 26).
    data_dir : path-like or None
        Data home (see :func:`tzsl.datasets.get_data_home`).
    path : path-like or None
        The HDF5 file for ``phac2-h5``.
    min_objects : int, default 3
        Keep attributes present in at least this many objects.
    """
    if dataset == "phac2-penn":
        penn = load_phac2_penn(data_dir)
        features = penn_feature_set(penn, min_objects=min_objects)
        features.info["data_files"] = sorted(str(p) for p in penn.sources)
        return features
    if dataset == "phac2-hold-mat":
        trials = load_phac2_hold_mat(data_dir)
        features = raw_feature_set(trials, load_phac2_labels(data_dir), eps=("hold",), min_objects=min_objects,
                                   dataset="phac2-hold-mat")
        features.info["data_files"] = sorted({t.source for t in trials})
        return features
    if dataset == "phac2-h5":
        if path is None:
            raise ConfigError("--dataset phac2-h5 needs --path pointing at the PHAC-2 HDF5 release file")
        trials = load_phac2_h5(path)
        features = raw_feature_set(trials, load_phac2_labels(data_dir), min_objects=min_objects,
                                   dataset="phac2-h5")
        features.info["data_files"] = [str(path)]
        return features
    raise ConfigError(f"unknown dataset {dataset!r}; choose one of {', '.join(DATASETS)}")


def summarise(features: FeatureSet) -> dict[str, object]:
    """What ``tzsl extract`` prints: counts, dimensions, kept and dropped attributes."""
    return {
        "dataset": features.dataset,
        "trials": features.n_trials,
        "objects": features.n_objects,
        "sensors": len(features.sensors),
        "sensor_names": list(features.sensors),
        "dimensions": int(features.X.shape[2]),
        "kept_attributes": list(features.attributes.columns),
        "dropped_attributes": list(features.info.get("dropped_attributes", [])),
    }


def format_summary(summary: dict[str, object]) -> str:
    """Human-readable lines of :func:`summarise`."""
    kept = summary["kept_attributes"]
    dropped = summary["dropped_attributes"]
    return "\n".join([
        f"dataset:    {summary['dataset']}",
        f"trials:     {summary['trials']}",
        f"objects:    {summary['objects']}",
        f"sensors:    {summary['sensors']} ({', '.join(summary['sensor_names'])})",
        f"dimensions: {summary['dimensions']} per sensor",
        f"attributes: {len(kept)} kept: {', '.join(kept)}",
        f"dropped:    {len(dropped)} ({', '.join(dropped) if dropped else 'none'})",
    ])

