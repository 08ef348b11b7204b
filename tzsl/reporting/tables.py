"""The report's tables: a CSV file as header and cell strings, its key columns first.

:func:`table_view` merges each paper column and each interval pair into the column they belong to
(``ours (low-high) [paper]``), prints counts whole and other numbers with 3 decimals, and shows a
short table with very many columns transposed. A wide table (more than :data:`KEY_MAX_COLUMNS`
columns after merging) also gets a *key view*: its text columns that vary, the accuracy-like
columns of :data:`KEY_NUMBERS` and a non-empty ``note``, with the text columns that hold one value
in every row said once above it; the page shows the key view and keeps the full table behind a
toggle (:func:`table_entry`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd

__all__ = ["FOLD_ROWS", "KEY_MAX_COLUMNS", "KEY_NUMBERS", "TRANSPOSE_COLUMNS", "TRANSPOSE_MAX_ROWS", "WIDE_COLUMNS",
           "read_table", "table_entry", "table_view"]

#: Tables longer than this (rows) are folded away by default.
FOLD_ROWS = 40

#: Tables with more columns than this (after merging paper and interval columns) use a smaller font.
WIDE_COLUMNS = 7

#: Tables with more columns than this (after merging) show their key columns, the rest behind a toggle.
KEY_MAX_COLUMNS = 10

#: Numeric columns a key view keeps, where present: accuracies, their baselines, differences, calibration.
KEY_NUMBERS = ("accuracy", "accuracy_mean", "balanced_accuracy", "maxdap", "avgdap", "uni", "seen", "unseen",
               "harmonic", "zsl", "chance", "majority", "control", "difference", "ece", "brier")

#: Text columns longer than this (characters, in some row) stay out of a key view (they are in the full table).
KEY_TEXT_MAX = 80

#: Columns a generic ``ci95_low``/``ci95_high`` pair belongs to (first one present).
INTERVAL_TARGETS = ("accuracy", "accuracy_mean", "mean", "value", "difference", "balanced_accuracy", "harmonic")

#: First-column values of summary rows (their counts may be fractional means).
SUMMARY_ROWS = ("mean", "std", "sd", "average")

#: Tables with more columns than this and at most :data:`TRANSPOSE_MAX_ROWS` rows are shown transposed
#: (when they have no key view).
TRANSPOSE_COLUMNS = 12
TRANSPOSE_MAX_ROWS = 8


def _summary_mask(table: pd.DataFrame) -> pd.Series:
    if table.shape[1] == 0:
        return pd.Series(False, index=table.index)
    return table.iloc[:, 0].astype(str).str.lower().isin(SUMMARY_ROWS)


def _is_count(values: pd.Series, summary: pd.Series) -> bool:
    """Numeric column whose values are whole numbers outside the summary rows (a count)."""
    if not pd.api.types.is_numeric_dtype(values) or pd.api.types.is_bool_dtype(values):
        return False
    present = values[~summary].dropna()
    if not len(present):
        present = values.dropna()
    return bool(len(present)) and bool((present == present.round()).all())


def _number(value: Any, count: bool) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if count:
            return f"{value:.0f}" if float(value).is_integer() else f"{value:.1f}"
        return f"{value:.3f}"
    return str(value).replace(";", "; ")


def _interval_pairs(columns: list[str]) -> dict[str, tuple[str, str]]:
    """Column -> its (low, high) interval columns, by name ``X_ci95_low`` or a generic pair."""
    pairs = {c: (f"{c}_ci95_low", f"{c}_ci95_high") for c in columns
             if f"{c}_ci95_low" in columns and f"{c}_ci95_high" in columns}
    if "ci95_low" in columns and "ci95_high" in columns:
        target = next((c for c in INTERVAL_TARGETS if c in columns), None)
        if target is not None and target not in pairs:
            pairs[target] = ("ci95_low", "ci95_high")
    return pairs


def _key_columns(shown: list[str], cells: list[list[str]], text: set[int]) -> tuple[list[int], list[tuple[str, str]]]:
    """Positions of a wide table's key columns and the (column, value) of its one-valued text columns.

    Key: text columns with more than one value (and no cell over :data:`KEY_TEXT_MAX` characters),
    the first column, the :data:`KEY_NUMBERS` present with a value somewhere and ``note`` when some row
    has one; none when
    the table has no column of :data:`KEY_NUMBERS` (then nothing says which columns matter).
    """
    if not any(c in KEY_NUMBERS for c in shown) or len(cells) < 2:
        return [], []
    keep, constants = [], []
    for j, name in enumerate(shown):
        values = {row[j] for row in cells}
        if j in text and name != "note":
            if len(values) == 1:
                constants.append((name, next(iter(values))))
            elif j == 0 or max(len(v) for v in values) <= KEY_TEXT_MAX:
                keep.append(j)
        elif j == 0 or (name in KEY_NUMBERS and values - {"-"}) or (name == "note" and values - {"-"}):
            keep.append(j)
    return keep, constants


def table_view(table: pd.DataFrame) -> dict[str, Any]:
    """Header and cell strings of a table, ours beside the paper's and intervals in the cell.

    A column ``X`` with ``paper_X`` becomes ``X [paper]`` with cells ``ours [paper]`` (an empty
    ``paper_*`` column is left out: the study has no paper number); with
    ``X_ci95_low``/``X_ci95_high`` (or a generic ``ci95_low``/``ci95_high`` pair, attached to
    the first of :data:`INTERVAL_TARGETS`), cells read ``ours (low-high)``. Counts (columns
    whole outside the mean/std rows) print without decimals (a mean count with one), other
    numbers with 3, missing values as ``-``. A table with more than :data:`KEY_MAX_COLUMNS`
    columns gets a key view (module docstring); a short table with very many columns and no key
    view (more than :data:`TRANSPOSE_COLUMNS`, at most :data:`TRANSPOSE_MAX_ROWS` rows) is
    transposed: one row per column, one column per original row, labelled by its leading
    text/count cells.

    Returns
    -------
    dict with ``header`` (list of str), ``rows`` (list of list of str), ``classes`` (CSS
    class of each column: ``"paper"`` for columns of paper numbers only, ``"text"`` for
    text, left-aligned), ``n_rows``, ``n_columns``, ``transposed`` (bool) and ``key``: None, or
    the key view as a dict with ``header``, ``rows``, ``classes`` (those of the key columns) and
    ``constants`` (list of (column, value): one value in every row).
    """
    columns = [str(c) for c in table.columns]
    table = table.set_axis(columns, axis=1)
    intervals = _interval_pairs(columns)
    merged = {c: f"paper_{c}" for c in columns if f"paper_{c}" in columns and table[f"paper_{c}"].notna().any()}
    empty_paper = {c for c in columns if c.startswith("paper_") and table[c].isna().all()}
    hidden = set(merged.values()) | empty_paper | {x for pair in intervals.values() for x in pair}
    shown = [c for c in columns if c not in hidden]
    summary = _summary_mask(table)
    count = {c: _is_count(table[c], summary) for c in columns}
    labels = [c + (" (95% CI)" if c in intervals else "") + (" [paper]" if c in merged else "") for c in shown]
    cells = []
    for record in table.to_dict("records"):
        row = []
        for c in shown:
            text = _number(record[c], count[c])
            if c in intervals:
                low, high = (record[x] for x in intervals[c])
                if not (pd.isna(low) or pd.isna(high)):
                    text += f" ({low:.3f}\u2013{high:.3f})"
            if c in merged and not pd.isna(record[merged[c]]):
                text += f" [{_number(record[merged[c]], count[merged[c]])}]"
            row.append(text)
        cells.append(row)
    text_columns = {i for i, c in enumerate(shown) if not pd.api.types.is_numeric_dtype(table[c])}
    classes = [" ".join(k for k, on in (("paper", c.startswith("paper")), ("text", i in text_columns)) if on)
               for i, c in enumerate(shown)]
    keep, constants = _key_columns(shown, cells, text_columns) if len(shown) > KEY_MAX_COLUMNS else ([], [])
    key = None
    if keep:
        key = {"header": [labels[j] for j in keep], "rows": [[row[j] for j in keep] for row in cells],
               "classes": [classes[j] for j in keep], "constants": constants}
    elif len(shown) > TRANSPOSE_COLUMNS and 0 < len(cells) <= TRANSPOSE_MAX_ROWS:
        n_key = 0
        while n_key < min(2, len(shown) - 1) and (n_key in text_columns or count[shown[n_key]]):
            n_key += 1
        n_key = max(n_key, 1)
        header = ["column"] + [" / ".join(row[:n_key]) for row in cells]
        rows = [[labels[j]] + [row[j] for row in cells] for j in range(n_key, len(shown))]
        return {"header": header, "rows": rows, "classes": ["text"] + [""] * len(cells), "n_rows": len(rows),
                "n_columns": len(header), "transposed": True, "key": None}
    return {"header": labels, "rows": cells, "classes": classes, "n_rows": len(cells),
            "n_columns": len(labels), "transposed": False, "key": key}


def read_table(path: Path) -> pd.DataFrame | str:
    """The CSV at ``path``, or why it could not be read (one line)."""
    try:
        return pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        return f"not readable as CSV ({exc})"


def table_entry(path: Path, root: Path, index: int) -> dict[str, Any]:
    """What the page template needs of one CSV: its name, an id, its :func:`table_view` and layout flags.

    ``wide``: more than :data:`WIDE_COLUMNS` columns (smaller font); ``fold``: more than
    :data:`FOLD_ROWS` rows (folded away); ``simulated``: a ``data`` column says ``simulated``.
    """
    entry: dict[str, Any] = {"name": str(path.relative_to(root)), "id": f"t{index}", "error": None,
                             "simulated": False, "wide": False, "transposed": False, "key": None}
    table = read_table(path)
    if isinstance(table, str):
        entry["error"] = table
        return entry
    if "data" in table.columns:
        entry["simulated"] = bool(table["data"].astype(str).str.lower().eq("simulated").any())
    view = table_view(table)
    entry.update(view, wide=view["n_columns"] > WIDE_COLUMNS, fold=view["n_rows"] > FOLD_ROWS)
    return entry
