"""The leaderboard block of the docs: the benchmark's tables as Markdown (``make numbers``, never typed).

:func:`leaderboard_block` reads a ``tzsl benchmark`` folder (``datasets.csv``, ``ranks.csv``,
``friedman.csv``, ``meta_analysis.csv``, ``manifest.json``, and ``defaults.csv`` when the defaults
were chosen across datasets) and writes: per method and dataset the per-class mean accuracy with its
95% interval over the standard confirmation splits, chance beside; the mean rank and the mean gain
over chance; the Friedman test and the critical difference; and each method's difference from the
generic default pooled across datasets.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from tzsl.models.choices import DEFAULT_METHOD
from tzsl.reporting.benchmark_blocks import MissingResults
from tzsl.reporting.markdown_cells import number, signed
from tzsl.studies.benchmark.defaults import DEFAULTS_FILE, EVERY_DATASET, left_out_rows, mean_regrets
from tzsl.studies.benchmark.summary import reference_method

__all__ = ["leaderboard_block"]

#: The files of a benchmark folder the block reads.
LEADERBOARD_FILES = ("datasets.csv", "ranks.csv", "friedman.csv", "meta_analysis.csv")


def _read(root: Path, name: str) -> pd.DataFrame:
    path = root / name
    if not path.is_file():
        raise MissingResults(f"{root}: no {name}; run make benchmark or make benchmark-defaults "
                             f"(tzsl benchmark --out {root}) first")
    return pd.read_csv(path)


def _cell(row: pd.Series) -> str:
    return (f"{number(row['per_class_accuracy'])} [{number(row['ci95_low'])}, {number(row['ci95_high'])}]"
            if not pd.isna(row["ci95_low"]) else number(row["per_class_accuracy"]))


def leaderboard_block(results: str | Path) -> str:
    """The leaderboard's Markdown from the benchmark folder ``results``.

    Raises
    ------
    MissingResults
        A file of :data:`LEADERBOARD_FILES` is missing (the block is left as it is).
    """
    root = Path(results)
    datasets, ranks, friedman, meta = (_read(root, name) for name in LEADERBOARD_FILES)
    manifest = json.loads((root / "manifest.json").read_text()) if (root / "manifest.json").is_file() else {}
    config = manifest.get("config", {})
    if config.get("max_splits"):
        raise MissingResults(f"{root}: a quick look (--max-splits {config['max_splits']}), not the benchmark")
    names = list(dict.fromkeys(datasets["dataset"]))
    chance = datasets.groupby("dataset")["chance"].first()
    splits = datasets.groupby("dataset")["n_splits"].max()
    command = "tzsl benchmark --defaults" if config.get("defaults_from") else "tzsl benchmark"
    lines = [f"Generated from `{root.name}/` (`{command}`, standard splits "
             f"{config.get('splits_version', 'v1')}, {config.get('purpose', 'confirm')} splits) by `make numbers`: "
             "per-class mean accuracy over each dataset's splits [95% interval over splits]; a method's mean rank "
             "and mean gain over chance are over the datasets every method completed (lower rank is better).", "",
             "| method | " + " | ".join(f"{n} ({int(splits[n])} splits)" for n in names)
             + " | mean rank | mean gain over chance |",
             "|---" * (len(names) + 3) + "|",
             "| chance | " + " | ".join(number(chance[n]) for n in names) + " | | |"]
    cells = datasets.set_index(["method", "dataset"])
    for r in ranks.itertuples():
        row = [(_cell(cells.loc[(r.method, n)]) if (r.method, n) in cells.index else "-") for n in names]
        lines.append(f"| `{r.method}` | " + " | ".join(row) + f" | {r.mean_rank:.2f} | "
                     f"{number(r.mean_gain_over_chance)} |")
    f = friedman.iloc[0]
    lines.append("")
    if isinstance(f.get("note"), str) and f["note"]:
        lines.append(f"No Friedman test: {f['note']}.")
    else:
        lines.append(f"Friedman test over {int(f['n_datasets'])} datasets and {int(f['n_methods'])} methods: "
                     f"chi2 = {float(f['chi2']):.2f} (p = {float(f['chi2_pvalue']):.3g}), Iman-Davenport F = "
                     f"{float(f['f']):.2f} (p = {float(f['f_pvalue']):.3g}); Nemenyi critical difference "
                     f"{float(f['critical_difference']):.2f} ranks at alpha {float(f['alpha']):g} (Demsar 2006): "
                     "two methods whose mean ranks differ by less do not differ significantly.")
    reference = reference_method(meta["method_b"], ranks)
    pooled = meta[meta["method_b"] == reference].set_index("method_a")
    lines += ["", f"Each method minus `{reference}` (the generic default), paired on shared splits and pooled over "
                  "datasets by a random-effects meta-analysis (DerSimonian-Laird) [95% interval]:", "",
              "| method | difference | datasets | I2 |", "|---|---|---|---|"]
    for r in ranks.itertuples():
        if r.method == reference or r.method not in pooled.index:
            continue
        m = pooled.loc[r.method]
        lines.append(f"| `{r.method}` | {signed(m['effect'], m['ci95_low'], m['ci95_high'])} | "
                     f"{int(m['n_datasets'])} | {number(m['i2'], 2)} |")
    if (root / DEFAULTS_FILE).is_file():
        lines += _defaults_lines(pd.read_csv(root / DEFAULTS_FILE), ranks, friedman.iloc[0], pooled)
    return "\n".join(lines)


def _defaults_lines(defaults: pd.DataFrame, ranks: pd.DataFrame, friedman: pd.Series,
                    pooled: pd.DataFrame) -> list[str]:
    """The defaults chosen across datasets (``defaults.csv``): leave one dataset out, the regret, ``auto`` beside;
    ``pooled``: each method minus the shipped default, pooled over datasets (rows by ``method_a``)."""
    every = defaults[defaults["dataset"] == EVERY_DATASET].set_index("choice")
    lodo = left_out_rows(defaults)
    lines = ["", "Defaults chosen across datasets (best mean rank on the selection splits): with each dataset left "
                 "out, the choice made on the others, scored on the left-out dataset's confirmation splits beside "
                 f"its hindsight best there (the regret), DAP with `detector = \"auto\"` (chosen on each split's "
                 f"training objects), the shipped default `{DEFAULT_METHOD}`, and the rule applied to the left-out "
                 "dataset's own selection splits (`own`: a choice made on that dataset's data, the regret left "
                 "when datasets need not agree). Every score of a row is a mean over "
                 "the same splits, those of the left-out dataset on which every method ran (complete splits, as in "
                 f"the ranks); the hindsight best is the highest of {len(ranks)} noisy means, so on a dataset of "
                 "few splits the regret is large even for a sound choice:", "",
             "| left out (complete splits) | choice | chosen on the others | score | hindsight best | regret | "
             "`auto` (regret) | shipped (regret) | `own` (regret) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in lodo.itertuples():
        lines.append(f"| {r.dataset} ({int(r.n_splits)}) | {r.choice} | `{r.chosen}` | {number(r.chosen_score)} | "
                     f"`{r.best}` {number(r.best_score)} | {number(r.regret)} | {number(r.auto_score)} "
                     f"({number(r.auto_regret)}) | {number(r.shipped_score)} ({number(r.shipped_regret)}) | "
                     f"{_own(r)} |")
    for choice, m in mean_regrets(defaults).iterrows():
        lines.append("")
        lines.append(f"Mean regret of the {choice} chosen with each dataset left out: {number(m['regret'])} "
                     f"over {m['n_datasets']} datasets (the goal: at most 0.02); `auto` {number(m['auto_regret'])} "
                     f"over {m['n_auto']}, the shipped default {number(m['shipped_regret'])}, `own` "
                     f"{number(m['own_regret'])}."
                     + (f" The least mean regret any one method reaches on these splits, picked in hindsight: "
                        f"{number(m['bound_regret'])} (`{m['bound_method']}`); no {choice} chosen once for every "
                        "dataset does better." if m["bound_method"] is not None else ""))
    if "default" in every.index:
        chosen = str(every.loc["default", "chosen"])
        lines.append("")
        choices = ", ".join(f"{c} `{name}`" for c, name in every["chosen"].items())
        lines.append(f"Chosen on every dataset's selection splits: {choices} (shipped: `{DEFAULT_METHOD}`)."
                     + _beaten(chosen, ranks, friedman) + _successor(chosen, pooled))
    return lines


def _own(row) -> str:
    """The ``own`` cell of a leave-one-dataset-out row: the method, its score and regret (``-`` without one)."""
    if not isinstance(row.own_chosen, str):
        return "-"
    return f"`{row.own_chosen}` {number(row.own_score)} ({number(row.own_regret)})"


def _successor(chosen: str, pooled: pd.DataFrame) -> str:
    """Whether ``chosen`` replaces the shipped default: its pooled confirmation difference must exclude 0."""
    if chosen == DEFAULT_METHOD:
        return " It is the shipped default."
    if chosen not in pooled.index:
        return f" `{chosen}` has no pooled difference from the shipped default, so the default stays."
    m = pooled.loc[chosen]
    verdict = ("above 0: the shipped default should become it" if m["ci95_low"] > 0 else
               "below 0: the shipped default stays" if m["ci95_high"] < 0 else
               "it includes 0: the shipped default stays")
    return (f" It replaces the shipped default only if its pooled difference from it on these confirmation splits "
            f"has an interval above 0 ({{doc}}`choices`): {signed(m['effect'], m['ci95_low'], m['ci95_high'])}, "
            f"{verdict}.")


def _beaten(method: str, ranks: pd.DataFrame, friedman: pd.Series) -> str:
    """Which methods' mean ranks on these splits beat ``method``'s by more than the critical difference."""
    cd = float(friedman.get("critical_difference", float("nan")))
    by = ranks.set_index("method")["mean_rank"]
    if method not in by.index or pd.isna(cd):
        return ""
    better = [m for m, rank in by.items() if by[method] - rank > cd]
    return (" On the critical-difference diagram no method is significantly better than it." if not better else
            f" Significantly better on the critical-difference diagram: {', '.join(f'`{m}`' for m in better)}.")
