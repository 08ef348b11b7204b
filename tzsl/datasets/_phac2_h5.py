"""Raw PHAC-2 recordings in the official HDF5 release layout (PROVENANCE.md section 2).

One top-level group per trial, named ``<object>_<id3>_<trial2>`` (e.g. ``car_sponge_101_01``)::

    <trial>/biotacs/finger_{0,1}/electrodes   (N, 19)  raw ADC counts
                                 pac          (N, 22)  22 sub-samples per row (2200 Hz)
                                 pdc, tac, tdc (N,)
    <trial>/gripper_aperture/joint_position   (N,)     metres (also joint_velocity, joint_effort)
    <trial>/state/controller_detail_state     (N,) S30 EP state per row (see PHAC2_EPS)
    <trial>/transforms/translation            (N, 3)   tool frame position, metres (optional)
    <trial>/timestamps, accelerometer, state/controller_state, adjectives (optional)

Rows are 100 Hz. The official file also holds non-trial groups ``adjectives``,
``adjectives_neg`` and ``train_test_*``; they are skipped.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import h5py
import numpy as np

from tzsl._io import atomic_write
from tzsl.datasets._phac2_hold_mat import TRIAL_ID_RE, parse_trial_id
from tzsl.datasets._types import PHAC2_EPS, BiotacSignals, RawTrial
from tzsl.exceptions import DataFileError

#: Top-level groups of the official release that are not trials.
NON_TRIAL_GROUPS: tuple[str, ...] = ("adjectives", "adjectives_neg")
NON_TRIAL_PREFIXES: tuple[str, ...] = ("train_test_",)
#: BioTac signal -> trailing shape per row.
BIOTAC_SIGNALS: dict[str, tuple[int, ...]] = {
    "electrodes": (19,),
    "pac": (22,),
    "pdc": (),
    "tac": (),
    "tdc": (),
}
FINGERS: tuple[str, ...] = ("finger_0", "finger_1")
_STATE_LEN = 30


def _is_trial_group(name: str) -> bool:
    if name in NON_TRIAL_GROUPS or name.startswith(NON_TRIAL_PREFIXES):
        return False
    return True


def list_phac2_h5_trials(path: str | os.PathLike) -> list[str]:
    """Names of the trial groups in a PHAC-2 HDF5 file, in file order.

    Raises
    ------
    DataFileError
        Not an HDF5 file / truncated, or a top-level entry that is neither a known
        non-trial group nor named ``<object>_<id3>_<trial2>``.
    """
    path = Path(path)
    with _open(path) as fh:
        return _trial_names(fh, path)


def _open(path: Path) -> h5py.File:
    if not path.is_file():
        raise DataFileError(path, "file not found")
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise DataFileError(
            path, f"not a readable HDF5 file (truncated or corrupt?): {exc}"
        ) from None


def _trial_names(fh: h5py.File, path: Path) -> list[str]:
    names = []
    for name in fh.keys():
        if not _is_trial_group(name):
            continue
        if TRIAL_ID_RE.match(name) is None or not isinstance(fh.get(name), h5py.Group):
            raise DataFileError(
                path,
                f"top-level entry {name!r} is not a trial group <object>_<id3>_<trial2> nor a "
                f"known non-trial group {NON_TRIAL_GROUPS + tuple(p + '*' for p in NON_TRIAL_PREFIXES)}",
            )
        names.append(name)
    return names


def _dataset(group: h5py.Group, rel: str, path: Path, trial: str) -> np.ndarray:
    """Read ``group[rel]`` as an array; clear errors for missing / unreadable entries."""
    obj = group.get(rel)
    if obj is None:
        # name the first missing level (e.g. a whole finger) to make the message actionable
        parts = rel.split("/")
        missing = rel
        for depth in range(1, len(parts) + 1):
            if group.get("/".join(parts[:depth])) is None:
                missing = "/".join(parts[:depth])
                break
        what = "group" if missing != rel else "dataset"
        raise DataFileError(path, f"missing {what} {trial}/{missing} (needed: {trial}/{rel})", trial=trial)
    if not isinstance(obj, h5py.Dataset):
        raise DataFileError(path, f"{trial}/{rel} is a group, expected a dataset", trial=trial)
    try:
        return obj[()]
    except (OSError, ValueError, TypeError) as exc:
        raise DataFileError(path, f"cannot read {trial}/{rel} (corrupt?): {exc}", trial=trial) from None


def _numeric(arr: np.ndarray, rel: str, tail: tuple[int, ...], path: Path, trial: str) -> np.ndarray:
    arr = np.asarray(arr)
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise DataFileError(path, f"{trial}/{rel} is not numeric ({arr.dtype})", trial=trial)
    if arr.ndim != 1 + len(tail) or arr.shape[1:] != tail:
        want = "(N" + "".join(f", {t}" for t in tail) + ")" if tail else "(N,)"
        raise DataFileError(
            path, f"{trial}/{rel} has shape {arr.shape}; expected {want}", trial=trial
        )
    out = arr.astype(np.float64)
    bad = ~np.isfinite(out)
    if bad.any():
        row = int(np.argwhere(bad)[0][0])
        raise DataFileError(path, f"{trial}/{rel} holds NaN/inf (first at row {row})", trial=trial)
    return out


def _strings(arr: np.ndarray) -> np.ndarray:
    arr = np.asarray(arr)
    if arr.dtype.kind == "S":
        return np.char.strip(np.char.decode(arr, "ascii", "replace"))
    if arr.dtype.kind == "O":
        return np.array(
            [(v.decode("ascii", "replace") if isinstance(v, bytes) else str(v)).strip() for v in arr.ravel()],
            dtype=str,
        )
    return np.char.strip(arr.astype(str))


def _read_trial(group: h5py.Group, path: Path, trial: str) -> RawTrial:
    object_name, object_id, trial_index = parse_trial_id(trial, path)
    fingers = []
    columns: dict[str, int] = {}
    for finger in FINGERS:
        signals = {}
        for name, tail in BIOTAC_SIGNALS.items():
            rel = f"biotacs/{finger}/{name}"
            signals[name] = _numeric(_dataset(group, rel, path, trial), rel, tail, path, trial)
            columns[rel] = signals[name].shape[0]
        fingers.append(BiotacSignals(**signals))
    rel = "gripper_aperture/joint_position"
    aperture = _numeric(_dataset(group, rel, path, trial), rel, (), path, trial)
    columns[rel] = aperture.shape[0]
    rel = "state/controller_detail_state"
    raw_phase = _dataset(group, rel, path, trial)
    if np.asarray(raw_phase).ndim != 1:
        raise DataFileError(path, f"{trial}/{rel} has shape {np.shape(raw_phase)}; expected (N,)", trial=trial)
    phase = _strings(raw_phase)
    columns[rel] = phase.shape[0]
    tool_z = None
    if group.get("transforms/translation") is not None:
        rel = "transforms/translation"
        tool_z = _numeric(_dataset(group, rel, path, trial), rel, (3,), path, trial)[:, 2].copy()
        columns[rel] = tool_z.shape[0]
    adjectives = None
    if group.get("adjectives") is not None:
        adjectives = tuple(str(a) for a in _strings(np.atleast_1d(_dataset(group, "adjectives", path, trial))))
    if len(set(columns.values())) != 1:
        lengths = ", ".join(f"{k}: {v}" for k, v in columns.items())
        raise DataFileError(path, f"inconsistent lengths (rows per dataset): {lengths}", trial=trial)
    if aperture.shape[0] == 0:
        raise DataFileError(path, "trial has no rows (N = 0)", trial=trial)
    return RawTrial(
        trial_id=trial,
        object_id=object_id,
        object_name=object_name,
        trial_index=trial_index,
        source=str(path),
        fingers=tuple(fingers),
        gripper_aperture=aperture,
        phase=phase,
        tool_z=tool_z,
        adjectives=adjectives,
    )


def require_eps(trial: RawTrial, eps: Iterable[str] = tuple(PHAC2_EPS)) -> None:
    """Check that every exploratory procedure in ``eps`` has at least one row in ``trial``.

    Parameters
    ----------
    trial : RawTrial
    eps : iterable of str
        EP names (keys of :data:`PHAC2_EPS`) or raw ``controller_detail_state`` strings.

    Raises
    ------
    DataFileError
        Names the trial's source file, the trial and the absent EP.
    """
    for ep in eps:
        if not np.any(trial.ep_mask(ep)):
            state = PHAC2_EPS.get(ep, ep)
            raise DataFileError(
                trial.source,
                f"exploratory procedure {ep!r} (controller_detail_state {state!r}) is absent",
                trial=trial.trial_id,
            )


def iter_phac2_h5(
    path: str | os.PathLike,
    trials: Sequence[str] | None = None,
    *,
    eps: Iterable[str] | None = None,
) -> Iterator[RawTrial]:
    """Yield the trials of a PHAC-2 HDF5 file one at a time (constant memory).

    Same parameters, checks and errors as :func:`load_phac2_h5`; the file stays open
    while the iterator is alive. Requested ``trials`` are checked to exist before the
    first trial is yielded.
    """
    path = Path(path)
    eps = None if eps is None else tuple(eps)
    with _open(path) as fh:
        names = _trial_names(fh, path)
        if trials is not None:
            known = set(names)
            for t in trials:
                if t not in known:
                    raise DataFileError(path, "trial not in file", trial=t)
            names = list(trials)
        for name in names:
            try:
                trial = _read_trial(fh[name], path, name)
            except OSError as exc:  # h5py raises OSError on truncated data blocks
                raise DataFileError(
                    path, f"cannot read trial (truncated or corrupt?): {exc}", trial=name
                ) from None
            if eps is not None:
                require_eps(trial, eps)
            yield trial


def load_phac2_h5(
    path: str | os.PathLike,
    trials: Sequence[str] | None = None,
    *,
    eps: Iterable[str] | None = None,
) -> list[RawTrial]:
    """Read raw trials from a PHAC-2 HDF5 file in the official release layout.

    Parameters
    ----------
    path : str or path-like
        The HDF5 file (e.g. ``phac_train_test_pos_neg_90_10_1_20.h5`` of the release, or a
        file written by :func:`write_phac2_h5`).
    trials : sequence of str or None
        Trial ids to read (file order if None: all trial groups). For the full release
        (600 trials, several GB as float64) prefer :func:`iter_phac2_h5`.
    eps : iterable of str or None
        If given, every returned trial must contain these EPs (see :func:`require_eps`).

    Returns
    -------
    list of RawTrial
        Float64 signals (raw ADC counts), ``gripper_aperture`` in metres, ``phase`` the
        decoded ``controller_detail_state`` per row, ``tool_z`` the z of
        ``transforms/translation`` (metres) or None if absent, ``adjectives`` the trial's
        adjective list or None.

    Raises
    ------
    DataFileError
        Not HDF5 / truncated; unknown top-level entry; a requested trial is absent; a
        missing finger or signal (names file, trial and dataset path); wrong shape;
        inconsistent lengths; NaN/inf; an EP in ``eps`` absent.
    """
    return list(iter_phac2_h5(path, trials, eps=eps))


def write_phac2_h5(path: str | os.PathLike, trials: Sequence[RawTrial]) -> Path:
    """Write trials to an HDF5 file in the PHAC-2 release layout (readable by :func:`load_phac2_h5`).

    Written per trial: ``biotacs/finger_{i}/{electrodes, pac, pdc, tac, tdc}`` (the
    arrays' own dtype), ``gripper_aperture/joint_position`` (metres),
    ``state/controller_detail_state`` (S30), ``transforms/translation`` (N, 3) if
    ``tool_z`` is set (x = y = 0: RawTrial keeps only z), and ``adjectives`` if set.
    Fields RawTrial does not carry (timestamps, accelerometer, joint velocity/effort,
    controller_state, rotation) are not written. The file is replaced atomically.

    Parameters
    ----------
    path : str or path-like
        Destination ``.h5`` file.
    trials : sequence of RawTrial
        Trials with distinct ids of the form ``<object>_<id3>_<trial2>``, two fingers.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    DataFileError
        Duplicate or malformed trial ids, a state name longer than 30 characters, or not
        exactly two fingers.
    """
    path = Path(path)
    seen: set[str] = set()
    for t in trials:
        parse_trial_id(t.trial_id, path)
        if t.trial_id in seen:
            raise DataFileError(path, "duplicate trial id", trial=t.trial_id)
        seen.add(t.trial_id)
        if len(t.fingers) != len(FINGERS):
            raise DataFileError(path, f"{len(t.fingers)} fingers; expected 2", trial=t.trial_id)
        too_long = [s for s in np.unique(np.asarray(t.phase, dtype=str)) if len(s.encode()) > _STATE_LEN]
        if too_long:
            raise DataFileError(path, f"state name {too_long[0]!r} exceeds {_STATE_LEN} bytes", trial=t.trial_id)

    def _write(tmp: Path) -> None:
        with h5py.File(tmp, "w") as fh:
            for t in trials:
                g = fh.create_group(t.trial_id)
                for finger, sig in zip(FINGERS, t.fingers, strict=True):
                    fg = g.create_group(f"biotacs/{finger}")
                    for name in BIOTAC_SIGNALS:
                        fg.create_dataset(name, data=np.asarray(getattr(sig, name)))
                g.create_dataset("gripper_aperture/joint_position", data=np.asarray(t.gripper_aperture))
                g.create_dataset(
                    "state/controller_detail_state", data=np.asarray(t.phase, dtype=str).astype(f"S{_STATE_LEN}")
                )
                if t.tool_z is not None:
                    z = np.asarray(t.tool_z, dtype=np.float64)
                    translation = np.zeros((z.shape[0], 3))
                    translation[:, 2] = z
                    g.create_dataset("transforms/translation", data=translation)
                if t.adjectives is not None:
                    g.create_dataset("adjectives", data=np.array(list(t.adjectives), dtype="S"))

    return atomic_write(path, _write)
