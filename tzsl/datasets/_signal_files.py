"""Per-trial signal files of the plain-file format: read one (``.npz`` / ``.csv``), check its values,
and resolve the ``signal_file`` cell naming it (inside the dataset folder)."""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import looks_binary, read_npz
from tzsl.datasets._paths import resolve_inside
from tzsl.datasets._tables import SIGNAL_SUFFIXES, TRIALS_FILE, Problem
from tzsl.exceptions import DataFileError, first_line


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
        return signal_from_arrays(path, read_npz(path))
    if suffix == ".csv":
        return _read_signal_csv(path)
    raise DataFileError(path, f"unsupported signal file type {path.suffix!r}; use {' or '.join(SIGNAL_SUFFIXES)}")


def signal_from_arrays(path: str | os.PathLike, arrays: dict[str, np.ndarray]) -> tuple[tuple[str, ...], np.ndarray]:
    """Channels and values of a signal ``.npz`` already read into ``arrays`` (see :func:`read_signal_file`).

    ``path`` names the file in errors. One 1-D numeric array per channel, all of one length.
    """
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
    return channels, np.column_stack([arrays[c].astype(np.float64) for c in channels])




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
        raise DataFileError(path, f"not a readable CSV file ({first_line(exc)})") from None
    except UnicodeDecodeError:
        raise DataFileError(path, "not a UTF-8 text file (a binary file given as CSV?)") from None
    except Exception as exc:  # noqa: BLE001 - pandas/OS raise many types for unreadable files
        raise DataFileError(path, f"not a readable CSV file ({type(exc).__name__}: {first_line(exc)})") from None
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
    for c, col in zip(channels, frame.columns, strict=True):
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


def resolve_signal_path(folder: Path, text: str, root: str | None = None) -> tuple[Path, None] | tuple[None, str]:
    """``signal_file`` cell -> resolved absolute path inside ``folder``, or None and why it is refused.

    ``root``: ``os.path.realpath(folder)``, when resolving many cells of one folder.
    """
    suffix = os.path.splitext(text.replace("\\", "/").rstrip("/").rpartition("/")[2])[1]
    suffix = "" if suffix == "." else suffix  # PurePosixPath(text).suffix, without its cost
    if text and suffix.lower() not in SIGNAL_SUFFIXES:
        return None, f"signal_file {text!r}: unsupported type {suffix!r}; use {' or '.join(SIGNAL_SUFFIXES)}"
    return resolve_inside(folder, text, "signal_file", root)


def read_checked_signal(folder: Path, rel: str, trial_id: str, channels: Sequence[str], min_rows: int = 1,
                        root: str | None = None) -> np.ndarray:
    """The checked signal of one ``signal_file`` cell, shape (n_rows, n_channels), float64.

    Parameters
    ----------
    folder : Path
        The dataset folder; ``rel`` is resolved inside it.
    rel : str
        The ``signal_file`` cell.
    trial_id : str
        The trial, for messages.
    channels : sequence of str
        Channels to keep, in this order (the file may hold more).
    min_rows : int, default 1
    root : str, optional
        ``os.path.realpath(folder)``, when reading many files of one folder.

    Raises
    ------
    DataFileError
        Path outside the folder, unreadable file, channels missing, fewer than ``min_rows``
        rows, NaN/inf (names the file, the trial and, for CSV files, the line).
    """
    resolved = resolve_signal_path(folder, rel, root)
    if resolved[0] is None:
        raise DataFileError(folder / TRIALS_FILE, resolved[1], trial=trial_id)
    path = resolved[0]
    found, values = read_signal_file(path)
    absent = [c for c in channels if c not in found]
    if absent:
        raise DataFileError(path, f"channel(s) {absent} missing (has {list(found)}); every trial and sensor of a "
                            "dataset records the same channels (those of the first signal file, or dataset.toml's "
                            "[signals] channels)", trial=trial_id)
    values = values[:, [found.index(c) for c in channels]]
    problems = check_signal_values(rel, channels, values, path.suffix.lower() == ".csv", min_rows)
    if problems:
        raise DataFileError(folder, "; ".join(map(str, problems)), trial=trial_id)
    return values
