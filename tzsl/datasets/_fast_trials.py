"""Columnar reading of a clean trials table (CSV or Parquet): :func:`read_clean_trials`.

The checker in :mod:`tzsl.datasets._validate` walks the table row by row so that every problem
gets its line; at 100,000 trials x 2 sensors that walk (and parsing every number from text) takes
most of a minute. This module reads the table column-wise with pyarrow and checks the same rules
vectorised. It only ever *accepts* a table: whenever anything is off (a rule broken, a layout it
cannot map to lines, pyarrow missing) it returns None, and the row-by-row checker runs and
reports the problems with their lines. On a clean table both give identical results (the
floats are parsed with correct rounding by both).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._tables import TRIAL_RESERVED_COLUMNS

__all__ = ["CleanTrials", "read_clean_trials"]

_ID_COLUMNS = ("trial_id", "class", "object", "sensor", "signal_file")
_INT_COLUMNS = ("trial_index", "object_id")


@dataclass
class CleanTrials:
    """A checked trials table, in the checker's layout (see ``ScannedDataset``)."""

    trials: pd.DataFrame  # trial_id, class, object, trial_index, object_id, line
    sensors: tuple[str, ...] | None  # None: the table has no sensor column
    lines: np.ndarray  # (n_trials, n_sensors) line of each row
    kind: str  # "columns" or "signals"
    feature_names: tuple[str, ...] | None = None
    X: np.ndarray | None = None  # (n_trials, n_sensors, n_features)
    signal_files: np.ndarray | None = None  # (n_trials, n_sensors) of str


def _read_table(path: Path):
    """pyarrow Table of the file, or None (no pyarrow, unreadable, or rows not one per line)."""
    try:
        import pyarrow as pa  # noqa: PLC0415 - optional (the parquet extra)
        import pyarrow.csv as pcsv  # noqa: PLC0415
        import pyarrow.parquet as pq  # noqa: PLC0415
    except ImportError:
        return None
    try:
        if path.suffix == ".parquet":
            return pq.read_table(path)
        with open(path, "rb") as fh:
            raw = fh.read()
        head = raw[: raw.find(b"\n")].decode("utf-8-sig", errors="replace")
        types = {c.strip(): pa.string() for c in head.split(",") if c.strip() in _ID_COLUMNS}
        table = pcsv.read_csv(pa.BufferReader(raw), convert_options=pcsv.ConvertOptions(
            column_types=types, strings_can_be_null=False, quoted_strings_can_be_null=False))
        # line numbers are row + 2 only when every record is one non-empty line
        newlines = raw.count(b"\n") + (0 if raw.endswith(b"\n") else 1)
        if newlines != table.num_rows + 1 or b"\r" in raw or b'"' in raw:
            return None
        return table
    except Exception:  # noqa: BLE001 - anything unusual goes to the row-by-row checker
        return None


def read_clean_trials(path: Path, classes: set | None) -> CleanTrials | None:
    """The trials table at ``path`` if it breaks no rule of the format, else None.

    ``classes``: the class names of ``classes.csv`` (None: unknown, so never clean here).
    """
    if classes is None:
        return None
    table = _read_table(path)
    if table is None:
        return None
    header = [str(c) for c in table.column_names]
    if (len(set(header)) != len(header) or any(not h or h != h.strip() for h in header)
            or not {"trial_id", "class"} <= set(header)):
        return None
    features = [h for h in header if h not in TRIAL_RESERVED_COLUMNS]
    has_signals = "signal_file" in header
    if has_signals == bool(features) or table.num_rows == 0:
        return None
    cols: dict[str, np.ndarray] = {}
    for name in _ID_COLUMNS:
        if name in header:
            column = table.column(name)
            if str(column.type) not in ("string", "large_string") or column.null_count:
                return None
            values = column.to_numpy(zero_copy_only=False).astype(object)
            text = pd.Series(values, dtype=object)
            if (text.str.len() == 0).any() or (text.str.strip() != text).any():
                return None
            cols[name] = values
    for name in _INT_COLUMNS:
        if name in header:
            column = table.column(name)
            if not str(column.type).startswith(("int", "uint")) or column.null_count:
                return None
            cols[name] = column.to_numpy().astype(np.int64)
    n_rows = table.num_rows
    if not set(pd.unique(cols["class"])) <= classes:
        return None
    obj = cols.get("object", cols["class"])
    sensor = cols.get("sensor")
    frame = pd.DataFrame({"trial_id": cols["trial_id"], "class": cols["class"], "object": obj,
                          "sensor": sensor if sensor is not None else "",
                          **{k: cols[k] for k in _INT_COLUMNS if k in cols}})
    if frame.duplicated(["trial_id", "sensor"]).any():
        return None
    if (frame.groupby("object", sort=False)["class"].nunique() > 1).any():
        return None
    if "object_id" in frame and (frame.groupby("object", sort=False)["object_id"].nunique() > 1).any():
        return None
    per_trial = [c for c in ("class", "object", *_INT_COLUMNS) if c in frame]
    if (frame.groupby("trial_id", sort=False)[per_trial].nunique() > 1).any(axis=None):
        return None
    trial_code, trial_ids = pd.factorize(frame["trial_id"], sort=False)
    sensor_code, sensor_names = pd.factorize(frame["sensor"], sort=False)
    n_trials, n_sensors = len(trial_ids), len(sensor_names)
    if n_trials * n_sensors != n_rows:
        return None
    where = np.full((n_trials, n_sensors), -1, dtype=np.int64)
    where[trial_code, sensor_code] = np.arange(n_rows)
    lines = where + 2
    first = where.min(axis=1)  # the trial's first row (rows of a trial can be in any order)
    first_row = frame.iloc[first]
    trials = pd.DataFrame({"trial_id": first_row["trial_id"].to_numpy(), "class": first_row["class"].to_numpy(),
                           "object": first_row["object"].to_numpy()})
    for name in _INT_COLUMNS:
        trials[name] = pd.array(first_row[name].to_numpy() if name in frame else [None] * n_trials, dtype="Int64")
    trials["line"] = first + 2
    sensors = tuple(str(s) for s in sensor_names) if sensor is not None else None
    out = CleanTrials(trials=trials, sensors=sensors, lines=lines, kind="signals" if has_signals else "columns")
    if has_signals:
        out.signal_files = cols["signal_file"][where]
        return out
    X = np.empty((n_rows, len(features)))
    for j, name in enumerate(features):
        column = table.column(name)
        if not (str(column.type) in ("double", "float") or str(column.type).startswith(("int", "uint"))):
            return None
        if column.null_count:
            return None
        X[:, j] = column.to_numpy()
    if not np.isfinite(X).all():
        return None
    out.X = X[where.reshape(-1)].reshape(n_trials, n_sensors, len(features))
    out.feature_names = tuple(features)
    return out
