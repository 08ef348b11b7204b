"""The SIMULATED scale-benchmark datasets: sizes, distinct class rows, CSV and Parquet read the same."""

from __future__ import annotations

import numpy as np
import pytest

from tzsl.datasets import read_plain_dataset, synthetic_dataset_arrays, write_synthetic_dataset


def test_arrays_have_the_requested_shape_and_distinct_classes():
    K, cls, X = synthetic_dataset_arrays(600, n_classes=12, n_attributes=6, n_sensors=3, n_features=5, seed=1)
    assert K.shape == (12, 6) and X.shape == (600, 3, 5) and cls.shape == (600,)
    assert np.unique(K, axis=0).shape[0] == 12
    assert (K.sum(axis=0) >= 2).all() and (K.sum(axis=0) <= 10).all()
    assert np.bincount(cls).min() == 50
    # the features carry the attributes: class means differ far more than the noise of a mean
    means = np.stack([X[cls == c].mean(axis=0) for c in range(12)])
    assert means.std(axis=0).mean() > 3 * X.std(axis=0).mean() / np.sqrt(50)


def test_csv_and_parquet_folders_read_the_same(tmp_path):
    pytest.importorskip("pyarrow")
    a = read_plain_dataset(write_synthetic_dataset(tmp_path / "csv", 240, n_classes=12, n_attributes=6))
    b = read_plain_dataset(write_synthetic_dataset(tmp_path / "pq", 240, n_classes=12, n_attributes=6,
                                                   table_format="parquet"))
    assert not (tmp_path / "pq" / "trials.csv").exists()
    np.testing.assert_array_equal(a.X, b.X)
    assert a.X.shape == (240, 2, 32) and a.sensors == ("s0", "s1") and a.name == "synthetic-SIMULATED"
    assert list(a.trials["class"][:3]) == ["c00", "c01", "c02"]
