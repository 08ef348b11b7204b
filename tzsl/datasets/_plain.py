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

import os
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._plain_write import feature_set_to_plain, settings_to_toml, write_plain_dataset
from tzsl.datasets._signal_files import read_checked_signal
from tzsl.datasets._types import FeatureSet
from tzsl.datasets._validate import (
    DEFAULT_SENSOR,
    SPLITS_FILE,
    TRIALS_FILE,
    scan_dataset,
)
from tzsl.exceptions import ConfigError, DataFileError, TzslError, problems_error

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
        return self._read_signal(trial, sensor, min_rows, None)

    def _read_signal(self, trial: int, sensor: int, min_rows: int, root: str | None) -> np.ndarray:
        """:meth:`read_signal`; ``root`` = ``os.path.realpath(self.folder)`` when reading many."""
        if self.signal_files is None or self.channels is None:
            raise DataFileError(self.folder, "dataset has feature columns, not signal files")
        return read_checked_signal(self.folder, str(self.signal_files[trial, sensor]),
                                   str(self.trials["trial_id"].iat[trial]), self.channels, min_rows, root)

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
        root = os.path.realpath(self.folder)
        if n_threads <= 1 or len(trials) < 2:
            return [self._read_signal(i, sensor, min_rows, root) for i in trials]
        with ThreadPoolExecutor(max_workers=n_threads) as pool:
            return list(pool.map(lambda i: self._read_signal(i, sensor, min_rows, root), trials))

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
            if self.X is None or self.feature_names is None:  # set together
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


def _problem_error(folder: Path, problems: list) -> TzslError:
    """The error of a dataset's problems: each names its file inside ``folder`` and its line."""
    errors = [DataFileError(Path(folder) / p.file, p.message, line=p.line) for p in problems]
    error = problems_error(errors, folder, error=lambda message: DataFileError(None, message),
                           hint=f" (all: tzsl validate {folder})")
    assert error is not None  # the callers pass at least one problem
    return error


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
    assert meta is not None  # scan_dataset reads the trials of a folder without problems
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


__all__ = [
    "DEFAULT_SENSOR",
    "PLAIN_FORMAT_HELP",
    "PlainDataset",
    "feature_set_to_plain",
    "read_plain_dataset",
    "settings_to_toml",
    "write_plain_dataset",
]
