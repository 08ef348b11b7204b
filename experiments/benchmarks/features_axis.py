"""Features as a benchmark axis: per-channel statistics against ROCKET on the raw-signal datasets (issue 42, item 5).

Today a signal dataset's trial becomes per-channel statistics (``[signals] statistics``, default mean, std,
min and max of every channel over the trial). The candidates are a time-series transform from a library,
ROCKET's random convolutional kernels (:class:`tzsl.features.RocketFeatures` over pyts, the extra
``tzsl[timeseries]``; 25 kernels, max and PPV per kernel and channel, every channel resampled to 256
points and z-normalised per trial), alone (``rocket``) and beside the statistics (``statistics+rocket``,
the statistics keep the level and scale ROCKET's normalisation removes).

Data: the raw-signal datasets tzsl has here, as plain-file folders (``tzsl convert``):

* ``phac2-hold``: ``tzsl convert --dataset phac2-hold-mat --out DIR``, 6 PHAC-2 objects x 10 HOLD trials, 2
  BioTacs x 23 channels, 4 attributes, its ``dataset.toml``'s baseline of 100 rows. The generic study draws
  no random split of 6 objects (every kept attribute needs 2 positive and 2 negative training objects), so
  here: 2 test objects, at least 1 positive training object per attribute (``random_min_train_positives=1``).
* ``biotac-slide``: ``tzsl data fetch biotac-slide`` then ``tzsl convert --dataset biotac-slide --out DIR``, 20
  materials x 50 slides, 1 BioTac x 44 channels, 3 attributes; the generic study's random splits (its
  relaxed number of test objects).

Splits: the library's seeded random object splits of ``--purpose`` (``select``: seed 0, the rule's; ``confirm``:
seed 1, the numbers shown), :data:`N_DRAWS` draws, repeated test-object sets dropped (a small dataset draws the same
set again), the first :data:`MAX_SPLITS` distinct ones kept. Method: the generic default
:data:`tzsl.models.choices.DEFAULT_METHOD`, fitted as a study's comparison fits it
(:func:`tzsl.studies.zero_shot.methods.fit_predict_split`, seed ``seed + split``), the same splits and seeds for
every feature set; its z-scoring is fitted on each split's training trials. ROCKET's kernels do not depend on the
data and every trial is transformed on its own, so the features are computed once per dataset without leakage
(tests/features/test_rocket_features.py checks it).

Hypothesis and rule, written before any of these numbers was measured
---------------------------------------------------------------------
H: ROCKET features recognise unseen objects better than the per-channel statistics. Rule: ``rocket`` ships as
a feature set a study can name (``statistics = ["rocket"]``, or beside the statistics) whatever the numbers
say. A candidate becomes the default of signal datasets only if, on the selection splits of EVERY dataset,
its paired trial-accuracy gain over ``statistics`` (same trials, :func:`tzsl.evaluation.paired_difference_interval`,
two-level bootstrap over splits and test objects) has a 95% interval above 0; the numbers reported for the
choice are those of the confirmation splits. Shown beside, never decisive: each feature set's accuracy with
its interval (:func:`tzsl.evaluation.bootstrap_accuracy`), its CPU seconds (features, and fits summed over
the splits) and its feature count.

Run::

    export TZSL_DATA_DIR=/path/to/data
    tzsl convert --dataset phac2-hold-mat --out /tmp/phac2_hold_plain
    tzsl convert --dataset biotac-slide --out /tmp/bt_plain
    cd experiments/benchmarks
    nice -n 5 python features_axis.py --purpose select --seed 0 --phac2-hold /tmp/phac2_hold_plain \\
        --biotac-slide /tmp/bt_plain --out /tmp/tzsl_bench/features-select
    nice -n 5 python features_axis.py --purpose confirm --seed 1 --phac2-hold /tmp/phac2_hold_plain \\
        --biotac-slide /tmp/bt_plain --out /tmp/tzsl_bench/features-confirm
    cd ../.. && make numbers BENCH_RESULTS=/tmp/tzsl_bench

Each writes ``features_axis_trials_<datasets>_<purpose>_seed<seed>.csv`` (one row per dataset, feature set and
test trial) and ``features_axis_summary_<datasets>_<purpose>_seed<seed>.csv`` (one row per dataset and feature
set; a run may name one dataset, the block reads every summary); ``make
numbers`` makes the ``features-axis-benchmark`` block of experiments/benchmarks/README.md from every summary
under ``BENCH_RESULTS``.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from tzsl.evaluation import PURPOSES, bootstrap_accuracy, paired_difference_interval
from tzsl.features import load_plain_dataset
from tzsl.files import atomic_write
from tzsl.models.choices import DEFAULT_METHOD
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.methods import fit_predict_split
from tzsl.studies.zero_shot.relaxations import relaxed_n_test
from tzsl.studies.zero_shot.study import make_splits

#: Random split draws per dataset and run (repeated test-object sets are dropped) ...
N_DRAWS = 20
#: ... and the first this many distinct ones are used.
MAX_SPLITS = 10
#: Feature set name -> its ``statistics`` setting; the first is today's, the reference of every difference.
FEATURE_SETS: dict[str, tuple[str, ...]] = {
    "statistics": ("mean", "std", "min", "max"),
    "rocket": ("rocket",),
    "statistics+rocket": ("mean", "std", "min", "max", "rocket"),
}
REFERENCE = "statistics"
#: Split settings per dataset beyond the generic study's (see the module docstring).
SPLIT_SETTINGS: dict[str, dict] = {"phac2-hold": {"n_test": 2, "min_train_negatives": 2}, "biotac-slide": {}}


def dataset_splits(features, name: str, purpose: str, seed: int) -> list:
    """The first :data:`MAX_SPLITS` distinct random splits of ``features`` for ``purpose`` (:data:`N_DRAWS` draws of
    seed ``seed``)."""
    extra = dict(SPLIT_SETTINGS[name])
    if "n_test" not in extra:
        extra["n_test"] = relaxed_n_test(features.attributes, ZeroShotSettings().splits)
    config = ZeroShotSettings(splits={"n_splits": N_DRAWS, "seed": seed, "purpose": purpose, **extra})
    drawn, _ = make_splits(features, "random", config)
    seen: set[tuple[str, ...]] = set()
    splits = []
    for split in drawn:
        key = tuple(sorted(split.test_objects))
        if key not in seen and len(splits) < MAX_SPLITS:
            seen.add(key)
            splits.append(split)
    return splits


def run_dataset(name: str, folder: Path, purpose: str, seed: int) -> pd.DataFrame:
    """Per-trial rows of every feature set on the dataset's splits (the splits of the reference's features)."""
    rows = []
    splits = None
    for feature_set, statistics in FEATURE_SETS.items():
        start = time.process_time()
        features = load_plain_dataset(folder, statistics=statistics, cache=False)
        features_cpu = time.process_time() - start
        if splits is None:  # the same test objects for every feature set (the attribute table is the same)
            splits = dataset_splits(features, name, purpose, seed)
        for i, split in enumerate(splits):
            start = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit, y = fit_predict_split({"name": DEFAULT_METHOD}, features, split, seed + i)
            cpu = time.process_time() - start
            correct = np.asarray(fit.predicted) == np.asarray(y)
            truth = np.asarray(split.test_objects)[np.asarray(y)]
            rows.append(pd.DataFrame({"dataset": name, "feature_set": feature_set, "split": i,
                                      "trial": np.arange(len(y)), "object": truth,
                                      "correct": correct.astype(int), "fit_cpu_s": cpu,
                                      "features_cpu_s": features_cpu, "n_features": features.X.shape[2],
                                      "n_sensors": features.X.shape[1], "n_test": len(split.test_objects),
                                      "chance": 1.0 / len(split.test_objects)}))
            print(f"{name} {feature_set:18s} split {i} accuracy {correct.mean():.3f} cpu {cpu:6.1f} s", flush=True)
    return pd.concat(rows, ignore_index=True)


def summarise(table: pd.DataFrame, *, purpose: str, seed: int) -> pd.DataFrame:
    """One row per dataset and feature set: accuracy [95% interval], the paired difference to :data:`REFERENCE`
    on the same trials [95% interval], whether that interval lies above 0 (``gain``), CPU seconds, sizes."""
    out = []
    for dataset, part in table.groupby("dataset", sort=False):
        by = {f: t.sort_values(["split", "trial"], kind="stable").reset_index(drop=True)
              for f, t in part.groupby("feature_set", sort=False)}
        ref = by[REFERENCE]
        objects, splits = ref["object"].to_numpy(), ref["split"].to_numpy()
        for feature_set, t in by.items():
            acc = bootstrap_accuracy(t["correct"].to_numpy(), classes=objects, splits=splits)
            row = {"purpose": purpose, "seed": int(seed), "dataset": dataset, "feature_set": feature_set,
                   "method": DEFAULT_METHOD,
                   "n_splits": int(t["split"].nunique()), "n_trials": len(t), "n_test": int(t["n_test"].iloc[0]),
                   "chance": float(t.groupby("split")["chance"].first().mean()),
                   "n_features": int(t["n_features"].iloc[0]) * int(t["n_sensors"].iloc[0]),
                   "accuracy": acc.mean, "accuracy_ci95_low": acc.ci95_low, "accuracy_ci95_high": acc.ci95_high,
                   "features_cpu_s": float(t["features_cpu_s"].iloc[0]),
                   "fit_cpu_s": float(t.groupby("split")["fit_cpu_s"].first().sum())}
            if feature_set == REFERENCE:
                row.update({"difference": np.nan, "difference_ci95_low": np.nan, "difference_ci95_high": np.nan,
                            "gain": False})
            else:
                d = paired_difference_interval(t["correct"].to_numpy(), ref["correct"].to_numpy(), classes=objects,
                                               splits=splits)
                row.update({"difference": d.mean, "difference_ci95_low": d.ci95_low,
                            "difference_ci95_high": d.ci95_high, "gain": bool(d.ci95_low > 0)})
            out.append(row)
    return pd.DataFrame(out)


def verdict(summary: pd.DataFrame) -> str | None:
    """The candidate the rule makes the default (its gain's interval above 0 on every dataset), or None."""
    for feature_set in FEATURE_SETS:
        rows = summary[summary["feature_set"] == feature_set]
        if feature_set != REFERENCE and len(rows) and bool(rows["gain"].all()):
            return feature_set
    return None


def main(argv: list[str] | None = None) -> pd.DataFrame:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--purpose", choices=PURPOSES, default="select",
                        help="select: the rule's splits (seed 0); confirm: the numbers shown (seed 1)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--phac2-hold", type=Path, help="plain folder of `tzsl convert --dataset phac2-hold-mat`")
    parser.add_argument("--biotac-slide", type=Path, help="plain folder of `tzsl convert --dataset biotac-slide`")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    folders = {"phac2-hold": args.phac2_hold, "biotac-slide": args.biotac_slide}
    if not any(folders.values()):
        parser.error("give --phac2-hold and/or --biotac-slide")
    with threadpool_limits(limits=1):
        table = pd.concat([run_dataset(name, folder, args.purpose, args.seed)
                           for name, folder in folders.items() if folder is not None], ignore_index=True)
    summary = summarise(table, purpose=args.purpose, seed=args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    tag = f"{'+'.join(name for name, folder in folders.items() if folder is not None)}_{args.purpose}_seed{args.seed}"
    atomic_write(args.out / f"features_axis_trials_{tag}.csv", lambda p: table.to_csv(p, index=False))
    atomic_write(args.out / f"features_axis_summary_{tag}.csv", lambda p: summary.to_csv(p, index=False))
    print(summary.to_string(index=False))
    if args.purpose == "select":
        chosen = verdict(summary)
        print(f"rule: {chosen} becomes the default" if chosen else "rule: the statistics stay the default")
    return summary


if __name__ == "__main__":
    main()
