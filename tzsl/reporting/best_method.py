"""Which method is best, with the evidence: read from method comparison tables (issue 23).

A method comparison (``method_comparison.csv``, :data:`tzsl.studies.comparison.method_runs.COMPARISON_COLUMNS`)
holds, per study and split kind, every method's accuracy with its interval and its paired
difference to the study's reference (the paper's method) with its interval. Two uses:

* :func:`best_rows` / :func:`findings`: the most accurate method of each group of a run's own
  table, said in sentences for the report, with the paired difference as the evidence and, when no
  method beats the reference with an interval excluding 0, a sentence saying so;
* :func:`confirm_choice`: the protocol for a choice a user inherits - the best method picked on
  *selection* splits, its accuracy and its difference to the reference reported from
  *confirmation* splits (``[splits] purpose``), where it was not picked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["KIND_COLUMN", "best_rows", "beats_reference", "confirm_choice", "findings", "split_kinds"]

#: Column naming the split kind (random / challenging) of a comparison row, when the table has one.
KIND_COLUMN = "kind"


def split_kinds(table: pd.DataFrame) -> pd.Series:
    """The split kind of every row: the :data:`KIND_COLUMN` (or ``split_kind``) where present, else read from the study
    label (``...challenging...`` -> challenging; the PHAC-2 and zero-shot studies' comparisons are
    on random splits; other studies keep their own label)."""
    for column in (KIND_COLUMN, "split_kind"):  # a method comparison names its split kind (file splits too)
        if column in table.columns:
            return table[column].astype(str)
    study = table["study"].astype(str)
    random = study.str.startswith(("phac2", "zero-shot")) & ~study.str.contains("challenging")
    return pd.Series(np.where(study.str.contains("challenging"), "challenging",
                              np.where(random, "random", study)), index=table.index)


def beats_reference(row: pd.Series) -> bool:
    """Whether the row's paired difference to the reference has an interval above 0."""
    low = row.get("difference_ci95_low")
    return bool(low is not None and not pd.isna(low) and float(low) > 0 and row["method"] != row["reference"])


def best_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The most accurate method of each (study, split kind, purpose) group, with a ``beats_reference`` flag.

    Parameters
    ----------
    table : DataFrame
        A method comparison (columns ``study``, ``method``, ``accuracy``, ``reference``,
        ``difference``, ``difference_ci95_low/high``; ``purpose`` and :data:`KIND_COLUMN` optional).

    Returns
    -------
    DataFrame
        One row per group: the group's best row (highest accuracy; ties: table order) with
        ``kind``, ``beats_reference`` and ``any_beats_reference`` (some method of the group beats
        the reference with an interval excluding 0) added.
    """
    ran = table[table["accuracy"].notna()].copy()
    ran[KIND_COLUMN] = split_kinds(ran)
    if "purpose" not in ran.columns:
        ran["purpose"] = ""
    ran["purpose"] = ["" if pd.isna(v) else str(v) for v in ran["purpose"]]
    rows = []
    for _, group in ran.groupby(["study", KIND_COLUMN, "purpose"], sort=False):
        best = group.loc[group["accuracy"].idxmax()].copy()
        best["beats_reference"] = beats_reference(best)
        best["any_beats_reference"] = any(beats_reference(r) for _, r in group.iterrows())
        rows.append(best)
    return pd.DataFrame(rows).reset_index(drop=True)


def _interval(row: pd.Series, column: str, low: str, high: str, sign: str = "") -> str:
    value = f"{row[column]:{sign}.3f}"
    if not (pd.isna(row.get(low)) or pd.isna(row.get(high))):
        value += f" [{row[low]:{sign}.3f}, {row[high]:{sign}.3f}]"
    return value


def _sentence(best: pd.Series) -> str:
    purpose = f", {best['purpose']} splits" if best["purpose"] else ""
    where = f"{best['study']}, {best[KIND_COLUMN]} splits{purpose}"
    accuracy = _interval(best, "accuracy", "ci95_low", "ci95_high")
    reference = best["reference"]
    if best["method"] == reference:
        text = f"{where}: the most accurate method is the reference {reference}, {accuracy}."
    else:
        diff = _interval(best, "difference", "difference_ci95_low", "difference_ci95_high", "+")
        text = (f"{where}: the most accurate method is {best['method']}, {accuracy}; paired difference to "
                f"{reference} {diff}" + (" (interval excludes 0)." if best["beats_reference"] else "."))
    if not best["any_beats_reference"]:
        text += f" No method beats {reference} with an interval excluding 0."
    if best["purpose"] == "select":
        text += " These are selection splits: confirm the choice on confirmation splits before reporting it."
    return text


def findings(paths: list[Path]) -> list[str]:
    """Sentences naming the best method of every group of the comparison tables at ``paths``.

    For a PHAC-2 or zero-shot comparison without challenging-split rows, a sentence says that
    the table has none (so a reader does not take the random-split winner for both).
    """
    out: list[str] = []
    for path in paths:
        table = pd.read_csv(path)
        if table.empty or not {"study", "method", "accuracy", "reference"} <= set(table.columns):
            continue
        best = best_rows(table)
        out += [_sentence(row) for _, row in best.iterrows()]
        kinds = set(best[KIND_COLUMN]) if len(best) else set()
        if "random" in kinds and "challenging" not in kinds:
            out.append(f"{path.name} has no rows on challenging splits, so it names no best method there.")
    return out


def confirm_choice(selection: pd.DataFrame, confirmation: pd.DataFrame) -> pd.DataFrame:
    """The best method of each split kind picked on ``selection``, reported from ``confirmation``.

    Parameters
    ----------
    selection, confirmation : DataFrame
        Method comparisons of the same methods on selection and on confirmation splits (both
        with :data:`KIND_COLUMN` or study labels :func:`split_kinds` reads).

    Returns
    -------
    DataFrame
        One row per split kind: ``kind``, ``chosen`` (best on selection), ``selection_accuracy``,
        its confirmation ``accuracy`` with ``ci95_low/high``, ``difference`` to the reference with
        ``difference_ci95_low/high``, ``reference``, ``beats_reference`` (interval above 0:
        only then may the chosen method become the shipped default) and the split counts.
    """
    confirm = confirmation[confirmation["accuracy"].notna()].copy()
    confirm[KIND_COLUMN] = split_kinds(confirm)
    rows = []
    for _, pick in best_rows(selection).iterrows():
        hit = confirm[(confirm[KIND_COLUMN] == pick[KIND_COLUMN]) & (confirm["method"] == pick["method"])]
        row = {"kind": pick[KIND_COLUMN], "chosen": pick["method"], "selection_accuracy": pick["accuracy"],
               "selection_n_splits": pick.get("n_splits"), "reference": pick["reference"]}
        if hit.empty:
            rows.append({**row, "beats_reference": False, "note": "not run on the confirmation splits"})
            continue
        c = hit.iloc[0]
        rows.append({**row, **{k: c.get(k) for k in ("accuracy", "ci95_low", "ci95_high", "difference",
                                                    "difference_ci95_low", "difference_ci95_high")},
                     "confirmation_n_splits": c.get("n_splits"), "beats_reference": beats_reference(c),
                     "note": ""})
    return pd.DataFrame(rows)
