"""Errors raised by tzsl.

Every error a user can cause with bad input is a :class:`TzslError`. The command line
catches these and prints their message (never a traceback) with a non-zero exit code.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path


class TzslError(Exception):
    """Base class of every error tzsl raises on purpose."""


class DataFileError(TzslError):
    """A data file is missing, unreadable, corrupt or holds unexpected content.

    The message is ``path:line: problem`` (the format compilers and linters use, so editors
    can jump to it), ``path: problem`` without a line, and ``path, trial T: problem`` when the
    problem is local to one trial.

    Parameters
    ----------
    path : str or path-like or None
        The file concerned (shown as ``str(path)``).
    problem : str
        What is wrong, in words a user can act on.
    trial : str or None
        The trial concerned, when the problem is local to one trial.
    line : int or None
        1-based line of a text file (header = line 1), when known.
    """

    def __init__(
        self, path: str | os.PathLike[str] | None, problem: str, trial: str | None = None, line: int | None = None
    ) -> None:
        self.path = None if path is None else os.fspath(path) if isinstance(path, os.PathLike) else str(path)
        self.problem = problem
        self.trial = trial
        self.line = line
        where = []
        if self.path is not None:
            where.append(self.path if line is None else f"{self.path}:{line}")
        if trial is not None:
            where.append(f"trial {trial}")
        prefix = ", ".join(where) + ": " if where else ""
        super().__init__(prefix + problem)


class DataMissingError(DataFileError):
    """A dataset file is not where tzsl looks for it; the message says what to download."""


class ChecksumError(DataFileError):
    """A dataset file exists but its sha256 differs from the registry's."""


class ConfigError(TzslError):
    """An experiment configuration or command-line option is invalid."""


class SplitError(TzslError):
    """A train/test split cannot be made or a supplied split is invalid."""


class ModelBundleError(TzslError):
    """A saved model bundle is corrupt, tampered with or from another tzsl version."""


class PartialRunError(Exception):
    """A run completed and wrote its results, but some (split, method) fits failed.

    Not a :class:`TzslError`: the command line lists :attr:`failures` (one line each) and exits
    with code 1 at the end. The failed rows hold NaN scores and the reason in their ``error``
    column; ``manifest.json`` lists them too.

    Parameters
    ----------
    root : str or Path
        The results folder (written).
    failures : list of str
        One line per failed fit: ``table: split=..., method=...: ErrorType: message``.
    """

    exit_code = 1

    def __init__(self, root: str | Path, failures: list[str]) -> None:
        self.root = str(root)
        self.failures = list(failures)
        super().__init__(
            f"{len(self.failures)} fit(s) failed; the other results are in {self.root} "
            "(NaN where a fit failed, the reason in the table's error column):\n" + "\n".join(self.failures)
        )


def problems_error(
    problems: Sequence[str | TzslError],
    source: str | Path,
    *,
    error: Callable[[str], TzslError] = ConfigError,
    hint: str = "",
    limit: int = 20,
) -> TzslError | None:
    """The one error for a list of problems found in ``source`` (None when there is none).

    One problem: that problem alone, on one line, as linters print it (an error given as a
    :class:`TzslError` is returned as it is). Several: ``SOURCE: N problem(s)HINT:`` and one
    indented line per problem, at most ``limit`` of them, then how many more.

    Parameters
    ----------
    problems : sequence of str or TzslError
        Each names its file (and line or key) itself.
    source : str or Path
        What was checked (a file, a folder), named on the heading line.
    error : callable
        Builds the error from the message (default :class:`ConfigError`).
    hint : str
        Added after the count, e.g. ``" (all: tzsl validate DIR)"``.
    limit : int
        Most problems listed.
    """
    if not problems:
        return None
    if len(problems) == 1:
        only = problems[0]
        return only if isinstance(only, TzslError) else error(str(only))
    shown = "\n  ".join(str(p) for p in problems[:limit])
    more = f"\n  ... and {len(problems) - limit} more" if len(problems) > limit else ""
    return error(f"{source}: {len(problems)} problem(s){hint}:\n  {shown}{more}")


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (its type's name when it has none), for a one-line message."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def error_text(exc: BaseException) -> str:
    """``Type: first line`` of an exception (its type's name alone when it has no message)."""
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0]}" if text else type(exc).__name__
