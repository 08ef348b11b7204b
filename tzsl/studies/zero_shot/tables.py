"""Tables of the zero-shot study, in the DAP paper's layout (section 4), with the paper's numbers beside
on the paper's dataset and protocol only.

Views of the per-split test posteriors (:class:`tzsl.studies.zero_shot.split_posteriors.SplitPosteriors`):
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
    Outcomes,
    Split,
    add_trust_columns,
    bootstrap_accuracy,
    per_attribute_balanced_accuracy,
    per_class_mean_accuracy,
    shuffled_rows_control,
    summarise_over_splits,
)
from tzsl.models.dap import dap_accuracy_over_subsets
from tzsl.value_lists import PRIORS

if TYPE_CHECKING:
    from tzsl.studies.papers.run_labels import StudyLabels
    from tzsl.studies.zero_shot.split_posteriors import SplitPosteriors

__all__ = [
    "CONTROL_ROW",
    "table_titles",
    "attribute_accuracy_summary",
    "attribute_accuracy_table",
    "attribute_subsets",
    "attribute_sweep",
    "multilabel_table",
    "negative_control",
    "split_label",
    "table1_fusion",
    "table2_priors",
    "table3_challenging",
]

#: Label of the negative-control row (test attribute rows shuffled among the test classes).
CONTROL_ROW = "control"
#: Shuffled tables drawn per split for the negative control.
CONTROL_PERMUTATIONS = 100

#: An accuracy column: (fusion, prior, multilabel, metric).
Scored = tuple[str, str, bool, str]


def _outcomes(results: list[SplitPosteriors], columns: dict[str, Scored], control: bool = True,
              seed: int = 0) -> tuple[Outcomes, dict | None]:
    """Per-trial outcomes of every column on every split, and the negative-control row.

    The control row (``split = "control"``): for each column, the test classes' attribute
    rows are shuffled among the test classes (:func:`tzsl.evaluation.shuffled_rows_control`,
    :data:`CONTROL_PERMUTATIONS` tables per split) and the same posteriors rescored; its value
    is the mean over splits of the share of trials recognised, which must be chance within
    its interval (two-level bootstrap over the splits it pools). Splits whose test objects
    share one attribute row (a single test object) cannot be shuffled and are left out of it.
    """
    outcomes = Outcomes()
    for r in results:
        for column, (fusion, prior, multilabel, metric) in columns.items():
            outcomes.add(split_label(r.split), column, r.y, r.predict(fusion, prior, multilabel) == r.y, metric=metric)
    if not control:
        return outcomes, None
    shuffleable = [r for r in results if len(np.unique(r.K, axis=0)) >= 2]  # a 1-class split has no control
    if not shuffleable:
        return outcomes, None
    row: dict = {"split": CONTROL_ROW}
    for column, scored in columns.items():
        correct, classes, splits = negative_control(shuffleable, scored, seed=seed)
        outcomes.add(CONTROL_ROW, column, classes, correct, metric=scored[3], inner_splits=splits)
        row[column] = bootstrap_accuracy(correct, classes=classes, splits=splits, metric=scored[3], n_boot=1).mean
    return outcomes, row


def negative_control(results: list[SplitPosteriors], scored: Scored, seed: int = 0,
                     n_permutations: int = CONTROL_PERMUTATIONS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shuffled-rows control of one DAP variant over all splits.

    Returns
    -------
    correct : ndarray of float, shape (n_trials,)
        Share of the shuffled tables under which each test trial was recognised.
    classes, splits : ndarray of shape (n_trials,)
        Test object (row of ``K``) and split label of each trial.
    """
    fusion, prior, multilabel, _ = scored
    correct, classes, splits = [], [], []
    for i, r in enumerate(results):
        table = pd.DataFrame(r.K, index=pd.RangeIndex(len(r.K)))
        correct.append(shuffled_rows_control(_permuted_scores(r, fusion, prior, multilabel), table, r.y,
                                             n_permutations=n_permutations, random_state=seed + i))
        classes.append(r.y)
        splits.append(np.full(len(r.y), split_label(r.split), dtype=object))
    return np.concatenate(correct), np.concatenate(classes), np.concatenate(splits)


