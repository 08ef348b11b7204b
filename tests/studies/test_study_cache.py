"""The study cache (issue 22): a study run again unchanged is restored, byte for byte; any change recomputes it."""

from __future__ import annotations

import json
import os
import sys
import time
import types
import warnings
from pathlib import Path
from typing import Literal

import pandas as pd
import platformdirs
import pytest
from pydantic import Field

from tzsl.cache import MAX_SIZE_ENV, STUDY_CACHE_ENV
from tzsl.exceptions import ConfigError
from tzsl.studies.config import Compute, Output, load_experiment, register_study, unregister_study
from tzsl.studies.config._common import Section
from tzsl.studies.engine import run_experiment
from tzsl.studies.outputs.study_cache import study_cache_folder, study_key
from tzsl.studies.outputs.study_run import StudyRun

sys.path.insert(0, str(Path(__file__).parent))
from test_reproduce import TINY_HAND

PLUGIN = "cache-test"
#: How many times the plug-in's runner really ran (a restored study does not run it).
CALLS: list[int] = []


class PluginWarning(UserWarning):
    """A warning category of the plug-in's own (the command line groups warnings by category)."""


class CacheCompute(Compute):
    cache: bool = True


class CacheData(Section):
    plain: str | None = None


class CacheStudy(Section):
    """A plug-in study that reads the files of ``dataset.plain`` and writes one table of ``n`` rows."""

    study: Literal["cache-test"] = PLUGIN
    description: str = ""
    n: int = Field(3, ge=1)
    fail: str = ""  # the error text of the table's first row (a failed fit)
    dataset: CacheData = Field(default_factory=CacheData)
    compute: CacheCompute = Field(default_factory=CacheCompute)
    output: Output = Field(default_factory=Output)


def run_plugin(exp, results, say) -> StudyRun:
    CALLS.append(1)
    folder = Path(exp.config.dataset.plain)
    total = sum(float(p.read_text()) for p in sorted(folder.glob("*.txt")))
    table = pd.DataFrame({"row": range(exp.config.n), "value": total / 3.0})
    if exp.config.fail:
        table["error"] = [exp.config.fail] + [""] * (exp.config.n - 1)
    results.write_csv("plugin.csv", table)
    say(f"plugin: {exp.config.n} rows")
    warnings.warn("the plug-in always warns", UserWarning, stacklevel=1)
    for _ in range(2):  # a category of its own, twice: a restored run raises it again, as often
        warnings.warn("the plug-in's own kind", PluginWarning, stacklevel=1)
    return StudyRun({"plugin": table}, {"study_kind": PLUGIN}, data_files=sorted(folder.glob("*.txt")))


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv(STUDY_CACHE_ENV, "1")
    register_study(PLUGIN, schema=CacheStudy, runner=f"{__name__}:run_plugin", main_table="plugin",
                   description="a test plug-in")
    data = tmp_path / "data"
    data.mkdir()
    (data / "a.txt").write_text("1.5")
    CALLS.clear()
    yield tmp_path, data
    unregister_study(PLUGIN)


def _toml(tmp_path: Path, data: Path, body: str = "n = 4") -> Path:
    path = tmp_path / "plugin.toml"
    path.write_text(f'study = "{PLUGIN}"\n{body}\n[dataset]\nplain = "{data}"\n')
    return path


def _run(toml: Path, out: Path) -> tuple[Path, dict, list[str]]:
    lines: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        results, _ = run_experiment(toml, out=out, echo=lines.append)
    assert [(str(w.message).split(" (")[0], w.category) for w in caught] == [
        ("the plug-in always warns", UserWarning), ("the plug-in's own kind", PluginWarning),
        ("the plug-in's own kind", PluginWarning)]
    return results.root, json.loads((results.root / "manifest.json").read_text()), lines


def test_a_study_run_again_is_restored_byte_for_byte(plugin):
    tmp_path, data = plugin
    toml = _toml(tmp_path, data)
    first, manifest1, lines1 = _run(toml, tmp_path / "one")
    second, manifest2, lines2 = _run(toml, tmp_path / "two")
    assert len(CALLS) == 1
    assert (first / "plugin.csv").read_bytes() == (second / "plugin.csv").read_bytes()
    assert manifest1["config"]["study_cache"]["restored"] is False
    assert manifest2["config"]["study_cache"]["restored"] is True
    assert manifest2["config"]["study_cache"]["key"] == manifest1["config"]["study_cache"]["key"]
    assert manifest2["warnings"] == manifest1["warnings"] == [
        "the plug-in always warns", "the plug-in's own kind (PluginWarning) (x2)"]
    assert manifest2["data_files"] == manifest1["data_files"]
    assert manifest2["outputs"]["plugin.csv"] == manifest1["outputs"]["plugin.csv"]
    assert lines2[1].startswith("note: restored from the study cache") and lines2[2:] == lines1[1:]
    assert not any(line.startswith("note:") for line in lines1)


