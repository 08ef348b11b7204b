"""Cells of the generated Markdown tables: a number, ``ours [interval]``, a results CSV found by name."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["find_table", "number", "ours", "signed"]


def signed(value, low, high) -> str:
    """A difference with its interval, signs shown: ``+0.078 [+0.042, +0.117]``."""
    return f"{float(value):+.3f} [{float(low):+.3f}, {float(high):+.3f}]"


def number(v, digits: int = 3) -> str:
    """``v`` with ``digits`` decimals; ``-`` for None or NaN."""
    return "-" if v is None or pd.isna(v) else f"{float(v):.{digits}f}"


def ours(row: pd.Series, column: str, low: str | None = None, high: str | None = None) -> str:
    """``row[column]`` with its interval ``[low, high]`` when the row has one (default ``<column>_ci95_*``)."""
    low, high = low or f"{column}_ci95_low", high or f"{column}_ci95_high"
    value = number(row.get(column))
    if low in row.index and high in row.index and not pd.isna(row[low]):
        value += f" [{number(row[low])}, {number(row[high])}]"
    return value


def find_table(root: Path, name: str) -> pd.DataFrame | None:
    """The ``name`` nearest the top of the folder ``root`` (searched recursively; among equally deep
    ones the first sorted path), or None: ``results/table1_fusion.csv`` wins over
    ``results/evidence/table1_fusion.csv``."""
    found = sorted(root.rglob(name), key=lambda p: (len(p.relative_to(root).parts), p)) if root.is_dir() else []
    return pd.read_csv(found[0]) if found else None
