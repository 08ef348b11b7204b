"""One path from a dataset to features: a built-in dataset, a feature table or a plain-file folder.

Every study, ``tzsl extract`` and ``tzsl convert --dataset`` read their features through
:func:`load_features`; a built-in dataset (:func:`tzsl.datasets.get_dataset`) is turned into
features by :func:`dataset_features` according to what it publishes (static features, raw
signals, or, for a dataset of the catalog, the plain-file folder it is converted to).
"""

from __future__ import annotations

import os
from pathlib import Path

from tzsl._profile import timed
from tzsl.datasets import FeatureSet, get_dataset, read_feature_table
from tzsl.exceptions import ConfigError
from tzsl.features._builtin_feature_sets import fabric_depth_feature_set, simulated_grasp_feature_set
from tzsl.features._feature_sets import penn_feature_set, raw_feature_set
from tzsl.features._signal_features import load_plain_dataset, plain_feature_set

__all__ = ["DEFAULT_MIN_OBJECTS", "dataset_features", "load_features"]

#: Keep an attribute only when at least this many objects have it (the DAP paper's filter).
DEFAULT_MIN_OBJECTS = 3


def dataset_features(name: str, data_dir: str | os.PathLike | None = None, path: str | os.PathLike | None = None,
                     min_objects: int = DEFAULT_MIN_OBJECTS) -> FeatureSet:
    """Features of the built-in dataset ``name`` (``tzsl datasets`` lists them).

    Parameters
    ----------
    name : str
        A registered dataset, e.g. ``"phac2-penn"`` (Penn static features: 600 trials x 2 BioTacs
        x 52), ``"phac2-h5"`` (the raw HDF5 release at ``path``: 2 x 104 with 4 EPs) or
        ``"phac2-hold-mat"`` (60 raw HOLD-phase trials: 2 x 26), ``"fabric-depth"`` (1300 depth
        images: 1 x 99 texture descriptors), ``"hand-simulated"`` (simulated grasps: 1 x the
        packed grasp features) or a catalog dataset such as ``"biotac-slide"`` (its plain-file folder:
        1 x the per-channel statistics of its ``dataset.toml``).
    data_dir : path-like or None
        Data home (see :func:`tzsl.datasets.get_data_home`).
    path : path-like or None
        The file of a dataset that ``needs_path``.
    min_objects : int
        Keep attributes present in at least this many objects.

    Returns
    -------
    FeatureSet
        ``X`` (n_trials, n_sensors, n_features); ``info["data_files"]``: the files read; a catalog dataset's
        ``info["plain_folder"]``: its converted plain-file folder.
    """
    dataset = get_dataset(name)
    loaded = dataset.load(data_dir, path)
    if dataset.content == "static-features":
        features = penn_feature_set(loaded, min_objects=min_objects)
    elif dataset.content == "depth-images":
        features = fabric_depth_feature_set(loaded, min_objects=min_objects)
    elif dataset.content == "plain":
        features = plain_feature_set(loaded, min_objects=min_objects)
        features.info["plain_folder"] = str(loaded.folder)  # a catalog dataset's converted folder (its splits.csv)
    elif dataset.content == "simulated-grasps":
        features = simulated_grasp_feature_set(loaded, dataset.labels(data_dir), min_objects=min_objects)
    else:
        features = raw_feature_set(loaded, dataset.labels(data_dir), eps=dataset.eps, min_objects=min_objects,
                                   dataset=dataset.name)
    features.info["data_files"] = dataset.data_files(loaded)
    return features


@timed("load")
def load_features(builtin: str | None = None, *, features_file: str | os.PathLike | None = None,
                  plain: str | os.PathLike | None = None, data_dir: str | os.PathLike | None = None,
                  path: str | os.PathLike | None = None, min_objects: int | None = None,
                  **plain_options) -> FeatureSet:
    """One :class:`~tzsl.datasets.FeatureSet` from exactly one source.

    Parameters
    ----------
    builtin : str or None
        A built-in dataset (:func:`dataset_features`).
    features_file : path-like or None
        A table written by ``tzsl extract --out`` (.csv or .npz).
    plain : path-like or None
        A plain-file dataset folder (``tzsl formats``); ``plain_options`` go to
        :func:`~tzsl.features.load_plain_dataset` (``statistics``, ``baseline_rows``, ``channels``,
        ``n_jobs``, ``cache``).
    data_dir, path
        Data home, and the input file of a dataset that needs one.
    min_objects : int or None
        Attribute filter of a built-in dataset or plain folder (None: each one's default).

    Returns
    -------
    FeatureSet
        With ``info["data_files"]``, the files read (recorded in the manifest).
    """
    given = [k for k, v in (("builtin", builtin), ("features_file", features_file), ("plain", plain)) if v is not None]
    if len(given) != 1:
        raise ConfigError("no data source: give a built-in dataset, a feature table or a plain folder" if not given
                          else f"give one data source, not {' and '.join(given)}")
    if builtin is not None:
        return dataset_features(builtin, data_dir=data_dir, path=path,
                                min_objects=DEFAULT_MIN_OBJECTS if min_objects is None else min_objects)
    if features_file is not None:
        features = read_feature_table(Path(features_file))
        features.info.setdefault("data_files", [str(features_file)])
        return features
    assert plain is not None  # exactly one source is given (checked above)
    features = load_plain_dataset(Path(plain), min_objects=min_objects, **plain_options)
    features.info.setdefault("data_files", sorted(str(p) for p in Path(plain).rglob("*") if p.is_file()))
    return features
