"""PHAC-2: the zero-shot searches' criterion, neg_log_loss against accuracy (issue 41).

ESZSLCV, SAECV and the embedding model's weight-decay search (:func:`tzsl.evaluation.select_embedding_alpha`)
choose their regularisers on held-out training classes by ``scoring``; both criteria use the same tie rule
(scores within ``TIE_TOLERANCE`` of the best are tied, the most regularised wins). This benchmark decides
the default criterion. Hypothesis and rule, written before any run:

H: choosing the regularisers by neg_log_loss instead of accuracy (same tie rule) (a) never changes a choice
under a relative 1e-12 perturbation of the features, while accuracy does on some fits, and (b) costs no
accuracy: on the selection splits, for each method (eszsl, sae, embedding), the paired difference
neg_log_loss minus accuracy in zero-shot test accuracy has a 95% interval whose lower bound is above -0.02.
Rule: neg_log_loss becomes the default of every method for which (a) and (b) hold on the selection splits;
for a method where either fails, accuracy stays its default and its published numbers are marked as able to
move with the last bit.

(a) is read as written: no changed choice with neg_log_loss AND at least one with accuracy, over the
method's selection fits. Candidates per split: the registered ``eszsl`` and ``sae`` methods with their
attribute model's ``scoring`` set, and the embedding model (``lam`` = the fabric study's reference 0.1,
``DEFAULT_ALPHAS``, ``max_iter`` 500, ``random_state`` the split's seed) refitted with the alpha that
``select_embedding_alpha(..., scoring=...)`` chose, as ``tzsl.studies.fabric`` does. Every fit is repeated
on the features times ``1 + 1e-12 u`` (``u`` uniform in [-1, 1], seeded by split): did the chosen
regulariser change, how many test predictions changed. Features: PHAC-2 Penn (``dataset_features``);
splits: the library's seeded random splits (``make_splits``, ``purpose`` select or confirm).

Output (``--out DIR``): ``selection_criterion_fits_<purpose>_seed<S>.csv`` (one row per split, method and
scoring), ``selection_criterion_trials_<purpose>_seed<S>.csv`` (per-trial correctness) and
``selection_criterion_summary_<purpose>_seed<S>.csv`` (per method and scoring: accuracy [95% interval],
chance, paired difference to accuracy-scoring [95% interval], fits, changed choices and predictions, and
on selection splits the rule's verdict), which the ``selection-criterion-benchmark`` block of
experiments/benchmarks/README.md reads::

    export TZSL_DATA_DIR=/path/to/data
    nice -n 5 python experiments/benchmarks/selection_criterion.py --purpose select --seed 0 \
        --n-splits 10 --out /tmp/tzsl_selection_criterion/select
    nice -n 5 python experiments/benchmarks/selection_criterion.py --purpose confirm --seed 1 \
        --n-splits 10 --out /tmp/tzsl_selection_criterion/confirm
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from threadpoolctl import threadpool_limits

from tzsl.evaluation import DEFAULT_ALPHAS, bootstrap_accuracy, paired_difference_interval, select_embedding_alpha
from tzsl.features import dataset_features
from tzsl.files import atomic_write
from tzsl.fit_store import fit_cached
from tzsl.models import build_method
from tzsl.models.protocol import attribute_rows
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.study import make_splits

#: The compared methods and criteria; the first criterion is the reference of the paired differences.
METHODS = ("eszsl", "sae", "embedding")
SCORINGS = ("accuracy", "neg_log_loss")
REFERENCE, CANDIDATE = SCORINGS
#: Relative size of the feature perturbation.
PERTURBATION = 1e-12
#: Rule (b): the 95% interval of neg_log_loss minus accuracy must have its lower bound above this.
MIN_LOWER_BOUND = -0.02
#: The embedding model's loss weight (the fabric study's reference lambda) and L-BFGS iterations.
EMBEDDING_LAM = 0.1
EMBEDDING_MAX_ITER = 500
#: File names (``<prefix><purpose>_seed<seed>.csv``); the README block reads the summaries.
FITS_PREFIX = "selection_criterion_fits_"
TRIALS_PREFIX = "selection_criterion_trials_"
SUMMARY_PREFIX = "selection_criterion_summary_"


def fit_method(method: str, scoring: str, X_tr: np.ndarray, objects_tr: np.ndarray, rows_tr: np.ndarray,
               seed: int):
    """One fitted candidate and its chosen regularisers (``{"gamma": ..., "lam": ...}`` and the like).

    ``rows_tr``: one attribute row per class of ``np.unique(objects_tr)``.
    """
    Y = attribute_rows(objects_tr, rows_tr)
    if method == "embedding":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # folds stopped at max_iter are scored, as the fabric study does
            alpha, _ = select_embedding_alpha(X_tr, objects_tr, rows_tr, lam=EMBEDDING_LAM, alphas=DEFAULT_ALPHAS,
                                              random_state=seed, max_iter=EMBEDDING_MAX_ITER, scoring=scoring)
            model = fit_cached(build_method("embedding", lam=EMBEDDING_LAM, alpha=alpha, early_stopping=False,
                                            max_iter=EMBEDDING_MAX_ITER, random_state=seed, calibration="none"),
                               X_tr, Y, objects_tr)
        return model, {"alpha": alpha}
    # calibration="none": a temperature would not move the argmax
    model = fit_cached(build_method(method, calibration="none", scoring=scoring, random_state=seed), X_tr, Y,
                       objects_tr)
    cv = model.attribute_model_
    return model, ({"gamma": cv.best_gamma_, "lam": cv.best_lam_} if method == "eszsl" else {"lam": cv.best_lam_})


def _choice(chosen: dict) -> str:
    return ",".join(f"{k}={v:g}" for k, v in chosen.items())


def run_split(X: np.ndarray, objects: np.ndarray, table: pd.DataFrame, train_objects, test_objects, *,
              purpose: str, seed: int, index: int, methods=METHODS) -> tuple[list[dict], pd.DataFrame]:
    """Every (method, scoring) of one split, fitted on ``X`` and on ``X`` perturbed: (fit rows, trial rows).

    ``X``: (n_trials, n_features); ``objects``: each trial's class; ``table``: attribute row per class
    (index: class); ``train_objects``/``test_objects``: the split's classes.
    """
    train, test = np.isin(objects, list(train_objects)), np.isin(objects, list(test_objects))
    u = np.random.default_rng([seed, index]).uniform(-1.0, 1.0, X.shape)
    X_p = X * (1.0 + PERTURBATION * u)
    K = table.loc[list(test_objects)].to_numpy(dtype=float)
    y = pd.Index(list(test_objects)).get_indexer(objects[test])
    rows_tr = table.loc[np.unique(objects[train])].to_numpy(dtype=float)
    name = f"{purpose}-{seed}-{index}"
    fits, trials = [], []
    with threadpool_limits(limits=1):  # many small dense problems: one BLAS thread per job
        for method in methods:
            for scoring in SCORINGS:
                start = time.process_time()
                model, chosen = fit_method(method, scoring, X[train], objects[train], rows_tr, seed)
                pred = model.decision_function(X[test], K).argmax(1)
                model_p, chosen_p = fit_method(method, scoring, X_p[train], objects[train], rows_tr, seed)
                pred_p = model_p.decision_function(X_p[test], K).argmax(1)
                correct = (pred == y).astype(float)
                fits.append({"purpose": purpose, "seed": seed, "split": name, "method": method, "scoring": scoring,
                             "n_test": int(test.sum()), "chance": 1.0 / len(test_objects),
                             "accuracy": correct.mean(), "accuracy_perturbed": float(np.mean(pred_p == y)),
                             "chosen": _choice(chosen), "chosen_perturbed": _choice(chosen_p),
                             "choice_changed": chosen != chosen_p,
                             "predictions_changed": int(np.sum(pred != pred_p)),
                             "cpu_seconds": time.process_time() - start})
                trials.append(pd.DataFrame({"purpose": purpose, "seed": seed, "split": name, "method": method,
                                            "scoring": scoring, "class": objects[test], "correct": correct}))
    return fits, pd.concat(trials, ignore_index=True)


def run(X, objects, table, splits, *, purpose: str, seed: int, methods=METHODS,
        n_jobs: int = 1) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`run_split` over ``splits`` (with ``train_objects``, ``test_objects``, ``kept_attributes``) in
    parallel, one job per split."""
    jobs = (delayed(run_split)(X, objects, table.loc[:, list(s.kept_attributes)], s.train_objects, s.test_objects,
                               purpose=purpose, seed=seed, index=i, methods=methods) for i, s in enumerate(splits))
    out = Parallel(n_jobs=n_jobs, verbose=0)(jobs)
    fits = pd.DataFrame([row for rows, _ in out for row in rows])
    return fits, pd.concat([t for _, t in out], ignore_index=True)


