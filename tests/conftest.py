"""Shared fixtures: where the real data lives, and small synthetic helpers; the order test files are handed out."""

from __future__ import annotations

import os
from collections import Counter
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


@pytest.fixture(scope="session")
def run_folder(tmp_path_factory) -> Path:
    """The temporary folder every xdist worker of this test run shares (the base temp folder without xdist)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session")
def shared_cache(run_folder) -> Path:
    """The cache folder of this test run, shared by its xdist workers: a fit or a feature table one worker
    computed (the fit store and the feature caches key on content and write atomically) is read by the other."""
    return run_folder / "tzsl-cache"


@pytest.fixture(autouse=True)
def _isolated_cache(shared_cache, tmp_path_factory, monkeypatch):
    """Keep joblib caches of tests out of the user's cache directory (in the run's shared cache folder, so a
    test asserting a cold cache makes its own); the study cache is off (tests run a study again after changing
    what it does; tests/studies/test_study_cache.py turns it on). The platform's user cache folder is a
    temporary one too, for the tests that unset TZSL_CACHE_DIR."""
    monkeypatch.setenv("TZSL_CACHE_DIR", str(shared_cache))
    monkeypatch.setenv("TZSL_STUDY_CACHE", "0")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.getbasetemp() / "user-cache"))


def pytest_collection_modifyitems(config, items):
    """Hand out the longest test files first, so that no xdist worker is left alone at the end of a run.

    ``make test`` runs ``--dist loadfile --no-loadscope-reorder``: a worker takes whole files in the order
    collected here. A file marked ``schedule_first(seconds)`` (a docs build, a wheel install: minutes of one
    process; ``seconds`` is its rough cost on one worker, an ordering hint) comes first, longest first; the
    others follow by their number of tests, largest first, as pytest-xdist orders them by default. Started last,
    the docs build (about 150 s) kept one worker busy while the other had nothing left to run.
    """
    per_file = Counter(item.path for item in items)

    def rank(item) -> tuple[int, float]:
        first = item.get_closest_marker("schedule_first")
        if first is not None:
            return 0, -float(first.args[0])
        return 1, -per_file[item.path]

    items.sort(key=rank)  # stable: a file's tests stay together and in their order
