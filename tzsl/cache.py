"""tzsl's cache folder: where it is, what it holds, how large it may grow.

Every on-disk cache of tzsl lives in one folder, decided here by :func:`get_cache_dir` (every
other module asks it): ``$TZSL_CACHE_DIR`` when that variable is set, else the user cache folder
of the platform, ``platformdirs.user_cache_dir("tzsl") / "joblib"`` (``~/.cache/tzsl/joblib`` on
Linux, ``$XDG_CACHE_HOME/tzsl/joblib`` when that is set).

Two of its parts hold whole results and are managed here (:data:`CACHE_PARTS`):

* the **study cache**, ``studies/<key>/`` (:mod:`tzsl.studies.outputs.study_cache`): a study run again
  unchanged is restored from it. It is on by default; ``TZSL_STUDY_CACHE=0`` (:data:`STUDY_CACHE_ENV`)
  turns it off, and so does ``[compute] cache = false`` for one study;
* the **fit store**, ``fits/<xx>/<key>.pkl`` (:mod:`tzsl.fit_store`): fitted models read back
  instead of refitted.

The other sub-folders (texture descriptors of :class:`joblib.Memory`, ``signals/``,
``deep-features/``) are neither counted nor pruned here.

**Age.** An entry's age is the time since it was last written or read: a restored study and a
fit read back mark their entry used (its modification time). Pruning removes the least recently
used entries first.

**Size cap.** After a study stores an entry in the study cache, the entries of both parts are
pruned, least recently used first, until together they fit in :data:`DEFAULT_MAX_SIZE_GB`
gigabytes (10^9 bytes), or ``$TZSL_CACHE_MAX_GB`` (:data:`MAX_SIZE_ENV`) when set.
``tzsl cache info`` shows each part's folder, size, number of entries and oldest entry;
``tzsl cache prune [--older-than DAYS] [--max-size GB]`` prunes by hand (:func:`prune`).

**Safe while studies run.** Entries are written under a temporary name starting with ``.`` and
moved into place in one step, so an entry is whole or absent. Pruning never removes an entry, or
a temporary name, used in the last :data:`IN_USE_SECONDS` seconds: a study being restored marks
its entry used before it copies from it, and a study being stored writes its temporary entry
within seconds. Temporary names older than that are left over from an interrupted run and are
removed by every prune. An entry is moved aside in one step before its files are deleted, so a
reader sees it whole or not at all; a fit read back while its file is deleted keeps reading it.
"""

from __future__ import annotations

import math
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import platformdirs

from tzsl.exceptions import ConfigError

__all__ = [
    "CACHE_DIR_ENV",
    "CACHE_PARTS",
    "DEFAULT_MAX_SIZE_GB",
    "FITS_FOLDER",
    "IN_USE_SECONDS",
    "MAX_SIZE_ENV",
    "STUDIES_FOLDER",
    "STUDY_CACHE_ENV",
    "CacheEntry",
    "CachePartInfo",
    "PruneReport",
    "cache_entries",
    "cache_info",
    "check_size_gb",
    "enforce_size_cap",
    "env_cache_dir",
    "format_age",
    "format_size",
    "get_cache_dir",
    "mark_used",
        "prune",
    "size_cap_gb",
    "study_cache_on",
    "user_cache_folder",
]

#: Environment variable naming the cache folder (all of tzsl's caches move with it).
CACHE_DIR_ENV = "TZSL_CACHE_DIR"
#: Environment variable: ``0`` (or ``off``, ``false``, ``no``) turns the study cache off.
STUDY_CACHE_ENV = "TZSL_STUDY_CACHE"
#: Environment variable: the size cap of the study cache and the fit store together, in GB (> 0).
MAX_SIZE_ENV = "TZSL_CACHE_MAX_GB"
#: The size cap (GB, 10^9 bytes) when :data:`MAX_SIZE_ENV` is unset.
DEFAULT_MAX_SIZE_GB = 10.0
#: Sub-folder of the cache folder holding the study cache (one folder per entry).
STUDIES_FOLDER = "studies"
#: Sub-folder of the cache folder holding the fit store (one file per entry, in ``<xx>/`` folders).
FITS_FOLDER = "fits"
#: The managed parts of the cache folder: sub-folder -> the name shown to users.
CACHE_PARTS = {STUDIES_FOLDER: "study cache", FITS_FOLDER: "fit store"}
#: Entries and temporary names used less than this many seconds ago are never pruned.
IN_USE_SECONDS = 600.0
_APP = "tzsl"
_OFF = frozenset({"0", "off", "false", "no"})
_GB = 1e9
_DAY = 86400.0


def user_cache_folder() -> Path:
    """The platform's per-user cache folder of tzsl (``platformdirs.user_cache_dir("tzsl")``), absolute."""
    return Path(platformdirs.user_cache_dir(_APP)).resolve()


