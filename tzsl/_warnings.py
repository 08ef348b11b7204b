"""Warnings a run shows and records: one line each, never a source path.

Python users get :func:`warnings.warn` as usual. The command line prints each warning as one
line, ``tzsl: warning: MESSAGE`` (:func:`one_line`), and a run records the warnings raised while
it ran in its manifest (:class:`recorded_warnings`).
"""

from __future__ import annotations

import warnings
from types import TracebackType

__all__ = ["one_line", "recorded_warnings"]


def one_line(message: Warning | str, category: type[Warning]) -> str:
    """``tzsl: warning: MESSAGE`` on one line (the first line of the message; the category when
    it names more than a plain warning)."""
    text = (str(message).strip().splitlines() or [category.__name__])[0]
    if category not in (UserWarning, RuntimeWarning) and category.__name__ not in text:
        text = f"{text} ({category.__name__})"
    return f"tzsl: warning: {text}"


class recorded_warnings:  # noqa: N801 - used as a context manager, like warnings.catch_warnings
    """Record, as one-line texts, every warning shown while the block runs; still show them.

    ``with recorded_warnings() as log: ...`` then ``log.lines`` (in order, repeats kept once
    with their count: ``"... (x3)"``). Warnings go on to whatever showed them before (the command
    line's one-line printer, or Python's default).
    """

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}
        self._previous = None

    def __enter__(self) -> recorded_warnings:
        self._previous = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            text = one_line(message, category)[len("tzsl: warning: "):]
            self._counts[text] = self._counts.get(text, 0) + 1
            self._previous(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        warnings.showwarning = self._previous

    @property
    def lines(self) -> list[str]:
        """The warnings shown, one line each, in first-seen order."""
        return [text if n == 1 else f"{text} (x{n})" for text, n in self._counts.items()]
