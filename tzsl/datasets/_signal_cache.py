"""Every signal file of a plain dataset at once: parallel reads and one consolidated cache.

:func:`read_signal_table` reads the per-trial signal files of a :class:`~tzsl.datasets.PlainDataset`
(each checked as by :meth:`~tzsl.datasets.PlainDataset.read_signal`) into one
:class:`SignalTable`: the signals of every (sensor, trial) stacked in one array plus row offsets.
Parsing a small ``.npz`` is Python work (the zip directory, the ``.npy`` headers) that holds the
GIL, so the files are read by ``n_jobs`` worker *processes*, in chunks.

The table is then kept in the cache folder (:func:`~tzsl.datasets.get_cache_dir`), one entry per
dataset folder: ``signals/<hash of the folder's real path>/`` holds ``index.npz`` (key, offsets)
and ``values-<key>.npy`` (the stacked signals, read back memory-mapped). The key is a SHA-256 of
the cache format, the channels read and, for every signal file in trial order, its path inside
the folder, its size and its modification time in nanoseconds (``os.stat``): any file added,
removed, renamed, rewritten or touched changes the key, and the next read rebuilds the entry.
The files' *contents* are not hashed: that would read every byte of every file, the very cost the
cache saves; a rewrite that keeps a file's size and its nanosecond modification time (e.g. a copy
with ``cp -p`` of different content over it) is the one change the key does not see - delete the
cache folder then.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tzsl._io import atomic_write, ensure_folder
from tzsl.cache import env_cache_dir, get_cache_dir
from tzsl.datasets._signal_files import check_signal_values, read_checked_signal
from tzsl.exceptions import ConfigError, DataFileError

__all__ = ["SIGNAL_CACHE_VERSION", "SignalTable", "read_signal_table", "signal_cache_folder"]

#: Format of a cache entry; part of its key (a new format never reads an old entry).
SIGNAL_CACHE_VERSION = 1
#: Threads per reading process (parsing a small ``.npz`` holds the GIL, but its I/O and zlib do not).
READ_THREADS = 4
#: Fewer files than this are read in this process (starting worker processes costs about a second).
PARALLEL_MIN_FILES = 2_000


@dataclass
class SignalTable:
    """The checked signals of every (sensor, trial) of a dataset, stacked.

    Attributes
    ----------
    values : ndarray (n_rows_total, n_channels) of float64
        Every signal, sensor-major then trial order; read-only (memory-mapped) when from the cache.
    offsets : ndarray (n_sensors * n_trials + 1,) of int64
        Signal ``k = sensor * n_trials + trial`` is ``values[offsets[k]:offsets[k + 1]]``.
    n_trials : int
    from_cache : bool
        Whether the table came from the cache (no signal file was opened).
    """

    values: np.ndarray
    offsets: np.ndarray
    n_trials: int
    from_cache: bool = False

    def signals(self, sensor: int, start: int, stop: int) -> list[np.ndarray]:
        """Signals of trials ``start:stop`` of ``sensor``: a list of (n_rows_i, n_channels) arrays (views)."""
        first = sensor * self.n_trials + start
        bounds = self.offsets[first: first + (stop - start) + 1]
        block = np.asarray(self.values[bounds[0]: bounds[-1]])
        return np.split(block, bounds[1:-1] - bounds[0])


def signal_cache_folder(folder: str | os.PathLike, cache_dir: str | os.PathLike) -> Path:
    """The cache entry folder of dataset ``folder``: ``cache_dir/signals/<sha256 of its real path>``."""
    digest = hashlib.sha256(os.path.realpath(folder).encode("utf-8")).hexdigest()[:24]
    return Path(cache_dir) / "signals" / digest


def _cache_root(cache: bool | str | os.PathLike | None) -> Path | None:
    """``cache`` -> the cache folder or None (off). None: ``$TZSL_CACHE_DIR`` if set; True: the default folder."""
    if cache is None:
        return env_cache_dir()
    if cache is False:
        return None
    return get_cache_dir(None if cache is True else cache)


def _key(data) -> str | None:
    """SHA-256 of the format, channels and every file's (relative path, size, mtime_ns); None if one is
    refused or missing (the read then reports it with its trial)."""
    digest = hashlib.sha256(f"tzsl-signals {SIGNAL_CACHE_VERSION}\0{list(data.channels)!r}\0".encode())
    root = os.path.realpath(data.folder)
    try:  # the paths were checked to stay inside the folder by the dataset's reader, and again by a read
        for rel in data.signal_files.T.reshape(-1):
            st = os.stat(os.path.join(root, str(rel).replace("\\", "/")))
            digest.update(f"{rel}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    except OSError:
        return None
    return digest.hexdigest()


def _load_entry(entry: Path, key: str, n_files: int, n_channels: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The cached (values, offsets) of ``key``, or None (absent, stale, or unreadable: rebuilt)."""
    try:
        with np.load(entry / "index.npz", allow_pickle=False) as index:
            if str(index["key"]) != key:
                return None
            offsets = np.asarray(index["offsets"], dtype=np.int64)
        values = np.load(entry / f"values-{key[:32]}.npy", mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, KeyError, EOFError):
        return None
    if (offsets.shape != (n_files + 1,) or values.dtype != np.float64
            or values.shape != (int(offsets[-1]), n_channels)):
        return None
    return values, offsets


