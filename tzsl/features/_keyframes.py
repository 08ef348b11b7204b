"""Key-frame selection for tactile press videos (F14, fabric ZSL paper section 4.1).

The paper ("first frame as reference") takes the first frame ``V(1)`` of a press video,
which is always recorded before contact, and computes for every later frame

    Diff(t) = | I(V(t)) - I(V(1)) |,   t = 2, ..., T,

where ``I`` is the **mean intensity** of a frame. The start key frame is the first frame
whose difference exceeds a threshold, the end key frame is the frame of maximum
difference, and ``n_between`` (3) frames are spread evenly between them: 5 key frames.

Difference measures (``measure``)
---------------------------------
``"mean_intensity"`` (default, the paper's)
    ``|mean(V(t)) - mean(V(1))|`` over all pixels and channels, in intensity units.
``"mean_abs"``
    ``mean(|V(t) - V(1)|)``: the mean per-pixel absolute change. Not in the paper. On
    GelSight Wedge videos contact brightens some regions and darkens others, and the
    two cancel in the mean intensity; the per-pixel measure does not cancel. On the 15
    real press videos of ``data/gelsight_press`` the paper's measure puts the end frame
    outside the force plateau in 3 videos, the per-pixel measure in none (see
    ``tests/features/test_keyframes.py``).

Threshold (``threshold_mode``)
------------------------------
``"relative"`` (default)
    ``threshold`` is a fraction of the video's own difference range: with
    ``floor = min_{t>=2} Diff(t)`` (the noise level between two contact-free frames)
    and ``peak = max_t Diff(t)``, the start is the first frame with
    ``Diff(t) - floor > threshold * (peak - floor)``. The default 0.1 is the usual
    10 % onset criterion of a rising signal (as in the 10-90 % rise time); it is fixed
    a priori, not tuned on any data, and it is independent of sensor gain, lighting
    and codec noise. It cannot tell a press from noise: a video without contact still
    yields key frames (check ``KeyFrames.difference``).
``"absolute"``
    ``threshold`` is in the measure's intensity units (0-255 for 8-bit video): the start
    is the first frame with ``Diff(t) > threshold``. A video where no frame exceeds it
    is an error (no press detected).

Frame indices are 0-based (frame ``V(1)`` of the paper is index 0).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from skimage.color import rgb2gray, rgba2rgb
from skimage.util import img_as_float
from sklearn.base import BaseEstimator, TransformerMixin

from tzsl.datasets import read_video
from tzsl.exceptions import ConfigError, DataFileError

__all__ = ["KeyFrames", "KeyFrameSelector", "frame_differences", "key_frame_indices"]

_MEASURES = ("mean_intensity", "mean_abs")
_MODES = ("relative", "absolute")
# Frames per chunk when differencing a video (bounds temporary memory to ~chunk x frame).
_CHUNK = 16


@dataclass(frozen=True)
class KeyFrames:
    """The key frames of one video.

    Attributes
    ----------
    indices : ndarray of shape (n_between + 2,), int
        0-based frame indices in time order: start, the evenly spaced ones, end.
    frames : ndarray of shape (n_between + 2, H, W[, C])
        The selected frames (same dtype as the video; float in [0, 1] if ``as_gray``).
    difference : ndarray of shape (T,), float
        ``Diff(t)`` for every frame (``difference[0] == 0``), in intensity units.
    source : str or None
        File or label of the video (used in error messages).
    """

    indices: np.ndarray
    frames: np.ndarray
    difference: np.ndarray
    source: str | None = None

    @property
    def start(self) -> int:
        """Index of the start key frame (first frame over the threshold)."""
        return int(self.indices[0])

    @property
    def end(self) -> int:
        """Index of the end key frame (maximum difference)."""
        return int(self.indices[-1])


def _err(source: str | None, problem: str) -> DataFileError:
    return DataFileError(source, problem)


def _check_video(video: np.ndarray, source: str | None) -> np.ndarray:
    video = np.asarray(video)
    if video.ndim not in (3, 4):
        raise _err(source, f"a video must have shape (T, H, W) or (T, H, W, C); got {video.shape}")
    if not (np.issubdtype(video.dtype, np.integer) or np.issubdtype(video.dtype, np.floating)):
        raise _err(source, f"video frames must be numeric; got dtype {video.dtype}")
    if np.issubdtype(video.dtype, np.floating) and not np.isfinite(video).all():
        raise _err(source, "video contains NaN or infinite values")
    return video


def frame_differences(
    video: np.ndarray, measure: str = "mean_intensity", *, source: str | None = None
) -> np.ndarray:
    """Difference of every frame to the first frame (vectorised over frames).

    Parameters
    ----------
    video : ndarray of shape (T, H, W) or (T, H, W, C)
        Frames in intensity units (e.g. uint8 0-255).
    measure : {"mean_intensity", "mean_abs"}
        See the module docstring.
    source : str or None
        Name of the video for error messages.

    Returns
    -------
    ndarray of shape (T,), float64
        ``Diff(t)``; ``Diff(0) == 0``.
    """
    video = _check_video(video, source)
    if measure not in _MEASURES:
        raise ConfigError(f"measure must be one of {_MEASURES}; got {measure!r}")
    axes = tuple(range(1, video.ndim))
    if measure == "mean_intensity":
        means = video.mean(axis=axes, dtype=np.float64)
        return np.abs(means - means[0])
    ref = video[0].astype(np.float32)
    out = np.empty(video.shape[0], dtype=np.float64)
    for lo in range(0, video.shape[0], _CHUNK):  # chunks of frames bound the memory
        chunk = video[lo : lo + _CHUNK].astype(np.float32)
        out[lo : lo + _CHUNK] = np.abs(chunk - ref).mean(axis=axes, dtype=np.float64)
    return out


def key_frame_indices(
    difference: np.ndarray,
    *,
    threshold: float = 0.1,
    threshold_mode: str = "relative",
    n_between: int = 3,
    source: str | None = None,
) -> np.ndarray:
    """Start, evenly spaced and end key-frame indices from a difference curve.

    Parameters
    ----------
    difference : ndarray of shape (T,)
        ``Diff(t)`` as from :func:`frame_differences`.
    threshold, threshold_mode : float, {"relative", "absolute"}
        See the module docstring.
    n_between : int
        Frames evenly spaced strictly between start and end.
    source : str or None
        Name of the video for error messages.

    Returns
    -------
    ndarray of shape (n_between + 2,), int64
        Strictly increasing 0-based indices: ``start``, ``n_between`` frames at
        ``round(linspace(start, end, n_between + 2))``, ``end``.

    Raises
    ------
    DataFileError
        Fewer than ``n_between + 2`` frames; no frame over the threshold (absolute
        mode) or a video without any change (relative mode); fewer than
        ``n_between + 2`` frames from start to end, so the key frames cannot be
        distinct.
    """
    _check_params(threshold, threshold_mode, n_between)
    diff = np.asarray(difference, dtype=np.float64)
    n_key = n_between + 2
    if diff.ndim != 1:
        raise _err(source, f"difference curve must be 1-D; got shape {diff.shape}")
    if diff.shape[0] < n_key:
        raise _err(
            source, f"video has {diff.shape[0]} frames; key-frame selection needs at least {n_key}"
        )
    later = diff[1:]  # t = 2..T of the paper
    peak = later.max()
    end = 1 + int(np.argmax(later))
    if threshold_mode == "relative":
        floor = later.min()
        if not peak > floor:
            raise _err(source, "no frame differs from the others (constant difference curve); "
                       "the video shows no press")
        over = later - floor > threshold * (peak - floor)
    else:
        over = later > threshold
        if not over.any():
            raise _err(
                source,
                f"no frame differs from the first frame by more than the threshold "
                f"{threshold:g} (maximum difference {peak:.3g}); no press detected",
            )
    start = 1 + int(np.argmax(over))
    if end - start < n_key - 1:
        raise _err(
            source,
            f"the press rises from the threshold (frame {start}) to its maximum (frame {end}) "
            f"in {end - start} frames; {n_key} distinct key frames need at least {n_key - 1}",
        )
    return np.floor(np.linspace(start, end, n_key) + 0.5).astype(np.int64)


def _check_params(threshold: float, threshold_mode: str, n_between: int) -> None:
    if threshold_mode not in _MODES:
        raise ConfigError(f"threshold_mode must be one of {_MODES}; got {threshold_mode!r}")
    if isinstance(n_between, bool) or not isinstance(n_between, (int, np.integer)) or n_between < 0:
        raise ConfigError(f"n_between must be an integer >= 0; got {n_between!r}")
    try:
        thr = float(threshold)
    except (TypeError, ValueError):
        raise ConfigError(f"threshold must be a number; got {threshold!r}") from None
    if threshold_mode == "relative" and not 0.0 < thr < 1.0:
        raise ConfigError(f"a relative threshold must lie in (0, 1); got {threshold!r}")
    if threshold_mode == "absolute" and not thr > 0.0:
        raise ConfigError(f"an absolute threshold must be > 0; got {threshold!r}")


class KeyFrameSelector(TransformerMixin, BaseEstimator):
    """Select the paper's 5 key frames of a press video (F14).

    Stateless: ``fit`` only validates the parameters. See the module docstring for the
    difference measures and the threshold.

    Parameters
    ----------
    threshold : float, default=0.1
        Onset threshold: a fraction in (0, 1) of the video's difference range
        (``threshold_mode="relative"``) or intensity units (``"absolute"``).
    n_between : int, default=3
        Frames evenly spaced between the start and end key frames (the paper: 3).
    measure : {"mean_intensity", "mean_abs"}, default="mean_intensity"
        Frame difference to the first frame; ``"mean_intensity"`` is the paper's.
    threshold_mode : {"relative", "absolute"}, default="relative"
        How ``threshold`` is read.
    as_gray : bool, default=False
        Return the key frames as grey images (``skimage.color.rgb2gray`` for colour
        frames; float in [0, 1] for integer input), ready for
        :class:`tzsl.features.TextureDescriptor`.

    Attributes
    ----------
    n_key_frames_ : int
        ``n_between + 2``.

    Notes
    -----
    ``X`` is one video (an ndarray of shape (T, H, W) or (T, H, W, C)) or a sequence of
    videos (ndarrays or paths of video files, read with
    :func:`tzsl.datasets.read_video`). An ndarray is always one video.
    """

    def __init__(
        self,
        threshold: float = 0.1,
        n_between: int = 3,
        measure: str = "mean_intensity",
        threshold_mode: str = "relative",
        as_gray: bool = False,
    ) -> None:
        self.threshold = threshold
        self.n_between = n_between
        self.measure = measure
        self.threshold_mode = threshold_mode
        self.as_gray = as_gray

    def _validate(self) -> None:
        _check_params(self.threshold, self.threshold_mode, self.n_between)
        if self.measure not in _MEASURES:
            raise ConfigError(f"measure must be one of {_MEASURES}; got {self.measure!r}")

    def fit(self, X=None, y=None) -> KeyFrameSelector:
        """Validate the parameters (nothing is learnt).

        Parameters
        ----------
        X : ignored
        y : ignored

        Returns
        -------
        self
        """
        self._validate()
        self.n_key_frames_ = int(self.n_between) + 2
        return self

    def select_one(self, video: np.ndarray | str | os.PathLike, source: str | None = None) -> KeyFrames:
        """Key frames of one video.

        Parameters
        ----------
        video : ndarray of shape (T, H, W) or (T, H, W, C), or path of a video file
        source : str or None
            Name used in error messages (defaults to the file path for a path).

        Returns
        -------
        KeyFrames
        """
        self._validate()
        if isinstance(video, (str, os.PathLike)):
            source = source or str(video)
            frames = read_video(Path(video))
        else:
            frames = video
        video = _check_video(frames, source)
        diff = frame_differences(video, self.measure, source=source)
        idx = key_frame_indices(
            diff,
            threshold=self.threshold,
            threshold_mode=self.threshold_mode,
            n_between=int(self.n_between),
            source=source,
        )
        frames = video[idx]
        if self.as_gray:
            frames = _to_gray(frames)
        return KeyFrames(indices=idx, frames=frames, difference=diff, source=source)

    def select(self, X) -> list[KeyFrames]:
        """Key frames of each video in ``X`` (see the class Notes for ``X``).

        Returns
        -------
        list of KeyFrames
            One per video (a one-element list for a single ndarray).
        """
        if isinstance(X, np.ndarray):
            return [self.select_one(X, source=None)]
        if isinstance(X, (str, os.PathLike)):
            return [self.select_one(X)]
        if not isinstance(X, Sequence) or len(X) == 0:
            raise ConfigError("X must be a video array or a non-empty sequence of videos/paths")
        return [
            self.select_one(v, source=None if isinstance(v, (str, os.PathLike)) else f"video {i}")
            for i, v in enumerate(X)
        ]

    def transform(self, X) -> np.ndarray:
        """The key frames, in time order.

        Parameters
        ----------
        X : ndarray or sequence of ndarrays / paths
            One video (ndarray) or several (see the class Notes).

        Returns
        -------
        ndarray
            For one ndarray video: shape (n_between + 2, H, W[, C]). For a sequence:
            shape (n_videos, n_between + 2, H, W[, C]); all videos must share their
            frame shape.
        """
        picked = self.select(X)
        if isinstance(X, np.ndarray):
            return picked[0].frames
        shapes = {kf.frames.shape[1:] for kf in picked}
        if len(shapes) > 1:
            raise DataFileError(
                None, f"videos have different frame shapes {sorted(shapes)}; cannot stack key frames"
            )
        return np.stack([kf.frames for kf in picked])

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.input_tags.three_d_array = True
        tags.requires_fit = False
        return tags


def _to_gray(frames: np.ndarray) -> np.ndarray:
    """(n, H, W[, 3|4]) -> (n, H, W) float grey; integer input scaled to [0, 1]."""
    if frames.ndim == 4:
        if frames.shape[-1] == 4:
            frames = np.stack([rgba2rgb(f) for f in frames])
        if frames.shape[-1] == 3:
            return rgb2gray(frames)
        if frames.shape[-1] == 1:
            frames = frames[..., 0]
        else:
            raise DataFileError(None, f"cannot convert frames with {frames.shape[-1]} channels to grey")
    return img_as_float(frames)
