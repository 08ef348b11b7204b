"""A failure in one (split, method) is recorded, not fatal: MOABB's ``error_score = nan``, once.

Studies call :func:`attempt` around each (split, method) fit. A failure becomes a one-line
``error`` text (``"ZSLInputError: ..."``) in that row of the study's table, with NaN scores, and
the other fits go on. :func:`table_failures` reads every ``error`` column of the tables a run
wrote; the engine (:func:`tzsl.studies.engine.run_experiment`) records them in the manifest
and ``tzsl run`` lists them on stderr and exits with :data:`EXIT_PARTIAL` at the end.

A failure whose every error is a :class:`tzsl.exceptions.TzslError` is a *refusal*
(:func:`only_refusals`): the method declined this split's input on purpose (too few training classes
for its folds), the same on every run of the same code, data and settings. Any other exception may
come from the machine (a killed worker, a full disk) and is tried again by the next run (the study
cache keeps a study whose failures are all refusals, :mod:`tzsl.studies.outputs.study_cache`).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import pandas as pd

from tzsl.exceptions import TzslError, error_text  # re-exported: the one-line text of a failed fit

__all__ = ["ERROR_COLUMN", "EXIT_PARTIAL", "attempt", "error_text", "only_refusals", "table_failures"]

#: Column of a study table that holds the failure of that row's fit (empty when it succeeded).
ERROR_COLUMN = "error"
#: Exit code of a run that completed but with failed (split, method) fits (see tzsl.cli._root).
EXIT_PARTIAL = 1
#: An exception's type name as :func:`error_text` writes it (``ZSLInputError``, ``LinAlgError``, ...).
_TYPE_NAME = re.compile(r"\b[A-Z]\w*(?:Error|Exception|Warning|Exit|Interrupt)\b")

T = TypeVar("T")




def attempt(fit: Callable[..., T], *args: Any, **kwargs: Any) -> tuple[T | None, str]:
    """``(fit(*args, **kwargs), "")``, or ``(None, error_text)`` if it raised an Exception.

    KeyboardInterrupt, SystemExit and MemoryError are not caught: they stop the run (exit 1).
    """
    try:
        return fit(*args, **kwargs), ""
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - recorded in the table, reported at the end
        return None, error_text(exc)


def table_failures(tables: Mapping[str, pd.DataFrame]) -> list[str]:
    """``"table: split=..., method=...: error"`` for every row with a non-empty error, all tables."""
    lines: list[str] = []
    for name, table in tables.items():
        if not isinstance(table, pd.DataFrame) or ERROR_COLUMN not in table.columns:
            continue
        failed = table[table[ERROR_COLUMN].fillna("").astype(str).str.len() > 0]
        keys = [c for c in ("condition", "config", "split", "seed", "method") if c in table.columns]
        for _, row in failed.iterrows():
            where = ", ".join(f"{k}={row[k]}" for k in keys if not pd.isna(row[k]))
            lines.append(f"{name}: {where}: {row[ERROR_COLUMN]}")
    return lines


def _subclass_names(cls: type) -> set[str]:
    """The names of ``cls`` and of every subclass of it defined so far."""
    names = {cls.__name__}
    subclasses: list[type] = cls.__subclasses__()
    for sub in subclasses:
        names |= _subclass_names(sub)
    return names


def only_refusals(failures: list[str]) -> bool:
    """Whether every failure line names only :class:`TzslError` types (refusals of the input, not accidents).

    Parameters
    ----------
    failures : list of str
        Lines of :func:`table_failures` (an ``error`` cell may join several ``"method: Type: message"``).

    Returns
    -------
    bool
        True for an empty list. False when a line names another exception type, or none that can be read.
    """
    ours = _subclass_names(TzslError)
    for line in failures:
        named = set(_TYPE_NAME.findall(line))
        if not named or not named <= ours:
            return False
    return True
