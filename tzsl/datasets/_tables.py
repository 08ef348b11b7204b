"""The plain-file format's vocabulary (file names, reserved columns, ``dataset.toml`` keys),
:class:`Problem`, and the readers of its tables (CSV or Parquet rows with line numbers, settings).

Line numbers are those of the text file, 1-based, the header being line 1 (blank lines are
skipped but counted).
"""

from __future__ import annotations

import csv
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tzsl.datasets._paths import check_inside

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



# --------------------------------------------------------------------------- helpers


def trials_file_name(folder: Path) -> str:
    """``trials.csv``, or ``trials.parquet`` when only that one exists."""
    if not (folder / TRIALS_FILE).exists() and (folder / TRIALS_PARQUET).exists():
        return TRIALS_PARQUET
    return TRIALS_FILE


def read_parquet_rows(path: Path, name: str, problems: list[Problem]
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
        lines = str(exc).strip().splitlines()
        problems.append(Problem(name, None,
                                f"not a readable Parquet file ({lines[0] if lines else type(exc).__name__})"))
        return None
    header = [str(c).strip() for c in frame.columns]
    if not header:
        problems.append(Problem(name, 1, "table has no columns; expected a header naming its columns"))
        return None
    check_header(name, header, problems)
    columns = []
    for c in frame.columns:
        col = frame[c]
        text = col.to_numpy().astype(str) if col.dtype.kind in "iufb" else col.astype("string").fillna("").to_numpy()
        if col.dtype.kind == "f":
            text = np.where(col.isna().to_numpy(), "", text)
        columns.append(np.char.strip(np.asarray(text, dtype=str)))
    cells = np.column_stack(columns).tolist() if columns else []
    return header, [(r + 2, row) for r, row in enumerate(cells)]


def foreign_separator(header: list[str]) -> str | None:
    """The separator of a header read as one comma-separated field that holds ``;`` or a tab (a spreadsheet's
    "CSV" in a comma-decimal locale, or a tab-separated export), else None."""
    if len(header) != 1:
        return None
    return next((sep for sep in (";", "\t") if sep in header[0]), None)


def not_utf8(path: Path, exc: UnicodeDecodeError) -> str:
    """What a file that failed to decode as UTF-8 holds instead: UTF-16 (its byte-order mark) or the first bad byte."""
    with open(path, "rb") as fh:
        start = fh.read(2)
    if start in (b"\xff\xfe", b"\xfe\xff"):
        return "it is UTF-16"
    return f"byte 0x{exc.object[exc.start]:02x} at byte {exc.start} is not UTF-8"


def read_rows(
    folder: Path, name: str, problems: list[Problem], required: bool = True
) -> tuple[list[str], list[tuple[int, list[str]]]] | None:
    """Header and (line, cells) rows of a CSV (or Parquet) file; None if absent or unreadable."""
    path = folder / name
    outside = check_inside(folder, name)
    if outside is not None:
        problems.append(Problem(name, None, outside))
        return None
    if name.endswith(".parquet") and path.is_file():
        return read_parquet_rows(path, name, problems)
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
            separator = foreign_separator(header)
            if separator is not None:
                problems.append(Problem(name, 1, f"fields are separated by {separator!r}, not by commas; save the "
                                                 "file as comma-separated CSV"))
                return None
            for row in reader:
                if not any(cell.strip() for cell in row):
                    continue
                line = reader.line_num
                if len(row) != len(header):
                    problems.append(Problem(name, line, f"row has {len(row)} fields; the header has {len(header)}"))
                    continue
                rows.append((line, [cell.strip() for cell in row]))
    except UnicodeDecodeError as exc:
        problems.append(Problem(name, None, f"cannot read the file as UTF-8 text ({not_utf8(path, exc)}); "
                                            "save it as CSV UTF-8"))
        return None
    except (OSError, csv.Error) as exc:
        problems.append(Problem(name, None, f"cannot read the file: {exc}"))
        return None
    check_header(name, header, problems)
    return header, rows


def check_header(name: str, header: list[str], problems: list[Problem]) -> None:
    """Problems of a table's header (line 1): columns without a name, names given twice."""
    empty = [i + 1 for i, h in enumerate(header) if not h]
    if empty:
        problems.append(Problem(name, 1, f"header column(s) {empty} have no name"))
    dup = sorted({h for h in header if h and header.count(h) > 1})
    if dup:
        problems.append(Problem(name, 1, f"header names column(s) {dup} more than once"))


def to_float(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def key_line(folder: Path, table: str, key: str) -> int | None:
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


def find_table(folder: Path, table: str) -> int | None:
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
                problems.append(Problem(SETTINGS_FILE, key_line(folder, "", key), f"{key!r} must be a table [{key}]"))
                continue
            table, entries = key, value
        else:
            known = [k for k in SETTINGS_SCHEMA[""]] + [f"[{t}]" for t in SETTINGS_SCHEMA if t]
            problems.append(Problem(SETTINGS_FILE, key_line(folder, "", key), f"unknown key {key!r}; known: {known}"))
            continue
        for sub, val in entries.items():
            where = key_line(folder, table, sub)
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


