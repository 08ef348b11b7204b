"""tzsl/_io.py: atomic writes (replace in one step, no partial file, umask permissions, one-line failures),
file checksums, and .npz files checked before loading. The refusal to overwrite without --force lives in
ResultsDir and is tested in tests/studies/test_outputs.py."""

from __future__ import annotations

import hashlib
import io
import os
import stat
import zipfile

import numpy as np
import pytest

from tzsl._io import MAX_NPZ_BYTES_ENV, atomic_write, file_sha256, read_npy, read_npz
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


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_atomic_write_creates_file_and_folder_with_full_content(tmp_path):
    target = tmp_path / "new" / "sub" / "table.csv"
    seen = {}

    def write(tmp):
        seen["tmp"] = tmp
        assert tmp.parent == target.parent  # same folder: os.replace stays on one filesystem
        assert tmp != target
        tmp.write_text("a,b\n1,2\n")

    assert atomic_write(target, write) == target
    assert target.read_text() == "a,b\n1,2\n"
    assert not seen["tmp"].exists()
    assert _leftovers(target.parent) == []


def test_atomic_write_replaces_existing_file_in_one_step(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    inode_before = target.stat().st_ino

    def write(tmp):
        # until the writer returns, readers still see the complete old file
        assert target.read_text() == "old"
        tmp.write_text("new")

    atomic_write(target, write)
    assert target.read_text() == "new"
    assert target.stat().st_ino != inode_before  # replaced (renamed over), not rewritten in place


def test_atomic_write_failure_keeps_old_file_and_leaves_no_partial_file(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("complete old content")

    def write(tmp):
        tmp.write_text("half of the new")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        atomic_write(target, write)
    assert target.read_text() == "complete old content"
    assert _leftovers(tmp_path) == []
    assert sorted(os.listdir(tmp_path)) == ["out.txt"]


def test_atomic_write_failure_without_old_file_creates_nothing(tmp_path):
    target = tmp_path / "never.txt"

    def write(tmp):
        tmp.write_bytes(b"partial")
        raise ValueError("bad table")

    with pytest.raises(ValueError):
        atomic_write(target, write)
    assert not target.exists()
    assert os.listdir(tmp_path) == []


def test_atomic_write_when_writer_writes_nothing_leaves_an_empty_file(tmp_path):
    # mkstemp creates the temporary file, so a writer that writes nothing gives an empty file
    target = tmp_path / "empty.txt"
    atomic_write(target, lambda tmp: None)
    assert target.read_bytes() == b""


def test_file_sha256_matches_hashlib_and_reads_large_files_in_blocks(tmp_path):
    data = os.urandom(3 * (1 << 20) + 123)  # more than one 1 MiB block
    path = tmp_path / "blob.bin"
    path.write_bytes(data)
    assert file_sha256(path) == hashlib.sha256(data).hexdigest()
    assert file_sha256(str(path)) == hashlib.sha256(data).hexdigest()
    path.write_bytes(data[:-1] + bytes([data[-1] ^ 1]))  # one bit changed
    assert file_sha256(path) != hashlib.sha256(data).hexdigest()


def test_file_sha256_of_empty_file(tmp_path):
    path = tmp_path / "empty"
    path.write_bytes(b"")
    assert file_sha256(path) == hashlib.sha256(b"").hexdigest()


@pytest.mark.parametrize("at, xor", [(64, 91), (61, 8)])
def test_a_flipped_header_byte_is_one_line(tmp_path, at, xor):
    """A damaged .npy header makes numpy's header parser raise the tokenizer's errors (found by the lab-file
    property test: byte 64 xor 91 gave TokenError and a traceback); every one is a one-line DataFileError."""
    path = tmp_path / "t1.npy"
    np.save(path, np.arange(24.0).reshape(12, 2))  # byte 64 is in the shape: "(12,{2)" after the flip
    raw = path.read_bytes()
    path.write_bytes(raw[:at] + bytes([raw[at] ^ xor]) + raw[at + 1:])
    with pytest.raises(DataFileError, match=r"t1\.npy: ") as info:
        read_npy(path)
    assert "\n" not in str(info.value)
