"""Plain-file datasets -> :class:`~tzsl.datasets.FeatureSet` (features from columns or signals).

:func:`load_plain_dataset` is the one call that turns a dataset folder (format in
``data/README.md``) into the FeatureSet every later layer uses: feature columns are taken as
they are; signal files are summarised per channel by
:class:`~tzsl.features.SignalStatistics` with the settings of ``dataset.toml`` (or the
arguments, which win). Also :func:`raw_trial_signals`, the 23 BioTac channels of a raw
PHAC-2 trial as plain arrays (used to write PHAC-2 as a signal dataset).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from tzsl.datasets import FeatureSet, PlainDataset, RawTrial, read_plain_dataset, read_signal_table
from tzsl.exceptions import ConfigError
from tzsl.features._attribute_filter import filter_attributes
from tzsl.features._baseline import check_raw_trial
from tzsl.features._rocket_features import SIGNAL_TRANSFORMS, RocketFeatures
from tzsl.features._signal_stats import (
    DEFAULT_SIGNAL_STATISTICS,
    SignalStatistics,
    check_statistics,
    min_rows_for,
)
from tzsl.features._time_average import biotac_channel_matrix

#: Trials summarised per batch (bounds the memory of the summary statistics' intermediate arrays).
_BATCH = 256

FEATURE_SOURCES = ("auto", "columns", "signals")


def plain_feature_set(
    data: PlainDataset,
    features: str = "auto",
    *,
    statistics: Sequence[str] | None = None,
    baseline_rows: int | None = None,
    channels: Sequence[str] | None = None,
    min_objects: int | None = None,
    n_jobs: int | None = None,
    cache: bool | str | os.PathLike | None = None,
) -> FeatureSet:
    """The FeatureSet of a read plain-file dataset.

    Parameters
    ----------
    data : PlainDataset
        From :func:`tzsl.datasets.read_plain_dataset`.
    features : {"auto", "columns", "signals"}, default "auto"
        What the dataset must hold; "auto" accepts either. A mismatch is a ConfigError.
    statistics : sequence of str, optional
        Per-channel statistics for signal datasets (names of
        :data:`~tzsl.features.SIGNAL_STATISTICS`, and ``"rocket"`` for the ROCKET features of
        :class:`~tzsl.features.RocketFeatures`, appended after the statistics; needs
        ``tzsl[timeseries]``); default ``[signals] statistics`` of ``dataset.toml``, else
        ``("mean", "std", "min", "max")``.
    baseline_rows : int, optional
        Baseline rows for signal datasets (0: none); default ``[signals] baseline_rows``,
        else 0.
    channels : sequence of str, optional
        Channels to use, in order; default ``data.channels``.
    min_objects : int, optional
        If given, keep only attributes present in at least this many objects with trials
        (:func:`~tzsl.features.filter_attributes`); dropped names go to
        ``info["dropped_attributes"]``. Default: keep every attribute of ``classes.csv``.
    n_jobs : int, optional
        Processes reading the signal files (joblib convention; default: this process only).
    cache : bool, path-like or None
        The consolidated signal cache of :func:`tzsl.datasets.read_signal_table`: a cache folder,
        ``True`` (the default cache folder), ``False`` (none) or ``None`` (``$TZSL_CACHE_DIR`` if
        set, else none).

    Returns
    -------
    FeatureSet
        ``X`` (n_trials, n_sensors, d): the feature columns, or for signals
        ``d = n_channels * n_statistics`` named ``"<channel>_<statistic>"`` (channel-major,
        in signal units), then with ``"rocket"`` the ``n_channels * 2 * 25`` ROCKET features
        (:data:`~tzsl.features.DEFAULT_ROCKET_KERNELS` kernels); see
        :meth:`tzsl.datasets.PlainDataset.to_feature_set` for the rest. ``info`` also holds
        ``statistics``, ``baseline_rows`` and ``channels`` for signal datasets.

    Raises
    ------
    ConfigError
        Bad ``features`` / ``statistics`` / ``baseline_rows`` / ``channels``.
    DataFileError
        A signal file that cannot be read or fails its checks (names file and trial).
    """
    if features not in FEATURE_SOURCES:
        raise ConfigError(f"features must be one of {FEATURE_SOURCES}, got {features!r}")
    if features != "auto" and features != data.kind:
        have = "feature columns" if data.kind == "columns" else "signal files"
        raise ConfigError(f"{data.folder}: features={features!r} but the dataset has {have}")
    if data.kind == "columns":
        if statistics is not None or baseline_rows is not None or channels is not None:
            raise ConfigError(f"{data.folder}: statistics/baseline_rows/channels apply to signal datasets only")
        result = data.to_feature_set()
    else:
        result = _signal_feature_set(data, statistics, baseline_rows, channels, n_jobs, cache)
    if min_objects is not None:
        kept, dropped = filter_attributes(result.attributes, min_objects)
        result.attributes = kept
        result.info["dropped_attributes"] = dropped
        result.info["min_objects"] = int(min_objects)
    return result


def _signal_feature_set(
    data: PlainDataset,
    statistics: Sequence[str] | None,
    baseline_rows: int | None,
    channels: Sequence[str] | None,
    n_jobs: int | None,
    cache: bool | str | os.PathLike | None,
) -> FeatureSet:
    config = data.settings.get("signals", {})
    named = tuple(statistics) if statistics is not None else tuple(config.get("statistics", DEFAULT_SIGNAL_STATISTICS))
    stats, transforms = split_signal_features(named)
    baseline = int(config.get("baseline_rows", 0)) if baseline_rows is None else baseline_rows
    if channels is not None:
        if isinstance(channels, str) or not isinstance(channels, Sequence) or not channels:
            raise ConfigError(f"channels must be a non-empty sequence of names, got {channels!r}")
        data = _with_channels(data, tuple(channels))
    need = max(min_rows_for(stats, baseline), 2 if transforms else 1)
    extractors: list[SignalStatistics | RocketFeatures] = []
    if stats:
        extractors.append(SignalStatistics(statistics=stats, baseline_rows=baseline or None, channels=data.channels))
    if "rocket" in transforms:  # kernels of seed 0, the same for every split and run
        extractors.append(RocketFeatures(baseline_rows=baseline or None, channels=data.channels, random_state=0))
    n_trials, n_sensors = data.n_trials, len(data.sensors)
    table = read_signal_table(data, need, n_jobs=n_jobs, cache=cache)
    first = table.signals(0, 0, 1)
    for extractor in extractors:
        extractor.fit(first)  # reads the channel count only (each trial is summarised on its own)
    names = [n for extractor in extractors for n in extractor.get_feature_names_out()]
    X = np.empty((n_trials, n_sensors, len(names)))
    for s in range(n_sensors):
        for lo in range(0, n_trials, _BATCH):
            batch = table.signals(s, lo, min(lo + _BATCH, n_trials))
            X[lo:lo + len(batch), s] = np.concatenate([e.transform(batch) for e in extractors], axis=1)
    return data.to_feature_set(
        X, tuple(names),
        info={"statistics": list(named), "baseline_rows": int(baseline or 0), "channels": list(data.channels)},
    )


def split_signal_features(names: object) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """A ``statistics`` setting -> (its per-channel statistics, its transforms), in the given order.

    Parameters
    ----------
    names : sequence of str
        Names of :data:`~tzsl.features.SIGNAL_STATISTICS` and of
        :data:`~tzsl.features.SIGNAL_TRANSFORMS` (``"rocket"``), each at most once; at least one.

    Returns
    -------
    tuple of str, tuple of str
        The statistics (checked; may be empty when a transform is named) and the transforms.

    Raises
    ------
    ConfigError
        Not a non-empty sequence of distinct known names (one line listing the known names).
    """
    if isinstance(names, str) or not isinstance(names, Sequence) or len(names) == 0:
        return check_statistics(names), ()  # its one-line error
    transforms = tuple(n for n in names if n in SIGNAL_TRANSFORMS)
    stats = tuple(n for n in names if n not in SIGNAL_TRANSFORMS)
    if len(set(transforms)) != len(transforms):
        raise ConfigError(f"statistics lists a name twice: {list(names)}")
    if stats:
        try:
            check_statistics(stats)
        except ConfigError as exc:
            raise ConfigError(f"{exc}, or the transform(s) {', '.join(SIGNAL_TRANSFORMS)}") from None
    return stats, transforms


def _with_channels(data: PlainDataset, channels: tuple[str, ...]) -> PlainDataset:
    if len(set(channels)) != len(channels):
        raise ConfigError(f"channels lists a name twice: {list(channels)}")
    from dataclasses import replace  # noqa: PLC0415

    return replace(data, channels=channels)


def load_plain_dataset(
    folder: str | os.PathLike,
    features: str = "auto",
    *,
    statistics: Sequence[str] | None = None,
    baseline_rows: int | None = None,
    channels: Sequence[str] | None = None,
    min_objects: int | None = None,
    n_jobs: int | None = None,
    cache: bool | str | os.PathLike | None = None,
) -> FeatureSet:
    """Read a plain-file dataset folder into a FeatureSet, in one call.

    ``read_plain_dataset(folder)`` (checks every file, raising a DataFileError that lists
    every problem with file and line) followed by :func:`plain_feature_set` (parameters
    documented there).

    Examples
    --------
    >>> fs = load_plain_dataset("my_dataset")                       # doctest: +SKIP
    >>> fs.X.shape, fs.attributes.shape, fs.info["classes"].shape   # doctest: +SKIP
    """
    return plain_feature_set(read_plain_dataset(folder), features, statistics=statistics,
                             baseline_rows=baseline_rows, channels=channels, min_objects=min_objects,
                             n_jobs=n_jobs, cache=cache)


def raw_trial_signals(trial: RawTrial) -> list[np.ndarray]:
    """The 23 BioTac channels of every finger of a raw trial, as plain arrays.

    Parameters
    ----------
    trial : RawTrial
        One trial (checked here).

    Returns
    -------
    list of ndarray of float64, one per finger, each of shape (n, 23)
        Columns in :data:`~tzsl.features.BIOTAC_CHANNELS` order (``pac`` = the mean of the
        row's 22 sub-samples), raw ADC counts. With ``baseline_rows=100`` and the
        statistic ``mean``, :class:`SignalStatistics` over all rows gives the paper's
        time averages (for the HOLD-only files, whose recording is the HOLD EP).
    """
    check_raw_trial(trial)
    return list(biotac_channel_matrix(trial))
