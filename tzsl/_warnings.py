"""Warnings a run shows and records: one line per kind on the terminal, every one in the manifest.

Python users get :func:`warnings.warn` as usual. The command line prints the first warning of each
kind as one line, ``tzsl: warning: MESSAGE`` (:func:`one_line`, no source path), and at the end one
line counting the repeats it did not print (:class:`TerminalWarnings`); a run records every warning
raised while it ran, with its count, in its manifest (:class:`recorded_warnings`).
"""

from __future__ import annotations

import re
import sys
import warnings
from collections.abc import Callable
from types import TracebackType

__all__ = ["TerminalWarnings", "one_line", "recorded_warnings", "warn_again", "warning_kind"]

#: Categories too general to be a kind by themselves: their kind is the message's wording.
_GENERIC = (UserWarning, RuntimeWarning, Warning)
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")
_QUOTED = re.compile(r"'[^']*'|\"[^\"]*\"")


def one_line(message: Warning | str, category: type[Warning]) -> str:
    """``tzsl: warning: MESSAGE`` on one line (the first line of the message; the category when
    it names more than a plain warning)."""
    text = (str(message).strip().splitlines() or [category.__name__])[0]
    if category not in (UserWarning, RuntimeWarning) and category.__name__ not in text:
        text = f"{text} ({category.__name__})"
    return f"tzsl: warning: {text}"


class recorded_warnings:
    """Record, as one-line texts, every warning shown while the block runs; still show them.

    ``with recorded_warnings() as log: ...`` then ``log.lines`` (in order, repeats kept once
    with their count: ``"... (x3)"``). Warnings go on to whatever showed them before (the command
    line's one-line printer, or Python's default).
    """

    def __init__(self) -> None:
        self._seen: dict[str, tuple[type[Warning], int]] = {}  # text -> (category first seen with it, count)
        self._previous: Callable[..., None] | None = None  # warnings.showwarning while the block runs

    def __enter__(self) -> recorded_warnings:
        previous = self._previous = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            text = one_line(message, category)[len("tzsl: warning: "):]
            first, n = self._seen.get(text, (category, 0))
            self._seen[text] = (first, n + 1)
            previous(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._previous is not None:
            warnings.showwarning = self._previous

    @property
    def lines(self) -> list[str]:
        """The warnings shown, one line each, in first-seen order."""
        return [text if n == 1 else f"{text} (x{n})" for text, (_, n) in self._seen.items()]

    @property
    def shown(self) -> list[tuple[str, str, int]]:
        """``(text, category, count)`` of each warning, in first-seen order; ``category`` is
        ``"module:QualName"`` (:func:`warn_again` raises it again as it was)."""
        return [(text, f"{category.__module__}:{category.__qualname__}", n)
                for text, (category, n) in self._seen.items()]


def warn_again(shown: list[tuple[str, str, int]], stacklevel: int = 2) -> None:
    """Raise again the warnings of :attr:`recorded_warnings.shown`, each with its category and count.

    A category whose module is not imported in this process (or that is no Warning) is raised as a
    ``UserWarning`` with the same text, which names the category.
    """
    for text, category_path, n in shown:
        module, _, name = category_path.partition(":")
        category = getattr(sys.modules.get(module), name, None)
        if not (isinstance(category, type) and issubclass(category, Warning)):
            category = UserWarning
        for _ in range(n):
            warnings.warn(text, category, stacklevel=stacklevel + 1)


def warning_kind(message: Warning | str, category: type[Warning]) -> str:
    """What makes two warnings "the same kind": the category, or for a plain ``UserWarning`` /
    ``RuntimeWarning`` the first line's wording with numbers and quoted names blanked
    (``"attribute 'hard' ... 3 objects"`` and ``"attribute 'soft' ... 2 objects"`` are one kind)."""
    if category not in _GENERIC:
        return category.__name__
    text = (str(message).strip().splitlines() or [""])[0]
    return f"{category.__name__}: {_NUMBER.sub('#', _QUOTED.sub('…', text))}"


def _kind_label(kind: str, width: int = 48) -> str:
    """How the closing line names a kind: its category, and for a plain ``UserWarning`` /
    ``RuntimeWarning`` also its (blanked) wording, cut to ``width`` characters, so two kinds of one
    category are told apart (``UserWarning "attribute … is rare: # objects"``)."""
    category, _, wording = kind.partition(": ")
    if not wording:
        return category
    return f'{category} "{wording if len(wording) <= width else wording[:width - 1] + "…"}"'


class TerminalWarnings:
    """The command line's warning printer: the first warning of each kind, one line each.

    ``show`` has the signature of :func:`warnings.showwarning`; ``summary()`` is the closing line
    (None when nothing was held back), e.g. ``tzsl: warning: 22 more warnings of the kinds above
    (GridEdgeWarning: 21, UserWarning "attribute … is rare: # objects": 1); a run lists every one in
    its manifest.json``.

    Parameters
    ----------
    echo : callable
        Prints one line (the command line's stderr).
    """

    def __init__(self, echo) -> None:
        self._echo = echo
        self._held: dict[str, int] = {}

    def show(self, message, category, filename, lineno, file=None, line=None) -> None:
        kind = warning_kind(message, category)
        if kind in self._held:
            self._held[kind] += 1
            return
        self._held[kind] = 0
        self._echo(one_line(message, category))

    def summary(self) -> str | None:
        """One line counting the warnings held back, per kind; None when none were."""
        repeats = {kind: n for kind, n in self._held.items() if n}
        if not repeats:
            return None
        names = ", ".join(f"{_kind_label(kind)}: {n}" for kind, n in repeats.items())
        return (f"tzsl: warning: {sum(repeats.values())} more warnings of the kinds above ({names}); a run lists "
                "every one in its manifest.json")
