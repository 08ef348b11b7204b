"""Is a class split zero-shot? Find test classes seen in training, and propose a valid variant.

A zero-shot test class must have an attribute row that **no training class has**
(SPEC, evaluation rules): otherwise the attribute classifiers have seen that very row with
its trials, and recognising the class is ordinary supervised recognition. The fabric data's
8-attribute matrix breaks this in the paper's split: groups 3, 4 and 5 share one row, and
group 5 is a test class while 3 and 4 train (config 2, testing group 4, has the same flaw).

:func:`seen_test_classes` lists such test classes. :func:`zero_shot_variant` proposes a
split without them, in one of two documented ways:

``"drop"`` (the default and our choice for the fabric headline)
    Every test class whose row occurs in training leaves the test set and is not used for
    training either. The training classes stay exactly the paper's, and every attribute
    keeps its training classes; the cost is fewer test classes (fabric config 1: groups 0
    and 7, chance 1/2).
``"merge"``
    Every test class whose row occurs in training is merged with the training classes
    sharing its row into one new *test* class (label ``"3+4+5"``); those training classes
    leave training. The number of test classes is kept (fabric config 1: 0, 3+4+5, 7;
    chance 1/3) but training shrinks, and an attribute may lose all its positive (or
    negative) training classes: such attributes are reported in
    :attr:`ZeroShotVariant.excluded_attributes` (fabric a8: ``attr_3``, held only by
    groups 3, 4, 5). If the test rows then coincide over the kept attributes, the variant
    is refused.

Merging the shared classes into one *training* class instead gives the same test set as
``"drop"`` with more training data under a label the paper does not have; we keep the
paper's training classes and drop.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd

from tzsl.exceptions import SplitError

__all__ = ["ZeroShotVariant", "seen_test_classes", "zero_shot_variant"]


@dataclass(frozen=True)
class ZeroShotVariant:
    """A class split whose test classes all have attribute rows unseen in training.

    Attributes
    ----------
    strategy : {"none", "drop", "merge"}
        How it was made (``"none"``: the split was already zero-shot).
    train_classes, test_classes : tuple
        Classes of the variant; merged classes are labelled ``"a+b+c"``.
    class_map : dict
        Original class -> class of the variant, for every class used (dropped ones absent).
    dropped_classes : tuple
        Original classes used by neither set.
    excluded_attributes : tuple of str
        Attributes without a positive or without a negative training class in the variant.
    note : str
        One sentence saying what was changed and why (for a report's deviations section).
    """

    strategy: str
    train_classes: tuple
    test_classes: tuple
    class_map: dict = field(default_factory=dict)
    dropped_classes: tuple = ()
    excluded_attributes: tuple[str, ...] = ()
    note: str = ""


def _rows(class_attributes: pd.DataFrame, classes: Sequence[Hashable], what: str) -> np.ndarray:
    missing = [c for c in classes if c not in class_attributes.index]
    if missing:
        raise SplitError(f"{what} class(es) {missing} not in the class-attribute table")
    return class_attributes.loc[list(classes)].to_numpy()


def seen_test_classes(
    class_attributes: pd.DataFrame, train_classes: Sequence[Hashable], test_classes: Sequence[Hashable]
) -> dict[Hashable, tuple]:
    """Test classes whose attribute row occurs among the training classes.

    Parameters
    ----------
    class_attributes : DataFrame of shape (n_classes, n_attributes)
        Indexed by class; compare over the columns given (pass the kept attributes only).
    train_classes, test_classes : sequence
        Disjoint class labels of the split.

    Returns
    -------
    dict
        ``{test class: (training classes with the same row, ...)}``, in test-class order;
        empty when the split is zero-shot.
    """
    both = set(train_classes) & set(test_classes)
    if both:
        raise SplitError(f"class(es) {sorted(both, key=str)} are both training and test classes")
    train = _rows(class_attributes, train_classes, "training")
    test = _rows(class_attributes, test_classes, "test")
    same = (test[:, None, :] == train[None, :, :]).all(axis=2)  # (n_test, n_train)
    return {t: tuple(train_classes[int(j)] for j in np.flatnonzero(same[i]))
            for i, t in enumerate(test_classes) if same[i].any()}


def _untrainable(class_attributes: pd.DataFrame, train_classes: Sequence[Hashable]) -> tuple[str, ...]:
    train = _rows(class_attributes, train_classes, "training").astype(bool)
    pos = train.sum(axis=0)
    return tuple(str(a) for a, p in zip(class_attributes.columns, pos, strict=True) if p == 0 or p == len(train))


def zero_shot_variant(
    class_attributes: pd.DataFrame,
    train_classes: Sequence[Hashable],
    test_classes: Sequence[Hashable],
    *,
    strategy: Literal["drop", "merge"] = "drop",
) -> ZeroShotVariant:
    """A variant of the split with no test class seen in training (see the module docstring).

    Parameters
    ----------
    class_attributes : DataFrame of shape (n_classes, n_attributes)
        0/1 rows indexed by class.
    train_classes, test_classes : sequence
    strategy : {"drop", "merge"}, default "drop"

    Returns
    -------
    ZeroShotVariant
        ``strategy="none"`` and the split unchanged when it is already zero-shot.

    Raises
    ------
    SplitError
        Unknown strategy; no test class left; merged test rows not distinct over the kept
        attributes.
    """
    if strategy not in ("drop", "merge"):
        raise SplitError(f"strategy must be 'drop' or 'merge', got {strategy!r}")
    train_classes, test_classes = list(train_classes), list(test_classes)
    seen = seen_test_classes(class_attributes, train_classes, test_classes)
    if not seen:
        return ZeroShotVariant("none", tuple(train_classes), tuple(test_classes),
                               {c: c for c in train_classes + test_classes},
                               excluded_attributes=_untrainable(class_attributes, train_classes),
                               note="the split is zero-shot as given")
    described = "; ".join(f"test class {t} has the row of training class(es) {', '.join(map(str, s))}"
                          for t, s in seen.items())
    if strategy == "drop":
        test = [c for c in test_classes if c not in seen]
        if not test:
            raise SplitError(f"dropping every test class seen in training leaves no test class ({described})")
        return ZeroShotVariant(
            "drop", tuple(train_classes), tuple(test), {c: c for c in train_classes + test},
            dropped_classes=tuple(seen), excluded_attributes=_untrainable(class_attributes, train_classes),
            note=f"{described}: dropped from the test set (and not trained on), "
                 f"leaving test classes {', '.join(map(str, test))}",
        )
    class_map: dict = {}
    leaving: set = set()
    for t, shared in seen.items():
        label = "+".join(map(str, sorted([t, *shared], key=lambda c: (str(type(c)), c))))
        for c in (t, *shared):
            class_map[c] = label
        leaving.update(shared)
    train = [c for c in train_classes if c not in leaving]
    if not train:
        raise SplitError(f"merging leaves no training class ({described})")
    test = list(dict.fromkeys(class_map.get(c, c) for c in test_classes))
    class_map.update({c: c for c in train + test_classes if c not in class_map})
    excluded = _untrainable(class_attributes, train)
    kept = [a for a in class_attributes.columns if str(a) not in excluded]
    rows = pd.DataFrame([class_attributes.loc[[c for c in class_map if class_map[c] == lab][0], kept]
                         for lab in test], index=test)
    if rows.duplicated().any():
        raise SplitError(f"merging makes test classes {rows.index[rows.duplicated(keep=False)].tolist()} "
                         f"share a row over the {len(kept)} trainable attributes")
    return ZeroShotVariant(
        "merge", tuple(train), tuple(test), class_map, excluded_attributes=excluded,
        note=f"{described}: merged into test class(es) {', '.join(sorted(set(class_map[t] for t in seen)))} "
             f"(their training classes leave training)"
             + (f"; attribute(s) {', '.join(excluded)} then have no positive or no negative training class "
                "and are left out" if excluded else ""),
    )
