"""The environment a run ran in, against the lock the published numbers were made in (issue 41).

``make reproduce-tables``, ``make evidence`` and ``make test`` install the versions of
``requirements/core.lock.txt`` (and ``requirements/dev.lock.txt`` for the extras), which ``make lock``
writes; every number the README publishes is generated in that environment. A manifest records
:func:`environment_record`: every installed distribution and its version, the lock file's sha256 and
each locked package whose installed version differs from the lock, so that a reader can tell whether
a results folder came from the locked environment (``matches_lock``) and, if not, what differed. An
installed wheel (``pip install tzsl``) ships no lock: the record says so, and its numbers may differ
from the README's in the last digits or, where a choice is close, more
(docs/user_guide/reproducing.md#the-locked-environment).
"""

from __future__ import annotations

import hashlib
import re
from functools import cache
from importlib import metadata
from pathlib import Path

__all__ = ["CORE_LOCK", "environment_record", "installed_distributions", "locked_versions"]

#: The lock of the published numbers, relative to the source checkout.
CORE_LOCK = Path("requirements") / "core.lock.txt"

#: ``name==version`` at the start of a lock line (pip's requirement syntax, as ``uv pip compile`` writes it).
_PINNED = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*==\s*([^\s;#]+)")


def _normalised(name: str) -> str:
    """A distribution name as PEP 503 compares them (case, ``-``, ``_`` and ``.`` folded)."""
    return re.sub(r"[-_.]+", "-", name).lower()


def locked_versions(lock: Path) -> dict[str, str]:
    """``{normalised name: version}`` of every ``name==version`` line of a lock file."""
    pins = {}
    for line in lock.read_text(encoding="utf-8").splitlines():
        found = _PINNED.match(line)
        if found:
            pins[_normalised(found.group(1))] = found.group(2)
    return pins


@cache
def _distributions() -> tuple[tuple[str, str], ...]:
    """Read once per process: parsing every distribution's metadata takes a noticeable part of a second, and a
    benchmark writes a manifest per dataset."""
    found: dict[str, str] = {}
    for dist in metadata.distributions():
        name = dist.metadata["Name"]
        if name:
            found.setdefault(_normalised(name), dist.version)
    return tuple(sorted(found.items()))


def installed_distributions() -> dict[str, str]:
    """``{normalised name: version}`` of every distribution importable in this interpreter (as it was at its first
    call in this process), sorted."""
    return dict(_distributions())


def environment_record(source: Path | None = None) -> dict:
    """What a manifest records of the environment (see the module docstring).

    Parameters
    ----------
    source : Path or None
        The source checkout holding the lock; default: the checkout this tzsl runs from.

    Returns
    -------
    dict
        ``installed`` (every distribution: version), ``lock_file`` (relative path, or None without
        one), ``lock_sha256``, ``matches_lock`` (every locked package installed at its locked version;
        None without a lock) and ``differs`` (``{name: {"locked": v, "installed": w or None}}``).
    """
    root = Path(__file__).resolve().parents[3] if source is None else Path(source)
    installed = installed_distributions()
    lock = root / CORE_LOCK
    if not lock.is_file():
        return {"installed": installed, "lock_file": None, "lock_sha256": None, "matches_lock": None,
                "differs": {}}
    pins = locked_versions(lock)
    differs = {name: {"locked": version, "installed": installed.get(name)}
               for name, version in pins.items() if installed.get(name) != version}
    return {
        "installed": installed,
        "lock_file": CORE_LOCK.as_posix(),
        "lock_sha256": hashlib.sha256(lock.read_bytes()).hexdigest(),
        "matches_lock": not differs,
        "differs": differs,
    }
