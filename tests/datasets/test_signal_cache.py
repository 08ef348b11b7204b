"""Every signal file of a plain dataset at once: parallel reads and the consolidated cache (issue 22, item 4)."""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import _signal_cache, read_plain_dataset, read_signal_table, write_plain_dataset
from tzsl.exceptions import DataFileError
from tzsl.features import load_plain_dataset

CLASSES = pd.DataFrame({"hard": [1, 0, 1], "soft": [0, 1, 0], "round": [0, 1, 1]},
                       index=pd.Index(["cube", "ball", "disc"], name="class"))


@pytest.fixture
def dataset(tmp_path):
    """12 trials x 2 sensors of random length (4..30 rows) and 3 channels; returns (folder, signals)."""
    rng = np.random.default_rng(3)
    names = np.array(CLASSES.index)[np.arange(12) % 3]
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(12)], "class": names})
    signals = [[rng.standard_normal((int(rng.integers(4, 31)), 3)) for _ in range(2)] for _ in range(12)]
    folder = write_plain_dataset(tmp_path / "ds", CLASSES, trials, sensors=("s0", "s1"), signals=signals,
                                 channels=("p", "q", "r"))
    return folder, signals


def _entry_files(cache):
    return sorted(p.name for p in cache.rglob("*") if p.is_file())


def _assert_table_holds(table, signals):
    for s in range(2):
        got = table.signals(s, 0, 12)
        assert len(got) == 12
        for i in range(12):
            np.testing.assert_array_equal(got[i], signals[i][s])


def test_miss_then_hit_give_identical_arrays(dataset, tmp_path):
    folder, signals = dataset
    cache = tmp_path / "cache"
    data = read_plain_dataset(folder)
    fresh = read_signal_table(data, cache=cache)
    assert not fresh.from_cache
    assert _entry_files(cache)[0] == "index.npz" and len(_entry_files(cache)) == 2
    hit = read_signal_table(read_plain_dataset(folder), cache=cache)
    assert hit.from_cache
    np.testing.assert_array_equal(hit.offsets, fresh.offsets)
    np.testing.assert_array_equal(np.asarray(hit.values), fresh.values)
    _assert_table_holds(hit, signals)
    _assert_table_holds(read_signal_table(data, cache=False), signals)  # no cache: read afresh, same arrays
    # the features from the cache are those of a fresh read, bit for bit
    X_cached = load_plain_dataset(folder, cache=cache).X
    X_fresh = load_plain_dataset(folder, cache=False).X
    np.testing.assert_array_equal(X_cached, X_fresh)


def test_a_changed_file_invalidates_the_entry(dataset, tmp_path):
    folder, signals = dataset
    cache = tmp_path / "cache"
    read_signal_table(read_plain_dataset(folder), cache=cache)
    rel = read_plain_dataset(folder).signal_files[5, 1]
    new = signals[5][1] + 100.0
    np.savez_compressed(folder / rel, p=new[:, 0], q=new[:, 1], r=new[:, 2])  # same size, new content
    again = read_signal_table(read_plain_dataset(folder), cache=cache)
    assert not again.from_cache
    np.testing.assert_array_equal(again.signals(1, 5, 6)[0], new)
    assert len(_entry_files(cache)) == 2  # the stale values file is gone
    assert read_signal_table(read_plain_dataset(folder), cache=cache).from_cache
    # touching a file (same bytes, new modification time) is a change too
    st = os.stat(folder / rel)
    os.utime(folder / rel, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert not read_signal_table(read_plain_dataset(folder), cache=cache).from_cache
    # other channels are another table (in that order)
    two = replace(read_plain_dataset(folder), channels=("r", "p"))
    assert not read_signal_table(two, cache=cache).from_cache
    hit = read_signal_table(two, cache=cache)
    assert hit.from_cache
    np.testing.assert_array_equal(hit.signals(0, 2, 3)[0], signals[2][0][:, [2, 0]])


def test_environment_variable_and_switches(dataset, tmp_path, monkeypatch):
    folder, _ = dataset
    data = read_plain_dataset(folder)
    monkeypatch.delenv("TZSL_CACHE_DIR", raising=False)
    read_signal_table(data)  # None without $TZSL_CACHE_DIR: no cache written anywhere
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "env"))
    assert not read_signal_table(data).from_cache
    assert read_signal_table(data).from_cache and read_signal_table(data, cache=True).from_cache
    assert not read_signal_table(data, cache=False).from_cache


def test_a_larger_min_rows_is_checked_on_a_hit(dataset, tmp_path):
    folder, signals = dataset
    cache = tmp_path / "cache"
    data = read_plain_dataset(folder)
    read_signal_table(data, cache=cache)
    need = max(len(signals[i][0]) for i in range(12))
    short = next(i for i in range(12) if len(signals[i][0]) < need)
    with pytest.raises(DataFileError) as cached:
        read_signal_table(data, need, cache=cache)
    with pytest.raises(DataFileError) as fresh:
        read_signal_table(data, need, cache=False)
    assert str(cached.value) == str(fresh.value)
    assert f"trial t{short}" in str(cached.value) and f"at least {need} needed" in str(cached.value)


def test_parallel_reads_equal_one_process_and_name_a_bad_file(dataset, tmp_path, monkeypatch):
    folder, signals = dataset
    monkeypatch.setattr(_signal_cache, "PARALLEL_MIN_FILES", 2)
    data = read_plain_dataset(folder)
    _assert_table_holds(read_signal_table(data, n_jobs=2, cache=False), signals)
    rel = data.signal_files[7, 0]
    bad = signals[7][0].copy()
    bad[1, 2] = np.inf
    np.savez_compressed(folder / rel, p=bad[:, 0], q=bad[:, 1], r=bad[:, 2])
    with pytest.raises(DataFileError, match=r"trial t7: .*channel 'r' is infinite at row 1"):
        read_signal_table(data, n_jobs=2, cache=tmp_path / "cache")
    assert not (tmp_path / "cache").exists()  # nothing cached from a failed read


def test_a_cache_that_cannot_be_written_warns_and_reads(dataset, tmp_path):
    folder, signals = dataset
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    with pytest.warns(RuntimeWarning, match="signal cache not written"):
        table = read_signal_table(read_plain_dataset(folder), cache=blocked)
    _assert_table_holds(table, signals)
