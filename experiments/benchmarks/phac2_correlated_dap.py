"""DAP with correlated attribute errors on PHAC-2 (issue 32): a Gaussian rule over held-out detector logits.

Hypotheses (stated before any run on selection splits)
------------------------------------------------------
H1, "DAP with correlated errors": DAP scores class ``c`` by ``sum_a log p(a = K[c, a] | x)``, as
if the attributes' errors were independent; on an unseen object they come together. Model a
trial's fused detector logits ``s`` (m,) as Gaussian around its class's expected logits,
``s ~ N(mu(K[c]), Sigma)``, with ``mu_a(1)``, ``mu_a(0)`` and ``Sigma`` estimated on the
*held-out* logits of the training objects (object-grouped CV: each training object scored by
detectors that never saw it, as an unseen object is), and score ``c`` by
``-0.5 (s - mu(K[c]))^T Sigma^-1 (s - mu(K[c]))`` (method ``gauss-full``).

H2 (own): part of DAP's loss is not the correlation but the detectors' posteriors on unseen
objects, which are fitted on the same objects they are scored for in training and so are
over-confident and shifted; the same rule with a diagonal ``Sigma`` (each attribute recalibrated
on held-out training objects, errors still independent: ``gauss-diag``) beats DAP too. Comparing
``gauss-full`` with ``gauss-diag`` isolates what the correlation adds.

Choices fixed before measuring
------------------------------
* Detectors: those of the registered ``dap-avg-logistic-c1`` (:func:`fit_predict_split`, bare),
  unchanged; its own predictions are the reference ``dap-avg-logistic-c1``.
* ``s``: the logit of the sensor-averaged posterior (AVGDAP's fusion,
  :func:`tzsl.models.dap.fuse_attribute_posteriors`), clipped to ``[1e-6, 1 - 1e-6]``.
* Held-out logits: 10 object-grouped folds of the training objects
  (:func:`tzsl.models.protocol.class_grouped_folds` over objects), the bank cloned and refitted
  per fold without ``groups`` (:class:`~tzsl.models.LogisticAttribute` ignores them; the bank's
  at-least-2-objects check then counts trials, so an attribute with 2 positive training objects is
  still scored on each of them by a detector that saw the other); an attribute present or absent
  in fewer than 2 of a fold's training trials is left out of that fold's fit and its held-out
  logits are missing (residual 0 in ``Sigma``; their share is ``missing``). A ``mu_a(v)`` with no
  held-out logit at all is the mean in-sample logit of the split's final detectors over the
  training trials with ``a = v`` (their count is ``mu_fallbacks``).
* ``mu_a(v)``: the mean over training objects with ``a = v`` of the object's mean held-out logit.
* ``Sigma``: Ledoit-Wolf (:class:`sklearn.covariance.LedoitWolf`) of the per-TRIAL residuals
  ``s - mu(A)``. Why trial-level: one test trial is scored at a time, and its deviation from its
  class's mean logits is its object's effect plus its own trial noise, so the covariance of a
  trial given its class is the total (between- plus within-object) covariance. The covariance of
  per-object mean residuals (``gauss-object``) keeps only the between-object part; it is reported
  as a diagnostic and never adopted.

Decision rule (fixed before running on selection splits)
--------------------------------------------------------
On the selection splits (20 random splits, ``--purpose select --seed 0``, and the 5 challenging
splits) the criterion of a method is the mean of its random-split accuracy and its challenging-
split accuracy (each the mean over splits, :func:`tzsl.evaluation.bootstrap_accuracy`'s point).
``gauss-full`` (H1) is adopted if its criterion is higher than ``dap-avg-logistic-c1``'s;
``gauss-diag`` (H2) by the same rule; if both pass, the higher criterion is adopted. Only an
adopted method is run once on confirmation splits (``--purpose confirm --seed 32 --n-random 50``
and every challenging split, ``--references`` adding ``dap-avg`` and ``eszsl``).

Outcome: on the selection splits neither ``gauss-full`` nor ``gauss-diag`` passed the rule (both
below ``dap-avg-logistic-c1`` on random and challenging splits), so neither was run on
confirmation splits nor registered; the numbers are in the issue's record, not typed here.

Measurements
------------
(a) error structure of the held-out training logits (``oof_``) and of the test logits
(``test_``, residuals against the training ``mu``): ``between_share`` (share of the residual sum
of squares, pooled over attributes, that lies between objects), ``obj_corr`` / ``obj_abs_corr``
(mean off-diagonal correlation, and its absolute value, across attributes of the per-object mean
residuals), ``obj_err_corr`` (the same of truth-signed residuals ``(1 - 2 a) r``: positive when
the errors of an object's attributes come together), ``within_corr`` (the same of the trials'
deviations from their object's mean), ``error_dispersion`` (the variance over trials of the count
of a trial's 0/1 attribute errors, logit >= 0 read as present, over the variance that count would
have were the attributes' errors independent with the same rates: 1 independent, above 1 the
errors pile onto the same trials); and the 0/1 error correlation of
:func:`tzsl.evaluation.within_object_error_correlation` on the test objects.
(b) per-trial correctness of every rule; ``summary.csv``: accuracy [two-level bootstrap 95%
interval] per kind and method and the paired difference to each reference
(:func:`tzsl.evaluation.paired_differences_table`); ``decision.csv``: the criterion.

Per-split held-out logits are cached in ``--out`` (``<split>.npz``)::

    nice -n 5 python experiments/benchmarks/phac2_correlated_dap.py --out /tmp/lever32-select --purpose select \
        --seed 0 --n-random 20
    nice -n 5 python experiments/benchmarks/phac2_correlated_dap.py --out /tmp/lever32-confirm --purpose confirm \
        --seed 32 --n-random 50 --references
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from phac2_detectors_confirm import MEMBERS, splits_of
from scipy.special import logit
from sklearn.base import clone
from sklearn.covariance import LedoitWolf

from tzsl.evaluation import (
    PURPOSES,
    bootstrap_accuracy,
    paired_differences_table,
    within_object_error_correlation,
)
from tzsl.features import dataset_features
from tzsl.models import GridEdgeWarning
from tzsl.models.dap import break_ties, fuse_attribute_posteriors
from tzsl.models.protocol import class_grouped_folds
from tzsl.studies.config import ZeroShotSettings
from tzsl.studies.zero_shot.methods import fit_predict_split
from tzsl.studies.zero_shot.study import split_masks

DETECTOR_METHOD = "dap-avg-logistic-c1"
#: Object-grouped folds of the training objects for the held-out logits.
N_FOLDS = 10
#: Posterior clip before the logit.
EPS = 1e-6
#: The rules scored from the held-out logits: label -> covariance kind.
RULES = {"gauss-full": "trial", "gauss-diag": "diagonal", "gauss-object": "object"}
#: Methods the decision rule may adopt (gauss-object is a diagnostic).
CANDIDATES = ("gauss-full", "gauss-diag")


def fused_logits(bank, X: np.ndarray) -> np.ndarray:
    """Logit of the sensor-averaged posterior of a fitted bank, shape (n_trials, n_attributes)."""
    present, _ = fuse_attribute_posteriors(bank.predict_proba(X), "avg")
    return logit(np.clip(present, EPS, 1 - EPS))


def held_out_logits(template, X: np.ndarray, A: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Fused logits (n, m) of every training trial from a clone of ``template`` fitted without its object.

    NaN where an attribute was present or absent in fewer than 2 of a fold's training trials (not fitted there).
    """
    S = np.full(A.shape, np.nan)
    for fit_rows, held in class_grouped_folds(groups, N_FOLDS, "held-out logits (objects)"):
        varies = ((A[fit_rows] == 1).sum(axis=0) >= 2) & ((A[fit_rows] == 0).sum(axis=0) >= 2)
        bank = clone(template).fit(X[fit_rows], A[fit_rows][:, varies])  # no groups: see the module docstring
        S[np.ix_(held, np.flatnonzero(varies))] = fused_logits(bank, X[held])
    return S


