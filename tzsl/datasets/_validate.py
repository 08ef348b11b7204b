"""Check a plain-file dataset folder and list every problem, each with file and line.

The format itself is described in ``data/README.md`` ("Plain-file dataset format") and by
``tzsl formats``; :mod:`tzsl.datasets._plain` reads and writes it. The format's vocabulary
(file names, reserved columns, ``dataset.toml`` keys) and table readers are in
:mod:`tzsl.datasets._tables`, signal files in :mod:`tzsl.datasets._signal_files` (both
re-exported here). This module holds the one scan both the validator and the reader use:
:func:`scan_dataset` parses every file, collects a :class:`Problem` for everything wrong (it
never stops at the first) and returns what it could parse.

Line numbers are those of the text file, 1-based, the header being line 1 (blank lines are
skipped but counted). Rows must not contain line breaks inside quoted cells.
"""

from __future__ import annotations

import math
import os
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._fast_trials import read_clean_trials
from tzsl.datasets._paths import check_inside
from tzsl.datasets._signal_files import (
    check_signal_values,
    read_signal_file,
    resolve_signal_path,
)
from tzsl.datasets._tables import (  # noqa: F401 - the format's vocabulary, re-exported
    BINARY_TEXT,
    CLASS_COLUMN,
    CLASSES_FILE,
    DEFAULT_SENSOR,
    GROUPS_FILE,
    SETTINGS_FILE,
    SETTINGS_SCHEMA,
    SIGNAL_SUFFIXES,
    SPLIT_COLUMNS,
    SPLIT_ROLES,
    SPLITS_FILE,
    TRIAL_RESERVED_COLUMNS,
    TRIALS_FILE,
    TRIALS_PARQUET,
    Problem,
    find_table,
    key_line,
    read_rows,
    read_settings,
    to_float,
    trials_file_name,
)
from tzsl.exceptions import DataFileError


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


# --------------------------------------------------------------------------- the scan


