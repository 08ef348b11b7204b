"""Active touch on the SIMULATED hand: choosing the next grasp type (or stopping) after each grasp.

The paper's Shadow-hand data are not public, so this runs on grasps simulated from Table 4
(:func:`tzsl.datasets.simulate_grasps`); every number it writes carries ``data = "simulated"``.

Per seed: a fresh simulated data set; :class:`tzsl.models.HandDAPClassifier` fitted on the
grasps of the training objects only; per test grasp the LDAP-fused DAP log-scores over the test
objects (DAP paper eqs. 9-10, 3). The posterior after several grasps is their sum (DF-MDAP,
eqs. 11-12: naive Bayes across grasps).

Grasp types (:data:`GRASP_TYPES`) are defined by how many BioTacs touch: ``pinch`` (1-2),
``tripod`` (3), ``power`` (4-5). A robot chooses a type, not the exact grasp, so a grasp of the
chosen type is drawn (without replacement) from the test object's grasps of that type.

Policy: the type with the largest expected reduction of class entropy
(:func:`tzsl.models.active_touch.expected_information_gain`) under a confusion model per type
(:func:`tzsl.models.active_touch.binned_confusion` of out-of-fold LDAP posteriors). Table 4 gives only 6
training objects, several attributes carried by a single one, so the folds are stratified over
the training *grasps* (as the model's own Platt calibration), not grouped by object: the
confusion is estimated on held-out grasps of seen objects and is therefore optimistic for unseen
objects. Compared with: always one type (``fixed:<type>``), a uniformly random type
(``random_type``), and a uniformly random grasp (``random_grasp``, the paper's sequences).
Stopping rule (post hoc on each trajectory): stop once the top class posterior >= a threshold.

Accuracy is per sequence (``n_sequences`` per test object and seed), with 95% intervals from
:func:`tzsl.evaluation.bootstrap_accuracy_columns` (seeds, then test objects, resampled).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from sklearn.model_selection import StratifiedKFold

from tzsl._parallel import reissued, relayed
from tzsl.datasets import HandTable, simulate_grasps
from tzsl.evaluation import bootstrap_accuracy_columns, paired_difference_interval
from tzsl.models.active_touch import binned_confusion, expected_information_gain, outcome_log_likelihoods
from tzsl.models.dap import break_ties
from tzsl.models.multigrasp import fuse_grasp_posteriors
from tzsl.studies.config import ActiveTouchStudy, HandSettings
from tzsl.studies.hand.study import fit_hand_model, hand_features

__all__ = ["GRASP_TYPES", "HAND_OUTPUTS", "grasp_type_of", "run_active_hand"]

#: Grasp types by the number of touching BioTacs (inclusive ranges).
GRASP_TYPES: dict[str, tuple[int, int]] = {"pinch": (1, 2), "tripod": (3, 3), "power": (4, 5)}
#: Files :func:`run_active_hand` writes.
HAND_OUTPUTS: tuple[str, ...] = ("active_touch_hand.csv", "active_touch_hand_stop.csv", "active_touch_hand.png")
_N_BINS, _SMOOTHING = 10, 1.0  # PerEPAttributeModel's defaults


def grasp_type_of(contact: np.ndarray) -> np.ndarray:
    """Index into :data:`GRASP_TYPES` of each grasp from its (n, F) touching-BioTac mask; -1 for none."""
    n = np.asarray(contact, dtype=bool).sum(axis=1)
    out = np.full(n.shape, -1)
    for t, (lo, hi) in enumerate(GRASP_TYPES.values()):
        out[(n >= lo) & (n <= hi)] = t
    return out


def _ldap(model, features) -> np.ndarray:
    P_mat, contact, P_sh = model.attribute_posteriors(features.to_array())
    return fuse_grasp_posteriors(P_mat, contact, P_sh, "ldap")


def _type_confusion(features, table: HandTable, config: HandSettings, cv: int, seed: int,
                    columns: list[str]) -> np.ndarray:
    """Confusion (n_types, n_attributes, 2, n_bins) from out-of-fold LDAP posteriors of training grasps."""
    train = np.flatnonzero(np.isin(features.objects, table.train_objects) & features.contact.any(axis=1))
    tr = features.subset(train)
    oof = np.full((len(tr), len(columns)), np.nan)
    folds = StratifiedKFold(n_splits=cv, shuffle=True, random_state=seed)
    for fit_idx, held in folds.split(np.zeros(len(tr)), tr.objects):
        model = fit_hand_model(tr.subset(fit_idx), table, config, seed)
        oof[held] = _ldap(model, tr.subset(held))[:, [list(model.K_.columns).index(c) for c in columns]]
    types = grasp_type_of(tr.contact)
    P = np.where(types[None, :, None] == np.arange(len(GRASP_TYPES))[:, None, None], oof[None], np.nan)
    A = table.K.loc[tr.objects, columns].to_numpy(dtype=int)
    return binned_confusion(P, A, n_bins=_N_BINS, smoothing=_SMOOTHING)


def _sequences(S: np.ndarray, obj: np.ndarray, types: np.ndarray, L: np.ndarray | None, strategy: str,
               n_sequences: int, max_grasps: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Predictions and top posteriors (n_objects * n_sequences, max_grasps) of one strategy.

    ``S`` (n_grasps, n_classes) per-grasp log-scores, ``obj`` (n_grasps,) class index of each
    grasp's object, ``types`` (n_grasps,) grasp type; sequences of object ``z`` are rows
    ``z * n_sequences ...``.
    """
    n_cls, n_types = S.shape[1], len(GRASP_TYPES)
    seq_obj = np.repeat(np.arange(n_cls), n_sequences)
    n = seq_obj.size
    mine = obj[None, :] == seq_obj[:, None]  # (n, G) grasps of the sequence's object
    keys = rng.random(mine.shape)
    used = np.zeros(mine.shape, dtype=bool)
    total = np.zeros((n, n_cls))
    pred, top = np.empty((n, max_grasps), dtype=int), np.empty((n, max_grasps))
    lb = total - np.logaddexp.reduce(total, axis=1, keepdims=True)  # normalised log posterior after each step
    fixed = strategy.removeprefix("fixed:")
    for step in range(max_grasps):
        left = mine & ~used
        if not left.any(axis=1).all():
            raise ValueError("a test object has fewer grasps than max_grasps")
        avail = np.stack([(left & (types[None, :] == t)).any(axis=1) for t in range(n_types)], axis=1)  # (n, T)
        if strategy == "random_grasp":
            allowed = left
        else:
            if strategy == "active":
                score = expected_information_gain(lb, L)
            elif strategy == "random_type":
                score = rng.random((n, n_types))
            else:  # a fixed type first; another type only when the object has no grasp of it left
                score = (np.array(list(GRASP_TYPES)) == fixed).astype(float)[None, :] + 0.01 * rng.random((n, n_types))
            choice = np.where(avail, score, -np.inf).argmax(axis=1)
            allowed = left & (types[None, :] == choice[:, None])
        g = np.where(allowed, keys, -1.0).argmax(axis=1)
        used[np.arange(n), g] = True
        total += S[g]
        lb = total - np.logaddexp.reduce(total, axis=1, keepdims=True)
        pred[:, step] = break_ties(lb, rng)
        top[:, step] = np.exp(lb.max(axis=1))
    return pred, top


