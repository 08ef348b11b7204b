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

Selection and confirmation splits (:data:`PURPOSES`): a choice (a method, a grid, a default) is
made on *selection* splits and the numbers shown for it come from *confirmation* splits. Every
test-object set belongs to exactly one of the two (:func:`split_purpose`, a hash of the sorted
test objects), and a random draw for one purpose rejects the other's sets, so no seed of a
confirmation run can draw a split that a selection run with any seed draws. The purpose also
enters the seed of the draws (:func:`purpose_seed`), so the two streams differ from the first draw.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from numbers import Integral

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

from tzsl._scoring import duplicate_attribute_groups
from tzsl.exceptions import SplitError

__all__ = [
    "PURPOSES",
    "Split",
    "attribute_exclusions",
    "check_attribute_table",
    "duplicate_attribute_groups",
    "purpose_seed",
    "random_object_splits",
    "split_purpose",
]

#: What a run's splits are for: ``select`` (make a choice) or ``confirm`` (report the chosen).
PURPOSES: tuple[str, ...] = ("select", "confirm")

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
            for r, c in zip(rows[:5], cols[:5], strict=True)
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


def kept_mask(attributes: tuple[str, ...], excluded: tuple[tuple[str, str], ...]) -> np.ndarray:
    out = {a for a, _ in excluded}
    return np.array([a not in out for a in attributes], dtype=bool)


def check_min_counts(min_train_positives: int, min_train_negatives: int) -> None:
    for name, v in (("min_train_positives", min_train_positives), ("min_train_negatives", min_train_negatives)):
        if not isinstance(v, Integral) or v < 0:
            raise SplitError(f"{name} must be a non-negative integer, got {v!r}")


# --------------------------------------------------------------------------- selection / confirmation


def split_purpose(test_objects) -> str:
    """The purpose (``"select"`` or ``"confirm"``) a test-object set belongs to.

    A fixed partition of every possible test set: the parity of the first byte of the SHA-256 of
    the sorted object names, joined by a unit separator. It depends on the set only (not its
    order, the seed or the dataset's other objects), so the partition is the same for every run.

    Parameters
    ----------
    test_objects : iterable of str
        The split's test objects.

    Returns
    -------
    str
        An element of :data:`PURPOSES`.
    """
    key = "\x1f".join(sorted(map(str, test_objects))).encode("utf-8")
    return PURPOSES[hashlib.sha256(key).digest()[0] & 1]


def purpose_seed(seed: int, purpose: str | None) -> int:
    """The seed of a run's draws and fits for ``purpose``: ``seed`` itself when ``purpose`` is None.

    Parameters
    ----------
    seed : int
        The run's seed, ``0 <= seed < 2**32``.
    purpose : {"select", "confirm"} or None

    Returns
    -------
    int
        In ``[0, 2**32)``; ``SeedSequence([seed, 1 + PURPOSES.index(purpose)])``'s first word.
    """
    if purpose is None:
        return int(seed)
    check_purpose(purpose)
    return int(np.random.SeedSequence([int(seed), 1 + PURPOSES.index(purpose)]).generate_state(1)[0])


def check_purpose(purpose) -> None:
    """Raise :class:`SplitError` unless ``purpose`` is None or one of :data:`PURPOSES`."""
    if purpose is not None and purpose not in PURPOSES:
        raise SplitError(f"purpose must be one of {list(PURPOSES)} (or None), got {purpose!r}")


# --------------------------------------------------------------------------- random (F5)


def random_object_splits(
    object_attributes: pd.DataFrame,
    n_test: int = 10,
    n_splits: int = 5,
    random_state: int | np.random.RandomState | None = 0,
    min_train_positives: int = 3,
    min_train_negatives: int = 1,
    max_draws: int = 1000,
    purpose: str | None = None,
    distinct: bool = False,
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
    purpose : {"select", "confirm"} or None, default None
        Draw only test sets of this purpose (:func:`split_purpose`), from the generator seeded
        with :func:`purpose_seed`; needs an integer ``random_state``. None: every test set, from
        ``random_state`` itself.
    distinct : bool, default False
        Reject a draw whose test set an earlier split of this call has (the standard splits of
        :mod:`tzsl.studies.benchmark`). The splits then end early when ``max_draws`` draws in a
        row give no new valid test set (a small dataset has fewer distinct test sets than
        ``n_splits``): at most ``n_splits`` are returned, at least one.

    Returns
    -------
    list of Split
        ``kind="random"``, names ``random-1`` .. ``random-<n_splits>``, ``seed`` = the
        integer ``random_state`` (None otherwise); with ``purpose``, every split's
        :func:`split_purpose` is ``purpose``; with ``distinct``, no two share a test set.

    Raises
    ------
    SplitError
        Invalid table or parameters; fewer distinct attribute vectors than ``n_test``; no
        valid draw within ``max_draws`` (the message counts why draws were rejected).
    """
    A = check_attribute_table(object_attributes)
    check_min_counts(min_train_positives, min_train_negatives)
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
    check_purpose(purpose)
    seed = int(random_state) if isinstance(random_state, Integral) else None
    if purpose is not None and seed is None:
        raise SplitError(f"purpose={purpose!r} needs an integer random_state, got {random_state!r}")
    rng = check_random_state(random_state if purpose is None else purpose_seed(seed, purpose))
    names = np.asarray(objects, dtype=object)

    splits: list[Split] = []
    seen: set[bytes] = set()
    for k in range(n_splits):
        rejected = {"duplicate test vectors": 0, "every attribute excluded": 0,
                    f"a test set of the {_other(purpose)} splits": 0, "a test set of an earlier split": 0}
        for _ in range(max_draws):
            test = np.zeros(n_objects, dtype=bool)
            test[rng.choice(n_objects, size=n_test, replace=False)] = True
            if purpose is not None and split_purpose(names[test]) != purpose:
                rejected[f"a test set of the {_other(purpose)} splits"] += 1
                continue
            if distinct and test.tobytes() in seen:
                rejected["a test set of an earlier split"] += 1
                continue
            excluded = attribute_exclusions(A[~test], attributes, min_train_positives, min_train_negatives)
            kept = kept_mask(attributes, excluded)
            if not kept.any():
                rejected["every attribute excluded"] += 1
                continue
            if len(np.unique(A[test][:, kept], axis=0)) < n_test:
                rejected["duplicate test vectors"] += 1
                continue
            break
        else:
            if distinct and splits:  # every distinct valid test set (or all max_draws found) is drawn
                break
            why = ", ".join(f"{n} rejected for {r}" for r, n in rejected.items() if n)
            raise SplitError(
                f"random split {k + 1}: no valid draw of {n_test} test objects out of {n_objects} "
                f"in {max_draws} draws ({why}); lower n_test or min_train_positives, or raise max_draws"
            )
        seen.add(test.tobytes())
        splits.append(
            Split(
                name=f"random-{k + 1}",
                train_objects=tuple(o for o, t in zip(objects, test, strict=True) if not t),
                test_objects=tuple(o for o, t in zip(objects, test, strict=True) if t),
                attributes=attributes,
                excluded_attributes=excluded,
                kind="random",
                seed=seed,
                min_train_positives=int(min_train_positives),
                min_train_negatives=int(min_train_negatives),
            )
        )
    return splits


def _other(purpose: str | None) -> str:
    """The purpose other than ``purpose`` (a label for messages)."""
    return "other" if purpose is None else PURPOSES[1 - PURPOSES.index(purpose)]
