"""Feature tables on disk: a :class:`FeatureSet` as CSV or ``.npz``.

CSV layout (one row per trial and sensor, "long" in sensors, "wide" in features)::

    trial_id,object_id,object_name,trial_index,sensor,<feature_1>,...,<feature_d>

plus a sidecar ``<name>.attributes.csv`` holding the class-attribute table
(``object_name,<attribute_1>,...``). The ``.npz`` layout stores the same content as arrays:
``X`` (n_trials, n_sensors, d) float64, ``sensors``, ``feature_names``, one array per trial
column (``trial_id``, ``object_id``, ``object_name``, ``trial_index``), ``attribute_names``,
``attribute_objects`` and ``attributes`` (n_objects, n_attributes) int.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import atomic_write, looks_binary, read_npz
from tzsl.datasets._types import TRIAL_COLUMNS, FeatureSet
from tzsl.exceptions import DataFileError

SUPPORTED_SUFFIXES = (".csv", ".npz")


def _attributes_sidecar(path: Path) -> Path:
    return path.with_name(path.stem + ".attributes.csv")


def feature_table_paths(path: str | Path) -> list[Path]:
    """Every file :func:`write_feature_table` writes for ``path``."""
    path = Path(path)
    if path.suffix == ".csv":
        return [path, _attributes_sidecar(path)]
    return [path]


def feature_set_to_frame(features: FeatureSet) -> pd.DataFrame:
    """The long CSV table: n_trials * n_sensors rows, trial columns + ``sensor`` + features."""
    n, s, d = features.X.shape
    trials = features.trials[list(TRIAL_COLUMNS)]
    meta = trials.loc[trials.index.repeat(s)].reset_index(drop=True)
    meta.insert(len(TRIAL_COLUMNS), "sensor", np.tile(np.asarray(features.sensors), n))
    values = pd.DataFrame(features.X.reshape(n * s, d), columns=list(features.feature_names))
    return pd.concat([meta, values], axis=1)


def write_feature_table(features: FeatureSet, path: str | Path) -> list[Path]:
    """Write ``features`` to ``path`` (``.csv`` or ``.npz``); returns the files written.

    Writes are atomic (temporary file + rename). Overwrite checks are the caller's job.
    """
    path = Path(path)
    if path.suffix not in SUPPORTED_SUFFIXES:
        raise DataFileError(path, f"unsupported feature table type {path.suffix!r}; use .csv or .npz")
    if path.suffix == ".csv":
        frame = feature_set_to_frame(features)
        attrs = features.attributes.rename_axis("object_name").reset_index()
        atomic_write(path, lambda p: frame.to_csv(p, index=False))
        atomic_write(_attributes_sidecar(path), lambda p: attrs.to_csv(p, index=False))
    else:
        arrays = {
            "X": features.X,
            "sensors": np.asarray(features.sensors),
            "feature_names": np.asarray(features.feature_names),
            "attribute_names": np.asarray(features.attributes.columns, dtype=str),
            "attribute_objects": np.asarray(features.attributes.index, dtype=str),
            "attributes": features.attributes.to_numpy(dtype=int),
        }
        for column in TRIAL_COLUMNS:
            values = features.trials[column].to_numpy()
            arrays[column] = values.astype(str) if values.dtype == object else values
        def _save(p: Path) -> None:
            with open(p, "wb") as fh:
                np.savez_compressed(fh, **arrays)
        atomic_write(path, _save)
    return feature_table_paths(path)


def read_csv_table(path: Path) -> pd.DataFrame:
    """A CSV table, or one line naming the file and what is wrong with it."""
    try:
        if looks_binary(path):
            raise UnicodeDecodeError("utf-8", b"", 0, 1, "binary")
        return pd.read_csv(path)
    except UnicodeDecodeError:
        raise DataFileError(path, "not a UTF-8 text file (a binary file given as CSV?)") from None
    except pd.errors.EmptyDataError:
        raise DataFileError(path, "file is empty; expected a header line", line=1) from None
    except (pd.errors.ParserError, OSError, ValueError) as exc:
        text = str(exc).strip().splitlines()
        raise DataFileError(path, f"not a readable CSV table ({text[0] if text else type(exc).__name__})") from None


def read_feature_table(path: str | Path, dataset: str = "") -> FeatureSet:
    """Read a table written by :func:`write_feature_table` back into a :class:`FeatureSet`."""
    path = Path(path)
    if not path.is_file():
        raise DataFileError(path, "feature table not found")
    if path.suffix == ".npz":
        data = read_npz(path)
        missing = {"X", "sensors", "feature_names", "attributes", *TRIAL_COLUMNS} - set(data)
        if missing:
            raise DataFileError(path, f"missing arrays {sorted(missing)}")
        try:
            trials = pd.DataFrame({c: data[c] for c in TRIAL_COLUMNS})
            for column in ("trial_id", "object_name"):
                trials[column] = trials[column].astype(str)
            attributes = pd.DataFrame(
                data["attributes"], index=pd.Index(data["attribute_objects"], name="object_name"),
                columns=list(data["attribute_names"]),
            )
            X = data["X"].astype(float)
        except (KeyError, TypeError, ValueError) as exc:
            raise DataFileError(path, f"arrays do not form a feature table ({type(exc).__name__}: "
                                f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
        if X.ndim != 3 or X.shape[0] != len(trials):
            raise DataFileError(path, f"X has shape {X.shape}; expected ({len(trials)}, n_sensors, n_features)")
        sensors = tuple(str(s) for s in data["sensors"])
        names = tuple(str(s) for s in data["feature_names"])
    elif path.suffix == ".csv":
        frame = read_csv_table(path)
        absent = [c for c in (*TRIAL_COLUMNS, "sensor") if c not in frame.columns]
        if absent:
            raise DataFileError(path, f"missing columns {absent}")
        sensors = tuple(pd.unique(frame["sensor"]).astype(str))
        names = tuple(c for c in frame.columns if c not in (*TRIAL_COLUMNS, "sensor"))
        trial_order = pd.unique(frame["trial_id"])
        wide = frame.set_index(["trial_id", "sensor"])
        if wide.index.duplicated().any():
            dup = wide.index[wide.index.duplicated()][0]
            raise DataFileError(path, f"duplicate row for trial {dup[0]!r}, sensor {dup[1]!r}")
        full = pd.MultiIndex.from_product([trial_order, sensors])
        if len(full) != len(wide):
            raise DataFileError(path, "every trial needs exactly one row per sensor")
        try:
            X = wide.loc[full, list(names)].to_numpy(dtype=float)
        except ValueError:
            raise DataFileError(path, "a feature column holds text that is not a number") from None
        X = X.reshape(len(trial_order), len(sensors), len(names))
        trials = frame.drop_duplicates("trial_id")[list(TRIAL_COLUMNS)].reset_index(drop=True)
        sidecar = _attributes_sidecar(path)
        if not sidecar.is_file():
            raise DataFileError(sidecar, "attribute table missing (written beside the feature CSV)")
        attributes = read_csv_table(sidecar)
        if "object_name" not in attributes.columns:
            raise DataFileError(sidecar, "header lacks the column 'object_name'", line=1)
        attributes = attributes.set_index("object_name")
    else:
        raise DataFileError(path, f"unsupported feature table type {path.suffix!r}; use .csv or .npz")
    if not np.isfinite(X).all():
        bad = int(np.argwhere(~np.isfinite(X))[0, 0])
        raise DataFileError(path, "NaN or infinite feature value", trial=str(trials["trial_id"][bad]))
    return FeatureSet(X=X, trials=trials, sensors=sensors, feature_names=names,
                      attributes=attributes, dataset=dataset or path.stem, info={"source": str(path)})
