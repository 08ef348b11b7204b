"""Data home and cache directory resolution."""

from __future__ import annotations

from pathlib import Path

import platformdirs

from tzsl.datasets import get_cache_dir, get_data_home


def test_explicit_argument_wins_over_env(tmp_path, monkeypatch):
    monkeypatch.setenv("TZSL_DATA_DIR", str(tmp_path / "env"))
    assert get_data_home(tmp_path / "arg") == (tmp_path / "arg").resolve()


def test_env_used_without_argument(tmp_path, monkeypatch):
    monkeypatch.setenv("TZSL_DATA_DIR", str(tmp_path / "env"))
    assert get_data_home() == (tmp_path / "env").resolve()
    assert get_data_home(None) == (tmp_path / "env").resolve()


def test_user_cache_dir_is_last_resort(monkeypatch):
    monkeypatch.delenv("TZSL_DATA_DIR", raising=False)
    expected = (Path(platformdirs.user_cache_dir("tzsl")) / "data").resolve()
    assert get_data_home() == expected


def test_home_expands_user(monkeypatch, tmp_path):
    monkeypatch.setenv("HOME", str(tmp_path))
    assert get_data_home("~/d") == (tmp_path / "d").resolve()


def test_cache_dir_env_and_default(tmp_path, monkeypatch):
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "c"))
    assert get_cache_dir() == (tmp_path / "c").resolve()
    assert get_cache_dir(tmp_path / "x") == (tmp_path / "x").resolve()
    monkeypatch.delenv("TZSL_CACHE_DIR")
    assert get_cache_dir() == (Path(platformdirs.user_cache_dir("tzsl")) / "joblib").resolve()
