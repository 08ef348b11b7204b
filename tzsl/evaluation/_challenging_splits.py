"""Challenging object splits (F6, DAP paper section 4.6): test objects from one wedge of a 2-D map.

All objects' features are projected to a 2-D PCA map (unsupervised: no attribute or label is
used); the plane is cut into four wedges by the lines y = x and y = -x, and each test set is a
wedge (or half of one), so test objects differ in their features from the training objects.
The rules every split obeys (distinct test vectors, minimum positive training objects per
attribute) are those of :mod:`tzsl.evaluation._splits`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import pandas as pd
from sklearn.decomposition import PCA
from sklearn.preprocessing import StandardScaler

from tzsl.evaluation._splits import (
    Split,
    attribute_exclusions,
    check_attribute_table,
    check_min_counts,
    duplicate_attribute_groups,
    kept_mask,
)
from tzsl.exceptions import SplitError

__all__ = ["WEDGES", "challenging_splits"]

#: Wedge names of the plane cut by y = x and y = -x, counter-clockwise from the left wedge.
WEDGES: tuple[str, ...] = ("left", "bottom", "right", "top")
# Each wedge is two 45-degree sectors; sector k covers angles [-180 + 45 k, -135 + 45 k).
# The halving line of a wedge (y = 0 for left/right, x = 0 for top/bottom) separates them.
_SECTOR_EDGES = np.arange(-135.0, 180.0, 45.0)  # 7 inner edges -> sectors 0..7
_SECTOR_NAME = (
    "left-lower", "bottom-left", "bottom-right", "right-lower",
    "right-upper", "top-right", "top-left", "left-upper",
)
_SECTOR_WEDGE = ("left", "bottom", "bottom", "right", "right", "top", "top", "left")



def _object_map(object_features: pd.DataFrame, standardize: bool) -> tuple[pd.DataFrame, np.ndarray]:
    """2-D PCA map: fit on all rows (trials), project, average per object (index order kept)."""
    X = object_features.to_numpy(dtype=float)
    if standardize:
        X = StandardScaler().fit_transform(X)
    if not np.any(X.var(axis=0) > 0):
        raise SplitError("object_features do not vary across rows: no 2-D map can be drawn")
    pca = PCA(n_components=2, svd_solver="full")
    P = pca.fit_transform(X)
    coords = pd.DataFrame(P, columns=["x", "y"], index=object_features.index)
    coords = coords.groupby(level=0, sort=False).mean()
    return coords, pca.explained_variance_ratio_


def _validate_features(object_features: pd.DataFrame, objects: tuple[str, ...]) -> pd.DataFrame:
    if not isinstance(object_features, pd.DataFrame):
        raise SplitError(
            "object_features must be a DataFrame indexed by object name (one row per object, or "
            f"one row per trial), got {type(object_features).__name__}"
        )
    feats = object_features.copy()
    feats.index = feats.index.map(str)
    try:
        X = feats.to_numpy(dtype=float)
    except (TypeError, ValueError) as exc:
        raise SplitError(f"object_features must be numeric: {exc}") from None
    if X.ndim != 2 or X.shape[1] < 2:
        raise SplitError(f"object_features needs at least 2 feature columns, got shape {X.shape}")
    bad_rows = ~np.isfinite(X).all(axis=1)
    if bad_rows.any():
        raise SplitError(
            "object_features has NaN or infinite values in rows of object(s) "
            f"{sorted(set(feats.index[bad_rows]))[:5]}"
        )
    have = set(feats.index)
    unknown = sorted(have - set(objects))
    missing = [o for o in objects if o not in have]
    if unknown:
        raise SplitError(f"object_features has object(s) not in the attribute table: {unknown[:10]}")
    if missing:
        raise SplitError(f"object(s) of the attribute table have no features: {missing[:10]}")
    return feats


def challenging_splits(
    object_features: pd.DataFrame,
    object_attributes: pd.DataFrame,
    *,
    standardize: bool = True,
    halve: Literal["densest", "left", "bottom", "right", "top"] = "densest",
    min_train_positives: int = 3,
    min_train_negatives: int = 1,
) -> tuple[list[Split], pd.DataFrame]:
    """Challenging splits from a 2-D map of haptic similarity (DAP paper 4.6, Fig. 3, Table 3).

    Procedure (paper, with our reading of the unclear points):

    1. **Map.** PCA to 2 components, fitted on every row of ``object_features``; each
       object's point is the mean of its rows' projections. The paper fits PCA on the trial
       vectors (z-scored features, already reduced to 25-d by PCA) and averages each
       object's 10 trials, so pass one row per trial to follow it exactly; one row per
       object (mean features) also works. ``standardize=True`` z-scores each column first,
       as the paper's features are (section 4.3); the top 2 PCs of z-scored features equal
       those of their 95%-variance PCA, so raw per-trial features + ``standardize=True``
       reproduce the paper's map. The map uses test objects' features but no labels: it only
       chooses the split, as in the paper.
    2. **Wedges.** The lines y = x and y = -x cut the plane into left, bottom, right and top
       wedges (angle ranges [135, -135), [-135, -45), [-45, 45), [45, 135) degrees; points on
       a line go to the wedge counter-clockwise of it; the origin goes to "right").
    3. **Halving.** The paper halves "the partition on the left", which it calls
       significantly denser than the others. All wedges span the same angle, so we take the
       *densest* wedge to be the one holding the most objects (ties: left, bottom, right,
       top) and halve it along its bisecting axis: y = 0 for left/right (the paper's line),
       x = 0 for top/bottom. ``halve="left"`` forces the paper's choice. On PHAC-2 the
       densest wedge is the left one.
    4. **Splits.** Partitions are numbered 1..5 counter-clockwise, starting where the
       halved wedge starts: for the left wedge 1 left-upper, 2 left-lower, 3 bottom,
       4 right, 5 top (the halves of a top/bottom wedge are its right/left halves).
       Split ``k`` tests on partition ``k`` and trains on all objects of the other four.
    5. **Rules.** Attributes with too few positive / negative training objects are left out
       for the split (reported). Within the test partition, objects repeating an earlier
       object's vector over the kept attributes are dropped (kept: the first in
       attribute-table order) and reported in :attr:`Split.dropped_objects`; dropped objects
       are in neither set, so no test attribute vector is seen in training through them.

    Parameters
    ----------
    object_features : DataFrame of shape (n_rows, n_features)
        Indexed by object name; one row per object or several (one per trial). Every object
        of ``object_attributes`` must appear, and no other.
    object_attributes : DataFrame of shape (n_objects, n_attributes)
        0/1 table indexed by object name.
    standardize : bool, default True
        z-score feature columns before the PCA (fitted on all rows).
    halve : {"densest", "left", "bottom", "right", "top"}, default "densest"
        Wedge to cut in two.
    min_train_positives, min_train_negatives : int, default 3 and 1
        Exclusion rule (see module docstring).

    Returns
    -------
    splits : list of 5 Split
        ``kind="challenging"``, names ``challenging-1`` .. ``challenging-5``.
    map_coords : DataFrame
        One row per object (attribute-table order) with columns ``object``, ``x``, ``y``
        (PCA map coordinates, unitless), ``wedge``, ``partition`` (int 1..5),
        ``partition_label`` (e.g. ``"left-upper"``) and ``dropped`` (bool: removed from its
        test set as a duplicate vector). ``attrs`` holds ``halved_wedge``, ``wedge_counts``
        and ``explained_variance_ratio`` (shape (2,)), for drawing the lines y = x, y = -x and
        the halving line.

    Raises
    ------
    SplitError
        Invalid table / features, unknown ``halve``, or an empty partition.
    """
    A = check_attribute_table(object_attributes)
    check_min_counts(min_train_positives, min_train_negatives)
    objects = tuple(map(str, object_attributes.index))
    attributes = tuple(map(str, object_attributes.columns))
    if halve not in ("densest", *WEDGES):
        raise SplitError(f"halve must be 'densest' or one of {WEDGES}, got {halve!r}")
    feats = _validate_features(object_features, objects)
    if len(feats) < 2:
        raise SplitError("object_features needs at least 2 rows for a 2-D PCA map")

    coords, evr = _object_map(feats, standardize)
    coords = coords.loc[list(objects)]
    # + 0.0 turns -0.0 into 0.0, so a point on y = 0 left of the origin is at 180 degrees
    x, y = coords["x"].to_numpy() + 0.0, coords["y"].to_numpy() + 0.0
    angle = np.degrees(np.arctan2(y, x))  # (-180, 180]
    sector = np.digitize(angle, _SECTOR_EDGES)  # 0..7; angle 180 -> 7 (left-upper)
    wedge = np.asarray(_SECTOR_WEDGE)[sector]
    counts = {w: int((wedge == w).sum()) for w in WEDGES}
    halved = max(WEDGES, key=lambda w: counts[w]) if halve == "densest" else halve

    # Partitions: the halved wedge's two sectors stay apart, other wedges join theirs.
    # Walk sectors counter-clockwise starting at the halved wedge's first sector.
    start = next(
        s for s in range(8) if _SECTOR_WEDGE[s] == halved and _SECTOR_WEDGE[s - 1] != halved
    )
    order = [(start + i) % 8 for i in range(8)]
    labels: list[str] = []
    sector_part = np.empty(8, dtype=int)
    for s in order:
        w = _SECTOR_WEDGE[s]
        label = _SECTOR_NAME[s] if w == halved else w
        if label not in labels:
            labels.append(label)
        sector_part[s] = labels.index(label) + 1
    partition = sector_part[sector]
    sizes = {labels[p - 1]: int((partition == p).sum()) for p in range(1, 6)}
    empty = [lab for lab, n in sizes.items() if n == 0]
    if empty:
        raise SplitError(
            f"challenging splits: partition(s) {empty} hold no object (objects per partition: "
            f"{sizes}; halved wedge: {halved}); the 2-D map does not give 5 non-empty partitions"
        )

    splits = []
    dropped_mask = np.zeros(len(objects), dtype=bool)
    for p in range(1, 6):
        in_part = partition == p
        excluded = attribute_exclusions(A[~in_part], attributes, min_train_positives, min_train_negatives)
        kept = kept_mask(attributes, excluded)
        test_idx = np.flatnonzero(in_part)
        dropped = []
        for group in duplicate_attribute_groups(A[test_idx][:, kept]):
            keep = objects[test_idx[group[0]]]
            for g in group[1:]:
                dropped_mask[test_idx[g]] = True
                dropped.append(
                    (objects[test_idx[g]], f"same attribute vector as test object {keep!r}")
                )
        dropped_names = {d for d, _ in dropped}
        splits.append(
            Split(
                name=f"challenging-{p}",
                train_objects=tuple(o for o, t in zip(objects, in_part, strict=True) if not t),
                test_objects=tuple(objects[i] for i in test_idx if objects[i] not in dropped_names),
                attributes=attributes,
                excluded_attributes=excluded,
                dropped_objects=tuple(sorted(dropped, key=lambda d: objects.index(d[0]))),
                kind="challenging",
                seed=None,
                min_train_positives=int(min_train_positives),
                min_train_negatives=int(min_train_negatives),
            )
        )

    map_coords = pd.DataFrame(
        {
            "object": list(objects),
            "x": x,
            "y": y,
            "wedge": wedge,
            "partition": partition,
            "partition_label": [labels[p - 1] for p in partition],
            "dropped": dropped_mask,
        }
    )
    map_coords.attrs.update(
        halved_wedge=halved, wedge_counts=counts, explained_variance_ratio=evr.copy()
    )
    return splits, map_coords
