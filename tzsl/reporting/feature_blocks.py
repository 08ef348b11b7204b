"""The generated block of the features benchmark (``experiments/benchmarks/features_axis.py``).

:func:`features_axis_block` makes the ``features-axis-benchmark`` block of
``experiments/benchmarks/README.md`` (and of the features section of the user guide) from every
``features_axis_summary_*.csv`` under a results folder: per purpose, dataset and feature set the trial
accuracy with its interval and the paired difference to the per-channel statistics, then the rule's
verdict as the selection rows record it (``gain``).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from tzsl.reporting.benchmark_blocks import runs_by_purpose
from tzsl.reporting.markdown_cells import number, ours, signed

__all__ = ["FEATURES_AXIS_FILES", "features_axis_block"]

#: The summary CSVs of ``experiments/benchmarks/features_axis.py`` (one per purpose and seed).
FEATURES_AXIS_FILES = "features_axis_summary_*.csv"


def features_axis_block(results: str | Path) -> str:
    """Per-channel statistics against ROCKET on the raw-signal datasets (``features_axis.py``).

    Parameters
    ----------
    results : path-like
        A folder holding the benchmark's summaries (searched recursively).

    Returns
    -------
    str
        Markdown: one table row per purpose, seed, dataset and feature set (accuracy [95% interval],
        difference to ``statistics`` [95% interval], feature count, CPU seconds), then the rule's verdict.

    Raises
    ------
    MissingResults
        No such file under ``results``.
    """
    table = runs_by_purpose(results, FEATURES_AXIS_FILES, "features_axis.py --purpose select")
    method = ", ".join(f"`{m}`" for m in dict.fromkeys(table["method"]))
    lines = [f"Generated from `features_axis_summary_*.csv` by `make numbers`: trial accuracy [95% interval] of the "
             f"generic default method ({method}) on each dataset's random splits with each feature set, the "
             "paired difference to `statistics` on the same trials [95% interval], the number of features (all "
             "sensors) and the CPU seconds of the features and of the fits (summed over the splits).",
             "", "| purpose | seed | dataset | splits (trials) | chance | feature set | features | accuracy | "
             "minus `statistics` | CPU features (s) | CPU fits (s) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        diff = "-" if pd.isna(r["difference"]) else signed(r["difference"], r["difference_ci95_low"],
                                                            r["difference_ci95_high"])
        lines.append(f"| {r['purpose']} | {int(r['seed'])} | {r['dataset']} | {int(r['n_splits'])} "
                     f"({int(r['n_trials'])}) | {number(r['chance'])} | `{r['feature_set']}` | "
                     f"{int(r['n_features'])} | {ours(r, 'accuracy')} | {diff} | {float(r['features_cpu_s']):.1f} | "
                     f"{float(r['fit_cpu_s']):.1f} |")
    select = table[(table["purpose"] == "select") & (table["feature_set"] != "statistics")]
    if len(select):
        gains = select.groupby("feature_set", sort=False)["gain"].agg(lambda g: bool(g.astype(bool).all()))
        said = "; ".join(f"`{name}`: {'holds' if held else 'does not hold'}" for name, held in gains.items())
        chosen = [name for name, held in gains.items() if held]
        lines += ["", "The rule, fixed before measuring: a candidate becomes the default of signal datasets only if "
                      "its paired gain over `statistics` has a 95% interval above 0 on the selection splits of every "
                      f"dataset ({said}): "
                      + (f"`{chosen[0]}` becomes the default." if chosen
                         else "the per-channel statistics stay the default; `rocket` ships as a feature set a "
                              "study can name.")]
    return "\n".join(lines)