def test_a_changed_setting_or_data_file_is_computed_again(plugin):
    tmp_path, data = plugin
    toml = _toml(tmp_path, data)
    _run(toml, tmp_path / "one")
    _run(_toml(tmp_path, data, "n = 5"), tmp_path / "two")
    assert len(CALLS) == 2
    (data / "a.txt").write_text("2.5")  # same size, new content and time
    third, _, _ = _run(_toml(tmp_path, data), tmp_path / "three")
    assert len(CALLS) == 3 and pd.read_csv(third / "plugin.csv")["value"].iloc[0] == pytest.approx(2.5 / 3)
    (data / "b.txt").write_text("1")  # a new file in the dataset folder
    _run(_toml(tmp_path, data), tmp_path / "four")
    assert len(CALLS) == 4


@pytest.mark.parametrize("switch", ["env", "setting"])
def test_the_study_cache_can_be_turned_off(plugin, monkeypatch, switch):
    tmp_path, data = plugin
    body = "n = 4"
    if switch == "env":
        monkeypatch.setenv(STUDY_CACHE_ENV, "0")
    else:
        body += "\n[compute]\ncache = false"
    toml = _toml(tmp_path, data, body)
    _run(toml, tmp_path / "one")
    _run(toml, tmp_path / "two")
    assert len(CALLS) == 2
    folder = study_cache_folder()
    assert folder is None or not folder.exists() or not any(folder.iterdir())


def test_the_study_cache_is_on_by_default_in_the_user_cache_folder(plugin, monkeypatch):
    """No variable set: the second run is restored from platformdirs' user cache folder; a changed data file or
    setting is computed again (never a stale result)."""
    tmp_path, data = plugin
    monkeypatch.delenv("TZSL_CACHE_DIR")
    monkeypatch.delenv(STUDY_CACHE_ENV)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    expected = (Path(platformdirs.user_cache_dir("tzsl")) / "joblib" / "studies").resolve()
    assert expected.is_relative_to(tmp_path) and study_cache_folder() == expected
    toml = _toml(tmp_path, data)
    _, manifest1, _ = _run(toml, tmp_path / "one")
    _, manifest2, lines = _run(toml, tmp_path / "two")
    assert len(CALLS) == 1 and manifest2["config"]["study_cache"]["restored"] is True
    assert [p.name for p in expected.iterdir()] == [manifest1["config"]["study_cache"]["key"]]
    assert sum(line.startswith("note: restored from the study cache") for line in lines) == 1
    (data / "a.txt").write_text("4.5")  # same size, new content
    os.utime(data / "a.txt", ns=(1_000_000_000, 1_000_000_000))  # and an old time: the mtime still differs
    third, manifest3, _ = _run(toml, tmp_path / "three")
    assert len(CALLS) == 2 and manifest3["config"]["study_cache"]["restored"] is False
    assert pd.read_csv(third / "plugin.csv")["value"].iloc[0] == pytest.approx(4.5 / 3)
    _, manifest4, _ = _run(_toml(tmp_path, data, "n = 6"), tmp_path / "four")
    assert len(CALLS) == 3 and manifest4["config"]["study_cache"]["restored"] is False


