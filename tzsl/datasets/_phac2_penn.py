"""Penn's per-trial static PHAC-2 features (Chu et al., RAS 2015) from their pickles.

96 Python-2 pickles ``static_feature_<adjective>_<EP state>.pkl`` (24 adjectives x 4
EPs; PROVENANCE.md section 3), each ``{'train': {...}, 'test': {...}}`` with
``features`` (n, 47) float64, ``labels`` (n,) 0/1 for that adjective, ``object_ids``
(n,) and ``object_names`` (n,) trial names. All 24 files of one EP carry the same
features; they differ only in labels and in Penn's train/test split. They are read with
:func:`tzsl.datasets.safe_load_pickle` (no code execution).
"""

from __future__ import annotations

import os
import re
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets._phac2_hold_mat import LABELS_CSV, parse_trial_id, read_phac2_labels_csv
from tzsl.datasets._registry import fetch, registered_files
from tzsl.datasets._safe_pickle import safe_load_pickle
from tzsl.datasets._types import PHAC2_EPS, TRIAL_COLUMNS
from tzsl.exceptions import DataFileError

PENN_STATIC_DIR = "phac2/penn_bolt_ml_data/static_adjective_phase_set/"

#: Names of Penn's 47 static features (PROVENANCE.md section 3). Pairs ``_f0``/``_f1``
#: are BioTac finger 0/1; 20-22 are gripper / tool kinematics; 23-46 are per-trial PCA
#: polynomial coefficients (NOT comparable across trials).
PENN_FEATURE_NAMES: tuple[str, ...] = (
    *(
        f"{name}_f{finger}"
        for name in (
            "pdc_rise_count",
            "pdc_area",
            "pdc_max",
            "pac_energy",
            "pac_spectral_centroid",
            "pac_spectral_variance",
            "pac_spectral_skewness",
            "pac_spectral_kurtosis",
            "tac_area",
            "tdc_time_constant",
        )
        for finger in (0, 1)
    ),
    "gripper_min",
    "gripper_mean",
    "transform_distance",
    *(f"electrode_polyfit_{i:02d}" for i in range(24)),
)
N_PENN_FEATURES = len(PENN_FEATURE_NAMES)

_STATE_TO_EP = {state: ep for ep, state in PHAC2_EPS.items()}
_FILE_RE = re.compile(
    r"^static_feature_(?P<adjective>.+)_(?P<state>" + "|".join(PHAC2_EPS.values()) + r")\.pkl$"
)
_FIELDS = ("features", "labels", "object_ids", "object_names")


@dataclass(frozen=True)
class PennStaticData:
    """Penn's static features of every PHAC-2 trial and the object x adjective labels.

    Attributes
    ----------
    X : ndarray of shape (n_trials, 4, 47), float64, read-only
        ``X[i, e, f]`` = feature ``f`` of trial ``i`` in EP ``eps[e]``; unstandardised
        (units as in Penn's code: ADC counts, metres for 20-22).
    trials : DataFrame with n_trials rows
        Columns :data:`TRIAL_COLUMNS` (``trial_id``, ``object_id``, ``object_name``,
        ``trial_index``); sorted by object_id then trial_index; row ``i`` describes ``X[i]``.
    eps : tuple of str
        EP names in :data:`PHAC2_EPS` order: squeeze, hold, slow_slide, fast_slide.
    feature_names : tuple of str, length 47
        :data:`PENN_FEATURE_NAMES`.
    labels : DataFrame of shape (n_objects, n_adjectives), int64 0/1
        Index ``object_name`` (``<object>_<id3>``) in object-id order; columns the
        adjectives, sorted.
    object_ids : Series
        Numeric object id, indexed by ``object_name`` (same order as ``labels``).
    sources : tuple of str
        The pickle files read (and the label CSV it was checked against, if any).
    """

    X: np.ndarray
    trials: pd.DataFrame
    eps: tuple[str, ...]
    feature_names: tuple[str, ...]
    labels: pd.DataFrame
    object_ids: pd.Series
    sources: tuple[str, ...]

    @property
    def n_trials(self) -> int:
        return int(self.X.shape[0])

    def trial_labels(self) -> np.ndarray:
        """Label row of every trial's object, shape (n_trials, n_adjectives), int 0/1."""
        return self.labels.loc[self.trials["object_name"]].to_numpy()


