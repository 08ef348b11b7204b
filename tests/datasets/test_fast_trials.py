"""A clean trials table read column-wise gives exactly what the row-by-row checker gives."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import FeatureSet, _validate, feature_set_to_plain, write_plain_dataset, write_synthetic_dataset

pytest.importorskip("pyarrow")


def _both(folder, monkeypatch):
    fast, problems = _validate.scan_dataset(folder, check_signals=False)
    assert problems == []
    with monkeypatch.context() as m:
        m.setattr(_validate, "read_clean_trials", lambda *a: None)
        slow, problems = _validate.scan_dataset(folder, check_signals=False)
    assert problems == []
    pd.testing.assert_frame_equal(fast.trials, slow.trials)
    assert (fast.sensors, fast.kind, fast.feature_names) == (slow.sensors, slow.kind, slow.feature_names)
    np.testing.assert_array_equal(fast.signal_lines, slow.signal_lines)
    return fast, slow


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
def test_feature_columns_bit_for_bit(tmp_path, monkeypatch, table_format):
    folder = write_synthetic_dataset(tmp_path / "d", 300, n_classes=12, n_attributes=6, table_format=table_format)
    fast, slow = _both(folder, monkeypatch)
    np.testing.assert_array_equal(fast.X, slow.X)
    assert fast.X.dtype == np.float64 and fast.X.shape == (300, 2, 32)


def test_objects_ids_and_shuffled_sensor_rows(tmp_path, monkeypatch):
    rng = np.random.default_rng(0)
    names = [f"o{i}" for i in range(6)]
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(18)], "object_id": np.repeat(np.arange(6), 3) + 10,
                           "object_name": np.repeat(names, 3), "trial_index": np.tile([3, 1, 2], 6)})
    attrs = pd.DataFrame(rng.integers(0, 2, size=(6, 3)), index=pd.Index(names, name="object_name"),
                         columns=["a", "b", "c"])
    fs = FeatureSet(X=rng.normal(size=(18, 2, 3)), trials=trials, sensors=("L", "R"), feature_names=("x", "y", "z"),
                    attributes=attrs, dataset="toy")
    folder = feature_set_to_plain(fs, tmp_path / "d")
    table = pd.read_csv(folder / "trials.csv")
    table.sample(frac=1.0, random_state=1).to_csv(folder / "trials.csv", index=False)  # rows in any order
    fast, slow = _both(folder, monkeypatch)
    np.testing.assert_array_equal(fast.X, slow.X)
    assert list(fast.trials["object_id"].unique()) != []


def test_signal_files(tmp_path, monkeypatch):
    rng = np.random.default_rng(1)
    classes = pd.DataFrame({"hard": [1, 0, 1], "flat": [1, 0, 0]},
                           index=pd.Index(["cube", "ball", "disc"], name="class"))
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(6)], "class": ["cube", "ball", "disc"] * 2})
    folder = write_plain_dataset(tmp_path / "s", classes, trials, sensors=("l", "r"), channels=("p", "q"),
                                 signals=[[rng.normal(size=(4, 2)) for _ in range(2)] for _ in range(6)])
    fast, slow = _both(folder, monkeypatch)
    np.testing.assert_array_equal(fast.signal_files, slow.signal_files)
    np.testing.assert_array_equal(fast.signal_rows, slow.signal_rows)


@pytest.mark.parametrize("edit", [
    lambda t: t.replace("cube", " cube", 1),          # whitespace around a name
    lambda t: t.replace("\n", "\n\n", 2),             # a blank line shifts line numbers
])
def test_anything_unusual_goes_to_the_row_by_row_checker(tmp_path, edit):
    classes = pd.DataFrame({"hard": [1, 0, 1]}, index=pd.Index(["cube", "ball", "disc"], name="class"))
    trials = pd.DataFrame({"trial_id": ["t1", "t2", "t3"], "class": ["cube", "ball", "disc"]})
    folder = write_plain_dataset(tmp_path / "d", classes, trials, X=np.ones((3, 1, 1)), feature_names=("f",))
    path = folder / "trials.csv"
    path.write_text(edit(path.read_text()))
    assert _validate.read_clean_trials(path, {"cube", "ball", "disc"}) is None
