"""The trials table may be Parquet (trials.parquet) and reads exactly as the same CSV; signals read in threads."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tzsl.datasets import read_plain_dataset, validate_dataset, write_plain_dataset
from tzsl.features import load_plain_dataset

pytest.importorskip("pyarrow")


def _classes() -> pd.DataFrame:
    return pd.DataFrame({"hard": [1, 0, 1], "soft": [0, 1, 1]}, index=pd.Index(["cube", "ball", "disc"], name="class"))


def _to_parquet(folder):
    pd.read_csv(folder / "trials.csv", dtype=str, keep_default_na=False).pipe(
        lambda t: t.astype({c: float for c in t.columns if c.startswith("f_")})).to_parquet(folder / "trials.parquet")
    (folder / "trials.csv").unlink()


def test_parquet_trials_equal_csv(tmp_path):
    rng = np.random.default_rng(0)
    trials = pd.DataFrame({"trial_id": ["t1", "t2", "t3", "t4"], "class": ["cube", "ball", "disc", "cube"]})
    X = rng.normal(size=(4, 2, 3)) / 3.0
    csv = write_plain_dataset(tmp_path / "csv", _classes(), trials, sensors=("l", "r"), X=X,
                              feature_names=("f_a", "f_b", "f_c"))
    pq = write_plain_dataset(tmp_path / "pq", _classes(), trials, sensors=("l", "r"), X=X,
                             feature_names=("f_a", "f_b", "f_c"))
    _to_parquet(pq)
    assert validate_dataset(pq) == []
    a, b = read_plain_dataset(csv), read_plain_dataset(pq)
    np.testing.assert_array_equal(a.X, b.X)  # exact, bit for bit
    pd.testing.assert_frame_equal(a.trials, b.trials)


def test_parquet_problems_name_the_parquet_file(tmp_path):
    trials = pd.DataFrame({"trial_id": ["t1", "t2"], "class": ["cube", "cone"]})
    folder = write_plain_dataset(tmp_path / "pq", _classes(), trials, X=np.ones((2, 1, 1)), feature_names=("f_a",))
    _to_parquet(folder)
    problems = validate_dataset(folder)
    assert [(p.file, p.line) for p in problems] == [("trials.parquet", 3)]
    (folder / "trials.parquet").write_bytes(b"PAR1 broken")
    assert "not a readable Parquet file" in validate_dataset(folder)[0].message


def test_signals_read_in_threads_equal_serial(tmp_path):
    rng = np.random.default_rng(1)
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(12)], "class": ["cube", "ball", "disc"] * 4})
    signals = [[rng.normal(size=(5, 2))] for _ in range(12)]
    folder = write_plain_dataset(tmp_path / "sig", _classes(), trials, signals=signals, channels=("p", "q"))
    data = read_plain_dataset(folder)
    serial = data.read_signals(range(12), 0, n_threads=1)
    threaded = data.read_signals(range(12), 0, n_threads=4)
    for a, b, s in zip(serial, threaded, signals, strict=True):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, s[0])
    assert load_plain_dataset(folder).X.shape == (12, 1, 8)