def _evaluate_seed(table: HandTable, study: HandSettings, config: ActiveTouchStudy, seed: int,
                   strategies: Sequence[str]) -> dict:
    sim = simulate_grasps(table.K, **study.simulation.model_dump(), random_state=seed)
    features = hand_features(sim.grasps, table, study)
    model = fit_hand_model(features, table, study, seed)
    columns = list(model.K_.columns)
    names = list(table.test_objects)
    K = table.K.loc[names, columns].to_numpy(dtype=float)
    test = np.isin(features.objects, names) & features.contact.any(axis=1)
    te = features.subset(test)
    S = model.dap_rule().decision_function(_ldap(model, te), K)
    obj = pd.Index(names).get_indexer(te.objects)
    types = grasp_type_of(te.contact)
    L = outcome_log_likelihoods(_type_confusion(features, table, study, config.hand.cv, seed, columns), K,
                                config.methods.n_samples, random_state=seed)
    out = {}
    for i, s in enumerate(strategies):
        rng = np.random.default_rng([seed, i])
        pred, top = _sequences(S, obj, types, L, s, config.hand.n_sequences, config.hand.max_grasps, rng)
        out[s] = {"correct": (pred == np.repeat(np.arange(len(names)), config.hand.n_sequences)[:, None]).astype(float),
                  "top": top}
    return {"strategies": out, "objects": np.repeat(names, config.hand.n_sequences), "n_classes": len(names),
            "type_share": np.bincount(types, minlength=len(GRASP_TYPES)) / len(types)}


