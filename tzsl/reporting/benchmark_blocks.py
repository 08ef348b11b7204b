"""The benchmarks' generated blocks (:data:`tzsl.reporting.readme_results.BLOCKS`), one per benchmark CSV.

Each reads its own CSV under the results folder it is given and raises :class:`MissingResults`
when that CSV is not there; :func:`~tzsl.reporting.readme_results.update_file` then leaves that
block as it is and says so, so one benchmark's numbers are regenerated without the others' results.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pandas as pd

from tzsl.exceptions import ConfigError
from tzsl.reporting.markdown_cells import find_table, number, ours, signed

__all__ = ["BENCHMARK_BLOCKS", "BEST_METHOD_FILE", "ENSEMBLE_CALIBRATION_FILES", "ENSEMBLE_REUSE_FILES",
           "ESZSL_PUBLIC_FILE", "EXACT_SOLVER_FILES", "SELECTION_CRITERION_FILES", "MissingResults",
           "benchmark_accuracy_block",
           "benchmark_table", "best_method_block", "ensemble_calibration_block", "ensemble_reuse_block",
           "eszsl_public_block", "exact_solver_threshold_block", "runs_by_purpose", "search_benchmark_block",
           "selection_criterion_block"]

#: The decision CSV of ``experiments/benchmarks/phac2_best_method.py``.
BEST_METHOD_FILE = "phac2_best_method.csv"
#: The summary CSV of ``experiments/benchmarks/phac2_eszsl_public.py``.
ESZSL_PUBLIC_FILE = "eszsl_public.csv"
#: The summary CSVs of ``experiments/benchmarks/calibration_refit.py --method ensemble`` (one per purpose and seed).
ENSEMBLE_CALIBRATION_FILES = "calibration_refit_summary_phac2_ensemble_*.csv"
#: The summary CSVs of ``experiments/benchmarks/ensemble_reuse.py`` (one per purpose and seed).
ENSEMBLE_REUSE_FILES = "ensemble_reuse_summary_*.csv"
#: The summary CSVs of ``experiments/benchmarks/exact_solver_threshold.py --data phac2`` (one per purpose and seed).
EXACT_SOLVER_FILES = "exact_solver_threshold_phac2_*.csv"
#: The summary CSVs of ``experiments/benchmarks/selection_criterion.py`` (one per purpose and seed).
SELECTION_CRITERION_FILES = "selection_criterion_summary_*.csv"


class MissingResults(ConfigError):
    """A block's CSV is not in the results folder given (the block is left as it is)."""


def benchmark_table(root: Path, name: str, script: str) -> pd.DataFrame:
    """The CSV ``name`` under ``root``; :class:`MissingResults` naming the benchmark ``script`` that writes it."""
    table = find_table(root, name)
    if table is None:
        raise MissingResults(f"{root}: no {name}; run experiments/benchmarks/{script} --out {root}/{name} first")
    return table


