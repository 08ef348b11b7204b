"""Defaults chosen across datasets: leave one dataset out, and the regret against each dataset's hindsight best.

A default (the generic study's method, its DAP detector) is inherited by every user on every dataset,
so it is chosen across datasets, on selection splits, and judged on datasets it did not see:

* **the rule**, fixed before any result: the method with the best mean rank of per-class mean
  accuracy over the datasets' *selection* splits (ties: the higher mean score, then the name), among
  the benchmark's methods (``default``) or among its DAP rows only (``detector``);
* **leave one dataset out**: for each dataset, the rule applied to the *other* datasets' selection
  scores; the method chosen is scored on the left-out dataset's *confirmation* splits, beside that
  dataset's hindsight best (the best method on those same confirmation splits, known only
  afterwards): the difference is the **regret**;
* beside both, the per-dataset choice made on a user's training objects alone: DAP with
  ``detector="auto"`` (pseudo-unseen CV over detector families), and the shipped default;
* the least mean regret any single method reaches, picked in hindsight on the confirmation splits
  (:func:`hindsight_single_method`): no default, however chosen, does better on these splits;
* and the rule applied to the left-out dataset's *own* selection splits (``own``): a choice made on
  that dataset's data, whose regret is what is left when datasets need not agree, so beside a
  default's regret it tells how much of it is the datasets disagreeing and how much the noise of
  the scores.

:func:`leave_one_dataset_out` makes the table (``defaults.csv`` of ``tzsl benchmark --defaults``);
:func:`choose` applies the rule to every dataset (the choice the shipped default should equal).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from tzsl.exceptions import ConfigError
from tzsl.studies.benchmark.statistics import mean_ranks
from tzsl.studies.benchmark.summary import ranked_methods

__all__ = ["AUTO_METHOD", "DEFAULTS_FILE", "EVERY_DATASET", "HINDSIGHT", "choose", "choose_on_every_dataset",
           "hindsight_single_method", "is_dap_row", "leave_one_dataset_out", "left_out_rows", "mean_regrets"]

#: The benchmark row of the per-dataset detector choice made on training objects (``dap`` with ``detector="auto"``).
AUTO_METHOD = "dap-avg-auto"
#: The leave-one-dataset-out table a benchmark run with ``--defaults`` writes, and the choice made on every dataset.
DEFAULTS_FILE = "defaults.csv"
#: ``dataset`` of the rows of the choice made on every dataset's selection splits (what a default should be).
EVERY_DATASET = "(every dataset)"
#: The ``dataset`` of the rows of :func:`hindsight_single_method` in ``defaults.csv``.
HINDSIGHT = "(one method, in hindsight)"


def is_dap_row(method: str) -> bool:
    """Whether a benchmark row is a DAP with uniform prior and average fusion (one per detector)."""
    return method == "dap-avg" or method.startswith("dap-avg-")


def choose(select: pd.DataFrame, candidates: Sequence[str] | None = None) -> str:
    """The rule: the best mean rank over the datasets of ``select`` (ties: higher mean score, then name), among the
    candidates with a score on every one of them.

    Parameters
    ----------
    select : DataFrame
        Long scores (``dataset``, ``method``, ``split``, ``score``) of selection splits; complete
        splits only (:func:`tzsl.studies.benchmark.summary.complete_splits`).
    candidates : sequence of str, optional
        The methods the choice is among (default: every method of ``select``).

    Raises
    ------
    ConfigError
        No candidate has a score.
    """
    scores = select if candidates is None else select[select["method"].isin(list(candidates))]
    ranked, _ = ranked_methods(scores)  # a default must run on every dataset it was chosen on
    scores = scores[scores["method"].isin(ranked)]
    if scores["score"].notna().sum() == 0:
        raise ConfigError("no selection score to choose a default on (no candidate has scores on every dataset)")
    ranks = mean_ranks(scores)
    best = ranks.sort_values(["mean_rank", "mean_score", "method"], ascending=[True, False, True])
    return str(best["method"].iloc[0])


def _means(confirm: pd.DataFrame) -> pd.DataFrame:
    return confirm.groupby(["dataset", "method"])["score"].mean().unstack("method")


def leave_one_dataset_out(select: pd.DataFrame, confirm: pd.DataFrame, default_method: str) -> pd.DataFrame:
    """The defaults chosen with each dataset left out, scored on it, beside its hindsight best.

    Parameters
    ----------
    select, confirm : DataFrame
        Long scores (``dataset``, ``method``, ``split``, ``score``) of the selection and confirmation
        splits (complete splits only); the datasets of ``confirm`` are each left out in turn.
    default_method : str
        The shipped default (:data:`tzsl.models.choices.DEFAULT_METHOD`), shown beside.

    Returns
    -------
    DataFrame
        One row per (dataset, choice), choice ``default`` (among every method) or ``detector`` (among
        the DAP rows): ``chosen`` (on the other datasets' selection splits), ``seen`` (those datasets),
        ``chosen_score`` (its mean per-class accuracy on the left-out dataset's confirmation splits),
        ``n_splits`` (the left-out dataset's complete confirmation splits, those every method ran on: every
        score of the row is a mean over them), ``best`` and ``best_score`` (the hindsight best there, among
        the same candidates: every method but :data:`AUTO_METHOD`, which is compared with a default, not a
        candidate for one), ``regret`` (best minus chosen, >= 0), the same score and regret for
        ``auto`` (:data:`AUTO_METHOD`) and ``shipped`` (``default_method``), and ``own_chosen``,
        ``own_score`` and ``own_regret`` for the rule applied to the left-out dataset's own selection
        splits; NaN where that method has no score (or the dataset no selection scores).
    """
    means = _means(confirm)
    rows = []
    for dataset in means.index:
        others = select[select["dataset"] != dataset]
        if others["dataset"].nunique() == 0:
            raise ConfigError(f"leave-one-dataset-out needs selection scores of a dataset other than {dataset!r}")
        seen = ", ".join(sorted(others["dataset"].unique()))
        n_splits = confirm.loc[confirm["dataset"] == dataset, "split"].nunique()
        on = means.loc[dataset].dropna()
        eligible = [m for m in on.index if m != AUTO_METHOD]  # auto is compared with a default, not one
        for choice, candidates in (("default", eligible), ("detector", [m for m in eligible if is_dap_row(m)])):
            if not candidates:
                continue
            chosen = choose(others, candidates)
            best = str(on[candidates].idxmax())
            row = {"dataset": dataset, "choice": choice, "chosen": chosen, "seen": seen,
                   "n_splits": n_splits,
                   "chosen_score": on.get(chosen, np.nan), "best": best, "best_score": on[best]}
            row["regret"] = row["best_score"] - row["chosen_score"]
            for label, method in (("auto", AUTO_METHOD), ("shipped", default_method)):
                row[f"{label}_score"] = on.get(method, np.nan)
                row[f"{label}_regret"] = row["best_score"] - row[f"{label}_score"]
            own = select[(select["dataset"] == dataset) & select["method"].isin(candidates)]
            row["own_chosen"] = choose(own) if own["score"].notna().any() else None
            row["own_score"] = on.get(row["own_chosen"], np.nan) if row["own_chosen"] else np.nan
            row["own_regret"] = row["best_score"] - row["own_score"]
            rows.append(row)
    return pd.DataFrame(rows)


def choose_on_every_dataset(select: pd.DataFrame) -> pd.DataFrame:
    """The rule applied to every dataset's selection splits: the default (and detector) the package should ship.

    Returns
    -------
    DataFrame
        One row per choice (``default``: among every method; ``detector``: among the DAP rows), with
        ``dataset`` :data:`EVERY_DATASET`, ``chosen`` and ``seen`` (the datasets); :func:`leave_one_dataset_out`
        estimates how such a choice fares on a dataset it did not see.
    """
    methods = [m for m in dict.fromkeys(select["method"]) if m != AUTO_METHOD]
    seen = ", ".join(sorted(select["dataset"].unique()))
    choices = (("default", methods), ("detector", [m for m in methods if is_dap_row(m)]))
    return pd.DataFrame([{"dataset": EVERY_DATASET, "choice": choice, "chosen": choose(select, candidates),
                          "seen": seen} for choice, candidates in choices if candidates])


def hindsight_single_method(confirm: pd.DataFrame) -> pd.DataFrame:
    """The single method with the least mean regret over the datasets, picked on the confirmation splits.

    What no default (one method for every dataset), however it is chosen, can beat on these splits: a
    bound on the leave-one-dataset-out regret, not a choice (it is made on the splits it is scored on).

    Parameters
    ----------
    confirm : DataFrame
        Long scores of the confirmation splits (complete splits only), as for :func:`leave_one_dataset_out`.

    Returns
    -------
    DataFrame
        One row per choice (``default``: among every method scored on every dataset but
        :data:`AUTO_METHOD`; ``detector``: among its DAP rows), ``dataset`` :data:`HINDSIGHT`, ``chosen``,
        ``seen`` (the datasets) and ``regret`` (its mean over the datasets of each dataset's best among
        the same candidates minus the method's score).
    """
    means = _means(confirm)
    means = means.loc[:, means.notna().all() & (means.columns != AUTO_METHOD)]
    seen = ", ".join(sorted(means.index))
    rows = []
    for choice, candidates in (("default", list(means.columns)),
                               ("detector", [m for m in means.columns if is_dap_row(m)])):
        if not candidates:
            continue
        part = means[candidates]
        regret = part.max(axis=1).to_numpy()[:, None] - part
        mean_regret = regret.mean().sort_index().sort_values(kind="stable")
        rows.append({"dataset": HINDSIGHT, "choice": choice, "chosen": str(mean_regret.index[0]), "seen": seen,
                     "regret": float(mean_regret.iloc[0])})
    return pd.DataFrame(rows)


def left_out_rows(defaults: pd.DataFrame) -> pd.DataFrame:
    """The leave-one-dataset-out rows of a ``defaults.csv`` table (not the :data:`EVERY_DATASET` or
    :data:`HINDSIGHT` rows)."""
    return defaults[~defaults["dataset"].isin([EVERY_DATASET, HINDSIGHT])]


def mean_regrets(defaults: pd.DataFrame) -> pd.DataFrame:
    """The mean regrets of a ``defaults.csv`` table, per choice, as the terminal and the leaderboard give them.

    Returns
    -------
    DataFrame
        Indexed by ``choice`` (in the table's order): ``chosen`` (the methods chosen with a dataset left
        out, sorted, comma-joined), ``n_datasets``, the mean ``regret``, ``auto_regret`` (over the
        ``n_auto`` datasets where ``auto`` ran), ``shipped_regret``, ``own_regret``, and the
        :data:`HINDSIGHT` bound: ``bound_method`` and ``bound_regret`` (None / NaN without that row).
    """
    bound = defaults[defaults["dataset"] == HINDSIGHT].set_index("choice")
    rows = [{"choice": choice, "chosen": ", ".join(sorted(set(part["chosen"]))), "n_datasets": len(part),
             "regret": part["regret"].mean(), "auto_regret": part["auto_regret"].mean(),
             "n_auto": int(part["auto_regret"].notna().sum()), "shipped_regret": part["shipped_regret"].mean(),
             "own_regret": part["own_regret"].mean(),
             "bound_method": bound["chosen"].get(choice), "bound_regret": bound["regret"].get(choice, np.nan)}
            for choice, part in left_out_rows(defaults).groupby("choice", sort=False)]
    return pd.DataFrame(rows).set_index("choice")