def object_means(R: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-object NaN-ignoring mean rows (n_objects, m) of ``R`` (n, m) and each trial's object index (n,)."""
    _, codes = np.unique(groups, return_inverse=True)
    codes = codes.ravel()
    means = np.stack([np.nanmean(R[codes == o], axis=0) for o in range(codes.max() + 1)])
    return means, codes


def class_means(S: np.ndarray, A: np.ndarray, groups: np.ndarray, S_fit: np.ndarray) -> tuple[np.ndarray, int]:
    """``mu`` of shape (2, m): mean over objects with ``a = v`` of the object's mean held-out logit.

    Where no held-out logit of value ``v`` exists, the mean in-sample logit ``S_fit`` (n, m) of the
    trials with ``a = v``; returns ``(mu, number of such fallbacks)``.
    """
    with warnings.catch_warnings():  # an object or value without held-out logits: NaN, filled below
        warnings.simplefilter("ignore", RuntimeWarning)
        S_obj = object_means(S, groups)[0]
        A_obj = object_means(A.astype(float), groups)[0]
        mu = np.stack([[np.nanmean(S_obj[A_obj[:, a] == v, a]) for a in range(A.shape[1])] for v in (0, 1)])
    missing = np.isnan(mu)
    for v, a in zip(*np.nonzero(missing), strict=True):
        mu[v, a] = S_fit[A[:, a] == v, a].mean()
    return mu, int(missing.sum())


def residuals(S: np.ndarray, A: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """``s - mu(A)`` of shape (n, m); missing logits give residual 0."""
    R = S - np.where(A.astype(bool), mu[1], mu[0])
    return np.nan_to_num(R, nan=0.0)


def covariance(R: np.ndarray, groups: np.ndarray, kind: str) -> np.ndarray:
    """Ledoit-Wolf covariance (m, m) of trial residuals, of per-object mean residuals, or its diagonal."""
    if kind == "object":
        return LedoitWolf().fit(object_means(R, groups)[0]).covariance_
    C = LedoitWolf().fit(R).covariance_
    return np.diag(np.diag(C)) if kind == "diagonal" else C


def gaussian_scores(S: np.ndarray, K: np.ndarray, mu: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Class scores (n, k): ``-0.5 (s - mu(K[c]))^T C^-1 (s - mu(K[c]))``."""
    M = np.where(K.astype(bool), mu[1], mu[0])  # (k, m)
    D = S[:, None, :] - M[None]
    return -0.5 * np.einsum("nkm,ml,nkl->nk", D, np.linalg.inv(C), D)


def mean_off_diagonal(M: np.ndarray) -> tuple[float, float]:
    """Mean off-diagonal correlation across the columns of ``M`` (units x m), and of its absolute value."""
    keep = M.std(axis=0) > 0
    Cr = np.corrcoef(M[:, keep], rowvar=False)
    off = Cr[~np.eye(Cr.shape[0], dtype=bool)]
    return float(off.mean()), float(np.abs(off).mean())


def error_dispersion(S: np.ndarray, A: np.ndarray) -> float:
    """Variance of the per-trial count of 0/1 errors of logits ``S`` (n, m) over its value under independence."""
    known = ~np.isnan(S)
    errors = ((S >= 0) != A.astype(bool)) & known
    rates = errors.sum(axis=0) / np.maximum(known.sum(axis=0), 1)
    return float(errors.sum(axis=1).var() / (rates * (1 - rates)).sum())


def error_structure(S: np.ndarray, R: np.ndarray, A: np.ndarray, groups: np.ndarray) -> dict[str, float]:
    """Measurement (a) of logits ``S`` (n, m), their residuals ``R`` and the trials' objects ``groups`` and
    attributes ``A``."""
    R_obj, codes = object_means(R, groups)
    A_obj = object_means(A.astype(float), groups)[0]
    within = R - R_obj[codes]
    total = ((R - R.mean(axis=0)) ** 2).sum()
    corr, abs_corr = mean_off_diagonal(R_obj)
    return {"between_share": float(1 - (within ** 2).sum() / total), "obj_corr": corr, "obj_abs_corr": abs_corr,
            "error_dispersion": error_dispersion(S, A),
            "obj_err_corr": mean_off_diagonal((1 - 2 * A_obj) * R_obj)[0],
            "within_corr": mean_off_diagonal(within)[0]}


def score_split(features, split, seed: int, references: bool, out: Path) -> tuple[pd.DataFrame, dict]:
    """One split: per-trial correctness of DAP, every Gaussian rule and (``references``) the reference methods."""
    train, test = split_masks(features, split)
    attributes = list(split.kept_attributes)
    A = features.attributes.loc[features.objects, attributes].to_numpy(dtype=int)
    groups = features.objects
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=int)
    cache = out / f"{split.name}.npz"
    start = time.process_time()
    fit, y = fit_predict_split({"name": DETECTOR_METHOD, "calibration": "none"}, features, split, seed)
    rows = [(DETECTOR_METHOD, fit.predicted == y)]
    if cache.exists():
        S_oof = np.load(cache)["S_oof"]
    else:
        S_oof = held_out_logits(fit.model.attribute_model_, features.X[train], A[train], groups[train])
        np.savez(cache, S_oof=S_oof)
    S_test = fused_logits(fit.model.attribute_model_, features.X[test])
    mu, fallbacks = class_means(S_oof, A[train], groups[train],
                                fused_logits(fit.model.attribute_model_, features.X[train]))
    R_oof = residuals(S_oof, A[train], mu)
    for label, kind in RULES.items():
        scores = gaussian_scores(S_test, K, mu, covariance(R_oof, groups[train], kind))
        rows.append((label, break_ties(scores, random_state=seed) == y))
    if references:
        for label in ("dap-avg", "eszsl"):
            member, truth = fit_predict_split(MEMBERS[label], features, split, seed)
            rows.append((label, member.predicted == truth))
    hard = (S_test >= 0).astype(int)
    info = {"split": split.name, "missing": float(np.isnan(S_oof).mean()), "mu_fallbacks": fallbacks,
            "cpu_seconds": time.process_time() - start,
            "test_error_corr01": within_object_error_correlation(A[test], hard, groups[test]),
            **{f"oof_{k}": v for k, v in error_structure(S_oof, R_oof, A[train], groups[train]).items()},
            **{f"test_{k}": v for k, v in error_structure(S_test, residuals(S_test, A[test], mu), A[test],
                                                          groups[test]).items()}}
    classes = np.asarray(split.test_objects)[y]
    table = pd.concat([pd.DataFrame({"method": label, "split": split.name, "class": classes, "trial": np.arange(len(y)),
                                     "correct": correct.astype(float)}) for label, correct in rows], ignore_index=True)
    return table, info


def summary(trials: pd.DataFrame, references: tuple[str, ...]) -> pd.DataFrame:
    """Per kind and method: accuracy [interval] and the paired difference to each reference present."""
    out = []
    for kind, sub in trials.groupby("kind", sort=False):
        present = [r for r in references if r in set(sub["method"])]
        diffs = {r: paired_differences_table(sub.drop(columns="kind"), reference=r).set_index("method")
                 for r in present}
        for method, t in sub.groupby("method", sort=False):
            iv = bootstrap_accuracy(t["correct"].to_numpy(), classes=t["class"].to_numpy(),
                                    splits=t["split"].to_numpy())
            row = {"kind": kind, "method": method, "n_splits": t["split"].nunique(), "accuracy": iv.mean,
                   "ci95_low": iv.ci95_low, "ci95_high": iv.ci95_high}
            for r, d in diffs.items():
                hit = d.loc[method] if method in d.index else None
                for col, key in (("", "difference"), ("_low", "ci95_low"), ("_high", "ci95_high")):
                    row[f"minus_{r}{col}"] = np.nan if hit is None else hit[key]
            out.append(row)
    return pd.DataFrame(out)


def decision(result: pd.DataFrame) -> pd.DataFrame:
    """The rule of the module docstring: criterion = mean of the random and challenging accuracies."""
    wide = result.pivot(index="method", columns="kind", values="accuracy")
    wide["criterion"] = wide[["random", "challenging"]].mean(axis=1)
    wide["beats_dap"] = wide["criterion"] > wide.loc[DETECTOR_METHOD, "criterion"]
    wide["adoptable"] = wide.index.isin(CANDIDATES) & wide["beats_dap"]
    return wide.reset_index()


def lever_main(description: str, score: Callable, progress: Callable[[dict], str],
               decide: Callable[[pd.DataFrame], pd.DataFrame]) -> None:
    """The command line of a PHAC-2 lever script (this one, ``phac2_stacked_detectors.py``): fit and score
    every split of the chosen purpose with ``score(features, split, seed, references, out) -> (trials,
    info)``, print one line per split (accuracies and ``progress(info)``), then write ``summary.csv``
    and ``decision.csv`` (``decide(summary)``) and print them with the mean error structure."""
    ap = argparse.ArgumentParser(description=description.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n-random", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--purpose", choices=PURPOSES, default="select")
    ap.add_argument("--references", action="store_true", help="also fit dap-avg (RBF-SVM) and eszsl")
    ap.add_argument("--summarise", action="store_true", help="only summarise the trials.csv of --out")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.summarise:
        features = dataset_features("phac2-penn")
        warnings.simplefilter("ignore", GridEdgeWarning)
        config = ZeroShotSettings.of_preset("phac2-dap", splits={"seed": args.seed, "purpose": args.purpose,
                                                                 "n_splits": args.n_random})
        parts, infos = [], []
        for kind, index, split in splits_of(features, config, True):
            table, info = score(features, split, config.study_seed + index, args.references, args.out)
            parts.append(table.assign(kind=kind))
            infos.append({"kind": kind, **info})
            pd.concat(parts, ignore_index=True).to_csv(args.out / "trials.csv", index=False)
            pd.DataFrame(infos).to_csv(args.out / "error_structure.csv", index=False)
            acc = table.groupby("method", sort=False)["correct"].mean()
            print(f"{split.name}: " + ", ".join(f"{m} {a:.3f}" for m, a in acc.items()) + progress(info), flush=True)
    trials = pd.read_csv(args.out / "trials.csv")
    result = summary(trials, (DETECTOR_METHOD, "dap-avg", "eszsl"))
    result.to_csv(args.out / "summary.csv", index=False)
    chosen = decide(result)
    chosen.to_csv(args.out / "decision.csv", index=False)
    structure = pd.read_csv(args.out / "error_structure.csv").drop(columns="split").groupby("kind", sort=False).mean()
    with pd.option_context("display.width", 220, "display.max_columns", 30, "display.max_rows", 200):
        print(result.round(3).to_string(index=False))
        print(chosen.round(3).to_string(index=False))
        print(structure.round(3).T.to_string())


def main() -> None:
    lever_main(__doc__, score_split,
               lambda info: (f"; oof between-share {info['oof_between_share']:.2f}, obj err corr "
                             f"{info['oof_obj_err_corr']:.2f}; cpu {info['cpu_seconds']:.0f} s"),
               decision)


if __name__ == "__main__":
    main()
