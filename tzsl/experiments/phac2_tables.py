"""Tables of the PHAC-2 DAP study (DAP paper section 4), each with the paper's numbers beside.

Views of the per-split test posteriors (:class:`tzsl.experiments.phac2_dap.SplitPosteriors`):
Tables 1-3, the multi-label comparison, per-attribute accuracy and the attribute-count sweep
(section 4.7). Mean and std rows over splits come from :func:`tzsl.evaluation.summarise_over_splits`.
"""

from __future__ import annotations

from itertools import combinations
from math import comb
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from tzsl.evaluation import (
    Split,
    per_attribute_balanced_accuracy,
    per_class_mean_accuracy,
    summarise_over_splits,
)
from tzsl.models import dap_accuracy_over_subsets

if TYPE_CHECKING:
    from tzsl.experiments.phac2_dap import SplitPosteriors

__all__ = [
    "FUSIONS",
    "PRIORS",
    "attribute_accuracy_summary",
    "attribute_accuracy_table",
    "attribute_subsets",
    "attribute_sweep",
    "multilabel_table",
    "split_label",
    "table1_fusion",
    "table2_priors",
    "table3_challenging",
]

#: DAP sensor fusions of Table 1.
FUSIONS = ("max", "avg")
#: Attribute priors of Table 2, in its column order.
PRIORS = ("uni", "test", "train")


def split_label(split: Split) -> str:
    """Short label of a split in the tables: the part after its last "-" (``random-3`` -> ``3``)."""
    return split.name.rsplit("-", 1)[-1]


def _paper(table: dict, split: str, i: int):
    """Entry ``i`` of the paper's row for ``split`` (its "average" row for our "mean"), NaN where none."""
    key = "average" if split == "mean" else split
    value = table.get(key)
    return np.nan if value is None or value[i] is None else value[i]


def table1_fusion(results: list[SplitPosteriors]) -> pd.DataFrame:
    """Table 1: MAXDAP vs AVGDAP, uni-prior, per random split + mean/std, paper beside."""
    from tzsl.experiments.paper_numbers import DAP_TABLE1  # noqa: PLC0415

    rows = [{
        "split": split_label(r.split), "n_test_objects": r.split.n_test, "chance": r.split.chance,
        "maxdap": r.accuracy("max", "uni"), "avgdap": r.accuracy("avg", "uni"),
        "avgdap_per_class_mean": per_class_mean_accuracy(r.y, r.predict("avg", "uni")),
        "n_attributes": len(r.attributes),
    } for r in results]
    table = summarise_over_splits(pd.DataFrame(rows)).reset_index()
    table["paper_maxdap"] = [_paper(DAP_TABLE1, s, 0) for s in table["split"]]
    table["paper_avgdap"] = [_paper(DAP_TABLE1, s, 1) for s in table["split"]]
    return table


def table2_priors(results: list[SplitPosteriors]) -> pd.DataFrame:
    """Table 2: AVGDAP with uni / test / train attribute priors, paper beside."""
    from tzsl.experiments.paper_numbers import DAP_TABLE2  # noqa: PLC0415

    rows = [{"split": split_label(r.split), **{p: r.accuracy("avg", p) for p in PRIORS}} for r in results]
    table = summarise_over_splits(pd.DataFrame(rows)).reset_index()
    for i, p in enumerate(PRIORS):
        table[f"paper_{p}"] = [_paper(DAP_TABLE2, s, i) for s in table["split"]]
    return table


def table3_challenging(results: list[SplitPosteriors], map_coords: pd.DataFrame | None = None) -> pd.DataFrame:
    """Table 3: challenging splits (AVGDAP, uni-prior), sizes and chance, paper beside."""
    from tzsl.experiments.paper_numbers import DAP_TABLE3  # noqa: PLC0415

    rows = []
    for r in results:
        label = split_label(r.split)
        part = ""
        if map_coords is not None:
            labels = map_coords.loc[map_coords["partition"] == int(label), "partition_label"]
            part = labels.iloc[0] if len(labels) else ""
        rows.append({
            "split": label, "partition": part, "n_objects": r.split.n_test, "chance": r.split.chance,
            "avgdap": r.accuracy("avg", "uni"),
            "avgdap_per_class_mean": per_class_mean_accuracy(r.y, r.predict("avg", "uni")),
            "excluded_attributes": ";".join(a for a, _ in r.split.excluded_attributes),
            "dropped_duplicate_objects": ";".join(o for o, _ in r.split.dropped_objects),
        })
    table = summarise_over_splits(pd.DataFrame(rows)).reset_index()
    for i, name in enumerate(("paper_n_objects", "paper_chance", "paper_avgdap")):
        table[name] = [_paper(DAP_TABLE3, s, i) for s in table["split"]]
    return table


