"""The benchmark's tables and figures across datasets, and its lines on the terminal.

:func:`summarise` turns the collected scores (:func:`~tzsl.studies.benchmark.runner.collect_scores`)
into the per-dataset table (mean per-class accuracy with its 95% interval, chance, gain over chance,
trial accuracy and GZSL's harmonic mean beside), the mean ranks across datasets, the Friedman test
with Nemenyi's critical difference and its diagram, and the meta-analysed paired effects with their
forest plot against the generic default (:data:`tzsl.models.choices.DEFAULT_METHOD`), all written
into the benchmark's results folder.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd

from tzsl.exceptions import TzslError, first_line
from tzsl.studies.benchmark.figures import critical_difference_diagram, meta_analysis_figure
from tzsl.studies.benchmark.statistics import (
    critical_difference,
    friedman_test,
    mean_ranks,
    meta_analysis,
    per_dataset_table,
)

__all__ = ["BENCHMARK_FILES", "complete_splits", "long_scores", "ranked_methods", "reference_method", "summarise",
           "terminal_lines"]

#: What a benchmark writes at the top of its folder (checked free before any fit).
BENCHMARK_FILES = ("scores.csv", "datasets.csv", "gzsl.csv", "ranks.csv", "friedman.csv", "meta_analysis.csv",
                   "critical_difference.png", "meta_analysis.png", "manifest.json")
#: The primary metric of the benchmark (a column of scores.csv).
PRIMARY = "per_class_accuracy"
#: Significance level of the Friedman test and the critical difference.
ALPHA = 0.05
#: Methods shown on the terminal's rank line (the table has them all).
SHOWN_RANKS = 5


def long_scores(scores: pd.DataFrame) -> pd.DataFrame:
    """The primary metric of collected scores as the statistics' long table: ``dataset``, ``method``, ``split``,
    ``score``, ``chance`` (:mod:`tzsl.studies.benchmark.statistics`)."""
    return scores.rename(columns={PRIMARY: "score"})[["dataset", "method", "split", "score", "chance"]]


def reference_method(methods: Iterable[str], ranks: pd.DataFrame) -> str:
    """The method others are compared with: the generic default when it ran, else the best mean rank."""
    from tzsl.models.choices import DEFAULT_METHOD  # noqa: PLC0415

    return DEFAULT_METHOD if DEFAULT_METHOD in set(methods) else str(ranks["method"].iloc[0])


def _dataset_table(scores: pd.DataFrame, gzsl: pd.DataFrame) -> pd.DataFrame:
    """:func:`per_dataset_table` of the primary metric, with mean trial accuracy and GZSL's H beside."""
    table = per_dataset_table(long_scores(scores))
    trial = scores.groupby(["dataset", "method"])["trial_accuracy"].mean().rename("trial_accuracy")
    table = table.merge(trial.reset_index(), on=["dataset", "method"], how="left")
    if not gzsl.empty:
        harmonic = gzsl.groupby(["dataset", "method"])["harmonic"].mean().rename("gzsl_harmonic")
        table = table.merge(harmonic.reset_index(), on=["dataset", "method"], how="left")
    else:
        table["gzsl_harmonic"] = np.nan
    return table.rename(columns={"score": PRIMARY})


def complete_splits(long: pd.DataFrame) -> pd.DataFrame:
    """The rows of the splits on which every method that ran on their dataset has a score.

    Ranks, the Friedman test and the paired effects compare methods on the same splits: a split where
    one method failed (NaN) is left out for all of them on that dataset (complete cases). A method with no
    score on any split of a dataset (one that cannot run there, e.g. ``detector="auto"`` with too few
    training classes for its pseudo-unseen folds) did not run on it: it leaves no split out there, and
    :func:`ranked_methods` leaves it out of the ranks across datasets.

    Parameters
    ----------
    long : DataFrame
        Columns ``dataset``, ``method``, ``split``, ``score`` (NaN: a failed fit), ...

    Returns
    -------
    DataFrame
        The same columns, only complete splits, no NaN score.
    """
    scored = long["score"].notna()
    ran = scored.groupby([long["dataset"], long["method"]]).transform("any")
    long, scored = long[ran], scored[ran]
    methods = long.groupby("dataset")["method"].transform("nunique")
    present = scored.groupby([long["dataset"], long["split"]]).transform("sum")
    return long[present.eq(methods) & scored].reset_index(drop=True)


def ranked_methods(long: pd.DataFrame) -> tuple[list[str], dict[str, list[str]]]:
    """The methods scored on every dataset of ``long`` (a Friedman block must be complete), and the others.

    Returns
    -------
    ranked : list of str
    unranked : dict
        ``{method: [datasets it has no score on]}``.
    """
    datasets = sorted(long["dataset"].unique())
    scored = long[long["score"].notna()].groupby("method")["dataset"].agg(set)
    methods = sorted(long["method"].unique())
    unranked = {m: [d for d in datasets if d not in scored.get(m, set())] for m in methods}
    return [m for m in methods if not unranked[m]], {m: ds for m, ds in unranked.items() if ds}


