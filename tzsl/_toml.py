"""TOML text of the settings tzsl writes (experiment files, ``dataset.toml``): one writer for every file.

Python's ``tomllib`` reads TOML but does not write it; the files tzsl writes hold only top-level
scalars and one-level tables of strings, numbers, booleans, lists and inline tables, which
:func:`toml_value` and :func:`toml_text` cover.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from numbers import Integral, Real

__all__ = ["toml_text", "toml_value"]


def toml_value(value: object) -> str:
    """``value`` as a TOML value (a string, integer, float, boolean, list or inline table).

    Raises
    ------
    TypeError
        Any other type (the caller names the file it was writing).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, Integral):
        return str(int(value))
    if isinstance(value, Real):
        return repr(float(value))
    if isinstance(value, str):
        # a TOML basic string: JSON escapes quotes, backslashes and control characters as TOML does (DEL too)
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {value!r} as TOML")


def toml_text(settings: Mapping) -> str:
    """The TOML text of ``settings``: its top-level scalars, then one ``[table]`` per mapping value."""
    lines = [f"{k} = {toml_value(v)}" for k, v in settings.items() if not isinstance(v, Mapping)]
    for table, entries in settings.items():
        if isinstance(entries, Mapping):
            lines += ["", f"[{table}]"] + [f"{k} = {toml_value(v)}" for k, v in entries.items()]
    return "\n".join(lines) + "\n"
