"""The cache folder (tzsl.cache, issue 33): where it is, `tzsl cache info` and `tzsl cache prune`, the size cap."""

from __future__ import annotations

import os
import time
from pathlib import Path

import platformdirs
import pytest
from click.testing import CliRunner

from tzsl.cache import (
    CACHE_DIR_ENV,
    DEFAULT_MAX_SIZE_GB,
    IN_USE_SECONDS,
    MAX_SIZE_ENV,
    STUDY_CACHE_ENV,
    cache_entries,
    cache_info,
    get_cache_dir,
    prune,
    size_cap_gb,
)
from tzsl.cli import cli
from tzsl.exceptions import ConfigError
from tzsl.fit_store import resolve_store
from tzsl.studies.outputs.study_cache import study_cache_folder

DAY = 86400.0


def _study(root: Path, name: str, size: int, age_days: float) -> Path:
    """A study-cache entry of ``size`` bytes last used ``age_days`` ago."""
    entry = root / "studies" / name
    (entry / "files").mkdir(parents=True)
    (entry / "run.joblib").write_bytes(b"r" * (size // 2))
    (entry / "files" / "t.csv").write_bytes(b"c" * (size - size // 2))
    stamp = time.time() - age_days * DAY
    os.utime(entry, (stamp, stamp))
    return entry


def _fit(root: Path, key: str, size: int, age_days: float) -> Path:
    """A fit-store entry of ``size`` bytes last used ``age_days`` ago."""
    path = root / "fits" / key[:2] / f"{key}.pkl"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"f" * size)
    stamp = time.time() - age_days * DAY
    os.utime(path, (stamp, stamp))
    return path


@pytest.fixture
def root(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv(CACHE_DIR_ENV, str(folder))
    monkeypatch.delenv(STUDY_CACHE_ENV)  # on, as for a user
    return folder


def _cli(*args: str):
    return CliRunner().invoke(cli, ["cache", *args])


def test_without_the_variable_every_cache_is_in_the_user_cache_folder(tmp_path, monkeypatch):
    monkeypatch.delenv(CACHE_DIR_ENV)
    monkeypatch.delenv(STUDY_CACHE_ENV)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    folder = (Path(platformdirs.user_cache_dir("tzsl")) / "joblib").resolve()
    assert folder.is_relative_to(tmp_path)
    assert get_cache_dir() == folder
    assert study_cache_folder() == folder / "studies"  # on by default
    assert resolve_store(str(get_cache_dir())).folder == folder / "fits"
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "moved"))
    assert study_cache_folder() == (tmp_path / "moved" / "studies").resolve()
    monkeypatch.setenv(STUDY_CACHE_ENV, "0")
    assert study_cache_folder() is None


def test_info_counts_sizes_entries_and_the_oldest_age(root):
    _study(root, "a" * 64, 3000, 2.0)
    _study(root, "b" * 64, 1000, 5.0)
    _fit(root, "ab12", 700, 1.0)
    _fit(root, "cd34", 300, 9.0)
    (root / "fits" / "ab" / ".ab99.pkl.x1.tmp").write_bytes(b"t" * 50)  # a fit being written: not an entry
    studies, fits = cache_info()
    assert (studies.n_entries, studies.size) == (2, 4000) and studies.oldest_age == pytest.approx(5 * DAY, abs=60)
    assert (fits.n_entries, fits.size) == (2, 1000) and fits.oldest_age == pytest.approx(9 * DAY, abs=60)
    result = _cli("info")
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0].startswith(f"cache folder: {root.resolve()}")
    assert lines[1].startswith(f"size cap: {DEFAULT_MAX_SIZE_GB:g} GB")
    assert lines[2].startswith("study cache: 4.0 kB in 2 entries; oldest last used 5.0 days ago")
    assert lines[3].startswith("fit store: 1.0 kB in 2 entries; oldest last used 9.0 days ago")


def test_info_of_an_empty_or_missing_folder(root, monkeypatch):
    result = _cli("info")
    assert result.exit_code == 0, result.output
    assert "study cache: 0 B in 0 entries (" in result.output and "fit store: 0 B in 0 entries (" in result.output
    monkeypatch.setenv(STUDY_CACHE_ENV, "0")
    assert "study cache (off: TZSL_STUDY_CACHE=0): 0 B in 0 entries (" in _cli("info").output


def test_prune_older_than_removes_the_old_entries_of_both_caches(root):
    old_study, new_study = _study(root, "old", 1000, 40.0), _study(root, "new", 1000, 1.0)
    old_fit, new_fit = _fit(root, "aa01", 500, 31.0), _fit(root, "aa02", 500, 29.0)
    result = _cli("prune", "--older-than", "30")
    assert result.exit_code == 0, result.output
    assert not old_study.exists() and not old_fit.exists() and new_study.exists() and new_fit.exists()
    assert "removed study cache entry old (1.0 kB, last used 40.0 days ago)" in result.output
    assert "removed 1 fit store entries, 500 B, last used 31.0 days to 31.0 days ago" in result.output
    assert "left: 1.5 kB in both caches" in result.output


def test_prune_max_size_removes_the_least_recently_used_first(root):
    entries = [_study(root, "s40", 1000, 40.0), _fit(root, "aa30", 1000, 30.0), _study(root, "s20", 1000, 20.0),
               _fit(root, "bb10", 1000, 10.0), _study(root, "s05", 1000, 5.0)]
    assert [e.path for e in cache_entries()] == [p.resolve() for p in entries]
    result = _cli("prune", "--max-size", "0.0000025")  # 2500 bytes: three entries must go, the oldest three
    assert result.exit_code == 0, result.output
    assert [p.exists() for p in entries] == [False, False, False, True, True]
    assert result.output.index("entry s40") < result.output.index("entry s20")
    assert "removed 1 fit store entries" in result.output and "left: 2.0 kB" in result.output


def test_prune_keeps_what_is_in_use_and_clears_left_over_temporary_names(root):
    recent = _study(root, "recent", 1000, 0.0)  # used now: a study may be restoring it
    leftover = _study(root, ".gone.123.tmp", 1000, 1.0)  # an interrupted write
    writing = _study(root, ".new.456.tmp", 1000, 0.0)  # a study storing its entry right now
    report = prune(max_size_gb=0.0)
    assert recent.exists() and writing.exists() and not leftover.exists()
    assert [e.path.name for e in report.removed] == [".gone.123.tmp"]
    assert [e.path.name for e in report.kept_in_use] == ["recent"]
    result = _cli("prune", "--max-size", "0")
    assert result.exit_code == 0 and "kept 1 entries over the limit: used in the last 10 min" in result.output
    later = time.time() + IN_USE_SECONDS + 1
    assert [e.path.name for e in prune(max_size_gb=0.0, now=later).removed] == [".new.456.tmp", "recent"]


def test_an_entry_used_after_the_scan_is_not_removed(root, monkeypatch):
    """A study restored between prune's scan and its removal keeps its entry (it marks it used first)."""
    entry = _study(root, "busy", 1000, 20.0)
    scanned = cache_entries()
    os.utime(entry)  # what run_cached does before it reads the entry
    import tzsl.cache as cache_module

    monkeypatch.setattr(cache_module, "cache_entries", lambda _root=None: scanned)
    assert prune(max_size_gb=0.0).removed == [] and entry.exists()


def test_a_fit_read_back_is_marked_used(root):
    store = resolve_store(None)
    path = _fit(root, "ee" + "0" * 62, 10, 20.0)
    path.write_bytes(__import__("pickle").dumps({"estimator": "fitted", "warnings": [], "seconds": 1.0}))
    os.utime(path, (time.time() - 20 * DAY,) * 2)
    assert store.load("ee" + "0" * 62) == "fitted"
    assert time.time() - path.stat().st_mtime < 60


@pytest.mark.parametrize("args, message", [
    (["--older-than", "-1"], "'-1': give a number of days >= 0"),
    (["--older-than", "soon"], "'soon': give a number of days >= 0"),
    (["--max-size", "nan"], "'nan': give a number of GB >= 0"),
    (["--max-size", "inf"], "'inf': give a number of GB >= 0"),
    (["--max-size", "-0.5"], "'-0.5': give a number of GB >= 0"),
])
def test_bad_values_are_one_line_usage_errors(root, args, message):
    _study(root, "kept", 1000, 100.0)
    result = _cli("prune", *args)
    assert result.exit_code == 2
    assert result.output.count("\n") == 1 and result.output.startswith("tzsl: error: ") and message in result.output
    assert (root / "studies" / "kept").exists()


@pytest.mark.parametrize("value", ["0", "-2", "lots", "nan"])
def test_a_bad_size_cap_variable_is_a_one_line_error(root, monkeypatch, value):
    monkeypatch.setenv(MAX_SIZE_ENV, value)
    with pytest.raises(ConfigError, match=f"^{MAX_SIZE_ENV}="):
        size_cap_gb()
    result = _cli("prune")
    assert result.exit_code == 3 and result.output.startswith(f"tzsl: error: {MAX_SIZE_ENV}=")


def test_prune_without_options_prunes_to_the_size_cap(root, monkeypatch):
    monkeypatch.setenv(MAX_SIZE_ENV, "0.0000015")  # 1500 bytes
    old, new = _study(root, "old", 1000, 3.0), _study(root, "new", 1000, 2.0)
    assert size_cap_gb() == 0.0000015
    result = _cli("prune")
    assert result.exit_code == 0, result.output
    assert not old.exists() and new.exists() and "(limit 1.5e-06 GB)" in result.output
