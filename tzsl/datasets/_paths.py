"""Containment of the paths a dataset or grasp folder names: a folder never reads outside itself.

A ``signal_file`` cell of ``trials.csv`` or a ``file`` cell of ``grasps.csv`` is a path relative to
its folder. It is refused when it is absolute, holds ``..``, or - once symbolic links are resolved -
points outside the folder (a link to ``/etc/passwd`` or to a sibling folder is refused as well as
``../../secret.csv``). The folder itself may be a link; containment is checked against its
resolved path.
"""

from __future__ import annotations

import os
import re
from pathlib import Path, PurePosixPath


def resolve_inside(folder: str | os.PathLike, text: str, what: str) -> tuple[Path | None, str | None]:
    """A path named inside ``folder`` -> its resolved absolute path, or None and why it is refused.

    Parameters
    ----------
    folder : path-like
        The dataset or grasp folder.
    text : str
        The cell text: a relative path with ``/`` (or ``\\``) separators.
    what : str
        Name of the column, for the message (``"signal_file"``, ``"file"``).

    Returns
    -------
    path : Path or None
        ``folder / text`` with every symbolic link resolved (it need not exist).
    reason : str or None
        Why the path is refused (empty, absolute, ``..``, or resolving outside ``folder``).
    """
    if not text:
        return None, f"{what} is empty"
    pure = PurePosixPath(text.replace("\\", "/"))
    if pure.is_absolute() or re.match(r"^[A-Za-z]:", text) or ".." in pure.parts:
        return None, f"{what} {text!r} must be a path relative to the folder, inside it (no '..', not absolute)"
    root = Path(folder).resolve()
    try:
        resolved = root.joinpath(*pure.parts).resolve()
    except (OSError, RuntimeError) as exc:  # a symlink loop
        return None, f"{what} {text!r} cannot be resolved ({exc})"
    if not resolved.is_relative_to(root):
        return None, f"{what} {text!r} is a symbolic link to {resolved}, outside the folder {root}; refusing to read it"
    return resolved, None


def check_inside(folder: str | os.PathLike, name: str) -> str | None:
    """Why the file ``folder/name`` (e.g. ``trials.csv``) is refused, or None when it is inside ``folder``."""
    path = Path(folder) / name
    if not path.is_symlink():
        return None
    _, reason = resolve_inside(folder, name, name)
    return reason