def _permuted_scores(r: SplitPosteriors, fusion: str, prior: str, multilabel: bool):
    """``table -> r.scores(fusion, prior, multilabel, table)`` for tables whose rows are rows of ``r.K``.

    DAP scores each class from its own row (same prior, same order of the per-attribute sum), so
    the scores against a shuffled table are the true table's scores with their columns shuffled,
    bit for bit: they are computed once, not once per shuffled table (a row that several test
    objects share gives the same column whichever of them is taken).
    """
    base = r.scores(fusion, prior, multilabel)  # (n_test_trials, n_test_objects)
    K = np.asarray(r.K, dtype=np.int64)
    column = {K[j].tobytes(): j for j in range(len(K) - 1, -1, -1)}  # each row's first column

    def score(table: pd.DataFrame) -> np.ndarray:
        rows = np.asarray(table.to_numpy(), dtype=np.int64)
        return base[:, [column[row.tobytes()] for row in rows]]
    return score


def _with_trust(table: pd.DataFrame, outcomes: Outcomes, control_row: dict | None) -> pd.DataFrame:
    """Append the control row (after mean/std) and add the interval and baseline columns."""
    if control_row is not None:
        table = pd.concat([table, pd.DataFrame([control_row])], ignore_index=True)
    return add_trust_columns(table, outcomes)


def split_label(split: Split) -> str:
    """Short label of a split in the tables: the part after its last "-" (``random-3`` -> ``3``)."""
    return split.name.rsplit("-", 1)[-1]


def _paper(table: dict, split: str, i: int):
    """Entry ``i`` of the paper's row for ``split`` (its "average" row for our "mean"), NaN where none."""
    key = "average" if split == "mean" else split
    value = table.get(key)
    return np.nan if value is None or value[i] is None else value[i]


def table1_fusion(results: list[SplitPosteriors], paper: bool = False) -> pd.DataFrame:
    """Table 1: MAXDAP vs AVGDAP, uni-prior, per random split + mean/std + control (``paper``: the paper's beside).

    Every accuracy column has its interval columns and the table ``chance`` (and ``majority``
    where test objects have unequal trial counts): :func:`tzsl.evaluation._trust.add_trust_columns`.
    """
    from tzsl.studies.papers.numbers import DAP_TABLE1  # noqa: PLC0415

    rows = [{
        "split": split_label(r.split), "n_test_objects": r.split.n_test, "chance": r.split.chance,
        "maxdap": r.accuracy("max", "uni"), "avgdap": r.accuracy("avg", "uni"),
        "avgdap_per_class_mean": per_class_mean_accuracy(r.y, r.predict("avg", "uni")),
        "n_attributes": len(r.attributes),
    } for r in results]
    outcomes, control = _outcomes(results, {"maxdap": ("max", "uni", False, "trial"),
                                            "avgdap": ("avg", "uni", False, "trial"),
                                            "avgdap_per_class_mean": ("avg", "uni", False, "class_mean")})
    table = _with_trust(summarise_over_splits(pd.DataFrame(rows)).reset_index(), outcomes, control)
    if paper:
        table["paper_maxdap"] = [_paper(DAP_TABLE1, s, 0) for s in table["split"]]
        table["paper_avgdap"] = [_paper(DAP_TABLE1, s, 1) for s in table["split"]]
    return table


