"""Loader output -> the tidy :class:`~tzsl.datasets.FeatureSet` every later layer uses.

Two sources:

* :func:`penn_feature_set` - Penn's static features (all 60 PHAC-2 objects): the
  comparable columns split per finger, 13 per EP, 52 per finger with the 4 EPs.
* :func:`raw_feature_set` - raw trials (HDF5 release or HOLD-only MATLAB files): the
  paper's 26 features per EP and BioTac, 104 with the 4 EPs, 26 for ``eps=("hold",)``.

Both filter the attribute table with :func:`~tzsl.features.filter_attributes`, counting
positives over the objects that have trials in the set (an attribute no object of the data
at hand shows cannot be learned from it); the dropped names go to
``info["dropped_attributes"]``. Z-scoring / PCA are *not* applied here: they must be fitted
on training objects only, inside a split.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import pandas as pd

from tzsl.datasets import TRIAL_COLUMNS, FeatureSet, RawTrial
from tzsl.exceptions import DataFileError
from tzsl.features._attribute_filter import check_attribute_table, filter_attributes
from tzsl.features._baseline import PHAC2_EP_NAMES, check_eps, trial_error
from tzsl.features._penn_columns import PENN_DROPPED_COLUMNS, select_penn_columns, short_ep_names
from tzsl.features._raw_features import RawTrialFeatures

if TYPE_CHECKING:  # the loader's structure; only its fields are used here
    from tzsl.datasets import PennStaticData


def _object_attributes(
    labels: pd.DataFrame, objects: Sequence[str], min_objects: int
) -> tuple[pd.DataFrame, list[str]]:
    """Rows of ``objects`` (in that order), filtered to attributes in >= min_objects of them."""
    table = check_attribute_table(labels)
    return filter_attributes(table.loc[list(objects)], min_objects)


def penn_feature_set(data: "PennStaticData", min_objects: int = 3) -> FeatureSet:
    """Per-finger Penn static features with the filtered attribute table.

    Parameters
    ----------
    data : PennStaticData
        From :func:`tzsl.datasets.load_phac2_penn`: ``X`` (n_trials, n_eps, 47),
        ``trials`` (table with :data:`~tzsl.datasets.TRIAL_COLUMNS`), ``eps`` (EP names
        along axis 1), ``labels`` (objects x adjectives, 0/1, indexed by object_name).
    min_objects : int, default 3
        Keep adjectives present in at least this many objects (19 of 24 on PHAC-2).

    Returns
    -------
    FeatureSet
        ``X`` (n_trials, 2, 13 * n_eps) - (600, 2, 52) on PHAC-2 - in Penn's units;
        ``sensors`` ``("finger_0", "finger_1")``; ``feature_names`` such as
        ``"hold:pdc_max"``; ``attributes`` the kept adjectives of the objects with trials;
        ``dataset`` ``"phac2-penn"``; ``info`` with ``dropped_attributes``, ``eps``,
        ``min_objects`` and ``penn_dropped_columns``.

    Raises
    ------
    DataFileError
        Malformed features or trial table, an object without a label row, invalid labels.
    """
    X, names = select_penn_columns(data.X, data.eps)
    trials = _check_trial_table(data.trials, X.shape[0])
    objects = trials["object_name"].unique()
    _check_labelled(objects, data.labels)
    attributes, dropped = _object_attributes(data.labels, objects, min_objects)
    return FeatureSet(
        X=X,
        trials=trials,
        sensors=("finger_0", "finger_1"),
        feature_names=tuple(names),
        attributes=attributes,
        dataset="phac2-penn",
        info={
            "dropped_attributes": dropped,
            "eps": list(short_ep_names(data.eps)),
            "min_objects": int(min_objects),
            "penn_dropped_columns": list(PENN_DROPPED_COLUMNS),
        },
    )


def raw_feature_set(
    trials: Sequence[RawTrial],
    labels: pd.DataFrame,
    eps: Sequence[str] = PHAC2_EP_NAMES,
    min_objects: int = 3,
    *,
    baseline_rows: int = 100,
    travel: str = "auto",
    dataset: str = "phac2-raw",
) -> FeatureSet:
    """Per-BioTac feature vectors of raw trials with the filtered attribute table.

    Parameters
    ----------
    trials : sequence of RawTrial, length n_trials
        E.g. from :func:`tzsl.datasets.load_phac2_h5` or
        :func:`tzsl.datasets.load_phac2_hold_mat`.
    labels : DataFrame (objects x attributes), 0/1
        Indexed by ``object_name``; every trial's object needs a row.
    eps : sequence of str, default the 4 PHAC-2 EPs
        ``("hold",)`` for the HOLD-only MATLAB files.
    min_objects : int, default 3
        Keep attributes present in at least this many of the trials' objects.
    baseline_rows, travel
        See :class:`~tzsl.features.RawTrialFeatures`.
    dataset : str, default "phac2-raw"
        Name stored in the result.

    Returns
    -------
    FeatureSet
        ``X`` (n_trials, n_fingers, 26 * n_eps): per finger 23 * n_eps BioTac averages
        (ADC counts relative to the baseline) then 3 * n_eps gripper features (m);
        ``trials`` with :data:`~tzsl.datasets.TRIAL_COLUMNS` plus ``source``;
        ``info`` with ``dropped_attributes``, ``eps``, ``min_objects``,
        ``baseline_rows`` and the resolved ``travel``.

    Raises
    ------
    DataFileError
        No trials, a duplicate trial id, a trial whose object has no label row, invalid
        labels, or any bad trial (see :class:`~tzsl.features.RawTrialFeatures`).
    """
    eps = check_eps(eps)
    trials = list(trials)
    if not trials:
        raise DataFileError(None, "no trials to extract features from")
    seen: set[str] = set()
    for trial in trials:
        if not isinstance(trial, RawTrial):
            raise DataFileError(None, f"expected RawTrial objects, got {type(trial).__name__}")
        if trial.trial_id in seen:
            raise trial_error(trial, "trial id occurs twice in the trial list")
        seen.add(trial.trial_id)
    _check_labelled_trials(trials, labels)
    extractor = RawTrialFeatures(eps=eps, baseline_rows=baseline_rows, travel=travel)
    X = extractor.fit_transform(trials)
    table = pd.DataFrame(
        {
            "trial_id": [t.trial_id for t in trials],
            "object_id": [int(t.object_id) for t in trials],
            "object_name": [t.object_name for t in trials],
            "trial_index": [int(t.trial_index) for t in trials],
            "source": [str(t.source) for t in trials],
        }
    )
    objects = table["object_name"].unique()
    attributes, dropped = _object_attributes(labels, objects, min_objects)
    return FeatureSet(
        X=X,
        trials=table,
        sensors=tuple(f"finger_{f}" for f in range(extractor.n_fingers_)),
        feature_names=tuple(extractor.get_feature_names_out()),
        attributes=attributes,
        dataset=dataset,
        info={
            "dropped_attributes": dropped,
            "eps": list(eps),
            "min_objects": int(min_objects),
            "baseline_rows": int(baseline_rows),
            "travel": extractor.travel_,
        },
    )


def _check_trial_table(trials: pd.DataFrame, n_trials: int) -> pd.DataFrame:
    if not isinstance(trials, pd.DataFrame):
        raise DataFileError(None, f"trial table must be a DataFrame, got {type(trials).__name__}")
    missing = [c for c in TRIAL_COLUMNS if c not in trials.columns]
    if missing:
        raise DataFileError(None, f"trial table lacks the columns {missing}")
    if len(trials) != n_trials:
        raise DataFileError(
            None, f"trial table has {len(trials)} rows but the features have {n_trials} trials"
        )
    return trials.reset_index(drop=True)


def _check_labelled(objects: Sequence[str], labels: pd.DataFrame) -> None:
    if not isinstance(labels, pd.DataFrame):
        raise DataFileError(None, f"labels must be a DataFrame, got {type(labels).__name__}")
    missing = [o for o in objects if o not in labels.index]
    if missing:
        raise DataFileError(
            labels.attrs.get("source"),
            f"{len(missing)} object(s) have trials but no row in the attribute table, "
            f"e.g. {missing[0]!r}",
        )


def _check_labelled_trials(trials: Sequence[RawTrial], labels: pd.DataFrame) -> None:
    if not isinstance(labels, pd.DataFrame):
        raise DataFileError(None, f"labels must be a DataFrame, got {type(labels).__name__}")
    for trial in trials:
        if trial.object_name not in labels.index:
            raise trial_error(
                trial,
                f"object {trial.object_name!r} has no row in the attribute table "
                f"({len(labels)} objects, e.g. {list(labels.index[:3])})",
            )
