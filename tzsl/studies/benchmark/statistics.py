"""Statistics of a cross-dataset benchmark: per-dataset scores, ranks, Friedman, Nemenyi, meta-analysis.

Every function takes the benchmark's long table of scores, one row per (dataset, method, split):

``dataset``, ``method``, ``split``
    Labels; a split is one train/test partition of the dataset's objects, the same for every
    method of that dataset (so two methods' scores on one split are paired).
``score``
    Per-class mean accuracy of the method on the split, a fraction in [0, 1], higher is better.
    NaN marks a fit that failed: its row is dropped, everything below uses the scores present.
``chance`` (optional)
    Chance accuracy of the row's split (1 / number of test classes), or pass ``chance`` as a
    Series (or mapping) from dataset to chance.

The cross-dataset comparison follows Demšar (2006): methods are ranked within each dataset by
their mean score over splits, the Friedman test (with the Iman-Davenport F correction) asks
whether the mean ranks differ more than chance would make them, and Nemenyi's critical
difference (CD) tells which mean ranks are far enough apart. :func:`meta_analysis` adds the size
of each paired difference, pooled across datasets by a DerSimonian-Laird random-effects model of
the per-dataset mean paired differences, as MOABB pools its per-dataset effects.

References
----------
Demšar, J. (2006). Statistical comparisons of classifiers over multiple data sets. Journal of
Machine Learning Research 7, 1-30.
DerSimonian, R. and Laird, N. (1986). Meta-analysis in clinical trials. Controlled Clinical Trials
7(3), 177-188.
Jayaram, V. and Barachant, A. (2018). MOABB: trustworthy algorithm benchmarking for BCIs. Journal
of Neural Engineering 15(6), 066011.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy import stats

from tzsl.evaluation import bootstrap_accuracy
from tzsl.exceptions import ConfigError, TzslError

__all__ = ["META_COLUMNS", "MIN_VARIANCE", "N_BOOT", "RANK_DECIMALS", "SCORE_COLUMNS", "FriedmanResult",
           "critical_difference", "dataset_ranks", "friedman_test", "mean_ranks", "meta_analysis", "nemenyi_q",
           "paired_effects", "per_dataset_table", "rank_groups"]

#: Columns the long scores table must have.
SCORE_COLUMNS: tuple[str, ...] = ("dataset", "method", "split", "score")

#: Bootstrap replicates of the per-dataset intervals.
N_BOOT = 2000

#: Smallest variance given to a dataset's mean paired difference in the meta-analysis: a pair
#: whose differences are the same on every split (standard error 0) weighs a lot, not infinitely.
MIN_VARIANCE = 1e-12

#: Decimals mean scores are rounded to before ranking, so equal means computed in another order tie.
RANK_DECIMALS = 12


class FriedmanResult(NamedTuple):
    """The Friedman test of equal mean ranks (Demšar 2006, section 3.2.2).

    Attributes
    ----------
    chi2, chi2_pvalue : float
        Friedman's statistic, chi-square with ``n_methods - 1`` degrees of freedom under the null.
    f, f_pvalue : float
        Iman and Davenport's statistic, F with ``n_methods - 1`` and
        ``(n_methods - 1)(n_datasets - 1)`` degrees of freedom (inf when every dataset ranks
        the methods alike).
    n_datasets, n_methods : int
    """

    chi2: float
    chi2_pvalue: float
    f: float
    f_pvalue: float
    n_datasets: int
    n_methods: int


def _clean_scores(scores: pd.DataFrame) -> pd.DataFrame:
    """The scores table checked, failed fits (NaN scores) dropped; columns SCORE_COLUMNS (+ chance)."""
    if not isinstance(scores, pd.DataFrame):
        raise TzslError(f"the benchmark scores must be a DataFrame, got {type(scores).__name__}")
    missing = [c for c in SCORE_COLUMNS if c not in scores.columns]
    if missing:
        raise TzslError(f"the benchmark scores lack column(s) {missing}; they have {list(scores.columns)}")
    keep = list(SCORE_COLUMNS) + (["chance"] if "chance" in scores.columns else [])
    df = scores[keep].copy()
    if df[["dataset", "method", "split"]].isna().any().any():
        raise TzslError("the benchmark scores have rows without a dataset, method or split label")
    try:
        df["score"] = df["score"].astype(float)
    except (TypeError, ValueError):
        raise TzslError("the benchmark scores' score column must be numeric") from None
    values = df["score"].to_numpy()
    bad = ~np.isnan(values) & ~((values >= 0) & (values <= 1))
    if bad.any():
        raise TzslError(f"scores must be accuracies in [0, 1] (NaN for a failed fit); got {values[bad][:5].tolist()}")
    dup = df.duplicated(["dataset", "method", "split"])
    if dup.any():
        first = df.loc[dup, ["dataset", "method", "split"]].iloc[0].tolist()
        raise TzslError(f"the benchmark scores have several rows for (dataset, method, split) = {first}")
    df = df[~np.isnan(values)].reset_index(drop=True)
    if df.empty:
        raise TzslError("the benchmark scores have no score (every fit failed or the table is empty)")
    return df


def _row_chance(df: pd.DataFrame, chance: pd.Series | Mapping | None) -> np.ndarray | None:
    """Chance accuracy of each row, shape (n_rows,), or None when neither given nor a column."""
    if chance is None:
        if "chance" not in df.columns:
            return None
        values = df["chance"].astype(float).to_numpy()
    else:
        by_dataset = chance if isinstance(chance, pd.Series) else pd.Series(dict(chance))
        values = df["dataset"].map(by_dataset).astype(float).to_numpy()
        if np.isnan(values).any():
            lacking = sorted(map(str, df.loc[np.isnan(values), "dataset"].unique()))
            raise TzslError(f"no chance accuracy for dataset(s) {lacking}")
    if not ((values >= 0) & (values <= 1)).all():
        raise TzslError("chance accuracies must be fractions in [0, 1]")
    return values


def per_dataset_table(
    scores: pd.DataFrame,
    chance: pd.Series | Mapping | None = None,
    *,
    n_boot: int = N_BOOT,
    random_state: int | None = 0,
) -> pd.DataFrame:
    """Each method's mean score on each dataset, its 95% interval across splits and its gain over chance.

    The interval is the package's bootstrap (:func:`tzsl.evaluation.bootstrap_accuracy`) at the
    split level: splits drawn with replacement, the percentile interval of the mean score; a
    method scored on a single split has none (NaN).

    Parameters
    ----------
    scores : DataFrame
        The long scores table (module docstring), n_rows rows.
    chance : Series or mapping, optional
        Chance accuracy per dataset (index: dataset); default: the ``chance`` column of
        ``scores`` (averaged over the method's splits), else NaN.
    n_boot : int, default 2000
        Bootstrap replicates.
    random_state : int or None, default 0

    Returns
    -------
    DataFrame
        One row per (dataset, method) with a score, sorted by both: ``dataset``, ``method``,
        ``score`` (mean over splits), ``ci95_low``, ``ci95_high``, ``n_splits``, ``chance``,
        ``gain_over_chance`` (``score - chance``, accuracy points as a fraction).
    """
    df = _clean_scores(scores)
    row_chance = _row_chance(df, chance)
    df["chance"] = np.nan if row_chance is None else row_chance
    rows = []
    for (dataset, method), group in df.groupby(["dataset", "method"], sort=True):
        values = group["score"].to_numpy()
        low = high = math.nan
        if len(values) > 1:
            interval = bootstrap_accuracy(values, classes=np.zeros(len(values), dtype=int),
                                          splits=group["split"].to_numpy(), n_boot=n_boot,
                                          random_state=random_state)
            low, high = interval.ci95_low, interval.ci95_high
        mean, base = float(values.mean()), float(group["chance"].mean())
        rows.append({"dataset": dataset, "method": method, "score": mean, "ci95_low": low, "ci95_high": high,
                     "n_splits": len(values), "chance": base, "gain_over_chance": mean - base})
    return pd.DataFrame(rows, columns=["dataset", "method", "score", "ci95_low", "ci95_high", "n_splits",
                                       "chance", "gain_over_chance"])


def _mean_scores(df: pd.DataFrame) -> pd.DataFrame:
    """Mean score over splits, shape (n_datasets, n_methods); NaN where a method has no score."""
    return df.groupby(["dataset", "method"])["score"].mean().unstack("method")


def dataset_ranks(scores: pd.DataFrame) -> pd.DataFrame:
    """Rank of each method within each dataset by mean score over splits (1 = best, ties averaged).

    Only datasets where every method has a score are ranked (a Friedman block must be complete);
    the others are left out with a warning naming them.

    Parameters
    ----------
    scores : DataFrame
        The long scores table (module docstring).

    Returns
    -------
    DataFrame of shape (n_datasets, n_methods)
        Index: the ranked datasets; columns: the methods; every row sums to ``k(k+1)/2``.
    """
    wide = _mean_scores(_clean_scores(scores))
    complete = wide.notna().all(axis=1)
    if not complete.any():
        raise TzslError("no dataset has a score for every method, so none can be ranked")
    if not complete.all():
        warnings.warn(f"dataset(s) {sorted(map(str, wide.index[~complete]))} left out of the ranks: "
                      "some method has no score there", stacklevel=2)
    return wide[complete].round(RANK_DECIMALS).rank(axis=1, ascending=False, method="average")


def mean_ranks(scores: pd.DataFrame, chance: pd.Series | Mapping | None = None) -> pd.DataFrame:
    """Mean rank of each method across the datasets :func:`dataset_ranks` ranks.

    Parameters
    ----------
    scores : DataFrame
        The long scores table (module docstring).
    chance : Series or mapping, optional
        As in :func:`per_dataset_table`.

    Returns
    -------
    DataFrame
        One row per method, best mean rank first (ties by name): ``method``, ``mean_rank``,
        ``mean_score`` (mean over the ranked datasets of the per-dataset mean score),
        ``mean_gain_over_chance`` (likewise of ``score - chance``; NaN without chance),
        ``n_datasets`` (datasets ranked, the same for every method).
    """
    df = _clean_scores(scores)
    row_chance = _row_chance(df, chance)
    ranks = dataset_ranks(df)
    means = _mean_scores(df).loc[ranks.index, ranks.columns]
    if row_chance is None:
        gain = pd.Series(np.nan, index=ranks.columns)
    else:
        base = df.assign(score=row_chance)
        gain = (means - _mean_scores(base).loc[ranks.index, ranks.columns]).mean(axis=0)
    out = pd.DataFrame({"method": ranks.columns, "mean_rank": ranks.mean(axis=0).to_numpy(),
                        "mean_score": means.mean(axis=0).to_numpy(), "mean_gain_over_chance": gain.to_numpy(),
                        "n_datasets": len(ranks)})
    return out.sort_values(["mean_rank", "method"], kind="stable").reset_index(drop=True)


def _ranks_and_n(data: pd.DataFrame) -> tuple[np.ndarray, int]:
    """Mean ranks (k,) and N from a scores table, a :func:`mean_ranks` table or a rank matrix."""
    if not isinstance(data, pd.DataFrame):
        raise TzslError(f"the Friedman test takes a DataFrame, got {type(data).__name__}")
    if set(SCORE_COLUMNS) <= set(data.columns):
        ranks = dataset_ranks(data)
        return ranks.mean(axis=0).to_numpy(), len(ranks)
    if {"mean_rank", "n_datasets"} <= set(data.columns):
        n = data["n_datasets"].to_numpy()
        if len(n) and (n != n[0]).any():
            raise TzslError("mean ranks over different numbers of datasets cannot be tested together")
        return data["mean_rank"].astype(float).to_numpy(), int(n[0]) if len(n) else 0
    matrix = data.astype(float).to_numpy()
    k = matrix.shape[1]
    if not np.isfinite(matrix).all() or not np.allclose(matrix.sum(axis=1), k * (k + 1) / 2):
        raise TzslError("a rank matrix (datasets x methods) must hold, in each row, the ranks 1..k of the methods")
    return matrix.mean(axis=0), matrix.shape[0]


def friedman_test(data: pd.DataFrame) -> FriedmanResult:
    """Friedman's test of equal mean ranks and Iman and Davenport's F version (Demšar 2006).

    ``chi2 = 12 N / (k (k + 1)) * (sum_j R_j^2 - k (k + 1)^2 / 4)`` with ``R_j`` the mean ranks
    (no tie correction, as in Demšar) and ``F = (N - 1) chi2 / (N (k - 1) - chi2)``.

    Parameters
    ----------
    data : DataFrame
        The long scores table (ranked by :func:`dataset_ranks`), the output of
        :func:`mean_ranks` (columns ``mean_rank``, ``n_datasets``), or a rank matrix of shape
        (n_datasets, n_methods).

    Returns
    -------
    FriedmanResult

    Raises
    ------
    ConfigError
        Fewer than 2 datasets or 2 methods.
    """
    r, n = _ranks_and_n(data)
    k = len(r)
    if n < 2 or k < 2:
        raise ConfigError(f"the Friedman test needs at least 2 datasets and 2 methods, got {n} dataset(s) "
                          f"and {k} method(s)")
    chi2 = max(0.0, 12 * n / (k * (k + 1)) * (float(np.sum(r**2)) - k * (k + 1) ** 2 / 4))
    denominator = n * (k - 1) - chi2
    f = (n - 1) * chi2 / denominator if denominator > 0 else math.inf
    f_p = float(stats.f.sf(f, k - 1, (k - 1) * (n - 1))) if math.isfinite(f) else 0.0
    return FriedmanResult(chi2, float(stats.chi2.sf(chi2, k - 1)), f, f_p, n, k)


def _check_alpha(alpha: float) -> None:
    if not 0 < alpha < 1:
        raise ConfigError(f"alpha must be in (0, 1), got {alpha!r}")


def nemenyi_q(k: int, alpha: float = 0.05) -> float:
    """Critical value ``q_alpha`` of the Nemenyi test: the studentized range quantile over sqrt(2).

    Parameters
    ----------
    k : int
        Methods compared (at least 2).
    alpha : float, default 0.05
        Significance level.

    Returns
    -------
    float
        ``studentized_range.ppf(1 - alpha, k, inf) / sqrt(2)`` (Demšar 2006, Table 5a).
    """
    if not isinstance(k, (int, np.integer)) or k < 2:
        raise ConfigError(f"Nemenyi's test compares at least 2 methods, got k = {k!r}")
    _check_alpha(alpha)
    return float(stats.studentized_range.ppf(1 - alpha, int(k), np.inf)) / math.sqrt(2)


def critical_difference(k: int, n_datasets: int, alpha: float = 0.05) -> float:
    """Nemenyi's critical difference of mean ranks, ``q_alpha sqrt(k (k + 1) / (6 N))`` (Demšar 2006).

    Two methods whose mean ranks over ``N`` datasets differ by at least this much perform
    differently at level ``alpha`` (all pairs compared).

    Parameters
    ----------
    k : int
        Methods compared (at least 2).
    n_datasets : int
        Datasets ranked, N (at least 1).
    alpha : float, default 0.05

    Returns
    -------
    float
        The critical difference, in ranks.
    """
    if not isinstance(n_datasets, (int, np.integer)) or n_datasets < 1:
        raise ConfigError(f"the critical difference needs at least 1 dataset, got {n_datasets!r}")
    return nemenyi_q(k, alpha) * math.sqrt(k * (k + 1) / (6 * n_datasets))


def rank_groups(ranks: pd.Series, cd: float) -> list[tuple[str, ...]]:
    """Groups of methods whose mean ranks differ by less than ``cd`` (the bars of a CD diagram).

    Parameters
    ----------
    ranks : Series
        Mean rank of each method (index: method).
    cd : float
        Critical difference (:func:`critical_difference`).

    Returns
    -------
    list of tuple of str
        Maximal runs of methods, in rank order, whose first and last mean ranks differ by less
        than ``cd``; runs of a single method are left out.
    """
    order = ranks.astype(float).sort_values(kind="stable")
    r = order.to_numpy()
    last = np.searchsorted(r, r + cd, side="left") - 1  # (k,): furthest method within cd of each
    first = np.arange(len(r))
    keep = (last > first) & np.r_[True, last[1:] != last[:-1]]
    names = [str(m) for m in order.index]
    return [tuple(names[i:j + 1]) for i, j in zip(first[keep], last[keep], strict=True)]


def paired_effects(scores: pd.DataFrame) -> pd.DataFrame:
    """Per dataset and ordered pair of methods, the paired differences over their shared splits.

    Parameters
    ----------
    scores : DataFrame
        The long scores table (module docstring).

    Returns
    -------
    DataFrame
        One row per (dataset, method_a, method_b), a != b, both scored on the dataset:
        ``dataset``, ``method_a``, ``method_b``, ``n_splits`` (splits where both have a score),
        ``difference`` (mean over them of A's score minus B's), ``sd`` (their standard
        deviation, ddof 1), ``se`` (``sd / sqrt(n_splits)``), ``smd`` (``difference / sd``, the
        standardized difference; 0 when both are 0, signed inf for a constant non-zero
        difference). ``sd``, ``se`` and ``smd`` are NaN below 2 shared splits, ``difference``
        below 1.
    """
    df = _clean_scores(scores)
    methods = np.array(sorted(df["method"].unique(), key=str), dtype=object)
    k = len(methods)
    a_idx, b_idx = np.nonzero(~np.eye(k, dtype=bool))
    parts = []
    for dataset, group in df.groupby("dataset", sort=True):
        x = group.pivot(index="split", columns="method", values="score").reindex(columns=methods)
        x = x.to_numpy(dtype=float)  # (n_splits, k)
        both = np.isfinite(x)[:, :, None] & np.isfinite(x)[:, None, :]  # (n_splits, k, k)
        n = both.sum(axis=0)  # (k, k)
        diff = np.where(both, x[:, :, None] - x[:, None, :], 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = diff.sum(axis=0) / n
            sd = np.sqrt(np.where(both, (diff - mean) ** 2, 0.0).sum(axis=0) / (n - 1))
            sd[n < 2] = np.nan
            smd = np.where(sd > 0, mean / sd, np.where(mean == 0, 0.0, np.copysign(np.inf, mean)))
            smd[n < 2] = np.nan
            se = sd / np.sqrt(n)
        present = np.isfinite(x).any(axis=0)  # (k,)
        rows = present[a_idx] & present[b_idx]
        i, j = a_idx[rows], b_idx[rows]
        parts.append(pd.DataFrame({"dataset": dataset, "method_a": methods[i], "method_b": methods[j],
                                   "n_splits": n[i, j], "difference": mean[i, j], "sd": sd[i, j],
                                   "se": se[i, j], "smd": smd[i, j]}))
    return pd.concat(parts, ignore_index=True)


META_COLUMNS: tuple[str, ...] = ("method_a", "method_b", "n_datasets", "n_datasets_left_out", "effect", "se",
                                 "ci95_low", "ci95_high", "z", "p_value", "tau2", "i2", "q", "smd")


def meta_analysis(scores: pd.DataFrame) -> pd.DataFrame:
    """Random-effects meta-analysis across datasets of every ordered pair's paired difference.

    For a pair (A, B), each dataset where both share at least 2 splits gives its mean paired
    difference ``d_j`` (A minus B) with variance ``v_j = se_j^2`` (at least :data:`MIN_VARIANCE`)
    from :func:`paired_effects`. DerSimonian and Laird's estimate of the between-dataset variance
    is ``tau2 = max(0, (Q - (m - 1)) / (sum w - sum w^2 / sum w))`` with ``w = 1 / v``, ``m``
    datasets and Cochran's ``Q = sum w (d - d_fixed)^2``; the pooled effect is the weighted mean
    of ``d_j`` with weights ``1 / (v_j + tau2)``, its standard error ``1 / sqrt(sum weights)``,
    its 95% interval and two-sided p-value from the normal distribution. ``I2 = (Q - (m - 1)) / Q``
    (at least 0) is the share of the spread due to differences between datasets. With one dataset
    the result is that dataset's ``d``, ``se`` and normal interval. ``smd`` pools the per-dataset
    standardized differences with weights ``sqrt(n_splits)``, as MOABB combines its effects.

    Parameters
    ----------
    scores : DataFrame
        The long scores table (module docstring).

    Returns
    -------
    DataFrame
        One row per ordered pair of methods, a != b (A minus B; swapping them negates ``effect``,
        ``ci95``, ``z`` and ``smd``): ``method_a``, ``method_b``, ``n_datasets`` (datasets
        pooled), ``n_datasets_left_out`` (datasets where both have a score but share fewer than
        2 splits), ``effect``, ``se``, ``ci95_low``, ``ci95_high`` (score differences, fractions),
        ``z``, ``p_value``, ``tau2``, ``i2``, ``q`` (NaN for ``i2`` and ``q`` with one dataset),
        ``smd``. A pair with no dataset to pool has NaN statistics.
    """
    effects = paired_effects(scores)
    if effects.empty:
        return pd.DataFrame(columns=list(META_COLUMNS))
    methods = sorted(pd.unique(pd.concat([effects["method_a"], effects["method_b"]])), key=str)
    pairs = pd.MultiIndex.from_tuples([(a, b) for a in methods for b in methods if a != b],
                                      names=["method_a", "method_b"])
    left_out = (effects[effects["n_splits"] < 2].groupby(["method_a", "method_b"]).size()
                .reindex(pairs, fill_value=0).to_numpy())
    used = effects[effects["n_splits"] >= 2]
    code = pairs.get_indexer(pd.MultiIndex.from_frame(used[["method_a", "method_b"]]))
    p = len(pairs)
    d, n_splits = used["difference"].to_numpy(), used["n_splits"].to_numpy(dtype=float)
    v = np.maximum(used["se"].to_numpy() ** 2, MIN_VARIANCE)
    m = np.bincount(code, minlength=p)  # datasets pooled per pair, (p,)

    def total(values: np.ndarray) -> np.ndarray:
        return np.bincount(code, weights=values, minlength=p)

    with np.errstate(invalid="ignore", divide="ignore"):
        w = 1 / v
        fixed = total(w * d) / total(w)
        q = total(w * (d - fixed[code]) ** 2)
        c = total(w) - total(w**2) / total(w)
        tau2 = np.where(m > 1, np.maximum(0.0, (q - (m - 1)) / c), 0.0)
        w_star = 1 / (v + tau2[code])
        effect = total(w_star * d) / total(w_star)
        se = 1 / np.sqrt(total(w_star))
        z = effect / se
        i2 = np.where(q > 0, np.maximum(0.0, (q - (m - 1)) / q), 0.0)
        sqrt_n = np.sqrt(n_splits)
        smd = total(sqrt_n * used["smd"].to_numpy()) / total(sqrt_n)
    none = m == 0
    se = np.where(none, np.nan, se)
    half = float(stats.norm.ppf(0.975)) * se
    out = pd.DataFrame({"method_a": pairs.get_level_values(0), "method_b": pairs.get_level_values(1),
                        "n_datasets": m, "n_datasets_left_out": left_out, "effect": effect, "se": se,
                        "ci95_low": effect - half, "ci95_high": effect + half, "z": z,
                        "p_value": 2 * stats.norm.sf(np.abs(z)), "tau2": np.where(none, np.nan, tau2),
                        "i2": np.where(m > 1, i2, np.nan), "q": np.where(m > 1, q, np.nan), "smd": smd})
    return out[list(META_COLUMNS)]