def multilabel_table(results: list[SplitPosteriors]) -> pd.DataFrame:
    """Independent vs joint attribute classifiers (AVGDAP, uni-prior), paper beside (0.39 vs 0.31)."""
    from tzsl.experiments.paper_numbers import DAP_INDEPENDENT_ACCURACY, DAP_MULTILABEL_ACCURACY  # noqa: PLC0415

    rows = [{"split": split_label(r.split), "independent": r.accuracy("avg", "uni"),
             "multilabel": r.accuracy("avg", "uni", multilabel=True)} for r in results if r.P_multilabel is not None]
    table = summarise_over_splits(pd.DataFrame(rows)).reset_index()
    mean = table["split"] == "mean"
    table["paper_independent"] = np.where(mean, DAP_INDEPENDENT_ACCURACY, np.nan)
    table["paper_multilabel"] = np.where(mean, DAP_MULTILABEL_ACCURACY, np.nan)
    return table


def attribute_accuracy_table(results: list[SplitPosteriors], sensors: tuple[str, ...]) -> pd.DataFrame:
    """Per-attribute accuracy and balanced accuracy on test trials (threshold 0.5), per split and sensor.

    Rows: one per (split, attribute, sensor), plus ``sensor="mean"`` rows averaging the
    sensors as the paper's Fig. 2a does. Balanced accuracy is NaN where an attribute takes a
    single value on the split's test objects.
    """
    rows = []
    for r in results:
        truth = r.K[r.y].astype(bool)  # (n, m)
        pred = r.P >= 0.5  # (n, s, m)
        correct = pred == truth[:, None, :]
        acc = correct.mean(axis=0)  # (s, m)
        bal = np.stack([per_attribute_balanced_accuracy(truth, pred[:, s, :]) for s in range(pred.shape[1])])
        for j, attr in enumerate(r.attributes):
            for s, sensor in enumerate(sensors):
                rows.append({"split": split_label(r.split), "attribute": attr, "sensor": sensor,
                             "accuracy": acc[s, j], "balanced_accuracy": bal[s, j]})
            rows.append({"split": split_label(r.split), "attribute": attr, "sensor": "mean",
                         "accuracy": acc[:, j].mean(), "balanced_accuracy": np.nanmean(bal[:, j])
                         if np.isfinite(bal[:, j]).any() else np.nan})
    return pd.DataFrame(rows)


def attribute_accuracy_summary(per_split: pd.DataFrame) -> pd.DataFrame:
    """Mean over splits of the sensor-averaged per-attribute accuracy, with the paper's quoted values."""
    from tzsl.experiments.paper_numbers import DAP_ATTRIBUTE_ACCURACY_QUOTED, DAP_MEAN_ATTRIBUTE_ACCURACY  # noqa: PLC0415

    mean_rows = per_split[per_split["sensor"] == "mean"]
    summary = mean_rows.groupby("attribute", sort=False)[["accuracy", "balanced_accuracy"]].mean().reset_index()
    summary["paper_accuracy"] = summary["attribute"].map(DAP_ATTRIBUTE_ACCURACY_QUOTED)
    overall = pd.DataFrame([{"attribute": "mean", "accuracy": summary["accuracy"].mean(),
                             "balanced_accuracy": summary["balanced_accuracy"].mean(),
                             "paper_accuracy": DAP_MEAN_ATTRIBUTE_ACCURACY}])
    return pd.concat([summary, overall], ignore_index=True)


def attribute_subsets(m: int, j: int, max_subsets: int, rng: np.random.Generator) -> np.ndarray:
    """Up to ``max_subsets`` distinct j-subsets of m attributes as (r, j) column indices."""
    total = comb(m, j)
    if total <= max_subsets:
        return np.array(list(combinations(range(m), j)), dtype=np.intp).reshape(-1, j)
    chosen: set[tuple[int, ...]] = set()
    while len(chosen) < max_subsets:
        draws = np.sort(rng.random((max_subsets, m)).argsort(axis=1)[:, :j], axis=1)
        chosen.update(map(tuple, draws.tolist()))
    return np.array(sorted(chosen)[:max_subsets], dtype=np.intp)


def attribute_sweep(results: list[SplitPosteriors], min_attributes: int = 7, max_subsets: int = 1000,
                    seed: int = 0, fusion: str = "avg", prior: str = "uni") -> pd.DataFrame:
    """Accuracy vs number of attributes j (section 4.7), reusing the fitted posteriors.

    For each split and each j from ``min_attributes`` to the split's attribute count, up to
    ``max_subsets`` random j-subsets are scored in one vectorised pass. Rows: (split, j) with
    the mean and std over subsets, and ``split="mean"`` rows averaging the splits.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for r in results:
        m = len(r.attributes)
        for j in range(min_attributes, m + 1):
            subsets = attribute_subsets(m, j, max_subsets, rng)
            acc = dap_accuracy_over_subsets(r.P, r.K, r.y, subsets, fusion=fusion, prior=prior)
            rows.append({"split": split_label(r.split), "n_attributes": j, "n_subsets": len(subsets),
                         "accuracy_mean": acc.mean(), "accuracy_std": acc.std(), "chance": r.split.chance})
    table = pd.DataFrame(rows)
    mean = table.groupby("n_attributes", as_index=False).agg(
        n_subsets=("n_subsets", "sum"), accuracy_mean=("accuracy_mean", "mean"),
        accuracy_std=("accuracy_mean", "std"), chance=("chance", "mean"))
    mean.insert(0, "split", "mean")
    return pd.concat([table, mean], ignore_index=True)
