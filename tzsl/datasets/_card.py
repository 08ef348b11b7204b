"""A dataset card: what a zero-shot study can and cannot learn from a plain dataset.

``tzsl validate DIR`` ends with it (``--json`` for a machine). Numbers are counted from the
dataset; the split settings it is read against (test classes per split, positive training
objects per attribute) are the caller's (the command line passes the generic study's defaults).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

__all__ = ["card_lines", "dataset_card"]


def dataset_card(classes: pd.DataFrame, trial_classes: Sequence[str], *, n_test: int,
                 min_train_positives: int, min_train_negatives: int) -> dict:
    """Counts a zero-shot study of this dataset depends on.

    Parameters
    ----------
    classes : DataFrame of shape (n_classes, n_attributes)
        0/1 class-attribute table (``classes.csv``).
    trial_classes : sequence of str, length n_trials
        The class of every trial (one entry per trial, not per sensor row).
    n_test : int
        Test (unseen) classes per random split of the default study (0: no split can be drawn).
    min_train_positives, min_train_negatives : int
        Positive / negative training classes an attribute needs to be learned (attribute SVMs
        tuned by class-grouped CV need 2 of each).

    Returns
    -------
    dict
        ``n_classes``, ``n_classes_with_trials``, ``trials_per_class`` (min, median, max),
        ``positives`` (attribute -> classes with it), ``identical_rows`` (groups of classes
        sharing a row: no attribute model can tell them apart), ``too_rare`` (attributes with
        fewer than ``min_train_positives`` positive or ``min_train_negatives`` negative classes,
        even before any class is held out), ``n_distinct_rows``, ``n_test`` (the default split's
        test classes, at most the distinct rows) and ``chance`` (1 / that).
    """
    K = classes.to_numpy(dtype=int)
    counts = pd.Series(list(trial_classes)).value_counts()
    per_class = counts.reindex(classes.index, fill_value=0).to_numpy()
    with_trials = per_class[per_class > 0]
    positives = dict(zip(map(str, classes.columns), K.sum(axis=0).tolist(), strict=True))
    n_classes = len(classes)
    rows, inverse = np.unique(K, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    names = classes.index.astype(str)
    first = {r: i for i, r in reversed(list(enumerate(inverse)))}  # a row's first class, table order
    groups = [list(names[inverse == r]) for r in sorted(first, key=first.__getitem__) if (inverse == r).sum() > 1]
    too_rare = [a for a, p in positives.items() if p < min_train_positives or n_classes - p < min_train_negatives]
    n_split = max(0, min(n_test, len(rows)))
    return {
        "n_classes": n_classes,
        "n_classes_with_trials": int(with_trials.size),
        "trials_per_class": [int(with_trials.min()), float(np.median(with_trials)), int(with_trials.max())]
        if with_trials.size else [0, 0.0, 0],
        "positives": positives,
        "identical_rows": groups,
        "too_rare": too_rare,
        "n_distinct_rows": int(len(rows)),
        "n_test": n_split,
        "chance": (1.0 / n_split) if n_split else float("nan"),
        "min_train_positives": min_train_positives,
        "min_train_negatives": min_train_negatives,
    }


def card_lines(card: dict) -> list[str]:
    """The card for people, one fact a line."""
    low, median, high = card["trials_per_class"]
    positives = ", ".join(f"{a} {p}" for a, p in card["positives"].items())
    lines = [
        "dataset card:",
        f"  classes:              {card['n_classes']} ({card['n_classes_with_trials']} with trials, "
        f"{card['n_distinct_rows']} distinct attribute rows)",
        f"  trials per class:     min {low}, median {median:g}, max {high}",
        f"  positive classes:     {positives}",
    ]
    if card["identical_rows"]:
        groups = "; ".join(" = ".join(g) for g in card["identical_rows"])
        lines.append(f"  identical rows:       {groups} (no attribute model can tell these apart)")
    else:
        lines.append("  identical rows:       none")
    rare = ", ".join(card["too_rare"]) or "none"
    lines.append(f"  too rare to learn:    {rare} (fewer than {card['min_train_positives']} positive or "
                 f"{card['min_train_negatives']} negative classes)")
    if card["n_test"]:
        lines.append(f"  default random split: {card['n_test']} unseen classes, chance {card['chance']:.3f} "
                     "(the template's study, after relaxing what this dataset cannot honour)")
    else:
        lines.append("  default random split: none can be drawn (tzsl run would stop with the reason)")
    return lines
