"""One path from a dataset to features (tzsl.features.load_features) and the dataset contract (tzsl.datasets)."""

from __future__ import annotations

from typing import get_args, get_type_hints

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import FeatureSet, TactileDataset, dataset_names, get_dataset, register_dataset
from tzsl.exceptions import ConfigError
from tzsl.features import load_features


def _features() -> FeatureSet:
    rng = np.random.default_rng(0)
    names = np.repeat(["obj_a", "obj_b", "obj_c"], 2)
    trials = pd.DataFrame({
        "trial_id": [f"{o}_{i % 2}" for i, o in enumerate(names)],
        "object_id": np.repeat([1, 2, 3], 2),
        "object_name": names,
        "trial_index": np.tile([0, 1], 3),
    })
    attributes = pd.DataFrame({"hard": [1, 0, 1], "soft": [0, 1, 1]},
                              index=pd.Index(["obj_a", "obj_b", "obj_c"], name="object_name"))
    return FeatureSet(X=rng.normal(size=(6, 2, 3)), trials=trials, sensors=("left", "right"),
                      feature_names=("f0", "f1", "f2"), attributes=attributes, dataset="toy")


def test_features_and_plain_together_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="give one data source, not features_file and plain"):
        load_features(features_file=tmp_path / "f.csv", plain=tmp_path)


def test_no_source_is_refused():
    with pytest.raises(ConfigError, match="no data source"):
        load_features()


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_feature_table_round_trip(tmp_path, suffix):
    from tzsl.datasets._feature_table import write_feature_table  # what `tzsl extract --out` calls

    fs = _features()
    path = tmp_path / f"features{suffix}"
    write_feature_table(fs, path)
    back = load_features(features_file=str(path))
    np.testing.assert_allclose(back.X, fs.X)
    np.testing.assert_array_equal(back.objects, fs.objects)
    assert back.sensors == fs.sensors
    pd.testing.assert_frame_equal(back.attributes.astype(int), fs.attributes, check_names=False)


def test_missing_feature_table_names_the_file(tmp_path):
    from tzsl.exceptions import DataFileError

    with pytest.raises(DataFileError, match="missing.npz"):
        load_features(features_file=tmp_path / "missing.npz")


def test_built_in_dataset_goes_to_dataset_features(monkeypatch, tmp_path):
    calls = []
    fs = _features()

    def fake(name, data_dir=None, path=None, min_objects=None):
        calls.append((name, data_dir, path, min_objects))
        return fs

    import tzsl.features._dataset_features as module

    monkeypatch.setattr(module, "dataset_features", fake)
    got = load_features("phac2-h5", data_dir=tmp_path, path=tmp_path / "x.h5")
    assert got is fs
    assert calls == [("phac2-h5", tmp_path, tmp_path / "x.h5", module.DEFAULT_MIN_OBJECTS)]


def test_plain_dir_is_loaded_and_its_files_recorded(monkeypatch, tmp_path):
    import tzsl.features._dataset_features as module

    (tmp_path / "classes.csv").write_text("x")
    seen = []
    monkeypatch.setattr(module, "load_plain_dataset", lambda p, **kw: seen.append((p, kw)) or _features())
    got = load_features(plain=str(tmp_path), statistics=["mean"])
    assert seen == [(tmp_path, {"min_objects": None, "statistics": ["mean"]})]
    assert got.info["data_files"] == [str(tmp_path / "classes.csv")]


#: The kinds of content a dataset may declare: the values of TactileDataset.content's Literal.
CONTENT_KINDS = get_args(get_args(get_type_hints(TactileDataset)["content"])[0])


def test_the_dataset_registry_lists_the_builtin_datasets_once():
    assert set(dataset_names()) >= {"phac2-penn", "phac2-h5", "phac2-hold-mat"}
    assert "phac2-h5" not in dataset_names(convertible=True)  # read from the user's file, never written out
    for name in dataset_names():
        dataset = get_dataset(name)
        assert dataset.name == name and dataset.description and dataset.source and dataset.eps
        assert dataset.content in CONTENT_KINDS
    with pytest.raises(ConfigError, match=r"unknown dataset 'nope'; choose one of phac2-penn"):
        get_dataset("nope")
    with pytest.raises(ValueError, match="already registered"):
        register_dataset(get_dataset("phac2-penn"))


def test_a_dataset_that_needs_a_path_says_so_in_one_line():
    with pytest.raises(ConfigError, match="--dataset phac2-h5 needs --path"):
        get_dataset("phac2-h5").load()


def test_a_dataset_class_must_implement_load():
    class Incomplete(TactileDataset):
        name = "incomplete"

    with pytest.raises(TypeError):
        Incomplete()


def test_the_experiment_schema_reads_the_dataset_names_from_the_registry(tmp_path):
    from tzsl.studies.config import load_experiment

    toml = tmp_path / "x.toml"
    toml.write_text('study = "zero-shot"\n[dataset]\nbuiltin = "nope"\n')
    with pytest.raises(ConfigError, match=r"builtin = 'nope': expected one of phac2-penn"):
        load_experiment(toml)
    toml.write_text('study = "zero-shot"\n[dataset]\nbuiltin = "phac2-h5"\n')
    with pytest.raises(ConfigError, match="needs path"):
        load_experiment(toml)


def test_tzsl_datasets_lists_them(tmp_path):
    import json

    from click.testing import CliRunner

    from tzsl.cli import cli

    result = CliRunner().invoke(cli, ["datasets", "--json"])
    assert result.exit_code == 0, result.output
    assert [r["name"] for r in json.loads(result.output)] == list(dataset_names())
    bad = CliRunner().invoke(cli, ["extract", "--dataset", "nope"])
    assert bad.exit_code == 2 and "'nope': expected one of phac2-penn" in bad.output
