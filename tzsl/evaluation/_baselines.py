"""What a zero-shot accuracy should be compared with: chance, trivial baselines, a control.

* **Chance**: ``1 / n_test_classes``, the expected per-trial (and per-class mean) accuracy
  of a guess that ignores the trial.
* **Majority class**: always predict the test class with the most trials. Its per-trial
  accuracy is ``max_count / n_trials``; above chance when test classes have unequal trial
  counts (fabric: 27 test fabrics), and it knows the test class frequencies, so it is an
  optimistic trivial baseline. Its per-class mean accuracy is exactly chance.
* **Per-attribute majority**: predict for every attribute its more frequent value (in the
  training objects' rows when given, else in the test samples: the optimistic version).
  Plain attribute accuracy must beat it to mean anything; its balanced accuracy is 0.5 by
  construction, which is why balanced accuracy is the attribute headline.
* **Negative control** (:func:`shuffled_rows_control`): the test classes' attribute rows are
  permuted among the test classes and the trials rescored with the *same* attribute
  posteriors. Whatever the model, a uniformly random permutation gives chance in
  expectation (a trial is right exactly when the permutation sends its class to the row the
  model ranks first, probability ``1/n``). Every permutation drawn must change the table
  (the identity, or one only swapping equal rows, is redrawn; this moves the expectation
  off chance by less than ``1 / n!``). We do not use derangements
  (every class on another row): for a model with accuracy ``acc`` they give
  ``(1 - acc) / (n - 1)``, *below* chance, so a derangement control could not "come out at
  chance". A control at chance shows that the accuracy above chance comes from the correct
  attribute assignment, not from the scoring code or the test-class set.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

from tzsl.evaluation._metrics import per_attribute_balanced_accuracy
from tzsl.exceptions import TzslError

__all__ = [
    "attribute_baselines",
    "chance_accuracy",
    "majority_class_accuracy",
    "shuffled_attribute_rows",
    "shuffled_rows_control",
]


def chance_accuracy(y_true) -> float:
    """``1 / number of test classes`` (the distinct labels of ``y_true``; or an int count)."""
    if isinstance(y_true, (int, np.integer)):
        n = int(y_true)
    else:
        n = len(pd.unique(np.asarray(y_true).ravel()))
    if n < 1:
        raise TzslError("chance accuracy needs at least one test class")
    return 1.0 / n


def majority_class_accuracy(y_true) -> float:
    """Per-trial accuracy of always predicting the test class with the most trials.

    Parameters
    ----------
    y_true : array-like of shape (n_trials,)
        True test class of each trial.

    Returns
    -------
    float in (0, 1]
        ``max_count / n_trials``. (Its per-class mean accuracy is ``1 / n_classes``.)
    """
    y = np.asarray(y_true).ravel()
    if y.size == 0:
        raise TzslError("majority-class accuracy needs at least one trial")
    _, counts = np.unique(y.astype(str) if y.dtype == object else y, return_counts=True)
    return float(counts.max() / y.size)


def attribute_baselines(A_true, A_pred, A_train=None, attributes=None) -> pd.DataFrame:
    """Attribute accuracy, balanced accuracy (headline) and the per-attribute majority baseline.

    Parameters
    ----------
    A_true : array-like of shape (n_samples, n_attributes)
        True 0/1 attributes of each test sample (its object's row).
    A_pred : array-like of shape (n_samples, n_attributes)
        Predicted 0/1 attributes.
    A_train : array-like of shape (n_train_objects, n_attributes), optional
        Training objects' rows: the majority value per attribute is taken there (a baseline
        that sees no test label). Without it, the test samples' majority (optimistic).
    attributes : sequence of str, optional
        Row names (default ``a0, a1, ...``).

    Returns
    -------
    DataFrame indexed by attribute, plus a last row ``mean``
        ``accuracy``, ``balanced_accuracy`` (NaN where the test samples have one value),
        ``majority_accuracy`` (the baseline's plain accuracy), ``majority_balanced_accuracy``
        (0.5, or NaN where undefined); ``mean`` averages each column skipping NaN.
    """
    T = np.asarray(A_true, dtype=float)
    P = np.asarray(A_pred, dtype=float)
    bacc = per_attribute_balanced_accuracy(T, P)  # validates 0/1 and shapes
    T, P = T.reshape(len(T), -1).astype(bool), P.reshape(len(P), -1).astype(bool)
    if A_train is None:
        majority = T.mean(axis=0) >= 0.5
    else:
        R = np.asarray(A_train, dtype=float).reshape(-1, T.shape[1])
        if R.shape[0] == 0 or not np.isin(R, (0.0, 1.0)).all():
            raise TzslError(f"A_train must be non-empty 0/1 rows of {T.shape[1]} attributes")
        majority = R.mean(axis=0) >= 0.5
    majority_acc = (T == majority).mean(axis=0)
    defined = ~np.isnan(bacc)
    names = list(attributes) if attributes is not None else [f"a{j}" for j in range(T.shape[1])]
    if len(names) != T.shape[1]:
        raise TzslError(f"{len(names)} attribute names for {T.shape[1]} attribute columns")
    table = pd.DataFrame(
        {
            "accuracy": (T == P).mean(axis=0),
            "balanced_accuracy": bacc,
            "majority_accuracy": majority_acc,
            "majority_balanced_accuracy": np.where(defined, 0.5, np.nan),
        },
        index=pd.Index(names, name="attribute"),
    )
    table.loc["mean"] = table.mean(axis=0, skipna=True)
    return table


def shuffled_attribute_rows(class_attributes: pd.DataFrame, random_state=None, max_draws: int = 1000) -> pd.DataFrame:
    """The same attribute rows permuted among the same classes, the table really changed.

    Parameters
    ----------
    class_attributes : DataFrame of shape (n_classes, n_attributes)
        Test classes' 0/1 rows, indexed by class.
    random_state : int, Generator or None
    max_draws : int, default 1000
        Permutations tried before giving up (only needed when most rows are equal).

    Returns
    -------
    DataFrame
        Same index and columns; row ``k`` holds the original row of class ``perm[k]``, and
        at least one class's row differs from its own.

    Raises
    ------
    TzslError
        Fewer than 2 classes, or every row equal (no permutation changes the table).
    """
    K = class_attributes.to_numpy()
    if K.shape[0] < 2 or len(np.unique(K, axis=0)) < 2:
        raise TzslError(f"shuffling needs at least 2 different class rows, got {K.shape[0]} class(es) "
                        f"with {len(np.unique(K, axis=0)) if K.size else 0} distinct row(s)")
    rng = np.random.default_rng(random_state)
    for _ in range(max_draws):
        perm = rng.permutation(K.shape[0])
        if (K[perm] != K).any():
            return pd.DataFrame(K[perm], index=class_attributes.index, columns=class_attributes.columns)
    raise TzslError(f"no permutation changing the table in {max_draws} draws")


def shuffled_rows_control(
    score_classes: Callable[[pd.DataFrame], np.ndarray],
    class_attributes: pd.DataFrame,
    y_true,
    *,
    n_permutations: int = 100,
    random_state: int | None = 0,
) -> np.ndarray:
    """Negative control: per-trial share of correct answers over shuffled class-attribute tables.

    Parameters
    ----------
    score_classes : callable
        ``score_classes(table) -> scores`` of shape (n_trials, n_classes), higher is
        better, one column per row of ``table`` in order; the caller closes over its fixed
        attribute posteriors (e.g. ``lambda K: dap_log_scores(P, K.to_numpy(), prior)``).
    class_attributes : DataFrame of shape (n_classes, n_attributes)
        The test classes' true rows, indexed by class.
    y_true : array-like of shape (n_trials,)
        True class of each trial (values of ``class_attributes.index``).
    n_permutations : int, default 100
        Tables drawn with :func:`shuffled_attribute_rows` (seeded from ``random_state``).

    Returns
    -------
    ndarray of float, shape (n_trials,)
        Fraction of the permutations under which each trial was recognised; its mean is
        the control's accuracy (chance in expectation), and it can be passed as
        ``correct`` to :func:`tzsl.evaluation.bootstrap_accuracy` for an interval.
    """
    y = np.asarray(y_true)
    classes = np.asarray(class_attributes.index)
    unknown = set(pd.unique(y)) - set(classes)
    if unknown:
        raise TzslError(f"true class(es) {sorted(map(str, unknown))[:5]} not in the class-attribute table")
    if not isinstance(n_permutations, (int, np.integer)) or n_permutations < 1:
        raise TzslError(f"n_permutations must be a positive integer, got {n_permutations!r}")
    rng = np.random.default_rng(random_state)
    hits = np.zeros(len(y))
    for _ in range(n_permutations):
        table = shuffled_attribute_rows(class_attributes, random_state=rng)
        scores = np.asarray(score_classes(table))
        if scores.shape != (len(y), len(classes)):
            raise TzslError(f"score_classes returned shape {scores.shape}, expected {(len(y), len(classes))}")
        hits += classes[np.argmax(scores, axis=1)] == y
    return hits / n_permutations
