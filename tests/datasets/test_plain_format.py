"""The plain-file dataset format: write, read, FeatureSet (feature columns and signal files)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import (
    FeatureSet,
    feature_set_to_plain,
    read_plain_dataset,
    write_plain_dataset,
)
from tzsl.evaluation import read_splits_csv
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.features import SignalStatistics, load_plain_dataset

CLASSES = pd.DataFrame(
    {"hard": [1, 0, 1], "soft": [0, 1, 0], "round": [0, 1, 1]},
    index=pd.Index(["cube", "ball", "disc"], name="class"),
)


def _trials(n_per_object: int = 2) -> pd.DataFrame:
    """Two objects of class cube, one of ball, one of disc; ``n_per_object`` trials each."""
    objects = [("cube", "cube_a"), ("cube", "cube_b"), ("ball", "ball_a"), ("disc", "disc_a")]
    rows = [(f"{obj}_{k}", cls, obj) for cls, obj in objects for k in range(n_per_object)]
    return pd.DataFrame(rows, columns=["trial_id", "class", "object"])


def test_feature_columns_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    trials = _trials()
    X = rng.standard_normal((8, 2, 3)) * 10.0 ** rng.integers(-200, 200, (8, 2, 3))
    write_plain_dataset(tmp_path / "ds", CLASSES, trials, sensors=("left", "right"), X=X,
                        feature_names=("f_a", "pressure:max", "3"),
                        attribute_groups={"hard": "material", "soft": "material", "round": "shape"},
                        settings={"name": "toy"})
    fs = load_plain_dataset(tmp_path / "ds")
    assert isinstance(fs, FeatureSet)
    np.testing.assert_array_equal(fs.X, X)  # exact: floats are written with repr
    assert fs.sensors == ("left", "right") and fs.feature_names == ("f_a", "pressure:max", "3")
    assert fs.dataset == "toy"
    assert list(fs.trials["trial_id"]) == list(trials["trial_id"])
    assert list(fs.trials["class"]) == list(trials["class"])
    # objects default ids 0..3 in file order, trial_index 1..n per object
    assert list(fs.trials["object_id"]) == [0, 0, 1, 1, 2, 2, 3, 3]
    assert list(fs.trials["trial_index"]) == [1, 2] * 4
    # attributes per object = its class row; two objects share class cube
    assert list(fs.attributes.index) == ["cube_a", "cube_b", "ball_a", "disc_a"]
    np.testing.assert_array_equal(fs.attributes.to_numpy(), CLASSES.loc[["cube", "cube", "ball", "disc"]].to_numpy())
    np.testing.assert_array_equal(fs.trial_attributes()[:2], [[1, 0, 0], [1, 0, 0]])
    pd.testing.assert_frame_equal(fs.info["classes"], CLASSES, check_names=False)
    assert fs.info["attribute_groups"] == {"hard": "material", "soft": "material", "round": "shape"}
    assert fs.info["features"] == "columns" and fs.info["splits_file"] is None
    # subset keeps working with the extra class column
    sub = fs.subset(fs.trials["class"].to_numpy() == "cube")
    assert sub.n_objects == 2 and list(sub.attributes.index) == ["cube_a", "cube_b"]


def test_minimal_trials_file_defaults(tmp_path):
    folder = tmp_path / "ds"
    folder.mkdir()
    (folder / "classes.csv").write_text("class,a,b\nx,1,0\ny,0,1\n")
    (folder / "trials.csv").write_text("trial_id,class,v1,v2\nr1,x,1,2\nr2,y,3,4\nr3,x,5,6\n")
    data = read_plain_dataset(folder)
    assert data.kind == "columns" and data.sensors == ("sensor_0",) and data.name == "ds"
    fs = data.to_feature_set()
    assert fs.X.shape == (3, 1, 2)
    assert list(fs.trials["object_name"]) == ["x", "y", "x"]  # object = class by default
    assert list(fs.trials["trial_index"]) == [1, 1, 2]
    assert list(fs.attributes.index) == ["x", "y"]


def test_explicit_trial_index_and_object_id(tmp_path):
    trials = _trials().assign(object_id=[7, 7, 8, 8, 9, 9, 10, 10], trial_index=[3, 4] * 4)
    write_plain_dataset(tmp_path / "ds", CLASSES, trials, X=np.zeros((8, 1, 1)), feature_names=("f",))
    fs = load_plain_dataset(tmp_path / "ds")
    assert list(fs.trials["object_id"]) == [7, 7, 8, 8, 9, 9, 10, 10]
    assert list(fs.trials["trial_index"]) == [3, 4] * 4


@pytest.mark.parametrize("signal_format", ["npz", "csv"])
def test_signal_files(tmp_path, signal_format):
    rng = np.random.default_rng(1)
    trials = _trials()
    signals = [[rng.standard_normal((int(rng.integers(5, 40)), 3)) for _ in range(2)] for _ in range(8)]
    settings = {"signals": {"baseline_rows": 2, "statistics": ["mean", "iqr", "slope"]}}
    write_plain_dataset(tmp_path / "ds", CLASSES, trials, sensors=("s0", "s1"), signals=signals,
                        channels=("p", "q", "r"), settings=settings, signal_format=signal_format)
    assert (tmp_path / "ds" / "signals" / f"cube_a_0_s1.{signal_format}").is_file()
    fs = load_plain_dataset(tmp_path / "ds")
    assert fs.X.shape == (8, 2, 9)
    assert fs.feature_names[:4] == ("p_mean", "p_iqr", "p_slope", "q_mean")
    assert fs.info["statistics"] == ["mean", "iqr", "slope"] and fs.info["baseline_rows"] == 2
    for s in range(2):
        ref = SignalStatistics(statistics=("mean", "iqr", "slope"), baseline_rows=2).fit_transform(
            [signals[i][s] for i in range(8)])
        np.testing.assert_allclose(fs.X[:, s], ref, rtol=1e-12, atol=1e-12)
    # arguments win over dataset.toml; channels selects and orders
    fs2 = load_plain_dataset(tmp_path / "ds", "signals", statistics=("max",), baseline_rows=0, channels=("r", "p"))
    assert fs2.feature_names == ("r_max", "p_max")
    np.testing.assert_allclose(fs2.X[3, 1], signals[3][1][:, [2, 0]].max(axis=0))


def test_signal_problem_found_at_load_names_file_and_trial(tmp_path):
    signals = [[np.ones((4, 2))] for _ in range(8)]
    signals[5][0][2, 1] = np.nan
    write_plain_dataset(tmp_path / "ds", CLASSES, _trials(), signals=signals, channels=("a", "b"),
                        signal_format="csv")
    data = read_plain_dataset(tmp_path / "ds")  # the reader only checks that signal files exist
    with pytest.raises(DataFileError, match=r"trial ball_a_1: signals/ball_a_1\.csv:4: channel 'b' is NaN"):
        load_plain_dataset(tmp_path / "ds")
    with pytest.raises(DataFileError, match="at least 6 needed"):
        data.read_signal(0, 0, min_rows=6)


def test_invalid_folder_lists_problems(tmp_path):
    folder = tmp_path / "ds"
    folder.mkdir()
    (folder / "classes.csv").write_text("class,a\nx,1\nx,0\n")
    (folder / "trials.csv").write_text("trial_id,class,v\nr1,z,1\n")
    with pytest.raises(DataFileError) as info:
        read_plain_dataset(folder)
    message = str(info.value)
    assert "2 problem(s)" in message
    assert "classes.csv:3: class 'x' is defined twice" in message
    assert "trials.csv:2: trial 'r1': class 'z' is not in classes.csv" in message
    assert f"tzsl validate {folder}" in message


def test_feature_source_and_parameters_are_checked(tmp_path):
    write_plain_dataset(tmp_path / "ds", CLASSES, _trials(), X=np.zeros((8, 1, 2)), feature_names=("a", "b"))
    with pytest.raises(ConfigError, match="features='signals' but the dataset has feature columns"):
        load_plain_dataset(tmp_path / "ds", "signals")
    with pytest.raises(ConfigError, match="apply to signal datasets only"):
        load_plain_dataset(tmp_path / "ds", statistics=("mean",))
    with pytest.raises(ConfigError, match="features must be one of"):
        load_plain_dataset(tmp_path / "ds", "images")


def test_min_objects_filters_attributes(tmp_path):
    write_plain_dataset(tmp_path / "ds", CLASSES, _trials(), X=np.zeros((8, 1, 1)), feature_names=("f",))
    fs = load_plain_dataset(tmp_path / "ds", min_objects=3)  # hard: 3 objects, soft: 1, round: 2
    assert list(fs.attributes.columns) == ["hard"]
    assert fs.info["dropped_attributes"] == ["soft", "round"]


def test_splits_file_reads_with_the_evaluation_reader(tmp_path):
    write_plain_dataset(tmp_path / "ds", CLASSES, _trials(), X=np.zeros((8, 1, 1)), feature_names=("f",))
    (tmp_path / "ds" / "splits.csv").write_text(
        "split,object,role\nA,cube_a,train\nA,ball_a,train\nA,cube_b,train\nA,disc_a,test\n")
    data = read_plain_dataset(tmp_path / "ds")
    splits = read_splits_csv(data.splits_file, data.object_attributes, min_train_positives=1)
    assert splits[0].test_objects == ("disc_a",)
    assert load_plain_dataset(tmp_path / "ds").info["splits_file"] == str(tmp_path / "ds" / "splits.csv")


def test_writer_refuses_overwrite_and_replaces_with_force(tmp_path):
    out = tmp_path / "ds"
    write_plain_dataset(out, CLASSES, _trials(), X=np.zeros((8, 1, 1)), feature_names=("f",))
    with pytest.raises(ConfigError, match="already exists; use --force"):
        write_plain_dataset(out, CLASSES, _trials(), X=np.ones((8, 1, 1)), feature_names=("f",))
    assert (load_plain_dataset(out).X == 0).all()
    # a failing write leaves the old dataset untouched and no temporary folder behind
    with pytest.raises(ConfigError, match="reserved"):
        write_plain_dataset(out, CLASSES, _trials(), X=np.ones((8, 1, 1)), feature_names=("class",), force=True)
    assert (load_plain_dataset(out).X == 0).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]
    write_plain_dataset(out, CLASSES, _trials(), X=np.ones((8, 1, 1)), feature_names=("f",), force=True)
    assert (load_plain_dataset(out).X == 1).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]
    # --force never replaces a folder that is not a dataset
    other = tmp_path / "home"
    other.mkdir()
    (other / "notes.txt").write_text("keep me")
    with pytest.raises(ConfigError, match="refusing to replace"):
        write_plain_dataset(other, CLASSES, _trials(), X=np.zeros((8, 1, 1)), feature_names=("f",), force=True)
    assert (other / "notes.txt").read_text() == "keep me"


def test_feature_set_to_plain_round_trip_keeps_classes(tmp_path):
    write_plain_dataset(tmp_path / "a", CLASSES, _trials(), sensors=("l", "r"),
                        X=np.arange(48.0).reshape(8, 2, 3) / 7, feature_names=("x", "y", "z"))
    fs = load_plain_dataset(tmp_path / "a")
    feature_set_to_plain(fs, tmp_path / "b")
    again = load_plain_dataset(tmp_path / "b")
    np.testing.assert_array_equal(again.X, fs.X)
    pd.testing.assert_frame_equal(again.trials, fs.trials)
    pd.testing.assert_frame_equal(again.attributes, fs.attributes)
    pd.testing.assert_frame_equal(again.info["classes"], fs.info["classes"])
