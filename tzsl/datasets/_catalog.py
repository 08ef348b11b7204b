"""The catalog's converted folders: a public dataset written once as a plain-file folder in the cache folder.

A catalog dataset (:class:`~tzsl.datasets.CatalogDataset`) is fetched into the data home as published
(its registered files, each with a sha256) and converted by its loader into a plain-file dataset
folder. :func:`converted_folder` keeps that folder under ``<cache folder>/catalog/<name>-<key>``,
where the key is a digest of everything the conversion depends on (the registered hashes of the
files it reads, the loader's version, its class table), so a study reads the folder written by an
earlier one and a changed input gives a new folder. The folder is written atomically by the plain
format's writer; two processes converting at once leave one folder.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.cache import get_cache_dir
from tzsl.datasets._registry import fetch
from tzsl.datasets._tables import CLASSES_FILE
from tzsl.exceptions import ConfigError, DataFileError, first_line

__all__ = ["CATALOG_FOLDER", "RegisteredSignals", "conversion_key", "converted_folder", "read_class_table"]

#: Sub-folder of the cache folder holding the converted catalog datasets.
CATALOG_FOLDER = "catalog"


def conversion_key(parts: Sequence[str]) -> str:
    """A 16-hex-digit digest of ``parts`` (the inputs of a conversion, in order)."""
    return hashlib.sha256(json.dumps(list(parts)).encode("utf-8")).hexdigest()[:16]


def converted_folder(name: str, parts: Sequence[str], build: Callable[[Path], object],
                     cache_dir: str | Path | None = None) -> Path:
    """The converted folder of catalog dataset ``name``, written by ``build(folder)`` when absent.

    Parameters
    ----------
    name : str
        The dataset.
    parts : sequence of str
        What the conversion depends on (:func:`conversion_key`).
    build : callable
        Writes the plain-file folder it is given (which does not exist yet), atomically.
    cache_dir : path-like, optional
        The cache folder (:func:`tzsl.cache.get_cache_dir`).

    Returns
    -------
    Path
        ``<cache folder>/catalog/<name>-<key>``, holding a plain-file dataset.
    """
    folder = get_cache_dir(cache_dir) / CATALOG_FOLDER / f"{name}-{conversion_key(parts)}"
    if (folder / CLASSES_FILE).is_file():
        return folder
    try:
        build(folder)
    except ConfigError:
        if (folder / CLASSES_FILE).is_file():  # another process wrote it meanwhile
            return folder
        raise
    return folder


class RegisteredSignals(Sequence):
    """The signals of registered files, each fetched (hash-checked) and read only when the plain-format writer asks.

    Parameters
    ----------
    relpaths : list of str
        One registered file per trial (paths relative to the data home).
    data_dir : path-like or None
        The data home.
    read : callable
        ``read(path) -> ndarray (n_samples, n_channels)``: the loader's reader of one file as published.

    ``signals[i]`` is ``[read(fetch(relpaths[i]))]``: trial ``i``'s one sensor, as
    :func:`~tzsl.datasets.write_plain_dataset` takes it, so a conversion never holds every trial at once.
    """

    def __init__(self, relpaths: list[str], data_dir: str | os.PathLike | None,
                 read: Callable[[Path], np.ndarray]) -> None:
        self.relpaths, self.data_dir, self.read = relpaths, data_dir, read

    def __len__(self) -> int:
        return len(self.relpaths)

    def __getitem__(self, i):  # the writer indexes one trial at a time
        return [self.read(fetch(self.relpaths[i], self.data_dir))]


def read_class_table(path: str | os.PathLike, columns: Sequence[str]) -> pd.DataFrame:
    """A catalog dataset's sourced class-attribute table as text cells, its header checked (every loader's reader).

    Parameters
    ----------
    path : path-like
        The CSV (one line per object and attribute, with the value's source).
    columns : sequence of str
        The header it must have, in order.

    Returns
    -------
    DataFrame
        Every cell as written (strings; an empty cell stays ``""``).

    Raises
    ------
    DataFileError
        Not a readable CSV, or another header (line 1), in one line naming the file.
    """
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"not a readable CSV table ({type(exc).__name__}: {first_line(exc)})") from None
    if tuple(table.columns) != tuple(columns):
        raise DataFileError(path, f"columns are {list(table.columns)}; expected {list(columns)}", line=1)
    return table