def rule_verdict(summary: pd.DataFrame) -> pd.DataFrame:
    """The rule per method, from the summary rows of both scorings: (a), (b) and whether both hold."""
    rows = []
    for method, s in summary.groupby("method", sort=False):
        by = s.set_index("scoring")
        stable = int(by.loc[CANDIDATE, "n_choice_flips"]) == 0
        flips = int(by.loc[REFERENCE, "n_choice_flips"]) > 0
        b = float(by.loc[CANDIDATE, "diff_ci95_low"]) > MIN_LOWER_BOUND
        rows.append({"method": method, "rule_a_holds": stable and flips, "rule_b_holds": b,
                     "rule_holds": stable and flips and b})
    return pd.DataFrame(rows)


def summarise(fits: pd.DataFrame, trials: pd.DataFrame) -> pd.DataFrame:
    """Per (method, scoring): accuracy [95% interval], chance, paired difference to accuracy-scoring
    [95% interval], fits, changed choices and predictions; on selection splits the rule's verdict."""
    rows = []
    for (method, scoring), t in trials.groupby(["method", "scoring"], sort=False):
        f = fits[(fits.method == method) & (fits.scoring == scoring)]
        ref = trials[(trials.method == method) & (trials.scoring == REFERENCE)]
        keys = dict(classes=t["class"].to_numpy(), splits=t.split.to_numpy())
        iv = bootstrap_accuracy(t.correct.to_numpy(), **keys)
        d = (None if scoring == REFERENCE else
             paired_difference_interval(t.correct.to_numpy(), ref.correct.to_numpy(), **keys))
        rows.append({"purpose": t.purpose.iloc[0], "seed": int(t.seed.iloc[0]), "method": method,
                     "scoring": scoring, "n_splits": t.split.nunique(), "n_fits": len(f),
                     "accuracy": iv.mean, "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high,
                     "chance": f.chance.mean(), "diff_vs_accuracy": np.nan if d is None else d.mean,
                     "diff_ci95_low": np.nan if d is None else d.ci95_low,
                     "diff_ci95_high": np.nan if d is None else d.ci95_high,
                     "n_choice_flips": int(f.choice_changed.sum()),
                     "n_changed_predictions": int(f.predictions_changed.sum()),
                     "n_test_trials": int(f.n_test.sum())})
    summary = pd.DataFrame(rows)
    if (summary.purpose == "select").all():
        summary = summary.merge(rule_verdict(summary), on="method", how="left")
        summary["rule_min_lower_bound"] = MIN_LOWER_BOUND
    return summary


