"""Checks shared by the lab readers of ``tzsl convert --from`` (:mod:`tzsl.datasets._lab_formats`).

Every value a reader takes from a user's file passes through here: the paths a mapping or a
label table names (inside the mapping's folder unless ``--allow-outside``), the cells of
``labels.csv`` and ``classes.csv``, declared array sizes (against the size limit), signal values
(finite, at least one row), channel names and trial ids. A problem is one
:class:`~tzsl.exceptions.DataFileError` line naming the file and the record (label-table line,
bag message, HDF5 group).
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import stat
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Generic, TypeVar

import numpy as np
import pandas as pd

from tzsl._io import MAX_NPZ_BYTES_ENV
from tzsl._progress import progress_bar as progress_bar_of
from tzsl.datasets._lab_mapping import LabMapping
from tzsl.datasets._paths import resolve_inside
from tzsl.datasets._tables import Problem, read_rows
from tzsl.datasets._validate import ScannedDataset, scan_classes
from tzsl.exceptions import DataFileError

__all__ = ["ChannelCheck", "LabSource", "LabelRow", "TrialIds", "Trials", "channel_names", "check_signal",
           "check_size", "has_control", "lab_error", "one_line", "progress_bar", "read_class_table",
           "read_label_table", "seconds", "to_float"]

#: trial id -> sensor -> (channel names (n_channels,), values (n_rows, n_channels) float64)
Trials = dict[str, dict[str, tuple[list[str], np.ndarray]]]

T = TypeVar("T")
#: The mapping type of a :class:`LabSource` (each reader reads one kind).
M = TypeVar("M", bound=LabMapping, covariant=True)
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


@contextlib.contextmanager
def progress_bar(items: Sequence[T], desc: str, show: bool) -> Iterator[Iterable[T]]:
    """``items`` with a progress bar on stderr when ``show`` and stderr is a terminal.

    A context manager: the bar is closed when an error leaves the block, so the error line
    stands on a line of its own.
    """
    with progress_bar_of(items, show=show, desc=desc) as bar:
        yield bar


def one_line(text: object) -> str:
    """``text`` with control characters (newlines, tabs, NUL) written as escapes: one line."""
    return _CONTROL.sub(lambda m: repr(m.group())[1:-1], str(text))




def has_control(text: str) -> bool:
    """Whether ``text`` holds a control character (a line break, tab, NUL)."""
    return _CONTROL.search(text) is not None


def lab_error(path: str | os.PathLike, problem: str, line: int | None = None) -> DataFileError:
    """The one-line error ``path[:line]: problem`` (control characters escaped)."""
    return DataFileError(one_line(path), one_line(problem), line=line)


@dataclass(frozen=True)
class LabSource(Generic[M]):
    """What every lab reader reads: the checked mapping, its file, the class names and the limits.

    Attributes
    ----------
    mapping_file : Path
        The TOML mapping; paths it (and its label table) names are relative to its folder.
    mapping : BagMapping or Hdf5Mapping or SeriesMapping
    classes : frozenset of str
        The class names of ``classes.csv``: a recording's class must be one of them.
    limit : int
        Largest declared signal size read, in bytes of float64 values (the ``.npz`` limit).
    allow_outside : bool
        Read paths outside the mapping's folder (absolute, ``..``, links pointing out).
    progress : bool
        Show progress bars.
    """

    mapping_file: Path
    mapping: M
    classes: frozenset[str]
    limit: int
    allow_outside: bool = False
    progress: bool = True

    @functools.cached_property
    def root(self) -> str:
        """The mapping's folder, links resolved."""
        return os.path.realpath(self.mapping_file.parent)

    def path(self, text: str, what: str, named_in: Path, line: int | None = None) -> Path:
        """The file ``text`` (a mapping value or a label-table cell) names, refused when outside the folder.

        ``what`` names the key or column for the message; ``named_in`` and ``line`` the file
        (and line) holding ``text``. A pipe or device is refused too (reading it could block).
        """
        if has_control(text):
            raise lab_error(named_in, f"{what} {text!r} holds a control character; not a file name", line)
        if self.allow_outside:
            path = Path(os.path.expanduser(text))
            path = path if path.is_absolute() else self.mapping_file.parent / path
        else:
            resolved, reason = resolve_inside(self.root, text, what, self.root)
            if reason is not None or resolved is None:  # resolve_inside gives a reason whenever it gives no path
                raise lab_error(named_in, f"{reason}; the mapping reads only inside {self.root} "
                                          "(pass --allow-outside to read it)", line)
            path = resolved
        try:
            mode = os.stat(path).st_mode
        except OSError:
            return path  # missing or unreadable: its reader says so
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            raise lab_error(named_in, f"{what} {text!r} is not a regular file or folder (a pipe or device?)", line)
        return path

    def glob(self, patterns: Sequence[str], key: str) -> list[Path]:
        """Files and folders matching the mapping's ``key`` globs, sorted; each checked to be inside.

        ``*`` stays in one folder, ``**`` spans folders (not following links to folders), names
        starting with a dot are not matched.
        """
        found: dict[str, Path] = {}  # resolved path -> the match naming it
        for pattern in patterns:
            if not self.allow_outside:
                self.path(pattern, f"{key} pattern", self.mapping_file)  # no '..', not absolute
            text = os.path.expanduser(pattern) if self.allow_outside else pattern
            anchor = Path(Path(text).anchor) if Path(text).is_absolute() else self.mapping_file.parent
            relative = os.path.relpath(text, anchor) if Path(text).is_absolute() else text
            try:
                matches = list(anchor.glob(relative))
            except (ValueError, NotImplementedError, OSError) as exc:
                raise lab_error(self.mapping_file, f"{key}: pattern {pattern!r} is not a usable glob ({exc})") from None
            for match in matches:
                parts = match.relative_to(anchor).parts
                if any(p.startswith(".") and p not in (".", "..") for p in parts):
                    continue
                self.path(os.path.join(*parts) if not self.allow_outside else str(match), f"{key} match",
                          self.mapping_file)  # a link pointing outside, a pipe
                real = os.path.realpath(match)
                if real in found and found[real] != match:
                    raise lab_error(self.mapping_file, f"{key}: {found[real]} and {match} are the same file (a link); "
                                                       "its recordings would be read twice")
                found[real] = match
        if not found:
            raise lab_error(self.mapping_file, f"{key}: no file matches {list(patterns)}")
        return sorted(found.values())

    def files_inside(self, folder: Path) -> None:
        """Refuse a link inside ``folder`` (a ROS 2 bag) pointing outside the mapping's folder, and a pipe."""
        if self.allow_outside:
            return
        for here, dirs, files in os.walk(folder):
            for name in dirs + files:
                self.path(os.path.relpath(os.path.join(here, name), self.mapping_file.parent), "file", folder)


