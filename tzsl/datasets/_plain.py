"""The plain-file dataset format: read and write a folder of CSV (and signal) files.

A user with their own sensor and attribute list describes a dataset with a few plain files
(:data:`PLAIN_FORMAT_HELP`, also in ``data/README.md`` and ``tzsl formats``).
:func:`read_plain_dataset` checks the folder (every problem at once, see
:func:`~tzsl.datasets.validate_dataset`) and returns a :class:`PlainDataset`; for feature
columns :meth:`PlainDataset.to_feature_set` gives the :class:`~tzsl.datasets.FeatureSet`
directly, for signal files the features come from
:func:`tzsl.features.plain_feature_set` / :func:`tzsl.features.load_plain_dataset`
(the data layer knows no feature extractor). :func:`write_plain_dataset` and
:func:`feature_set_to_plain` write a folder atomically.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from concurrent.futures import ThreadPoolExecutor
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import ensure_folder
from tzsl.datasets._types import FeatureSet
from tzsl.datasets._validate import (
    CLASS_COLUMN,
    CLASSES_FILE,
    DEFAULT_SENSOR,
    GROUPS_FILE,
    SETTINGS_FILE,
    SPLITS_FILE,
    TRIAL_RESERVED_COLUMNS,
    TRIALS_FILE,
    check_signal_values,
    read_signal_file,
    resolve_signal_path,
    scan_dataset,
)
from tzsl.exceptions import ConfigError, DataFileError

PLAIN_FORMAT_HELP = """\
A dataset is one folder. Paths inside it are relative to the folder; text files are UTF-8
CSV with one header line, comma-separated, one record per line (line numbers in messages
count the header as line 1).

classes.csv (required) - one row per class
    class,<attribute_1>,...,<attribute_k>
    First column "class": a unique, non-empty class name. Every other column is one
    attribute; each entry is 0 or 1 (0.0 / 1.0 accepted; empty or other text is an error).
    Two classes with the same attribute row are an error unless dataset.toml sets
    [classes] allow_identical_rows = true.

attribute_groups.csv (optional) - group attributes, e.g. material vs shape
    attribute,group
    One row per attribute of classes.csv; every attribute needs exactly one group.

trials.csv (required) - one row per trial and sensor
    Reserved columns:
      trial_id     (required) trial name; unique per sensor
      class        (required) a class of classes.csv
      object       (optional) object / instance name; default = the class. An object
                   belongs to one class; a class may have several objects. Splits and the
                   attribute table of a FeatureSet are per object.
      sensor       (optional) sensor name for multi-sensor data: then every trial has
                   exactly one row per sensor; without the column: one sensor "sensor_0"
      trial_index  (optional) integer; default = 1, 2, ... per object in file order
      object_id    (optional) integer per object; default = 0, 1, ... in file order
      signal_file  (optional) path of the trial's signal file (see below)
    Then EITHER feature columns: every column not reserved above is a feature, in file
    order, holding a finite number in every row (the feature names are the headers);
    OR a signal_file column and no other non-reserved column.

signal files (with signal_file) - one per trial and sensor, time x channels
    .npz: one 1-D numeric array per channel, named by the channel, all of equal length;
    .csv: a header line of channel names, then one line per time step (numbers only).
    Every file has the same channel names (order may differ; features follow the order
    of [signals] channels, else of the first file). No NaN/inf. Per-channel summary
    statistics over time give the features (see [signals] below).

splits.csv (optional) - object splits, long format (as tzsl.evaluation.read_splits_csv)
    split,object,role[,kind,seed]
    role is train or test; object is an object name of trials.csv.

dataset.toml (optional) - settings
    name = "my-dataset"            # dataset name (default: the folder name)
    [classes]
    allow_identical_rows = false   # true: classes may share an attribute row
    [signals]                      # only for signal files
    channels = ["p1", "p2"]        # channels used, in this order (default: all, as in
                                   #   the first file); files may hold more
    baseline_rows = 0              # >0: subtract each channel's mean over the first
                                   #   baseline_rows rows of the trial (0: none)
    statistics = ["mean", "std", "min", "max"]   # per-channel statistics, in order

