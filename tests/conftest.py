"""Shared fixtures: where the real data lives, and small synthetic helpers."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
_DEFAULT_SHARED = REPO.parent / "shared" / "data"


def _shared_data_dir() -> Path | None:
    env = os.environ.get("TZSL_DATA_DIR")
    for candidate in (Path(env) if env else None, _DEFAULT_SHARED):
        if candidate is not None and (candidate / "phac2").is_dir():
            return candidate
    return None


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The real data folder (``../shared/data``).

    Missing data fails the test run with a clear message under CI and skips elsewhere.
    """
    found = _shared_data_dir()
    if found is None:
        msg = (
            "real data not found: expected ../shared/data beside the checkout "
            "(or TZSL_DATA_DIR pointing at a folder with phac2/, fabric/, gelsight_press/)"
        )
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return found


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch):
    """Keep joblib caches of tests out of the user's cache directory; the study cache is off (tests run
    a study again after changing what it does; tests/studies/test_study_cache.py turns it on). The
    platform's user cache folder is a temporary one too, for the tests that unset TZSL_CACHE_DIR."""
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "tzsl-cache"))
    monkeypatch.setenv("TZSL_STUDY_CACHE", "0")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.getbasetemp() / "user-cache"))