@dataclass(frozen=True)
class LabelRow:
    """One line of a label table: its 1-based line number and its cells (text)."""

    line: int
    cells: dict[str, str] = field(default_factory=dict)


def _first_problem(path: Path, problems: list[Problem]) -> DataFileError:
    """The first of ``problems`` found in ``path`` as one line (how many more it has, when more)."""
    first = problems[0]
    more = f" (and {len(problems) - 1} more problem(s) in this file)" if len(problems) > 1 else ""
    return lab_error(path, first.message + more, first.line)


def read_label_table(source: LabSource[LabMapping], key: str, required: tuple[str, ...],
                     optional: tuple[str, ...] = ()) -> tuple[Path, list[LabelRow]]:
    """The rows of the label table named by the mapping's ``key``, every cell checked.

    Columns: ``required`` (each cell non-empty) and ``optional`` ones, no others; every line has
    the header's number of fields; a ``class`` must be in ``classes.csv``; cells are read as text
    (spaces around them removed); blank lines are skipped.
    """
    path = source.path(getattr(source.mapping, key), key, source.mapping_file)
    problems: list[Problem] = []
    parsed = read_rows(path.parent, path.name, problems)
    if problems or parsed is None:  # read_rows reports a problem whenever it returns None
        raise _first_problem(path, problems)
    header, lines = parsed
    missing = [c for c in required if c not in header]
    unknown = [c for c in header if c not in required + optional]
    if missing or unknown:
        hint = f"missing column(s) {missing}" if missing else f"unknown column(s) {[one_line(c) for c in unknown]}"
        raise lab_error(path, f"{hint}; expected {', '.join(required)}"
                              + (f"[, {', '.join(optional)}]" if optional else ""), 1)
    rows = []
    for line, values in lines:
        cells = dict(zip(header, values, strict=True))
        for column, text in cells.items():
            if _CONTROL.search(text):
                raise lab_error(path, f"{column}: {one_line(repr(text))} holds a control character (a line break "
                                      "or tab inside a cell?)", line)
        empty = [c for c in required if not cells[c]]
        if empty:
            raise lab_error(path, f"empty {', '.join(empty)}", line)
        if cells["class"] not in source.classes:
            raise lab_error(path, f"class {cells['class']!r} is not in the class table "
                                  f"({source.mapping.classes})", line)
        rows.append(LabelRow(line, cells))
    if not rows:
        raise lab_error(path, "no trial: the table has a header but no data lines", 1)
    return path, rows


