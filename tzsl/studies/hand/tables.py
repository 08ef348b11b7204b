"""The hand study's tables (per seed, then mean and std over seeds) and its text summary.

Views of the per-seed rows :func:`tzsl.studies.hand.study.run_hand_study` collects; the mean/std
rows come from :func:`tzsl.evaluation.summarise_over_splits`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from tzsl.evaluation import Outcomes, add_trust_columns, summarise_over_splits
from tzsl.studies.papers import numbers as paper

if TYPE_CHECKING:
    from tzsl.studies.hand.results import HandStudyResult

__all__ = ["SUBSETS", "attribute_table", "distance_table", "format_hand_summary", "table5", "with_intervals"]

#: Table 5 columns: the paper's object subsets (section 5.8), then all test objects.
SUBSETS: tuple[str, ...] = ("homogeneous", "heterogeneous_shape", "heterogeneous_material")


def with_intervals(table: pd.DataFrame, records: list[tuple], kind: str, by: tuple[str, ...],
                   baselines: bool = True) -> pd.DataFrame:
    """``table`` with interval (and chance / majority) columns from the study's per-grasp records.

    ``records``: ``(kind, seed, column, classes, correct, metric, keys)`` tuples collected by the
    study; those of ``kind`` go into an :class:`~tzsl.evaluation._trust.Outcomes` with
    ``split_column="seed"`` (intervals: within a seed over test objects, and on the ``mean``
    rows over seeds and test objects; :func:`~tzsl.evaluation._trust.add_trust_columns`).
    """
    outcomes = Outcomes(split_column="seed", by=by)
    for k, seed, column, classes, correct, metric, keys in records:
        if k == kind:
            outcomes.add(seed, column, classes, correct, metric=metric, **keys)
    return add_trust_columns(table, outcomes, baselines=baselines)


def table5(rows: list[dict]) -> pd.DataFrame:
    """Table 5: per-seed single-grasp accuracies per method and subset, mean/std rows, paper beside."""
    df = summarise_over_splits(pd.DataFrame(rows), split_column="seed", by=["method"])
    for col in [*SUBSETS, "all"]:
        df[f"paper_{col}"] = [
            np.nan if seed == "std" else paper.DAP_HAND_TABLE5.get(m.lower(), {}).get(col, np.nan)
            for seed, m in zip(df["seed"], df["method"], strict=True)
        ]
    return df


def attribute_table(rows: list[dict]) -> pd.DataFrame:
    """Per-attribute accuracy per seed with mean/std rows, an all-attribute mean row, paper beside."""
    df = summarise_over_splits(pd.DataFrame(rows), split_column="seed", by=["attribute", "kind"])
    df["paper_accuracy"] = df["attribute"].map(paper.DAP_HAND_ATTRIBUTE_ACCURACY_QUOTED).where(df["seed"] != "std")
    per_seed = pd.DataFrame(rows).groupby("seed")["accuracy"].mean()
    mean_rows = pd.DataFrame({
        "seed": [*per_seed.index.astype(object), "mean", "std"],
        "attribute": "mean", "kind": "all",
        "accuracy": [*per_seed.to_numpy(), per_seed.mean(), per_seed.std(ddof=1)],
        "paper_accuracy": [paper.DAP_HAND_MEAN_ATTRIBUTE_ACCURACY] * (len(per_seed) + 1) + [np.nan],
    })
    return pd.concat([df, mean_rows], ignore_index=True)


def distance_table(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """The distance matrix S (eq. 13) per seed, then its mean over seeds."""
    df = pd.concat(frames, ignore_index=True)
    table = summarise_over_splits(df, split_column="seed", by=["object"])
    return table[table["seed"] != "std"].reset_index(drop=True)  # S: mean over seeds, no std rows


def format_hand_summary(result: HandStudyResult) -> str:
    """Table 5, the T and k curves (means over seeds) beside the paper, as plain text."""
    pct = lambda v: "" if pd.isna(v) else f"{100 * v:6.2f}%"  # noqa: E731
    lines = []
    if result.simulated:
        lines.append("NOTE: these numbers come from SIMULATED grasps, not from the paper's robot data.")
    t5 = result.table5[result.table5["seed"] == "mean"]
    cols = [c for c in (*SUBSETS, "all") if c in t5.columns]
    lines.append("Table 5, single-grasp accuracy, mean over seeds (paper in brackets):")
    lines.append(f"  {'method':<8}" + "".join(f"{c:>32}" for c in cols))
    for _, r in t5.iterrows():
        cells = [f"{pct(r[c]).strip()} ({pct(r.get('paper_' + c, np.nan)).strip() or '-'})" for c in cols]
        lines.append(f"  {r['method']:<8}" + "".join(f"{c:>32}" for c in cells))
    T = result.multigrasp_T[result.multigrasp_T["seed"] == "mean"]
    lines.append("DF-MDAP accuracy vs T: " + ", ".join(f"T={int(t)}: {pct(a).strip()}"
                                                      for t, a in zip(T["T"], T["accuracy"], strict=True)))
    k = result.multigrasp_k[result.multigrasp_k["seed"] == "mean"]
    lines.append("SC-MDAP accuracy vs k: " + ", ".join(
        f"k={int(kk)}: {pct(a).strip()} ({g:.1f} grasps)"
        for kk, a, g in zip(k["k"], k["accuracy"], k["mean_grasps_used"], strict=True)))
    objects = [("LDAP (single grasp)", t5[t5["method"] == "LDAP"])]
    for label, df, col in (("DF-MDAP", T, "T"), ("SC-MDAP", k, "k")):
        methods = [m for m in pd.unique(result.confusion["method"]) if m.startswith(label)]
        if methods:
            setting = int(methods[0].split("=")[1].rstrip(")"))
            objects.append((methods[0], df[df[col] == setting]))
    n_objects = result.confusion.groupby("seed")["true"].nunique().max()
    for label, row in objects:
        if len(row):
            lines.append(f"{label}: test objects with all grasps/sequences correct "
                         f"{row['objects_all_correct'].item():.1f}/{n_objects}, with most correct "
                         f"{row['objects_majority_correct'].item():.1f}/{n_objects} "
                         "(mean over seeds)")
    lines.append(f"paper: LDAP {pct(paper.DAP_HAND_SINGLE_GRASP_BEST).strip()}, SC-MDAP (k=4) all correct on "
                 f"{paper.DAP_HAND_SC_OBJECTS_PERFECT[0]}/{paper.DAP_HAND_SC_OBJECTS_PERFECT[1]} objects")
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)