def _store_entry(entry: Path, key: str, values: np.ndarray, offsets: np.ndarray) -> None:
    """Write the entry: values first, then the index naming their key (a reader never sees half of it)."""
    ensure_folder(entry, "signal cache folder")
    name = f"values-{key[:32]}.npy"

    def write_values(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.save(fh, values, allow_pickle=False)

    def write_index(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, key=np.array(key), offsets=offsets)

    atomic_write(entry / name, write_values)
    atomic_write(entry / "index.npz", write_index)
    for old in entry.glob("values-*.npy"):
        if old.name != name:
            old.unlink(missing_ok=True)


def _read_one(folder: Path, root: str, rel: str, trial_id: str, channels: tuple[str, ...],
              min_rows: int) -> np.ndarray | None:
    try:
        return read_checked_signal(folder, rel, trial_id, channels, min_rows, root)
    except DataFileError:
        return None  # re-raised in the caller's process, with its own message


def _read_chunk(folder: Path, root: str, rels: list[str], trial_ids: list[str], channels: tuple[str, ...],
                min_rows: int) -> list[np.ndarray | None]:
    """Read consecutive signal files in threads (file I/O and zlib release the GIL); None for a failing file."""
    with ThreadPoolExecutor(max_workers=READ_THREADS) as pool:
        return list(pool.map(lambda rt: _read_one(folder, root, rt[0], rt[1], channels, min_rows),
                             zip(rels, trial_ids, strict=True)))


def _read_all(data, min_rows: int, n_jobs: int | None) -> list[np.ndarray]:
    """Every signal, sensor-major then trial order, read in ``n_jobs`` processes (chunks of files)."""
    from joblib import Parallel, delayed, effective_n_jobs  # noqa: PLC0415

    root = os.path.realpath(data.folder)
    rels = [str(r) for r in data.signal_files.T.reshape(-1)]
    tids = [str(t) for t in data.trials["trial_id"]] * len(data.sensors)
    workers = effective_n_jobs(n_jobs)  # joblib: None = 1, -1 = every core
    if workers <= 1 or len(rels) < PARALLEL_MIN_FILES:
        results = [_read_chunk(data.folder, root, rels, tids, data.channels, min_rows)]
    else:
        step = -(-len(rels) // (4 * workers))
        chunks = [(lo, min(lo + step, len(rels))) for lo in range(0, len(rels), step)]
        results = Parallel(n_jobs=workers)(delayed(_read_chunk)(data.folder, root, rels[lo:hi], tids[lo:hi],
                                                                data.channels, min_rows) for lo, hi in chunks)
    signals: list[np.ndarray] = []
    for k, signal in enumerate(signal for part in results for signal in part):
        # a failing file (None) is read again here: the first one raises its own error
        signals.append(signal if signal is not None
                       else read_checked_signal(data.folder, rels[k], tids[k], data.channels, min_rows, root))
    return signals


def _check_rows(data, offsets: np.ndarray, min_rows: int) -> None:
    """A cached table read with a larger ``min_rows``: the first too-short signal raises as a fresh read would."""
    short = np.flatnonzero(np.diff(offsets) < min_rows)
    if short.size:
        k = int(short[0])
        trial = k % data.n_trials
        rel = str(data.signal_files[trial, k // data.n_trials])
        rows = np.zeros((int(offsets[k + 1] - offsets[k]), len(data.channels)))
        problems = check_signal_values(rel, data.channels, rows, False, min_rows)
        raise DataFileError(data.folder, "; ".join(map(str, problems)), trial=str(data.trials["trial_id"].iat[trial]))


def read_signal_table(data, min_rows: int = 1, *, n_jobs: int | None = None,
                      cache: bool | str | os.PathLike | None = None) -> SignalTable:
    """Every checked signal of a plain signal dataset, from the cache when no file changed.

    Parameters
    ----------
    data : PlainDataset
        A dataset with signal files (``kind == "signals"``).
    min_rows : int, default 1
        Fewest rows a signal needs (see :meth:`~tzsl.datasets.PlainDataset.read_signal`).
    n_jobs : int, optional
        Processes reading the files (joblib convention; ``None``: this process). Datasets of
        fewer than :data:`PARALLEL_MIN_FILES` files are read in this process.
    cache : bool, path-like or None
        The consolidated cache (module docstring): a cache folder; ``True``:
        :func:`~tzsl.datasets.get_cache_dir`; ``False``: none; ``None``: ``$TZSL_CACHE_DIR`` if
        set, else none.

    Returns
    -------
    SignalTable

    Raises
    ------
    DataFileError
        The first signal file that fails its checks (file, trial and, for CSV files, line).
    """
    if data.signal_files is None or data.channels is None:
        raise DataFileError(data.folder, "dataset has feature columns, not signal files")
    root = _cache_root(cache)
    key = entry = None
    n_files = data.signal_files.size
    if root is not None:
        key = _key(data)
        entry = signal_cache_folder(data.folder, root)
        loaded = None if key is None else _load_entry(entry, key, n_files, len(data.channels))
        if loaded is not None:
            _check_rows(data, loaded[1], min_rows)
            return SignalTable(values=loaded[0], offsets=loaded[1], n_trials=data.n_trials, from_cache=True)
    signals = _read_all(data, min_rows, n_jobs)
    offsets = np.zeros(n_files + 1, dtype=np.int64)
    np.cumsum([len(s) for s in signals], out=offsets[1:])
    values = np.concatenate(signals) if signals else np.empty((0, len(data.channels)))
    if key is not None and entry is not None and key == _key(data):  # no file changed while it was read
        try:
            _store_entry(entry, key, values, offsets)
        except (ConfigError, OSError) as exc:  # a cache that cannot be written costs time, not the run
            warnings.warn(f"signal cache not written ({str(exc).splitlines()[0]}); the next run reads the files "
                          "again", RuntimeWarning, stacklevel=2)
    return SignalTable(values=values, offsets=offsets, n_trials=data.n_trials)
