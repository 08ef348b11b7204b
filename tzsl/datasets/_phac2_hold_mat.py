"""Raw HOLD-phase PHAC-2 MATLAB files and the 60x24 PHAC-2 adjective matrix.

The HOLD files (``phac2/imperial_cvpr2021_hold/<object>_<id3>_<trial2>_HOLD.mat``,
6 objects x 10 trials, PROVENANCE.md section 5) hold the 10 s thermal-hold EP of one
trial: per finger ``F{0,1}Electrodes`` (19, T), ``F{0,1}pac`` (22, T), ``F{0,1}pdc``,
``F{0,1}tac``, ``F{0,1}tdc`` (1, T) raw uint16 ADC counts, and the gripper ``JPos``
(1, T, metres), ``JVel``, ``JEff``. T = 1000 rows at 100 Hz (1001 in one file).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Iterable

import numpy as np
import pandas as pd
import scipy.io

from tzsl.datasets._registry import fetch, registered_files
from tzsl.datasets._types import PHAC2_EPS, BiotacSignals, RawTrial
from tzsl.exceptions import DataFileError

HOLD_DIR = "phac2/imperial_cvpr2021_hold/"
LABELS_CSV = "phac2/derived/phac2_labels_60x24.csv"

#: ``<object>_<id3>_<trial2>``, e.g. ``car_sponge_101_01``.
TRIAL_ID_RE = re.compile(r"^(?P<object>.+)_(?P<id>\d{3})_(?P<trial>\d{2})$")

# variable -> number of rows it must have (T columns each); F{f}Electrodes etc.
_FINGER_VARS: dict[str, int] = {"Electrodes": 19, "pac": 22, "pdc": 1, "tac": 1, "tdc": 1}
_GRIPPER_VARS: dict[str, int] = {"JPos": 1, "JVel": 1, "JEff": 1}


def parse_trial_id(trial_id: str, source: str | os.PathLike | None = None) -> tuple[str, int, int]:
    """Split ``<object>_<id3>_<trial2>`` into (object_name, object_id, trial_index).

    ``object_name`` keeps the id (``car_sponge_101``) so that it is unique: PHAC-2 has
    two car sponges (101 and 109), two tooth-paste boxes and two chalkboard erasers.

    Raises
    ------
    DataFileError
        The id does not follow the pattern (``source`` names the file).
    """
    match = TRIAL_ID_RE.match(trial_id)
    if match is None:
        raise DataFileError(source, f"trial name {trial_id!r} does not follow <object>_<id3>_<trial2>")
    return (
        f"{match['object']}_{match['id']}",
        int(match["id"]),
        int(match["trial"]),
    )


def read_phac2_labels_csv(path: str | os.PathLike) -> pd.DataFrame:
    """Read and validate a PHAC-2 object x adjective CSV.

    Parameters
    ----------
    path : str or path-like
        CSV with header ``object_id,object_name,<adjectives...>`` and 0/1 values.

    Returns
    -------
    DataFrame of shape (n_objects, n_adjectives), int64 0/1
        Index ``object_name`` in the unique form ``<object>_<id3>`` (e.g.
        ``car_sponge_101``), rows in object-id order; columns the adjectives, sorted.

    Raises
    ------
    DataFileError
        Unreadable CSV, missing id/name columns, duplicate objects, empty or non-0/1
        entries.
    """
    path = Path(path)
    try:
        raw = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise DataFileError(path, f"cannot read label CSV: {exc}") from None
    for col in ("object_id", "object_name"):
        if col not in raw.columns:
            raise DataFileError(path, f"label CSV has no {col!r} column")
    adjectives = sorted(c for c in raw.columns if c not in ("object_id", "object_name"))
    if not adjectives:
        raise DataFileError(path, "label CSV has no adjective columns")
    if raw[["object_id", "object_name"]].isna().any().any():
        raise DataFileError(path, "label CSV has an empty object_id or object_name")
    try:
        ids = raw["object_id"].astype(np.int64).to_numpy()
    except (TypeError, ValueError):
        raise DataFileError(path, "label CSV object_id column is not integer") from None
    names = [f"{name}_{oid:03d}" for name, oid in zip(raw["object_name"].astype(str), ids, strict=True)]
    dup_ids = pd.Index(ids)[pd.Index(ids).duplicated()]
    if len(dup_ids):
        raise DataFileError(path, f"duplicate object_id {int(dup_ids[0])} in label CSV")
    values = raw[adjectives]
    bad = values.isna() | ~values.isin([0, 1])
    if bad.to_numpy().any():
        row, col = np.argwhere(bad.to_numpy())[0]
        raise DataFileError(
            path,
            f"label of object {names[row]!r} for adjective {adjectives[col]!r} is "
            f"{values.iat[row, col]!r}; expected 0 or 1",
        )
    labels = pd.DataFrame(
        values.to_numpy(dtype=np.int64), index=pd.Index(names, name="object_name"),
        columns=pd.Index(adjectives, name="adjective"),
    )
    order = np.argsort(ids, kind="stable")
    return labels.iloc[order]


def load_phac2_labels(data_dir: str | os.PathLike | None = None) -> pd.DataFrame:
    """The 60 x 24 PHAC-2 object x adjective matrix (Penn's 2013 binary labels).

    Reads the registered, checksum-verified ``phac2/derived/phac2_labels_60x24.csv``.

    Returns
    -------
    DataFrame of shape (60, 24), int64 0/1
        Index ``object_name`` (``<object>_<id3>``, object-id order), columns the 24
        adjectives in alphabetical order.
    """
    return read_phac2_labels_csv(fetch(LABELS_CSV, data_dir))


def _mat_variable(mat: dict, name: str, rows: int, path: Path, trial: str) -> np.ndarray:
    if name not in mat:
        raise DataFileError(path, f"MAT file has no variable {name!r}", trial=trial)
    arr = np.asarray(mat[name])
    if arr.ndim != 2 or arr.shape[0] != rows:
        raise DataFileError(
            path, f"variable {name!r} has shape {arr.shape}; expected ({rows}, T)", trial=trial
        )
    if not np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.complexfloating):
        raise DataFileError(path, f"variable {name!r} is not real numeric ({arr.dtype})", trial=trial)
    arr = arr.astype(np.float64)
    finite = np.isfinite(arr)
    if not finite.all():
        col = int(np.argwhere(~finite)[0][1])
        raise DataFileError(
            path, f"variable {name!r} holds NaN/inf (first at row {col})", trial=trial
        )
    return arr


def read_hold_mat(path: str | os.PathLike) -> RawTrial:
    """Read one ``<object>_<id3>_<trial2>_HOLD.mat`` file.

    Parameters
    ----------
    path : str or path-like
        The MAT file (MATLAB 5 format, as in the Imperial coursework copy).

    Returns
    -------
    RawTrial
        ``fingers`` (finger_0, finger_1) with float64 raw ADC counts: ``pdc``, ``tac``,
        ``tdc`` of shape (T,), ``pac`` (T, 22), ``electrodes`` (T, 19);
        ``gripper_aperture`` (T,) in metres (``JPos``); ``phase`` (T,) all
        ``"HOLD_FOR_10_SECONDS"``; ``tool_z`` None; ``adjectives`` None (labels come from
        :func:`load_phac2_labels`).

    Raises
    ------
    DataFileError
        Unreadable / truncated / corrupt file, a missing variable, a wrong shape, unequal
        lengths or NaN/inf values; the message names the file.
    """
    path = Path(path)
    name = path.name
    if not name.endswith("_HOLD.mat"):
        raise DataFileError(path, "HOLD file name must end with '_HOLD.mat'")
    trial_id = name[: -len("_HOLD.mat")]
    object_name, object_id, trial_index = parse_trial_id(trial_id, path)
    try:
        mat = scipy.io.loadmat(str(path))
    except NotImplementedError:
        raise DataFileError(
            path, "MATLAB v7.3 (HDF5) MAT files are not supported; re-save as MATLAB 5 (-v7)",
            trial=trial_id,
        ) from None
    except Exception as exc:  # noqa: BLE001 - scipy raises ValueError, TypeError, OSError, ... on corrupt files
        raise DataFileError(
            path, f"cannot read MAT file, truncated or corrupt ({type(exc).__name__}: {exc})",
            trial=trial_id,
        ) from None
    arrays: dict[str, np.ndarray] = {}
    for finger in (0, 1):
        for var, rows in _FINGER_VARS.items():
            key = f"F{finger}{var}"
            arrays[key] = _mat_variable(mat, key, rows, path, trial_id)
    for var, rows in _GRIPPER_VARS.items():
        arrays[var] = _mat_variable(mat, var, rows, path, trial_id)
    lengths = {k: v.shape[1] for k, v in arrays.items()}
    if len(set(lengths.values())) != 1:
        raise DataFileError(
            path, f"variables have different lengths T: {lengths}", trial=trial_id
        )
    n_rows = arrays["JPos"].shape[1]
    if n_rows == 0:
        raise DataFileError(path, "variables are empty (T = 0)", trial=trial_id)
    fingers = tuple(
        BiotacSignals(
            pdc=arrays[f"F{f}pdc"][0],
            pac=np.ascontiguousarray(arrays[f"F{f}pac"].T),
            tac=arrays[f"F{f}tac"][0],
            tdc=arrays[f"F{f}tdc"][0],
            electrodes=np.ascontiguousarray(arrays[f"F{f}Electrodes"].T),
        )
        for f in (0, 1)
    )
    return RawTrial(
        trial_id=trial_id,
        object_id=object_id,
        object_name=object_name,
        trial_index=trial_index,
        source=str(path),
        fingers=fingers,
        gripper_aperture=arrays["JPos"][0],
        phase=np.full(n_rows, PHAC2_EPS["hold"]),
        tool_z=None,
        adjectives=None,
    )


def load_phac2_hold_mat(
    data_dir: str | os.PathLike | None = None, files: Iterable[str | os.PathLike] | None = None
) -> list[RawTrial]:
    """The raw HOLD-phase trials of PHAC-2 (6 objects x 10 trials).

    Parameters
    ----------
    data_dir : str or path-like or None
        Data home (see :func:`tzsl.datasets.get_data_home`). Used when ``files`` is None:
        all 60 registered files under ``phac2/imperial_cvpr2021_hold/`` are fetched and
        checksum-verified.
    files : iterable of path-like or None
        Explicit ``*_HOLD.mat`` files to read instead (not checksum-verified; e.g. the
        user's own recordings in the same format).

    Returns
    -------
    list of RawTrial
        Sorted by (object_id, trial_index); see :func:`read_hold_mat`.
    """
    if files is None:
        paths = [fetch(rel, data_dir) for rel in registered_files(HOLD_DIR)]
    else:
        paths = [Path(p) for p in files]
    trials = [read_hold_mat(p) for p in paths]
    seen: dict[str, str] = {}
    for t in trials:
        if t.trial_id in seen:
            raise DataFileError(t.source, f"trial also read from {seen[t.trial_id]}", trial=t.trial_id)
        seen[t.trial_id] = t.source
    return sorted(trials, key=lambda t: (t.object_id, t.trial_index))