def write_csv(table: pd.DataFrame, path: Path) -> None:
    atomic_write(path, lambda p: table.to_csv(p, index=False, float_format="%.6g"))


def phac2_inputs(purpose: str, seed: int, n_splits: int):
    """PHAC-2 Penn features (trials side by side), trial classes, attribute table and the random splits."""
    features = dataset_features("phac2-penn")
    config = ZeroShotSettings.of_preset("phac2-dap", splits={"n_splits": n_splits, "seed": seed, "purpose": purpose})
    splits, _ = make_splits(features, "random", config)
    return features.X.reshape(len(features.objects), -1), np.asarray(features.objects), features.attributes, splits


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--purpose", choices=("select", "confirm"), required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-splits", type=int, default=10)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    ap.add_argument("--n-jobs", type=int, default=1)
    ap.add_argument("--cache", type=Path, default=None,
                    help="fit store folder (TZSL_CACHE_DIR): the embedding's fold fits, shared by both scorings")
    args = ap.parse_args(argv)
    if args.cache is not None:
        os.environ["TZSL_CACHE_DIR"] = str(args.cache.resolve())  # read by the fit store, in every worker
    start = time.perf_counter()
    X, objects, table, splits = phac2_inputs(args.purpose, args.seed, args.n_splits)
    fits, trials = run(X, objects, table, splits, purpose=args.purpose, seed=args.seed, methods=args.methods,
                       n_jobs=args.n_jobs)
    summary = summarise(fits, trials)
    tag = f"{args.purpose}_seed{args.seed}.csv"
    write_csv(fits, args.out / f"{FITS_PREFIX}{tag}")
    write_csv(trials, args.out / f"{TRIALS_PREFIX}{tag}")
    write_csv(summary, args.out / f"{SUMMARY_PREFIX}{tag}")
    with pd.option_context("display.width", 250, "display.max_columns", 30):
        print(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    print(f"wall time {time.perf_counter() - start:.0f} s, CPU of the fits {fits.cpu_seconds.sum():.0f} s")


if __name__ == "__main__":
    main()
