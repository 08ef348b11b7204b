"""Progress bars, shown only where someone watches them: every tqdm bar of tzsl is made here.

A bar redraws itself with carriage returns; written to a file (``tzsl run ... > log 2>&1``,
``make evidence > log``) each redraw is kept, and the log becomes mostly bars. :func:`progress_bar`
therefore shows a bar only when it is asked for (the callers' ``progress`` / ``verbose``
switches, ``--no-progress``, ``[compute] progress``) *and* :func:`bars_wanted` finds a watcher:
standard error is a terminal, or tqdm draws a notebook widget (Jupyter: no carriage returns).
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from typing import Any

from tqdm import autonotebook, std
from tqdm.auto import tqdm

__all__ = ["bars_wanted", "progress_bar"]


def _stderr_is_terminal() -> bool:
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty()) if isatty is not None else False
    except ValueError:  # a closed stream
        return False


def bars_wanted(show: bool | None) -> bool:
    """Whether a bar asked for with ``show`` is drawn: asked (True; None counts as asked) and watched
    (standard error is a terminal, or tqdm's notebook widget is in use)."""
    if show is False:
        return False
    return _stderr_is_terminal() or autonotebook.tqdm is not std.tqdm


def progress_bar(iterable: Iterable[Any] | None = None, *, show: bool | None, **kwargs: Any) -> tqdm:
    """A tqdm bar over ``iterable`` (keywords as tqdm's), drawn only when :func:`bars_wanted` says so;
    otherwise a silent pass-through that still counts (``update``, ``set_postfix``, ``close`` work)."""
    return tqdm(iterable, disable=not bars_wanted(show), **kwargs)
