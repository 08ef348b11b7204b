"""Check a plain-file dataset folder and list every problem, each with file and line.

The format itself is described in ``data/README.md`` ("Plain-file dataset format") and by
``tzsl formats``; :mod:`tzsl.datasets._plain` reads and writes it. This module holds the
format's vocabulary (file names, reserved columns, ``dataset.toml`` keys) and the one scan
both the validator and the reader use: :func:`scan_dataset` parses every file, collects a
:class:`Problem` for everything wrong (it never stops at the first) and returns what it
could parse.

Line numbers are those of the text file, 1-based, the header being line 1 (blank lines are
skipped but counted). Rows must not contain line breaks inside quoted cells.
"""

from __future__ import annotations

import csv
import math
import os
import re
import tomllib
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np
import pandas as pd

from tzsl._io import looks_binary, read_npz
from tzsl.datasets._paths import check_inside, resolve_inside
from tzsl.exceptions import DataFileError

CLASSES_FILE = "classes.csv"
TRIALS_FILE = "trials.csv"
#: The trials table may be Parquet instead (needs pyarrow: the ``parquet`` extra).
TRIALS_PARQUET = "trials.parquet"
GROUPS_FILE = "attribute_groups.csv"
SPLITS_FILE = "splits.csv"
SETTINGS_FILE = "dataset.toml"

#: First column of ``classes.csv``.
CLASS_COLUMN = "class"
#: Columns of ``trials.csv`` that are never features.
TRIAL_RESERVED_COLUMNS: tuple[str, ...] = (
    "trial_id", "class", "object", "sensor", "signal_file", "trial_index", "object_id",
)
#: Sensor name of datasets whose ``trials.csv`` has no ``sensor`` column.
DEFAULT_SENSOR = "sensor_0"
#: Suffixes of per-trial signal files.
SIGNAL_SUFFIXES: tuple[str, ...] = (".npz", ".csv")
#: Text accepted in an attribute cell of ``classes.csv``.
BINARY_TEXT = {"0": 0, "1": 1, "0.0": 0, "1.0": 1}
#: ``dataset.toml``: table -> key -> expected type ("" is the top level).
SETTINGS_SCHEMA: dict[str, dict[str, type]] = {
    "": {"name": str},
    "classes": {"allow_identical_rows": bool},
    "signals": {"channels": list, "baseline_rows": int, "statistics": list},
}
SPLIT_COLUMNS = ("split", "object", "role")
SPLIT_ROLES = ("train", "test")


@dataclass(frozen=True)
class Problem:
    """One problem in a dataset folder.

    Attributes
    ----------
    file : str
        Path of the file relative to the dataset folder (``"trials.csv"``,
        ``"signals/t01.npz"``).
    line : int or None
        1-based line of the text file (header = line 1); None when the problem concerns the
        whole file or a binary file.
    message : str
        What is wrong, in words a user can act on.
    """

    file: str
    line: int | None
    message: str

    def __str__(self) -> str:
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        return f"{where}: {self.message}"


@dataclass
class ScannedDataset:
    """What :func:`scan_dataset` could parse (parts with problems are left out or None).

    Attributes
    ----------
    folder : Path
    settings : dict
        ``dataset.toml`` content (``{}`` without the file).
    classes : DataFrame (n_classes, n_attributes) of int64 0/1, or None
        Indexed by class name (index name ``"class"``), columns = attributes in file order.
    attribute_groups : dict attribute -> group, or None
    trials : DataFrame or None
        One row per trial in order of first appearance: ``trial_id``, ``class``,
        ``object``, ``trial_index`` (int or <NA>), ``object_id`` (int or <NA>), ``line``
        (first line of the trial in ``trials.csv``).
    sensors : tuple of str
        In order of first appearance (``(DEFAULT_SENSOR,)`` without a ``sensor`` column).
    kind : {"columns", "signals"} or None
    X : ndarray (n_trials, n_sensors, n_features) of float64, or None
        Feature columns (kind "columns"); missing entries are NaN.
    feature_names : tuple of str or None
    signal_files : ndarray (n_trials, n_sensors) of str, or None
        Paths relative to the folder (kind "signals"); ``""`` where missing.
    signal_lines : ndarray (n_trials, n_sensors) of int, or None
        Line of each (trial, sensor) row in ``trials.csv``.
    channels : tuple of str or None
        From ``[signals] channels`` or the first readable signal file.
    """

    folder: Path
    settings: dict = field(default_factory=dict)
    classes: pd.DataFrame | None = None
    class_lines: dict[str, int] = field(default_factory=dict)
    attribute_groups: dict[str, str] | None = None
    trials: pd.DataFrame | None = None
    sensors: tuple[str, ...] = ()
    kind: str | None = None
    X: np.ndarray | None = None
    feature_names: tuple[str, ...] | None = None
    signal_files: np.ndarray | None = None
    signal_lines: np.ndarray | None = None
    channels: tuple[str, ...] | None = None
    signal_rows: np.ndarray | None = None