def table2_priors(results: list[SplitPosteriors], paper: bool = False) -> pd.DataFrame:
    """Table 2: AVGDAP with uni / test / train attribute priors, intervals, chance, control.

    ``paper``: the paper's numbers beside.
    """
    from tzsl.studies.papers.numbers import DAP_TABLE2  # noqa: PLC0415

    rows = [{"split": split_label(r.split), **{p: r.accuracy("avg", p) for p in PRIORS}} for r in results]
    outcomes, control = _outcomes(results, {p: ("avg", p, False, "trial") for p in PRIORS})
    table = _with_trust(summarise_over_splits(pd.DataFrame(rows)).reset_index(), outcomes, control)
    for i, p in enumerate(PRIORS if paper else ()):
        table[f"paper_{p}"] = [_paper(DAP_TABLE2, s, i) for s in table["split"]]
    return table


def table3_challenging(results: list[SplitPosteriors], map_coords: pd.DataFrame | None = None,
                       paper: bool = False) -> pd.DataFrame:
    """Table 3: challenging splits, MAXDAP and AVGDAP (uni-prior), sizes, intervals, chance, control.

    The paper reports AVGDAP only, and only its mean (``paper_avgdap`` on the ``mean`` row, with
    ``paper``): partition numbering is arbitrary, so only the means compare.
    """
    from tzsl.studies.papers.numbers import DAP_TABLE3  # noqa: PLC0415

    rows = []
    for r in results:
        label = split_label(r.split)
        part = ""
        if map_coords is not None:
            labels = map_coords.loc[map_coords["partition"] == int(label), "partition_label"]
            part = labels.iloc[0] if len(labels) else ""
        rows.append({
            "split": label, "partition": part, "n_objects": r.split.n_test, "chance": r.split.chance,
            "maxdap": r.accuracy("max", "uni"), "avgdap": r.accuracy("avg", "uni"),
            "avgdap_per_class_mean": per_class_mean_accuracy(r.y, r.predict("avg", "uni")),
            "excluded_attributes": ";".join(a for a, _ in r.split.excluded_attributes),
            "dropped_duplicate_objects": ";".join(o for o, _ in r.split.dropped_objects),
        })
    outcomes, control = _outcomes(results, {"maxdap": ("max", "uni", False, "trial"),
                                            "avgdap": ("avg", "uni", False, "trial"),
                                            "avgdap_per_class_mean": ("avg", "uni", False, "class_mean")})
    table = _with_trust(summarise_over_splits(pd.DataFrame(rows)).reset_index(), outcomes, control)
    if paper:
        table["paper_avgdap"] = np.where(table["split"] == "mean", DAP_TABLE3["average"][2], np.nan)
    return table


def multilabel_table(results: list[SplitPosteriors], paper: bool = False) -> pd.DataFrame:
    """Independent vs joint attribute classifiers (AVGDAP, uni-prior); ``paper``: section 4.4's numbers beside."""
    from tzsl.studies.papers.numbers import DAP_INDEPENDENT_ACCURACY, DAP_MULTILABEL_ACCURACY  # noqa: PLC0415

    rows = [{"split": split_label(r.split), "independent": r.accuracy("avg", "uni"),
             "multilabel": r.accuracy("avg", "uni", multilabel=True)} for r in results if r.P_multilabel is not None]
    outcomes, _ = _outcomes([r for r in results if r.P_multilabel is not None],
                            {"independent": ("avg", "uni", False, "trial"),
                             "multilabel": ("avg", "uni", True, "trial")}, control=False)
    table = add_trust_columns(summarise_over_splits(pd.DataFrame(rows)).reset_index(), outcomes)
    if paper:
        mean = table["split"] == "mean"
        table["paper_independent"] = np.where(mean, DAP_INDEPENDENT_ACCURACY, np.nan)
        table["paper_multilabel"] = np.where(mean, DAP_MULTILABEL_ACCURACY, np.nan)
    return table


