"""Features of the built-in datasets tzsl computes itself: fabric depth images and simulated grasps.

``fabric-depth`` (:class:`~tzsl.datasets.FabricData`): one :class:`TextureDescriptor` vector per
depth image, cached on disk with :class:`joblib.Memory` under
:func:`tzsl.datasets.get_cache_dir`, keyed on the sha256 of the image files and the descriptor
parameters (the fabric study reads the same cache, :func:`depth_image_descriptors`).
``hand-simulated`` (:class:`~tzsl.datasets.SimulatedGrasps`): the packed grasp features of
:func:`grasp_features` (the hand study's input), one sensor ``"hand"``.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from tqdm.auto import tqdm

from tzsl._io import file_sha256
from tzsl._parallel import reissued, relayed
from tzsl.datasets import FabricData, FeatureSet, SimulatedGrasps, get_cache_dir, read_depth_images
from tzsl.exceptions import ConfigError
from tzsl.features._attribute_filter import filter_attributes
from tzsl.features._grasp_features import MATERIAL_FEATURES, grasp_features
from tzsl.features._texture import DESCRIPTOR_CHUNK, TextureDescriptor, texture_feature_names

__all__ = ["depth_image_descriptors", "descriptor_memory", "descriptor_params", "fabric_depth_feature_set",
           "fabric_group_table",
           "files_digest", "simulated_grasp_feature_set"]


def files_digest(paths: Sequence[str | os.PathLike]) -> str:
    """sha256 over every file's name and content sha256, in order (the cache key of the data)."""
    digest = hashlib.sha256()
    for p in paths:
        digest.update(Path(p).name.encode())
        digest.update(file_sha256(p).encode())
    return digest.hexdigest()


def descriptor_params(descriptor: TextureDescriptor) -> dict:
    """The descriptor's parameters that change its output (all but ``n_jobs``)."""
    return {k: v for k, v in descriptor.get_params().items() if k != "n_jobs"}


def descriptor_memory(cache_dir=None) -> joblib.Memory:
    """The on-disk cache of texture descriptors (default folder :func:`tzsl.datasets.get_cache_dir`)."""
    return joblib.Memory(str(get_cache_dir(cache_dir)), verbose=0)


def _describe_depth_chunk(paths: list[str], params: dict) -> np.ndarray:
    """Descriptors (n, d) of a few depth PNGs, read and described in one joblib job."""
    images = read_depth_images(paths)
    return TextureDescriptor(**params, n_jobs=1).fit(images[:1]).transform(images)


def _describe_depth_files(digest: str, paths: list[str], params: dict, n_jobs: int | None) -> np.ndarray:
    """Descriptors of depth PNGs (the cached unit; ``paths`` and ``n_jobs`` are not in the key).

    The files are read in the workers that describe them (chunks of the descriptor's batch size),
    not one after the other in this process before.
    """
    chunks = [paths[i:i + DESCRIPTOR_CHUNK] for i in range(0, len(paths), DESCRIPTOR_CHUNK)]
    parts = Parallel(n_jobs=n_jobs)(delayed(relayed(_describe_depth_chunk))(c, params) for c in chunks)
    return np.concatenate([reissued(p) for p in parts], axis=0)


def depth_image_descriptors(
    fabric: FabricData,
    descriptor: TextureDescriptor | None = None,
    *,
    cache_dir=None,
    n_jobs: int | None = 1,
    progress: bool = False,
) -> np.ndarray:
    """Texture descriptors of every depth image, cached on disk.

    Parameters
    ----------
    fabric : FabricData
        From :func:`tzsl.datasets.load_fabric` (with images).
    descriptor : TextureDescriptor or None
        Descriptor parameters (default: ``TextureDescriptor()``); its ``n_jobs`` is ignored.
    cache_dir : str, path or None
        Cache folder (default :func:`tzsl.datasets.get_cache_dir`).
    n_jobs : int or None
        joblib workers for a cold computation.
    progress : bool
        Say on stderr when the descriptors are computed rather than read from the cache.

    Returns
    -------
    ndarray of shape (n_images, d), float64
        Rows in the order of ``fabric.images``; ``d = 99`` for the default descriptor.
    """
    params = descriptor_params(descriptor if descriptor is not None else TextureDescriptor())
    paths = fabric.images["path"].tolist()
    if not paths:
        raise ConfigError("the fabric data has no image table; load it with images=True")
    digest = files_digest(paths)
    cached = descriptor_memory(cache_dir).cache(_describe_depth_files, ignore=["paths", "n_jobs"])
    if progress and not cached.check_call_in_cache(digest, paths, params, n_jobs):
        tqdm.write(f"computing texture descriptors of {len(paths)} depth images (cached afterwards)")
    return cached(digest, paths, params, n_jobs)


def _feature_set(X: np.ndarray, trials: pd.DataFrame, object_rows: pd.DataFrame, sensor: str,
                 feature_names: Sequence[str], dataset: str, min_objects: int, info: dict) -> FeatureSet:
    """A one-sensor FeatureSet with the attribute table filtered to ``min_objects`` objects."""
    attributes, dropped = filter_attributes(object_rows, min_objects)
    return FeatureSet(X=np.asarray(X, dtype=np.float64)[:, None, :], trials=trials.reset_index(drop=True),
                      sensors=(sensor,), feature_names=tuple(feature_names), attributes=attributes,
                      dataset=dataset, info={"dropped_attributes": dropped, "min_objects": int(min_objects), **info})