def _figure(table: pd.DataFrame):
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for i, (s, g) in enumerate(table.groupby("strategy", sort=False)):
        ax.plot(g["grasps"], g["accuracy"], "-o", ms=3, color=f"C{i}", label=s)
        if s in ("active", "random_grasp"):  # the main comparison's intervals; every interval is in the CSV
            ax.fill_between(g["grasps"], g["ci95_low"], g["ci95_high"], color=f"C{i}", alpha=0.15)
    ax.axhline(table["chance"].iloc[0], color="k", lw=0.8, ls="--", label="chance")
    ax.set_xlabel("grasps done")
    ax.set_ylabel("accuracy")
    ax.set_title("SIMULATED hand: choosing the next grasp type\n(bands: 95% intervals of active and random grasp)",
                 fontsize=10)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def run_active_hand(table: HandTable, results_dir, config: ActiveTouchStudy,
                    log: Callable[[str], None] | None = None) -> dict[str, pd.DataFrame]:
    """Run the simulated-hand comparison and write :data:`HAND_OUTPUTS`; returns the two tables."""
    results_dir.check_free(HAND_OUTPUTS)
    log = log or (lambda _msg: None)
    study = HandSettings()  # the hand study's defaults
    strategies = ["active", *(f"fixed:{t}" for t in GRASP_TYPES), "random_type", "random_grasp"]
    runs = [reissued(r) for r in Parallel(n_jobs=config.compute.n_jobs)(
        delayed(relayed(_evaluate_seed))(table, study, config, seed, strategies) for seed in config.hand.seeds)]
    for seed, r in zip(config.hand.seeds, runs, strict=True):
        log(f"simulated hand, seed {seed}: active after 1..{config.hand.max_grasps} grasps "
            f"{np.round(r['strategies']['active']['correct'].mean(axis=0), 3).tolist()}")
    classes = np.concatenate([r["objects"] for r in runs])
    splits = np.concatenate([np.full(len(r["objects"]), i) for i, r in enumerate(runs)])
    boot = {"classes": classes, "splits": splits, "n_boot": config.methods.n_boot, "random_state": 0}
    C = np.hstack([np.vstack([r["strategies"][s]["correct"] for r in runs]) for s in strategies])
    acc, low, high = bootstrap_accuracy_columns(C, **boot)
    chance = float(np.mean([1.0 / r["n_classes"] for r in runs]))
    k = config.hand.max_grasps
    curves = pd.DataFrame({"data": "simulated", "strategy": np.repeat(strategies, k),
                           "grasps": np.tile(np.arange(1, k + 1), len(strategies)), "accuracy": acc,
                           "ci95_low": low, "ci95_high": high, "chance": chance, "n_seeds": len(runs)})
    rows = []
    for s in strategies:
        corr = np.vstack([r["strategies"][s]["correct"] for r in runs])
        top = np.vstack([r["strategies"][s]["top"] for r in runs])
        for t in config.methods.thresholds:
            hit = top >= t
            stop = np.where(hit.any(axis=1), hit.argmax(axis=1), k - 1)
            at = corr[np.arange(len(stop)), stop]
            a = bootstrap_accuracy_columns(at[:, None], **boot)
            d = paired_difference_interval(at, corr[:, -1], **boot)
            used = float(np.mean([(stop[splits == i] + 1).mean() for i in range(len(runs))]))
            rows.append({"data": "simulated", "strategy": s, "threshold": float(t), "accuracy": a[0][0],
                         "accuracy_ci95_low": a[1][0], "accuracy_ci95_high": a[2][0],
                         "max_grasps": k, "max_grasps_accuracy": float(corr[:, -1].mean()), "difference": d.mean,
                         "difference_ci95_low": d.ci95_low, "difference_ci95_high": d.ci95_high,
                         "mean_grasps": used, "grasps_saved": k - used})
    out = {"active_touch_hand": curves, "active_touch_hand_stop": pd.DataFrame(rows)}
    for name, t in out.items():
        results_dir.write_csv(f"{name}.csv", t)
    results_dir.write_figure("active_touch_hand.png", _figure(curves))
    shares: np.ndarray = np.mean([r["type_share"] for r in runs], axis=0)  # per grasp type
    for t in out.values():
        t.attrs["type_share"] = dict(zip(GRASP_TYPES, np.round(shares, 3).tolist(), strict=True))
    return out
