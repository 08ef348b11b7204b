"""Headline evidence of the PHAC-2 study: DAP fusion x prior with paired differences, and the seed-refit spread.

Two tables beside Tables 1-3 and the method comparison (:func:`tzsl.studies.zero_shot.study.run_zero_shot_tables`):

* ``dap_fusion_prior.csv``: every DAP fusion x attribute prior on every split kind run, scored
  like the method comparison (:func:`tzsl.studies.comparison.method_runs.method_summary`): accuracy
  with its two-level bootstrap interval, the paired difference to AVGDAP with the uniform prior
  (``dap-avg``) on the same trials with its interval, and the spreads below;
* ``refit_accuracy.csv`` (``[splits] refit_seeds`` > 0): the accuracy of every DAP variant and
  compared method on the first ``refit_splits`` splits of each kind, fitted again with
  ``refit_seeds`` other model seeds (attribute SVMs' CV shuffles and under-sampling draws, seeded
  methods' own randomness); the split (train/test objects) stays the same. ``refit = 0`` is the
  study's own fit.

``sd_over_splits`` (standard deviation of the per-split accuracy over splits) and
``sd_over_refit_seeds`` (pooled within-split standard deviation over model seeds, the square root
of the mean over refitted splits of the variance over seeds; :func:`add_refit_spread`) stand side
by side in both tables and in the method comparison: a difference between two methods smaller
than the refit spread is noise of the fit, not of the split.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet
from tzsl.studies.comparison.calibration import CALIBRATION_COLUMNS
from tzsl.studies.comparison.method_runs import comparison_trials, method_summary
from tzsl.studies.config import dap_label, method_label
from tzsl.studies.outputs.failures import ERROR_COLUMN, attempt
from tzsl.studies.papers.run_labels import StudyLabels
from tzsl.studies.zero_shot.methods import fit_predict_split, method_comparison, study_detector
from tzsl.studies.zero_shot.tables import split_label
from tzsl.value_lists import FUSIONS, PRIORS

if TYPE_CHECKING:
    from tzsl.evaluation import Split
    from tzsl.studies.zero_shot.split_posteriors import SplitPosteriors

__all__ = ["FUSION_PRIOR_TABLE", "REFIT_TABLE", "add_refit_spread", "dap_fusion_prior",
           "evidence_tables", "model_seed", "refit_accuracy"]

#: File stems of the two tables.
FUSION_PRIOR_TABLE = "dap_fusion_prior"
REFIT_TABLE = "refit_accuracy"


def model_seed(seed: int, index: int, refit: int = 0) -> int:
    """The model seed of split ``index`` (``refit`` 0: the study's own fit; k > 0: its k-th refit).

    Parameters
    ----------
    seed : int
        The study's seed (``[splits] seed``).
    index : int
        Position of the split among the study's fits (challenging splits start at 100).
    refit : int
        0 for the study's fit, 1, 2, ... for the refits.

    Returns
    -------
    int
        Independent streams per (seed, index, refit) from :class:`numpy.random.SeedSequence`.
    """
    entropy = [seed, index] + ([refit] if refit else [])
    return int(np.random.SeedSequence(entropy).generate_state(1)[0])


def _variant_accuracies(r: SplitPosteriors, fusions, priors) -> dict[str, float]:
    detector = study_detector([r])
    return {dap_label(f, detector, prior=p): r.accuracy(f, p) for f in fusions for p in priors}


def dap_fusion_prior(by_kind: dict[str, list[SplitPosteriors]], fusions, priors,
                     labels: StudyLabels) -> pd.DataFrame:
    """Every DAP fusion x prior on every split kind, with the paired difference to ``dap-avg``.

    Parameters
    ----------
    by_kind : dict
        Split kind (``random``, ``challenging``) -> the fitted splits of that kind.
    fusions, priors : sequence of str
        The reference (``avg`` with ``uni``) is always scored, first.
    labels : StudyLabels
        ``study`` and ``data`` columns.

    Returns
    -------
    DataFrame
        The columns of :data:`~tzsl.studies.comparison.method_runs.COMPARISON_COLUMNS` with ``fusion``
        and ``prior`` after ``method``, less the paper, grid-edge and calibration columns; one
        row per (split kind, fusion, prior), ``dap-avg`` (the reference) first.
    """
    fusions = ["avg", *[f for f in fusions if f != "avg"]]
    priors = ["uni", *[p for p in priors if p != "uni"]]
    blocks = []
    for kind, results in by_kind.items():
        if not results:
            continue
        detector = study_detector(results)
        variants = {dap_label(f, detector, prior=p): (f, p) for f in fusions for p in priors}
        trials = [comparison_trials(label, split_label(r.split), np.asarray(r.split.test_objects)[r.y],
                                    r.predict(f, p) == r.y) for r in results for label, (f, p) in variants.items()]
        seconds = {label: [r.fit_seconds for r in results] for label in variants}
        chance = float(np.mean([r.split.chance for r in results]))
        table = method_summary(pd.concat(trials, ignore_index=True), seconds, chance, dap_label("avg", detector),
                               study=labels.study, data=labels.data, split_kind=kind)
        table.insert(4, "fusion", table["method"].map({v: f for v, (f, _) in variants.items()}))
        table.insert(5, "prior", table["method"].map({v: p for v, (_, p) in variants.items()}))
        blocks.append(table.drop(columns=["paper_accuracy", "share_at_grid_edge", *CALIBRATION_COLUMNS]))
    return pd.concat(blocks, ignore_index=True) if blocks else pd.DataFrame()


def refit_accuracy(features: FeatureSet, by_kind: dict[str, tuple[list[SplitPosteriors], int]],
                   refit: Callable[[Split, int, int], SplitPosteriors], *, seed: int, n_seeds: int,
                   n_splits: int | None, fusions, priors, methods: dict[str, list[dict]]) -> pd.DataFrame:
    """Accuracy of every DAP variant and method on the same splits, refitted with other model seeds.

    Parameters
    ----------
    features : FeatureSet
    by_kind : dict
        Split kind -> (its fitted splits, the index offset of its model seeds: 0 random, 100
        challenging, as the study fits them).
    refit : callable
        ``refit(split, index, k)``: the split's attribute models fitted with the k-th refit seed
        (:func:`tzsl.studies.zero_shot.study.fit_split` with ``refit=k``).
    seed : int
        The study's seed (the compared methods get ``seed + offset + i`` in the study's own fit).
    n_seeds : int
        Refit seeds per split (k = 1 .. n_seeds).
    n_splits : int or None
        Splits of each kind refitted, the first ones (None: all).
    fusions, priors : sequence of str
        The DAP variants scored (:func:`~tzsl.studies.config.dap_label`).
    methods : dict
        Split kind -> the method entries compared on it (none: DAP only).

    Returns
    -------
    DataFrame
        ``split_kind, split, method, refit, model_seed, accuracy, error``; ``refit = 0`` rows are
        the study's own fits (the compared methods' are read back from the fit store when it holds
        them). A fit that fails has NaN accuracy and its reason in ``error`` (method ``dap``: the
        attribute models' refit).
    """
    rows = []
    for kind, (results, offset) in by_kind.items():
        for i, r in enumerate(results[:n_splits]):
            base = {"split_kind": kind, "split": split_label(r.split)}
            for k in range(n_seeds + 1):
                dap_seed = model_seed(seed, offset + i, k)
                fitted, error = (r, "") if k == 0 else attempt(refit, r.split, offset + i, k)
                scored = _variant_accuracies(fitted, fusions, priors) if fitted is not None else {"dap": np.nan}
                rows += [{**base, "method": name, "refit": k, "model_seed": dap_seed, "accuracy": acc,
                          ERROR_COLUMN: error} for name, acc in scored.items()]
                method_seed = seed + offset + i if k == 0 else dap_seed  # k = 0: the study's own seed
                for spec in methods.get(kind, []):
                    done, error = attempt(fit_predict_split, spec, features, r.split, method_seed)
                    acc = np.nan if done is None else float((done[0].predicted == done[1]).mean())
                    rows.append({**base, "method": method_label(spec), "refit": k, "model_seed": method_seed,
                                 "accuracy": acc, ERROR_COLUMN: error})
    return pd.DataFrame(rows, columns=["split_kind", "split", "method", "refit", "model_seed", "accuracy",
                                       ERROR_COLUMN])


def add_refit_spread(table: pd.DataFrame, refits: pd.DataFrame | None) -> pd.DataFrame:
    """``table`` with ``sd_over_refit_seeds`` of each (split kind, method) from :func:`refit_accuracy` rows.

    The pooled within-split standard deviation: the square root of the mean, over the refitted
    splits, of the variance (ddof 1) of the accuracy over that split's model seeds. NaN where a
    method has no split with two fits.
    """
    if refits is None or refits.empty or table.empty:
        return table
    var = refits.groupby(["split_kind", "method", "split"], sort=False)["accuracy"].var(ddof=1).dropna()
    pooled = np.sqrt(var.groupby(level=["split_kind", "method"], sort=False).mean()).rename("pooled")
    out = table.drop(columns="sd_over_refit_seeds").merge(pooled.reset_index(), on=["split_kind", "method"],
                                                          how="left")
    out = out.rename(columns={"pooled": "sd_over_refit_seeds"})
    return out[list(table.columns)]


def evidence_tables(features: FeatureSet, by_kind: dict[str, tuple[list[SplitPosteriors], int]], *, seed: int,
                    labels: StudyLabels, methods: list[dict], compare_on, refit_seeds: int,
                    refit_splits: int | None, refit: Callable[[Split, int, int], SplitPosteriors], purpose: str = "",
                    n_jobs: int = 1, per_class: dict[str, pd.DataFrame] | None = None) -> dict[str, pd.DataFrame]:
    """The method comparison on each split kind of ``compare_on``, the fusion x prior table and the refit spread.

    Parameters
    ----------
    features : FeatureSet
    by_kind : dict
        Split kind (``random``, ``challenging``; ``file`` for a split file, compared like
        ``random``) -> (its fitted splits, the index offset of its model seeds).
    seed : int
        The study's seed.
    labels : StudyLabels
    methods : list of dict
        Registry method entries compared with DAP (empty: no method comparison).
    compare_on : sequence of {"random", "challenging"}
    refit_seeds, refit_splits, refit
        See :func:`refit_accuracy` (``refit_seeds = 0``: no refits, ``sd_over_refit_seeds`` NaN).
    per_class : dict, optional
        Filled by each compared kind's :func:`~tzsl.studies.zero_shot.methods.method_comparison`.

    Returns
    -------
    dict of DataFrame
        ``labels.methods_table``, ``labels.comparison_table`` and ``labels.reliability_table``
        (:func:`~tzsl.studies.zero_shot.methods.method_comparison` of each compared kind, stacked,
        column ``split_kind``) when ``methods``; :data:`FUSION_PRIOR_TABLE`; :data:`REFIT_TABLE`
        when ``refit_seeds``.
    """
    compared = {kind: [dict(m) for m in methods] for kind, (results, _) in by_kind.items()
                if results and methods and ("random" if kind == "file" else kind) in compare_on}
    parts = [method_comparison(features, by_kind[kind][0], seed=seed + by_kind[kind][1], methods=specs,
                               labels=labels, purpose=purpose, split_kind=kind, n_jobs=n_jobs, per_class=per_class)
             for kind, specs in compared.items()]
    tables = {name: pd.concat([p[name] for p in parts], ignore_index=True) for name in (parts[0] if parts else {})}
    fitted = {kind: results for kind, (results, _) in by_kind.items() if results}
    tables[FUSION_PRIOR_TABLE] = dap_fusion_prior(fitted, FUSIONS, PRIORS, labels)
    if refit_seeds:
        refits = refit_accuracy(features, {k: v for k, v in by_kind.items() if v[0]}, refit, seed=seed,
                                n_seeds=refit_seeds, n_splits=refit_splits, fusions=FUSIONS, priors=PRIORS,
                                methods=compared)
        tables[REFIT_TABLE] = refits
        for name in (FUSION_PRIOR_TABLE, labels.comparison_table):
            if name in tables:
                tables[name] = add_refit_spread(tables[name], refits)
    return tables
