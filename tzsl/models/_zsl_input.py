"""Input checks and training classes shared by the zero-shot attribute models of tzsl.models.

:func:`training_classes` defines the protocol's training classes (distinct attribute rows) and
their order; :func:`attribute_rows` turns labelled trials and one row per class into the
attribute rows ``A`` that ``fit(X, A, groups)`` takes.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import validate_data

from tzsl.exceptions import ConfigError, TzslError

__all__ = [
    "DEFAULT_GRID_EXTENSIONS",
    "GridEdgeWarning",
    "MIN_CV_CLASSES",
    "ZSLInputError",
    "attribute_rows",
    "check_int",
    "check_no_duplicate_rows",
    "check_positive",
    "class_grouped_folds",
    "encode_training_classes",
    "extend_at_edge",
    "share_of_objects",
    "training_classes",
    "validate_class_table",
    "validate_features",
    "validate_features_and_rows",
]

_DUPLICATE_MODES = ("error", "merge")


class ZSLInputError(TzslError, ValueError):
    """Arrays given to a zero-shot model are unusable.

    Raised for non-finite or wrongly shaped features, a class-attribute table that does not match
    the labels, or duplicate attribute rows. A :class:`ValueError` too, as scikit-learn expects.
    """


def validate_features(est: BaseEstimator, X, *, reset: bool) -> np.ndarray:
    """Validate features ``X`` (n, d) as float64, finite; set or check ``n_features_in_``."""
    try:
        return validate_data(est, X, reset=reset, dtype=np.float64)
    except ValueError as exc:
        raise ZSLInputError(f"{type(est).__name__}: X (features): {exc}") from exc


def validate_features_and_rows(est: BaseEstimator, X, Y) -> tuple[np.ndarray, np.ndarray]:
    """Validate training features (n, d) and attribute rows (n, m) (1-D: one attribute)."""
    if Y is None:
        raise ZSLInputError(
            f"{type(est).__name__} requires y to be passed, but the target y is None"
        )
    try:
        X, Y = validate_data(est, X, Y, reset=True, dtype=np.float64, multi_output=True, y_numeric=True)
    except ValueError as exc:
        raise ZSLInputError(f"{type(est).__name__}: X, Y (attribute rows): {exc}") from exc
    return X, (Y.reshape(-1, 1) if Y.ndim == 1 else Y).astype(np.float64)


def training_classes(Y: np.ndarray, est_name: str, groups=None) -> tuple[np.ndarray, np.ndarray]:
    """Training classes of a zero-shot attribute model: the distinct rows of ``Y``.

    Parameters
    ----------
    Y : ndarray of shape (n_trials, n_attributes)
        Attribute row of each training trial's class.
    est_name : str
        Estimator name for the error message.
    groups : array-like of shape (n_trials,), optional
        Object or class of each trial. When the groups are the classes themselves (each group
        has one attribute row and no two groups share one, e.g. PHAC-2 objects or fabric
        classes), the classes are put in sorted group order, as scikit-learn orders
        ``classes_ = np.unique(y)``. The order fixes class-grouped CV folds and early-stopping
        hold-outs, not the model's definition.

    Returns
    -------
    class_attributes : ndarray of shape (n_classes, n_attributes)
        Distinct rows, in ``np.unique(Y, axis=0)`` (lexicographic) order unless the groups
        are the classes (then sorted group order).
    y : ndarray of shape (n_trials,), int
        Each trial's row in ``class_attributes``.

    Raises
    ------
    ZSLInputError
        Fewer than 2 distinct rows, or ``groups`` of the wrong length.
    """
    S, y = np.unique(Y, axis=0, return_inverse=True)
    y = y.ravel()
    if S.shape[0] < 2:
        raise ZSLInputError(
            f"{est_name}: only one class (one distinct attribute row) in the training data; "
            "at least 2 are needed"
        )
    if groups is not None:
        groups = np.asarray(groups)
        if groups.shape != (Y.shape[0],):
            raise ZSLInputError(f"{est_name}: groups must have shape ({Y.shape[0]},), got {groups.shape}")
        _, g = np.unique(groups, return_inverse=True)
        g = g.ravel()
        pairs = np.unique(np.column_stack([g, y]), axis=0)
        if pairs.shape[0] == S.shape[0] == g.max() + 1:  # one row per group, one group per row
            order = pairs[np.argsort(pairs[:, 0]), 1]  # row of each group, in sorted group order
            rank = np.empty_like(order)
            rank[order] = np.arange(order.size)
            return S[order], rank[y]
    return S, y


#: Fewest training classes (distinct attribute rows) class-grouped CV can run on: 2 held out, 2 trained on.
MIN_CV_CLASSES = 4


def class_grouped_folds(
    groups, n_splits: int, who: str, *, strict: bool = False
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Class-grouped CV folds that can always be fitted: each validates on >= 2 and trains on >= 2 groups.

    The one fold builder of zero-shot tuning (:class:`ESZSLCV`, :class:`SAECV`,
    :func:`tzsl.evaluation.select_embedding_alpha`). A group is one training class, i.e. one
    distinct attribute row: classes that share a row are one group, so they are always held out
    together and, like any group, never fill a fold alone. Unlike ``GroupKFold`` (which balances
    *samples* and so leaves a large merged group alone in its fold), groups are dealt so that the
    folds' group counts differ by at most one; sample counts are balanced second (the group with
    most samples goes first, to the fold with fewest groups, then fewest samples). Deterministic.

    Parameters
    ----------
    groups : array-like of shape (n_samples,)
        Group (training class) of each sample.
    n_splits : int >= 2
        Requested folds; capped at ``n_groups // 2`` so that each fold validates on >= 2 groups.
    who : str
        Caller's name, for the error message.
    strict : bool, default=False
        If True, ``n_splits > n_groups // 2`` is an error (the user asked for that many folds)
        instead of being capped.

    Returns
    -------
    list of (train_indices, validation_indices)
        ``min(n_splits, n_groups // 2)`` folds; indices into the samples, sorted.

    Raises
    ------
    ZSLInputError
        Fewer than 4 groups (no fold can hold out 2 and train on 2), or ``strict`` and too many
        folds requested. The message says why.
    """
    groups = np.asarray(groups).ravel()
    labels, g, counts = np.unique(groups, return_inverse=True, return_counts=True)
    g = g.ravel()
    n_groups = labels.size
    if n_groups < MIN_CV_CLASSES:
        raise ZSLInputError(
            f"{who}: class-grouped cross-validation needs at least 4 training classes (distinct "
            f"attribute rows; classes sharing a row count once): 2 held out, 2 trained on; got {n_groups}"
        )
    if strict and n_splits > n_groups // 2:
        raise ZSLInputError(
            f"{who}: {n_splits} folds of {n_groups} training classes would validate some fold on "
            f"fewer than 2 classes; each fold needs at least 2 held out: use at most {n_groups // 2} folds"
        )
    k = min(int(n_splits), n_groups // 2)
    fold_groups, fold_samples = np.zeros(k, dtype=int), np.zeros(k, dtype=int)
    fold_of_group = np.empty(n_groups, dtype=int)
    for u in np.argsort(-counts, kind="stable"):  # largest group first
        f = int(np.lexsort((np.arange(k), fold_samples, fold_groups))[0])
        fold_of_group[u] = f
        fold_groups[f] += 1
        fold_samples[f] += counts[u]
    fold_of_sample = fold_of_group[g]
    return [
        (np.flatnonzero(fold_of_sample != f), np.flatnonzero(fold_of_sample == f)) for f in range(k)
    ]


class GridEdgeWarning(UserWarning):
    """A tuned hyper-parameter was chosen at the low or high end of its grid (the optimum may lie outside)."""


#: Default bound on the log-scale steps the CV models (:class:`ESZSLCV`, :class:`SAECV`) add beyond a grid edge
#: that was selected.
DEFAULT_GRID_EXTENSIONS = 3


def extend_at_edge(grid: np.ndarray, index: int) -> np.ndarray | None:
    """``grid`` (sorted, > 0) extended one log-scale step beyond the edge at ``index``; None if interior.

    The step is the ratio of the two values at that edge (a 1-point grid is never extended).

    Parameters
    ----------
    grid : ndarray of shape (k,)
        Increasing positive values.
    index : int
        Position of the selected value.

    Returns
    -------
    ndarray of shape (k + 1,) or None
    """
    if grid.size < 2 or 0 < index < grid.size - 1:
        return None
    if index == 0:
        return np.concatenate([[grid[0] * grid[0] / grid[1]], grid])
    return np.concatenate([grid, [grid[-1] * grid[-1] / grid[-2]]])


def attribute_rows(y, class_attributes) -> np.ndarray:
    """Each trial's attribute row from class labels and one row per class.

    Parameters
    ----------
    y : array-like of shape (n_trials,)
        Class labels.
    class_attributes : array-like of shape (n_classes, n_attributes)
        One row per class of ``np.unique(y)``, in that (sorted) order.

    Returns
    -------
    ndarray of shape (n_trials, n_attributes), float64
        ``Y`` for ``fit(X, Y)`` of an attribute model.
    """
    classes, idx = np.unique(np.asarray(y), return_inverse=True)
    S = validate_class_table(class_attributes)
    if S.shape[0] != classes.size:
        raise ZSLInputError(
            f"class_attributes has {S.shape[0]} rows but y has {classes.size} classes "
            f"{classes.tolist()}; give one row per class, in sorted label order"
        )
    return S[idx.ravel()]


def validate_class_table(S, *, n_attributes: int | None = None, what: str = "class_attributes"):
    """Validate a class-attribute table (k, m): 2-D, numeric, finite; attributes may be real."""
    try:
        S = np.asarray(S, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ZSLInputError(f"{what} must be a numeric (classes x attributes) array: {exc}") from exc
    if S.ndim != 2 or S.shape[0] == 0 or S.shape[1] == 0:
        raise ZSLInputError(
            f"{what} must be a non-empty 2-D array (classes x attributes), got shape {S.shape}"
        )
    bad = np.argwhere(~np.isfinite(S))
    if bad.size:
        where = ", ".join(f"row {r} attribute {c} = {S[r, c]}" for r, c in bad[:5])
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        raise ZSLInputError(f"{what} holds non-finite values (NaN or inf): {where}{more}")
    if n_attributes is not None and S.shape[1] != n_attributes:
        raise ZSLInputError(
            f"{what} has {S.shape[1]} attributes (columns) but the model was fitted with "
            f"{n_attributes}"
        )
    return S


def duplicate_row_groups(S: np.ndarray) -> list[np.ndarray]:
    """Groups (index arrays, each of length >= 2) of identical rows of ``S``."""
    _, inverse, counts = np.unique(S, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    return [np.flatnonzero(inverse == u) for u in np.flatnonzero(counts > 1)]


def check_no_duplicate_rows(S: np.ndarray, what: str = "class_attributes") -> None:
    """Error when two candidate classes share an attribute vector (the argmax is undecidable)."""
    groups = duplicate_row_groups(S)
    if groups:
        listed = "; ".join("rows " + ", ".join(map(str, g)) for g in groups)
        raise ZSLInputError(
            f"{what} has identical attribute rows ({listed}): classes with the same attribute "
            "vector cannot be told apart by a zero-shot model; merge them before predicting"
        )


def encode_training_classes(
    y: np.ndarray, S, duplicate_attributes: str, est_name: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Map labels to rows of the training attribute table.

    Returns
    -------
    classes : ndarray (k,)
        Sorted unique labels; row ``j`` of ``S`` belongs to ``classes[j]``.
    S : ndarray (k, m)
        The validated attribute table.
    S_unique : ndarray (u, m)
        Distinct attribute rows (``u == k`` unless ``duplicate_attributes="merge"``).
    y_unique : ndarray (n,)
        Each sample's row in ``S_unique``.
    """
    if duplicate_attributes not in _DUPLICATE_MODES:
        raise ConfigError(
            f"{est_name}: duplicate_attributes must be one of {_DUPLICATE_MODES}, "
            f"got {duplicate_attributes!r}"
        )
    classes, y_idx = np.unique(y, return_inverse=True)
    S = validate_class_table(S)
    if S.shape[0] != classes.size:
        raise ZSLInputError(
            f"{est_name}: class_attributes has {S.shape[0]} rows but y has {classes.size} classes "
            f"{classes.tolist()}; give one row per class, in sorted label order"
        )
    groups = duplicate_row_groups(S)
    if groups and duplicate_attributes == "error":
        listed = "; ".join("{" + ", ".join(str(classes[i]) for i in g) + "}" for g in groups)
        raise ZSLInputError(
            f"{est_name}: training classes with identical attribute rows: {listed}. Zero-shot "
            'training cannot separate them; pass duplicate_attributes="merge" to treat each such '
            "set as one class"
        )
    S_unique, row_of_class = np.unique(S, axis=0, return_inverse=True)
    y_unique = row_of_class.ravel()[y_idx]
    if S_unique.shape[0] < 2:
        raise ZSLInputError(
            f"{est_name}: only one class (one distinct attribute row) in the training data; "
            "at least 2 are needed"
        )
    if not groups:  # keep the caller's row order when nothing was merged
        S_unique, y_unique = S, y_idx
    return classes, S, S_unique, y_unique


def check_positive(value, name: str, est_name: str, *, allow_zero: bool = False) -> float:
    """``value`` as a float; a ConfigError unless it is a finite real (not bool) > 0 (>= 0)."""
    if (
        not isinstance(value, numbers.Real)
        or isinstance(value, bool)
        or not np.isfinite(value)  # type: ignore[call-overload]  # numpy's stub omits numbers.Real
        or value < 0
        or (value == 0 and not allow_zero)
    ):
        raise ConfigError(
            f"{est_name}: {name} must be a finite number {'>=' if allow_zero else '>'} 0, got {value!r}"
        )
    return float(value)


def check_int(value, name: str, low: int, est_name: str) -> int:
    """``value`` as an int; a ConfigError unless it is an integer (not bool) >= ``low``."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < low:
        raise ConfigError(f"{est_name}: {name} must be an integer >= {low}, got {value!r}")
    return int(value)


def share_of_objects(groups: np.ndarray, cap: int | None, rng) -> np.ndarray:
    """Sorted indices of about ``cap`` trials taken from every object in proportion (all if ``n <= cap``).

    ``groups`` (n_trials,): object of each trial. Each object keeps ``max(1, floor(count * cap / n))``
    of its trials, chosen at random (one ``rng.permutation(n)``, drawn only when ``n > cap``).
    """
    n = groups.size
    if cap is None or n <= cap:
        return np.arange(n)
    _, codes, counts = np.unique(groups, return_inverse=True, return_counts=True)
    perm = rng.permutation(n)
    order = perm[np.argsort(codes[perm], kind="stable")]  # trials by object, random within
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n) - np.concatenate([[0], np.cumsum(counts)[:-1]])[codes[order]]
    quota = np.maximum(1, np.floor(counts * cap / n)).astype(np.int64)
    return np.flatnonzero(rank < quota[codes])