# --------------------------------------------------------------------------- helpers


def trials_file_name(folder: Path) -> str:
    """``trials.csv``, or ``trials.parquet`` when only that one exists."""
    if not (folder / TRIALS_FILE).exists() and (folder / TRIALS_PARQUET).exists():
        return TRIALS_PARQUET
    return TRIALS_FILE


def _read_parquet_rows(path: Path, name: str, problems: list[Problem]
                       ) -> tuple[list[str], list[tuple[int, list[str]]]] | None:
    """Header and (line, cells) rows of a Parquet table, as text (row r is "line" r + 2, as in CSV).

    Numbers become their shortest exact text (they read back to the same float64); nulls become ``""``.
    """
    try:
        import pyarrow.parquet as pq  # noqa: PLC0415 - optional: the parquet extra
    except ImportError:
        problems.append(Problem(name, None, "reading Parquet needs pyarrow: pip install 'tzsl[parquet]'"))
        return None
    try:
        frame = pq.read_table(path).to_pandas()
    except Exception as exc:  # noqa: BLE001 - pyarrow raises many types for corrupt files
        text = str(exc).strip().splitlines()
        problems.append(Problem(name, None, f"not a readable Parquet file ({text[0] if text else type(exc).__name__})"))
        return None
    header = [str(c).strip() for c in frame.columns]
    columns = []
    for c in frame.columns:
        col = frame[c]
        text = col.to_numpy().astype(str) if col.dtype.kind in "iufb" else col.astype("string").fillna("").to_numpy()
        if col.dtype.kind == "f":
            text = np.where(col.isna().to_numpy(), "", text)
        columns.append(np.char.strip(np.asarray(text, dtype=str)))
    cells = np.column_stack(columns).tolist() if columns else []
    return header, [(r + 2, row) for r, row in enumerate(cells)]


def _read_rows(
    folder: Path, name: str, problems: list[Problem], required: bool = True
) -> tuple[list[str], list[tuple[int, list[str]]]] | None:
    """Header and (line, cells) rows of a CSV (or Parquet) file; None if absent or unreadable."""
    path = folder / name
    outside = check_inside(folder, name)
    if outside is not None:
        problems.append(Problem(name, None, outside))
        return None
    if name.endswith(".parquet") and path.is_file():
        return _read_parquet_rows(path, name, problems)
    if not path.is_file():
        if required:
            problems.append(Problem(name, None, f"file not found in {folder}"))
        return None
    rows: list[tuple[int, list[str]]] = []
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            header = next(reader, None)
            if header is None or not any(h.strip() for h in header):
                problems.append(Problem(name, 1, "file is empty; expected a header line"))
                return None
            header = [h.strip() for h in header]
            for row in reader:
                if not any(cell.strip() for cell in row):
                    continue
                line = reader.line_num
                if len(row) != len(header):
                    problems.append(Problem(name, line, f"row has {len(row)} fields; the header has {len(header)}"))
                    continue
                rows.append((line, [cell.strip() for cell in row]))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        problems.append(Problem(name, None, f"cannot read the file: {exc}"))
        return None
    empty = [i + 1 for i, h in enumerate(header) if not h]
    if empty:
        problems.append(Problem(name, 1, f"header column(s) {empty} have no name"))
    dup = sorted({h for h in header if h and header.count(h) > 1})
    if dup:
        problems.append(Problem(name, 1, f"header names column(s) {dup} more than once"))
    return header, rows


