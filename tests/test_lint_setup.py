"""The lint and lock set-up agree with each other (issue 41): pyproject's lint extra, .pre-commit-config.yaml,
the lock files and the Makefile."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest

from tzsl.studies.outputs.environment import CORE_LOCK, environment_record, installed_distributions, locked_versions
from tzsl.studies.outputs.results_folder import ResultsDir

REPO = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())
DEV_LOCK = REPO / "requirements" / "dev.lock.txt"


def exact_pins(requirements: list[str]) -> dict[str, str]:
    pins = {}
    for req in requirements:
        found = re.match(r"^([A-Za-z0-9._-]+)==([^\s;]+)$", req)
        if found:
            pins[found.group(1).lower()] = found.group(2)
    return pins


def test_pre_commit_runs_the_lint_extras_pinned_ruff_and_the_projects_mypy():
    config = (REPO / ".pre-commit-config.yaml").read_text()
    lint = exact_pins(PYPROJECT["project"]["optional-dependencies"]["lint"])
    assert set(lint) >= {"ruff", "mypy"}
    assert f'"ruff=={lint["ruff"]}"' in config
    assert "entry: .venv/bin/mypy" in config  # the mypy of the locked environment
    assert locked_versions(DEV_LOCK)["ruff"] == lint["ruff"]
    assert locked_versions(DEV_LOCK)["mypy"] == lint["mypy"]


def test_make_test_runs_lint_first_and_lint_runs_both_tools():
    makefile = (REPO / "Makefile").read_text()
    assert re.search(r"^test: .*\blint\b", makefile, re.M)
    lint = re.search(r"^lint:.*\n((?:\t.*\n)+)", makefile, re.M).group(1)
    assert "ruff check" in lint and "mypy" in lint
    assert (REPO / ".ci" / "run").read_text().strip().endswith("make test")


def test_the_locks_hold_every_declared_dependency_at_one_version():
    core = locked_versions(REPO / CORE_LOCK)
    dev = locked_versions(DEV_LOCK)
    declared = [re.split(r"[<>=!~\[ ;]", req)[0].lower() for req in PYPROJECT["project"]["dependencies"]]
    assert not [name for name in declared if name.replace("_", "-") not in core]
    assert {name: (v, dev.get(name)) for name, v in core.items() if dev.get(name) != v} == {}
    extras = PYPROJECT["project"]["optional-dependencies"]
    for extra in ("test", "dask", "docs", "lint"):
        for req in extras[extra]:
            name = re.split(r"[<>=!~\[ ;]", req)[0].lower()
            if name != "tzsl":
                assert name in dev, f"{name} (extra {extra}) is not in {DEV_LOCK.name}"


def test_the_environment_record_names_each_package_that_differs_from_the_lock(tmp_path):
    installed = installed_distributions()
    (tmp_path / "requirements").mkdir()
    lock = tmp_path / CORE_LOCK
    lock.write_text(f"numpy=={installed['numpy']}    # via tzsl\nscipy==0.0.1\nnot-a-package==1.0\n")
    record = environment_record(tmp_path)
    assert record["lock_file"] == "requirements/core.lock.txt" and len(record["lock_sha256"]) == 64
    assert record["matches_lock"] is False
    assert record["differs"] == {"scipy": {"locked": "0.0.1", "installed": installed["scipy"]},
                                 "not-a-package": {"locked": "1.0", "installed": None}}
    lock.write_text(f"numpy=={installed['numpy']}\n")
    assert environment_record(tmp_path)["matches_lock"] is True
    assert environment_record(tmp_path / "no_checkout")["lock_file"] is None  # an installed wheel ships no lock


@pytest.mark.skipif(not (REPO / CORE_LOCK).is_file(), reason="no lock in this checkout")
def test_a_manifest_records_the_environment_against_the_lock(tmp_path):
    results = ResultsDir(tmp_path / "out")
    manifest = results.write_manifest({"study": "x"})
    record = json.loads(Path(manifest).read_text())["environment"]
    assert record["lock_file"] == "requirements/core.lock.txt"
    assert record["installed"]["numpy"] == installed_distributions()["numpy"]
    assert isinstance(record["matches_lock"], bool)


def test_make_test_keeps_a_files_tests_on_one_worker_and_no_test_relies_on_xdist_groups():
    """The locked pytest (9.2) names a test by a structured id that pytest-xdist 3.8 cannot suffix, so
    ``--dist loadgroup`` silently spread ``xdist_group`` tests over the workers and the docs were built twice
    (one worker waiting minutes for the other's lock). ``make test`` schedules by file instead."""
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    test_recipe = makefile.split("\ntest: ", 1)[1].split("\n\n", 1)[0]
    assert "--dist loadfile" in test_recipe
    marked = [p.relative_to(REPO) for p in (REPO / "tests").rglob("*.py")
              if "mark.xdist_" + "group" in p.read_text(encoding="utf-8")]
    assert marked == [], f"xdist groups are ignored by the locked pytest: {marked}"