def fabric_group_table(fabric: FabricData, groups: np.ndarray | None = None) -> pd.DataFrame:
    """The ``fabric-depth`` object-attribute table: one row per fabric group (``group-<g>``), unfiltered.

    Parameters
    ----------
    fabric : FabricData
        From :func:`tzsl.datasets.load_fabric` (``images=False`` suffices).
    groups : ndarray of int, optional
        The groups the trials hold (default: every group of the attribute matrix).

    Returns
    -------
    DataFrame (n_groups, n_attributes) of int64 0/1
        Indexed by ``object_name``, groups in ascending order.
    """
    order = sorted(set((fabric.attributes.index if groups is None else groups).tolist()))
    rows = fabric.attributes.loc[order].astype(np.int64)
    rows.index = pd.Index([f"group-{g}" for g in order], name="object_name")
    return rows


def fabric_depth_feature_set(fabric: FabricData, min_objects: int = 3) -> FeatureSet:
    """The ``fabric-depth`` dataset: one trial per depth image, one object per fabric group.

    The fabric paper recognises fabric *groups* it was not trained on, so the unit a split holds out
    is the group: each of the 8 groups is one object (and class), and its trials are the depth images
    of all its fabrics. (With one object per fabric, every test fabric's group row would also be a
    training fabric's, and nothing would be zero-shot.)

    Parameters
    ----------
    fabric : FabricData
        From :func:`tzsl.datasets.load_fabric` with images.
    min_objects : int, default 3
        Keep attributes present in at least this many groups.

    Returns
    -------
    FeatureSet
        ``X`` (n_images, 1, 99): the default :class:`TextureDescriptor` of every image
        (:func:`depth_image_descriptors`, cached); sensor ``"depth"``; trials with ``object_name`` =
        ``class`` = ``group-<g>`` (and the fabric in ``fabric``); ``attributes`` (8, n_attributes): the
        group x attribute matrix.
    """
    images = fabric.images
    X = depth_image_descriptors(fabric)
    groups = images["group"].to_numpy(dtype=np.int64)
    names_of = pd.Series([f"group-{g}" for g in groups])
    trials = pd.DataFrame({
        "trial_id": [f"{n}-{i}" for n, i in zip(images["fabric_name"], images["capture_index"], strict=True)],
        "object_id": groups,
        "object_name": names_of.to_numpy(),
        "trial_index": names_of.groupby(names_of).cumcount().to_numpy(dtype=np.int64) + 1,
        "class": names_of.to_numpy(),
        "fabric": images["fabric_name"].astype(str).to_numpy(),
    })
    rows = fabric_group_table(fabric, groups)
    names = texture_feature_names(descriptor_params(TextureDescriptor()))
    return _feature_set(X, trials, rows, "depth", names, "fabric-depth", min_objects,
                        {"attribute_set": fabric.attribute_set,
                         "duplicate_groups": [list(map(int, d)) for d in fabric.duplicate_groups]})


def simulated_grasp_feature_set(simulated: SimulatedGrasps, K: pd.DataFrame, min_objects: int = 3) -> FeatureSet:
    """The ``hand-simulated`` dataset: one trial per simulated grasp, one object per Table 4 row.

    Parameters
    ----------
    simulated : SimulatedGrasps
        From :func:`tzsl.datasets.simulate_grasps`.
    K : DataFrame of shape (n_objects, n_attributes), 0/1
        The class-attribute table the grasps were drawn from (indexed by object name).
    min_objects : int, default 3
        Keep attributes present in at least this many objects.

    Returns
    -------
    FeatureSet
        ``X`` (n_grasps, 1, F * 22 + F + n_joints): the packed grasp features of
        :func:`grasp_features` with its default windows (material means per BioTac, contact
        flags, closing-joint angles; ADC counts, 0/1, radians); sensor ``"hand"``.
    """
    features = grasp_features(simulated.grasps)
    objects = features.objects.astype(str)
    order = {o: i for i, o in enumerate(K.index)}
    trials = pd.DataFrame({"trial_id": features.grasp_ids.astype(str), "object_name": objects})
    trials.insert(1, "object_id", trials["object_name"].map(order).to_numpy(dtype=np.int64))
    trials["trial_index"] = trials.groupby("object_name", sort=False).cumcount().to_numpy(dtype=np.int64) + 1
    trials["class"] = objects
    n_fingers = features.material.shape[1]
    names = ([f"f{i}_{m}" for i in range(n_fingers) for m in MATERIAL_FEATURES]
             + [f"f{i}_contact" for i in range(n_fingers)] + list(features.joint_names))
    rows = K.loc[pd.unique(objects)].astype(np.int64).rename_axis("object_name")
    return _feature_set(features.to_array(), trials, rows, "hand", names, "hand-simulated", min_objects,
                        {"simulated": True, "simulation": dict(simulated.params)})
