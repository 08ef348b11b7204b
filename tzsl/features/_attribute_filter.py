"""Attribute filtering: keep attributes present in enough objects (DAP paper section 4.1).

"For our analysis we utilized 19 adjectives (after removing adjectives present in less
than 3 objects)." On PHAC-2 this drops crinkly (2 objects), nice (1), sticky (1), thin (2)
and unpleasant (1) and keeps the other 19 (bumpy and metallic, with exactly 3, stay).
"""

from __future__ import annotations

import numbers

import numpy as np
import pandas as pd

from tzsl.exceptions import ConfigError, DataFileError


def _is_binary_number(value: object) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return True
    if isinstance(value, numbers.Real) and not isinstance(value, str):
        return value == 0 or value == 1
    return False


def _shown(value: object) -> object:
    """Plain Python value for messages (``2.0``, not ``np.float64(2.0)``)."""
    return value.item() if isinstance(value, np.generic) else value


def check_attribute_table(table: pd.DataFrame) -> pd.DataFrame:
    """Validate a class-attribute table and return it as int64 0/1.

    Parameters
    ----------
    table : DataFrame of shape (n_objects, n_attributes)
        One row per object (unique index), one column per attribute, entries 0/1
        (bool, int or float 0.0/1.0; text such as ``"1"`` or ``"yes"`` is rejected).

    Returns
    -------
    DataFrame of shape (n_objects, n_attributes), int64
        Same index and columns.

    Raises
    ------
    DataFileError
        Not a DataFrame, duplicate objects or attributes, no attributes, or an entry
        that is missing or not 0/1 (names the object and the attribute). The file is
        ``table.attrs["source"]`` when set.
    """
    if not isinstance(table, pd.DataFrame):
        raise DataFileError(None, f"attribute table must be a DataFrame, got {type(table).__name__}")
    source = table.attrs.get("source")
    if table.shape[1] == 0:
        raise DataFileError(source, "attribute table has no attribute columns")
    if table.index.has_duplicates:
        dup = table.index[table.index.duplicated()][0]
        raise DataFileError(source, f"attribute table lists object {dup!r} twice")
    if table.columns.has_duplicates:
        dup = table.columns[table.columns.duplicated()][0]
        raise DataFileError(source, f"attribute table lists attribute {dup!r} twice")
    bad = np.zeros(table.shape, dtype=bool)
    for j, col in enumerate(table.columns):
        values = table[col]
        if pd.api.types.is_bool_dtype(values) and not values.isna().any():
            continue
        if pd.api.types.is_numeric_dtype(values):
            bad[:, j] = ~values.isin([0, 1]).to_numpy() | values.isna().to_numpy()
        else:  # object / text column: only real numbers (or bools) equal to 0 or 1 pass
            bad[:, j] = ~values.map(_is_binary_number).to_numpy(dtype=bool)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise DataFileError(
            source,
            f"attribute {table.columns[j]!r} of object {table.index[i]!r} is "
            f"{_shown(table.iat[i, j])!r}; expected 0 or 1",
        )
    return table.astype(np.int64)


def filter_attributes(
    table: pd.DataFrame, min_objects: int = 3
) -> tuple[pd.DataFrame, list[str]]:
    """Keep the attributes present in at least ``min_objects`` objects.

    Parameters
    ----------
    table : DataFrame of shape (n_objects, n_attributes)
        Class-attribute table, one row per object, 0/1 entries (see
        :func:`check_attribute_table`). Count over the objects you will learn from: on
        PHAC-2, all 60.
    min_objects : int >= 1, default 3
        Minimum number of objects with the attribute (DAP paper: 3).

    Returns
    -------
    kept : DataFrame of shape (n_objects, n_kept), int64 0/1
        The kept columns, in their original order.
    dropped : list of str
        The dropped attribute names, in their original order.

    Raises
    ------
    DataFileError
        Invalid table (unknown / non-binary entries, duplicates).
    ConfigError
        ``min_objects`` is not a positive integer, or it drops every attribute (the message lists
        how many objects each attribute has).
    """
    if (
        isinstance(min_objects, bool)
        or not isinstance(min_objects, numbers.Integral)
        or min_objects < 1
    ):
        raise ConfigError(f"min_objects must be a positive integer, got {min_objects!r}")
    table = check_attribute_table(table)
    counts = table.sum(axis=0)
    keep = counts >= int(min_objects)
    if not keep.any():
        ranked = counts.sort_values(ascending=False, kind="stable")
        shown = ", ".join(f"{a}: {int(n)}" for a, n in ranked.iloc[:10].items())
        more = f", ... ({len(ranked) - 10} more)" if len(ranked) > 10 else ""
        raise ConfigError(f"min_objects={min_objects} drops every attribute: objects per attribute (of "
                          f"{len(table)}) are {shown}{more}; use min_objects <= {int(ranked.iloc[0])}")
    kept = table.loc[:, keep.to_numpy()]
    dropped = [str(c) for c in table.columns[~keep.to_numpy()]]
    return kept, dropped