def summarise(scores: pd.DataFrame, gzsl: pd.DataFrame, results: Any) -> dict[str, Any]:
    """Write the benchmark's tables and figures into ``results`` (a :class:`~tzsl.studies.outputs.ResultsDir`).

    Parameters
    ----------
    scores : DataFrame
        :func:`~tzsl.studies.benchmark.runner.collect_scores` (one row per dataset, method, split).
    gzsl : DataFrame
        :func:`~tzsl.studies.benchmark.runner.collect_gzsl`.
    results : ResultsDir

    Returns
    -------
    dict
        ``datasets``, ``ranks``, ``friedman`` (DataFrames; ``friedman`` holds one row, or the reason
        the test could not run), ``meta``, ``reference`` (the method the forest plot compares with) and
        ``unranked`` (:func:`ranked_methods`: the methods with no score on some dataset, left out of the
        ranks and the test). The per-dataset table reads every score; the ranks, the test and the paired
        effects the splits every method completed (:func:`complete_splits`).
    """
    results.write_csv("scores.csv", scores)
    results.write_csv("gzsl.csv", gzsl)
    datasets = _dataset_table(scores, gzsl)
    results.write_csv("datasets.csv", datasets)
    long = complete_splits(long_scores(scores))
    ranked, unranked = ranked_methods(long)
    ranks = mean_ranks(long[long["method"].isin(ranked)])
    results.write_csv("ranks.csv", ranks)
    n_datasets = int(ranks["n_datasets"].iloc[0]) if len(ranks) else 0
    try:
        test = friedman_test(ranks)
        cd = critical_difference(test.n_methods, test.n_datasets, ALPHA)
        friedman = pd.DataFrame([{**test._asdict(), "alpha": ALPHA, "critical_difference": cd, "note": ""}])
    except TzslError as exc:  # one dataset: ranks exist, a test across datasets does not
        cd = float("nan")
        friedman = pd.DataFrame([{"n_datasets": n_datasets, "n_methods": len(ranks), "alpha": ALPHA,
                                  "critical_difference": cd, "note": first_line(exc)}])
    results.write_csv("friedman.csv", friedman)
    title = (f"mean rank of {PRIMARY.replace('_', ' ')} over {n_datasets} dataset(s); "
             f"CD = {cd:.2f} (Nemenyi, alpha {ALPHA})" if np.isfinite(cd) else
             f"mean rank over {n_datasets} dataset")
    results.write_file("critical_difference.png",
                       lambda path: critical_difference_diagram(ranks, cd if np.isfinite(cd) else 0.0, path,
                                                                title=title))
    meta = meta_analysis(long)
    results.write_csv("meta_analysis.csv", meta)
    reference = reference_method(long["method"], ranks)
    results.write_file("meta_analysis.png", lambda path: meta_analysis_figure(
        meta, reference, path, title=f"paired difference from {reference}, pooled over datasets (95% CI)"))
    return {"datasets": datasets, "ranks": ranks, "friedman": friedman, "meta": meta, "reference": reference,
            "unranked": unranked}


def terminal_lines(summary: dict[str, Any]) -> list[str]:
    """A screenful: per dataset its best method beside the reference and chance; the top mean ranks; the test."""
    datasets, ranks, friedman = summary["datasets"], summary["ranks"], summary["friedman"].iloc[0]
    reference = summary["reference"]
    lines = [f"per-class mean accuracy (95% interval over splits); reference {reference}:"]
    for name, table in datasets.groupby("dataset", sort=False):
        best = table.loc[table[PRIMARY].idxmax()]
        ref = table[table["method"] == reference]
        shown = (f"  {name}: best {best['method']} {best[PRIMARY]:.3f} "
                 f"[{best['ci95_low']:.3f}, {best['ci95_high']:.3f}]")
        if len(ref):
            r = ref.iloc[0]
            shown += f"; {reference} {r[PRIMARY]:.3f} [{r['ci95_low']:.3f}, {r['ci95_high']:.3f}]"
        lines.append(f"{shown}; chance {best['chance']:.3f} ({int(best['n_splits'])} splits)")
    top = ", ".join(f"{r.method} {r.mean_rank:.2f}" for r in ranks.head(SHOWN_RANKS).itertuples())
    lines.append(f"mean rank over {int(friedman['n_datasets'])} dataset(s), best first: {top}")
    if summary.get("unranked"):
        lines.append("not ranked, no score on some dataset (manifest): " + ", ".join(summary["unranked"]))
    if friedman["note"]:
        lines.append(f"note: no Friedman test: {friedman['note']}")
    else:
        lines.append(f"Friedman chi2 {friedman['chi2']:.2f} (p {friedman['chi2_pvalue']:.3g}), Iman-Davenport F "
                     f"{friedman['f']:.2f} (p {friedman['f_pvalue']:.3g}); critical difference "
                     f"{friedman['critical_difference']:.2f} ranks (Nemenyi, {ALPHA})")
    return lines