def _to_float(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Text cells -> float64 values (exact round trip) and a mask of cells that are not numbers."""
    cells = np.asarray(cells, dtype=str)
    try:
        return cells.astype(np.float64), np.zeros(cells.shape, dtype=bool)
    except ValueError:
        pass
    flat = cells.reshape(-1)
    values = np.full(flat.shape, np.nan)
    bad = np.zeros(flat.shape, dtype=bool)
    for k, text in enumerate(flat):  # only reached when some cell is not a number
        try:
            values[k] = float(text)
        except ValueError:
            bad[k] = True
    return values.reshape(cells.shape), bad.reshape(cells.shape)


def _key_line(folder: Path, table: str, key: str) -> int | None:
    """Line of ``key = ...`` inside ``[table]`` of dataset.toml (best effort, for messages)."""
    try:
        lines = (folder / SETTINGS_FILE).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    current = ""
    for i, text in enumerate(lines, start=1):
        stripped = text.strip()
        header = re.match(r"^\[\s*([^\]]+?)\s*\]", stripped)
        if header:
            current = header.group(1)
        elif current == table and re.match(rf"^{re.escape(key)}\s*=", stripped):
            return i
    return None


def _find_table(folder: Path, table: str) -> int | None:
    try:
        lines = (folder / SETTINGS_FILE).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    for i, text in enumerate(lines, start=1):
        if re.match(rf"^\[\s*{re.escape(table)}\s*\]", text.strip()):
            return i
    return None


def read_settings(folder: Path, problems: list[Problem]) -> dict:
    """``dataset.toml`` checked against :data:`SETTINGS_SCHEMA` (``{}`` without the file)."""
    path = folder / SETTINGS_FILE
    outside = check_inside(folder, SETTINGS_FILE)
    if outside is not None:
        problems.append(Problem(SETTINGS_FILE, None, outside))
        return {}
    if not path.is_file():
        return {}
    try:
        with open(path, "rb") as fh:
            settings = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        match = re.search(r"line (\d+)", str(exc))
        problems.append(Problem(SETTINGS_FILE, int(match.group(1)) if match else None, f"not valid TOML: {exc}"))
        return {}
    clean: dict = {}
    for key, value in settings.items():
        if key in SETTINGS_SCHEMA[""]:
            table, entries = "", {key: value}
        elif key in SETTINGS_SCHEMA and key:
            if not isinstance(value, dict):
                problems.append(Problem(SETTINGS_FILE, _key_line(folder, "", key), f"{key!r} must be a table [{key}]"))
                continue
            table, entries = key, value
        else:
            known = [k for k in SETTINGS_SCHEMA[""]] + [f"[{t}]" for t in SETTINGS_SCHEMA if t]
            problems.append(Problem(SETTINGS_FILE, _key_line(folder, "", key), f"unknown key {key!r}; known: {known}"))
            continue
        for sub, val in entries.items():
            where = _key_line(folder, table, sub)
            expected = SETTINGS_SCHEMA[table].get(sub)
            label = f"[{table}] {sub}" if table else sub
            if expected is None:
                problems.append(Problem(SETTINGS_FILE, where, f"unknown key {label!r}; known in "
                                        f"{'[' + table + ']' if table else 'the top level'}: "
                                        f"{sorted(SETTINGS_SCHEMA[table])}"))
                continue
            ok = isinstance(val, expected) and not (expected is int and isinstance(val, bool))
            if expected is list and ok:
                ok = len(val) > 0 and all(isinstance(v, str) and v for v in val) and len(set(val)) == len(val)
            if expected is int and ok:
                ok = val >= 0
            if not ok:
                want = {str: "a string", bool: "true or false", int: "an integer >= 0",
                        list: "a non-empty list of distinct non-empty strings"}[expected]
                problems.append(Problem(SETTINGS_FILE, where, f"{label} is {val!r}; expected {want}"))
                continue
            if table:
                clean.setdefault(table, {})[sub] = val
            else:
                clean[sub] = val
    return clean


def read_signal_file(path: str | os.PathLike) -> tuple[tuple[str, ...], np.ndarray]:
    """Read one per-trial signal file.

    Parameters
    ----------
    path : path-like
        ``.npz``: one 1-D numeric array per channel, all of the same length, named by the
        channel (channel order = order in the archive); ``.csv``: a header line of channel
        names, then one line per time step.

    Returns
    -------
    channels : tuple of str, length n_channels
    values : ndarray of float64, shape (n_rows, n_channels)
        May hold NaN/inf (checked by the caller, who knows the line numbers).

    Raises
    ------
    DataFileError
        Unreadable file, wrong suffix, no channels, arrays that are not 1-D numeric of one
        length, non-numeric CSV cells.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        arrays = read_npz(path)
        if not arrays:
            raise DataFileError(path, "archive holds no channel arrays")
        lengths = {}
        for name, arr in arrays.items():
            if arr.ndim != 1 or arr.dtype.kind not in "iufb":
                raise DataFileError(path, f"channel {name!r} has shape {arr.shape} and dtype {arr.dtype}; "
                                    "expected a 1-D numeric array per channel")
            lengths[name] = arr.shape[0]
        if len(set(lengths.values())) > 1:
            raise DataFileError(path, f"channels have different lengths: {lengths}")
        channels = tuple(arrays)
        values = np.column_stack([arrays[c].astype(np.float64) for c in channels])
        return channels, values
    if suffix == ".csv":
        return _read_signal_csv(path)
    raise DataFileError(path, f"unsupported signal file type {path.suffix!r}; use {' or '.join(SIGNAL_SUFFIXES)}")


def _first_line(exc: Exception) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def _read_signal_csv(path: Path) -> tuple[tuple[str, ...], np.ndarray]:
    """Channels and values of a signal CSV file (see :func:`read_signal_file`)."""
    try:
        if looks_binary(path):
            raise UnicodeDecodeError("utf-8", b"", 0, 1, "binary")
        frame = pd.read_csv(path, skip_blank_lines=False)
    except pd.errors.EmptyDataError:
        raise DataFileError(path, "file is empty; expected a header line of channel names", line=1) from None
    except pd.errors.ParserError as exc:
        match = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
        if match:
            want, line, saw = (int(g) for g in match.groups())
            raise DataFileError(path, f"line has {saw} fields; the header has {want}", line=line) from None
        raise DataFileError(path, f"not a readable CSV file ({_first_line(exc)})") from None
    except UnicodeDecodeError:
        raise DataFileError(path, "not a UTF-8 text file (a binary file given as CSV?)") from None
    except Exception as exc:  # noqa: BLE001 - pandas/OS raise many types for unreadable files
        raise DataFileError(path, f"not a readable CSV file ({type(exc).__name__}: {_first_line(exc)})") from None
    channels = tuple(str(c).strip() for c in frame.columns)
    if not channels:
        raise DataFileError(path, "no channel columns in the header", line=1)
    if not frame.index.equals(pd.RangeIndex(len(frame))):
        # pandas turns the surplus leading field(s) into the index when data lines are longer than the header
        extra = frame.index.nlevels
        trailing = frame.iloc[:, -1].isna().all() if frame.shape[1] else False
        hint = " (each data line ends with a trailing comma? remove it)" if extra == 1 and trailing else ""
        raise DataFileError(path, f"data lines have {len(channels) + extra} fields but the header names "
                            f"{len(channels)} channels{hint}", line=2)
    if len(set(channels)) != len(channels) or any(c.startswith("Unnamed:") for c in channels):
        raise DataFileError(path, f"channel names must be non-empty and distinct, got {list(channels)}", line=1)
    if frame.empty:
        raise DataFileError(path, "has a header line but no data lines", line=1)
    for c, col in zip(channels, frame.columns):
        if not pd.api.types.is_numeric_dtype(frame[col]):
            values = pd.to_numeric(frame[col], errors="coerce")
            bad = np.flatnonzero(values.isna() & frame[col].notna())
            if bad.size:
                raise DataFileError(path, f"channel {c!r} holds {frame[col].iloc[int(bad[0])]!r}, not a number",
                                    line=int(bad[0]) + 2)
    return channels, frame.to_numpy(dtype=np.float64)


def check_signal_values(
    rel: str, channels: Sequence[str], values: np.ndarray, csv_file: bool, min_rows: int = 1
) -> list[Problem]:
    """Problems of a read signal: too few rows, NaN/inf (first one located; counted)."""
    problems = []
    if values.shape[0] < min_rows:
        problems.append(Problem(rel, None, f"signal has {values.shape[0]} rows; at least {min_rows} needed"))
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = (int(v) for v in np.argwhere(bad)[0])
        what = "NaN or empty" if np.isnan(values[row, col]) else "infinite"
        count = int(bad.sum())
        if csv_file:
            problems.append(Problem(rel, row + 2, f"channel {channels[col]!r} is {what} "
                                    f"({count} non-finite value(s) in the file)"))
        else:
            problems.append(Problem(rel, None, f"channel {channels[col]!r} is {what} at row {row} "
                                    f"({count} non-finite value(s) in the file)"))
    return problems


def resolve_signal_path(folder: Path, text: str) -> tuple[Path | None, str | None]:
    """``signal_file`` cell -> resolved absolute path inside ``folder``, or None and why it is refused."""
    pure = PurePosixPath(text.replace("\\", "/"))
    if text and pure.suffix.lower() not in SIGNAL_SUFFIXES:
        return None, f"signal_file {text!r}: unsupported type {pure.suffix!r}; use {' or '.join(SIGNAL_SUFFIXES)}"
    return resolve_inside(folder, text, "signal_file")


# --------------------------------------------------------------------------- the scan


def _scan_classes(folder: Path, settings: dict, problems: list[Problem], scan: ScannedDataset) -> None:
    parsed = _read_rows(folder, CLASSES_FILE, problems)
    if parsed is None:
        return
    header, rows = parsed
    if header[0] != CLASS_COLUMN:
        problems.append(Problem(CLASSES_FILE, 1, f"first column must be {CLASS_COLUMN!r}, got {header[0]!r}"))
        return
    attributes = header[1:]
    if not attributes:
        problems.append(Problem(CLASSES_FILE, 1, "no attribute columns after 'class'"))
        return
    names, values, lines = [], [], []
    for line, cells in rows:
        name = cells[0]
        if not name:
            problems.append(Problem(CLASSES_FILE, line, "class name is empty"))
            continue
        if name in scan.class_lines:
            problems.append(Problem(CLASSES_FILE, line, f"class {name!r} is defined twice (also line "
                                    f"{scan.class_lines[name]})"))
            continue
        scan.class_lines[name] = line
        row = []
        for attr, text in zip(attributes, cells[1:]):
            if text not in BINARY_TEXT:
                shown = "empty" if not text else repr(text)
                problems.append(Problem(CLASSES_FILE, line, f"class {name!r}, attribute {attr!r}: entry is "
                                        f"{shown}; expected 0 or 1"))
                row.append(-1)
            else:
                row.append(BINARY_TEXT[text])
        names.append(name)
        values.append(row)
        lines.append(line)
    if not names:
        if rows:
            return
        problems.append(Problem(CLASSES_FILE, None, "no class rows"))
        return
    table = pd.DataFrame(np.array(values, dtype=np.int64), index=pd.Index(names, name=CLASS_COLUMN),
                         columns=pd.Index(attributes, name="attribute"))
    valid = (table.to_numpy() >= 0).all(axis=1)
    if valid.all() and len(valid) >= 2:  # judged only on a table without bad entries
        rows = table.to_numpy()
        for j in np.flatnonzero((rows == rows[0]).all(axis=0)):
            problems.append(Problem(CLASSES_FILE, 1, f"attribute {attributes[j]!r} is {rows[0, j]} for every class; "
                                    "no attribute classifier can be trained on one value: remove the column "
                                    "(or add a class that has the other value)"))
    if not settings.get("classes", {}).get("allow_identical_rows", False):
        first: dict[tuple, int] = {}
        for i in np.flatnonzero(valid):
            key = tuple(table.iloc[i])
            if key in first:
                j = first[key]
                problems.append(Problem(CLASSES_FILE, lines[i], f"class {names[i]!r} has the same attribute row "
                                        f"as class {names[j]!r} (line {lines[j]}); zero-shot learning cannot tell "
                                        "them apart (set [classes] allow_identical_rows = true in dataset.toml "
                                        "if this is intended)"))
            else:
                first[key] = i
    scan.classes = table


def _scan_groups(folder: Path, problems: list[Problem], scan: ScannedDataset) -> None:
    parsed = _read_rows(folder, GROUPS_FILE, problems, required=False)
    if parsed is None:
        return
    header, rows = parsed
    missing = [c for c in ("attribute", "group") if c not in header]
    if missing:
        problems.append(Problem(GROUPS_FILE, 1, f"header {header} lacks column(s) {missing}"))
        return
    ia, ig = header.index("attribute"), header.index("group")
    known = None if scan.classes is None else set(scan.classes.columns)
    groups: dict[str, str] = {}
    seen: dict[str, int] = {}
    for line, cells in rows:
        attr, group = cells[ia], cells[ig]
        if not attr or not group:
            problems.append(Problem(GROUPS_FILE, line, "attribute or group cell is empty"))
            continue
        if attr in seen:
            problems.append(Problem(GROUPS_FILE, line, f"attribute {attr!r} listed twice (also line {seen[attr]})"))
            continue
        seen[attr] = line
        if known is not None and attr not in known:
            problems.append(Problem(GROUPS_FILE, line, f"unknown attribute {attr!r}: not a column of {CLASSES_FILE}"))
            continue
        groups[attr] = group
    if known is not None:
        ungrouped = [a for a in scan.classes.columns if a not in seen]
        if ungrouped:
            problems.append(Problem(GROUPS_FILE, None, f"attribute(s) {ungrouped} of {CLASSES_FILE} have no group"))
    scan.attribute_groups = groups


def _int_cell(text: str) -> int | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return int(value) if math.isfinite(value) and value == int(value) else None


def _scan_trials(folder: Path, settings: dict, problems: list[Problem], scan: ScannedDataset,
                 check_signals: bool) -> None:
    tname = trials_file_name(folder)
    parsed = _read_rows(folder, tname, problems)
    if parsed is None:
        return
    header, rows = parsed
    missing = [c for c in ("trial_id", "class") if c not in header]
    if missing:
        problems.append(Problem(tname, 1, f"header lacks the column(s) {missing}"))
        return
    col = {name: i for i, name in enumerate(header)}
    features = [h for h in header if h and h not in TRIAL_RESERVED_COLUMNS]
    has_signals = "signal_file" in col
    if has_signals and features:
        problems.append(Problem(tname, 1, f"has a signal_file column and feature columns {features}; "
                                "a dataset has one or the other (every non-reserved column is a feature)"))
        return
    if not has_signals and not features:
        problems.append(Problem(tname, 1, "no feature columns and no signal_file column"))
        return
    scan.kind = "signals" if has_signals else "columns"
    classes = None if scan.classes is None else set(scan.classes.index)
    if not rows:
        problems.append(Problem(tname, None, "no trial rows"))
        return

    def cell(cells: list[str], name: str) -> str | None:
        return cells[col[name]] if name in col else None

    trial_pos: dict[str, int] = {}
    meta: list[dict] = []
    sensors: dict[str, int] = {}
    row_of: dict[tuple[str, str], int] = {}  # (trial, sensor) -> index into kept rows
    kept_rows: list[tuple[int, list[str]]] = []
    object_class: dict[str, tuple[str, int]] = {}
    object_ids: dict[str, tuple[int, int]] = {}
    for line, cells in rows:
        tid, cls = cell(cells, "trial_id"), cell(cells, "class")
        obj = cell(cells, "object")
        sensor = cell(cells, "sensor") if "sensor" in col else DEFAULT_SENSOR
        empty = [n for n, v in (("trial_id", tid), ("class", cls), ("object", obj), ("sensor", sensor))
                 if v is not None and not v]
        if empty:
            problems.append(Problem(tname, line, f"empty {', '.join(empty)} cell"))
            continue
        obj = obj if obj is not None else cls
        if classes is not None and cls not in classes:
            problems.append(Problem(tname, line, f"trial {tid!r}: class {cls!r} is not in {CLASSES_FILE}"))
        index_text, oid_text = cell(cells, "trial_index"), cell(cells, "object_id")
        trial_index = None if index_text is None else _int_cell(index_text)
        object_id = None if oid_text is None else _int_cell(oid_text)
        if index_text is not None and trial_index is None:
            problems.append(Problem(tname, line, f"trial {tid!r}: trial_index {index_text!r} is not an integer"))
        if oid_text is not None and object_id is None:
            problems.append(Problem(tname, line, f"trial {tid!r}: object_id {oid_text!r} is not an integer"))
        if (tid, sensor) in row_of:
            prev = kept_rows[row_of[(tid, sensor)]][0]
            what = f"trial id {tid!r}" + (f" with sensor {sensor!r}" if "sensor" in col else "")
            problems.append(Problem(tname, line, f"duplicate {what} (also line {prev})"))
            continue
        if obj in object_class and object_class[obj][0] != cls:
            prev_cls, prev_line = object_class[obj]
            problems.append(Problem(tname, line, f"object {obj!r} has class {cls!r} here but {prev_cls!r} "
                                    f"on line {prev_line}; an object belongs to one class"))
        object_class.setdefault(obj, (cls, line))
        if object_id is not None:
            if obj in object_ids and object_ids[obj][0] != object_id:
                problems.append(Problem(tname, line, f"object {obj!r} has object_id {object_id} here but "
                                        f"{object_ids[obj][0]} on line {object_ids[obj][1]}"))
            object_ids.setdefault(obj, (object_id, line))
        if tid in trial_pos:
            first = meta[trial_pos[tid]]
            diffs = [n for n, a, b in (("class", cls, first["class"]), ("object", obj, first["object"]),
                                       ("trial_index", trial_index, first["trial_index"]),
                                       ("object_id", object_id, first["object_id"])) if a != b]
            if diffs:
                problems.append(Problem(tname, line, f"trial {tid!r}: {', '.join(diffs)} differ(s) from its "
                                        f"row on line {first['line']}"))
        else:
            trial_pos[tid] = len(meta)
            meta.append({"trial_id": tid, "class": cls, "object": obj, "trial_index": trial_index,
                         "object_id": object_id, "line": line})
        sensors.setdefault(sensor, len(sensors))
        row_of[(tid, sensor)] = len(kept_rows)
        kept_rows.append((line, cells))

    if not meta:
        return
    sensor_names = tuple(sensors)
    n_trials, n_sensors = len(meta), len(sensor_names)
    where = np.full((n_trials, n_sensors), -1)
    for (tid, sensor), k in row_of.items():
        where[trial_pos[tid], sensors[sensor]] = k
    for i, s in np.argwhere(where < 0):
        have = [sensor_names[j] for j in np.flatnonzero(where[i] >= 0)]
        problems.append(Problem(tname, meta[i]["line"], f"trial {meta[i]['trial_id']!r} has no row for "
                                f"sensor {sensor_names[s]!r} (it has {have}; every trial needs one row per sensor)"))
    lines = np.array([kept_rows[k][0] if k >= 0 else 0 for k in where.reshape(-1)]).reshape(where.shape)
    scan.sensors = sensor_names
    scan.signal_lines = lines
    trials = pd.DataFrame(meta)
    for name in ("trial_index", "object_id"):
        trials[name] = pd.array([v for v in trials[name]], dtype="Int64")
    scan.trials = trials

    if scan.kind == "columns":
        idx = [col[f] for f in features]
        cells = np.array([[kept_rows[k][1][j] for j in idx] if k >= 0 else [""] * len(idx)
                          for k in where.reshape(-1)], dtype=str)
        values, bad = _to_float(cells)
        present = (where.reshape(-1) >= 0)[:, None]
        for r, j in np.argwhere((bad | ~np.isfinite(values)) & present):
            text = str(cells[r, j])
            line = int(lines.reshape(-1)[r])
            if not text:
                msg = "is empty"
            elif bad[r, j]:
                msg = f"is {text!r}, not a number"
            else:
                msg = f"is {text} (NaN/inf)"
            tid = meta[r // n_sensors]["trial_id"]
            problems.append(Problem(tname, line, f"trial {tid!r}: feature {features[j]!r} {msg}"))
        scan.X = np.where(bad, np.nan, values).reshape(n_trials, n_sensors, len(features))
        scan.feature_names = tuple(features)
        return

    # signals
    files = np.array([kept_rows[k][1][col["signal_file"]] if k >= 0 else "" for k in where.reshape(-1)],
                     dtype=object).reshape(where.shape)
    scan.signal_files = files
    configured = settings.get("signals", {}).get("channels")
    scan.channels = tuple(configured) if configured else None
    reference: str | None = None
    baseline = int(settings.get("signals", {}).get("baseline_rows", 0) or 0)
    n_rows = np.zeros(where.shape, dtype=np.int64)
    for i, s in np.argwhere(where >= 0):
        line, text = int(lines[i, s]), files[i, s]
        tid = meta[i]["trial_id"]
        path, reason = resolve_signal_path(folder, text)
        if path is None:
            problems.append(Problem(tname, line, f"trial {tid!r}: {reason}"))
            continue
        if not path.is_file():
            problems.append(Problem(tname, line, f"trial {tid!r}: signal file {text!r} not found"))
            continue
        if not check_signals and scan.channels is not None:
            continue
        try:
            channels, values = read_signal_file(path)
        except DataFileError as exc:
            problems.append(Problem(text, exc.line, f"{exc.problem} ({tname} line {line})"))
            continue
        n_rows[i, s] = values.shape[0]
        if scan.channels is None:
            scan.channels, reference = channels, text
        expected = scan.channels
        absent = [c for c in expected if c not in channels]
        if absent or (configured is None and set(channels) != set(expected)):
            extra = [c for c in channels if c not in expected]
            origin = f"[signals] channels of {SETTINGS_FILE}" if configured else f"the first signal file {reference!r}"
            detail = []
            if absent:
                detail.append(f"missing {absent}")
            if extra and configured is None:
                detail.append(f"extra {extra}")
            problems.append(Problem(text, None, f"has {len(channels)} channel(s), expected {len(expected)} as in "
                                    f"{origin}: {'; '.join(detail)} ({tname} line {line})"))
            continue
        if not check_signals:
            continue
        order = [channels.index(c) for c in expected]
        problems.extend(check_signal_values(text, expected, values[:, order], path.suffix.lower() == ".csv",
                                            min_rows=max(1, baseline)))
    scan.signal_rows = n_rows


def _scan_splits(folder: Path, problems: list[Problem], scan: ScannedDataset) -> None:
    parsed = _read_rows(folder, SPLITS_FILE, problems, required=False)
    if parsed is None:
        return
    header, rows = parsed
    missing = [c for c in SPLIT_COLUMNS if c not in header]
    if missing:
        problems.append(Problem(SPLITS_FILE, 1, f"header {header} lacks column(s) {missing}"))
        return
    io, ir = header.index("object"), header.index("role")
    objects = None if scan.trials is None else set(scan.trials["object"])
    for line, cells in rows:
        obj, role = cells[io], cells[ir]
        if objects is not None and obj not in objects:
            problems.append(Problem(SPLITS_FILE, line, f"unknown object {obj!r}: no trial in {TRIALS_FILE} has it"))
        if role not in SPLIT_ROLES:
            problems.append(Problem(SPLITS_FILE, line, f"role {role!r} is not one of {SPLIT_ROLES}"))


def scan_dataset(folder: str | os.PathLike, *, check_signals: bool = True) -> tuple[ScannedDataset, list[Problem]]:
    """Parse every file of a plain-file dataset folder and collect every problem.

    Parameters
    ----------
    folder : path-like
        The dataset folder.
    check_signals : bool, default True
        Read every signal file (channels, NaN/inf, row counts). False only checks that
        each exists (and reads the first for its channel names when ``dataset.toml`` names
        none); the reader uses this and checks each file when it computes features.

    Returns
    -------
    scan : ScannedDataset
    problems : list of Problem
        In file order: dataset.toml, classes.csv, attribute_groups.csv, trials.csv (and the
        signal files it names), splits.csv.
    """
    folder = Path(folder)
    problems: list[Problem] = []
    scan = ScannedDataset(folder=folder)
    if not folder.is_dir():
        return scan, [Problem(str(folder), None, "dataset folder not found")]
    scan.settings = read_settings(folder, problems)
    _scan_classes(folder, scan.settings, problems, scan)
    _scan_groups(folder, problems, scan)
    _scan_trials(folder, scan.settings, problems, scan, check_signals)
    if scan.kind == "columns" and "signals" in scan.settings:
        problems.append(Problem(SETTINGS_FILE, _key_line(folder, "", "signals") or _find_table(folder, "signals"),
                                f"[signals] settings given but {TRIALS_FILE} has feature columns, not signal_file"))
    _scan_splits(folder, problems, scan)
    return scan, problems


def validate_dataset(
    folder: str | os.PathLike, *, statistics: Collection[str] | None = None
) -> list[Problem]:
    """Every problem of a plain-file dataset folder (empty list when it is valid).

    Checks ``dataset.toml`` (syntax, unknown keys, types), ``classes.csv`` (header, empty
    or duplicate class names, entries other than 0/1, classes with identical attribute
    rows), ``attribute_groups.csv`` (unknown or repeated attributes, attributes without a
    group), ``trials.csv`` (required columns, classes missing from classes.csv, duplicate
    trial ids per sensor, trials missing a sensor row, inconsistent class/object of a
    trial, objects in two classes, non-numeric / empty / NaN / inf features, missing or
    unreadable signal files, channel names differing from ``[signals] channels`` or the
    first file, NaN/inf in signals, fewer rows than ``baseline_rows``) and ``splits.csv``
    (unknown objects, roles other than train/test). Every problem has its file and, for
    text files, its line.

    Parameters
    ----------
    folder : path-like
    statistics : collection of str, optional
        Names allowed in ``[signals] statistics`` (the data layer does not know the feature
        extractors: pass ``tzsl.features.SIGNAL_STATISTICS``); None skips this check.

    Returns
    -------
    list of Problem
    """
    scan, problems = scan_dataset(folder, check_signals=True)
    names = scan.settings.get("signals", {}).get("statistics")
    if statistics is not None and names:
        unknown = [s for s in names if s not in statistics]
        if unknown:
            problems.append(Problem(SETTINGS_FILE, _key_line(Path(folder), "signals", "statistics"),
                                    f"unknown statistic(s) {unknown}; choose from {', '.join(statistics)}"))
    return problems
