"""Cells of the generated Markdown tables: a number, ``ours [interval]``, a results CSV found by name."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["MOVES_WITH_LAST_BIT", "find_table", "number", "only_movable_rows_differ", "ours", "signed"]

#: Said in a row whose numbers can move with the last bit (its table's note says why); ``--check`` lets such a
#: row differ from a run on another machine and names it, since the table itself says that it can.
MOVES_WITH_LAST_BIT = "(can move with the last bit)"


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


def only_movable_rows_differ(old: str, new: str) -> bool:
    """Whether every line that differs between two texts of equal length is a row marked as movable."""
    old_lines, new_lines = old.splitlines(), new.splitlines()
    return len(old_lines) == len(new_lines) and all(
        MOVES_WITH_LAST_BIT in a and MOVES_WITH_LAST_BIT in b
        for a, b in zip(old_lines, new_lines, strict=True) if a != b)
