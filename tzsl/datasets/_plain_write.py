"""Write a plain-file dataset folder atomically: :func:`write_plain_dataset`, :func:`feature_set_to_plain`.

The format is described in :data:`tzsl.datasets._plain.PLAIN_FORMAT_HELP` and ``data/README.md``.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import ensure_folder
from tzsl._toml import toml_text
from tzsl.datasets._tables import (
    CLASS_COLUMN,
    CLASSES_FILE,
    GROUPS_FILE,
    SETTINGS_FILE,
    TRIAL_RESERVED_COLUMNS,
    TRIALS_FILE,
    TRIALS_PARQUET,
)
from tzsl.datasets._types import FeatureSet
from tzsl.exceptions import ConfigError


def settings_to_toml(settings: Mapping) -> str:
    """``dataset.toml`` text of a settings mapping (top-level scalars, then one-level tables)."""
    try:
        return toml_text(settings)
    except TypeError as exc:
        raise ConfigError(f"{exc} to {SETTINGS_FILE}") from None


def _safe_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", str(text)).strip("._") or "trial"


def _looks_like_dataset(folder: Path) -> bool:
    return any((folder / name).exists() for name in (CLASSES_FILE, TRIALS_FILE, TRIALS_PARQUET))


def _install_folder(tmp: Path, folder: Path, force: bool) -> None:
    """Move the finished ``tmp`` folder to ``folder`` (replacing an old dataset with force)."""
    if folder.exists():
        if not folder.is_dir():
            raise ConfigError(f"{folder} exists and is not a folder")
        if any(folder.iterdir()):
            if not force:
                raise ConfigError(f"{folder} already exists; use --force to overwrite")
            if not _looks_like_dataset(folder):
                raise ConfigError(f"{folder} is not empty and holds no {CLASSES_FILE}/{TRIALS_FILE}; "
                                  "refusing to replace it even with --force")
            old = Path(tempfile.mkdtemp(prefix=f".{folder.name}.old-", dir=folder.parent))
            old.rmdir()
            os.replace(folder, old)
            try:
                os.replace(tmp, folder)
            except BaseException:
                os.replace(old, folder)
                raise
            shutil.rmtree(old, ignore_errors=True)
            return
        folder.rmdir()
    os.replace(tmp, folder)


def write_plain_dataset(
    folder: str | os.PathLike,
    classes: pd.DataFrame,
    trials: pd.DataFrame,
    *,
    sensors: Sequence[str] | None = None,
    X: np.ndarray | None = None,
    feature_names: Sequence[str] | None = None,
    signals: Sequence[Sequence[np.ndarray]] | None = None,
    channels: Sequence[str] | None = None,
    attribute_groups: Mapping[str, str] | None = None,
    settings: Mapping | None = None,
    signal_format: str = "npz",
    table_format: str = "csv",
    force: bool = False,
) -> Path:
    """Write a plain-file dataset folder, atomically.

    Everything is written to a temporary folder beside ``folder`` and moved into place at
    the end; a failure leaves ``folder`` untouched.

    Parameters
    ----------
    folder : path-like
        Destination; must not exist or be empty, unless ``force`` (then it must already be
        a dataset folder: holding ``classes.csv`` or ``trials.csv``).
    classes : DataFrame (n_classes, n_attributes), 0/1
        Indexed by class name.
    trials : DataFrame with n_trials rows
        ``trial_id`` and ``class``; optional ``object``, ``trial_index``, ``object_id``.
    sensors : sequence of str, optional
        Names of the n_sensors sensors; written as a ``sensor`` column. None: no column
        (then n_sensors must be 1).
    X : ndarray (n_trials, n_sensors, d), optional
        Feature columns, named by ``feature_names``. Exactly one of ``X`` and ``signals``.
    signals : sequence (n_trials) of sequence (n_sensors) of ndarray (n_rows, n_channels)
        Per-trial signals, written to ``signals/<trial>[_<sensor>].<signal_format>``;
        channels named by ``channels``.
    attribute_groups : mapping attribute -> group, optional
    settings : mapping, optional
        ``dataset.toml`` content (see :data:`PLAIN_FORMAT_HELP`).
    signal_format : {"npz", "csv"}, default "npz"
    table_format : {"csv", "parquet"}, default "csv"
        The trials table as ``trials.csv`` or ``trials.parquet`` (needs pyarrow).
    force : bool, default False
        Replace an existing dataset folder.

    Returns
    -------
    Path
        ``folder``.

    Floats are written with the shortest representation that reads back to the same
    float64 (``repr``), so a round trip is exact.
    """
    folder = Path(folder)
    if (X is None) == (signals is None):
        raise ConfigError("give exactly one of X (feature columns) and signals")
    if signal_format not in ("npz", "csv"):
        raise ConfigError(f"signal_format must be 'npz' or 'csv', got {signal_format!r}")
    if table_format not in ("csv", "parquet"):
        raise ConfigError(f"table_format must be 'csv' or 'parquet', got {table_format!r}")
    if folder.exists() and folder.is_dir() and any(folder.iterdir()) and not force:
        raise ConfigError(f"{folder} already exists; use --force to overwrite")
    missing = [c for c in ("trial_id", "class") if c not in trials.columns]
    if missing:
        raise ConfigError(f"trials table lacks column(s) {missing}")
    n_trials = len(trials)
    if X is not None:
        n_sensors = X.shape[1]
    else:
        assert signals is not None  # exactly one of X and signals is given (checked above)
        n_sensors = len(signals[0])
    if sensors is None and n_sensors != 1:
        raise ConfigError(f"{n_sensors} sensors need names (sensors=...)")
    if sensors is not None and len(sensors) != n_sensors:
        raise ConfigError(f"sensors names {len(sensors)} sensors; the data has {n_sensors}")
    meta_cols = [c for c in ("trial_id", "class", "object", "object_id", "trial_index") if c in trials.columns]
    meta = trials[meta_cols].reset_index(drop=True)
    long = meta.loc[meta.index.repeat(n_sensors)].reset_index(drop=True)
    if sensors is not None:
        long["sensor"] = np.tile(np.asarray(sensors, dtype=object), n_trials)

    ensure_folder(folder.parent)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.tmp-", dir=folder.parent))
    try:
        cls = classes.astype(np.int64).rename_axis(CLASS_COLUMN).reset_index()
        cls.to_csv(tmp / CLASSES_FILE, index=False)
        if X is not None:
            if X.shape[0] != n_trials or feature_names is None or len(feature_names) != X.shape[2]:
                raise ConfigError(f"X has shape {X.shape}; needs {n_trials} trials and a name per feature")
            clash = [f for f in feature_names if f in TRIAL_RESERVED_COLUMNS]
            if clash:
                raise ConfigError(f"feature name(s) {clash} are reserved trials.csv columns")
            values = pd.DataFrame(np.asarray(X, dtype=np.float64).reshape(n_trials * n_sensors, -1),
                                  columns=list(feature_names))
            _write_trials(tmp, pd.concat([long, values], axis=1), table_format)
        else:
            assert signals is not None  # exactly one of X and signals is given (checked above)
            if channels is None:
                raise ConfigError("signals need channel names (channels=...)")
            _check_channel_names(channels, signal_format)
            (tmp / "signals").mkdir()
            names, used = [], set()
            for i, tid in enumerate(meta["trial_id"]):
                if len(signals[i]) != n_sensors:
                    raise ConfigError(f"trial {tid!r} has {len(signals[i])} signals; expected {n_sensors}")
                for s in range(n_sensors):
                    stem = _safe_name(tid) + (f"_{_safe_name(sensors[s])}" if sensors is not None else "")
                    if stem in used:
                        stem = f"{stem}_{i}_{s}"
                    used.add(stem)
                    rel = f"signals/{stem}.{signal_format}"
                    _write_signal(tmp / rel, np.asarray(signals[i][s], dtype=np.float64), channels)
                    names.append(rel)
            long["signal_file"] = names
            _write_trials(tmp, long, table_format)
        if attribute_groups is not None:
            pd.DataFrame({"attribute": list(attribute_groups), "group": list(attribute_groups.values())}).to_csv(
                tmp / GROUPS_FILE, index=False)
        if settings:
            (tmp / SETTINGS_FILE).write_text(settings_to_toml(settings), encoding="utf-8")
        _install_folder(tmp, folder, force)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return folder


def _write_trials(tmp: Path, table: pd.DataFrame, table_format: str) -> None:
    if table_format == "parquet":
        table.to_parquet(tmp / TRIALS_PARQUET, index=False)
    else:
        table.to_csv(tmp / TRIALS_FILE, index=False)


def _check_channel_names(channels: Sequence[str], signal_format: str) -> None:
    """Refuse, in one line, channel names a signal file cannot give back exactly.

    Both formats: empty, repeated, or holding a NUL character (a zip member name ends at a NUL).
    CSV also: spaces around a name and pandas' ``Unnamed:`` prefix (the reader strips the one and
    refuses the other).
    """
    for k, name in enumerate(channels, start=1):
        if not isinstance(name, str):
            raise ConfigError(f"channel {k}, {name!r}, is not text; channel names are strings")
        if not name:
            raise ConfigError(f"channel {k} has an empty name; every channel needs a name")
        if "\0" in name:
            raise ConfigError(f"channel {k}, {name!r}, holds a NUL character, which no signal file can store")
        if signal_format == "csv" and name != name.strip():
            raise ConfigError(f"channel {k}, {name!r}, begins or ends with a space, which a CSV signal file "
                              "does not keep; rename it or use signal_format='npz'")
        if signal_format == "csv" and name.startswith("Unnamed:"):
            raise ConfigError(f"channel {k}, {name!r}, reads back from a CSV signal file as an unnamed column; "
                              "rename it or use signal_format='npz'")
    repeated = sorted({c for c in channels if channels.count(c) > 1})
    if repeated:
        raise ConfigError(f"channel name(s) {repeated} appear more than once; every channel needs its own name")


def _write_npz(path: Path, arrays: Sequence[tuple[str, np.ndarray]]) -> None:
    """Write ``arrays`` as a compressed ``.npz`` archive, whatever their names.

    The format of :func:`numpy.savez_compressed` (one deflated ``<name>.npy`` member per array,
    in order, read back by :func:`tzsl._io.read_npz` and :func:`numpy.load`), written member by
    member: ``savez_compressed(file, **arrays)`` takes the names as keyword arguments, so an
    array named ``file`` clashes with its first parameter and one named ``allow_pickle`` is
    taken as that option and never written.
    """
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
        for name, array in arrays:
            member = zipfile.ZipInfo(name + ".npy")
            if member.filename != name + ".npy":  # a NUL (anywhere), a path separator other than / (Windows)
                raise ConfigError(f"array name {name!r} cannot be stored in an .npz archive")
            member.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(member, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.ascontiguousarray(array), allow_pickle=False)


def _write_signal(path: Path, values: np.ndarray, channels: Sequence[str]) -> None:
    if values.ndim != 2 or values.shape[1] != len(channels):
        raise ConfigError(f"signal for {path.name} has shape {values.shape}; expected (n_rows, {len(channels)})")
    if path.suffix == ".npz":
        _write_npz(path, [(c, values[:, j]) for j, c in enumerate(channels)])
    else:
        pd.DataFrame(values, columns=list(channels)).to_csv(path, index=False)


def feature_set_to_plain(
    features: FeatureSet,
    folder: str | os.PathLike,
    *,
    settings: Mapping | None = None,
    force: bool = False,
) -> Path:
    """Write a :class:`~tzsl.datasets.FeatureSet` as a plain-file dataset with feature columns.

    Classes: ``features.info["classes"]`` and ``features.trials["class"]`` when present
    (a FeatureSet read from a plain folder); otherwise every object is its own class and
    ``classes.csv`` is the object-attribute table. ``trials.csv`` gets one row per trial and
    sensor with ``trial_id``, ``class``, ``object``, ``object_id``, ``trial_index``,
    ``sensor`` and the features. ``dataset.toml`` gets ``name`` = ``features.dataset`` and,
    when two classes share an attribute row, ``[classes] allow_identical_rows = true``;
    ``settings`` entries are merged over these.
    """
    trials = features.trials
    if "class" in trials.columns and isinstance(features.info.get("classes"), pd.DataFrame):
        classes = features.info["classes"]
        cls = trials["class"].to_numpy()
    else:
        classes = features.attributes.rename_axis(CLASS_COLUMN)
        cls = trials["object_name"].to_numpy()
    table = pd.DataFrame({
        "trial_id": trials["trial_id"].to_numpy(),
        "class": cls,
        "object": trials["object_name"].to_numpy(),
        "object_id": trials["object_id"].to_numpy(),
        "trial_index": trials["trial_index"].to_numpy(),
    })
    merged: dict = {"name": features.dataset} if features.dataset else {}
    if classes.duplicated().any():
        merged["classes"] = {"allow_identical_rows": True}
    for key, value in (settings or {}).items():
        if isinstance(value, Mapping):
            merged.setdefault(key, {}).update(value)
        else:
            merged[key] = value
    groups = features.info.get("attribute_groups")
    return write_plain_dataset(folder, classes, table, sensors=features.sensors, X=features.X,
                               feature_names=features.feature_names, attribute_groups=groups,
                               settings=merged, force=force)


__all__ = ["feature_set_to_plain", "settings_to_toml", "write_plain_dataset"]
