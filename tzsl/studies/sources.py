"""Where a study's features come from: a built-in dataset, a feature table, or a plain-file folder."""

from __future__ import annotations

import os
from pathlib import Path

from tzsl.datasets import FeatureSet
from tzsl.exceptions import ConfigError


def load_study_features(
    dataset: str | None = "phac2-penn",
    features_file: str | os.PathLike | None = None,
    plain_dir: str | os.PathLike | None = None,
    data_dir: str | os.PathLike | None = None,
    path: str | os.PathLike | None = None,
) -> FeatureSet:
    """One :class:`FeatureSet` from exactly one source.

    Parameters
    ----------
    dataset : str or None
        A built-in dataset (see :data:`tzsl.studies.extract.DATASETS`).
    features_file : path-like or None
        A table written by ``tzsl extract --out`` (.csv or .npz).
    plain_dir : path-like or None
        A plain-file dataset folder (``tzsl formats``).
    data_dir, path
        Data home, and the input file of ``phac2-h5``.
    """
    if features_file is not None and plain_dir is not None:
        raise ConfigError("give either --features or --plain, not both")
    if features_file is not None:
        from tzsl.datasets import read_feature_table  # noqa: PLC0415

        return read_feature_table(Path(features_file))
    if plain_dir is not None:
        from tzsl.features import load_plain_dataset  # noqa: PLC0415

        return load_plain_dataset(Path(plain_dir))
    if dataset is None:
        raise ConfigError("no data source: give --dataset, --features or --plain")
    from tzsl.studies.extract import extract_features  # noqa: PLC0415

    return extract_features(dataset, data_dir=data_dir, path=path)
