"""tzsl/studies/sources.py: one FeatureSet from exactly one source."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import FeatureSet
from tzsl.exceptions import ConfigError
from tzsl.studies.sources import load_study_features


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
    with pytest.raises(ConfigError, match="either --features or --plain, not both"):
        load_study_features(features_file=tmp_path / "f.csv", plain_dir=tmp_path)


def test_no_source_is_refused():
    with pytest.raises(ConfigError, match="no data source"):
        load_study_features(dataset=None)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_feature_table_round_trip_wins_over_the_dataset(tmp_path, suffix):
    from tzsl.datasets._feature_table import write_feature_table  # what `tzsl extract --out` calls

    fs = _features()
    path = tmp_path / f"features{suffix}"
    write_feature_table(fs, path)
    back = load_study_features(dataset="no-such-dataset", features_file=str(path))
    np.testing.assert_allclose(back.X, fs.X)
    np.testing.assert_array_equal(back.objects, fs.objects)
    assert back.sensors == fs.sensors
    pd.testing.assert_frame_equal(back.attributes.astype(int), fs.attributes, check_names=False)


def test_missing_feature_table_names_the_file(tmp_path):
    from tzsl.exceptions import DataFileError

    with pytest.raises(DataFileError, match="missing.npz"):
        load_study_features(features_file=tmp_path / "missing.npz")


def test_built_in_dataset_goes_to_extract_features(monkeypatch, tmp_path):
    calls = []
    fs = _features()

    def fake_extract(dataset, data_dir=None, path=None):
        calls.append((dataset, data_dir, path))
        return fs

    import tzsl.studies.extract as extract

    monkeypatch.setattr(extract, "extract_features", fake_extract)
    got = load_study_features("phac2-h5", data_dir=tmp_path, path=tmp_path / "x.h5")
    assert got is fs
    assert calls == [("phac2-h5", tmp_path, tmp_path / "x.h5")]


def test_plain_dir_is_loaded_not_the_dataset(monkeypatch, tmp_path):
    import tzsl.features as features

    seen = []
    monkeypatch.setattr(features, "load_plain_dataset", lambda p: seen.append(p) or "plain")
    assert load_study_features("phac2-penn", plain_dir=str(tmp_path)) == "plain"
    assert seen == [tmp_path]