def benchmark_accuracy_block(results: str | Path) -> str:
    """The PHAC-2 accuracy benchmark's tables from its ``accuracy.csv`` (and ``grid_summary.csv``).

    Raises
    ------
    MissingResults
        No ``accuracy.csv`` under ``results``.
    """
    root = Path(results)
    table = benchmark_table(root, "accuracy.csv", "phac2_accuracy.py")
    kinds = list(dict.fromkeys(table["kind"]))
    splits = {k: f"{int(table.loc[table['kind'] == k, 'n_splits'].max())} splits{_purpose(table, k)}" for k in kinds}
    lines = ["Generated from `accuracy.csv` by `make numbers`: accuracy [95% interval] and the paired difference "
             "to `dap-avg[paper]` on the same trials [95% interval].", "",
             "| method | " + " | ".join(f"{k} ({splits[k]}) | diff" for k in kinds) + " |",
             "|---|" + "---|---|" * len(kinds)]
    cells = {(r["method"], r["kind"]): r for _, r in table.iterrows()}
    for method in dict.fromkeys(table["method"]):
        row = []
        for kind in kinds:
            r = cells.get((method, kind))
            if r is None:
                row += ["", ""]
                continue
            diff = ("-" if pd.isna(r["diff_ci95_low"]) or r["method"] == "dap-avg[paper]"
                    else signed(r["diff_vs_avgdap"], r["diff_ci95_low"], r["diff_ci95_high"]))
            row += [ours(r, "accuracy", "ci95_low", "ci95_high"), diff]
        lines.append(f"| `{method}` | " + " | ".join(row) + " |")
    grid = find_table(root, "grid_summary.csv")
    if grid is not None:
        gammas = [c for c in grid.columns if c.startswith("gamma")]
        edge = "share_at_edge" in grid.columns  # written since grid="adaptive" (issue 23 item 4)
        lines += ["", "Chosen attribute SVMs per grid (`grid_summary.csv`): mean grouped-CV log-loss"
                  + (", the share of fits whose chosen C or gamma sits at an end of the final grid, the mean "
                     "CPU seconds of a split's fits" if edge else "") + " and the share of fits at each gamma.", "",
                  "| grid | fits | mean CV log-loss | " + ("at a grid edge | CPU s / split | " if edge else "")
                  + " | ".join(gammas) + " |",
                  "|---|---|---|" + ("---|---|" if edge else "") + "---|" * len(gammas)]
        lines += [f"| {r['grid']} | {int(r['n_fits'])} | {number(r['mean_cv_log_loss'])} | "
                  + (f"{100 * float(r['share_at_edge']):.0f}% | {float(r['cpu_seconds_per_split']):.1f} | "
                     if edge else "")
                  + " | ".join(f"{100 * float(r[g]):.0f}%" for g in gammas) + " |" for _, r in grid.iterrows()]
    pairs = find_table(root, "grid_pairs.csv")
    if pairs is not None:
        lines += ["", "Each grid against the previous one on the same trials (`grid_pairs.csv`):", "",
                  "| grid | minus | splits | difference [95% interval] |", "|---|---|---|---|"]
        lines += [f"| `{r['method']}` | `{r['reference']}` | {int(r['n_splits'])} | {float(r['diff']):+.3f} "
                  f"[{float(r['diff_ci95_low']):+.3f}, {float(r['diff_ci95_high']):+.3f}] |"
                  for _, r in pairs.iterrows()]
    return "\n".join(lines)


def _purpose(table: pd.DataFrame, kind: str) -> str:
    """``", confirm, seed 1"``: which random splits the rows of ``kind`` in ``accuracy.csv`` are ("" when it
    does not say)."""
    if "purpose" not in table.columns:
        return ""
    rows = table[table["kind"] == kind]
    purpose, seed = rows["purpose"].dropna().astype(str), rows["seed"].dropna()
    if purpose.empty or not purpose.iloc[0]:
        return ""
    return f", {purpose.iloc[0]}" + (f", seed {int(float(seed.iloc[0]))}" if len(seed) else "")


