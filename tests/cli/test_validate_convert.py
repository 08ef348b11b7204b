"""``tzsl formats``, ``tzsl validate`` and ``tzsl convert`` end to end (real PHAC-2 data where needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import EXIT_TZSL_ERROR, cli
from tzsl.datasets import write_plain_dataset
from tzsl.evaluation import random_object_splits, write_splits_csv
from tzsl.features import SIGNAL_STATISTICS, load_plain_dataset


def _run(*args: str):
    return CliRunner().invoke(cli, [str(a) for a in args])


def _toy(folder: Path) -> Path:
    classes = pd.DataFrame({"hard": [1, 0, 1], "soft": [0, 1, 0], "round": [0, 1, 1]},
                           index=pd.Index(["cube", "ball", "disc"], name="class"))
    trials = pd.DataFrame({"trial_id": ["t1", "t2", "t3", "t4"], "class": ["cube", "ball", "disc", "cube"],
                           "object": ["c1", "b1", "d1", "c2"]})
    write_plain_dataset(folder, classes, trials, sensors=("left", "right"), X=np.arange(16.0).reshape(4, 2, 2),
                        feature_names=("f_a", "f_b"), attribute_groups={"hard": "material", "soft": "material",
                                                                         "round": "shape"})
    return folder


def test_formats_documents_every_file():
    result = _run("formats")
    assert result.exit_code == 0
    for word in ("classes.csv", "attribute_groups.csv", "trials.csv", "signal_file", "splits.csv", "dataset.toml",
                 "allow_identical_rows", "baseline_rows", "sensor_0", *SIGNAL_STATISTICS):
        assert word in result.output, word
    help_text = _run("formats", "--help").output
    assert "classes.csv (required)" in help_text and "class,<attribute_1>,...,<attribute_k>" in help_text


def test_validate_clean_prints_summary(tmp_path):
    result = _run("validate", _toy(tmp_path / "toy"))
    assert result.exit_code == 0, result.output
    assert "classes:    3 (3 with trials)" in result.output
    assert "attributes: 3 (material: 2, shape: 1)" in result.output
    assert "trials:     4" in result.output and "objects:    4" in result.output
    assert "sensors:    2 (left, right)" in result.output
    assert "features:   2 feature columns per sensor" in result.output
    assert result.output.strip().endswith("valid")


def test_validate_lists_every_problem_and_exits_2(tmp_path):
    folder = _toy(tmp_path / "toy")
    text = (folder / "classes.csv").read_text().replace("ball,0,1,1", "ball,0,x,1")
    (folder / "classes.csv").write_text(text)
    trials = (folder / "trials.csv").read_text().replace("t2,ball", "t2,cone")  # lines 4 and 5
    (folder / "trials.csv").write_text(trials)
    result = CliRunner().invoke(cli, ["validate", str(folder)])
    assert result.exit_code == EXIT_TZSL_ERROR
    assert "classes.csv:3: class 'ball', attribute 'soft': entry is 'x'; expected 0 or 1" in result.stdout
    assert "trials.csv:4: trial 't2': class 'cone' is not in classes.csv" in result.stdout
    assert "trials.csv:5: trial 't2': class 'cone' is not in classes.csv" in result.stdout
    assert result.stderr.strip() == f"tzsl: error: {folder}: 3 problem(s); see the list above"


def test_validate_runs_the_split_reader(tmp_path):
    folder = _toy(tmp_path / "toy")
    (folder / "splits.csv").write_text("split,object,role\ns,c1,train\ns,b1,test\ns,d1,test\ns,c2,test\n"
                                       "s,b1,train\n")
    result = _run("validate", folder)
    assert result.exit_code == EXIT_TZSL_ERROR
    assert "splits.csv:6: split 's': object 'b1' is in both train and test (also line 3)" in result.output


# --------------------------------------------------------------------------- real data


@pytest.fixture(scope="module")
def penn_folder(data_dir, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("convert") / "phac2-penn"
    result = _run("convert", "--dataset", "phac2-penn", "--out", out, "--data-dir", data_dir)
    assert result.exit_code == 0, result.output
    assert "60 classes x 19 attributes, 600 trials, 2 sensors, 52 feature columns" in result.output
    return out


@pytest.mark.realdata
def test_penn_round_trip_equals_built_in_features(penn_folder, data_dir):
    from tzsl.features import dataset_features

    ref = dataset_features("phac2-penn", data_dir=data_dir)
    fs = load_plain_dataset(penn_folder)
    np.testing.assert_array_equal(fs.X, ref.X)  # exact equality
    assert fs.X.dtype == ref.X.dtype
    pd.testing.assert_frame_equal(fs.attributes, ref.attributes, check_names=False)
    pd.testing.assert_frame_equal(fs.trials[list(ref.trials.columns)], ref.trials)
    assert fs.feature_names == ref.feature_names and fs.sensors == ref.sensors and fs.dataset == "phac2-penn"
    assert (fs.trials["class"] == fs.trials["object_name"]).all()  # in PHAC-2 each object is its own class


@pytest.mark.realdata
def test_penn_converted_validates_clean_with_splits(penn_folder, data_dir):
    result = _run("validate", penn_folder)
    assert result.exit_code == 0, result.output
    assert "classes:    60" in result.output and "attributes: 19" in result.output
    assert "trials:     600" in result.output and "sensors:    2 (finger_0, finger_1)" in result.output
    # generated PHAC-2 splits are a valid splits.csv of the converted folder
    fs = load_plain_dataset(penn_folder)
    splits = random_object_splits(fs.attributes, n_test=10, n_splits=3, random_state=0)
    work = penn_folder.parent / "with-splits"
    work.mkdir()
    for name in ("classes.csv", "trials.csv", "dataset.toml"):
        (work / name).write_bytes((penn_folder / name).read_bytes())
    write_splits_csv(splits, work / "splits.csv")
    result = _run("validate", work)
    assert result.exit_code == 0, result.output
    assert "splits:     splits.csv" in result.output


@pytest.mark.realdata
def test_convert_refuses_overwrite(penn_folder, data_dir):
    before = (penn_folder / "trials.csv").stat().st_mtime_ns
    result = _run("convert", "--dataset", "phac2-penn", "--out", penn_folder, "--data-dir", data_dir)
    assert result.exit_code == EXIT_TZSL_ERROR
    assert "already exists; use --force to overwrite" in result.output
    assert (penn_folder / "trials.csv").stat().st_mtime_ns == before


@pytest.mark.realdata
def test_hold_signal_dataset_reproduces_time_averages(data_dir, tmp_path):
    from tzsl.features import BIOTAC_CHANNELS, dataset_features

    out = tmp_path / "hold"
    out.mkdir()
    (out / "classes.csv").write_text("stale")  # an old dataset folder: replaced only with --force
    result = _run("convert", "--dataset", "phac2-hold-mat", "--out", out, "--data-dir", data_dir)
    assert result.exit_code == EXIT_TZSL_ERROR
    result = _run("convert", "--dataset", "phac2-hold-mat", "--out", out, "--data-dir", data_dir, "--force")
    assert result.exit_code == 0, result.output
    assert len(list((out / "signals").glob("*.npz"))) == 120
    result = _run("validate", out)
    assert result.exit_code == 0, result.output
    assert "23 channels x 1 statistics (mean), baseline_rows=100" in result.output

    ref = dataset_features("phac2-hold-mat", data_dir=data_dir)
    fs = load_plain_dataset(out)
    assert fs.X.shape == (60, 2, 23)
    assert fs.feature_names == tuple(f"{c}_mean" for c in BIOTAC_CHANNELS)
    # the generic path (mean after a 100-row baseline) = the paper's HOLD time averages
    np.testing.assert_allclose(fs.X, ref.X[:, :, :23], rtol=1e-12, atol=1e-9)
    pd.testing.assert_frame_equal(fs.attributes, ref.attributes, check_names=False)
    assert list(fs.trials["trial_id"]) == list(ref.trials["trial_id"])
    # other statistics of the same real signals are finite and differ between objects
    more = load_plain_dataset(out, statistics=("std", "slope", "iqr"), baseline_rows=0)
    assert more.X.shape == (60, 2, 69) and np.isfinite(more.X).all()
    per_object = pd.DataFrame(more.X[:, 0, :]).groupby(more.trials["object_name"].to_numpy()).mean()
    assert (per_object.std(axis=0) > 0).sum() > 60
