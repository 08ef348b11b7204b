"""PHAC-2, issue 32 item 4: the chosen attribute detector's DAP and the ensemble candidates against dap-avg and ESZSL.

On the random splits of ``--purpose`` / ``--seed`` (``--n-random`` of them) and the 5 challenging
partitions, every member is fitted once per split on the training objects, exactly as the
zero-shot study fits a compared method (:func:`tzsl.studies.zero_shot.methods.fit_predict_split`,
the study's method seed ``study seed + index``, challenging splits from index 100), bare
(``calibration = "none"``: a temperature does not change which class wins):

* ``dap-avg``: the paper's RBF-SVM DAP as the ensemble's member (``AttributeSVM(cv=5, grid="paper")``);
* ``dap-avg-logistic-c1``: the DAP of the detector chosen on selection splits (``detector="logistic-c1"``);
* ``eszsl``, ``sae``: the registered methods.

The ensembles are formed from those fits as :class:`tzsl.models.ScoreEnsembleZSL` forms them (the
mean of the members' trial-wise z-scored class scores, ties broken with the split's seed):
``ensemble-rbf`` (dap-avg, eszsl, sae: the members shipped before issue 32), ``ensemble-c1``
(dap-avg-logistic-c1, eszsl, sae) and ``ensemble-both`` (all four). Unlike the registered
ensemble, its members here share their seeds with the single methods.

``--dataset`` runs the same comparison on another dataset with an attribute table: a built-in one
(``fabric-depth``, ``hand-simulated``: SIMULATED grasps) or ``synthetic`` (SIMULATED:
:func:`tzsl.datasets.write_synthetic_dataset`, 600 trials of 60 classes, 30 attributes), with
``--n-test`` unseen classes per random split (and ``--no-challenging`` where challenging splits are not
sound).

Output (``--out`` folder): ``trials.csv`` (one row per method and test trial, written after every
split) and ``summary.csv`` (per split kind and method: accuracy with its two-level bootstrap 95%
interval, and the paired difference to ``dap-avg`` and to ``eszsl`` on the same trials with their
intervals)::

    nice -n 5 python experiments/benchmarks/phac2_detectors_confirm.py --out DIR --purpose select --seed 0 --n-random 5
    nice -n 5 python experiments/benchmarks/phac2_detectors_confirm.py --out DIR --purpose confirm --seed 32 \
        --n-random 50
    nice -n 5 python experiments/benchmarks/phac2_detectors_confirm.py --out DIR --dataset fabric-depth --n-test 3 \
        --n-random 3 --no-challenging --min-train-negatives 2
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from phac2_posteriors import CHALLENGING_OFFSET

from tzsl.datasets import write_synthetic_dataset
from tzsl.evaluation import PURPOSES, bootstrap_accuracy, paired_differences_table
from tzsl.features import dataset_features, load_features
from tzsl.models import AttributeSVM, GridEdgeWarning
from tzsl.models.dap import break_ties
from tzsl.models.protocol import zscore_rows
from tzsl.studies.comparison.method_runs import method_input
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.methods import fit_predict_split
from tzsl.studies.zero_shot.study import make_splits

#: Members fitted on every split: label -> registry entry (bare: no calibration).
MEMBERS: dict[str, dict] = {
    "dap-avg": {"name": "dap-avg", "estimator": AttributeSVM(cv=5, grid="paper"), "calibration": "none"},
    "dap-avg-logistic-c1": {"name": "dap-avg-logistic-c1", "calibration": "none"},
    "eszsl": {"name": "eszsl", "calibration": "none"},
    "sae": {"name": "sae", "calibration": "none"},
}
#: Ensembles formed from the members' class scores.
ENSEMBLES: dict[str, tuple[str, ...]] = {
    "ensemble-rbf": ("dap-avg", "eszsl", "sae"),
    "ensemble-c1": ("dap-avg-logistic-c1", "eszsl", "sae"),
    "ensemble-both": ("dap-avg", "dap-avg-logistic-c1", "eszsl", "sae"),
}
REFERENCES = ("dap-avg", "eszsl")


def features_of(dataset: str, out: Path):
    """The FeatureSet of ``dataset``: a built-in name, or ``synthetic`` (written once under ``out``)."""
    if dataset != "synthetic":
        return dataset_features(dataset)
    folder = out / "synthetic_dataset"
    if not folder.exists():
        write_synthetic_dataset(folder, 600, seed=0)
    return load_features(plain=folder)


def splits_of(features, config: ZeroShotSettings, challenging: bool) -> list:
    """``[(kind, index, Split)]``: the random splits of ``config`` then (``challenging``) the challenging ones."""
    random_splits, _ = make_splits(features, "random", config)
    out = [("random", i, s) for i, s in enumerate(random_splits)]
    if challenging:
        out += [("challenging", CHALLENGING_OFFSET + i, s) for i, s in enumerate(make_splits(features, "challenging",
                                                                                              config)[0])]
    return out


def score_split(features, split, seed: int) -> tuple[pd.DataFrame, dict[str, float]]:
    """One split: the per-trial correctness of every member and ensemble, and each member's fit CPU seconds."""
    scores, rows, cpu = {}, [], {}
    for label, spec in MEMBERS.items():
        start = time.process_time()
        (fit, y) = fit_predict_split(spec, features, split, seed)
        cpu[label] = time.process_time() - start
        K = features.attributes.loc[list(split.test_objects), list(split.kept_attributes)].to_numpy(dtype=float)
        test = np.isin(features.objects, split.test_objects)
        scores[label] = np.asarray(fit.model.decision_function(method_input(spec, features.X[test]), K))
        rows.append((label, fit.predicted == y))
    for label, members in ENSEMBLES.items():
        total = sum(zscore_rows(scores[m]) for m in members) / len(members)
        rows.append((label, break_ties(total, seed) == y))
    classes = np.asarray(split.test_objects)[y]
    table = pd.concat([pd.DataFrame({"method": label, "split": split.name, "class": classes,
                                     "trial": np.arange(len(y)), "correct": correct.astype(float)})
                       for label, correct in rows], ignore_index=True)
    return table, cpu


