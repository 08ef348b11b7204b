"""``tzsl convert --from series``: a folder of per-trial time series and a label table.

Each line of the label table names one file (``.csv`` with a header of channel names, ``.npy``
time x k, or a plain-format ``.npz`` signal file) of one trial (and sensor). A bad line or file
is one line naming the label-table line or the file (and its line or row).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import read_npy, read_npz
from tzsl.datasets._lab_checks import (
    ChannelCheck,
    LabelRow,
    LabSource,
    TrialIds,
    Trials,
    check_signal,
    check_size,
    lab_error,
    progress_bar,
    read_label_table,
    to_float,
)
from tzsl.datasets._lab_mapping import SeriesMapping
from tzsl.datasets._signal_files import read_signal_file, signal_from_arrays

__all__ = ["SERIES_SUFFIXES", "UNNAMED_SENSOR", "read_series"]

#: The sensor of a label table without a ``sensor`` column (written without a sensor column).
UNNAMED_SENSOR = ""
#: File types a series label table may name.
SERIES_SUFFIXES = (".csv", ".npy", ".npz")


def _read(path: Path, source: LabSource[SeriesMapping], labels_path: Path,
          row: LabelRow) -> tuple[list[str], np.ndarray]:
    """Channels and values (n_rows, n_channels) of one series file, checked."""
    mapping: SeriesMapping = source.mapping
    suffix = path.suffix.lower()
    if suffix not in SERIES_SUFFIXES:
        raise lab_error(labels_path, f"file {row.cells['file']!r}: unsupported type {path.suffix!r}; use "
                                     f"{', '.join(SERIES_SUFFIXES)}", row.line)
    if not path.is_file():
        what = "is a folder, not a file" if path.is_dir() else "not found"
        raise lab_error(labels_path, f"file {row.cells['file']!r} {what}", row.line)
    if suffix == ".npz":  # each channel checked to fit float64 exactly before it is converted
        arrays = read_npz(path, limit=source.limit)
        for name, array in arrays.items():
            if array.dtype.kind in "iu":
                to_float(array, path, f"channel {name!r}")
        names, values = signal_from_arrays(path, arrays)
        check_signal(values, names, path, "")
        return list(names), values
    if suffix == ".csv":
        names, values = read_signal_file(path)
        check_signal(values, names, path, "", 2)
        return list(names), values
    array = read_npy(path, limit=source.limit)
    check_size(int(array.size), path, "array", source.limit)
    values = to_float(array, path, "array")
    if values.ndim not in (1, 2):
        raise lab_error(path, f"array of shape {values.shape}; expected (time,) or (time, k)")
    values = values[:, None] if values.ndim == 1 else values
    channels = mapping.channels or [f"ch{k}" for k in range(values.shape[1])]
    if values.shape[1] != len(channels):
        raise lab_error(path, f"array of shape {values.shape}; the mapping's channels name {len(channels)}: "
                              f"expected (time, {len(channels)})")
    check_signal(values, channels, path, "")
    return list(channels), values


def read_series(source: LabSource[SeriesMapping]) -> tuple[Trials, pd.DataFrame]:
    """Trials (trial -> sensor -> (channels, values (time, n_channels))) and their classes, in label order."""
    labels_path, labels = read_label_table(source, "labels", ("file", "trial_id", "class"), ("sensor",))
    trials: Trials = {}
    first: dict[str, LabelRow] = {}  # trial -> its first line
    ids, channels = TrialIds(), ChannelCheck()
    with progress_bar(labels, "series", source.progress) as bar:
        for row in bar:
            trial, sensor = row.cells["trial_id"], row.cells.get("sensor", UNNAMED_SENSOR)
            if "sensor" in row.cells and not sensor.strip():
                raise lab_error(labels_path, "empty sensor (the table has a sensor column)", row.line)
            which = f"trial {trial!r}" + (f", sensor {sensor!r}" if sensor != UNNAMED_SENSOR else "")
            ids.add((trial, sensor), which, labels_path, "", row.line)
            if trial in first and first[trial].cells["class"] != row.cells["class"]:
                raise lab_error(labels_path, f"trial {trial!r} has class {row.cells['class']!r} here and "
                                             f"{first[trial].cells['class']!r} on line {first[trial].line}", row.line)
            first.setdefault(trial, row)
            path = source.path(row.cells["file"], "file", labels_path, row.line)
            names, values = _read(path, source, labels_path, row)
            channels(names, path, f"{labels_path.name} line {row.line}, {which}")
            trials.setdefault(trial, {})[sensor] = (names, values)
    sensors = list(dict.fromkeys(s for per in trials.values() for s in per))
    for trial, per in trials.items():
        lacking = [s for s in sensors if s not in per]
        if lacking:
            raise lab_error(labels_path, f"trial {trial!r} has no line for sensor(s) {lacking} (other trials have "
                                         f"them); every trial needs a file per sensor", first[trial].line)
    table = pd.DataFrame({"trial_id": list(first), "class": [r.cells["class"] for r in first.values()]})
    return trials, table
