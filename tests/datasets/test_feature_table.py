import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import FeatureSet
from tzsl.datasets._feature_table import read_feature_table, write_feature_table
from tzsl.exceptions import DataFileError


def _features() -> FeatureSet:
    rng = np.random.default_rng(0)
    trials = pd.DataFrame({
        "trial_id": ["a_001_01", "a_001_02", "b_002_01"],
        "object_id": [1, 1, 2],
        "object_name": ["a_001", "a_001", "b_002"],
        "trial_index": [1, 2, 1],
    })
    attrs = pd.DataFrame({"hard": [1, 0], "soft": [0, 1]}, index=pd.Index(["a_001", "b_002"], name="object_name"))
    return FeatureSet(X=rng.normal(size=(3, 2, 4)), trials=trials, sensors=("finger_0", "finger_1"),
                      feature_names=("f0", "f1", "f2", "f3"), attributes=attrs, dataset="toy")


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_round_trip(tmp_path, suffix):
    fs = _features()
    written = write_feature_table(fs, tmp_path / f"feat{suffix}")
    assert all(p.exists() for p in written)
    back = read_feature_table(tmp_path / f"feat{suffix}")
    np.testing.assert_allclose(back.X, fs.X)
    assert back.sensors == fs.sensors and back.feature_names == fs.feature_names
    assert back.trials["trial_id"].tolist() == fs.trials["trial_id"].tolist()
    assert back.attributes.loc["b_002", "soft"] == 1


def test_nan_is_reported_with_trial(tmp_path):
    fs = _features()
    fs.X[1, 0, 2] = np.nan
    write_feature_table(fs, tmp_path / "feat.npz")
    with pytest.raises(DataFileError, match="a_001_02"):
        read_feature_table(tmp_path / "feat.npz")


def test_csv_missing_sensor_row(tmp_path):
    write_feature_table(_features(), tmp_path / "feat.csv")
    frame = pd.read_csv(tmp_path / "feat.csv").iloc[:-1]
    frame.to_csv(tmp_path / "feat.csv", index=False)
    with pytest.raises(DataFileError, match="one row per sensor"):
        read_feature_table(tmp_path / "feat.csv")
