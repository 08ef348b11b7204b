"""tzsl/_io.py: atomic writes respect the umask, fail in one line, and .npz files are checked before loading."""

from __future__ import annotations

import io
import os
import stat
import zipfile

import numpy as np
import pytest

from tzsl._io import MAX_NPZ_BYTES_ENV, atomic_write, read_npz
from tzsl.exceptions import ConfigError, DataFileError


def _write_text(path):
    return atomic_write(path, lambda tmp: tmp.write_text("x"))


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_atomic_write_respects_the_umask(tmp_path, mask, mode):
    old = os.umask(mask)
    try:
        path = _write_text(tmp_path / "out.txt")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == mode


def test_atomic_write_under_a_file_is_one_line(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(ConfigError, match=r"afile/sub: cannot create the output folder: a parent is a file") as info:
        _write_text(tmp_path / "afile" / "sub" / "out.txt")
    assert "\n" not in str(info.value)


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores folder permissions")
def test_atomic_write_in_read_only_folder_is_one_line(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(ConfigError, match="permission denied"):
            _write_text(folder / "out.txt")
    finally:
        folder.chmod(0o700)


def _npz(path, **arrays):
    np.savez(path, **arrays)
    return path


def test_read_npz_round_trip(tmp_path):
    got = read_npz(_npz(tmp_path / "a.npz", x=np.arange(5.0), t=np.array(["a", "b"])))
    assert list(got) == ["x", "t"] and got["x"].tolist() == [0, 1, 2, 3, 4] and got["t"].tolist() == ["a", "b"]


def test_truncated_npz_is_one_line(tmp_path):
    path = _npz(tmp_path / "a.npz", x=np.arange(1000.0))
    path.write_bytes(path.read_bytes()[:500])
    with pytest.raises(DataFileError, match=r"a\.npz: not a readable \.npz archive") as info:
        read_npz(path)
    assert "\n" not in str(info.value)


def _lying_npz(path, shape):
    """A valid zip whose .npy header declares ``shape`` float64 but holds 8 bytes of data."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("X.npy", buf.getvalue() + b"\0" * 8)
    return path


def test_huge_declared_shape_is_refused_before_loading(tmp_path):
    path = _lying_npz(tmp_path / "huge.npz", (10**6, 10**6))
    with pytest.raises(DataFileError, match=rf"huge\.npz: arrays declare .* more than the limit .*{MAX_NPZ_BYTES_ENV}"):
        read_npz(path)


def test_limit_can_be_raised_and_lying_size_is_caught(tmp_path, monkeypatch):
    path = _lying_npz(tmp_path / "lie.npz", (1000,))
    monkeypatch.setenv(MAX_NPZ_BYTES_ENV, "100")
    with pytest.raises(DataFileError, match="more than the limit of 100"):
        read_npz(path)
    monkeypatch.setenv(MAX_NPZ_BYTES_ENV, "1e9")
    with pytest.raises(DataFileError, match="declares shape \\(1000,\\) of float64 \\(8,000 bytes\\) but holds 8"):
        read_npz(path)
    monkeypatch.setenv(MAX_NPZ_BYTES_ENV, "lots")
    with pytest.raises(ConfigError, match="not a number of bytes"):
        read_npz(path)


def test_object_arrays_are_refused(tmp_path):
    path = tmp_path / "obj.npz"
    np.savez(path, x=np.array([{"a": 1}], dtype=object))
    with pytest.raises(DataFileError, match="holds Python objects"):
        read_npz(path)
