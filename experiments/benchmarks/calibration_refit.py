"""Calibration folds that keep the chosen hyper-parameters vs folds that search them again (issue 33, item 5).

The calibrated DAP rows of a study (AVGDAP and MAXDAP, uniform prior) get their temperature from
pseudo-unseen folds of the split's training objects
(:func:`tzsl.studies.study_calibration.dap_split_posteriors`). With ``calibration_refit="search"``
(the former behaviour) each fold refits every (attribute, sensor) classifier with its whole
hyper-parameter search; with ``"pinned"`` (the default) each fold refits it once with the ``C`` /
``gamma`` the split's fit chose (:func:`tzsl.models._attribute_bank.chosen_settings`). For each
seeded random split the study's attribute bank is fitted once (as ``tzsl run`` fits it, no cache)
and both calibrations are computed from it, so every difference is the calibration's alone.
Printed per split: the CPU seconds of each calibration and each temperature; at the end, per
DAP variant: ECE of each (two-level bootstrap 95% interval over splits and test objects), the
paired ECE difference (pinned minus search, the same bootstrap replicates for both), the paired
accuracy difference (0 by construction: a temperature keeps the ranking) and the CPU seconds.

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

``--out DIR`` writes ``calibration_refit_trials_<tag>.csv`` (one row per refit, variant and test
trial) and ``calibration_refit_summary_<tag>.csv`` (one row per variant).
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl._io import atomic_write
from tzsl.datasets import write_synthetic_dataset
from tzsl.evaluation import (
    DEFAULT_N_BINS,
    bootstrap_cell_weights,
    calibration_intervals,
    calibration_terms,
    cluster_cells,
    equal_mass_bins,
    expected_calibration_error,
    paired_difference_interval,
)
from tzsl.features import dataset_features, load_plain_dataset
from tzsl.models.calibration import CALIBRATION_REFITS
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.study_calibration import dap_split_posteriors
from tzsl.studies.study_methods import split_masks
from tzsl.studies.zero_shot.study import fit_split, make_splits

#: The phac2-evidence study's attribute SVM settings (tzsl/studies/builtin/phac2_evidence.toml).
PHAC2_EVIDENCE_SVM = {"cv": 5, "undersampling": "select", "grid": "paper", "n_draws": 3, "search": "halving"}
VARIANTS = ("dap-avg", "dap-max")


def features_and_settings(data: str, trials: int, seed: int, n_splits: int, solver: str, work: Path):
    """The FeatureSet and the study settings of one benchmark data set."""
    compute = {"cache": False, "progress": False, "n_jobs": 1}
    splits = {"n_splits": n_splits, "seed": seed, "n_test": 10}
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
                predicted = proba.argmax(axis=1)
                terms = calibration_terms(proba, r.y, predicted=predicted)
                rows += [{"data": label, "split": i, "refit": refit, "variant": variant, "trial": k,
                          "class": int(r.y[k]), "correct": float(predicted[k] == r.y[k]),
                          "confidence": terms.confidence[k], "brier": terms.brier[k], "temperature": t, "cpu_s": cpu}
                         for k in range(len(r.y))]
            print(f"{label} split {i} {refit:6s} calibration cpu {cpu:6.1f} s  T(avg) {out['dap-avg'][2]:.3f}  "
                  f"T(max) {out['dap-max'][2]:.3f}", flush=True)
    table = pd.DataFrame(rows)
    summary = []
    for variant, t in table.groupby("variant", sort=False):
        wide = {refit: g.sort_values(["split", "trial"]) for refit, g in t.groupby("refit")}
        a, b = wide["pinned"], wide["search"]
        cls, spl = a["class"].to_numpy(), a["split"].to_numpy()
        row = {"data": label, "variant": variant, "n_splits": len(splits), "n_trials": len(a)}
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
    ap.add_argument("--out", type=Path, default=None, help="folder for the per-trial and summary CSVs")
    args = ap.parse_args()
    label = "phac2" if args.data == "phac2" else f"SIMULATED-{args.trials}-{args.solver}"
    with tempfile.TemporaryDirectory() as work:
        features, config = features_and_settings(args.data, args.trials, args.seed, args.n_splits, args.solver,
                                                 Path(work))
        table, summary = run(features, config, label)
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
        args.out.mkdir(parents=True, exist_ok=True)
        tag = f"{label}_seed{args.seed}"
        atomic_write(args.out / f"calibration_refit_trials_{tag}.csv", lambda p: table.to_csv(p, index=False))
        atomic_write(args.out / f"calibration_refit_summary_{tag}.csv", lambda p: summary.to_csv(p, index=False))


if __name__ == "__main__":
    main()