def read_class_table(source: LabSource[LabMapping]) -> pd.DataFrame:
    """``classes.csv`` checked as ``tzsl validate`` checks a dataset's: (n_classes, n_attributes) int 0/1."""
    path = source.path(source.mapping.classes, "classes", source.mapping_file)
    problems: list[Problem] = []
    scan = ScannedDataset(path.parent)
    scan_classes(path.parent, {"classes": {"allow_identical_rows": bool(source.mapping.allow_identical_rows)}},
                 problems, scan, path.name, source.mapping_file.name)
    table = scan.classes
    if problems or table is None:  # scan_classes reports a problem whenever it stores no table
        raise _first_problem(path, problems)
    for name in (*table.index, *table.columns):
        if _CONTROL.search(name):
            raise lab_error(path, f"{one_line(repr(name))} holds a control character", 1)
    return table.rename_axis(columns=None)


def seconds(row: LabelRow, path: Path) -> tuple[float, float]:
    """(start, end) in seconds of a label row: ``start`` >= 0 (default 0), ``end`` > start (default inf)."""
    bounds = []
    for column, default in (("start", 0.0), ("end", np.inf)):
        text = row.cells.get(column, "").strip()
        try:
            value = float(text) if text else default
        except ValueError:
            raise lab_error(path, f"{column} {text!r} is not a number of seconds", row.line) from None
        if text and not np.isfinite(value):
            raise lab_error(path, f"{column} {text!r} is not a finite number of seconds (leave it empty for "
                                  "the bag's start or end)", row.line)
        bounds.append(value)
    start, end = bounds
    if start < 0:
        raise lab_error(path, f"start {start:g} is negative; times are seconds from the bag's first message",
                        row.line)
    if end <= start:
        raise lab_error(path, f"end {end:g} is not after start {start:g}", row.line)
    return start, end


def check_size(n_values: int, path: Path, record: str, limit: int) -> None:
    """Refuse a signal declaring more than ``limit`` bytes of float64 values, before it is read."""
    if n_values * 8 > limit:
        raise lab_error(path, f"{record}: declares {n_values:,} values ({n_values * 8:,} bytes as float64), more than "
                              f"the limit of {limit:,} bytes; raise it with the environment variable "
                              f"{MAX_NPZ_BYTES_ENV} if the file is genuine")