def scan_classes(folder: Path, settings: dict, problems: list[Problem], scan: ScannedDataset,
                 file: str = CLASSES_FILE, settings_file: str = SETTINGS_FILE) -> None:
    """Check the class table ``folder/file`` into ``scan.classes`` (None if unparsable), adding to ``problems``;
    ``settings``: ``{"classes": {"allow_identical_rows": bool}}``, set in ``settings_file``."""
    parsed = read_rows(folder, file, problems)
    if parsed is None:
        return
    header, rows = parsed
    if header[0] != CLASS_COLUMN:
        problems.append(Problem(file, 1, f"first column must be {CLASS_COLUMN!r}, got {header[0]!r}"))
        return
    attributes = header[1:]
    if not attributes:
        problems.append(Problem(file, 1, "no attribute columns after 'class'"))
        return
    names, values, lines = [], [], []
    for line, cells in rows:
        name = cells[0]
        if not name:
            problems.append(Problem(file, line, "class name is empty"))
            continue
        if name in scan.class_lines:
            problems.append(Problem(file, line, f"class {name!r} is defined twice (also line "
                                    f"{scan.class_lines[name]})"))
            continue
        scan.class_lines[name] = line
        row = []
        for attr, text in zip(attributes, cells[1:], strict=True):
            if text not in BINARY_TEXT:
                shown = "empty" if not text else repr(text)
                problems.append(Problem(file, line, f"class {name!r}, attribute {attr!r}: entry is "
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
        problems.append(Problem(file, None, "no class rows"))
        return
    table = pd.DataFrame(np.array(values, dtype=np.int64), index=pd.Index(names, name=CLASS_COLUMN),
                         columns=pd.Index(attributes, name="attribute"))
    valid = (table.to_numpy() >= 0).all(axis=1)
    if valid.all() and len(valid) >= 2:  # judged only on a table without bad entries
        rows = table.to_numpy()
        for j in np.flatnonzero((rows == rows[0]).all(axis=0)):
            problems.append(Problem(file, 1, f"attribute {attributes[j]!r} is {rows[0, j]} for every class; "
                                    "no attribute classifier can be trained on one value: remove the column "
                                    "(or add a class that has the other value)"))
    if not settings.get("classes", {}).get("allow_identical_rows", False):
        first: dict[tuple, int] = {}
        for i in np.flatnonzero(valid).tolist():
            key = tuple(table.iloc[i])
            if key in first:
                earlier = first[key]
                problems.append(Problem(file, lines[i], f"class {names[i]!r} has the same attribute row "
                                        f"as class {names[earlier]!r} (line {lines[earlier]}); zero-shot learning "
                                        "cannot tell them apart (set [classes] allow_identical_rows = true in "
                                        f"{settings_file} if this is intended)"))
            else:
                first[key] = i
    scan.classes = table


def _scan_groups(folder: Path, problems: list[Problem], scan: ScannedDataset) -> None:
    parsed = read_rows(folder, GROUPS_FILE, problems, required=False)
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
    if scan.classes is not None:  # known is not None
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
    clean = None if check_inside(folder, tname) is not None or scan.classes is None else (
        read_clean_trials(folder / tname, set(scan.classes.index)))
    if clean is not None:  # a clean table read column-wise; otherwise the row-by-row checks below
        scan.kind, scan.trials, scan.signal_lines = clean.kind, clean.trials, clean.lines
        scan.sensors = clean.sensors or (DEFAULT_SENSOR,)
        scan.X, scan.feature_names = clean.X, clean.feature_names
        if clean.kind == "signals" and clean.signal_files is not None:  # set together
            present = np.ones(clean.signal_files.shape, dtype=bool)
            _scan_signal_files(folder, settings, problems, scan, clean.signal_files, present, check_signals, tname)
        return
    parsed = read_rows(folder, tname, problems)
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
        tid, cls = cells[col["trial_id"]], cells[col["class"]]  # required columns (checked above)
        obj = cell(cells, "object")
        sensor = cells[col["sensor"]] if "sensor" in col else DEFAULT_SENSOR
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
        table_cells = np.array([[kept_rows[k][1][j] for j in idx] if k >= 0 else [""] * len(idx)
                                for k in where.reshape(-1)], dtype=str)
        values, bad = to_float(table_cells)
        present = (where.reshape(-1) >= 0)[:, None]
        for r, j in np.argwhere((bad | ~np.isfinite(values)) & present):
            text = str(table_cells[r, j])
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

    files = np.array([kept_rows[k][1][col["signal_file"]] if k >= 0 else "" for k in where.reshape(-1)],
                     dtype=object).reshape(where.shape)
    _scan_signal_files(folder, settings, problems, scan, files, where >= 0, check_signals, tname)


def _scan_signal_files(folder: Path, settings: dict, problems: list[Problem], scan: ScannedDataset,
                       files: np.ndarray, present: np.ndarray, check_signals: bool, tname: str) -> None:
    """Check the signal files (n_trials, n_sensors) of the trials table where ``present``; fills ``scan``."""
    scan.signal_files = files
    assert scan.signal_lines is not None and scan.trials is not None  # _scan_trials fills both first
    lines, meta = scan.signal_lines, scan.trials["trial_id"].to_numpy()
    configured = settings.get("signals", {}).get("channels")
    scan.channels = tuple(configured) if configured else None
    reference: str | None = None
    baseline = int(settings.get("signals", {}).get("baseline_rows", 0) or 0)
    n_rows = np.zeros(present.shape, dtype=np.int64)
    root = os.path.realpath(folder)
    for i, s in np.argwhere(present):
        line, text = int(lines[i, s]), files[i, s]
        tid = meta[i]
        path, reason = resolve_signal_path(folder, text, root)
        if path is None:
            problems.append(Problem(tname, line, f"trial {tid!r}: {reason}"))
            continue
        if not os.path.isfile(path):
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
    parsed = read_rows(folder, SPLITS_FILE, problems, required=False)
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
    scan_classes(folder, scan.settings, problems, scan)
    _scan_groups(folder, problems, scan)
    _scan_trials(folder, scan.settings, problems, scan, check_signals)
    if scan.kind == "columns" and "signals" in scan.settings:
        problems.append(Problem(SETTINGS_FILE, key_line(folder, "", "signals") or find_table(folder, "signals"),
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
            problems.append(Problem(SETTINGS_FILE, key_line(Path(folder), "signals", "statistics"),
                                    f"unknown statistic(s) {unknown}; choose from {', '.join(statistics)}"))
    return problems