def summary(trials: pd.DataFrame) -> pd.DataFrame:
    """Per kind and method: accuracy [interval] and the paired differences to each of :data:`REFERENCES`."""
    out = []
    for kind, sub in trials.groupby("kind", sort=False):
        diffs = {ref: paired_differences_table(sub.drop(columns="kind"), reference=ref).set_index("method")
                 for ref in REFERENCES}
        for method, t in sub.groupby("method", sort=False):
            iv = bootstrap_accuracy(t["correct"].to_numpy(), classes=t["class"].to_numpy(),
                                    splits=t["split"].to_numpy())
            row = {"kind": kind, "method": method, "n_splits": t["split"].nunique(), "accuracy": iv.mean,
                   "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high}
            for ref, d in diffs.items():
                hit = d.loc[method] if method in d.index else None
                row.update({f"minus_{ref}": np.nan if hit is None else hit["difference"],
                            f"minus_{ref}_low": np.nan if hit is None else hit["ci95_low"],
                            f"minus_{ref}_high": np.nan if hit is None else hit["ci95_high"]})
            out.append(row)
    return pd.DataFrame(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n-random", type=int, default=50)
    ap.add_argument("--seed", type=int, default=32)
    ap.add_argument("--purpose", choices=PURPOSES, default="confirm")
    ap.add_argument("--no-challenging", action="store_true", help="random splits only")
    ap.add_argument("--no-random", action="store_true", help="challenging splits only")
    ap.add_argument("--summarise", action="store_true", help="only summarise the trials.csv of --out")
    ap.add_argument("--dataset", default="phac2-penn", help="phac2-penn, fabric-depth, hand-simulated or synthetic")
    ap.add_argument("--n-test", type=int, default=10, help="unseen classes per random split")
    ap.add_argument("--min-train-negatives", type=int, default=1,
                    help="a split leaves out an attribute absent in fewer training objects (the SVM's CV needs 2)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.summarise:
        features = features_of(args.dataset, args.out)
        warnings.simplefilter("ignore", GridEdgeWarning)
        config = ZeroShotSettings.of_preset("phac2-dap",
                                            splits={"seed": args.seed, "purpose": args.purpose,
                                                    "n_splits": args.n_random, "n_test": args.n_test,
                                                    "min_train_negatives": args.min_train_negatives})
        study_seed = config.study_seed
        parts, cpu_rows = [], []
        for kind, index, split in splits_of(features, config, not args.no_challenging):
            if args.no_random and kind == "random":
                continue
            table, cpu = score_split(features, split, study_seed + index)
            parts.append(table.assign(kind=kind))
            cpu_rows.append({"kind": kind, "split": split.name, **cpu})
            pd.concat(parts, ignore_index=True).to_csv(args.out / "trials.csv", index=False)
            pd.DataFrame(cpu_rows).to_csv(args.out / "cpu_seconds.csv", index=False)
            acc = table.groupby("method", sort=False)["correct"].mean()
            print(f"{split.name}: " + ", ".join(f"{m} {a:.3f}" for m, a in acc.items())
                  + f"; cpu {sum(cpu.values()):.0f} s", flush=True)
    result = summary(pd.read_csv(args.out / "trials.csv"))
    result.to_csv(args.out / "summary.csv", index=False)
    with pd.option_context("display.width", 220, "display.max_columns", 20):
        print(result.round(3).to_string(index=False))


if __name__ == "__main__":
    main()
