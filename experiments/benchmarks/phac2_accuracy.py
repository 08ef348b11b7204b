"""Stage 2 of the PHAC-2 accuracy benchmark: candidate methods on cached DAP posteriors.

Reads the per-split posteriors written by :mod:`benchmarks.phac2_posteriors` and scores, on the
same splits (20 seeded random, 5 challenging):

* ``dap-avg[paper]`` (the reference: AVGDAP, uniform prior, the paper's gamma grid),
  ``dap-avg[extended]`` (the extended gamma grid) and, where stage 1 fitted it,
  ``dap-avg[adaptive]`` (the extended grid widened at a chosen end of C or gamma);
* ``eszsl`` and ``sae`` (registry methods, both BioTacs side by side);
* ``dap-reliab``: DAP with per-attribute weights from the out-of-fold (grouped-CV) balanced
  accuracy of each attribute on the training objects;
* ``ens-*``: a convex combination of trial-wise z-scored class scores of DAP and ESZSL/SAE, the
  weight chosen by pseudo zero-shot folds of the *training* objects (DAP: their out-of-fold
  posteriors; ESZSL/SAE: refitted without the fold's objects);
* ``*+hub``: the same scores with each class column z-scored over the split's test trials
  (hubness correction; transductive: uses the unlabelled test trials together, no labels).

Every choice is made on training objects only. Output: one row per method and split kind with
the mean accuracy, the two-level bootstrap 95% interval (splits, then test objects) and the
paired difference to AVGDAP[paper] with its interval, and beside it ``grid_summary.csv`` (per
grid: the chosen SVMs' mean grouped-CV log-loss, the share of fits whose chosen C or gamma sits
at an end of its final grid, the share of fits at each gamma and the mean fit CPU seconds per
split) and ``grid_pairs.csv`` (each grid against the previous one, ``extended`` - ``paper`` and
``adaptive`` - ``extended``: paired AVGDAP difference on the same trials with its interval)::

    nice -n 5 python experiments/benchmarks/phac2_accuracy.py --cache /tmp/tzsl_accuracy \
        --out /tmp/tzsl_accuracy/accuracy.csv

``make numbers BENCH_RESULTS=/tmp/tzsl_accuracy`` writes both into ``experiments/benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import warnings
from itertools import pairwise
from pathlib import Path

import numpy as np
import pandas as pd
from phac2_posteriors import DEFAULT_PURPOSE, GRIDS, study_splits

from tzsl.evaluation import PURPOSES, bootstrap_accuracy, paired_difference_interval
from tzsl.features import dataset_features
from tzsl.models import build_method
from tzsl.models.protocol import attribute_rows
from tzsl.studies.zero_shot.study import split_masks

EPS = 1e-6
WEIGHTS = np.linspace(0.0, 1.0, 11)


def dap_scores(P: np.ndarray, K: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """AVGDAP log-scores with the uniform prior and optional attribute weights; (n, k)."""
    p = np.clip(P.mean(axis=1), EPS, 1 - EPS)
    w = np.ones(K.shape[1]) if w is None else w
    return (np.log(p) * w) @ K.T + (np.log1p(-p) * w) @ (1 - K).T


def zrows(S: np.ndarray) -> np.ndarray:
    """Each trial's class scores z-scored across the candidate classes."""
    sd = S.std(axis=1, keepdims=True)
    return (S - S.mean(axis=1, keepdims=True)) / np.where(sd > 0, sd, 1.0)


def zcols(S: np.ndarray) -> np.ndarray:
    """Hubness correction: each class column z-scored over the trials (then rows, for scale)."""
    sd = S.std(axis=0, keepdims=True)
    return zrows((S - S.mean(axis=0, keepdims=True)) / np.where(sd > 0, sd, 1.0))