def test_a_changed_plug_in_source_is_computed_again(plugin, monkeypatch):
    """The runner of a plug-in study lives outside tzsl: its source file is part of the key."""
    tmp_path, data = plugin
    module = tmp_path / "cache_plugin_runner.py"
    module.write_text("from test_study_cache import run_plugin  # v1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    unregister_study(PLUGIN)
    register_study(PLUGIN, schema=CacheStudy, runner="cache_plugin_runner:run_plugin", main_table="plugin",
                   description="a test plug-in")
    exp = load_experiment(_toml(tmp_path, data))
    before = study_key(exp)
    assert before is not None and study_key(exp) == before
    module.write_text("from test_study_cache import run_plugin  # v2\n")
    assert study_key(exp) != before


def test_a_plug_in_without_a_source_file_is_not_cached(plugin, monkeypatch):
    """Code defined in a notebook has no file to key on: the study is computed each time, and says why."""
    tmp_path, data = plugin
    notebook = types.ModuleType("notebook_plugin")  # no __file__, like a notebook's __main__
    notebook.run_plugin = run_plugin
    monkeypatch.setitem(sys.modules, "notebook_plugin", notebook)
    unregister_study(PLUGIN)
    register_study(PLUGIN, schema=CacheStudy, runner="notebook_plugin:run_plugin", main_table="plugin",
                   description="a test plug-in")
    toml = _toml(tmp_path, data)
    _, _, lines = _run(toml, tmp_path / "one")
    _, manifest, _ = _run(toml, tmp_path / "two")
    assert len(CALLS) == 2 and "study_cache" not in manifest["config"]
    assert "note: not kept in the study cache: the plug-in module notebook_plugin has no source file" in lines[1]
    assert not (tmp_path / "cache" / "studies").exists()


def test_the_size_cap_evicts_the_least_recently_used_entries_of_both_caches(plugin, monkeypatch):
    tmp_path, data = plugin
    root = tmp_path / "cache"
    old_study, old_fit = root / "studies" / "old-entry", root / "fits" / "ab" / "abc.pkl"
    old_study.mkdir(parents=True)
    (old_study / "run.joblib").write_bytes(b"x" * 3000)
    old_fit.parent.mkdir(parents=True)
    old_fit.write_bytes(b"y" * 2000)
    day = 86400
    os.utime(old_study, (time.time() - 30 * day,) * 2)
    os.utime(old_fit, (time.time() - 20 * day,) * 2)
    monkeypatch.setenv(MAX_SIZE_ENV, "0.000001")  # 1000 bytes: both old entries go; the new one is in use
    lines: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run_experiment(_toml(tmp_path, data), out=tmp_path / "one", echo=lines.append)
    assert not old_study.exists() and not old_fit.exists()
    assert len(list((root / "studies").iterdir())) == 1  # the new entry, just written, stays
    assert any(line.startswith("note: the study cache and fit store were over their size cap") for line in lines)


def test_a_bad_size_cap_fails_before_the_study_runs(plugin, monkeypatch):
    tmp_path, data = plugin
    monkeypatch.setenv(MAX_SIZE_ENV, "-3")
    with pytest.raises(ConfigError, match=f"{MAX_SIZE_ENV}=-3"):
        run_experiment(_toml(tmp_path, data), out=tmp_path / "one")
    assert CALLS == []


@pytest.mark.parametrize(("error", "stored"), [
    ("ValueError: injected", False),  # may be the machine's (a killed worker): tried again
    ("eszsl: ZSLInputError: injected; dap-avg-auto: ZSLInputError: injected too", True),  # refusals: the same again
    ("eszsl: ZSLInputError: injected; sae: LinAlgError: injected", False),
])
def test_a_run_with_failed_fits_is_stored_only_if_every_failure_is_a_refusal(plugin, error, stored):
    tmp_path, data = plugin
    toml = _toml(tmp_path, data, f'n = 4\nfail = "{error}"')
    for out in ("one", "two"):
        with pytest.raises(Exception, match="injected"):  # a restored run fails alike, naming the same fits
            _run(toml, tmp_path / out)
    assert len(CALLS) == (1 if stored else 2)


@pytest.mark.slow
def test_a_real_study_is_restored_with_every_file(tmp_path, monkeypatch):
    """The hand study writes its own manifest and figures through the results folder: all come back."""
    monkeypatch.setenv("TZSL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv(STUDY_CACHE_ENV, "1")
    toml = tmp_path / "hand.toml"
    toml.write_text(TINY_HAND)
    first, _ = run_experiment(toml, out=tmp_path / "one", n_jobs=1)
    second, done = run_experiment(toml, out=tmp_path / "two", n_jobs=1)
    assert done.record["study_cache"]["restored"] is True
    names = sorted(p.name for p in first.root.iterdir())
    assert names == sorted(p.name for p in second.root.iterdir()) and len(names) > 5
    for name in names:
        if name != "manifest.json":
            assert (first.root / name).read_bytes() == (second.root / name).read_bytes(), name


def test_a_broken_entry_is_computed_again_with_one_warning(plugin):
    tmp_path, data = plugin
    toml = _toml(tmp_path, data)
    _run(toml, tmp_path / "one")
    entry = next(study_cache_folder().iterdir())
    (entry / "files" / "plugin.csv").unlink()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        results, done = run_experiment(toml, out=tmp_path / "two")
    messages = [str(w.message) for w in caught]
    assert any("study cache entry unreadable" in m and "plugin.csv is missing" in m for m in messages)
    assert len(CALLS) == 2 and done.record["study_cache"]["restored"] is False
    assert (results.root / "plugin.csv").is_file()