def get_cache_dir(cache_dir: str | os.PathLike | None = None) -> Path:
    """The cache folder: the one place that says where tzsl's caches are.

    Parameters
    ----------
    cache_dir : str or path-like or None
        Explicit folder; wins over everything else. ``~`` is expanded.

    Returns
    -------
    Path
        ``cache_dir``, else ``$TZSL_CACHE_DIR``, else :func:`user_cache_folder` ``/ "joblib"``.
        Absolute; not created here.
    """
    if cache_dir is not None and str(cache_dir) != "":
        return Path(cache_dir).expanduser().resolve()
    return env_cache_dir() or (user_cache_folder() / "joblib")


def env_cache_dir() -> Path | None:
    """``$TZSL_CACHE_DIR`` as an absolute path, or None when it is unset or empty.

    The caches that are off unless a folder is named (an estimator's ``memory=None``, the signal
    cache's ``cache=None``) read this; the study cache and the studies' fit stores read
    :func:`get_cache_dir`.
    """
    env = os.environ.get(CACHE_DIR_ENV)
    return Path(env).expanduser().resolve() if env else None


def study_cache_on() -> bool:
    """False when ``$TZSL_STUDY_CACHE`` is ``0``, ``off``, ``false`` or ``no``; True otherwise (the default)."""
    return os.environ.get(STUDY_CACHE_ENV, "1").strip().lower() not in _OFF


def check_size_gb(value: float | str, minimum_exclusive: bool = False) -> float:
    """A size in GB: a finite number >= 0 (> 0 when ``minimum_exclusive``); ValueError otherwise."""
    try:
        gb = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{value!r} is not a number of GB") from None
    if not math.isfinite(gb) or gb < 0 or (minimum_exclusive and gb == 0):
        raise ValueError(f"{value}: give a number of GB {'>' if minimum_exclusive else '>='} 0")
    return gb


def size_cap_gb() -> float:
    """The size cap in GB (10^9 bytes): ``$TZSL_CACHE_MAX_GB`` (> 0) when set, else :data:`DEFAULT_MAX_SIZE_GB`.

    Raises
    ------
    ConfigError
        The variable is set to something other than a positive number.
    """
    text = os.environ.get(MAX_SIZE_ENV, "").strip()
    try:
        return check_size_gb(text, minimum_exclusive=True) if text else DEFAULT_MAX_SIZE_GB
    except ValueError as exc:
        raise ConfigError(f"{MAX_SIZE_ENV}={text}: {exc}") from None


def mark_used(path: str | os.PathLike) -> None:
    """Mark a cache entry (file or folder) used now, so pruning keeps it longest; a vanished entry is ignored."""
    try:
        os.utime(path)
    except OSError:
        pass


@dataclass(frozen=True)
class CacheEntry:
    """One entry of a managed cache part.

    Attributes
    ----------
    part : str
        ``"studies"`` or ``"fits"`` (:data:`CACHE_PARTS`).
    location : str
        The entry's folder (study cache) or file (fit store); :attr:`path` as a Path.
    size : int
        Bytes on disk (the sum of its files' sizes).
    used : float
        When it was last written or read (modification time, seconds since the epoch).
    temporary : bool
        A name starting with ``.``: being written, being removed, or left over by an interrupted run.
    """

    part: str
    location: str
    size: int
    used: float
    temporary: bool

    @property
    def path(self) -> Path:
        """The entry's folder or file."""
        return Path(self.location)


@dataclass(frozen=True)
class CachePartInfo:
    """What ``tzsl cache info`` shows of one part: folder, entries, bytes and the oldest entry's age (s)."""

    part: str
    folder: Path
    n_entries: int
    size: int
    oldest_age: float | None


@dataclass
class PruneReport:
    """What :func:`prune` did.

    Attributes
    ----------
    removed : list of CacheEntry
        The entries removed, least recently used first.
    kept_in_use : list of CacheEntry
        Entries over the size limit kept because they were used in the last :data:`IN_USE_SECONDS`.
    remaining_size : int
        Bytes left in both parts.
    now : float
        The time the ages were measured from (seconds since the epoch).
    """

    removed: list[CacheEntry]
    kept_in_use: list[CacheEntry]
    remaining_size: int
    now: float


def _folder_size(path: str | os.PathLike[str]) -> int:
    total = 0
    for folder, _dirs, files in os.walk(path):
        for name in files:
            try:
                total += os.lstat(os.path.join(folder, name)).st_size
            except OSError:  # removed meanwhile
                pass
    return total


def _scan_part(root: Path, part: str) -> list[CacheEntry]:
    """The entries of one part (a missing folder has none): one ``stat`` per fit-store file."""
    folder = root / part
    if part == STUDIES_FOLDER:
        found = _scandir(folder)
    else:
        found = [item for sub in _scandir(folder) if sub.is_dir(follow_symlinks=False) for item in _scandir(sub.path)]
    entries = []
    for item in found:
        try:
            st = item.stat(follow_symlinks=False)
            is_folder = item.is_dir(follow_symlinks=False)
        except OSError:  # removed meanwhile
            continue
        size = _folder_size(item.path) if is_folder else st.st_size
        entries.append(CacheEntry(part, item.path, size, st.st_mtime, item.name.startswith(".")))
    return entries


