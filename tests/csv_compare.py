"""Comparing results folders: every CSV byte for byte, but for the wall-clock ``fit_seconds`` column."""

from __future__ import annotations

import io
from pathlib import Path

import pandas as pd

#: Columns that time a fit (wall clock): equal runs differ there and only there.
TIMING_COLUMNS = ("fit_seconds",)


def csv_bytes(path: Path) -> bytes:
    """The file's bytes; for a table with a timing column, the table without it, written again."""
    data = path.read_bytes()
    header = data.split(b"\n", 1)[0].decode()
    timed = [c for c in TIMING_COLUMNS if c in header.split(",")]
    if not timed:
        return data
    table = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False)
    return table.drop(columns=timed).to_csv(index=False).encode()


def folder_csvs(folder: Path) -> dict[str, bytes]:
    """``{file name: csv_bytes}`` of every CSV in ``folder``."""
    return {p.name: csv_bytes(p) for p in sorted(Path(folder).glob("*.csv"))}