Check a folder with: tzsl validate DATASET_DIR
"""


@dataclass
class PlainDataset:
    """A checked plain-file dataset folder.

    Attributes
    ----------
    folder : Path
    name : str
        ``name`` of ``dataset.toml``, else the folder name.
    classes : DataFrame (n_classes, n_attributes) of int64 0/1
        Index ``class`` (file order), columns = attributes (file order).
    trials : DataFrame with n_trials rows
        :data:`~tzsl.datasets.TRIAL_COLUMNS` (``object_name`` = the ``object`` column) plus
        ``class``; in order of first appearance in ``trials.csv``.
    sensors : tuple of str, length n_sensors
    kind : {"columns", "signals"}
    X : ndarray (n_trials, n_sensors, n_features) of float64, or None
        Feature columns (kind "columns").
    feature_names : tuple of str or None
    signal_files : ndarray (n_trials, n_sensors) of str, or None
        Signal file of every trial and sensor, relative to ``folder`` (kind "signals").
    channels : tuple of str or None
        Channels read from each signal file, in feature order.
    attribute_groups : dict attribute -> group, or None
    settings : dict
        ``dataset.toml`` content.
    splits_file : Path or None
        ``splits.csv`` when present (read it with :func:`tzsl.evaluation.read_splits_csv`
        against :attr:`object_attributes`).
    """

    folder: Path
    name: str
    classes: pd.DataFrame
    trials: pd.DataFrame
    sensors: tuple[str, ...]
    kind: str
    X: np.ndarray | None = None
    feature_names: tuple[str, ...] | None = None
    signal_files: np.ndarray | None = None
    channels: tuple[str, ...] | None = None
    attribute_groups: dict[str, str] | None = None
    settings: dict = field(default_factory=dict)
    splits_file: Path | None = None

    @property
    def n_trials(self) -> int:
        return len(self.trials)

    @property
    def object_attributes(self) -> pd.DataFrame:
        """Attribute row of every object's class, shape (n_objects, n_attributes), int64 0/1.

        Indexed by ``object_name`` in order of first appearance.
        """
        first = self.trials.drop_duplicates("object_name")
        table = self.classes.loc[first["class"].to_numpy()].copy()
        table.index = pd.Index(first["object_name"].to_numpy(), name="object_name")
        return table

    def read_signal(self, trial: int, sensor: int, min_rows: int = 1) -> np.ndarray:
        """The signal of one trial and sensor, shape (n_rows, n_channels), float64.

        Channels in :attr:`channels` order.

        Raises
        ------
        DataFileError
            Unreadable file, channels missing, fewer than ``min_rows`` rows, NaN/inf
            (names the file, the trial and, for CSV files, the line).
        """
        if self.signal_files is None or self.channels is None:
            raise DataFileError(self.folder, "dataset has feature columns, not signal files")
        rel = str(self.signal_files[trial, sensor])
        tid = str(self.trials["trial_id"].iat[trial])
        path, reason = resolve_signal_path(self.folder, rel)
        if path is None:
            raise DataFileError(self.folder / TRIALS_FILE, reason, trial=tid)
        channels, values = read_signal_file(path)
        absent = [c for c in self.channels if c not in channels]
        if absent:
            raise DataFileError(path, f"channel(s) {absent} missing (has {list(channels)})", trial=tid)
        values = values[:, [channels.index(c) for c in self.channels]]
        problems = check_signal_values(rel, self.channels, values, path.suffix.lower() == ".csv", min_rows)
        if problems:
            raise DataFileError(self.folder, "; ".join(map(str, problems)), trial=tid)
        return values

    def read_signals(self, trials: Sequence[int], sensor: int, min_rows: int = 1,
                     n_threads: int | None = None) -> list[np.ndarray]:
        """:meth:`read_signal` of several trials of one sensor, read in parallel threads.

        Reading is I/O and zlib/CSV parsing, which release the GIL, so threads overlap them.

        Parameters
        ----------
        trials : sequence of int
            Trial indices.
        sensor : int
        min_rows : int, default 1
        n_threads : int, optional
            Default: ``min(8, os.cpu_count() + 4)``; 1 reads in this thread.

        Returns
        -------
        list of ndarray (n_rows_i, n_channels)
            In the order of ``trials``; the first failing file raises its :class:`DataFileError`.
        """
        trials = list(trials)
        n_threads = min(8, (os.cpu_count() or 1) + 4) if n_threads is None else int(n_threads)
        if n_threads <= 1 or len(trials) < 2:
            return [self.read_signal(i, sensor, min_rows) for i in trials]
        with ThreadPoolExecutor(max_workers=n_threads) as pool:
            return list(pool.map(lambda i: self.read_signal(i, sensor, min_rows), trials))

    def to_feature_set(
        self,
        X: np.ndarray | None = None,
        feature_names: Sequence[str] | None = None,
        info: Mapping | None = None,
    ) -> FeatureSet:
        """The :class:`~tzsl.datasets.FeatureSet` of this dataset.

        Parameters
        ----------
        X : ndarray (n_trials, n_sensors, d), optional
            Features computed from the signal files; default: the feature columns.
        feature_names : sequence of str, length d, optional
            Names of ``X``'s features (required with ``X``).
        info : mapping, optional
            Extra entries for ``FeatureSet.info``.

        Returns
        -------
        FeatureSet
            ``trials`` with :data:`~tzsl.datasets.TRIAL_COLUMNS` and ``class``;
            ``attributes`` = :attr:`object_attributes`; ``info`` with ``source`` (folder),
            ``classes`` (the full class table, also classes without trials),
            ``attribute_groups``, ``features`` (kind), ``splits_file`` and ``settings``.
        """
        if X is None:
            if self.X is None:
                raise ConfigError(f"{self.folder}: a signal dataset needs its features computed "
                                  "(tzsl.features.load_plain_dataset)")
            X, feature_names = self.X, self.feature_names
        elif feature_names is None or len(feature_names) != X.shape[2]:
            raise ConfigError("feature_names must name every feature of X")
        if X.shape[:2] != (self.n_trials, len(self.sensors)):
            raise ConfigError(f"X has shape {X.shape}; expected ({self.n_trials}, {len(self.sensors)}, d)")
        return FeatureSet(
            X=np.asarray(X, dtype=np.float64),
            trials=self.trials.copy(),
            sensors=self.sensors,
            feature_names=tuple(feature_names),
            attributes=self.object_attributes,
            dataset=self.name,
            info={
                "source": str(self.folder),
                "classes": self.classes.copy(),
                "attribute_groups": None if self.attribute_groups is None else dict(self.attribute_groups),
                "features": self.kind,
                "splits_file": None if self.splits_file is None else str(self.splits_file),
                "settings": dict(self.settings),
                **dict(info or {}),
            },
        )


def _problem_error(folder: Path, problems: list) -> DataFileError:
    shown = "\n  ".join(map(str, problems[:20]))
    more = f"\n  ... and {len(problems) - 20} more" if len(problems) > 20 else ""
    return DataFileError(folder, f"invalid dataset, {len(problems)} problem(s) (all: tzsl validate {folder}):\n  "
                         f"{shown}{more}")


def read_plain_dataset(folder: str | os.PathLike) -> PlainDataset:
    """Read and check a plain-file dataset folder.

    Every file but the signal files is checked as by
    :func:`~tzsl.datasets.validate_dataset`; signal files are only checked to exist (each
    is checked when read, :meth:`PlainDataset.read_signal`).

    Parameters
    ----------
    folder : path-like
        The dataset folder (format: :data:`PLAIN_FORMAT_HELP`).

    Returns
    -------
    PlainDataset

    Raises
    ------
    DataFileError
        The folder has problems; the message lists them with file and line.
    """
    folder = Path(folder)
    scan, problems = scan_dataset(folder, check_signals=False)
    if problems:
        raise _problem_error(folder, problems)
    meta = scan.trials
    objects = pd.unique(meta["object"])
    object_pos = {o: i for i, o in enumerate(objects)}
    object_id = meta["object_id"].copy()
    missing_id = object_id.isna().to_numpy()
    if missing_id.any():
        if not missing_id.all():
            raise DataFileError(folder / TRIALS_FILE, "object_id must be given for every trial or for none")
        object_id = meta["object"].map(object_pos)
    trial_index = meta["trial_index"].copy()
    if trial_index.isna().any():
        if not trial_index.isna().all():
            raise DataFileError(folder / TRIALS_FILE, "trial_index must be given for every trial or for none")
        trial_index = meta.groupby("object", sort=False).cumcount() + 1
    trials = pd.DataFrame({
        "trial_id": meta["trial_id"].astype(str).to_numpy(),
        "object_id": object_id.to_numpy(dtype=np.int64),
        "object_name": meta["object"].astype(str).to_numpy(),
        "trial_index": trial_index.to_numpy(dtype=np.int64),
        "class": meta["class"].astype(str).to_numpy(),
    })
    splits = folder / SPLITS_FILE
    return PlainDataset(
        folder=folder,
        name=str(scan.settings.get("name") or folder.resolve().name),
        classes=scan.classes,
        trials=trials,
        sensors=scan.sensors,
        kind=str(scan.kind),
        X=scan.X,
        feature_names=scan.feature_names,
        signal_files=scan.signal_files,
        channels=scan.channels,
        attribute_groups=scan.attribute_groups,
        settings=scan.settings,
        splits_file=splits if splits.is_file() else None,
    )


# --------------------------------------------------------------------------- writing


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise ConfigError(f"cannot write {value!r} to {SETTINGS_FILE}")


def settings_to_toml(settings: Mapping) -> str:
    """``dataset.toml`` text of a settings mapping (top-level scalars, then one-level tables)."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in settings.items() if not isinstance(v, Mapping)]
    for table, entries in settings.items():
        if isinstance(entries, Mapping):
            lines += ["", f"[{table}]"] + [f"{k} = {_toml_value(v)}" for k, v in entries.items()]
    return "\n".join(lines) + "\n"


