"""The ensemble's members fitted as the comparison fits those methods: one fit per configuration (issue 43, item 4).

The registered ``ensemble`` (:class:`tzsl.models.ScoreEnsembleZSL`) averages the z-scored class scores of
DAP, ESZSL and SAE. A study that compares it usually compares those methods too, and until this issue the
ensemble fitted every member again in a configuration of its own: its DAP member with
``AttributeSVM(cv=5, grid="paper")`` where the comparison's ``dap-avg`` has the registry's default
detector, each member with a seed drawn from the ensemble's (``SeedSequence([seed, member])``) where the
comparison gives every method the study's seed, and in each pseudo-unseen calibration fold every member
searched its hyper-parameters again where a calibrated method on its own keeps the ones its fit chose
(``calibration_refit="pinned"``). On the template bench's SIMULATED mid-size dataset (``make bench``,
part ``template``) the ensemble's DAP member and its folds were about half of the run's CPU.

The candidate (``reusing``): the members as the comparison fits those methods: the registered
``dap-avg``, ``eszsl`` and ``sae`` with their defaults, each seeded with the ensemble's seed (the study
gives the ensemble of split ``i`` the seed it gives every method on that split), refitted in the
calibration folds with the hyper-parameters its fit chose (``pin_members=True``). Every member fit, on
all training trials and in every fold, is then one that a comparison of those methods makes anyway,
with the same estimator, parameters, seed and training rows, so the fit store reads it back instead of
fitting it again. Today's (``separate``): ``DEFAULT_MEMBERS`` before this issue, each member's seed
drawn from the ensemble's, the members searching again in the folds (``pin_members=False``).

Hypothesis and rule, written before any of these numbers was measured
---------------------------------------------------------------------
H: the reusing ensemble is as accurate and as well calibrated as today's. Rule: on the selection splits
(PHAC-2 Penn features, :data:`N_SPLITS` random splits of seed 0, purpose ``select``, 10 test objects),
if the reusing ensemble's trial accuracy lies within the 95% interval of today's trial accuracy AND its
expected calibration error (ECE, of the calibrated posteriors) within the 95% interval of today's ECE
(two-level bootstrap over splits and test objects, :func:`tzsl.evaluation.bootstrap_accuracy` and
:func:`tzsl.evaluation.calibration_intervals`), the reusing configuration becomes the default
(``DEFAULT_MEMBERS``, the members' seed, ``pin_members``; inherited choices ``ensemble-members`` and
``ensemble-calibration-refit``); otherwise today's stays. The numbers shown for the choice are those of
:data:`N_SPLITS` random confirmation splits of seed 1 (purpose ``confirm``). Only random splits have a
purpose; the 5 challenging splits are not used. Shown beside, never decisive: the paired differences
reusing minus separate on the same trials (accuracy and ECE, with their 95% intervals) and the CPU
seconds.

Both ensembles are fitted as the method comparison fits them
(:func:`tzsl.studies.zero_shot.methods.fit_predict_split`: calibrated as a whole, seed ``study seed +
split``), one after the other in one fit store (a temporary ``TZSL_CACHE_DIR``) after the compared
``dap-avg``, ``eszsl`` and ``sae`` of the same split, as a study comparing all of them would. Per split
the script records the CPU seconds (one BLAS thread) of the three compared methods and of each ensemble,
and each ensemble's fit-store events (``hit``: a fit read back, ``miss``: fitted and stored).

Run::

    export TZSL_DATA_DIR=/path/to/data
    cd experiments/benchmarks
    nice -n 5 python ensemble_reuse.py --purpose select --seed 0 --out /tmp/tzsl_bench/reuse-select
    nice -n 5 python ensemble_reuse.py --purpose confirm --seed 1 --out /tmp/tzsl_bench/reuse-confirm
    cd ../.. && make numbers BENCH_RESULTS=/tmp/tzsl_bench

Each writes ``ensemble_reuse_trials_<purpose>_seed<seed>.csv`` (one row per ensemble and test trial) and
``ensemble_reuse_summary_<purpose>_seed<seed>.csv`` (one row: both ensembles' accuracy and ECE with
intervals, the paired differences, the rule's verdict on these splits, the CPU seconds and fit-store
events) into ``--out``; ``make numbers`` makes the ``ensemble-reuse-benchmark`` block of
experiments/benchmarks/README.md from every summary under ``BENCH_RESULTS``.
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
from calibration_refit import trial_rows
from threadpoolctl import threadpool_limits

from tzsl.cache import CACHE_DIR_ENV
from tzsl.evaluation import (
    DEFAULT_N_BINS,
    PURPOSES,
    bootstrap_accuracy,
    bootstrap_cell_weights,
    calibration_intervals,
    cluster_cells,
    equal_mass_bins,
    expected_calibration_error,
    paired_difference_interval,
)
from tzsl.features import dataset_features
from tzsl.files import atomic_write
from tzsl.fit_store import fit_store_counts
from tzsl.models import AttributeSVM
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.methods import fit_predict_split
from tzsl.studies.zero_shot.study import make_splits

#: Random splits per run (selection: seed 0, confirmation: seed 1).
N_SPLITS = 10
#: The two ensembles, in the order of the summary's columns.
VARIANTS = ("separate", "reusing")
#: The members of both, as registry names, in the ensemble's order.
MEMBER_NAMES = ("dap-avg", "eszsl", "sae")
#: The compared methods a study fits beside the ensemble (registry defaults, calibrated).
COMPARED = tuple({"name": name} for name in MEMBER_NAMES)


def separate_members(seed: int) -> list[dict]:
    """Today's members with the seeds today's ensemble drew for them from its own ``seed``.

    ``DEFAULT_MEMBERS`` before issue 43 (the DAP member's ``AttributeSVM(cv=5, grid="paper")``), member
    ``j`` seeded with ``SeedSequence([seed, j]).generate_state(1)[0] >> 1`` as :class:`ScoreEnsembleZSL`
    did, so these entries fit what that ensemble fitted whatever the shipped defaults are.
    """
    entries = [{"name": "dap-avg", "estimator": AttributeSVM(cv=5, grid="paper")}, {"name": "eszsl"},
               {"name": "sae"}]
    return [{**entry, "random_state": int(np.random.SeedSequence([int(seed), j]).generate_state(1)[0] >> 1)}
            for j, entry in enumerate(entries)]


def reusing_members(seed: int) -> list[dict]:
    """The candidate's members: the registered methods with their defaults, each with the ensemble's ``seed``."""
    return [{"name": name, "random_state": int(seed)} for name in MEMBER_NAMES]


def ensemble_spec(variant: str, seed: int) -> dict:
    """The ``ensemble`` entry of ``variant`` on a split whose comparison seed is ``seed``."""
    if variant == "separate":
        return {"name": "ensemble", "methods": separate_members(seed), "pin_members": False}
    return {"name": "ensemble", "methods": reusing_members(seed), "pin_members": True}


def _fit(spec: dict, features, split, seed: int):
    """``fit_predict_split`` with its CPU seconds and fit-store events; warnings silenced."""
    before = fit_store_counts()
    start = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit, y = fit_predict_split(spec, features, split, seed)
    return fit, y, time.process_time() - start, fit_store_counts(since=before)


def run(features, config, label: str = "phac2") -> pd.DataFrame:
    """Per-trial rows of both ensembles on every random split of ``config`` (one fit store for the run).

    Columns of :func:`calibration_refit.trial_rows` (``refit`` holds the variant), plus per split its chance
    (one over its test classes), the CPU seconds of the compared methods (``compared_cpu_s``) and each
    ensemble's fit-store hits and misses.
    """
    splits, _ = make_splits(features, "random", config)
    rows = []
    for i, split in enumerate(splits):
        seed = config.study_seed + i
        compared_cpu = sum(_fit(spec, features, split, seed)[2] for spec in COMPARED)
        for variant in VARIANTS:
            fit, y, cpu, events = _fit(ensemble_spec(variant, seed), features, split, seed)
            part = pd.DataFrame(trial_rows(label, i, variant, "ensemble", fit.proba, y, fit.model.temperature_, cpu,
                                           predicted=fit.predicted))
            rows.append(part.assign(chance=split.chance, compared_cpu_s=compared_cpu,
                                    fit_store_hit=events.get("hit", 0), fit_store_miss=events.get("miss", 0)))
            print(f"{label} split {i} {variant:8s} accuracy {part['correct'].mean():.3f} cpu {cpu:7.1f} s "
                  f"(compared methods {compared_cpu:.1f} s) fit store {events}", flush=True)
    return pd.concat(rows, ignore_index=True)


def paired_ece_difference(a: pd.DataFrame, b: pd.DataFrame, n_boot: int = 2000) -> tuple[float, float, float]:
    """ECE(a) - ECE(b) on the same trials (rows in the same order), each with its own predictions and bins,
    with a 95% interval from the same two-level bootstrap replicates: ``(difference, ci95_low, ci95_high)``."""
    classes, splits = a["class"].to_numpy(), a["split"].to_numpy()
    cell = cluster_cells(classes, splits)[0]
    n_cells = int(cell.max()) + 1
    counts = np.bincount(cell, minlength=n_cells).astype(float)
    gaps = []
    for t in (a, b):
        conf, correct = t["confidence"].to_numpy(), t["correct"].to_numpy()
        bins = equal_mass_bins(conf, DEFAULT_N_BINS)
        n_used = int(bins.max()) + 1
        gaps.append(np.bincount(cell * n_used + bins, weights=correct - conf,
                                minlength=n_cells * n_used).reshape(n_cells, n_used))
    reps = []
    for w in bootstrap_cell_weights(classes, splits, n_boot=n_boot, random_state=0):
        total = w @ counts
        reps.append(np.abs(w @ gaps[0]).sum(axis=1) / total - np.abs(w @ gaps[1]).sum(axis=1) / total)
    point = (expected_calibration_error(a["confidence"].to_numpy(), a["correct"].to_numpy())
             - expected_calibration_error(b["confidence"].to_numpy(), b["correct"].to_numpy()))
    low, high = np.quantile(np.concatenate(reps), [0.025, 0.975])
    return float(point), float(low), float(high)


def summarise(table: pd.DataFrame, *, purpose: str, seed: int) -> pd.DataFrame:
    """One row: each ensemble's accuracy and ECE with intervals, the paired differences reusing minus separate,
    the rule's two criteria on these splits (``accuracy_within``, ``ece_within``), CPU seconds and fit-store
    events summed over the splits."""
    by = {v: t.sort_values(["split", "trial"], kind="stable").reset_index(drop=True)
          for v, t in table.groupby("refit", sort=False)}
    a, b = by["reusing"], by["separate"]
    classes, splits = a["class"].to_numpy(), a["split"].to_numpy()
    row: dict = {"purpose": purpose, "seed": int(seed), "n_splits": int(a["split"].nunique()), "n_trials": len(a),
                 "chance": float(a.groupby("split")["chance"].first().mean())}
    for variant, t in by.items():
        acc = bootstrap_accuracy(t["correct"].to_numpy(), classes=classes, splits=splits)
        ece = calibration_intervals(t["confidence"], t["correct"], t["brier"], classes=classes, splits=splits)["ece"]
        per_split = t.groupby("split")
        row.update({f"{variant}_accuracy": acc.mean, f"{variant}_accuracy_ci95_low": acc.ci95_low,
                    f"{variant}_accuracy_ci95_high": acc.ci95_high, f"{variant}_ece": ece.mean,
                    f"{variant}_ece_ci95_low": ece.ci95_low, f"{variant}_ece_ci95_high": ece.ci95_high,
                    f"{variant}_cpu_s": float(per_split["cpu_s"].first().sum()),
                    f"{variant}_fit_store_hit": int(per_split["fit_store_hit"].first().sum()),
                    f"{variant}_fit_store_miss": int(per_split["fit_store_miss"].first().sum())})
    row["compared_cpu_s"] = float(a.groupby("split")["compared_cpu_s"].first().sum())
    acc = paired_difference_interval(a["correct"].to_numpy(), b["correct"].to_numpy(), classes=classes, splits=splits)
    ece = paired_ece_difference(a, b)
    row.update({"accuracy_difference": acc.mean, "accuracy_difference_ci95_low": acc.ci95_low,
                "accuracy_difference_ci95_high": acc.ci95_high, "ece_difference": ece[0],
                "ece_difference_ci95_low": ece[1], "ece_difference_ci95_high": ece[2]})
    row["accuracy_within"] = bool(row["separate_accuracy_ci95_low"] <= row["reusing_accuracy"]
                                  <= row["separate_accuracy_ci95_high"])
    row["ece_within"] = bool(row["separate_ece_ci95_low"] <= row["reusing_ece"] <= row["separate_ece_ci95_high"])
    row["rule_holds"] = row["accuracy_within"] and row["ece_within"]
    return pd.DataFrame([row])


def write_results(table: pd.DataFrame, summary: pd.DataFrame, out: Path, *, purpose: str, seed: int) -> None:
    """``ensemble_reuse_{trials,summary}_<purpose>_seed<seed>.csv`` into ``out`` (the names the README block reads)."""
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{purpose}_seed{seed}"
    atomic_write(out / f"ensemble_reuse_trials_{tag}.csv", lambda p: table.to_csv(p, index=False))
    atomic_write(out / f"ensemble_reuse_summary_{tag}.csv", lambda p: summary.to_csv(p, index=False))


def main(argv: list[str] | None = None) -> pd.DataFrame:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--purpose", choices=PURPOSES, default="select",
                        help="select: the rule's splits (seed 0); confirm: the numbers shown (seed 1)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n-splits", type=int, default=N_SPLITS)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    features = dataset_features("phac2-penn")
    config = ZeroShotSettings.of_preset(
        "phac2-dap", splits={"n_splits": args.n_splits, "seed": args.seed, "n_test": 10, "purpose": args.purpose},
        compute={"cache": False, "progress": False, "n_jobs": 1})
    before = os.environ.get(CACHE_DIR_ENV)
    with tempfile.TemporaryDirectory() as store, threadpool_limits(limits=1):
        os.environ[CACHE_DIR_ENV] = store  # one fit store for the run: what a study comparing all of them shares
        try:
            table = run(features, config)
        finally:
            if before is None:
                os.environ.pop(CACHE_DIR_ENV, None)
            else:
                os.environ[CACHE_DIR_ENV] = before
    summary = summarise(table, purpose=args.purpose, seed=args.seed)
    write_results(table, summary, args.out, purpose=args.purpose, seed=args.seed)
    s = summary.iloc[0]
    for name in ("accuracy", "ece"):
        print(f"{name}: separate {s[f'separate_{name}']:.3f} [{s[f'separate_{name}_ci95_low']:.3f}, "
              f"{s[f'separate_{name}_ci95_high']:.3f}], reusing {s[f'reusing_{name}']:.3f} "
              f"(within the interval: {s[f'{name}_within']})")
    print(f"CPU: separate {s['separate_cpu_s']:.1f} s, reusing {s['reusing_cpu_s']:.1f} s after the compared "
          f"methods' {s['compared_cpu_s']:.1f} s")
    if args.purpose == "select":
        print(f"rule ({'holds' if s['rule_holds'] else 'does not hold'}): "
              + ("the reusing members become the default" if s["rule_holds"] else "today's members stay"))
    return summary


if __name__ == "__main__":
    main()
