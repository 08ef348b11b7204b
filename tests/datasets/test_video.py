"""Video decoding (imageio + imageio-ffmpeg) and its error handling."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from tzsl.datasets import avi_frame_count, read_video
from tzsl.exceptions import DataFileError, DataMissingError


def write_avi(path, frames, fps=30):
    """Write an MJPG .avi (the GelSight format) with the ffmpeg shipped in imageio-ffmpeg."""
    import imageio.v3 as iio

    iio.imwrite(path, frames, plugin="FFMPEG", fps=fps, codec="mjpeg", quality=10, macro_block_size=16)
    return path


def _ramp(n=12, h=48, w=64):
    frames = np.zeros((n, h, w, 3), np.uint8)
    frames += (np.arange(n, dtype=np.uint8) * 15)[:, None, None, None]
    return frames


def test_round_trip_synthetic_mjpg(tmp_path):
    frames = _ramp()
    path = write_avi(tmp_path / "v.avi", frames)
    got = read_video(path)
    assert got.shape == frames.shape and got.dtype == np.uint8
    # MJPG is lossy; a flat frame survives within a few grey levels
    np.testing.assert_allclose(got.mean(axis=(1, 2, 3)), frames.mean(axis=(1, 2, 3)), atol=3)
    assert avi_frame_count(path) == 12


@pytest.mark.realdata
def test_reads_real_gelsight_mjpg(data_dir):
    path = data_dir / "gelsight_press" / "foam_brick_3.avi"
    video = read_video(path)
    assert video.shape == (55, 480, 640, 3) and video.dtype == np.uint8
    assert avi_frame_count(path) == 55
    assert 20 < video.mean() < 235  # real image content, not a blank decode


@pytest.mark.realdata
def test_truncated_real_file_is_an_error(data_dir, tmp_path):
    data = (data_dir / "gelsight_press" / "foam_brick_3.avi").read_bytes()
    bad = tmp_path / "half.avi"
    bad.write_bytes(data[: len(data) // 2])  # ffmpeg alone would silently decode 28 frames
    with pytest.raises(DataFileError, match=r"half\.avi.*truncated AVI"):
        read_video(bad)


def test_header_frame_count_mismatch(tmp_path):
    path = write_avi(tmp_path / "v.avi", _ramp())
    raw = bytearray(path.read_bytes())
    pos = raw.find(b"avih")
    raw[pos + 24 : pos + 28] = struct.pack("<I", 20)  # claim 20 frames
    path.write_bytes(bytes(raw))
    with pytest.raises(DataFileError, match=r"v\.avi.*decoded 12 frames but the AVI header declares 20"):
        read_video(path)


def test_empty_garbage_and_missing_files(tmp_path):
    empty = tmp_path / "empty.avi"
    empty.write_bytes(b"")
    with pytest.raises(DataFileError, match=r"empty\.avi.*empty file"):
        read_video(empty)
    junk = tmp_path / "junk.avi"
    junk.write_bytes(b"not a video " * 200)
    with pytest.raises(DataFileError, match=r"junk\.avi.*not a RIFF/AVI"):
        read_video(junk)
    junk_mp4 = tmp_path / "junk.mp4"
    junk_mp4.write_bytes(b"not a video " * 200)
    with pytest.raises(DataFileError, match=r"junk\.mp4.*cannot decode video"):
        read_video(junk_mp4)
    with pytest.raises(DataMissingError, match="nope.avi.*not found"):
        read_video(tmp_path / "nope.avi")


def test_avi_without_main_header(tmp_path):
    path = tmp_path / "bare.avi"
    path.write_bytes(b"RIFF" + struct.pack("<I", 20) + b"AVI " + b"\0" * 20)
    with pytest.raises(DataFileError, match="without a main header"):
        avi_frame_count(path)
