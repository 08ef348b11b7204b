"""Attribute detector families for DAP on PHAC-2 (issue 32): RBF-SVM against linear and object-robust detectors.

On the same splits (``--n-random`` random splits of ``--purpose``, by default ``select``, and the
5 challenging partitions unless ``--no-challenging``) and the same training objects, each detector
family of :class:`tzsl.models.AttributeClassifierBank` is fitted and scored with AVGDAP and the
uniform prior:

* ``rbf-svm``: the study's :class:`~tzsl.models.AttributeSVM` (``svm.cv = 5``, its default grid);
* ``logistic-C1``: :class:`~tzsl.models.LogisticAttribute` (z-score, L2 logistic, C = 1,
  class-balanced, its own posteriors), the per-EP model's classifier, nothing tuned;
* ``logistic``, ``linear-svm``, ``robust-logistic``: :class:`~tzsl.models.LinearAttribute`
  (``C`` by object-grouped CV with the grid widened at its ends, Platt posteriors);
* ``auto``: ``detector="auto"`` (RBF-SVM or logistic, chosen on pseudo-unseen training classes).

Per split and detector: trial accuracy, the accuracy with each attribute's errors made independent
of the other attributes' (:func:`accuracy_if_independent`), mean attribute balanced accuracy on the test objects,
the within-object correlation of attribute errors (:func:`tzsl.evaluation.within_object_error_correlation`,
0/1 errors of the sensor-averaged posterior; over objects and, ``_trial``, over trials), the share of
(attribute, sensor) fits whose ``C`` sits at an end of the final grid, CPU seconds of the fits, and for
``auto`` the family chosen.
Output: ``detectors.csv`` (one row per split and detector) and ``detectors_summary.csv`` (mean
per split kind and detector, with the paired difference to ``rbf-svm`` and its two-level
bootstrap 95% interval)::

    nice -n 5 python experiments/benchmarks/phac2_detectors.py --out /tmp/tzsl_detectors --n-random 5
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from phac2_posteriors import study_splits
from sklearn.base import clone

from tzsl.evaluation import (
    PURPOSES,
    bootstrap_accuracy,
    paired_difference_interval,
    per_attribute_balanced_accuracy,
    within_object_error_correlation,
)
from tzsl.features import dataset_features
from tzsl.models import GridEdgeWarning, LogisticAttribute
from tzsl.models.dap import break_ties, dap_log_scores, fuse_attribute_posteriors
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.spread import model_seed
from tzsl.studies.zero_shot.study import attribute_bank, split_masks

#: ``(label, bank parameters)`` of each detector compared; the first is the reference.
DETECTORS = (
    ("rbf-svm", {}),
    ("logistic-C1", {"estimator": LogisticAttribute()}),
    ("logistic", {"estimator": None, "detector": "logistic"}),
    ("linear-svm", {"estimator": None, "detector": "linear-svm"}),
    ("robust-logistic", {"estimator": None, "detector": "robust-logistic"}),
    ("auto", {"detector": "auto"}),
)


def avgdap_correct(P: np.ndarray, K: np.ndarray, y: np.ndarray, seed: int) -> np.ndarray:
    """Per-trial correctness (n,) of AVGDAP with the uniform prior on posteriors P (n, s, m) among classes K (k, m)."""
    present, absent = fuse_attribute_posteriors(P, "avg")
    scores = dap_log_scores(present, K, np.full(K.shape[1], 0.5), P_absent=absent)
    return break_ties(scores, random_state=seed) == y


def accuracy_if_independent(P: np.ndarray, A: np.ndarray, K: np.ndarray, y: np.ndarray, seed: int,
                            n_shuffles: int = 20) -> float:
    """AVGDAP accuracy with the attributes' errors made independent of each other.

    Each attribute's posteriors (all sensors together) are permuted among the test trials that
    share its true value, separately per attribute: every attribute keeps its error distribution
    given the truth, but which trial gets which error no longer depends on the other attributes.
    Above the actual accuracy: the errors fall together on the same trials and objects.
    """
    rng = np.random.default_rng(seed)
    hits = []
    for _ in range(n_shuffles):
        Q = P.copy()
        for m in range(A.shape[1]):
            for value in (0, 1):
                rows = np.flatnonzero(A[:, m] == value)
                Q[rows, :, m] = P[rng.permutation(rows), :, m]
        hits.append(avgdap_correct(Q, K, y, seed).mean())
    return float(np.mean(hits))


def score_split(features, split, config: ZeroShotSettings, index: int, labels: list[str], out: Path) -> list[dict]:
    """Fit every detector of ``labels`` on the split's training objects; one result row each.

    The test posteriors go to ``out / "<split>_<detector>.npz"`` (``P`` (n, s, m), ``A``, ``groups``, ``y``, ``K``).
    """
    attributes = list(split.kept_attributes)
    train, test = split_masks(features, split)
    A = features.attributes.loc[features.objects, attributes].to_numpy(dtype=int)
    groups = features.objects
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=int)
    y = pd.Index(split.test_objects).get_indexer(groups[test])
    seed = model_seed(config.study_seed, index, 0)
    reference = attribute_bank(config, attributes, seed)
    rows = []
    for label, params in DETECTORS:
        if label not in labels:
            continue
        bank = clone(reference).set_params(**params)
        start = time.process_time()
        bank.fit(features.X[train], A[train], groups[train])
        cpu = time.process_time() - start
        P = bank.predict_proba(features.X[test])
        np.savez(out / f"{split.name}_{label}.npz", P=P, A=A[test], groups=groups[test], y=y, K=K)
        correct = avgdap_correct(P, K, y, seed)
        hard = (P.mean(axis=1) >= 0.5).astype(int)
        edges = [bool(getattr(est, "grid_edges_", ())) for per in bank.estimators_ for est in per]
        fitted = f"{bank.detector_} ({type(bank.estimators_[0][0]).__name__})"
        rows.append({
            "split": split.name, "detector": label, "fitted": fitted, "accuracy": correct.mean(),
            "attribute_bacc": np.nanmean(per_attribute_balanced_accuracy(A[test], hard)),
            "accuracy_if_independent": accuracy_if_independent(P, A[test], K, y, seed),
            "error_correlation": within_object_error_correlation(A[test], hard, groups[test]),
            "error_correlation_trial": within_object_error_correlation(A[test], hard, groups[test], level="trial"),
            "at_grid_edge": np.mean(edges), "cpu_seconds": cpu,
            "auto_scores": str(bank.detector_choice_.get("scores", "")),
            "correct": correct, "classes": groups[test],
        })
        print(f"{split.name} {label}: accuracy {correct.mean():.3f}, attribute bacc {rows[-1]['attribute_bacc']:.3f}, "
              f"error correlation {rows[-1]['error_correlation']:.3f}, {cpu:.0f} s cpu"
              + (f", chose {bank.detector_}" if label == "auto" else ""), flush=True)
    return rows


def summary(rows: pd.DataFrame) -> pd.DataFrame:
    """Mean per split kind and detector, and the paired difference to the first detector with its interval."""
    out = []
    reference = DETECTORS[0][0]
    for kind, sub in rows.groupby("kind", sort=False):
        ref = sub[sub["detector"] == reference].set_index("split")
        for label, part in sub.groupby("detector", sort=False):
            part = part.set_index("split").loc[ref.index]
            correct = np.concatenate(part["correct"].to_list())
            classes = np.concatenate(part["classes"].to_list())
            splits = np.concatenate([np.full(len(c), s) for s, c in zip(part.index, part["correct"], strict=True)])
            acc = bootstrap_accuracy(correct, classes=classes, splits=splits)
            diff = paired_difference_interval(correct, np.concatenate(ref["correct"].to_list()),
                                              classes=classes, splits=splits)
            out.append({"kind": kind, "detector": label, "splits": len(part), "accuracy": acc[0],
                        "ci95_low": acc[1], "ci95_high": acc[2], f"minus_{reference}": diff[0],
                        "diff_low": diff[1], "diff_high": diff[2], "attribute_bacc": part["attribute_bacc"].mean(),
                        "accuracy_if_independent": part["accuracy_if_independent"].mean(),
                        "error_correlation": part["error_correlation"].mean(),
                        "error_correlation_trial": part["error_correlation_trial"].mean(),
                        "at_grid_edge": part["at_grid_edge"].mean(), "cpu_seconds": part["cpu_seconds"].mean(),
                        "fitted": "; ".join(sorted(set(part["fitted"])))})
    return pd.DataFrame(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n-random", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--purpose", choices=PURPOSES, default="select")
    ap.add_argument("--no-challenging", action="store_true", help="random splits only")
    ap.add_argument("--no-random", action="store_true", help="challenging splits only")
    ap.add_argument("--detectors", nargs="+", default=[d for d, _ in DETECTORS], choices=[d for d, _ in DETECTORS])
    args = ap.parse_args()
    if DETECTORS[0][0] not in args.detectors:
        ap.error(f"--detectors must include the reference {DETECTORS[0][0]!r}")
    args.out.mkdir(parents=True, exist_ok=True)
    features = dataset_features("phac2-penn")
    warnings.simplefilter("ignore", GridEdgeWarning)
    rows = []
    for kind, index, split in study_splits(features, args.n_random, args.seed, args.purpose):
        if (args.no_challenging and kind == "challenging") or (args.no_random and kind == "random"):
            continue
        config = ZeroShotSettings.of_preset("phac2-dap",
                                            splits={"n_splits": args.n_random, "seed": args.seed,
                                                    "purpose": args.purpose},
                                            compute={"cache": False, "n_jobs": 1, "progress": False}, svm={"cv": 5})
        rows += [{"kind": kind, **r} for r in score_split(features, split, config, index, args.detectors, args.out)]
        table = pd.DataFrame(rows)
        table.drop(columns=["correct", "classes"]).to_csv(args.out / "detectors.csv", index=False)  # after each split
    result = summary(table)
    result.to_csv(args.out / "detectors_summary.csv", index=False)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(result.round(3).to_string(index=False))


if __name__ == "__main__":
    main()
