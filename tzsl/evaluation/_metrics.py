"""Zero-shot metrics: trial accuracy, per-class mean accuracy, attribute and GZSL scores.

All functions take plain arrays of labels (any hashable dtype: str or int class names) and
return floats in [0, 1] (or NaN where documented). Bad input raises :class:`TzslError`
naming the argument and the problem.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from sklearn.metrics import accuracy_score, recall_score

from tzsl.exceptions import TzslError

__all__ = [
    "gzsl_scores",
    "per_attribute_balanced_accuracy",
    "per_class_accuracy",
    "per_class_mean_accuracy",
    "summarise_over_splits",
    "trial_accuracy",
]


def _labels(y_true, y_pred) -> tuple[np.ndarray, np.ndarray]:
    y_true, y_pred = np.asarray(y_true), np.asarray(y_pred)
    if y_true.ndim != 1 or y_pred.ndim != 1:
        raise TzslError(f"labels must be 1-d, got y_true {y_true.shape} and y_pred {y_pred.shape}")
    if y_true.shape != y_pred.shape:
        raise TzslError(f"y_true has {y_true.size} labels but y_pred has {y_pred.size}")
    if y_true.size == 0:
        raise TzslError("no samples: y_true and y_pred are empty")
    for name, y in (("y_true", y_true), ("y_pred", y_pred)):
        if y.dtype.kind == "f" and np.isnan(y).any():
            raise TzslError(f"{name} contains NaN labels")
        if y.dtype == object and pd.isna(y).any():
            raise TzslError(f"{name} contains missing labels")
    if y_true.dtype.kind != y_pred.dtype.kind and {y_true.dtype.kind, y_pred.dtype.kind} & {"U", "O", "S"}:
        # compare as strings when one side is text, as sklearn refuses mixed types
        y_true, y_pred = y_true.astype(str), y_pred.astype(str)
    return y_true, y_pred


def trial_accuracy(y_true, y_pred) -> float:
    """Fraction of trials whose predicted class is the true one (the DAP paper's metric).

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_trials,)
        True and predicted class (object) labels.

    Returns
    -------
    float in [0, 1]
    """
    y_true, y_pred = _labels(y_true, y_pred)
    return float(accuracy_score(y_true, y_pred))


def per_class_accuracy(y_true, y_pred) -> pd.Series:
    """Accuracy (recall) of each true class.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_trials,)

    Returns
    -------
    Series indexed by the sorted classes of ``y_true``
        Fraction of each class's trials predicted as that class.
    """
    y_true, y_pred = _labels(y_true, y_pred)
    classes = np.unique(y_true)
    recall = recall_score(y_true, y_pred, labels=classes, average=None, zero_division=0.0)
    return pd.Series(recall, index=pd.Index(classes, name="class"), name="accuracy")


def per_class_mean_accuracy(y_true, y_pred) -> float:
    """Mean over the true classes of each class's accuracy (standard ZSL metric).

    Unlike :func:`trial_accuracy`, every class weighs the same whatever its number of
    trials. Classes that occur only in ``y_pred`` do not count.

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_trials,)

    Returns
    -------
    float in [0, 1]
    """
    y_true, y_pred = _labels(y_true, y_pred)
    classes = np.unique(y_true)
    return float(recall_score(y_true, y_pred, labels=classes, average="macro", zero_division=0.0))


def _binary_matrix(name: str, M) -> np.ndarray:
    M = np.asarray(M)
    if M.ndim == 1:
        M = M[:, None]
    if M.ndim != 2:
        raise TzslError(f"{name} must be 2-d (n_samples, n_attributes), got shape {M.shape}")
    try:
        Mf = M.astype(float)
    except (TypeError, ValueError):
        raise TzslError(f"{name} must hold 0/1 values, got dtype {M.dtype}") from None
    bad = ~np.isin(Mf, (0.0, 1.0))
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise TzslError(
            f"{name} must hold only 0/1 values (threshold posteriors first): "
            f"row {r}, attribute column {c} is {M[r, c].tolist()!r} ({int(bad.sum())} such entries)"
        )
    return Mf.astype(bool)


def per_attribute_balanced_accuracy(A_true, A_pred) -> np.ndarray:
    """Balanced accuracy of every attribute: mean of its true-positive and true-negative rates.

    Parameters
    ----------
    A_true : array-like of shape (n_samples, n_attributes)
        True 0/1 attributes of each sample (its object's attribute row).
    A_pred : array-like of shape (n_samples, n_attributes)
        Predicted 0/1 attributes (e.g. posterior >= 0.5).

    Returns
    -------
    ndarray of float, shape (n_attributes,)
        ``(TP / P + TN / N) / 2`` per attribute. **NaN** where an attribute takes a single
        value over the samples (P = 0 or N = 0, e.g. no test object has it): its balanced
        accuracy is undefined, and reporting the one defined rate alone would not be
        comparable. Use ``np.nanmean`` to average over attributes.
    """
    T = _binary_matrix("A_true", A_true)
    P = _binary_matrix("A_pred", A_pred)
    if T.shape != P.shape:
        raise TzslError(f"A_true has shape {T.shape} but A_pred has shape {P.shape}")
    if T.shape[0] == 0:
        raise TzslError("no samples: A_true and A_pred are empty")
    n_pos = T.sum(axis=0)
    n_neg = T.shape[0] - n_pos
    tp = (T & P).sum(axis=0)
    tn = (~T & ~P).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        bacc = 0.5 * (tp / n_pos + tn / n_neg)
    bacc[(n_pos == 0) | (n_neg == 0)] = np.nan
    return bacc


def gzsl_scores(y_true, y_pred, seen_classes, unseen_classes) -> dict[str, float]:
    """Generalised zero-shot scores: seen and unseen per-class mean accuracy, harmonic mean.

    Predictions range over seen + unseen classes. ``seen`` is the per-class mean accuracy
    over the samples whose true class is seen, ``unseen`` the same over unseen-class samples
    (a seen sample predicted as any other class, unseen included, is wrong, and vice versa),
    and ``harmonic = 2 seen unseen / (seen + unseen)`` (0 when both are 0).

    Parameters
    ----------
    y_true, y_pred : array-like of shape (n_samples,)
    seen_classes, unseen_classes : array-like
        Disjoint class sets; every label of ``y_true`` is in one of them.

    Returns
    -------
    dict with float keys ``seen``, ``unseen``, ``harmonic``
    """
    y_true, y_pred = _labels(y_true, y_pred)
    seen, unseen = np.unique(np.asarray(seen_classes)), np.unique(np.asarray(unseen_classes))
    kinds = {y_true.dtype.kind, seen.dtype.kind, unseen.dtype.kind}
    if len(kinds) > 1 and kinds & {"U", "O", "S"}:
        y_true, y_pred = y_true.astype(str), y_pred.astype(str)
        seen, unseen = np.unique(seen.astype(str)), np.unique(unseen.astype(str))
    both = np.intersect1d(seen, unseen)
    if both.size:
        raise TzslError(f"class(es) {both[:10].tolist()} are both seen and unseen")
    is_seen, is_unseen = np.isin(y_true, seen), np.isin(y_true, unseen)
    stray = np.unique(y_true[~(is_seen | is_unseen)])
    if stray.size:
        raise TzslError(f"true class(es) {stray[:10].tolist()} are neither seen nor unseen")
    for name, mask in (("seen", is_seen), ("unseen", is_unseen)):
        if not mask.any():
            raise TzslError(f"no sample of a {name} class in y_true: GZSL needs both")
    s = per_class_mean_accuracy(y_true[is_seen], y_pred[is_seen])
    u = per_class_mean_accuracy(y_true[is_unseen], y_pred[is_unseen])
    h = 0.0 if s + u == 0 else 2.0 * s * u / (s + u)
    return {"seen": s, "unseen": u, "harmonic": h}


def summarise_over_splits(
    df: pd.DataFrame, *, split_column: str = "split", by: Sequence[str] = (), ddof: int = 1
) -> pd.DataFrame:
    """Append ``mean`` and ``std`` rows over splits (or seeds) to a per-split results table.

    The one place where tzsl averages a study's repetitions: the PHAC-2 tables (over splits),
    the GZSL table (over splits, per method), the hand tables (over seeds, per method or
    attribute), the fabric tables (over seeds, per condition, config and method).

    Parameters
    ----------
    df : DataFrame
        One row per split (per ``by`` group); metric columns numeric.
    split_column : str, default "split"
        The column naming the repetition (a split, a seed).
    by : sequence of str, default ()
        Group columns: with none, the whole table is one group and ``split_column`` (if
        present) becomes the index, as the split names index the rows. With ``by``, one
        ``mean`` and one ``std`` row per group (groups in order of appearance, all ``mean``
        rows before all ``std`` rows); ``split_column`` stays a column (object dtype, holding
        ``"mean"`` / ``"std"`` in the summary rows), the columns are ordered
        ``[split_column, *by, others...]`` and the index is a RangeIndex.
    ddof : int, default 1
        Delta degrees of freedom of the standard deviation (1: sample std over splits;
        NaN for a single split).

    Returns
    -------
    DataFrame
        The per-split rows followed by rows ``mean`` and ``std`` of the numeric columns,
        NaN skipped (e.g. an attribute undefined on some split). Non-numeric columns are
        left empty (NaN) in the summary rows.
    """
    if not isinstance(df, pd.DataFrame):
        raise TzslError(f"summarise_over_splits expects a DataFrame, got {type(df).__name__}")
    if df.empty:
        raise TzslError("summarise_over_splits: the results table has no rows")
    by = list(by)
    if by:
        return _summarise_groups(df, split_column, by, ddof)
    table = df.set_index(split_column) if split_column in df.columns else df.copy()
    reserved = {"mean", "std"} & set(map(str, table.index))
    if reserved:
        raise TzslError(f"summarise_over_splits: split names {sorted(reserved)} clash with the summary rows")
    numeric = table.select_dtypes(include=["number", "bool"]).astype(float)
    if numeric.shape[1] == 0:
        raise TzslError(f"summarise_over_splits: no numeric column in {list(table.columns)}")
    summary = pd.DataFrame(
        [numeric.mean(axis=0, skipna=True), numeric.std(axis=0, skipna=True, ddof=ddof)],
        index=pd.Index(["mean", "std"], name=table.index.name),
    )
    return pd.concat([table, summary.reindex(columns=table.columns)], axis=0)


def _summarise_groups(df: pd.DataFrame, split_column: str, by: list[str], ddof: int) -> pd.DataFrame:
    """:func:`summarise_over_splits` with group columns ``by`` (see there)."""
    missing = [c for c in [split_column, *by] if c not in df.columns]
    if missing:
        raise TzslError(f"summarise_over_splits: no column(s) {missing} in {list(df.columns)}")
    reserved = {"mean", "std"} & set(map(str, df[split_column]))
    if reserved:
        raise TzslError(f"summarise_over_splits: split names {sorted(reserved)} clash with the summary rows")
    keys = [split_column, *by]
    numeric = [c for c in df.columns if c not in keys and pd.api.types.is_numeric_dtype(df[c])]
    if not numeric:
        raise TzslError(f"summarise_over_splits: no numeric column in {list(df.columns)}")
    grouped = df.groupby(by, sort=False)[numeric]
    mean = grouped.mean().reset_index().assign(**{split_column: "mean"})
    std = grouped.std(ddof=ddof).reset_index().assign(**{split_column: "std"})
    out = pd.concat([df.assign(**{split_column: df[split_column].astype(object)}), mean, std], ignore_index=True)
    return out[keys + [c for c in df.columns if c not in keys]]
