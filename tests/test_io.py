"""tzsl/_io.py: atomic writes and file checksums (the refusal to overwrite without --force
lives in ResultsDir and is tested in tests/experiments/test_outputs.py)."""

from __future__ import annotations

import hashlib
import os

import pytest

from tzsl._io import atomic_write, file_sha256


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