def attribute_accuracy_table(results: list[SplitPosteriors], sensors: tuple[str, ...]) -> pd.DataFrame:
    """Per-attribute balanced accuracy, accuracy (threshold 0.5) and majority baseline, per split and sensor.

    Rows: one per (split, attribute, sensor), plus ``sensor="mean"`` rows averaging the
    sensors as the paper's Fig. 2a does. Balanced accuracy (the headline: its chance is 0.5
    whatever the attribute's frequency) is NaN where an attribute takes a single value on the
    split's test objects. ``majority``: plain accuracy of always answering the attribute's
    more frequent value among the split's training objects (the baseline plain accuracy must
    beat; its balanced accuracy is 0.5). ``*_ci95_low``/``*_ci95_high``: bootstrap over the
    split's test objects (:func:`tzsl.evaluation._trust.attribute_intervals`).
    """
    from tzsl.evaluation import attribute_intervals  # noqa: PLC0415

    rows = []
    for r in results:
        truth = r.K[r.y].astype(bool)  # (n, m)
        pred = r.P >= 0.5  # (n, s, m)
        correct = pred == truth[:, None, :]
        acc = correct.mean(axis=0)  # (s, m)
        majority = (truth == (r.train_prior >= 0.5)).mean(axis=0)  # (m,)
        bal = np.stack([per_attribute_balanced_accuracy(truth, pred[:, s, :]) for s in range(pred.shape[1])])
        # intervals within the split, over its test objects: per sensor, and for the sensor mean
        ivs = [attribute_intervals(c, truth, r.y, np.zeros(len(r.y)))
               for c in [*np.moveaxis(correct, 1, 0), correct.mean(axis=1)]]
        for j, attr in enumerate(r.attributes):
            for s, sensor in enumerate([*sensors, "mean"]):
                if sensor == "mean":
                    b = np.nanmean(bal[:, j]) if np.isfinite(bal[:, j]).any() else np.nan
                    a = acc[:, j].mean()
                else:
                    b, a = bal[s, j], acc[s, j]
                iv = ivs[s]
                rows.append({"split": split_label(r.split), "attribute": attr, "sensor": sensor,
                             "balanced_accuracy": b, "balanced_accuracy_ci95_low": iv["balanced_low"][j],
                             "balanced_accuracy_ci95_high": iv["balanced_high"][j], "accuracy": a,
                             "accuracy_ci95_low": iv["accuracy_low"][j], "accuracy_ci95_high": iv["accuracy_high"][j],
                             "majority": majority[j]})
    return pd.DataFrame(rows)