def _scandir(folder: str | os.PathLike[str]) -> list[os.DirEntry[str]]:
    try:
        with os.scandir(folder) as items:
            return list(items)
    except (FileNotFoundError, NotADirectoryError):
        return []


def cache_entries(root: str | os.PathLike | None = None) -> list[CacheEntry]:
    """Every entry (temporary names included) of the study cache and the fit store under ``root``.

    Parameters
    ----------
    root : path-like or None
        The cache folder (default :func:`get_cache_dir`).

    Returns
    -------
    list of CacheEntry
        Least recently used first.
    """
    root = get_cache_dir(root)
    return sorted((e for part in CACHE_PARTS for e in _scan_part(root, part)), key=lambda e: (e.used, e.location))


def cache_info(root: str | os.PathLike | None = None, now: float | None = None) -> list[CachePartInfo]:
    """Size, number of entries and the oldest entry's age (seconds) of each managed part, in
    :data:`CACHE_PARTS` order."""
    root = get_cache_dir(root)
    now = time.time() if now is None else now
    infos = []
    for part in CACHE_PARTS:
        entries = [e for e in _scan_part(root, part) if not e.temporary]
        oldest = min((e.used for e in entries), default=None)
        infos.append(CachePartInfo(part, root / part, len(entries), sum(e.size for e in entries),
                                   None if oldest is None else max(0.0, now - oldest)))
    return infos


def _remove(entry: CacheEntry, scanned_used: float) -> bool:
    """Remove an entry unless it was used since it was scanned; True when it is gone."""
    try:
        if entry.path.stat().st_mtime > scanned_used:  # restored or read back meanwhile: keep it
            return False
    except OSError:
        return True  # already gone
    if entry.path.is_dir():
        aside = entry.path.with_name(f".{entry.path.name.lstrip('.')}.removing.{os.getpid()}")
        try:
            os.replace(entry.path, aside)  # one step: readers see the whole entry or none
        except OSError:
            return False
        shutil.rmtree(aside, ignore_errors=True)
        return True
    try:
        entry.path.unlink()
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return True


def prune(root: str | os.PathLike | None = None, *, older_than_days: float | None = None,
          max_size_gb: float | None = None, now: float | None = None) -> PruneReport:
    """Remove the least recently used entries of the study cache and the fit store.

    Parameters
    ----------
    root : path-like or None
        The cache folder (default :func:`get_cache_dir`).
    older_than_days : float or None
        Remove every entry last used more than this many days ago.
    max_size_gb : float or None
        Then remove entries, least recently used first, until both parts together hold at most
        this many GB (10^9 bytes). None: no size limit.
    now : float or None
        The current time (seconds since the epoch; default :func:`time.time`).

    Returns
    -------
    PruneReport
        Temporary names left over by interrupted runs are always removed. Entries used in the
        last :data:`IN_USE_SECONDS` seconds are never removed (``kept_in_use`` lists those that
        keep the cache over ``max_size_gb``).

    Raises
    ------
    ValueError
        ``older_than_days`` or ``max_size_gb`` is negative or not finite.
    """
    for value in (older_than_days, max_size_gb):
        if value is not None:
            check_size_gb(value)  # a finite number >= 0, else ValueError
    now = time.time() if now is None else now
    entries = cache_entries(root)
    removed: list[CacheEntry] = []

    def removable(entry: CacheEntry) -> bool:
        return now - entry.used >= IN_USE_SECONDS

    left = []
    for entry in entries:
        stale = entry.temporary or (older_than_days is not None and now - entry.used > older_than_days * _DAY)
        if stale and removable(entry) and _remove(entry, entry.used):
            removed.append(entry)
        elif not entry.temporary:
            left.append(entry)
    total = sum(e.size for e in left)
    kept: list[CacheEntry] = []
    if max_size_gb is not None:
        limit = max_size_gb * _GB
        for entry in left:  # least recently used first
            if total <= limit:
                break
            if removable(entry) and _remove(entry, entry.used):
                removed.append(entry)
                total -= entry.size
            else:
                kept.append(entry)
    return PruneReport(removed, kept if max_size_gb is not None and total > max_size_gb * _GB else [], total, now)


def enforce_size_cap(root: str | os.PathLike | None = None) -> PruneReport:
    """Prune both parts to the size cap (:func:`size_cap_gb`), least recently used first."""
    return prune(root, max_size_gb=size_cap_gb())


def format_size(n_bytes: int) -> str:
    """Bytes as ``"512 B"``, ``"3.4 kB"``, ``"12.3 MB"`` or ``"1.23 GB"`` (powers of 1000)."""
    for unit, scale, digits in (("GB", _GB, 2), ("MB", 1e6, 1), ("kB", 1e3, 1)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:.{digits}f} {unit}"
    return f"{n_bytes} B"


def format_age(seconds: float) -> str:
    """An age as ``"40 s"``, ``"12 min"``, ``"5.0 h"`` or ``"3.2 days"``."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    if seconds < _DAY:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / _DAY:.1f} days"
