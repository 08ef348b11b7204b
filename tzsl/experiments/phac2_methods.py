"""Registry methods vs DAP on the same PHAC-2 splits (``phac2_methods.csv``, ``method_comparison.csv``).

Every method of ``[methods]`` (``eszsl``, ``embedding`` and ``compare``, see
:meth:`~tzsl.experiments.config.Phac2Methods.method_specs`) is fitted on each random split's
training objects with :func:`tzsl.experiments.study_methods.fit_predict` and scored on the
split's test trials. The reference is the paper's method, AVGDAP with a uniform prior, read
from the already fitted DAP posteriors (no refit).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, bootstrap_accuracy, paired_differences_table, summarise_over_splits
from tzsl.experiments._failures import ERROR_COLUMN, attempt
from tzsl.experiments.phac2_tables import split_label
from tzsl.experiments.study_methods import fit_predict, method_label

if TYPE_CHECKING:
    from tzsl.experiments.phac2_dap import SplitPosteriors

__all__ = ["DEFAULT_METHODS", "REFERENCE_METHOD", "method_comparison", "method_summary"]

#: Methods compared when none are given: ESZSL and the embedding model at lambda 0.1 and 1.
DEFAULT_METHODS: tuple[dict, ...] = ({"name": "eszsl"}, {"name": "embedding", "lam": 0.1},
                                     {"name": "embedding", "lam": 1.0})
#: Row label of the paper's method (AVGDAP, uniform prior) in ``method_comparison.csv``.
REFERENCE_METHOD = "dap-avg"


def _fit_predict_split(spec: dict, features: FeatureSet, split: Split, seed: int):
    """Fit on the split's training objects; (fit, true test rows)."""
    from tzsl.experiments.phac2_dap import split_masks  # noqa: PLC0415 - phac2_dap re-exports this module

    attributes = list(split.kept_attributes)
    train, test = split_masks(features, split)
    objects = features.objects
    class_rows = features.attributes.loc[np.unique(objects[train]), attributes].to_numpy(dtype=float)
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=float)
    fit = fit_predict(spec, features.X[train], objects[train], class_rows, features.X[test], K, seed)
    y = pd.Index(split.test_objects).get_indexer(objects[test])
    return fit, y


def _trials(method: str, split: str, objects: np.ndarray, correct: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"method": method, "split": split, "class": objects,
                         "trial": np.arange(len(objects)), "correct": correct.astype(float)})


def method_summary(trials: pd.DataFrame, fit_seconds: dict[str, list[float]], chance: float,
                   reference: str = REFERENCE_METHOD) -> pd.DataFrame:
    """One row per method: accuracy with its 95% interval, fit time, paired difference to ``reference``.

    Parameters
    ----------
    trials : DataFrame
        One row per (method, test trial): method, split, class, trial, correct (0/1).
    fit_seconds : dict
        Wall-clock seconds of every fit, per method.
    chance : float
        Mean over splits of 1 / test classes.

    Returns
    -------
    DataFrame
        Columns method, accuracy (mean over splits of the per-split trial accuracy), ci95_low,
        ci95_high (two-level bootstrap over splits then test objects with their trials), chance,
        fit_seconds (mean per split), difference (method minus ``reference`` on the same trials),
        difference_ci95_low, difference_ci95_high, reference, n_splits, n_trials.
    """
    rows = []
    for method, t in trials.groupby("method", sort=False):
        iv = bootstrap_accuracy(t["correct"].to_numpy(), classes=t["class"].to_numpy(), splits=t["split"].to_numpy())
        rows.append({"method": method, "accuracy": iv.mean, "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high,
                     "chance": chance, "fit_seconds": float(np.mean(fit_seconds[method])),
                     "n_splits": t["split"].nunique(), "n_trials": len(t)})
    table = pd.DataFrame(rows)
    diffs = _paired_differences(trials, reference).rename(
        columns={"ci95_low": "difference_ci95_low", "ci95_high": "difference_ci95_high"})
    table = table.merge(diffs[["method", "difference", "difference_ci95_low", "difference_ci95_high"]],
                        on="method", how="left")
    table["reference"] = reference
    columns = ["method", "accuracy", "ci95_low", "ci95_high", "chance", "fit_seconds", "difference",
               "difference_ci95_low", "difference_ci95_high", "reference", "n_splits", "n_trials"]
    return table[columns]


def _paired_differences(trials: pd.DataFrame, reference: str) -> pd.DataFrame:
    """Each method minus ``reference`` on the splits that method completed (a failed fit drops a split)."""
    parts = []
    for method in [m for m in trials["method"].unique() if m != reference]:
        splits = trials.loc[trials["method"] == method, "split"].unique()
        pair = trials[trials["method"].isin([method, reference]) & trials["split"].isin(splits)]
        parts.append(paired_differences_table(pair, reference=reference))
    columns = ["method", "difference", "ci95_low", "ci95_high"]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=columns)


def method_comparison(features: FeatureSet, results: list[SplitPosteriors], seed: int = 0,
                      methods: tuple[dict, ...] | list[dict] = DEFAULT_METHODS) -> dict[str, pd.DataFrame]:
    """Registry methods and AVGDAP on the same PHAC-2 splits (trial accuracy).

    Each method entry ``{"name": ..., **parameters}`` is built from the registry; a method
    taking a seed gets ``seed + i`` on split ``i``. Objects sharing an attribute row are merged
    into one training class by the methods that merge duplicates (ESZSL, the embedding model).

    Returns
    -------
    dict of DataFrame
        ``"phac2_methods"``: one row per split (dap_avg_uni and one column per method label,
        e.g. ``eszsl``, ``embedding_lam_0.1``; NaN where that fit failed, the reason in the
        ``error`` column), then mean and std rows;
        ``"method_comparison"``: :func:`method_summary` with ``dap-avg`` as the reference.
    """
    rows, trials = [], []
    seconds: dict[str, list[float]] = {REFERENCE_METHOD: []}
    for i, r in enumerate(results):
        label = split_label(r.split)
        objects = np.asarray(r.split.test_objects)[r.y]
        row = {"split": label, "chance": r.split.chance, "dap_avg_uni": r.accuracy("avg", "uni")}
        trials.append(_trials(REFERENCE_METHOD, label, objects, r.predict("avg", "uni") == r.y))
        seconds[REFERENCE_METHOD].append(r.fit_seconds)
        errors = []
        for spec in methods:
            name = method_label(spec)
            done, error = attempt(_fit_predict_split, spec, features, r.split, seed + i)
            if done is None:  # NaN for this (split, method), reported at the end of the run
                row[name] = np.nan
                errors.append(f"{name}: {error}")
                continue
            fit, y = done
            correct = fit.predicted == y
            row[name] = float(correct.mean())
            trials.append(_trials(name, label, objects, correct))
            seconds.setdefault(name, []).append(fit.fit_seconds)
        rows.append({**row, ERROR_COLUMN: "; ".join(errors)})
    per_split = summarise_over_splits(pd.DataFrame(rows)).reset_index()
    chance = float(np.mean([r.split.chance for r in results]))
    return {"phac2_methods": per_split,
            "method_comparison": method_summary(pd.concat(trials, ignore_index=True), seconds, chance)}