def attribute_accuracy_summary(per_split: pd.DataFrame, results: list[SplitPosteriors] | None = None,
                               paper: bool = False) -> pd.DataFrame:
    """Mean over splits of the sensor-averaged per-attribute scores, intervals, baselines, paper beside.

    Columns: attribute, balanced_accuracy (headline) and accuracy, each with
    ``_ci95_low``/``_ci95_high`` (two-level bootstrap over splits and test objects,
    :func:`tzsl.evaluation._trust.attribute_intervals`; needs ``results``), ``majority`` (the
    per-attribute majority baseline of ``accuracy``), ``majority_balanced_accuracy`` (0.5), and
    ``paper_accuracy`` (the paper's quoted values; only with ``paper``). Last row ``mean``:
    the mean over attributes.
    """
    from tzsl.evaluation import attribute_intervals  # noqa: PLC0415
    from tzsl.studies.papers.numbers import DAP_ATTRIBUTE_ACCURACY_QUOTED, DAP_MEAN_ATTRIBUTE_ACCURACY  # noqa: PLC0415

    mean_rows = per_split[per_split["sensor"] == "mean"]
    scores = ["balanced_accuracy", "accuracy", "majority"]
    summary = mean_rows.groupby("attribute", sort=False)[scores].mean().reset_index()
    overall = pd.DataFrame([{"attribute": "mean", **{c: summary[c].mean() for c in scores}}])
    summary = pd.concat([summary, overall], ignore_index=True)
    if results:
        attributes = list(summary["attribute"].iloc[:-1])
        correct, truth, classes, splits = [], [], [], []
        for r in results:
            cols = [r.attributes.index(a) if a in r.attributes else -1 for a in attributes]
            t = r.K[r.y].astype(float)
            c = ((r.P >= 0.5) == t[:, None, :].astype(bool)).mean(axis=1)
            missing = np.array(cols) < 0
            take = np.where(missing, 0, cols)
            correct.append(np.where(missing, np.nan, c[:, take]))
            truth.append(np.where(missing, np.nan, t[:, take]))
            classes.append(r.y)
            splits.append(np.full(len(r.y), split_label(r.split), dtype=object))
        iv = attribute_intervals(np.concatenate(correct), np.concatenate(truth), np.concatenate(classes),
                                 np.concatenate(splits))
        for name, key in (("balanced_accuracy", "balanced"), ("accuracy", "accuracy")):
            at = summary.columns.get_loc(name) + 1
            summary.insert(at, f"{name}_ci95_low", iv[f"{key}_low"])
            summary.insert(at + 1, f"{name}_ci95_high", iv[f"{key}_high"])
    summary["majority_balanced_accuracy"] = 0.5
    if paper:
        summary["paper_accuracy"] = summary["attribute"].map(DAP_ATTRIBUTE_ACCURACY_QUOTED)
        summary.loc[summary["attribute"] == "mean", "paper_accuracy"] = DAP_MEAN_ATTRIBUTE_ACCURACY
    return summary


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
    the mean and std over subsets, and ``split="mean"`` rows averaging the splits. Intervals
    (``ci95_low``/``ci95_high``) of ``accuracy_mean`` bootstrap test objects (and splits on the
    mean rows) with each trial's share of subsets that recognised it.
    """
    rng = np.random.default_rng(seed)
    rows = []
    outcomes = Outcomes(by=("n_attributes",))
    for r in results:
        m = len(r.attributes)
        for j in range(min_attributes, m + 1):
            subsets = attribute_subsets(m, j, max_subsets, rng)
            hits = dap_accuracy_over_subsets(r.P, r.K, r.y, subsets, fusion=fusion, prior=prior, per_trial=True)
            acc = hits.mean(axis=1)
            outcomes.add(split_label(r.split), "accuracy_mean", r.y, hits.mean(axis=0), n_attributes=j)
            rows.append({"split": split_label(r.split), "n_attributes": j, "n_subsets": len(subsets),
                         "accuracy_mean": acc.mean(), "accuracy_std": acc.std(), "chance": r.split.chance})
    table = pd.DataFrame(rows)
    mean = table.groupby("n_attributes", as_index=False).agg(
        n_subsets=("n_subsets", "sum"), accuracy_mean=("accuracy_mean", "mean"),
        accuracy_std=("accuracy_mean", "std"), chance=("chance", "mean"))
    mean.insert(0, "split", "mean")
    return add_trust_columns(pd.concat([table, mean], ignore_index=True), outcomes)


def table_titles(labels: StudyLabels) -> dict[str, str]:
    """Titles of the tables a run echoes (the paper's table names only beside its numbers)."""
    beside = " - ours beside the paper" if labels.paper else ""

    def named(paper_name: str, name: str) -> str:
        return paper_name if labels.paper else name

    return {
        "table1_fusion": f"{named('Table 1: ', '')}MAXDAP vs AVGDAP (uni-prior), random splits{beside}",
        "table2_priors": f"{named('Table 2: ', '')}AVGDAP by attribute prior, random splits{beside}",
        "table3_challenging": f"{named('Table 3: ', '')}challenging splits (MAXDAP and AVGDAP, uni-prior)"
                              + (" - the paper's mean beside ours" if labels.paper else ""),
        "multilabel": "Independent vs multi-label attribute classifiers (AVGDAP, uni-prior)",
        "attribute_accuracy": "Per-attribute test accuracy (mean over random splits and sensors)",
        labels.methods_table: "AVGDAP and every compared method on the same random splits (trial accuracy)",
        labels.comparison_table: "Methods vs AVGDAP (uni-prior) on the same random splits, 95% intervals",
        "gzsl": "Generalised zero-shot: seen / unseen per-class accuracy, harmonic mean (H)",
    }
