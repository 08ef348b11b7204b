"""Stage 1 of the PHAC-2 accuracy benchmark: DAP attribute posteriors of every split, cached.

For each split (``--n-random`` seeded random splits, seed ``--seed``, and the 5 challenging
splits) and each grid (``paper``, ``extended``, ``adaptive``) the per-(attribute, BioTac) SVM bank of
the PHAC-2 study (:func:`tzsl.studies.zero_shot.study.fit_split`, 5 object-grouped folds,
``select`` under-sampling) is fitted on the split's training objects. Saved per split:

* ``P_test`` (n_test_trials, 2, m): test posteriors ``p(a_m = 1 | x_s)``;
* ``P_oof`` (n_train_trials, 2, m): out-of-fold posteriors of the training trials (the Platt map
  of each SVM's object-grouped out-of-fold scores: every trial scored by a model that never saw
  its object), which stage 2 uses to choose weights on training objects only;
* ``log_loss`` (m, 2): grouped-CV criterion of the chosen configuration; ``gamma``, ``C`` (m, 2)
  the chosen values; ``at_edge`` (m, 2): the choice sits at an end of its (final) grid;
  ``cpu_seconds``: CPU time of the split's fit.

Expensive (about 10 s CPU per split and grid, more on a loaded machine); run once::

    nice -n 5 python experiments/benchmarks/phac2_posteriors.py --out /tmp/tzsl_accuracy --n-random 20

Stage 2 (:mod:`benchmarks.phac2_accuracy`) reads these files. Nothing here is in the repository's
results; the output folder is a cache.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.special import expit

from tzsl.evaluation import PURPOSES
from tzsl.features import dataset_features
from tzsl.models import GridEdgeWarning
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.study import fit_split, make_splits, split_masks

GRIDS = ("paper", "extended", "adaptive")
#: ``--purpose`` when not given: the study schema's default ``[splits] purpose``.
DEFAULT_PURPOSE = ZeroShotSettings.of_preset("phac2-dap").splits.purpose
#: split index offset of the challenging splits (as in run_zero_shot_tables)
CHALLENGING_OFFSET = 100


def study_splits(features, n_random: int, seed: int, purpose: str = DEFAULT_PURPOSE):
    """``[(kind, index, Split)]``: the random splits of ``purpose`` then the challenging ones."""
    config = ZeroShotSettings.of_preset("phac2-dap", splits={"n_splits": n_random, "seed": seed, "purpose": purpose})
    random_splits, _ = make_splits(features, "random", config)
    challenging, _ = make_splits(features, "challenging", config)
    return ([("random", i, s) for i, s in enumerate(random_splits)]
            + [("challenging", CHALLENGING_OFFSET + i, s) for i, s in enumerate(challenging)])


def oof_posteriors(bank) -> np.ndarray:
    """Out-of-fold training posteriors of a fitted bank, shape (n_train, n_sensors, m)."""
    cols = []
    for per_sensor in bank.estimators_:
        cols.append(np.stack([expit(est.platt_[0] * est.oof_scores_ + est.platt_[1]) for est in per_sensor], 1))
    return np.stack(cols, axis=2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n-random", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--purpose", choices=PURPOSES, default=DEFAULT_PURPOSE,
                    help="random splits that make a choice (select) or report it (confirm); default: the schema's")
    ap.add_argument("--no-challenging", action="store_true", help="random splits only")
    ap.add_argument("--grids", nargs="+", default=list(GRIDS), choices=GRIDS)
    ap.add_argument("--n-jobs", type=int, default=1)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    features = dataset_features("phac2-penn")
    warnings.simplefilter("ignore", GridEdgeWarning)
    for grid in args.grids:
        for kind, index, split in study_splits(features, args.n_random, args.seed, args.purpose):
            if args.no_challenging and kind == "challenging":
                continue
            path = args.out / f"{grid}_{split.name}.npz"
            if path.exists():
                continue
            config = ZeroShotSettings.of_preset("phac2-dap",
                                                splits={"n_splits": args.n_random, "seed": args.seed,
                                                        "purpose": args.purpose},
                                                compute={"cache": False, "n_jobs": args.n_jobs},
                                                svm={"cv": 5, "grid": grid})
            start = time.process_time()
            r = fit_split(features, split, config, index)
            cpu = time.process_time() - start
            bank = r.model
            train, _ = split_masks(features, split)
            # NaN: pruned by halving
            ll = np.array([[np.nanmin(est.cv_scores_) for est in per] for per in bank.estimators_])
            gam = np.array([[est.gamma_ for est in per] for per in bank.estimators_])
            C = np.array([[est.C_ for est in per] for per in bank.estimators_])
            # a fit whose chosen C or gamma sits at an end of its (final) grid
            edge = np.array([[bool(est.grid_edges_) for est in per] for per in bank.estimators_])
            np.savez(path, P_test=r.P, P_oof=oof_posteriors(bank), log_loss=ll, gamma=gam, C=C, at_edge=edge,
                     train_objects=features.objects[train], attributes=np.array(r.attributes),
                     fit_seconds=r.fit_seconds, cpu_seconds=cpu)
            print(f"{grid} {split.name}: AVGDAP {r.accuracy('avg', 'uni'):.3f}  "
                  f"{r.fit_seconds:.0f} s wall, {cpu:.0f} s cpu", flush=True)


if __name__ == "__main__":
    main()
