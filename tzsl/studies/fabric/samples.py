"""Samples of the fabric study: the public depth images and user GelSight videos as feature rows.

See :mod:`tzsl.studies.fabric.study` for the data conditions (``depth-sequence``, ``depth-image``,
``gelsight-<condition>``) and why they are built this way. Texture descriptors are cached with
:class:`joblib.Memory` under :func:`tzsl.datasets.get_cache_dir`, keyed on the sha256 of the
image (or video) files and the descriptor parameters; the depth images' descriptors are
:func:`tzsl.features.depth_image_descriptors` (also the ``fabric-depth`` dataset's features).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from skimage.transform import resize
from tqdm.auto import tqdm

from tzsl._io import file_sha256
from tzsl._parallel import reissued, relayed
from tzsl._profile import stage
from tzsl.datasets import FabricData, load_gelsight_fabric_videos
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import (
    KeyFrameSelector,
    TextureDescriptor,
    depth_image_descriptors,
    descriptor_memory,
    descriptor_params,
    files_digest,
)

__all__ = [
    "N_KEY_FRAMES",
    "PAPER_ROWS",
    "FabricSamples",
    "depth_image_descriptors",
    "depth_samples",
    "depth_sequence_rows",
    "descriptor_params",
    "files_digest",
    "gelsight_samples",
]

#: Key frames per sample (the paper's 5).
N_KEY_FRAMES = 5
#: GelSight conditions with a row in the paper's Table 1.
PAPER_ROWS = ("Flat", "Fold", "Rand")


@dataclass(frozen=True)
class FabricSamples:
    """Samples of one data condition.

    Attributes
    ----------
    condition : str
        Row name in the table (``depth-sequence``, ``depth-image``, ``gelsight-<folder>``).
    unit : str
        What one sample is (recorded in the table).
    X : ndarray of shape (n_samples, n_features), float64
        Descriptors (dimensionless texture statistics; see :class:`TextureDescriptor`).
    groups : ndarray of shape (n_samples,), int64
        Fabric group (class) of each sample, 0..7.
    samples : DataFrame
        One row per sample: fabric_id, fabric_name, group and the source (image ids or video).
    paper_row : str or None
        Row of the paper's Table 1 printed beside this condition.
    """

    condition: str
    unit: str
    X: np.ndarray
    groups: np.ndarray
    samples: pd.DataFrame
    paper_row: str | None


def depth_sequence_rows(images: pd.DataFrame, n_frames: int = N_KEY_FRAMES) -> np.ndarray:
    """Positions of ``n_frames`` evenly spaced images of every fabric, in capture order.

    Parameters
    ----------
    images : DataFrame
        :attr:`tzsl.datasets.FabricData.images` (columns fabric_id, capture_index).
    n_frames : int
        Images per fabric (the paper's 5 key frames).

    Returns
    -------
    ndarray of shape (n_fabrics, n_frames), int64
        Row positions in ``images``; fabrics in ascending fabric_id, images at capture
        positions ``round(linspace(0, n - 1, n_frames))`` of a fabric's n images.

    Raises
    ------
    DataFileError
        A fabric has fewer than ``n_frames`` images.
    """
    order = np.lexsort((images["capture_index"].to_numpy(), images["fabric_id"].to_numpy()))
    fab = images["fabric_id"].to_numpy()[order]
    ids, starts, sizes = np.unique(fab, return_index=True, return_counts=True)
    short = ids[sizes < n_frames]
    if short.size:
        raise DataFileError(
            None,
            f"fabric(s) {short[:10].tolist()} have fewer than {n_frames} depth images; a "
            f"depth sequence needs {n_frames}",
        )
    frac = np.linspace(0.0, 1.0, n_frames)
    local = np.floor(frac[None, :] * (sizes[:, None] - 1) + 0.5).astype(np.int64)
    return order[starts[:, None] + local]


def depth_samples(
    fabric: FabricData, descriptors: np.ndarray, n_frames: int = N_KEY_FRAMES
) -> tuple[FabricSamples, FabricSamples]:
    """The ``depth-sequence`` and ``depth-image`` samples (see the module docstring).

    Parameters
    ----------
    fabric : FabricData
    descriptors : ndarray of shape (n_images, d)
        :func:`depth_image_descriptors` (rows in ``fabric.images`` order).
    n_frames : int
        Images per sequence sample.

    Returns
    -------
    (sequence, image) : tuple of FabricSamples
        ``sequence.X`` has shape (n_fabrics, n_frames * d), ``image.X`` (n_images, d).
    """
    images = fabric.images
    descriptors = np.asarray(descriptors, dtype=np.float64)
    if descriptors.ndim != 2 or descriptors.shape[0] != len(images):
        raise ConfigError(
            f"descriptors must have shape ({len(images)}, d) (one row per depth image); "
            f"got {descriptors.shape}"
        )
    groups = images["group"].to_numpy(dtype=np.int64)
    rows = depth_sequence_rows(images, n_frames)
    first = images.iloc[rows[:, 0]]
    image_ids = images["image_id"].to_numpy()[rows]
    seq_table = pd.DataFrame(
        {
            "fabric_id": first["fabric_id"].to_numpy(),
            "fabric_name": first["fabric_name"].to_numpy(),
            "group": first["group"].to_numpy(),
            "image_ids": [" ".join(map(str, r)) for r in image_ids],
        }
    )
    sequence = FabricSamples(
        condition="depth-sequence",
        unit=f"fabric: {n_frames} evenly spaced depth images in capture order, descriptors concatenated",
        X=descriptors[rows].reshape(rows.shape[0], -1),
        groups=groups[rows[:, 0]],
        samples=seq_table,
        paper_row="Average",
    )
    image = FabricSamples(
        condition="depth-image",
        unit="depth image",
        X=descriptors,
        groups=groups,
        samples=images[["image_id", "fabric_id", "fabric_name", "group"]].reset_index(drop=True),
        paper_row="Average",
    )
    return sequence, image


def _shrink(frames: np.ndarray, max_side: int | None) -> np.ndarray:
    """(k, H, W) -> (k, h, w) with ``max(h, w) <= max_side`` (anti-aliased resize)."""
    if max_side is None or max(frames.shape[1:]) <= max_side:
        return frames
    scale = max_side / max(frames.shape[1:])
    shape = tuple(max(2, round(s * scale)) for s in frames.shape[1:])
    return np.stack([resize(f, shape, anti_aliasing=True, preserve_range=True) for f in frames])


def _describe_video(
    digest: str, path: str, selector_params: dict, descriptor_params: dict, max_side: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """Key-frame indices (5,) and concatenated descriptors (5 d,) of one video (cached unit)."""
    key = KeyFrameSelector(**selector_params).select_one(path)
    frames = _shrink(key.frames, max_side)
    desc = TextureDescriptor(**descriptor_params).fit(frames[None])
    return key.indices, desc.transform(frames[None])[0]


def gelsight_samples(
    root: str | os.PathLike,
    *,
    conditions: Sequence[str] | None = None,
    n_groups: int = 8,
    selector: KeyFrameSelector | None = None,
    descriptor: TextureDescriptor | None = None,
    max_side: int | None = 224,
    cache_dir=None,
    n_jobs: int | None = 1,
    progress: bool = False,
) -> list[FabricSamples]:
    """One :class:`FabricSamples` per condition folder of user-supplied GelSight videos.

    Parameters
    ----------
    root : str or path-like
        Layout of :func:`tzsl.datasets.load_gelsight_fabric_videos`.
    conditions : sequence of str or None
        Condition folders (None: all).
    n_groups : int
        Groups in ``root/fabric_groups.csv`` must lie in ``0 .. n_groups - 1`` (the rows of
        the attribute matrix).
    selector : KeyFrameSelector or None
        Key-frame parameters (default: the paper's, ``KeyFrameSelector()``); ``as_gray`` is
        always set.
    descriptor : TextureDescriptor or None
        Descriptor parameters (default ``TextureDescriptor()``).
    max_side : int or None
        Key frames are resized so their longer side is at most this many pixels (None: keep).
    cache_dir, n_jobs, progress
        As in :func:`depth_image_descriptors`; videos are spread over ``n_jobs`` workers.

    Returns
    -------
    list of FabricSamples
        ``X`` of shape (n_videos, 5 d); ``samples`` lists each video's path and key-frame
        indices.

    Raises
    ------
    DataFileError
        Groups outside ``0 .. n_groups - 1``; a video without a detectable press or too short.
    """
    videos = load_gelsight_fabric_videos(root, conditions)
    bad = sorted(set(videos.loc[(videos["group"] < 0) | (videos["group"] >= n_groups), "group"]))
    if bad:
        raise DataFileError(
            Path(root) / "fabric_groups.csv",
            f"groups {bad[:10]} are outside 0..{n_groups - 1}, the rows of the attribute matrix",
        )
    sel = selector if selector is not None else KeyFrameSelector()
    sel_params = {**sel.get_params(), "as_gray": True}
    desc_params = descriptor_params(descriptor if descriptor is not None else TextureDescriptor())
    cached = descriptor_memory(cache_dir).cache(_describe_video, ignore=["path"])
    paths = videos["path"].tolist()
    if progress:
        tqdm.write(f"key frames and descriptors of {len(paths)} GelSight videos (cached afterwards)")
    with stage("features"):  # key frames and descriptors, in joblib workers (cached)
        results = [reissued(r) for r in Parallel(n_jobs=n_jobs)(
            delayed(relayed(cached))(file_sha256(p), p, sel_params, desc_params, max_side) for p in paths
        )]
    lengths = {r[1].shape[0] for r in results}
    if len(lengths) > 1:
        raise DataFileError(Path(root), f"videos give descriptors of different lengths {sorted(lengths)}")
    table = videos.assign(key_frames=[" ".join(map(str, r[0])) for r in results])
    X_all = np.stack([r[1] for r in results])
    out = []
    for cond, rows in table.groupby("condition", sort=False):
        pos = rows.index.to_numpy()
        out.append(
            FabricSamples(
                condition=f"gelsight-{cond}",
                unit="GelSight press video: 5 key frames (paper's rule), descriptors concatenated",
                X=X_all[pos],
                groups=rows["group"].to_numpy(dtype=np.int64),
                samples=rows.reset_index(drop=True),
                paper_row=cond if cond in PAPER_ROWS else None,
            )
        )
    return out
