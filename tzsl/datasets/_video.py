"""Reading tactile videos (GelSight ``.avi``, MJPG and other ffmpeg-readable codecs).

Decoding goes through :mod:`imageio` with the ``imageio-ffmpeg`` plugin, which ships its
own static ffmpeg binary in the wheel (no system ffmpeg needed).

ffmpeg silently decodes whatever frames a truncated file still holds, so for AVI files
(RIFF containers) the reader also checks the container header: the RIFF chunk size must
fit the file, and the number of decoded frames must equal the frame count the main AVI
header (``avih.dwTotalFrames``) declares. Any mismatch is a :class:`DataFileError`.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np

from tzsl.exceptions import DataFileError, DataMissingError

__all__ = ["read_video", "avi_frame_count"]

# Bytes of the file start searched for the 'avih' header (it follows 'RIFF....AVI LIST....hdrl').
_AVI_HEADER_SEARCH = 4096


def avi_frame_count(path: str | os.PathLike) -> int:
    """Frame count declared in an AVI file's main header, without decoding anything.

    Parameters
    ----------
    path : str or path-like
        An ``.avi`` (RIFF/AVI) file.

    Returns
    -------
    int
        ``dwTotalFrames`` of the ``avih`` chunk (of the ``dmlh`` chunk for OpenDML
        files).

    Raises
    ------
    DataMissingError
        The file does not exist.
    DataFileError
        The file is empty, not a RIFF/AVI file, has no main AVI header, or is shorter
        than its RIFF header declares (truncated).
    """
    path = Path(path)
    if not path.is_file():
        raise DataMissingError(path, "video file not found")
    size = path.stat().st_size
    if size == 0:
        raise DataFileError(path, "empty file (0 bytes); expected an AVI video")
    with path.open("rb") as fh:
        head = fh.read(_AVI_HEADER_SEARCH)
    if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"AVI ":
        raise DataFileError(path, "not a RIFF/AVI file (no 'RIFF....AVI ' signature)")
    riff_size = struct.unpack("<I", head[4:8])[0] + 8
    if riff_size > size:
        raise DataFileError(
            path,
            f"truncated AVI: the RIFF header declares {riff_size} bytes but the file has "
            f"{size}; download or copy the file again",
        )
    pos = head.find(b"avih")
    # avih chunk: 4-byte id, 4-byte size, then MainAVIHeader; dwTotalFrames is its 5th DWORD.
    if pos < 0 or pos + 8 + 20 > len(head):
        raise DataFileError(path, "AVI file without a main header ('avih' chunk)")
    total = int(struct.unpack("<I", head[pos + 8 + 16 : pos + 8 + 20])[0])
    # OpenDML (AVI 2.0, files > 1 GB): avih counts only the first RIFF chunk; the
    # extended header 'dmlh' (first DWORD) holds the real total.
    dml = head.find(b"dmlh")
    if dml >= 0 and dml + 12 <= len(head):
        total = int(struct.unpack("<I", head[dml + 8 : dml + 12])[0])
    return total


def read_video(path: str | os.PathLike) -> np.ndarray:
    """Decode a whole video into memory.

    Parameters
    ----------
    path : str or path-like
        Video file (``.avi`` MJPG as written by GelSight tools, or anything ffmpeg
        decodes).

    Returns
    -------
    ndarray of shape (T, H, W, C), uint8
        All ``T`` frames, RGB (``C = 3``), intensities 0-255.

    Raises
    ------
    DataMissingError
        The file does not exist.
    DataFileError
        Empty, unreadable or corrupt file; a video without frames; for AVI files, a
        file shorter than its header declares or a decoded frame count that differs
        from the header's. The message names the file.
    """
    import imageio.v3 as iio  # noqa: PLC0415 - imageio is slow to import; only video readers need it

    path = Path(path)
    if not path.is_file():
        raise DataMissingError(path, "video file not found")
    if path.stat().st_size == 0:
        raise DataFileError(path, "empty file (0 bytes); expected a video")
    is_avi = path.suffix.lower() == ".avi"
    declared = avi_frame_count(path) if is_avi else None
    try:
        frames = iio.imread(path, plugin="FFMPEG")
    except Exception as exc:  # noqa: BLE001 - imageio/ffmpeg raise OSError, RuntimeError, StopIteration...
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DataFileError(path, f"cannot decode video ({type(exc).__name__}: {first})") from None
    frames = np.asarray(frames)
    if frames.ndim == 3:  # a single frame comes back without the time axis
        frames = frames[None]
    if frames.ndim != 4 or frames.shape[0] == 0:
        raise DataFileError(path, f"decoded no video frames (array of shape {frames.shape})")
    if frames.dtype != np.uint8:
        raise DataFileError(path, f"decoded frames have dtype {frames.dtype}; expected uint8")
    if declared is not None and frames.shape[0] != declared:
        raise DataFileError(
            path,
            f"decoded {frames.shape[0]} frames but the AVI header declares {declared}; "
            "the file is truncated or corrupt",
        )
    return frames
