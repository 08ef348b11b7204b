"""SIMULATED plain-file datasets of any size, for scale benchmarks: :func:`write_synthetic_dataset`.

Nothing here is tactile data: classes get random distinct 0/1 attribute rows, and every trial's
per-sensor features are a fixed random non-linear function of its class's attributes plus a
per-object offset and Gaussian trial noise. Zero-shot accuracy on these data says how well a
model recovers attributes that *are* in the features; it measures cost, not tactile performance.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._plain_write import write_plain_dataset
from tzsl.exceptions import ConfigError

__all__ = ["synthetic_dataset_arrays", "write_synthetic_dataset"]


def _distinct_rows(rng: np.random.Generator, n_classes: int, n_attributes: int) -> np.ndarray:
    """(n_classes, n_attributes) 0/1, distinct rows, every attribute present and absent at least twice."""
    if n_attributes < 63 and n_classes > 2**n_attributes - 2:
        raise ConfigError(f"{n_classes} classes need more than {n_attributes} attributes for distinct rows")
    for _ in range(1000):
        K = (rng.random((n_classes, n_attributes)) < 0.5).astype(np.int64)
        col = K.sum(axis=0)
        if np.unique(K, axis=0).shape[0] == n_classes and (col >= 2).all() and (col <= n_classes - 2).all():
            return K
    raise ConfigError(f"could not draw {n_classes} distinct attribute rows over {n_attributes} attributes")


def synthetic_dataset_arrays(
    n_trials: int,
    *,
    n_classes: int = 60,
    n_attributes: int = 30,
    n_sensors: int = 2,
    n_features: int = 32,
    noise: float = 1.0,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SIMULATED features: ``(K, cls, X)``.

    Returns
    -------
    K : ndarray (n_classes, n_attributes) of 0/1
        Class attribute rows (one object per class).
    cls : ndarray (n_trials,) of int
        Class of each trial, as balanced as ``n_trials`` allows (trial ``i`` has class ``i % n_classes``).
    X : ndarray (n_trials, n_sensors, n_features) float64
        ``tanh(K[cls] @ W_s) + 0.5 * sin(K[cls] @ V_s) + object offset + noise * N(0, 1)``, unitless.
    """
    if n_trials < 2 * n_classes:
        raise ConfigError(f"n_trials must be at least 2 per class ({2 * n_classes}), got {n_trials}")
    rng = np.random.default_rng(seed)
    K = _distinct_rows(rng, n_classes, n_attributes)
    W = rng.normal(size=(n_sensors, n_attributes, n_features)) / np.sqrt(n_attributes / 4)
    V = rng.normal(size=(n_sensors, n_attributes, n_features))
    centre = np.tanh(np.einsum("cm,smd->csd", K, W)) + 0.5 * np.sin(np.einsum("cm,smd->csd", K, V))
    centre += 0.3 * rng.normal(size=centre.shape)  # what of an object is not its attributes
    cls = np.arange(n_trials) % n_classes
    X = centre[cls] + noise * rng.normal(size=(n_trials, n_sensors, n_features))
    return K, cls, X


def write_synthetic_dataset(
    folder: str | os.PathLike,
    n_trials: int,
    *,
    n_classes: int = 60,
    n_attributes: int = 30,
    n_sensors: int = 2,
    n_features: int = 32,
    noise: float = 1.0,
    seed: int = 0,
    table_format: str = "csv",
    force: bool = False,
) -> Path:
    """Write a SIMULATED plain-file dataset (feature columns) of ``n_trials`` trials.

    See :func:`synthetic_dataset_arrays`; classes ``c00``, ..., attributes ``a00``, ...,
    sensors ``s0``, ..., features ``f00``, .... ``table_format``: ``"csv"`` or ``"parquet"``
    (the trials table). ``dataset.toml`` names it ``synthetic-SIMULATED``.
    """
    K, cls, X = synthetic_dataset_arrays(n_trials, n_classes=n_classes, n_attributes=n_attributes,
                                         n_sensors=n_sensors, n_features=n_features, noise=noise, seed=seed)
    width = len(str(n_classes - 1))
    names = np.array([f"c{c:0{width}d}" for c in range(n_classes)], dtype=object)
    classes = pd.DataFrame(K, index=pd.Index(names, name="class"),
                           columns=[f"a{j:02d}" for j in range(n_attributes)])
    trials = pd.DataFrame({"trial_id": [f"t{i}" for i in range(n_trials)], "class": names[cls]})
    return write_plain_dataset(folder, classes, trials, sensors=[f"s{k}" for k in range(n_sensors)], X=X,
                               feature_names=[f"f{i:02d}" for i in range(n_features)],
                               settings={"name": "synthetic-SIMULATED"}, table_format=table_format, force=force)
