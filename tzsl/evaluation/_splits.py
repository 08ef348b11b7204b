"""Object splits for zero-shot evaluation: random (F5) and challenging (F6).

A zero-shot split divides the *objects* (not the trials) into a training set, whose
attribute classifiers are fitted, and a test set of objects never touched before, each
recognised from its attribute row alone. Two rules from the DAP paper (sections 4.2 and
4.6) apply to every split made here or read from a file:

* the test objects' attribute vectors are mutually different (ZSL identifies a test object
  by its vector, so two equal vectors cannot be told apart);
* every attribute classifier is trained on at least ``min_train_positives`` (3) positive
  training objects. An attribute that misses this for a split is *left out for that split*
  and reported in :attr:`Split.excluded_attributes` with the reason. We also leave out an
  attribute with fewer than ``min_train_negatives`` (1) negative training objects, since no
  binary classifier can be fitted to one class.

Distinctness of test vectors is checked on the attributes kept for the split, i.e. after
the exclusions: those are the only attributes a ZSL model of that split sees.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral
from typing import Literal

import numpy as np
import pandas as pd
from sklearn.decomposition import PCA
from sklearn.preprocessing import StandardScaler
from sklearn.utils import check_random_state

from tzsl.exceptions import SplitError

__all__ = [
    "Split",
    "attribute_exclusions",
    "challenging_splits",
    "check_attribute_table",
    "duplicate_attribute_groups",
    "random_object_splits",
]

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


@dataclass(frozen=True)
class Split:
    """One zero-shot train/test division of the objects.

    Attributes
    ----------
    name : str
        Split name, e.g. ``"random-1"`` or ``"challenging-3"``.
    train_objects : tuple of str
        Objects whose trials train the attribute classifiers, in attribute-table order.
    test_objects : tuple of str
        Unseen objects to recognise, in attribute-table order; their attribute vectors over
        :attr:`kept_attributes` are mutually different.
    attributes : tuple of str
        Every attribute of the table the split was checked against.
    excluded_attributes : tuple of (str, str)
        ``(attribute, reason)`` for each attribute left out of this split (too few positive
        or negative training objects).
    dropped_objects : tuple of (str, str)
        ``(object, reason)`` for objects in neither set although the split kind would have
        used them (challenging splits drop test objects repeating another test object's
        attribute vector).
    kind : str
        ``"random"``, ``"challenging"`` or ``"file"``.
    seed : int or None
        The integer seed the split was drawn with (random splits), else None.
    min_train_positives, min_train_negatives : int or None
        The exclusion rule :attr:`excluded_attributes` was computed with (least number of
        positive / negative training objects an attribute needs), None when unknown. Split
        files record it, so a split read back keeps its rule (challenging: 3, random: 2 in
        the PHAC-2 study) whatever rule the reader would apply to a file without one.
    """

    name: str
    train_objects: tuple[str, ...]
    test_objects: tuple[str, ...]
    attributes: tuple[str, ...] = ()
    excluded_attributes: tuple[tuple[str, str], ...] = ()
    dropped_objects: tuple[tuple[str, str], ...] = ()
    kind: str = "random"
    seed: int | None = None
    min_train_positives: int | None = None
    min_train_negatives: int | None = None

    @property
    def kept_attributes(self) -> tuple[str, ...]:
        """Attributes used by this split, in table order (all but the excluded ones)."""
        out = {a for a, _ in self.excluded_attributes}
        return tuple(a for a in self.attributes if a not in out)

    @property
    def n_test(self) -> int:
        return len(self.test_objects)

    @property
    def chance(self) -> float:
        """Chance accuracy of the split, ``1 / n_test`` (NaN for an empty test set)."""
        return 1.0 / self.n_test if self.n_test else float("nan")


# --------------------------------------------------------------------------- helpers


def check_attribute_table(object_attributes: pd.DataFrame) -> np.ndarray:
    """Validate a 0/1 object-attribute table and return it as booleans.

    Parameters
    ----------
    object_attributes : DataFrame of shape (n_objects, n_attributes)
        Index: unique object names; columns: attribute names; entries 0/1 (or bool).

    Returns
    -------
    A : ndarray of bool, shape (n_objects, n_attributes)

    Raises
    ------
    SplitError
        Not a DataFrame, empty, duplicate object or attribute names, missing (NaN) or
        non-binary entries; the message names the object(s) and attribute(s).
    """
    if not isinstance(object_attributes, pd.DataFrame):
        raise SplitError(
            "attribute table must be a pandas DataFrame (objects x attributes), "
            f"got {type(object_attributes).__name__}"
        )
    if object_attributes.shape[0] == 0 or object_attributes.shape[1] == 0:
        raise SplitError(f"attribute table is empty (shape {object_attributes.shape})")
    for what, labels in (("object", object_attributes.index), ("attribute", object_attributes.columns)):
        dup = labels[labels.duplicated()].unique()
        if len(dup):
            raise SplitError(f"attribute table: duplicate {what} name(s) {list(map(str, dup))}")
    values = object_attributes.to_numpy(dtype=object)
    numeric = pd.DataFrame(values).apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isin(numeric, (0.0, 1.0))  # NaN and non-numeric are not in {0, 1}
    if bad.any():
        rows, cols = np.nonzero(bad)
        cells = [
            f"object {object_attributes.index[r]!r}, attribute {object_attributes.columns[c]!r}: "
            f"{values[r, c]!r}"
            for r, c in zip(rows[:5], cols[:5])
        ]
        more = f" (and {bad.sum() - 5} more)" if bad.sum() > 5 else ""
        raise SplitError(
            "attribute table must hold only 0/1 entries (missing or non-binary values found): "
            + "; ".join(cells) + more
        )
    return numeric.astype(bool)


def attribute_exclusions(
    A_train: np.ndarray,
    attributes: tuple[str, ...] | list[str],
    min_train_positives: int = 3,
    min_train_negatives: int = 1,
) -> tuple[tuple[str, str], ...]:
    """Attributes that cannot be trained on the given training objects, with the reason.

    Parameters
    ----------
    A_train : ndarray of bool, shape (n_train_objects, n_attributes)
        Attribute rows of the training objects (one row per object, not per trial).
    attributes : sequence of str, length n_attributes
    min_train_positives, min_train_negatives : int
        Least number of positive / negative training objects an attribute needs.

    Returns
    -------
    tuple of (attribute, reason)
    """
    A_train = np.asarray(A_train, dtype=bool).reshape(-1, len(attributes))
    pos = A_train.sum(axis=0)
    neg = A_train.shape[0] - pos
    out = []
    for j in np.flatnonzero((pos < min_train_positives) | (neg < min_train_negatives)):
        reasons = []
        if pos[j] < min_train_positives:
            reasons.append(f"{pos[j]} positive training object(s) < {min_train_positives}")
        if neg[j] < min_train_negatives:
            reasons.append(f"{neg[j]} negative training object(s) < {min_train_negatives}")
        out.append((str(attributes[j]), "; ".join(reasons)))
    return tuple(out)


def duplicate_attribute_groups(A: np.ndarray) -> list[np.ndarray]:
    """Groups of rows sharing an attribute vector.

    Parameters
    ----------
    A : ndarray of shape (n, n_attributes)

    Returns
    -------
    list of int ndarray
        Row indices (ascending) of each vector that occurs more than once, ordered by first
        occurrence. Empty when all rows differ.
    """
    A = np.asarray(A)
    if A.shape[0] < 2:
        return []
    _, first, inverse, counts = np.unique(
        A.reshape(A.shape[0], -1), axis=0, return_index=True, return_inverse=True, return_counts=True
    )
    inverse = inverse.reshape(-1)
    groups = [np.flatnonzero(inverse == g) for g in np.flatnonzero(counts > 1)]
    return sorted(groups, key=lambda g: g[0])


def _kept_mask(attributes: tuple[str, ...], excluded: tuple[tuple[str, str], ...]) -> np.ndarray:
    out = {a for a, _ in excluded}
    return np.array([a not in out for a in attributes], dtype=bool)


def _check_min_counts(min_train_positives: int, min_train_negatives: int) -> None:
    for name, v in (("min_train_positives", min_train_positives), ("min_train_negatives", min_train_negatives)):
        if not isinstance(v, Integral) or v < 0:
            raise SplitError(f"{name} must be a non-negative integer, got {v!r}")


# --------------------------------------------------------------------------- random (F5)


def random_object_splits(
    object_attributes: pd.DataFrame,
    n_test: int = 10,
    n_splits: int = 5,
    random_state: int | np.random.RandomState | None = 0,
    min_train_positives: int = 3,
    min_train_negatives: int = 1,
    max_draws: int = 1000,
) -> list[Split]:
    """Random object splits with mutually different test attribute vectors (DAP paper 4.2).

    Each split draws ``n_test`` test objects uniformly without replacement; the rest train.
    As in the paper, a draw whose test objects repeat an attribute vector is rejected and
    drawn again. Attributes with too few positive (or no negative) training objects are left
    out for that split and reported; vector distinctness is checked on the kept attributes.

    Parameters
    ----------
    object_attributes : DataFrame of shape (n_objects, n_attributes)
        0/1 table indexed by object name (PHAC-2: 60 x 19).
    n_test : int, default 10
        Test objects per split (PHAC-2: 10 test / 50 train).
    n_splits : int, default 5
    random_state : int, RandomState or None, default 0
        Seed of the draws; the same seed gives the same splits. Draws are sequential from
        one generator, so split ``k`` of ``n_splits=5`` equals split ``k`` of ``n_splits=3``.
    min_train_positives, min_train_negatives : int, default 3 and 1
        Exclusion rule (see module docstring).
    max_draws : int, default 1000
        Draws tried per split before giving up.

    Returns
    -------
    list of Split
        ``kind="random"``, names ``random-1`` .. ``random-<n_splits>``, ``seed`` = the
        integer ``random_state`` (None otherwise).

    Raises
    ------
    SplitError
        Invalid table or parameters; fewer distinct attribute vectors than ``n_test``; no
        valid draw within ``max_draws`` (the message counts why draws were rejected).
    """
    A = check_attribute_table(object_attributes)
    _check_min_counts(min_train_positives, min_train_negatives)
    objects = tuple(map(str, object_attributes.index))
    attributes = tuple(map(str, object_attributes.columns))
    n_objects = len(objects)
    for name, v in (("n_test", n_test), ("n_splits", n_splits), ("max_draws", max_draws)):
        if not isinstance(v, Integral) or isinstance(v, bool) or v < 1:
            raise SplitError(f"{name} must be a positive integer, got {v!r}")
    if n_test >= n_objects:
        raise SplitError(
            f"n_test={n_test} leaves no training object: the table has {n_objects} objects"
        )
    n_distinct = len(np.unique(A, axis=0))
    if n_distinct < n_test:
        raise SplitError(
            f"cannot draw {n_test} test objects with mutually different attribute vectors: "
            f"the table has only {n_distinct} distinct vectors among {n_objects} objects"
        )
    rng = check_random_state(random_state)
    seed = int(random_state) if isinstance(random_state, Integral) else None

    splits = []
    for k in range(n_splits):
        rejected = {"duplicate test vectors": 0, "every attribute excluded": 0}
        for _ in range(max_draws):
            test = np.zeros(n_objects, dtype=bool)
            test[rng.choice(n_objects, size=n_test, replace=False)] = True
            excluded = attribute_exclusions(A[~test], attributes, min_train_positives, min_train_negatives)
            kept = _kept_mask(attributes, excluded)
            if not kept.any():
                rejected["every attribute excluded"] += 1
                continue
            if len(np.unique(A[test][:, kept], axis=0)) < n_test:
                rejected["duplicate test vectors"] += 1
                continue
            break
        else:
            why = ", ".join(f"{n} rejected for {r}" for r, n in rejected.items() if n)
            raise SplitError(
                f"random split {k + 1}: no valid draw of {n_test} test objects out of {n_objects} "
                f"in {max_draws} draws ({why}); lower n_test or min_train_positives, or raise max_draws"
            )
        splits.append(
            Split(
                name=f"random-{k + 1}",
                train_objects=tuple(o for o, t in zip(objects, test) if not t),
                test_objects=tuple(o for o, t in zip(objects, test) if t),
                attributes=attributes,
                excluded_attributes=excluded,
                kind="random",
                seed=seed,
                min_train_positives=int(min_train_positives),
                min_train_negatives=int(min_train_negatives),
            )
        )
    return splits


# --------------------------------------------------------------------------- challenging (F6)


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
    _check_min_counts(min_train_positives, min_train_negatives)
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
        kept = _kept_mask(attributes, excluded)
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
                train_objects=tuple(o for o, t in zip(objects, in_part) if not t),
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