def reliability(P_oof: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Per-attribute weight ``max(0, 2 * bacc - 1)`` of the fused out-of-fold posteriors; (m,)."""
    pred = P_oof.mean(axis=1) >= 0.5
    pos = A.astype(bool)
    bacc = 0.5 * ((pred & pos).sum(0) / np.maximum(pos.sum(0), 1)
                  + (~pred & ~pos).sum(0) / np.maximum((~pos).sum(0), 1))
    return np.clip(2 * bacc - 1, 0.0, None)


def embedding_scores(name: str, X_tr, objects_tr, rows_tr, X_te, K, params=None):
    """Class scores of a registry embedding method fitted on the training trials; ((n_te, k), model)."""
    model = build_method(name, **(params or {}))
    model.fit(X_tr, attribute_rows(objects_tr, rows_tr), objects_tr)
    return model.decision_function(X_te, K), model


def fixed_params(name: str, model) -> dict:
    """The ridges a CV model chose (on the training objects), to refit it quickly inside pseudo folds."""
    am = getattr(model, "estimator_", model).attribute_model_  # the registry's methods wrap it in a calibrator
    if name == "eszsl":
        return {"gammas": (am.best_gamma_,), "lams": (am.best_lam_,)}
    return {"lams": (am.best_lam_,)}


def pseudo_zsl(features, split, train, P_oof, attrs, methods: dict, n_folds=5, seed=0):
    """Out-of-fold class scores on the training objects, folds of whole objects as pseudo-unseen classes.

    Returns a list of (y, {method: scores}) per fold, scores (n_fold_trials, n_fold_objects).
    """
    objects = features.objects[train]
    uniq = np.unique(objects)
    rng = np.random.default_rng(seed)
    fold_of = dict(zip(uniq, rng.permutation(np.arange(uniq.size) % n_folds), strict=True))
    fold = np.array([fold_of[o] for o in objects])
    X = features.X[train].reshape(train.sum(), -1)
    table = features.attributes.loc[:, attrs]
    out = []
    for f in range(n_folds):
        te = fold == f
        fo = np.unique(objects[te])
        K = table.loc[fo].to_numpy(dtype=float)
        y = pd.Index(fo).get_indexer(objects[te])
        scores = {"dap": dap_scores(P_oof[te], K)}
        rows_tr = table.loc[np.unique(objects[~te])].to_numpy(dtype=float)
        for name, params in methods.items():
            scores[name] = embedding_scores(name, X[~te], objects[~te], rows_tr, X[te], K, params)[0]
        out.append((y, scores))
    return out


def choose_weight(folds, first: str, other: str, hub: bool) -> float:
    """Weight ``w`` of ``w * z(first) + (1 - w) * z(other)`` maximising pseudo-ZSL accuracy (ties: larger w)."""
    norm = zcols if hub else zrows
    acc = np.zeros(WEIGHTS.size)
    for y, s in folds:
        a, b = norm(s[first]), norm(s[other])
        for i, w in enumerate(WEIGHTS):
            acc[i] += ((w * a + (1 - w) * b).argmax(1) == y).sum()
    return float(WEIGHTS[np.flatnonzero(acc == acc.max())[-1]])


def base_scores(features, split, index: int, cache: Path) -> dict | None:
    """Test and pseudo-ZSL scores of the base methods on one split (cached in ``cache``)."""
    import pickle

    files = {g: cache / f"{g}_{split.name}.npz" for g in GRIDS}
    if not (files["paper"].exists() and files["extended"].exists()):
        return None
    K = features.attributes.loc[list(split.test_objects), list(split.kept_attributes)].to_numpy(dtype=float)
    dap = {f"dap-avg[{g}]": dap_scores(np.load(f)["P_test"], K) for g, f in files.items() if f.exists()}
    path = cache / f"scores_{split.name}.pkl"
    if path.exists():  # the expensive part; the DAP scores of every grid fitted so far are added each time
        out = pickle.loads(path.read_bytes())
        out["S"] = {**dap, **{k: v for k, v in out["S"].items() if k not in dap}}
        return out
    paper = np.load(files["paper"])
    attrs = list(split.kept_attributes)
    train, test = split_masks(features, split)
    objects = features.objects
    y = pd.Index(split.test_objects).get_indexer(objects[test])
    A_tr = features.attributes.loc[objects[train], attrs].to_numpy(dtype=float)
    rows_tr = features.attributes.loc[np.unique(objects[train]), attrs].to_numpy(dtype=float)
    X = features.X.reshape(len(objects), -1)
    S = {**dap, "dap-reliab": dap_scores(paper["P_test"], K, reliability(paper["P_oof"], A_tr))}
    chosen_params = {}
    for name in ("eszsl", "sae"):
        S[name], model = embedding_scores(name, X[train], objects[train], rows_tr, X[test], K)
        chosen_params[name] = fixed_params(name, model)
    folds = pseudo_zsl(features, split, train, paper["P_oof"], attrs, chosen_params, seed=index)
    out = {"S": S, "y": y, "folds": folds, "test_objects": np.asarray(split.test_objects)}
    path.write_bytes(pickle.dumps({**out, "S": {k: v for k, v in S.items() if k not in dap}}))
    return out


def candidates(base: dict) -> tuple[dict, dict]:
    """Every candidate's test class scores from the base scores; (scores, chosen weights)."""
    S = dict(base["S"])
    folds = base["folds"]
    chosen = {}
    for a, b in (("dap", "eszsl"), ("dap", "sae"), ("eszsl", "sae")):
        for hub in (False, True):
            w = choose_weight(folds, a, b, hub)
            norm = zcols if hub else zrows
            label = f"ens-{a}-{b}" + ("+hub" if hub else "")
            ta = S["dap-avg[paper]"] if a == "dap" else S[a]
            S[label] = w * norm(ta) + (1 - w) * norm(S[b])
            chosen[label] = w
    S["mean-dap-eszsl-sae"] = sum(zrows(S[k]) for k in ("dap-avg[paper]", "eszsl", "sae"))
    S["mean-dapext-eszsl-sae"] = sum(zrows(S[k]) for k in ("dap-avg[extended]", "eszsl", "sae"))
    S["mean-eszsl-sae"] = zrows(S["eszsl"]) + zrows(S["sae"])
    S["mean-dap-eszsl-sae+hub"] = sum(zcols(S[k]) for k in ("dap-avg[paper]", "eszsl", "sae"))
    w3 = choose_simplex(folds)
    S["wmean-dap-eszsl-sae"] = sum(w * zrows(S[k])
                                   for w, k in zip(w3, ("dap-avg[paper]", "eszsl", "sae"), strict=True))
    chosen["wmean-dap-eszsl-sae"] = w3[0]
    for name in ("dap-avg[paper]", "eszsl", "sae"):
        S[f"{name}+hub"] = zcols(S[name])
    return S, chosen


def choose_simplex(folds, step: float = 0.25) -> tuple[float, float, float]:
    """Weights of (DAP, ESZSL, SAE) on a simplex grid maximising pseudo-ZSL accuracy (ties: most equal)."""
    grid = [(a, b, 1 - a - b) for a in np.arange(0, 1 + 1e-9, step) for b in np.arange(0, 1 - a + 1e-9, step)]
    best, key = None, None
    for w in grid:
        hits = sum(((w[0] * zrows(s["dap"]) + w[1] * zrows(s["eszsl"]) + w[2] * zrows(s["sae"])).argmax(1) == y).sum()
                   for y, s in folds)
        k = (hits, -np.ptp(w))
        if key is None or k > key:
            best, key = w, k
    return best


def grid_summary(cache: Path) -> pd.DataFrame:
    """Per grid: the chosen SVMs' mean grouped-CV log-loss, share at a grid edge, where the chosen gamma sits, CPU.

    ``share_at_edge``: fits whose chosen C or gamma is at an end of its final grid (for
    ``adaptive``, an end whose extensions were exhausted); ``gamma<1e-4`` / ``gamma>1``: fits
    whose chosen gamma lies outside the extended grid; ``cpu_seconds_per_split``: mean CPU time
    of a split's attribute fits.
    """
    rows = []
    for grid in GRIDS:
        files = sorted(cache.glob(f"{grid}_*.npz"))
        if not files:
            continue
        z = [np.load(f) for f in files]
        ll = np.concatenate([f["log_loss"].ravel() for f in z])
        gam = np.concatenate([f["gamma"].ravel() for f in z])
        edge = np.concatenate([f["at_edge"].ravel() for f in z]) if all("at_edge" in f for f in z) else None
        rows.append({"grid": grid, "n_splits": len(z), "n_fits": ll.size, "mean_cv_log_loss": ll.mean(),
                     "share_at_edge": np.nan if edge is None else float(edge.mean()),
                     "cpu_seconds_per_split": float(np.mean([f["cpu_seconds"] for f in z])),
                     "gamma<1e-4": float(np.mean(gam < 1e-4 * (1 - 1e-9))),
                     **{f"gamma={g:g}": float(np.mean(np.isclose(gam, g))) for g in (1e-4, 1e-3, 1e-2, 1e-1, 1.0)},
                     "gamma>1": float(np.mean(gam > 1.0 * (1 + 1e-9)))})
    return pd.DataFrame(rows)


def grid_pairs(trials: pd.DataFrame) -> pd.DataFrame:
    """Each grid's ``dap-avg`` minus the previous grid's (``GRIDS`` order), paired on the same trials, per kind."""
    rows = []
    for kind in dict.fromkeys(trials["kind"]):
        t = trials[trials.kind == kind]
        for before, after in pairwise(GRIDS):
            a, b = t[t.method == f"dap-avg[{after}]"], t[t.method == f"dap-avg[{before}]"]
            common = np.intersect1d(a.split.unique(), b.split.unique())
            if not common.size:
                continue
            a, b = a[a.split.isin(common)], b[b.split.isin(common)]
            cluster = {"classes": a["class"].to_numpy(), "splits": a.split.to_numpy()}
            d = paired_difference_interval(a.correct.to_numpy(), b.correct.to_numpy(), **cluster)
            rows.append({"kind": kind, "method": f"dap-avg[{after}]", "reference": f"dap-avg[{before}]",
                         "n_splits": common.size, "accuracy": bootstrap_accuracy(a.correct.to_numpy(), **cluster).mean,
                         "reference_accuracy": bootstrap_accuracy(b.correct.to_numpy(), **cluster).mean,
                         "diff": d.mean, "diff_ci95_low": d.ci95_low, "diff_ci95_high": d.ci95_high})
    return pd.DataFrame(rows)


def run(cache: Path, n_random: int, seed: int, purpose: str = DEFAULT_PURPOSE) -> pd.DataFrame:
    features = dataset_features("phac2-penn")
    records = []
    for kind, index, split in study_splits(features, n_random, seed, purpose):
        base = base_scores(features, split, index, cache)
        if base is None:
            continue
        S, chosen = candidates(base)
        y = base["y"]
        for name, scores in S.items():
            correct = scores.argmax(1) == y
            records.append(pd.DataFrame({"kind": kind, "split": split.name, "method": name,
                                         "class": base["test_objects"][y], "correct": correct.astype(float),
                                         "weight": chosen.get(name, np.nan)}))
        print(split.name, {k: round(float((v.argmax(1) == y).mean()), 3) for k, v in S.items()}, chosen, flush=True)
    return pd.concat(records, ignore_index=True)


def summarise(trials: pd.DataFrame, reference: str = "dap-avg[paper]") -> pd.DataFrame:
    rows = []
    for (kind, method), t in trials.groupby(["kind", "method"], sort=False):
        ref = trials[(trials.kind == kind) & (trials.method == reference)]
        iv = bootstrap_accuracy(t.correct.to_numpy(), classes=t["class"].to_numpy(), splits=t.split.to_numpy())
        d = paired_difference_interval(t.correct.to_numpy(), ref.correct.to_numpy(), classes=t["class"].to_numpy(),
                                       splits=t.split.to_numpy())
        rows.append({"kind": kind, "method": method, "accuracy": iv.mean, "ci95_low": iv.ci95_low,
                     "ci95_high": iv.ci95_high, "diff_vs_avgdap": d.mean, "diff_ci95_low": d.ci95_low,
                     "diff_ci95_high": d.ci95_high, "n_splits": t.split.nunique(),
                     "mean_weight": t.groupby("split").weight.first().mean()})
    return pd.DataFrame(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--n-random", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--purpose", choices=PURPOSES, default=DEFAULT_PURPOSE,
                    help="the random splits stage 1 fitted (its --purpose)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    grid = grid_summary(args.cache)
    grid.to_csv(args.out.with_name("grid_summary.csv"), index=False, float_format="%.4f")
    print(grid.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    trials = run(args.cache, args.n_random, args.seed, args.purpose)
    table = summarise(trials)
    # which random splits these are (the challenging partitions have no seed and no purpose)
    random = table["kind"] == "random"
    table.insert(1, "purpose", np.where(random, args.purpose, ""))
    table.insert(2, "seed", np.where(random, str(args.seed), ""))
    table.to_csv(args.out, index=False, float_format="%.4f")
    pairs = grid_pairs(trials)
    pairs.to_csv(args.out.with_name("grid_pairs.csv"), index=False, float_format="%.4f")
    with pd.option_context("display.width", 200):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
        print(pairs.to_string(index=False, float_format=lambda v: f"{v:.3f}"))


if __name__ == "__main__":
    main()