def to_float(values: np.ndarray, path: Path, record: str) -> np.ndarray:
    """``values`` as float64, refused when that would alter them or they are not numbers.

    Integers beyond 2**53 and floats wider than 64 bits do not fit float64 exactly; complex,
    text, compound and object arrays are not signals.
    """
    values = np.asarray(values)
    kind, size = values.dtype.kind, values.dtype.itemsize
    if kind not in "iufb" or (kind == "f" and size > 8):
        raise lab_error(path, f"{record}: holds {values.dtype} values; expected numbers (integers, floats up to "
                              "64 bits, booleans)")
    if kind in "iu" and size >= 8 and values.size and (values.max() > 2**53 or values.min() < -(2**53)):
        raise lab_error(path, f"{record}: integer {int(values.max() if values.max() > 2**53 else values.min())} "
                              "cannot be stored exactly as float64 (beyond 2**53)")
    return values.astype(np.float64)


def check_signal(values: np.ndarray, channels: Sequence[str], path: Path, record: str,
                 line_of_row: int | None = None, *, name_row: bool = True) -> None:
    """Refuse a signal (n_rows, n_channels) with no row or a NaN/inf value (the first one named).

    ``line_of_row``: the file line of row 0 (a CSV file: 2); None names the row index instead
    (unless not ``name_row``: one message, named by ``record``).
    """
    prefix = f"{record}: " if record else ""
    if values.shape[0] == 0 or values.shape[1] == 0:
        raise lab_error(path, f"{prefix}empty signal (shape {values.shape}); expected at least one row and channel")
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = (int(v) for v in np.argwhere(bad)[0])
        what = "NaN or empty" if np.isnan(values[row, col]) else "infinite"
        where = "" if line_of_row is not None or not name_row else f" at row {row}"
        raise lab_error(path, f"{prefix}channel {one_line(repr(channels[col]))} is {what}{where} "
                              f"({int(bad.sum())} non-finite value(s)); fix or drop it before converting",
                        None if line_of_row is None else line_of_row + row)


def channel_names(path: str, width: int | None) -> list[str]:
    """``pdc_data`` for a scalar field or 1-D dataset (``width`` None), ``electrode_data_0`` ... for a sequence."""
    base = re.sub(r"\[\d+\]", "", path).rsplit(".", 1)[-1].rsplit("/", 1)[-1]
    return [base] if width is None else [f"{base}_{i}" for i in range(width)]


class ChannelCheck:
    """Every sensor of every trial records the same channels (names distinct): the first one sets them."""

    def __init__(self) -> None:
        self.first: tuple[list[str], str] | None = None

    def __call__(self, channels: Sequence[str], path: Path, record: str, line: int | None = None) -> None:
        """Refuse ``channels`` of ``record`` in ``path`` when named twice or different from the first ones."""
        channels = list(channels)
        twice = sorted({c for c in channels if channels.count(c) > 1})
        if twice:
            raise lab_error(path, f"{record}: channel name(s) {twice} occur twice; every channel needs its own name",
                            line)
        if self.first is None:
            self.first = (channels, f"{one_line(path)}{'' if line is None else f':{line}'} ({record})")
            return
        if channels != self.first[0]:
            raise lab_error(path, f"{record}: channels {channels} differ from {self.first[0]} of {self.first[1]}; "
                                  "every sensor and trial must record the same channels", line)


class TrialIds:
    """Trial ids seen so far: a second recording of the same trial (and sensor) is refused."""

    def __init__(self) -> None:
        self.seen: dict[object, str] = {}

    def add(self, key: object, what: str, path: Path, record: str, line: int | None = None) -> None:
        """Refuse ``key`` (a trial id, or (trial id, sensor)) seen before; ``what`` describes it."""
        where = f"{one_line(path)}{'' if line is None else f':{line}'}{f' {record}' if record else ''}"
        if key in self.seen:
            prefix = f"{record}: " if record else ""
            raise lab_error(path, f"{prefix}{what} is recorded twice (also {self.seen[key]}); each is kept once, "
                                  "so give every recording its own trial id", line)
        self.seen[key] = where
