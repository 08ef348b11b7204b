"""The 15 real GelSight press videos with per-frame gripper force and width.

Layout under the data home (``gelsight_press/PROVENANCE.md``)::

    gelsight_press/<object>_<n>.avi           MJPG, 640 x 480, 30 fps, T frames
    gelsight_press/<object>_<n>_forces.pkl    float64 array (T,), gripper force in N
    gelsight_press/<object>_<n>_widths.pkl    float64 array (T,), gripper width in m

Every file is checked against the registry's sha256; the pickles are read with the
restricted unpickler (:func:`tzsl.datasets.safe_load_pickle`). Videos are decoded only
on request (:meth:`PressRecord.read_video`); their frame count is checked against the
force/width length from the AVI header at load time.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tzsl.datasets._home import get_data_home
from tzsl.datasets._registry import fetch, registered_files
from tzsl.datasets._safe_pickle import safe_load_pickle
from tzsl.datasets._video import avi_frame_count, read_video
from tzsl.exceptions import DataFileError

__all__ = ["PressRecord", "load_gelsight_press"]

_PREFIX = "gelsight_press/"
_VIDEO_RE = re.compile(r"^(?P<object>.+)_(?P<press>\d+)\.avi$")


@dataclass(frozen=True)
class PressRecord:
    """One press of the GelSight sensor onto an object.

    Attributes
    ----------
    object_name : str
        E.g. ``"golf_ball"``.
    press_index : int
        The ``<n>`` of the file name (1-based, as in the source).
    video_path : Path
        The ``.avi`` file (decode with :meth:`read_video`).
    forces : ndarray of shape (T,), float64
        Gripper force per video frame, newtons.
    widths : ndarray of shape (T,), float64
        Gripper opening per video frame, metres.
    """

    object_name: str
    press_index: int
    video_path: Path
    forces: np.ndarray
    widths: np.ndarray

    @property
    def name(self) -> str:
        """``<object>_<n>``."""
        return f"{self.object_name}_{self.press_index}"

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return int(self.forces.shape[0])

    def read_video(self) -> np.ndarray:
        """Decode the video: ndarray of shape (T, 480, 640, 3), uint8."""
        frames = read_video(self.video_path)
        if frames.shape[0] != self.n_frames:
            raise DataFileError(
                self.video_path, f"video has {frames.shape[0]} frames but {self.n_frames} force readings"
            )
        return frames


def _series(path: Path, what: str) -> np.ndarray:
    obj = safe_load_pickle(path)
    arr = np.asarray(obj) if isinstance(obj, np.ndarray) else None
    if arr is None or arr.ndim != 1 or not np.issubdtype(arr.dtype, np.number):
        shape = getattr(obj, "shape", None)
        raise DataFileError(
            path, f"expected a 1-D numeric numpy array of {what}; got {type(obj).__name__} {shape or ''}".rstrip()
        )
    arr = arr.astype(np.float64)
    if not np.isfinite(arr).all():
        raise DataFileError(path, f"{what} contain NaN or infinite values")
    return arr


def load_gelsight_press(data_dir: str | os.PathLike | None = None) -> list[PressRecord]:
    """Load the GelSight press records (forces and widths; videos lazily).

    Parameters
    ----------
    data_dir : str or path-like or None
        Data home (see :func:`tzsl.datasets.get_data_home`).

    Returns
    -------
    list of PressRecord
        Ordered by object name, then press index.

    Raises
    ------
    DataMissingError, ChecksumError
        A registered file is missing or corrupt.
    DataFileError
        A pickle is not a 1-D numeric array, forces and widths differ in length, or the
        AVI header's frame count differs from it.
    """
    home = get_data_home(data_dir)
    videos = [r for r in registered_files(_PREFIX) if r.endswith(".avi")]
    if not videos:
        raise DataFileError(None, f"the dataset registry lists no {_PREFIX}*.avi files")
    records = []
    for rel in videos:
        m = _VIDEO_RE.match(rel[len(_PREFIX):])
        if m is None:
            raise DataFileError(home / rel, "video name does not match <object>_<n>.avi")
        stem = rel[: -len(".avi")]
        video = fetch(rel, home)
        forces = _series(fetch(f"{stem}_forces.pkl", home), "forces")
        widths = _series(fetch(f"{stem}_widths.pkl", home), "widths")
        if forces.shape != widths.shape:
            raise DataFileError(
                video, f"forces have {forces.shape[0]} readings but widths {widths.shape[0]}"
            )
        declared = avi_frame_count(video)
        if declared != forces.shape[0]:
            raise DataFileError(
                video, f"AVI header declares {declared} frames but there are {forces.shape[0]} force readings"
            )
        records.append(PressRecord(m["object"], int(m["press"]), Path(video), forces, widths))
    return sorted(records, key=lambda r: (r.object_name, r.press_index))
