"""Settings a small dataset cannot honour, relaxed in a fixed order and said out loud.

A zero-shot study asks for things a dataset of a few classes may not have: ten test classes with
mutually different attribute rows, attributes with two positive training objects in every
split, five object-grouped CV folds, pseudo-unseen classes for calibrated stacking. Instead of
failing, :func:`relax_to_dataset` lowers each setting to what the dataset allows, in this order,
and returns one :class:`Relaxation` per change (printed as ``note:`` lines and recorded in the
manifest under ``relaxations``):

1. ``splits.n_test`` (test classes per random split): at most the number of distinct attribute
   rows and at most ``n_objects - 2`` (two training objects remain).
2. ``splits.min_train_negatives``: raised to 2 when a random split would keep an attribute with
   one negative training object (the attribute SVMs' object-grouped CV cannot tune it; the split
   leaves it out instead). If no split can be drawn, ``splits.n_test`` is lowered one by one
   (down to 2). Every split must leave each kept attribute 2 positive and 2 negative training
   objects, and its training objects :data:`~tzsl.models.protocol.MIN_CV_CLASSES` distinct attribute rows
   (the class-grouped CV of ESZSL, SAE and the embedding models, compared on random splits).
3. ``splits.challenging_min_train_positives``: lowered one by one (down to 2) until the
   challenging partitions can be drawn and each leaves every kept attribute 2 positive and 2
   negative training objects (and, when methods are compared on them, its training objects
   :data:`~tzsl.models.protocol.MIN_CV_CLASSES` distinct rows for their class-grouped CV); if never,
   challenging splits are left out (``splits.kinds``).
4. ``svm.cv`` (object-grouped folds): at most the fewest training objects of any split.
5. GZSL calibrated stacking (in :mod:`tzsl.studies.zero_shot.gzsl`): fewer pseudo-unseen classes;
   where none can be drawn, or a method cannot be fitted on them, that split reports the
   uncalibrated row only (``relaxed`` column of gzsl.csv).

Where nothing sound is possible (fewer than two distinct attribute rows, fewer than two
training objects) a :class:`~tzsl.exceptions.ConfigError` names the experiment and the reason.
A setting the dataset can honour is never changed, so the paper's data give the paper's splits.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet
from tzsl.evaluation import challenging_splits, random_object_splits
from tzsl.exceptions import ConfigError, SplitError
from tzsl.models.protocol import MIN_CV_CLASSES

__all__ = ["SVM_MIN_OBJECTS", "Relaxation", "relax_to_dataset", "relaxed_n_test", "trainable_attribute_rule"]


@dataclass(frozen=True)
class Relaxation:
    """One setting lowered to what the dataset allows.

    Attributes
    ----------
    setting : str
        Key of the experiment file (``splits.n_test``), or a GZSL split.
    asked, used
        The value asked for and the value used.
    why : str
        What in the dataset made the change necessary.
    """

    setting: str
    asked: Any
    used: Any
    why: str

    def line(self) -> str:
        """``setting: asked -> used (why)``, one line."""
        return f"{self.setting}: {self.asked} -> {self.used} ({self.why})"

    def record(self) -> dict:
        return {"setting": self.setting, "asked": self.asked, "used": self.used, "why": self.why}


#: The attribute SVMs' object-grouped CV needs this many positive and negative training objects.
SVM_MIN_OBJECTS = 2


def trainable_attribute_rule(splits) -> dict:
    """Least positive and negative training objects of an attribute the study keeps in a split.

    ``splits``: a ``[splits]`` section of the schema. Its ``random_min_train_positives`` and
    ``min_train_negatives``, each raised to :data:`SVM_MIN_OBJECTS` (every split the study draws
    leaves each kept attribute that many of both, steps 1-3). ``tzsl validate``'s dataset card and
    the model commands (:func:`tzsl.inference.model_bundles.training_subset`) leave out the same
    attributes.

    Returns
    -------
    dict
        ``min_train_positives`` and ``min_train_negatives`` (keywords of
        :func:`tzsl.evaluation.attribute_exclusions`).
    """
    return {"min_train_positives": max(splits.random_min_train_positives, SVM_MIN_OBJECTS),
            "min_train_negatives": max(splits.min_train_negatives, SVM_MIN_OBJECTS)}


def _trainable(A, drawn, min_classes: int = 1) -> bool:
    """Whether every attribute a split keeps has enough positive and negative training objects,
    and the training objects hold ``min_classes`` distinct attribute rows."""
    for split in drawn:
        train = A.loc[list(split.train_objects), list(split.kept_attributes)].to_numpy(dtype=int)
        positives = train.sum(axis=0)
        if (positives < SVM_MIN_OBJECTS).any() or (len(train) - positives < SVM_MIN_OBJECTS).any():
            return False
        if len(np.unique(train, axis=0)) < min_classes:
            return False
    return True


def _random_draw(A, n_test: int, splits, negatives: int):
    try:
        drawn = random_object_splits(A, n_test=n_test, n_splits=splits.n_splits, random_state=splits.seed,
                                     min_train_positives=splits.random_min_train_positives,
                                     min_train_negatives=negatives, purpose=splits.purpose)
    except SplitError:
        return None
    return drawn if _trainable(A, drawn, MIN_CV_CLASSES) else None


def _relax_random(source: str, A, splits, notes: list[Relaxation]) -> tuple[int, int, list]:
    """(n_test, min negatives, splits) for the random splits, relaxing steps 1 and 2."""
    n_objects, n_distinct = len(A), len(np.unique(A.to_numpy(), axis=0))
    cap = min(splits.n_test, n_distinct, n_objects - 2)
    if cap < 2:
        raise ConfigError(f"{source}: splits: no zero-shot split is possible: {n_objects} objects with "
                          f"{n_distinct} distinct attribute row(s) (needs 2 test classes with different rows "
                          "and 2 training objects)")
    if cap < splits.n_test:
        notes.append(Relaxation("splits.n_test", splits.n_test, cap,
                                f"{n_distinct} distinct attribute rows among {n_objects} objects"))
    asked = splits.min_train_negatives
    for n_test in range(cap, 1, -1):
        for negatives in dict.fromkeys((asked, max(asked, SVM_MIN_OBJECTS))):
            drawn = _random_draw(A, n_test, splits, negatives)
            if drawn is None:
                continue
            if negatives != asked:
                notes.append(Relaxation("splits.min_train_negatives", asked, negatives,
                                        "an attribute kept with 1 negative training object cannot be tuned by "
                                        "object-grouped CV: it is left out of that split instead"))
            if n_test != cap:
                notes.append(Relaxation("splits.n_test", cap, n_test,
                                        f"no draw of {cap} test objects with distinct rows leaves every kept "
                                        f"attribute {splits.random_min_train_positives} positive and 2 negative "
                                        "training objects"))
            return n_test, negatives, drawn
    raise ConfigError(f"{source}: splits: no random split of {n_objects} objects can be drawn (down to 2 test "
                      f"objects with distinct rows) that leaves every kept attribute "
                      f"{splits.random_min_train_positives} positive and 2 negative training objects and "
                      f"{MIN_CV_CLASSES} distinct training attribute rows; nothing sound to run")


def relaxed_n_test(object_attributes, splits) -> int:
    """Test objects per random split the study will use on this attribute table (0: no sound split).

    ``splits``: a ``[splits]`` section of the schema (its ``n_test`` before relaxation).
    """
    try:
        return _relax_random("", object_attributes, splits, [])[0]
    except ConfigError:
        return 0


def _relax_challenging(features: FeatureSet, splits, negatives: int, notes: list[Relaxation],
                       min_classes: int = 1) -> tuple[int | None, list, pd.DataFrame | None]:
    """(min positives, splits, object map) of the challenging splits, or (None, [], None) when none can be drawn.

    ``min_classes``: distinct training rows each partition needs (:data:`MIN_CV_CLASSES` when methods
    with class-grouped CV are compared on the challenging splits).
    """
    from tzsl.studies.zero_shot.study import object_map_features  # noqa: PLC0415

    asked = splits.challenging_min_train_positives
    for positives in range(asked, SVM_MIN_OBJECTS - 1, -1):
        try:
            drawn, object_map = challenging_splits(object_map_features(features), features.attributes,
                                                   min_train_positives=positives, min_train_negatives=negatives)
        except SplitError:
            continue
        # trainable attributes, and the training rows the compared methods' class-grouped CV needs
        if not _trainable(features.attributes, drawn, min_classes):
            continue
        if positives != asked:
            notes.append(Relaxation("splits.challenging_min_train_positives", asked, positives,
                                    "a partition's training objects lack positives of an attribute"))
        return positives, drawn, object_map
    notes.append(Relaxation("splits.kinds", "random + challenging", "random",
                            "no set of challenging partitions of the 2-D feature map leaves every kept attribute 2 "
                            f"positive and 2 negative training objects and {min_classes} distinct training row(s)"))
    return None, [], None


def relax_to_dataset(exp, features: FeatureSet):
    """The experiment with every setting ``features`` cannot honour relaxed, and what changed.

    Parameters
    ----------
    exp : Experiment
        A ``zero-shot`` or ``phac2-dap`` experiment (:mod:`tzsl.studies.config`).
    features : FeatureSet
        The dataset read.

    Returns
    -------
    exp : Experiment
        A copy with the relaxed settings (the same object when nothing changed).
    notes : list of Relaxation
        In the order of the module docstring.
    drawn : dict
        The splits drawn to check the relaxed settings, by kind: ``"random"`` -> ``(splits, None)``,
        ``"challenging"`` -> ``(splits, object map)`` (:func:`~tzsl.studies.zero_shot.study.make_splits`'s
        result under the relaxed settings), so the study draws them once; empty for ``kinds = ["file"]``.
    """
    c = exp.config
    splits, svm = c.splits, c.svm
    notes: list[Relaxation] = []
    found: dict[str, tuple[list, pd.DataFrame | None]] = {}
    if splits.kinds == ["file"]:
        return exp, notes, found
    A = features.attributes
    split_update: dict[str, Any] = {}
    train_sizes: list[int] = []
    negatives = splits.min_train_negatives
    if "random" in splits.kinds:
        n_test, negatives, drawn = _relax_random(exp.source, A, splits, notes)
        split_update.update(n_test=n_test, min_train_negatives=negatives)
        train_sizes += [len(s.train_objects) for s in drawn]
        found["random"] = (drawn, None)
    if "challenging" in splits.kinds:
        compared = "challenging" in c.methods.compare_on and bool(c.methods.method_specs())
        positives, drawn, object_map = _relax_challenging(features, splits, negatives, notes,
                                                          MIN_CV_CLASSES if compared else 1)
        if positives is None:
            kinds = [k for k in splits.kinds if k != "challenging"]
            if not kinds:
                raise ConfigError(f"{exp.source}: splits.kinds: no challenging split of this dataset can be drawn "
                                  "and no other kind is asked for; add \"random\"")
            split_update["kinds"] = kinds
        else:
            split_update["challenging_min_train_positives"] = positives
            train_sizes += [len(s.train_objects) for s in drawn]
            found["challenging"] = (drawn, object_map)
    fewest = min(train_sizes) if train_sizes else len(A)
    if fewest < 2:
        raise ConfigError(f"{exp.source}: splits: a split leaves {fewest} training object(s); the attribute "
                          "models need at least 2")
    svm_update = {}
    if svm.cv and svm.cv > fewest:
        svm_update["cv"] = fewest
        notes.append(Relaxation("svm.cv", svm.cv, fewest, f"a split has only {fewest} training objects"))
    changed = {k: v for k, v in split_update.items() if getattr(splits, k) != v}
    if not changed and not svm_update:
        return exp, notes, found
    config = c.model_copy(update={"splits": splits.model_copy(update=changed),
                                  "svm": svm.model_copy(update=svm_update)})
    return dataclasses.replace(exp, config=config), notes, found
