"""``bts3``: the BioTacSP Stability Set (yayaneath/biotac-sp-images), read as published.

The release (https://github.com/yayaneath/biotac-sp-images at commit :data:`BTS3_COMMIT`) holds two
CSV files, one per hand orientation: ``biotac-palmdown-grasps.csv`` and ``biotac-palmside-grasps.csv``.
Each line is one grasp of a Shadow hand with three BioTac SP fingertips (index ``ff``, middle ``mf``,
thumb ``th``): ``object`` (one of 41 object names), ``slipped`` (0 stable, 1 the object slid) and the
24 electrode values of each fingertip (``ff_biotac_1`` ... ``th_biotac_24``), one reading per grasp.
The registry lists both files under ``bts3/`` with their sha256 and their ``raw.githubusercontent.com``
link at that commit (``tzsl data fetch bts3``).

:func:`load_bts3` reads both (each verified by :func:`~tzsl.datasets.fetch`) into one table of grasps
and an array of shape (n_grasps, 3 fingertips, 24 electrodes). The class-attribute table of its 41
objects, which a catalog dataset needs before it can be studied, is not written yet (the catalog page
says what it may be written from).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._registry import fetch
from tzsl.exceptions import DataFileError, first_line

__all__ = ["BTS3", "BTS3_COMMIT", "BTS3_FILES", "BTS3_FINGERS", "Bts3Grasps", "load_bts3", "read_bts3_csv"]

#: The dataset's registry folder.
BTS3 = "bts3"
#: The commit of https://github.com/yayaneath/biotac-sp-images the registry pins.
BTS3_COMMIT = "bdd90cc376e673d8ac2f7c879af47c99ecc56783"
#: Hand orientation -> its registered file.
BTS3_FILES: dict[str, str] = {"palm_down": f"{BTS3}/biotac-palmdown-grasps.csv",
                              "palm_side": f"{BTS3}/biotac-palmside-grasps.csv"}
#: The fingertips, in the files' column order (index, middle, thumb).
BTS3_FINGERS: tuple[str, ...] = ("ff", "mf", "th")
#: Electrode values per fingertip.
N_ELECTRODES = 24
_HEADER = ("object", "slipped", *(f"{f}_biotac_{i}" for f in BTS3_FINGERS for i in range(1, N_ELECTRODES + 1)))


@dataclass(frozen=True)
class Bts3Grasps:
    """Grasps of the BioTacSP Stability Set.

    Attributes
    ----------
    trials : DataFrame with n_grasps rows
        ``grasp_id`` (``<orientation>_<line>``), ``object``, ``slipped`` (0/1), ``orientation``
        (``palm_down`` / ``palm_side``), ``source`` (the file) and ``line`` (its line, header = 1).
    X : ndarray of float64, shape (n_grasps, 3, 24)
        The electrode values of every fingertip (:data:`BTS3_FINGERS`), as published.
    """

    trials: pd.DataFrame
    X: np.ndarray


def read_bts3_csv(path: str | os.PathLike, orientation: str) -> Bts3Grasps:
    """One CSV file of the release.

    Parameters
    ----------
    path : path-like
        ``biotac-palmdown-grasps.csv`` or ``biotac-palmside-grasps.csv`` (or a file in their layout:
        the header ``object,slipped,ff_biotac_1,...,th_biotac_24``, one grasp per line).
    orientation : str
        Recorded in ``trials["orientation"]`` and in the grasp ids.

    Returns
    -------
    Bts3Grasps

    Raises
    ------
    DataFileError
        One line naming the file (and the line when known): another header, a line with another
        number of fields, an empty object name, ``slipped`` other than 0 or 1, an electrode value
        that is not a finite number, no grasp at all.
    """
    path = Path(path)
    try:
        frame = pd.read_csv(path, dtype={"object": str}, keep_default_na=False,
                            na_values={c: [""] for c in _HEADER[1:]})
    except pd.errors.EmptyDataError:
        raise DataFileError(path, "file is empty; expected the header object,slipped,ff_biotac_1,...", line=1) from None
    except pd.errors.ParserError as exc:
        raise DataFileError(path, f"not a readable CSV file in the release's layout ({first_line(exc)})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read it as text ({type(exc).__name__}: {first_line(exc)})") from None
    if tuple(frame.columns) != _HEADER or not frame.index.equals(pd.RangeIndex(len(frame))):
        raise DataFileError(path, "header is not object,slipped,ff_biotac_1..24,mf_biotac_1..24,th_biotac_1..24 "
                            "(the release's layout), or the lines have more fields than it", line=1)
    if frame.empty:
        raise DataFileError(path, "has a header line but no grasps", line=1)
    names = frame["object"].str.strip()
    empty = np.flatnonzero((names == "").to_numpy())
    if empty.size:
        raise DataFileError(path, "object name is empty", line=int(empty[0]) + 2)
    for column in _HEADER[1:]:
        values = pd.to_numeric(frame[column], errors="coerce")
        bad = np.flatnonzero((~np.isfinite(values.to_numpy(dtype=np.float64))))
        if bad.size:
            raise DataFileError(path, f"{column} holds {frame[column].iat[int(bad[0])]!r}, not a number",
                                line=int(bad[0]) + 2)
        frame[column] = values
    slipped = frame["slipped"].to_numpy(dtype=np.float64)
    wrong = np.flatnonzero(~np.isin(slipped, (0.0, 1.0)))
    if wrong.size:
        raise DataFileError(path, f"slipped is {frame['slipped'].iat[int(wrong[0])]!r}; 0 (stable) or 1 (slid)",
                            line=int(wrong[0]) + 2)
    lines = np.arange(2, len(frame) + 2)
    trials = pd.DataFrame({"grasp_id": [f"{orientation}_{n}" for n in lines], "object": names.to_numpy(),
                           "slipped": slipped.astype(np.int64), "orientation": orientation, "source": str(path),
                           "line": lines})
    X = frame[list(_HEADER[2:])].to_numpy(dtype=np.float64).reshape(len(frame), len(BTS3_FINGERS), N_ELECTRODES)
    return Bts3Grasps(trials, X)


def load_bts3(data_dir: str | os.PathLike | None = None) -> Bts3Grasps:
    """Both files of the release from the data home (each verified against its sha256), palm down first.

    Raises
    ------
    DataMissingError
        A file is not in the data home (the message names ``tzsl data fetch bts3``).
    ChecksumError
        A file whose sha256 differs from the registry's.
    DataFileError
        A file that is not in the release's layout (:func:`read_bts3_csv`).
    """
    parts = [read_bts3_csv(fetch(relpath, data_dir), orientation) for orientation, relpath in BTS3_FILES.items()]
    return Bts3Grasps(pd.concat([p.trials for p in parts], ignore_index=True), np.concatenate([p.X for p in parts]))