def search_benchmark_block(results: str | Path) -> str:
    """Full grid vs successive halving (``experiments/benchmarks/phac2_search.py``), one row per seed and grid.

    Reads every ``search_summary_seed<S>_<grid>.csv`` under ``results``.

    Raises
    ------
    MissingResults
        No such file under ``results``.
    """
    root = Path(results)
    found = sorted(root.rglob("search_summary_*.csv")) if root.is_dir() else []
    if not found:
        raise MissingResults(f"{root}: no search_summary_*.csv; run experiments/benchmarks/phac2_search.py --out "
                             f"{root} first")
    table = pd.concat([pd.read_csv(f) for f in found]).sort_values(["grid", "seed"])
    lines = ["Generated from `search_summary_*.csv` by `make numbers`: AVGDAP (uniform prior) trial accuracy "
             "[95% interval] of each search, the paired difference halving minus grid on the same trials "
             "[95% interval], the share of (attribute, sensor) models that chose the grid's configuration, and "
             "the CPU seconds of all attribute fits of each search (one process, one core).", "",
             "| gamma grid | seed | splits | grid | halving | halving - grid | interval holds 0 or is above it | "
             "same choice | CPU grid (s) | CPU halving (s) | CPU ratio |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        diff = signed(r["difference"], r["difference_ci95_low"], r["difference_ci95_high"])
        lines.append(f"| {r['grid']} | {int(r['seed'])} | {int(r['n_splits'])} | "
                     f"{ours(r, 'grid_avgdap', 'grid_ci95_low', 'grid_ci95_high')} | "
                     f"{ours(r, 'halving_avgdap', 'halving_ci95_low', 'halving_ci95_high')} | {diff} | "
                     f"{'yes' if float(r['difference_ci95_high']) >= 0 else 'no'} | "
                     f"{100 * float(r['same_choice_share']):.0f}% | {float(r['grid_cpu_s']):.1f} | "
                     f"{float(r['halving_cpu_s']):.1f} | {float(r['cpu_ratio']):.2f} |")
    return "\n".join(lines)


def best_method_block(results: str | Path) -> str:
    """The best-method decision (``phac2_best_method.csv``): chosen on selection splits, shown on confirmation.

    Raises
    ------
    MissingResults
        No ``phac2_best_method.csv`` under ``results``.
    """
    table = benchmark_table(Path(results), BEST_METHOD_FILE, "phac2_best_method.py")
    lines = [f"Generated from `{BEST_METHOD_FILE}` by `make numbers`: the most accurate method on the selection "
             "splits, then its accuracy [95% interval] and paired difference to the reference [95% interval] on "
             "the confirmation splits (seed "
             + ", ".join(str(int(v)) for v in dict.fromkeys(table["seed"])) + ").", "",
             "| splits | chosen on selection (splits) | selection accuracy | confirmation accuracy "
             "(splits) | minus reference | beats it |", "|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        diff = "-" if pd.isna(r.get("difference")) else (
            f"{signed(r['difference'], r['difference_ci95_low'], r['difference_ci95_high'])} vs `{r['reference']}`")
        lines.append(f"| {r['kind']} | `{r['chosen']}` ({number(r.get('selection_n_splits'), 0)}) | "
                     f"{number(r['selection_accuracy'])} | {ours(r, 'accuracy', 'ci95_low', 'ci95_high')} "
                     f"({number(r.get('confirmation_n_splits'), 0)}) | {diff} | "
                     f"{'yes' if bool(r['beats_reference']) else 'no'} |")
    notes = [f"{r['kind']}: {r['note']}" for _, r in table.iterrows() if isinstance(r.get("note"), str) and r["note"]]
    winners = table[table["beats_reference"].astype(bool)]
    verdict = ("The shipped default stays the reference: no chosen method beats it on the confirmation splits "
               "with an interval excluding 0." if winners.empty else
               "Beats the reference on the confirmation splits with an interval excluding 0: "
               + ", ".join(f"`{r['chosen']}` ({r['kind']})" for _, r in winners.iterrows()) + ".")
    return "\n".join(lines + [""] + [verdict] + ([""] + [f"Note, {n}." for n in notes] if notes else []))


def eszsl_public_block(results: str | Path) -> str:
    """tzsl's ESZSL against the public linear ESZSL (``eszsl_public.csv``), per purpose and method.

    Raises
    ------
    MissingResults
        No ``eszsl_public.csv`` under ``results``.
    """
    table = benchmark_table(Path(results), ESZSL_PUBLIC_FILE, "phac2_eszsl_public.py")
    reference = table.loc[table["diff_vs_public"].abs() < 1e-12, "method"].iloc[0]
    lines = [f"Generated from `{ESZSL_PUBLIC_FILE}` by `make numbers`: trial accuracy [95% interval] on the same "
             f"random PHAC-2 splits, the paired difference to `{reference}` [95% interval], and the share of "
             "splits whose chosen regulariser sits at a grid edge.", "",
             "| purpose | method | splits | accuracy | minus public | share at a grid edge |",
             "|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        diff = "-" if r["method"] == reference else signed(r["diff_vs_public"], r["diff_ci95_low"], r["diff_ci95_high"])
        lines.append(f"| {r['purpose']} | `{r['method']}` | {int(r['n_splits'])} | "
                     f"{ours(r, 'accuracy', 'ci95_low', 'ci95_high')} | {diff} | "
                     f"{100 * float(r['share_at_grid_edge']):.0f}% |")
    return "\n".join(lines)


def runs_by_purpose(results: str | Path, pattern: str, command: str) -> pd.DataFrame:
    """Every CSV matching ``pattern`` under ``results``, one table: selection runs first, then confirmation
    runs, each by seed (rows of one file keep their order).

    Raises
    ------
    MissingResults
        No such file under ``results`` (the message names ``experiments/benchmarks/<command>``).
    """
    root = Path(results)
    found = sorted(root.rglob(pattern)) if root.is_dir() else []
    if not found:
        raise MissingResults(f"{root}: no {pattern}; run experiments/benchmarks/{command} --out {root}/<run> first")
    table = pd.concat([pd.read_csv(f) for f in found], ignore_index=True)
    order = table["purpose"].map({"select": 0, "confirm": 1})
    return table.assign(order=order).sort_values(["order", "seed"], kind="stable")


def ensemble_calibration_block(results: str | Path) -> str:
    """The ensemble's calibration folds, members pinned vs searching (``calibration_refit.py --method ensemble``).

    Reads every :data:`ENSEMBLE_CALIBRATION_FILES` under ``results``, selection splits first.

    Raises
    ------
    MissingResults
        No such file under ``results``.
    """
    table = runs_by_purpose(results, ENSEMBLE_CALIBRATION_FILES, "calibration_refit.py --method ensemble")
    lines = ["Generated from `calibration_refit_summary_phac2_ensemble_*.csv` by `make numbers`: ECE [95% interval] "
             "of the calibrated `ensemble` on PHAC-2 random splits with its calibration folds refitting the members "
             "with their chosen hyper-parameters (pinned) or searching them again (search), the paired difference "
             "pinned minus search [95% interval], the accuracy difference (0: a temperature keeps the ranking) and "
             "the CPU seconds of the calibrations (one core, summed over the splits).", "",
             "| purpose | seed | splits (trials) | ECE pinned | ECE search | pinned - search | accuracy difference | "
             "CPU pinned (s) | CPU search (s) |", "|---|---|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        diff = signed(r["ece_difference"], r["ece_difference_ci95_low"], r["ece_difference_ci95_high"])
        lines.append(f"| {r['purpose']} | {int(r['seed'])} | {int(r['n_splits'])} ({int(r['n_trials'])}) | "
                     f"{ours(r, 'pinned_ece')} | {ours(r, 'search_ece')} | {diff} | "
                     f"{float(r['accuracy_difference']):+.3f} | {float(r['pinned_cpu_s']):.1f} | "
                     f"{float(r['search_cpu_s']):.1f} |")
    select = table[table["purpose"] == "select"]
    if len(select) and {"rule_max_ece_difference", "rule_min_cpu_saving"} <= set(select.columns):
        r = select.iloc[0]
        margin, saving = float(r["rule_max_ece_difference"]), float(r["rule_min_cpu_saving"])
        ece_ok = float(r["ece_difference_ci95_high"]) <= margin
        cpu_ok = float(r["pinned_cpu_s"]) <= (1 - saving) * float(r["search_cpu_s"])
        lines += ["", f"The rule, fixed before measuring: pin the members by default if on the selection splits the "
                      f"interval's upper end is at most {margin:.2f} ({'holds' if ece_ok else 'does not hold'}) and "
                      f"the calibration CPU falls by at least {100 * saving:.0f}% "
                      f"({'holds' if cpu_ok else 'does not hold'}): "
                      + ("the members are pinned by default." if ece_ok and cpu_ok else "the members keep searching.")]
    return "\n".join(lines)


def ensemble_reuse_block(results: str | Path) -> str:
    """The ensemble's former members against the comparison's fits as members (``ensemble_reuse.py``).

    Reads every :data:`ENSEMBLE_REUSE_FILES` under ``results``, selection splits first, and states the
    rule's verdict as the selection file records it (``accuracy_within``, ``ece_within``).

    Raises
    ------
    MissingResults
        No such file under ``results``.
    """
    table = runs_by_purpose(results, ENSEMBLE_REUSE_FILES, "ensemble_reuse.py --purpose select")
    lines = ["Generated from `ensemble_reuse_summary_*.csv` by `make numbers`: trial accuracy and ECE [95% interval] "
             "of the calibrated `ensemble` on PHAC-2 random splits with its former members (`separate`: the DAP "
             "member's `AttributeSVM(cv=5, grid=\"paper\")`, each member's seed drawn from the ensemble's, members "
             "searching again in the calibration folds) and with the members as the comparison fits those methods "
             "(`reusing`: the registered `dap-avg`, `eszsl` and `sae` with their defaults and the ensemble's seed, "
             "pinned in the folds), the paired differences reusing minus separate on the same trials "
             "[95% interval], and the CPU seconds (one core, summed over the splits) of each ensemble fitted after "
             "the compared `dap-avg`, `eszsl` and `sae` of the same splits in one fit store (their own CPU "
             "seconds in brackets), with the fits each ensemble read back from the store (hits) and made (misses).",
             "", "| purpose | seed | splits (trials) | chance | accuracy separate | accuracy reusing | reusing - "
             "separate | ECE separate | ECE reusing | reusing - separate | CPU separate (s) | CPU reusing (s) | fits "
             "read back / made (separate; reusing) |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        lines.append(f"| {r['purpose']} | {int(r['seed'])} | {int(r['n_splits'])} ({int(r['n_trials'])}) | "
                     f"{number(r['chance'])} | {ours(r, 'separate_accuracy')} | {ours(r, 'reusing_accuracy')} | "
                     f"{_paired(r, 'accuracy_difference')} | {ours(r, 'separate_ece')} | {ours(r, 'reusing_ece')} | "
                     f"{_paired(r, 'ece_difference')} | "
                     f"{float(r['separate_cpu_s']):.1f} | {float(r['reusing_cpu_s']):.1f} "
                     f"({float(r['compared_cpu_s']):.1f}) | {int(r['separate_fit_store_hit'])} / "
                     f"{int(r['separate_fit_store_miss'])}; {int(r['reusing_fit_store_hit'])} / "
                     f"{int(r['reusing_fit_store_miss'])} |")
    select = table[table["purpose"] == "select"]
    if len(select):
        r = select.iloc[0]
        accuracy, ece = bool(r["accuracy_within"]), bool(r["ece_within"])
        lines += ["", "The rule, fixed before measuring: the reusing members become the default if on the selection "
                      "splits the reusing ensemble's accuracy lies within the 95% interval of the former one's "
                      f"({'holds' if accuracy else 'does not hold'}) and its ECE within the 95% interval of the former "
                      f"one's ({'holds' if ece else 'does not hold'}): "
                      + ("the ensemble's members are the compared methods' fits by default." if accuracy and ece
                         else "the former members stay.")]
    return "\n".join(lines)


def _paired(row: pd.Series, column: str) -> str:
    """``row[column]`` with its interval ``<column>_ci95_low`` / ``_high``, signs shown."""
    return signed(row[column], row[f"{column}_ci95_low"], row[f"{column}_ci95_high"])


def exact_solver_threshold_block(results: str | Path) -> str:
    """``dap-avg`` with approximate against exact attribute SVMs on PHAC-2 (``exact_solver_threshold.py``).

    Reads every :data:`EXACT_SOLVER_FILES` under ``results``, selection splits first, and states the
    rule's verdict as the selection file records it (``rule_holds``, the script's ``guard_holds``).

    Raises
    ------
    MissingResults
        No such file under ``results``.
    """
    table = runs_by_purpose(results, EXACT_SOLVER_FILES, "exact_solver_threshold.py --data phac2")
    lines = ["Generated from `exact_solver_threshold_phac2_*.csv` by `make numbers`: PHAC-2 accuracy of the registered "
             "`dap-avg` with exact RBF-SVMs and with the approximate model (`solver`), each the mean over splits, and "
             "their paired difference approximate minus exact [95% percentile interval over splits]; the criterion "
             "is the mean of the random and challenging means; chance is one over the unseen classes, averaged "
             "the same way.", "",
             "| purpose | seed | split kind (splits) | chance | exact | approximate | approximate - exact |",
             "|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        if r["split_kind"] == "criterion":
            diff = f"{float(r['difference']):+.3f}"
        else:
            diff = signed(r["difference"], r["difference_ci95_low"], r["difference_ci95_high"])
        lines.append(f"| {r['purpose']} | {int(r['seed'])} | {r['split_kind']} ({int(r['n_splits'])}) | "
                     f"{number(r['chance'])} | {number(r['exact'])} | {number(r['approximate'])} | {diff} |")
    select = table[(table["purpose"] == "select") & (table["split_kind"] == "criterion")]
    if len(select):
        r = select.iloc[0]
        holds = bool(r["rule_holds"])
        lines += ["", "The rule, fixed before measuring: on the selection splits the approximate model's criterion "
                      f"may be at most {float(r['rule_max_criterion_loss']):.2f} below the exact one's "
                      f"({'holds' if holds else 'does not hold'}): "
                      + ("the exact-solver threshold is set below the template's training sets."
                         if holds else "the threshold stays where it was.")]
    return "\n".join(lines)


def selection_criterion_block(results: str | Path) -> str:
    """The zero-shot searches' criterion, neg_log_loss against accuracy (``selection_criterion.py``).

    Reads every :data:`SELECTION_CRITERION_FILES` under ``results``: the selection splits with the
    rule's verdict per method (``rule_a_holds``, ``rule_b_holds`` as the selection file records
    them), then the confirmation splits.

    Raises
    ------
    MissingResults
        No such file under ``results``.
    """
    table = runs_by_purpose(results, SELECTION_CRITERION_FILES, "selection_criterion.py --purpose select")
    lines = ["Generated from `selection_criterion_summary_*.csv` by `make numbers`: PHAC-2 trial accuracy "
             "[95% interval] of each method with its regularisers chosen by accuracy and by neg_log_loss (same "
             "tie rule), chance (one over the unseen classes), the paired difference neg_log_loss minus accuracy "
             "on the same trials [95% interval], and, over the fits repeated on the features times "
             "`1 + 1e-12 u`, the fits whose chosen regulariser changed and the test predictions that changed "
             "(accuracy / neg_log_loss)."]
    for purpose, part in table.groupby("purpose", sort=False):
        seeds = ", ".join(str(int(v)) for v in dict.fromkeys(part["seed"]))
        lines += ["", f"{'Selection' if purpose == 'select' else 'Confirmation'} splits (seed {seeds}):", "",
                  "| method | splits | chance | by accuracy | by neg_log_loss | neg_log_loss - accuracy | "
                  "changed choices (of fits) | changed predictions (of trials) |", "|---|---|---|---|---|---|---|---|"]
        for (_, method), rows in part.groupby(["seed", "method"], sort=False):
            by = rows.set_index("scoring")
            acc, nll = by.loc["accuracy"], by.loc["neg_log_loss"]
            lines.append(f"| `{method}` | {int(nll['n_splits'])} | {number(nll['chance'])} | "
                         f"{ours(acc, 'accuracy', 'ci95_low', 'ci95_high')} | "
                         f"{ours(nll, 'accuracy', 'ci95_low', 'ci95_high')} | "
                         f"{signed(nll['diff_vs_accuracy'], nll['diff_ci95_low'], nll['diff_ci95_high'])} | "
                         f"{int(acc['n_choice_flips'])} / {int(nll['n_choice_flips'])} ({int(nll['n_fits'])}) | "
                         f"{int(acc['n_changed_predictions'])} / {int(nll['n_changed_predictions'])} "
                         f"({int(nll['n_test_trials'])}) |")
        if purpose != "select" or "rule_holds" not in part.columns:
            continue
        verdicts = part[part["scoring"] == "neg_log_loss"]
        bound = float(verdicts["rule_min_lower_bound"].iloc[0])
        lines += ["", "The rule, fixed before measuring: neg_log_loss becomes a method's default if on the selection "
                      "splits (a) no choice by neg_log_loss changed under the perturbation while one by accuracy did, "
                      f"and (b) the interval of neg_log_loss minus accuracy has its lower bound above {bound:+.2f}.",
                  ""]
        flips = part.set_index(["method", "scoring"])["n_choice_flips"]
        for _, r in verdicts.iterrows():
            a, b = bool(r["rule_a_holds"]), bool(r["rule_b_holds"])
            changed = (f"changed choices: accuracy {int(flips[(r['method'], 'accuracy')])}, neg_log_loss "
                       f"{int(r['n_choice_flips'])}")
            lines.append(f"* `{r['method']}`: (a) {'holds' if a else 'does not hold'} ({changed}), (b) "
                         f"{'holds' if b else 'does not hold'} (lower bound {float(r['diff_ci95_low']):+.3f}): "
                         + ("neg_log_loss becomes its default." if a and b else
                            "accuracy stays its default; its published numbers can move with the last bit."))
    return "\n".join(lines)


#: Block name -> the function that makes it, for the benchmarks' blocks of this module
#: (:data:`tzsl.reporting.readme_results.BLOCKS` holds them with the others).
BENCHMARK_BLOCKS: dict[str, Callable[[Path], str]] = {
    "phac2-accuracy-benchmark": benchmark_accuracy_block, "attribute-search-benchmark": search_benchmark_block,
    "phac2-best-method": best_method_block, "eszsl-public-benchmark": eszsl_public_block,
    "ensemble-calibration-benchmark": ensemble_calibration_block,
    "exact-solver-threshold-benchmark": exact_solver_threshold_block,
    "selection-criterion-benchmark": selection_criterion_block, "ensemble-reuse-benchmark": ensemble_reuse_block}
