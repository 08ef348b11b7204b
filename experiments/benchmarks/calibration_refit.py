"""Calibration folds that keep the chosen hyper-parameters vs folds that search them again (issue 33, item 5).

The calibrated DAP rows of a study (AVGDAP and MAXDAP, uniform prior) get their temperature from
pseudo-unseen folds of the split's training objects
(:func:`tzsl.studies.comparison.calibration.dap_split_posteriors`). With ``calibration_refit="search"``
(the former behaviour) each fold refits every (attribute, sensor) classifier with its whole
hyper-parameter search; with ``"pinned"`` (the default) each fold refits it once with the ``C`` /
``gamma`` the split's fit chose (:func:`tzsl.models.detectors._attribute_bank.chosen_settings`). For each
seeded random split the study's attribute bank is fitted once (as ``tzsl run`` fits it, no cache)
and both calibrations are computed from it, so every difference is the calibration's alone.
Printed per split: the CPU seconds of each calibration and each temperature; at the end, per
DAP variant: ECE of each (two-level bootstrap 95% interval over splits and test objects), the
paired ECE difference (pinned minus search, the same bootstrap replicates for both), the paired
accuracy difference (0 by construction: a temperature keeps the ranking) and the CPU seconds.

``--method ensemble`` (issue 33, item 4) compares the same two for the registered ``ensemble``
(:class:`tzsl.models.ScoreEnsembleZSL`, calibrated as a whole, ``calibration_refit="pinned"``):
``search`` (``pin_members=False``) refits every member with its own search in each fold,
``pinned`` (``pin_members=True``) refits each member with the choice of the split's fit (the DAP
bank's ``C`` / ``gamma`` per classifier, ESZSL's ridges, SAE's ``lam``). Each split's members are
fitted once (the uncalibrated ensemble, into a temporary fit store) and read back by both calibrated
fits, so their CPU seconds are the folds' and the store's reads; the test trials' posteriors are
those of the calibrated ensemble as the method comparison fits it
(:func:`tzsl.studies.zero_shot.methods.fit_predict_split`, seed ``seed + split``). The rule,
written before any of these numbers was measured: pin the members by default if, on the selection
splits (PHAC-2, 5 random splits of seed 0, purpose ``select``), the paired ECE difference pinned
minus search has its 95% interval's upper end at most 0.02 and the calibration CPU seconds fall by
at least a third; the numbers shown are those of 5 random confirmation splits of seed 1 (purpose
``confirm``).

Data sets:

* ``--data phac2``: PHAC-2 (Penn features), the phac2-evidence study's settings (its ``[svm]``
  grid is the paper's, 5 object-grouped folds, successive halving), exact attribute SVMs;
* ``--data simulated``: SIMULATED trials of :func:`tzsl.datasets.synthetic_dataset_arrays`
  (60 classes, 30 attributes, 2 sensors; ``--trials``), the schema's default settings; with
  ``--solver approximate`` the large-data attribute model of ``make bench-scale``.

Run (confirmation splits: seed 1; the choice was made before any of these were seen)::

    export TZSL_DATA_DIR=/path/to/data
    nice -n 10 python experiments/benchmarks/calibration_refit.py --data phac2 --seed 1 --n-splits 5
    nice -n 10 python experiments/benchmarks/calibration_refit.py --data simulated --trials 2400 --seed 1 --n-splits 3
    nice -n 10 python experiments/benchmarks/calibration_refit.py --data simulated --trials 2400 --solver approximate \\
        --seed 1 --n-splits 3

    nice -n 10 python experiments/benchmarks/calibration_refit.py --data phac2 --method ensemble --seed 0 \
        --purpose select --n-splits 5 --out DIR
    nice -n 10 python experiments/benchmarks/calibration_refit.py --data phac2 --method ensemble --seed 1 \
        --purpose confirm --n-splits 5 --out DIR

``--out DIR`` writes ``calibration_refit_trials_<tag>.csv`` (one row per refit, variant and test
trial) and ``calibration_refit_summary_<tag>.csv`` (one row per variant; ``<tag>`` names the data,
the method for ``ensemble``, the purpose when given and the seed).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from tzsl.cache import CACHE_DIR_ENV
from tzsl.datasets import write_synthetic_dataset
from tzsl.evaluation import (
    DEFAULT_N_BINS,
    PURPOSES,
    bootstrap_cell_weights,
    calibration_intervals,
    calibration_terms,
    cluster_cells,
    equal_mass_bins,
    expected_calibration_error,
    paired_difference_interval,
)
from tzsl.features import dataset_features, load_plain_dataset
from tzsl.files import atomic_write
from tzsl.models.calibration import CALIBRATION_REFITS
from tzsl.studies.comparison.calibration import dap_split_posteriors
from tzsl.studies.comparison.method_runs import split_masks
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.methods import fit_predict_split
from tzsl.studies.zero_shot.study import fit_split, make_splits

#: The phac2-evidence study's attribute SVM settings (tzsl/studies/builtin/phac2_evidence.toml).
PHAC2_EVIDENCE_SVM = {"cv": 5, "undersampling": "select", "grid": "paper", "n_draws": 3, "search": "halving"}
VARIANTS = ("dap-avg", "dap-max")
#: The registry method of ``--method ensemble``.
ENSEMBLE = "ensemble"
#: The rule of ``--method ensemble``, fixed before measuring (written into its summary, read by its README block):
#: pin the members by default if on the selection splits the upper end of the paired ECE difference's 95%
#: interval is at most this ...
RULE_MAX_ECE_DIFFERENCE = 0.02
#: ... and the calibration CPU falls by at least this share.
RULE_MIN_CPU_SAVING = 1 / 3


def features_and_settings(data: str, trials: int, seed: int, n_splits: int, solver: str, work: Path,
                          purpose: str | None = None):
    """The FeatureSet and the study settings of one benchmark data set (``purpose``: the schema's default if None)."""
    compute = {"cache": False, "progress": False, "n_jobs": 1}
    splits = {"n_splits": n_splits, "seed": seed, "n_test": 10, **({"purpose": purpose} if purpose else {})}
    if data == "phac2":
        return dataset_features("phac2-penn"), ZeroShotSettings.of_preset("phac2-dap", splits=splits, compute=compute,
                                                                           svm=PHAC2_EVIDENCE_SVM)
    folder = work / f"synthetic_{trials}"
    write_synthetic_dataset(folder, trials, seed=0)
    return load_plain_dataset(folder), ZeroShotSettings(splits=splits, compute=compute, svm={"solver": solver})


def paired_ece_difference(conf_a, conf_b, correct, classes, splits, n_boot: int = 2000) -> tuple[float, float, float]:
    """ECE(a) - ECE(b) on the same trials, with a 95% interval from the same two-level bootstrap replicates.

    Each posterior keeps its own equal-mass bins (as its ECE has them); a replicate re-weights the
    (split, test object) cells of both. Returns ``(difference, ci95_low, ci95_high)``.
    """
    cell = cluster_cells(classes, splits)[0]
    n_cells = int(cell.max()) + 1
    counts = np.bincount(cell, minlength=n_cells).astype(float)
    gaps = []
    for c in (conf_a, conf_b):
        bins = equal_mass_bins(c, DEFAULT_N_BINS)
        n_used = int(bins.max()) + 1
        gaps.append(np.bincount(cell * n_used + bins, weights=correct - c,
                                minlength=n_cells * n_used).reshape(n_cells, n_used))
    reps = []
    for w in bootstrap_cell_weights(classes, splits, n_boot=n_boot, random_state=0):
        total = w @ counts
        reps.append(np.abs(w @ gaps[0]).sum(axis=1) / total - np.abs(w @ gaps[1]).sum(axis=1) / total)
    point = expected_calibration_error(conf_a, correct) - expected_calibration_error(conf_b, correct)
    low, high = np.quantile(np.concatenate(reps), [0.025, 0.975])
    return float(point), float(low), float(high)


def run(features, config, label: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per-trial terms of both calibrations on every split, and the per-variant summary."""
    splits, _ = make_splits(features, "random", config)
    rows = []
    for i, split in enumerate(splits):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = fit_split(features, split, config, i)
        train, _ = split_masks(features, split)
        A = features.attributes.loc[features.objects[train], list(r.attributes)].to_numpy(dtype=int)
        for refit in CALIBRATION_REFITS:
            start = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = dap_split_posteriors(r, features.X[train], A, features.objects[train],
                                           seed=config.splits.seed + i, refit=refit)
            cpu = time.process_time() - start
            for variant in VARIANTS:
                proba, _, t = out[variant]
                rows += trial_rows(label, i, refit, variant, proba, r.y, t, cpu)
            print(f"{label} split {i} {refit:6s} calibration cpu {cpu:6.1f} s  T(avg) {out['dap-avg'][2]:.3f}  "
                  f"T(max) {out['dap-max'][2]:.3f}", flush=True)
    return summarise(pd.DataFrame(rows), label, len(splits))


def trial_rows(label: str, split: int, refit: str, variant: str, proba: np.ndarray, y: np.ndarray,
               temperature: float, cpu: float, predicted: np.ndarray | None = None) -> list[dict]:
    """One row per test trial of one calibrated posterior (the columns :func:`summarise` reads)."""
    predicted = proba.argmax(axis=1) if predicted is None else predicted
    terms = calibration_terms(proba, y, predicted=predicted)
    return [{"data": label, "split": split, "refit": refit, "variant": variant, "trial": k, "class": int(y[k]),
             "correct": float(predicted[k] == y[k]), "confidence": terms.confidence[k], "brier": terms.brier[k],
             "temperature": temperature, "cpu_s": cpu} for k in range(len(y))]


def run_ensemble(features, config, label: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per-trial terms of the calibrated ensemble with each ``calibration_refit`` on every split, and the summary.

    The members' fits on all training trials are computed once per split (the uncalibrated ensemble, into a
    temporary fit store) and read back by both calibrated fits, so each one's CPU seconds are its folds'.
    """
    splits, _ = make_splits(features, "random", config)
    rows = []
    before = os.environ.get(CACHE_DIR_ENV)
    with tempfile.TemporaryDirectory() as store:
        os.environ[CACHE_DIR_ENV] = store
        try:
            for i, split in enumerate(splits):
                seed = config.splits.seed + i
                start = time.process_time()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    bare, _ = fit_predict_split({"name": ENSEMBLE, "calibration": "none"}, features, split, seed)
                members_cpu = time.process_time() - start
                for refit in CALIBRATION_REFITS:  # the calibrator's default refit; the ensemble pins its members or not
                    start = time.process_time()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        fit, y = fit_predict_split({"name": ENSEMBLE, "pin_members": refit == "pinned"}, features,
                                                   split, seed)
                    cpu = time.process_time() - start
                    if not np.array_equal(fit.predicted, bare.predicted):
                        raise AssertionError(f"split {i}: the calibrated ensemble ranks differently from its fit")
                    t = fit.model.temperature_
                    rows += trial_rows(label, i, refit, ENSEMBLE, fit.proba, y, t, cpu, predicted=fit.predicted)
                    print(f"{label} split {i} {refit:6s} members' fit cpu {members_cpu:6.1f} s, calibration cpu "
                          f"{cpu:6.1f} s  T {t:.3f}", flush=True)
        finally:
            if before is None:
                os.environ.pop(CACHE_DIR_ENV, None)
            else:
                os.environ[CACHE_DIR_ENV] = before
    return summarise(pd.DataFrame(rows), label, len(splits))


def summarise(table: pd.DataFrame, label: str, n_splits: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(table, summary)``: one summary row per variant, pinned against search on the same trials."""
    summary = []
    for variant, t in table.groupby("variant", sort=False):
        wide = {refit: g.sort_values(["split", "trial"]) for refit, g in t.groupby("refit")}
        a, b = wide["pinned"], wide["search"]
        cls, spl = a["class"].to_numpy(), a["split"].to_numpy()
        row = {"data": label, "variant": variant, "n_splits": n_splits, "n_trials": len(a)}
        for refit, g in wide.items():
            iv = calibration_intervals(g["confidence"], g["correct"], g["brier"], classes=cls, splits=spl)["ece"]
            row.update({f"{refit}_ece": iv.mean, f"{refit}_ece_ci95_low": iv.ci95_low,
                        f"{refit}_ece_ci95_high": iv.ci95_high, f"{refit}_accuracy": g["correct"].mean(),
                        f"{refit}_cpu_s": g.groupby("split")["cpu_s"].first().sum()})
        d = paired_ece_difference(a["confidence"].to_numpy(), b["confidence"].to_numpy(), a["correct"].to_numpy(),
                                  cls, spl)
        acc = paired_difference_interval(a["correct"].to_numpy(), b["correct"].to_numpy(), classes=cls, splits=spl)
        row.update({"ece_difference": d[0], "ece_difference_ci95_low": d[1], "ece_difference_ci95_high": d[2],
                    "accuracy_difference": acc.mean, "accuracy_difference_ci95_low": acc.ci95_low,
                    "accuracy_difference_ci95_high": acc.ci95_high})
        summary.append(row)
    return table, pd.DataFrame(summary)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", choices=["phac2", "simulated"], default="phac2")
    ap.add_argument("--trials", type=int, default=2400, help="SIMULATED trials (--data simulated)")
    ap.add_argument("--solver", choices=["auto", "exact", "approximate"], default="auto",
                    help="attribute solver of --data simulated")
    ap.add_argument("--seed", type=int, default=1, help="split seed (1: confirmation splits)")
    ap.add_argument("--n-splits", type=int, default=5)
    ap.add_argument("--method", choices=["dap", ENSEMBLE], default="dap",
                    help="the study's calibrated DAP rows (default) or the registered ensemble (--data phac2)")
    ap.add_argument("--purpose", choices=PURPOSES, default=None,
                    help="random splits that make a choice (select) or report it (confirm); default: the schema's")
    ap.add_argument("--out", type=Path, default=None, help="folder for the per-trial and summary CSVs")
    args = ap.parse_args()
    if args.method == ENSEMBLE and args.data != "phac2":
        ap.error("--method ensemble runs on --data phac2")
    label = "phac2" if args.data == "phac2" else f"SIMULATED-{args.trials}-{args.solver}"
    with tempfile.TemporaryDirectory() as work:
        features, config = features_and_settings(args.data, args.trials, args.seed, args.n_splits, args.solver,
                                                 Path(work), args.purpose)
        with threadpool_limits(limits=1):  # CPU seconds of one core (idle BLAS threads would spin on a busy machine)
            table, summary = (run_ensemble if args.method == ENSEMBLE else run)(features, config, label)
    for s in summary.to_dict("records"):
        print(f"{label} {s['variant']}: ECE pinned {s['pinned_ece']:.4f} [{s['pinned_ece_ci95_low']:.4f}, "
              f"{s['pinned_ece_ci95_high']:.4f}], search {s['search_ece']:.4f} [{s['search_ece_ci95_low']:.4f}, "
              f"{s['search_ece_ci95_high']:.4f}]; pinned - search {s['ece_difference']:+.4f} "
              f"[{s['ece_difference_ci95_low']:+.4f}, {s['ece_difference_ci95_high']:+.4f}]; accuracy "
              f"{s['pinned_accuracy']:.3f} vs {s['search_accuracy']:.3f} (difference {s['accuracy_difference']:+.4f} "
              f"[{s['accuracy_difference_ci95_low']:+.4f}, {s['accuracy_difference_ci95_high']:+.4f}]); calibration "
              f"CPU pinned {s['pinned_cpu_s']:.1f} s, search {s['search_cpu_s']:.1f} s "
              f"(seed {args.seed}, {s['n_splits']} splits)")
    if args.out:
        write_results(table, summary, args.out, label=label, method=args.method, purpose=config.splits.purpose,
                      seed=args.seed, name_purpose=bool(args.purpose))


def write_results(table: pd.DataFrame, summary: pd.DataFrame, out: Path, *, label: str, method: str, purpose: str,
                  seed: int, name_purpose: bool = True,
                  max_ece_difference: float = RULE_MAX_ECE_DIFFERENCE) -> pd.DataFrame:
    """Write the per-trial ``table`` and :func:`summarise`'s ``summary`` (with the run's ``method``, ``purpose``,
    ``seed`` and the rule's thresholds) into ``out`` as ``calibration_refit_{trials,summary}_<tag>.csv``.

    ``<tag>``: ``label``, ``ensemble`` for the ensemble, ``purpose`` when ``name_purpose`` (a run that named its
    purpose), ``seed<seed>``: the names the benchmark README's block reads. Returns the summary as written.
    """
    out.mkdir(parents=True, exist_ok=True)
    tag = "_".join([label] + ([ENSEMBLE] if method == ENSEMBLE else []) + ([purpose] if name_purpose else [])
                   + [f"seed{seed}"])
    summary = summary.assign(method=method, purpose=purpose, seed=seed, rule_max_ece_difference=max_ece_difference,
                             rule_min_cpu_saving=RULE_MIN_CPU_SAVING)
    atomic_write(out / f"calibration_refit_trials_{tag}.csv", lambda p: table.to_csv(p, index=False))
    atomic_write(out / f"calibration_refit_summary_{tag}.csv", lambda p: summary.to_csv(p, index=False))
    return summary


if __name__ == "__main__":
    main()
