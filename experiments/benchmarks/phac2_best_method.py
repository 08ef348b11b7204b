"""PHAC-2: the best method decided on selection splits, reported on confirmation splits (issue 23 item 5).

The method comparison of the zero-shot study (every registered feature method and DAP, on the
same splits and test trials; :func:`tzsl.studies.zero_shot.methods.method_comparison`) runs twice
with the same ``--seed``:

1. on SELECTION splits (``purpose = "select"``): ``--n-splits`` random splits and the 5
   challenging splits; the most accurate method of each split kind is the choice;
2. on CONFIRMATION splits (``purpose = "confirm"``): random splits that no selection seed can
   draw (:func:`tzsl.evaluation.split_purpose`), and the same 5 challenging partitions refitted
   with the confirmation seeds (the challenging map has no seed: its choice is not confirmed on
   other splits, and the CSV says so). The chosen method's accuracy and its paired difference to
   the paper's method ``dap-avg`` (AVGDAP, uniform prior, the paper's gamma grid) come from here.

The shipped default (``dap-avg``) changes only if a chosen method beats it on the confirmation
splits with an interval excluding 0 (``beats_reference``). Outputs: ``--out`` (one row per split
kind: :func:`tzsl.reporting.best_method.confirm_choice`) and ``<out stem>_comparison.csv``
beside it (every method x kind x purpose)::

    export TZSL_DATA_DIR=/path/to/data
    nice -n 5 python experiments/benchmarks/phac2_best_method.py --out /tmp/tzsl_accuracy/phac2_best_method.csv
    make numbers BENCH_RESULTS=/tmp/tzsl_accuracy   # its block in experiments/benchmarks/README.md
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import pandas as pd

from tzsl.features import dataset_features
from tzsl.reporting.best_method import confirm_choice
from tzsl.studies.config import ZeroShotSettings, every_feature_method
from tzsl.studies.papers.run_labels import StudyLabels
from tzsl.studies.zero_shot.methods import method_comparison
from tzsl.studies.zero_shot.study import fit_splits, make_splits

#: Split index offset of the challenging splits' fit seeds (as in run_zero_shot_tables).
CHALLENGING_OFFSET = 100
KINDS = ("random", "challenging")
#: What the challenging confirmation is: the same partitions, other fit seeds.
CHALLENGING_NOTE = ("the same challenging partitions as the selection (refitted with the confirmation seeds): "
                    "not confirmed on other splits")


#: The attribute SVMs of the reference: the paper's gamma grid, 5 object-grouped folds (as the ensemble's DAP member).
SVM_PARAMS = {"cv": 5, "grid": "paper"}


def comparison(features, purpose: str, seed: int, n_splits: int, kinds, methods: list[dict], n_jobs: int,
               echo=print, **tables) -> pd.DataFrame:
    """The method comparison of every kind in ``kinds`` on ``purpose`` splits of ``seed``.

    ``tables``: further :class:`~tzsl.studies.config.ZeroShotSettings` keys by table, e.g.
    ``splits={"n_test": 5}, svm={...}`` (tests: a tiny SVM grid); a given table replaces the default's keys.
    """
    given = {"splits": {"n_splits": n_splits, "seed": seed, "purpose": purpose}, "svm": dict(SVM_PARAMS),
             "compute": {"n_jobs": n_jobs, "progress": False}}
    config = ZeroShotSettings.of_preset("phac2-dap", **{t: {**given.get(t, {}), **tables.get(t, {})}
                                                        for t in {*given, *tables}})
    tables = []
    for kind in kinds:
        start = time.perf_counter()
        splits, _ = make_splits(features, kind, config)
        offset = CHALLENGING_OFFSET if kind == "challenging" else 0
        results = fit_splits(features, splits, config, offset=offset)
        labels = StudyLabels(study=f"phac2-{kind}")
        table = method_comparison(features, results, seed=config.study_seed + offset, methods=methods,
                                  labels=labels, purpose=purpose, split_kind=kind)[labels.comparison_table]
        tables.append(table.assign(kind=kind, seed=seed))
        echo(f"{purpose} {kind}: {len(splits)} splits in {time.perf_counter() - start:.0f} s")
    return pd.concat(tables, ignore_index=True)


def decide(selection: pd.DataFrame, confirmation: pd.DataFrame, seed: int) -> pd.DataFrame:
    """:func:`confirm_choice` with the seed and what the challenging confirmation can and cannot show."""
    table = confirm_choice(selection, confirmation)
    table.insert(0, "seed", seed)
    table["note"] = ["; ".join(n for n in (note, CHALLENGING_NOTE if kind == "challenging" else "") if n)
                     for note, kind in zip(table["note"].fillna(""), table["kind"], strict=True)]
    return table


def _write(table: pd.DataFrame, path: Path) -> None:
    tmp = path.with_suffix(".tmp")
    table.to_csv(tmp, index=False, float_format="%.4f")
    tmp.replace(path)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="the decision CSV (one row per split kind)")
    ap.add_argument("--n-splits", type=int, default=50, help="random splits per purpose")
    ap.add_argument("--seed", type=int, default=0, help="seed of the selection and of the confirmation splits")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--methods", nargs="+", default=None,
                    help="registry methods beside DAP (default: every feature method)")
    ap.add_argument("--n-jobs", type=int, default=1)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    features = dataset_features("phac2-penn")
    methods = every_feature_method() if args.methods is None else [{"name": m} for m in args.methods]
    selection = comparison(features, "select", args.seed, args.n_splits, args.kinds, methods, args.n_jobs)
    confirmation = comparison(features, "confirm", args.seed, args.n_splits, args.kinds, methods, args.n_jobs)
    decision = decide(selection, confirmation, args.seed)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    _write(pd.concat([selection, confirmation], ignore_index=True),
           args.out.with_name(f"{args.out.stem}_comparison.csv"))
    _write(decision, args.out)
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(decision.to_string(index=False, float_format=lambda v: f"{v:.3f}"))


if __name__ == "__main__":
    main()
