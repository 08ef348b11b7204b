"""Full grid vs successive halving of the attribute SVMs' search (issue 22, item 3), paired on PHAC-2.

For each seeded random split (``--n-splits`` splits of seed ``--seed``, as ``tzsl run phac2-dap``
draws them) the study's attribute bank (:func:`tzsl.studies.zero_shot.study.fit_split`: 5
object-grouped folds, ``select`` under-sampling, the ``--grid`` gamma grid, no cache) is fitted
twice on the split's training objects, with ``search="grid"`` and ``search="halving"``, in one
process on one core. Per split it prints the CPU seconds of each fit and the AVGDAP (uniform
prior) trial accuracy of each; at the end the mean accuracies with their two-level bootstrap
intervals (splits, then test objects), the paired difference (halving minus grid) with its
interval, the share of (attribute, sensor) models whose chosen configuration is the grid's, and
the CPU seconds of all attribute fits of each search. ``--out DIR`` writes
``search_trials_seed<S>_<grid>.csv`` (one row per search and test trial) and
``search_summary_seed<S>_<grid>.csv`` (one row: the numbers above), which ``make numbers
BENCH_RESULTS=DIR`` publishes in ``docs/user_guide/performance.md``::

    export TZSL_DATA_DIR=/path/to/data
    # selection
    nice -n 10 python experiments/benchmarks/phac2_search.py --seed 0 --n-splits 10 --out /tmp/tzsl_search
    # confirmation
    nice -n 10 python experiments/benchmarks/phac2_search.py --seed 1 --n-splits 10 --out /tmp/tzsl_search

A choice made on one seed's splits is confirmed on another seed's (``--seed 1``).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import pandas as pd

from tzsl.evaluation import bootstrap_accuracy, paired_difference_interval
from tzsl.features import dataset_features
from tzsl.files import atomic_write
from tzsl.models.attribute_training import SEARCHES
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.study import fit_split, make_splits


def chosen(bank) -> list[tuple]:
    """(draw, C, gamma) of every (attribute, sensor) model of a fitted bank."""
    return [(e.draw_, e.C_, e.gamma_) for per_sensor in bank.estimators_ for e in per_sensor]


def run(seed: int, n_splits: int, grid: str) -> tuple[pd.DataFrame, dict]:
    """Per-trial correctness of both searches on every split, and the summary row."""
    features = dataset_features("phac2-penn")
    compute = {"cache": False, "progress": False, "n_jobs": 1}
    base = ZeroShotSettings.of_preset("phac2-dap", splits={"n_splits": n_splits, "seed": seed}, compute=compute)
    splits, _ = make_splits(features, "random", base)
    rows, same, total = [], 0, 0
    for i, split in enumerate(splits):
        fitted = {}
        for search in SEARCHES:
            config = ZeroShotSettings.of_preset("phac2-dap", splits=base.splits, compute=compute,
                                                svm={"grid": grid, "search": search})
            start, wall = time.process_time(), time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fitted[search] = r = fit_split(features, split, config, i)
            cpu, wall = time.process_time() - start, time.perf_counter() - wall
            correct = (r.predict("avg", "uni") == r.y).astype(float)
            rows += [{"seed": seed, "grid": grid, "split": i, "search": search, "trial": t, "class": int(r.y[t]),
                      "correct": correct[t], "cpu_s": cpu, "wall_s": wall} for t in range(len(r.y))]
            print(f"seed {seed} split {i} {search:8s} cpu {cpu:6.1f} s  AVGDAP {correct.mean():.3f}", flush=True)
        a, b = chosen(fitted["grid"].model), chosen(fitted["halving"].model)
        same += sum(x == y for x, y in zip(a, b, strict=True))
        total += len(a)
    table = pd.DataFrame(rows)
    wide = table.pivot_table(index=["split", "class", "trial"], columns="search", values="correct")
    cls, spl = wide.index.get_level_values("class").to_numpy(), wide.index.get_level_values("split").to_numpy()
    summary: dict = {"seed": seed, "grid": grid, "n_splits": len(splits)}
    for search in SEARCHES:
        iv = bootstrap_accuracy(wide[search].to_numpy(), classes=cls, splits=spl)
        summary.update({f"{search}_avgdap": iv.mean, f"{search}_ci95_low": iv.ci95_low,
                        f"{search}_ci95_high": iv.ci95_high})
    d = paired_difference_interval(wide["halving"].to_numpy(), wide["grid"].to_numpy(), classes=cls, splits=spl)
    cpu = table.groupby(["search", "split"])["cpu_s"].first().groupby("search").sum()
    wall = table.groupby(["search", "split"])["wall_s"].first().groupby("search").sum()
    summary.update({"difference": d.mean, "difference_ci95_low": d.ci95_low, "difference_ci95_high": d.ci95_high,
                    "same_choice_share": same / total, "grid_cpu_s": cpu["grid"], "halving_cpu_s": cpu["halving"],
                    "cpu_ratio": cpu["grid"] / cpu["halving"], "grid_wall_s": wall["grid"],
                    "halving_wall_s": wall["halving"]})
    return table, summary


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-splits", type=int, default=10)
    ap.add_argument("--grid", choices=["paper", "extended"], default="paper",
                    help="gamma grid (the paper-reproduction studies' 'paper', or AttributeSVM's default 'extended')")
    ap.add_argument("--out", type=Path, default=None, help="folder for the per-trial and summary CSVs")
    args = ap.parse_args()
    table, s = run(args.seed, args.n_splits, args.grid)
    for search in SEARCHES:
        print(f"{search:8s} AVGDAP {s[f'{search}_avgdap']:.3f} [{s[f'{search}_ci95_low']:.3f}, "
              f"{s[f'{search}_ci95_high']:.3f}]")
    print(f"halving - grid: {s['difference']:+.4f} [{s['difference_ci95_low']:+.4f}, {s['difference_ci95_high']:+.4f}]"
          f"  (seed {args.seed}, {s['n_splits']} splits, {args.grid} grid)")
    print(f"same choice as the grid: {s['same_choice_share']:.3f} of the models; CPU grid {s['grid_cpu_s']:.1f} s, "
          f"halving {s['halving_cpu_s']:.1f} s, ratio {s['cpu_ratio']:.2f}")
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        tag = f"seed{args.seed}_{args.grid}"
        atomic_write(args.out / f"search_trials_{tag}.csv", lambda p: table.to_csv(p, index=False))
        atomic_write(args.out / f"search_summary_{tag}.csv", lambda p: pd.DataFrame([s]).to_csv(p, index=False))


if __name__ == "__main__":
    main()
