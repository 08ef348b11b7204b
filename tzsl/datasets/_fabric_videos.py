"""User-supplied GelSight fabric press videos (the paper's Flat / Fold / Rand conditions).

The study's press videos are not public. Put your own in this layout::

    <root>/fabric_groups.csv                 # same columns as fabric/fabric_groups.csv
    <root>/<condition>/<fabric_name>/<press>.avi

``<condition>`` is any folder name (the paper's are ``Flat``, ``Fold``, ``Rand``),
``<fabric_name>`` a ``fabric_name`` from the CSV (e.g. ``F0007``), ``<press>`` any file
stem (presses are ordered by name, numbers numerically). Files other than ``.avi`` are
ignored. :func:`load_gelsight_fabric_videos` returns the table of videos; frames are
decoded only when asked (:func:`tzsl.datasets.read_video`).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._fabric import read_fabric_groups
from tzsl.exceptions import DataFileError, DataMissingError

__all__ = ["load_gelsight_fabric_videos"]


def _natural_key(text: str) -> list:
    return [int(tok) if tok.isdigit() else tok for tok in re.split(r"(\d+)", text)]


def load_gelsight_fabric_videos(root: str | os.PathLike, conditions=None) -> pd.DataFrame:
    """Table of user-supplied GelSight fabric press videos (layout in the module docstring).

    Parameters
    ----------
    root : str or path-like
        Folder with ``fabric_groups.csv`` and one sub-folder per condition.
    conditions : sequence of str or None
        Conditions to load (e.g. ``["Flat", "Fold", "Rand"]``); None = every
        sub-folder of ``root``.

    Returns
    -------
    DataFrame
        One row per video, ordered by condition, fabric_id, press: condition,
        fabric_id, fabric_name, group, press (file stem), press_index (0-based within
        condition and fabric), path. Decode a video with
        :func:`tzsl.datasets.read_video`.

    Raises
    ------
    DataMissingError
        ``root``, ``fabric_groups.csv`` or a requested condition folder is missing, or
        a condition holds no video.
    DataFileError
        A fabric folder name is not in ``fabric_groups.csv``; a stray file where a
        fabric folder is expected.
    """
    root = Path(root)
    if not root.is_dir():
        raise DataMissingError(root, "GelSight video folder not found")
    fabrics = read_fabric_groups(root / "fabric_groups.csv", n_groups=None)
    by_name = fabrics.set_index("fabric_name")
    if conditions is None:
        cond_dirs = sorted((p for p in root.iterdir() if p.is_dir()), key=lambda p: _natural_key(p.name))
        if not cond_dirs:
            raise DataMissingError(root, "no condition folders (expected e.g. Flat/, Fold/, Rand/)")
    else:
        if isinstance(conditions, str):
            conditions = [conditions]
        cond_dirs = [root / c for c in conditions]
        for d in cond_dirs:
            if not d.is_dir():
                raise DataMissingError(d, "condition folder not found")
    rows: list[tuple[str, int, str, int, str, int, str]] = []
    for cdir in cond_dirs:
        n_before = len(rows)
        for fdir in sorted(cdir.iterdir(), key=lambda p: _natural_key(p.name)):
            if not fdir.is_dir():
                if fdir.name.startswith("."):
                    continue
                raise DataFileError(fdir, "expected only fabric folders (<condition>/<fabric_name>/<press>.avi)")
            if fdir.name not in by_name.index:
                raise DataFileError(
                    fdir, f"fabric folder {fdir.name!r} is not a fabric_name in {root / 'fabric_groups.csv'}")
            fab = by_name.loc[fdir.name]
            videos = sorted(
                (p for p in fdir.iterdir() if p.is_file() and p.suffix.lower() == ".avi"),
                key=lambda p: _natural_key(p.stem),
            )
            for k, v in enumerate(videos):
                rows.append((cdir.name, int(fab["fabric_id"]), fdir.name, int(fab["group"]), v.stem, k, str(v)))
        if len(rows) == n_before:
            raise DataMissingError(cdir, "condition folder holds no <fabric_name>/<press>.avi video")
    table = pd.DataFrame(
        rows, columns=["condition", "fabric_id", "fabric_name", "group", "press", "press_index", "path"]
    )
    return table.astype({"fabric_id": np.int64, "group": np.int64, "press_index": np.int64})