def _safe_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", str(text)).strip("._") or "trial"


def _looks_like_dataset(folder: Path) -> bool:
    return any((folder / name).exists() for name in (CLASSES_FILE, TRIALS_FILE, "trials.parquet"))


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
    if folder.exists() and folder.is_dir() and any(folder.iterdir()) and not force:
        raise ConfigError(f"{folder} already exists; use --force to overwrite")
    missing = [c for c in ("trial_id", "class") if c not in trials.columns]
    if missing:
        raise ConfigError(f"trials table lacks column(s) {missing}")
    n_trials = len(trials)
    n_sensors = X.shape[1] if X is not None else len(signals[0])
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
            pd.concat([long, values], axis=1).to_csv(tmp / TRIALS_FILE, index=False)
        else:
            if channels is None:
                raise ConfigError("signals need channel names (channels=...)")
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
            long.to_csv(tmp / TRIALS_FILE, index=False)
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


def _write_signal(path: Path, values: np.ndarray, channels: Sequence[str]) -> None:
    if values.ndim != 2 or values.shape[1] != len(channels):
        raise ConfigError(f"signal for {path.name} has shape {values.shape}; expected (n_rows, {len(channels)})")
    if path.suffix == ".npz":
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **{c: values[:, j] for j, c in enumerate(channels)})
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


__all__ = [
    "DEFAULT_SENSOR",
    "PLAIN_FORMAT_HELP",
    "PlainDataset",
    "feature_set_to_plain",
    "read_plain_dataset",
    "settings_to_toml",
    "write_plain_dataset",
]