def _file_key(path: Path) -> tuple[str, str]:
    match = _FILE_RE.match(path.name)
    if match is None:
        raise DataFileError(
            path,
            "file name does not follow static_feature_<adjective>_<EP state>.pkl with an EP "
            f"state in {sorted(_STATE_TO_EP)}",
        )
    return match["adjective"], _STATE_TO_EP[match["state"]]


def _read_one(path: Path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """features (n, 47), labels (n,), trial names (n) of one pickle, train+test."""
    data = safe_load_pickle(path)
    if not isinstance(data, Mapping) or not {"train", "test"} <= set(data):
        raise DataFileError(path, "expected a dict with 'train' and 'test' parts")
    feats, labels, names = [], [], []
    for part in ("train", "test"):
        block = data[part]
        if not isinstance(block, Mapping):
            raise DataFileError(path, f"{part!r} is a {type(block).__name__}, expected a dict")
        missing = [f for f in _FIELDS if f not in block]
        if missing:
            raise DataFileError(path, f"{part!r} lacks {missing}")
        f = np.asarray(block["features"])
        n = f.shape[0] if f.ndim else -1
        if f.ndim != 2 or f.shape[1] != N_PENN_FEATURES or not np.issubdtype(f.dtype, np.number):
            raise DataFileError(
                path, f"{part!r} features have shape {f.shape} ({f.dtype}); expected (n, 47) numeric"
            )
        parts = {k: np.asarray(block[k]) for k in ("labels", "object_ids", "object_names")}
        for key, arr in parts.items():
            if arr.shape != (n,):
                raise DataFileError(path, f"{part!r} {key} has shape {arr.shape}; expected ({n},)")
        trial_names = [
            v.decode("ascii", "replace") if isinstance(v, bytes) else str(v)
            for v in parts["object_names"]
        ]
        # the numeric ids must agree with the ids inside the trial names
        ids_from_names = np.array([parse_trial_id(t, path)[1] for t in trial_names], dtype=np.int64)
        wrong = np.flatnonzero(ids_from_names != parts["object_ids"].astype(np.int64))
        if wrong.size:
            i = int(wrong[0])
            raise DataFileError(
                path, f"object_id {parts['object_ids'][i]} disagrees with the trial name",
                trial=trial_names[i],
            )
        lab = parts["labels"]
        if not np.isin(lab, (0, 1)).all():
            i = int(np.flatnonzero(~np.isin(lab, (0, 1)))[0])
            raise DataFileError(path, f"label {lab[i]!r} is not 0/1", trial=trial_names[i])
        finite = np.isfinite(f.astype(np.float64))
        if not finite.all():
            i, j = (int(v) for v in np.argwhere(~finite)[0])
            raise DataFileError(
                path, f"feature {j} ({PENN_FEATURE_NAMES[j]}) is {f[i, j]} (NaN/inf)",
                trial=trial_names[i],
            )
        feats.append(f.astype(np.float64))
        labels.append(lab.astype(np.int64))
        names.extend(trial_names)
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise DataFileError(path, "trial appears twice in train+test", trial=name)
        seen.add(name)
    return np.concatenate(feats), np.concatenate(labels), names


def read_penn_static_pickles(
    paths: Sequence[str | os.PathLike], labels_csv: str | os.PathLike | None = None
) -> PennStaticData:
    """Read and cross-check a complete set of Penn static-feature pickles.

    Parameters
    ----------
    paths : sequence of path-like
        ``static_feature_<adjective>_<EP state>.pkl`` files forming a full adjective x EP
        grid (every adjective present for all 4 EPs). Not checksum-verified here.
    labels_csv : path-like or None
        If given, an object x adjective CSV (see :func:`read_phac2_labels_csv`) that the
        labels built from the pickles must equal.

    Returns
    -------
    PennStaticData

    Raises
    ------
    DataFileError
        A file is unreadable or not a safe pickle; a file is missing from the grid; NaN/inf
        features (names file and trial); files of one EP disagree on a trial's features
        (names both files and the trial); files cover different trials; a trial's label
        differs across EPs, or trials of one object have different labels (names object
        and trial); the labels differ from ``labels_csv``.
    """
    files = [Path(p) for p in paths]
    if not files:
        raise DataFileError(None, "no Penn static feature pickles given")
    grid: dict[tuple[str, str], Path] = {}
    for path in files:
        key = _file_key(path)
        if key in grid:
            raise DataFileError(path, f"duplicate of {grid[key]} (same adjective and EP)")
        grid[key] = path
    adjectives = sorted({adj for adj, _ in grid})
    eps = tuple(PHAC2_EPS)
    for adj in adjectives:
        for ep in eps:
            if (adj, ep) not in grid:
                folder = files[0].parent
                raise DataFileError(
                    folder / f"static_feature_{adj}_{PHAC2_EPS[ep]}.pkl",
                    f"missing: adjective {adj!r} has no file for EP {ep!r}",
                )

    first = grid[(adjectives[0], eps[0])]
    n_adj = len(adjectives)
    X: np.ndarray | None = None
    L: np.ndarray | None = None
    ref_names: list[str] = []
    ref_index: dict[str, int] = {}
    for e, ep in enumerate(eps):
        ep_ref: Path | None = None
        for a, adj in enumerate(adjectives):
            path = grid[(adj, ep)]
            feats, labels, names = _read_one(path)
            if X is None or L is None:  # the first file: both are made together
                meta = [(*parse_trial_id(t, path), t) for t in names]
                order = sorted(range(len(names)), key=lambda i: (meta[i][1], meta[i][2]))
                ref_names = [names[i] for i in order]
                ref_index = {t: i for i, t in enumerate(ref_names)}
                X = np.empty((len(ref_names), len(eps), N_PENN_FEATURES))
                L = np.empty((n_adj, len(eps), len(ref_names)), dtype=np.int64)
            if len(names) != len(ref_index) or not all(t in ref_index for t in names):
                extra = sorted(set(names) - set(ref_index))
                lacking = sorted(set(ref_index) - set(names))
                raise DataFileError(
                    path,
                    f"train+test cover different trials than {first.name}: "
                    f"extra {extra[:5]}, missing {lacking[:5]}",
                )
            pos = np.fromiter((ref_index[t] for t in names), dtype=np.intp, count=len(names))
            aligned = np.empty_like(feats)
            aligned[pos] = feats
            if ep_ref is None:
                X[:, e, :] = aligned
                ep_ref = path
            elif not np.array_equal(aligned, X[:, e, :]):
                i = int(np.flatnonzero((aligned != X[:, e, :]).any(axis=1))[0])
                raise DataFileError(
                    path,
                    f"features differ from {ep_ref} (same EP {ep!r}); all adjective files of "
                    "an EP must carry identical features",
                    trial=ref_names[i],
                )
            L[a, e, pos] = labels

    assert X is not None and L is not None
    trials = pd.DataFrame(
        [(t, *parse_trial_id(t)) for t in ref_names],
        columns=["trial_id", "object_name", "object_id", "trial_index"],
    )[list(TRIAL_COLUMNS)]
    trials["object_id"] = trials["object_id"].astype(np.int64)
    trials["trial_index"] = trials["trial_index"].astype(np.int64)

    # a trial's label for an adjective must not depend on the EP file it came from
    diff_ep = L != L[:, :1, :]
    if diff_ep.any():
        a, e, i = (int(v) for v in np.argwhere(diff_ep)[0])
        raise DataFileError(
            grid[(adjectives[a], eps[e])],
            f"label for {adjectives[a]!r} is {L[a, e, i]} here but {L[a, 0, i]} in "
            f"{grid[(adjectives[a], eps[0])].name}",
            trial=ref_names[i],
        )
    # all trials of one object must share its labels (trials are sorted by object)
    per_trial = L[:, 0, :].T  # (n_trials, n_adj)
    codes, starts = np.unique(trials["object_id"].to_numpy(), return_index=True)
    first_row = per_trial[np.repeat(starts, np.diff(np.append(starts, len(ref_names))))]
    bad = np.argwhere(per_trial != first_row)
    if bad.size:
        i, a = (int(v) for v in bad[0])
        obj = trials.at[i, "object_name"]
        raise DataFileError(
            grid[(adjectives[a], eps[0])],
            f"trials of one object with different labels: object {obj!r} has "
            f"{adjectives[a]!r} = {per_trial[i, a]} in trial {ref_names[i]} but "
            f"{first_row[i, a]} in its first trial",
            trial=ref_names[i],
        )
    obj_names = trials["object_name"].to_numpy()[starts]
    labels_df = pd.DataFrame(
        per_trial[starts],
        index=pd.Index(obj_names, name="object_name"),
        columns=pd.Index(adjectives, name="adjective"),
    )
    object_ids = pd.Series(codes.astype(np.int64), index=labels_df.index.copy(), name="object_id")
    sources = tuple(str(grid[(adj, ep)]) for ep in eps for adj in adjectives)

    if labels_csv is not None:
        _check_against_csv(labels_df, Path(labels_csv))
        sources = (*sources, str(labels_csv))
    X.flags.writeable = False
    return PennStaticData(
        X=X,
        trials=trials,
        eps=eps,
        feature_names=PENN_FEATURE_NAMES,
        labels=labels_df,
        object_ids=object_ids,
        sources=sources,
    )


def _check_against_csv(labels: pd.DataFrame, csv: Path) -> None:
    expected = read_phac2_labels_csv(csv)
    if set(expected.index) != set(labels.index):
        raise DataFileError(
            csv,
            "objects differ from the pickles: only in CSV "
            f"{sorted(set(expected.index) - set(labels.index))[:5]}, only in pickles "
            f"{sorted(set(labels.index) - set(expected.index))[:5]}",
        )
    if list(expected.columns) != list(labels.columns):
        raise DataFileError(
            csv,
            f"adjectives differ from the pickles: CSV {list(expected.columns)}, pickles "
            f"{list(labels.columns)}",
        )
    aligned = expected.loc[labels.index]
    diff = aligned.to_numpy() != labels.to_numpy()
    if diff.any():
        i, a = (int(v) for v in np.argwhere(diff)[0])
        raise DataFileError(
            csv,
            f"label matrix differs from the pickles: object {labels.index[i]!r}, adjective "
            f"{labels.columns[a]!r} is {aligned.iat[i, a]} in the CSV but {labels.iat[i, a]} "
            "in the pickles",
        )


def labels_csv_bytes(labels: pd.DataFrame) -> bytes:
    """``phac2/derived/phac2_labels_60x24.csv`` as registered, from the pickles' label matrix.

    ``labels``: (60, 24) 0/1, indexed ``<name>_<id>`` (:func:`read_penn_static_pickles`). Rows by
    object id, columns ``object_id, object_name`` then the adjectives; CRLF line ends (as published).
    """
    parts = [str(key).rpartition("_") for key in labels.index]
    table = pd.concat([pd.DataFrame({"object_id": [int(p[2]) for p in parts], "object_name": [p[0] for p in parts]}),
                       labels.reset_index(drop=True)], axis=1).sort_values("object_id", kind="stable")
    return table.to_csv(index=False, lineterminator="\r\n").encode()


_CACHE: dict[tuple, PennStaticData] = {}
_CACHE_LOCK = threading.Lock()


def load_phac2_penn(data_dir: str | os.PathLike | None = None) -> PennStaticData:
    """Penn's static features of all 600 PHAC-2 trials (60 objects x 10) and the labels.

    Fetches the 96 registered pickles and ``phac2/derived/phac2_labels_60x24.csv`` from the
    data home (checksum-verified on first use), reads them with the restricted unpickler,
    cross-checks them (see :func:`read_penn_static_pickles`) and checks that the label
    matrix built from the pickles equals the CSV. The result is cached in-process.

    Parameters
    ----------
    data_dir : str or path-like or None
        Data home; see :func:`tzsl.datasets.get_data_home`.

    Returns
    -------
    PennStaticData
        ``X`` (600, 4, 47) float64; ``trials`` 600 rows; ``labels`` (60, 24).

    Raises
    ------
    DataMissingError, ChecksumError, DataFileError
    """
    rels = registered_files(PENN_STATIC_DIR)
    paths = [fetch(rel, data_dir) for rel in rels]
    csv = fetch(LABELS_CSV, data_dir)
    key = tuple(
        (str(p), st.st_size, st.st_mtime_ns) for p in (*paths, csv) for st in (p.stat(),)
    )
    with _CACHE_LOCK:
        cached = _CACHE.get(key)
    if cached is None:
        cached = read_penn_static_pickles(paths, labels_csv=csv)
        n_obj = cached.labels.shape[0]
        if cached.n_trials != 600 or n_obj != 60 or cached.labels.shape[1] != 24:
            raise DataFileError(
                paths[0].parent,
                f"expected 600 trials, 60 objects, 24 adjectives; got {cached.n_trials}, "
                f"{n_obj}, {cached.labels.shape[1]}",
            )
        with _CACHE_LOCK:
            _CACHE[key] = cached
    # hand out copies of the mutable tables so callers cannot corrupt the cache
    return replace(
        cached,
        trials=cached.trials.copy(),
        labels=cached.labels.copy(),
        object_ids=cached.object_ids.copy(),
    )
