"""``physiclear``: PhysiCLeAR (clear-nus/octopi), GelSight videos of everyday objects, as a plain-file dataset.

The release (https://github.com/clear-nus/octopi at commit :data:`PHYSICLEAR_COMMIT`) holds 476 videos
``dataset/<object>_<k>.mov`` (MPEG-4 part 2 in a QuickTime container, 320 x 240 pixels, a few seconds)
recorded by hand with a GelSight Mini: one video is one exploration of one object, a press then a
rotation of the sensor against the object (the paper's two exploratory procedures, "pressing and
rotation"), the first frames before contact. The registry lists every video and ``utils/constants.py``
under ``physiclear/`` with their sha256 and ``raw.githubusercontent.com`` links at that commit (``tzsl data
fetch physiclear``). The objects, their ranks, materials and split are the shipped table
(:mod:`tzsl.datasets._physiclear_table`); the 13 video stems without ranks are not read.

Key frames (:func:`contact_key_frames`), the fabric paper's idea with the first frame as reference, as
these videos allow: ``Diff(t) = mean |V(t) - V(1)|`` over pixels and channels (the per-pixel measure of
:func:`tzsl.features.frame_differences`: a GelSight Mini press barely changes the mean intensity of a frame,
brighter and darker regions cancelling); the contact is every frame whose
``Diff(t) - floor`` exceeds :data:`CONTACT_LEVEL` (one half) of ``peak - floor`` (``floor`` and ``peak`` the
least and largest difference after the first frame: the full width at half maximum of the contact). The
fabric paper ends its key frames at the maximum difference (the end of a press); here the contact goes
on with the rotation, so the key frames are :data:`N_KEY_FRAMES` (5) frames evenly spaced from the first
to the last frame of the contact. A half-maximum, not the fabric default onset at a tenth of the range:
the MPEG-4 codec's noise after release stays above a tenth of the range in these videos, so such a
level would not end the contact.

Features: every key frame's grey image minus the first frame's (the imprint, without the sensor's own
illumination pattern that every video shares), described by :class:`tzsl.features.TextureDescriptor`
(default settings), the key frames' descriptors concatenated in time order: ``key<k>_<descriptor name>``,
one sensor ``gelsight``. One trial per video (``trial_id`` = the file stem), object and class = the object.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

import numpy as np
import pandas as pd

from tzsl.datasets._physiclear_table import (
    PHYSICLEAR,
    PhysiclearTable,
    physiclear_split_roles,
    physiclear_split_text,
    read_physiclear_attributes,
)
from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.datasets._registry import fetch, registered_files
from tzsl.datasets._video import read_video
from tzsl.exceptions import DataFileError

__all__ = ["CONTACT_LEVEL", "N_KEY_FRAMES", "PHYSICLEAR_SENSOR", "PHYSICLEAR_SETTINGS", "PHYSICLEAR_VIDEO_DIR",
           "NoContactError", "contact_key_frames", "convert_physiclear", "describe_physiclear_video",
           "each_contact_video", "physiclear_key_frames", "physiclear_videos"]

T = TypeVar("T")

#: The registry folder of the videos.
PHYSICLEAR_VIDEO_DIR = f"{PHYSICLEAR}/dataset/"
#: Key frames per video.
N_KEY_FRAMES = 5
#: The contact: frames over this fraction of the difference range (the half maximum).
CONTACT_LEVEL = 0.5
#: The one sensor of the written dataset.
PHYSICLEAR_SENSOR = "gelsight"
#: ``dataset.toml`` of the written folder (74 objects, classes may share a row).
PHYSICLEAR_SETTINGS: dict = {"name": PHYSICLEAR, "classes": {"allow_identical_rows": True}}


class NoContactError(DataFileError):
    """A video that decodes but holds no contact to take the key frames from (too few frames, no change,
    a contact shorter than the key frames)."""


def physiclear_videos(table: PhysiclearTable | None = None) -> pd.DataFrame:
    """The registered videos of the table's objects, one row per video.

    Returns
    -------
    DataFrame
        ``trial_id`` (the file stem), ``object``, ``take`` (the ``<k>`` of the name), ``relpath`` (the
        registered path); by object in the table's order, then take.
    """
    table = table or read_physiclear_attributes()
    order = {o: i for i, o in enumerate(table.classes.index)}
    rows = []
    for relpath in registered_files(PHYSICLEAR_VIDEO_DIR):
        stem = Path(relpath).stem
        obj, _, take = stem.rpartition("_")
        if obj in order and take.isdigit():
            rows.append((stem, obj, int(take), relpath))
    frame = pd.DataFrame(rows, columns=["trial_id", "object", "take", "relpath"])
    frame = frame.sort_values(["object", "take"], key=lambda c: c.map(order) if c.name == "object" else c)
    return frame.reset_index(drop=True)


def contact_key_frames(difference: np.ndarray, *, n_key: int = N_KEY_FRAMES, level: float = CONTACT_LEVEL,
                       source: str | os.PathLike | None = None) -> np.ndarray:
    """Key frames evenly spaced over the contact (module docstring).

    Parameters
    ----------
    difference : ndarray of shape (T,)
        ``Diff(t)`` to the first frame (:func:`tzsl.features.frame_differences`), intensity units.
    n_key : int
        Key frames.
    level : float in (0, 1)
        The contact threshold as a fraction of ``peak - floor``.
    source : path-like, optional
        The video, for messages.

    Returns
    -------
    ndarray of shape (n_key,), int64
        0-based frame indices, strictly increasing.

    Raises
    ------
    NoContactError
        Fewer than ``n_key + 1`` frames, no change after the first frame, or a contact of fewer than
        ``n_key`` frames (a :class:`DataFileError`: one line naming the video).
    """
    diff = np.asarray(difference, dtype=np.float64)
    if diff.ndim != 1 or diff.shape[0] < n_key + 1:
        raise NoContactError(source, f"video has {diff.shape[0]} frames; {n_key} key frames after the reference "
                            f"frame need at least {n_key + 1}")
    later = diff[1:]
    floor, peak = float(later.min()), float(later.max())
    if not peak > floor:
        raise NoContactError(source, "no frame differs from the others (constant difference curve); no contact")
    over = np.flatnonzero(later - floor > level * (peak - floor)) + 1
    first, last = int(over[0]), int(over[-1])
    if last - first + 1 < n_key:
        raise NoContactError(source, f"the contact lasts {last - first + 1} frames ({first} to {last}); "
                            f"{n_key} distinct key frames need at least {n_key}")
    return np.floor(np.linspace(first, last, n_key) + 0.5).astype(np.int64)


def physiclear_key_frames(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """The imprints of one video's key frames (module docstring): every key frame's grey image minus the first's.

    The one key-frame rule of ``physiclear``: the texture descriptors (:func:`describe_physiclear_video`) and
    the CNN + LSTM of the ``fabric-deep`` study (``[dataset] builtin = "physiclear"``) both read these.

    Parameters
    ----------
    path : path-like
        A video file.

    Returns
    -------
    images : ndarray of shape (N_KEY_FRAMES, H, W), float64
        Grey key frame minus grey first frame (:func:`skimage.color.rgb2gray`, so in [-1, 1]), in time order.
    keys : ndarray of shape (N_KEY_FRAMES,), int64
        Their 0-based frame indices (:func:`contact_key_frames`).

    Raises
    ------
    DataFileError
        An unreadable video or one whose frames are not RGB (one line naming it); :class:`NoContactError`
        (a DataFileError) for one whose contact cannot give the key frames.
    """
    # tzsl.features imports tzsl.datasets: imported here, when a video is read, not at import time
    from skimage.color import rgb2gray  # noqa: PLC0415 - scikit-image is slow to import; only reading videos needs it

    from tzsl.features import frame_differences  # noqa: PLC0415 - tzsl.features imports tzsl.datasets

    video = read_video(path)
    if video.ndim != 4 or video.shape[-1] != 3:
        raise DataFileError(path, f"decoded frames of shape {video.shape[1:]}; expected RGB (H, W, 3)")
    keys = contact_key_frames(frame_differences(video, "mean_abs", source=str(path)), source=path)
    return rgb2gray(video[keys]) - rgb2gray(video[0])[None], keys


def describe_physiclear_video(path: str | os.PathLike, descriptor=None) -> tuple[np.ndarray, list[str]]:
    """The features of one video (module docstring).

    Parameters
    ----------
    path : path-like
        A video file.
    descriptor : TextureDescriptor, optional
        Default: :class:`tzsl.features.TextureDescriptor` with its default settings.

    Returns
    -------
    features : ndarray of shape (N_KEY_FRAMES * d,), float64
        The key frames' descriptors in time order.
    names : list of str
        ``key<k>_<name>``, k = 1..N_KEY_FRAMES.

    Raises
    ------
    DataFileError
        An unreadable video (one line naming it); :class:`NoContactError` (a DataFileError) for one whose
        contact cannot give the key frames.
    """
    from tzsl.features import TextureDescriptor  # noqa: PLC0415 - tzsl.features imports tzsl.datasets

    images, keys = physiclear_key_frames(path)
    descriptor = TextureDescriptor() if descriptor is None else descriptor
    features = descriptor.fit_transform(images[None])[0]
    names = [f"key{k}_{name}" for k in range(1, len(keys) + 1) for name in descriptor.feature_names_per_image_]
    return features.astype(np.float64), names


def each_contact_video(read: Callable[[Path], T], paths: Iterable[Path]) -> tuple[list[T], list[int]]:
    """``read`` of every video of ``paths`` that holds a contact, and their positions in ``paths``.

    A video without a contact (:class:`NoContactError`) is left out; one warning names them all.

    Raises
    ------
    DataFileError
        No video holds a contact.
    """
    done, kept, left_out = [], [], []
    for i, path in enumerate(paths):
        try:
            done.append(read(path))
        except NoContactError as exc:
            left_out.append(f"{Path(path).name} ({exc.problem})")
            continue
        kept.append(i)
    if left_out:
        warnings.warn(f"physiclear: {len(left_out)} video(s) without a contact to take key frames from are left "
                      f"out: {'; '.join(left_out)}", UserWarning, stacklevel=3)
    if not done:
        raise DataFileError(None, "no physiclear video holds a contact to take key frames from")
    return done, kept


def convert_physiclear(out: str | os.PathLike, data_dir: str | os.PathLike | None = None, *, force: bool = False,
                       encoding: str = "levels", table: PhysiclearTable | None = None) -> Path:
    """Write ``physiclear`` as a plain-file dataset folder (module docstring), with the paper's split.

    Parameters
    ----------
    out : path-like
        The folder to write (as :func:`~tzsl.datasets.write_plain_dataset`: absent or empty unless ``force``).
    data_dir : path-like, optional
        Data home holding the registered videos (``tzsl data fetch physiclear``).
    force : bool, default False
        Replace an existing dataset folder.
    encoding : {"levels", "thresholds"}
        The ranks' encoding (:func:`~tzsl.datasets.read_physiclear_attributes`).
    table : PhysiclearTable, optional
        The class-attribute table (default: the shipped one in ``encoding``).

    Returns
    -------
    Path
        ``out``, holding ``classes.csv``, ``trials.csv`` (one sensor, ``N_KEY_FRAMES * d`` feature columns),
        ``dataset.toml`` and ``splits.csv`` (the paper's split over the written objects,
        :func:`~tzsl.datasets.physiclear_split_text`; attributes that are 0 or 1 for every written object
        are left out).

    Raises
    ------
    DataMissingError
        A registered video missing from the data home (the message names the command that fetches it).
    ChecksumError
        A video whose sha256 differs from the registry's (one line naming it).
    DataFileError
        A video that cannot be decoded (one line naming it), or no video of the table's objects.

    Warns
    -----
    UserWarning
        One line naming the videos left out because they hold no contact to take key frames from
        (:class:`NoContactError`: a recording of 3 frames, say); their objects keep their other videos.
    """
    table = table or read_physiclear_attributes(encoding=encoding)
    videos = physiclear_videos(table)
    if videos.empty:
        raise DataFileError(None, f"no registered video under {PHYSICLEAR_VIDEO_DIR} of the table's objects")
    described, kept = each_contact_video(describe_physiclear_video, (fetch(r, data_dir) for r in videos["relpath"]))
    names = described[0][1]
    videos = videos.iloc[kept].reset_index(drop=True)
    X = np.stack([features for features, _ in described])[:, None, :]
    trials = pd.DataFrame({"trial_id": videos["trial_id"], "class": videos["object"], "object": videos["object"],
                           "trial_index": videos.groupby("object", sort=False).cumcount().to_numpy() + 1})
    classes = table.classes.loc[list(dict.fromkeys(videos["object"]))]
    classes = classes.loc[:, classes.nunique() > 1]  # an attribute no written object has (a part of the release)
    folder = write_plain_dataset(out, classes, trials, sensors=[PHYSICLEAR_SENSOR], X=X, feature_names=names,
                                 settings=PHYSICLEAR_SETTINGS, force=force)
    (folder / "splits.csv").write_text(physiclear_split_text(physiclear_split_roles(), classes), encoding="utf-8")
    return folder
