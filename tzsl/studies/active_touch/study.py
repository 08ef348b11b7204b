"""Active touch on PHAC-2: accuracy vs number of EPs and EP-seconds, active policy vs fixed and random orders.

For every split (random: ``n_splits`` draws of ``n_test`` test objects; challenging: the 5 map
partitions) a :class:`tzsl.models.PerEPAttributeModel` is fitted on the training objects only
(its confusion model by grouped CV on those objects), and each test trial is explored EP by EP:

* ``active``: greedy expected information gain (bits), ``active_per_second``: gain per second;
* every fixed order of the EPs (``order:<ep>><ep>>...``, all 24), among them ``paper`` (the
  PHAC-2 recording order squeeze, hold, slow slide, fast slide);
* ``random``: the expected accuracy of a uniformly random order (exact: mean over all orders);
* ``best_fixed_train``: the fixed order with the best mean out-of-fold accuracy over 1..4 EPs on
  the *training* objects (chosen without test objects), and ``first:<ep>``: the best such order
  among those starting with ``<ep>`` (each EP first, the rest chosen on training objects);
* ``best_fixed_test_optimistic``: per row, the best of the 24 orders on the test trials. Chosen
  on test objects, so optimistic: an upper bound for any fixed order, not an honest method.

Accuracy is the mean over splits of the per-split trial accuracy with a 95% two-level bootstrap
interval (:func:`tzsl.evaluation.bootstrap_accuracy_columns`: splits with replacement, then test
objects with replacement within each drawn split, trials of an object kept together; every
column on the same replicates). Accuracy vs seconds uses each EP's duration
(:data:`tzsl.models.active_touch.PHAC2_EP_SECONDS`): at budget ``t`` a trial counts the prediction after the
EPs it has completed by ``t`` (before any EP, the chance ``1 / n_classes`` of a guess).

The stopping rule (top class posterior >= a threshold) is evaluated post hoc on each strategy's
trajectory (a greedy policy's trajectory does not depend on when it stops): accuracy at the stop,
mean EPs and seconds used, and the paired difference to running all four EPs on the same trials.
The posterior is the model's tempered one (exponents fitted on pseudo-unseen training objects,
:class:`tzsl.models.PerEPAttributeModel`); whether the rule keeps its promise (trials decided at
``t`` right a fraction ``t`` of the time), tempered and untempered, active and random order, is
the decided-at-t table of :mod:`tzsl.studies.active_touch.stopping`.
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import permutations

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from tzsl._parallel import reissued, relayed
from tzsl._profile import stage
from tzsl.datasets import FeatureSet
from tzsl.evaluation import (
    Split,
    bootstrap_accuracy_columns,
    challenging_splits,
    paired_difference_interval,
    purpose_seed,
    random_object_splits,
)
from tzsl.exceptions import ConfigError
from tzsl.fit_store import count_fits, fit_cached, fit_store_counts
from tzsl.models import PerEPAttributeModel
from tzsl.models.active_touch import ep_column_blocks, run_policy
from tzsl.studies.active_touch.stopping import decided_table, stop_outcomes, stopping_figure
from tzsl.studies.config import ActiveTouchStudy
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.zero_shot.study import object_map_features

__all__ = ["ACTIVE_TOUCH_OUTPUTS", "evaluate_split", "run_active_touch_study", "summarise"]

#: Files :func:`run_active_touch_study` writes.
ACTIVE_TOUCH_OUTPUTS: tuple[str, ...] = ("active_touch.csv", "active_touch_curves.csv", "active_touch_stop.csv",
                                         "active_touch_decided.csv", "active_touch.png", "active_touch_stopping.png")
_ACTIVE = ("active", "active_per_second")
_SHORT = {"squeeze": "sq", "hold": "ho", "slow_slide": "ss", "fast_slide": "fs"}
_SUMMARY = ("active", "active_per_second", "best_fixed_train", "first:*", "paper", "random",
            "best_fixed_test_optimistic")
_STOPPED = ("active", "active_per_second", "best_fixed_train", "paper", "random")


def _order_name(eps: tuple[str, ...], order: tuple[int, ...]) -> str:
    return "order:" + ">".join(_SHORT.get(eps[i], eps[i]) for i in order)


def _run_orders(S: np.ndarray, y: np.ndarray, orders: list[tuple[int, ...]], sec: np.ndarray, exponents=None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Correct indicator and top posterior (n_trials, n_orders, n_eps) of every fixed order after 1..n_eps EPs."""
    correct = np.empty((S.shape[0], len(orders), S.shape[1]), dtype=bool)
    top = np.empty(correct.shape)
    for o, order in enumerate(orders):
        res = run_policy(S, None, sec, policy=order, exponents=exponents, random_state=o)
        correct[:, o] = res["predictions"][:, 1:] == y[:, None]
        top[:, o] = res["top_probability"][:, 1:]
    return correct, top


def _train_order_accuracy(model: PerEPAttributeModel, A_train: np.ndarray, groups: np.ndarray,
                          orders: list[tuple[int, ...]]) -> np.ndarray:
    """Mean out-of-fold accuracy over 1..n_eps EPs of every order on the training objects, shape (n_orders,).

    Out-of-fold posteriors missing for an attribute in a fold (too few objects) count as 0.5.
    """
    objects, first = np.unique(groups, return_index=True)
    K = A_train[first]
    y = np.searchsorted(objects, groups)
    P = np.nan_to_num(model.oof_posteriors_, nan=0.5).transpose(1, 0, 2)[:, :, None, :]  # (n, E, 1, m)
    S = model.ep_log_scores(P, K)
    return _run_orders(S, y, orders, model.ep_seconds_)[0].mean(axis=(0, 2))


def evaluate_split(features: FeatureSet, split: Split, *, seed: int, update: str, cv: int, n_samples: int,
                   tempering: str) -> dict:
    """Fit on the split's training objects and explore its test trials with every strategy.

    Every strategy runs on the tempered posterior (exponents fitted on the training objects);
    ``active`` and the fixed orders are also run on the untempered product, for comparison.

    Returns
    -------
    dict with ``correct`` (strategy -> float (n_trials, n_eps): correct after 1..n_eps EPs;
    ``random`` is the mean over the orders), ``seconds`` and ``top`` (strategy -> cumulative
    seconds / top class posterior (n_trials, n_eps); not for ``random``), ``orders`` (names of
    the fixed orders), ``first_ep`` (active strategy -> (n_trials,) index of the first EP),
    ``objects`` (n_trials,), ``eps``, ``ep_seconds``, ``chosen`` (strategy -> order name chosen
    on training objects), ``n_classes``, ``exponents`` (2 ** n_eps,) and ``untempered`` (``correct``,
    ``seconds``, ``top`` of ``active`` and the fixed orders under the plain product).
    """
    attributes = list(split.kept_attributes)
    objects = features.objects
    train, test = np.isin(objects, split.train_objects), np.isin(objects, split.test_objects)
    A = features.attributes.loc[objects, attributes].to_numpy(dtype=int)
    before = fit_store_counts()
    model = fit_cached(PerEPAttributeModel(ep_columns=ep_column_blocks(features.feature_names), cv=cv,
                                           update=update, tempering=tempering, random_state=seed),
                       features.X[train], A[train], objects[train])
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=int)
    y = pd.Index(split.test_objects).get_indexer(objects[test])
    S = model.ep_log_scores(model.predict_proba(features.X[test]), K)
    eps, sec = model.eps_, model.ep_seconds_
    orders = list(permutations(range(len(eps))))
    names = [_order_name(eps, o) for o in orders]
    fixed, fixed_top = _run_orders(S, y, orders, sec, model.exponents_)
    correct, seconds, top = {}, {}, {}
    for o, (order, name) in enumerate(zip(orders, names, strict=True)):
        correct[name], top[name] = fixed[:, o].astype(float), fixed_top[:, o]
        seconds[name] = np.broadcast_to(np.cumsum(sec[list(order)]), fixed[:, o].shape)
    correct["random"] = fixed.mean(axis=1)  # expected correctness of a uniformly random order
    train_acc = _train_order_accuracy(model, A[train], objects[train], orders)
    chosen = {"paper": names[0], "best_fixed_train": names[int(np.argmax(train_acc))]}
    for e, ep in enumerate(eps):
        starts = [i for i, o in enumerate(orders) if o[0] == e]
        chosen[f"first:{ep}"] = names[starts[int(np.argmax(train_acc[starts]))]]
    for alias, name in chosen.items():
        correct[alias], seconds[alias], top[alias] = correct[name], seconds[name], top[name]
    L = model.outcome_log_likelihoods(K, n_samples=n_samples, random_state=seed)
    first_ep = {}
    plain: dict[str, dict[str, np.ndarray]] = {"correct": {}, "seconds": {}, "top": {}}
    _, plain_top = _run_orders(S, y, orders, sec)  # tempering does not change a fixed order's argmax
    for o, name in enumerate(names):
        plain["correct"][name], plain["seconds"][name], plain["top"][name] = correct[name], seconds[name], \
            plain_top[:, o]
    for policy, exponents, out in [(p, model.exponents_, None) for p in _ACTIVE] + [("active", None, plain)]:
        res = run_policy(S, L, sec, policy=policy, exponents=exponents, random_state=seed)
        target = {"correct": correct, "seconds": seconds, "top": top} if out is None else out
        target["correct"][policy] = (res["predictions"][:, 1:] == y[:, None]).astype(float)
        target["seconds"][policy] = np.cumsum(sec[res["order"]], axis=1)
        target["top"][policy] = res["top_probability"][:, 1:]
        if out is None:
            first_ep[policy] = res["order"][:, 0]
    return {"correct": correct, "seconds": seconds, "top": top, "orders": names, "first_ep": first_ep,
            "objects": objects[test], "eps": eps, "ep_seconds": sec, "chosen": chosen, "n_classes": K.shape[0],
            "exponents": model.exponents_, "untempered": plain, "fit_store": fit_store_counts(since=before)}


def _by_budget(r: dict, strategy: str, grid: np.ndarray) -> np.ndarray:
    """Correct indicator (n_trials, n_grid): prediction after the EPs completed within each budget."""
    if strategy == "random":
        return np.mean([_by_budget(r, s, grid) for s in r["orders"]], axis=0)
    done = (r["seconds"][strategy][:, :, None] <= grid[None, None, :]).sum(axis=1)  # EPs done by t
    cols = np.column_stack([np.full(len(r["objects"]), 1.0 / r["n_classes"]), r["correct"][strategy]])
    return np.take_along_axis(cols, done, axis=1)


def _at_stop(r: dict, strategy: str, threshold: float) -> np.ndarray:
    """(n_trials, 3): correct at the stop, EPs used, seconds used; stop after the first EP with top >= threshold."""
    if strategy == "random":
        return np.mean([_at_stop(r, s, threshold) for s in r["orders"]], axis=0)
    return stop_outcomes(r["top"][strategy], r["correct"][strategy], r["seconds"][strategy], threshold)[:, 1:]


def _columns(results: list[dict], grid: np.ndarray) -> tuple[list[tuple[str, str, float]], np.ndarray]:
    """Per-trial correctness of every (strategy, x_kind, x), stacked over splits: (n_trials_total, n_columns)."""
    keys, blocks = [], []
    for s in results[0]["correct"]:
        n_eps = results[0]["correct"][s].shape[1]
        keys += [(s, "eps", float(x)) for x in range(1, n_eps + 1)]
        blocks.append(np.vstack([r["correct"][s] for r in results]))
        budget = np.vstack([_by_budget(r, s, grid) for r in results])
        keys += [(s, "seconds", float(t)) for t in grid] + [(s, "seconds_mean", float(grid[-1]))]
        blocks += [budget, budget.mean(axis=1, keepdims=True)]
    return keys, np.hstack(blocks)


def summarise(results: list[dict], kind: str, *, thresholds, n_boot: int, seed: int
              ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The long table (every strategy, x) and the stopping table of one split kind."""
    grid = np.arange(0.0, float(results[0]["ep_seconds"].sum()) + 1.0)
    classes = np.concatenate([r["objects"] for r in results])
    splits = np.concatenate([np.full(len(r["objects"]), i) for i, r in enumerate(results)])
    boot = {"classes": classes, "splits": splits, "n_boot": n_boot, "random_state": seed}
    keys, C = _columns(results, grid)
    acc, low, high = bootstrap_accuracy_columns(C, **boot)
    base = {"split_kind": kind, "data": "real", "n_splits": len(results), "n_trials": int(classes.size),
            "chance": float(np.mean([1.0 / r["n_classes"] for r in results]))}
    table = pd.DataFrame([{**base, "strategy": s, "x_kind": xk, "x": x, "accuracy": a, "ci95_low": lo,
                           "ci95_high": hi} for (s, xk, x), a, lo, hi in zip(keys, acc, low, high, strict=True)])
    orders = table[table["strategy"].str.startswith("order:")]
    best = orders.loc[orders.groupby(["x_kind", "x"])["accuracy"].idxmax()].copy()
    best["chosen_order"], best["strategy"] = best["strategy"], "best_fixed_test_optimistic"
    table = pd.concat([table, best], ignore_index=True)
    for s in _ACTIVE:  # how often each EP is chosen first
        first = np.concatenate([r["first_ep"][s] for r in results])
        row = (table["strategy"] == s) & (table["x_kind"] == "eps") & (table["x"] == 1.0)
        for e, ep in enumerate(results[0]["eps"]):
            table.loc[row, f"first_{ep}"] = float(np.mean(first == e))
    stop_rows = []
    for s in _STOPPED:
        full = np.concatenate([r["correct"][s][:, -1] for r in results])
        full_acc = bootstrap_accuracy_columns(full[:, None], **boot)
        for t in thresholds:
            at = np.vstack([_at_stop(r, s, t) for r in results])
            a = bootstrap_accuracy_columns(at[:, :1], **boot)
            d = paired_difference_interval(at[:, 0], full, **boot)
            eps_used = float(np.mean([at[splits == i, 1].mean() for i in range(len(results))]))
            sec_used = float(np.mean([at[splits == i, 2].mean() for i in range(len(results))]))
            all_sec = float(results[0]["ep_seconds"].sum())
            stop_rows.append({**base, "strategy": s, "threshold": float(t), "accuracy": a[0][0],
                              "accuracy_ci95_low": a[1][0], "accuracy_ci95_high": a[2][0],
                              "all_eps_accuracy": full_acc[0][0], "difference": d.mean,
                              "difference_ci95_low": d.ci95_low, "difference_ci95_high": d.ci95_high,
                              "mean_eps": eps_used, "eps_saved": len(results[0]["eps"]) - eps_used,
                              "mean_seconds": sec_used, "seconds_saved": all_sec - sec_used})
    return table, pd.DataFrame(stop_rows)


def summary_table(table: pd.DataFrame) -> pd.DataFrame:
    """One row per (split kind, strategy): accuracy after 1..n EPs and mean over the seconds budgets, with intervals.

    A ``chance`` row per split kind gives ``1 / n_classes`` (mean over splits) in every accuracy column.
    """
    rows = []
    for kind, sub in table.groupby("split_kind", sort=False):
        n_eps = int(sub.loc[sub["x_kind"] == "eps", "x"].max())
        chance = float(sub["chance"].iloc[0])
        names = [s for pattern in _SUMMARY for s in dict.fromkeys(sub["strategy"])
                 if s == pattern or (pattern.endswith("*") and s.startswith(pattern[:-1]))]
        for s in names:
            g = sub[sub["strategy"] == s]
            row = {"split_kind": kind, "strategy": s}
            for _, r in g[g["x_kind"] == "eps"].sort_values("x").iterrows():
                col = f"acc_{int(r['x'])}ep"
                row.update({col: r["accuracy"], f"{col}_ci95_low": r["ci95_low"], f"{col}_ci95_high": r["ci95_high"]})
            m = g[g["x_kind"] == "seconds_mean"].iloc[0]
            row.update({"acc_mean_over_seconds": m["accuracy"], "acc_mean_over_seconds_ci95_low": m["ci95_low"],
                        "acc_mean_over_seconds_ci95_high": m["ci95_high"]})
            rows.append(row)
        rows.append({"split_kind": kind, "strategy": "chance",
                     **{f"acc_{k}ep": chance for k in range(1, n_eps + 1)}, "acc_mean_over_seconds": chance})
    return pd.DataFrame(rows)


def _figure(table: pd.DataFrame):
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    kinds = list(dict.fromkeys(table["split_kind"]))
    fig, axes = plt.subplots(2, len(kinds), figsize=(6 * len(kinds), 8), squeeze=False)
    styles = {"active": "C0", "active_per_second": "C4", "best_fixed_train": "C2", "paper": "C1", "random": "C7",
              "best_fixed_test_optimistic": "C3"}
    for col, kind in enumerate(kinds):
        for row, x_kind in enumerate(("eps", "seconds")):
            ax = axes[row, col]
            sub = table[(table["split_kind"] == kind) & (table["x_kind"] == x_kind)]
            for i, (_, g) in enumerate(sub[sub["strategy"].str.startswith("order:")].groupby("strategy")):
                g = g.sort_values("x")
                ax.plot(g["x"], g["accuracy"], color="0.75", lw=0.6, label="each of the 24 fixed orders" if i == 0
                        else None, zorder=1)
            for s, color in styles.items():
                g = sub[sub["strategy"] == s].sort_values("x")
                optimistic = s == "best_fixed_test_optimistic"
                ax.plot(g["x"], g["accuracy"], ":" if optimistic else "-", marker="o" if x_kind == "eps" else None,
                        color=color, label=s + (" (chosen on test)" if optimistic else ""), zorder=3)
                if s in ("active", "random"):  # the main comparison's intervals; every interval is in the CSVs
                    ax.fill_between(g["x"], g["ci95_low"], g["ci95_high"], color=color, alpha=0.15, zorder=2)
            ax.axhline(sub["chance"].iloc[0], color="k", lw=0.8, ls="--", label="chance")
            ax.set_xlabel("EPs done" if x_kind == "eps" else "cumulative EP seconds")
            ax.set_ylabel("trial accuracy")
            ax.set_title(f"PHAC-2 {kind} splits (n={sub['n_splits'].iloc[0]})")
            if x_kind == "eps":
                ax.set_xticks(sorted(sub["x"].unique()))
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("Active touch on PHAC-2; bands: 95% bootstrap intervals of active and random order", fontsize=10)
    fig.tight_layout()
    return fig


def make_active_splits(features: FeatureSet, kind: str, config: ActiveTouchStudy) -> list[Split]:
    """The random (of ``[splits] purpose``'s test sets only) or challenging splits of the study."""
    splits = config.splits
    if kind == "random":
        return random_object_splits(features.attributes, n_test=splits.n_test, n_splits=splits.n_splits,
                                    random_state=splits.seed, purpose=splits.purpose)
    if kind == "challenging":
        return challenging_splits(object_map_features(features), features.attributes)[0]
    raise ConfigError(f"unknown split kind {kind!r}; choose random or challenging")


def run_active_touch_study(features: FeatureSet, results_dir: ResultsDir, config: ActiveTouchStudy,
                           log: Callable[[str], None] | None = None) -> dict[str, pd.DataFrame]:
    """Run the active-touch evaluation on PHAC-2 features and write its tables and figure.

    Parameters
    ----------
    features : FeatureSet
        EP-prefixed features (``dataset_features("phac2-penn")``).
    results_dir : ResultsDir
        :data:`ACTIVE_TOUCH_OUTPUTS` must be free (checked before computing) unless forced; the
        manifest is the engine's.
    config : ActiveTouchStudy
        The checked study file's tables (``[splits]``, ``[methods]``, ``[compute]``); from Python e.g.
        ``ActiveTouchStudy(splits={"kinds": ["random"], "n_splits": 2})``.
    log : callable, optional
        Receives progress lines.

    Returns
    -------
    dict of DataFrame
        ``active_touch`` (one row per kind and strategy, see :func:`summary_table`),
        ``active_touch_curves`` (columns ``split_kind, data, strategy, x_kind ("eps" | "seconds" |
        "seconds_mean"), x, accuracy, ci95_low, ci95_high, n_splits, n_trials, chance`` and, where
        relevant, ``chosen_order``, ``first_<ep>``) and ``active_touch_stop`` (stopping rule per threshold:
        accuracy, all-EPs accuracy, paired difference, mean EPs / seconds used and saved; ``posterior``
        names the tempering) and ``active_touch_decided`` (accuracy of the trials decided at each
        threshold against it, tempered and untempered, active and random order:
        :func:`tzsl.studies.active_touch.stopping.decided_table`); each with its interval
        columns. ``.attrs["chosen"]`` holds the orders chosen per split, ``.attrs["exponents"]`` the
        posterior exponents fitted per split (indexed by :func:`tzsl.models.active_touch.done_subset_index`).
    """
    results_dir.check_free(ACTIVE_TOUCH_OUTPUTS)
    log = log or (lambda _msg: None)
    tables, stops, decided, chosen, exponents = [], [], [], {}, {}
    methods, study_seed = config.methods, purpose_seed(config.splits.seed, config.splits.purpose)
    for k, kind in enumerate(config.splits.kinds):
        splits = make_active_splits(features, kind, config)
        seeds = [int(np.random.SeedSequence([study_seed, k, i]).generate_state(1)[0]) for i in range(len(splits))]
        with stage("fit"):  # per-EP attribute models and their evaluation, in joblib workers
            results = [reissued(r) for r in Parallel(n_jobs=config.compute.n_jobs)(
                delayed(relayed(evaluate_split))(features, split, seed=s, update=methods.update, cv=methods.cv,
                                                 n_samples=methods.n_samples, tempering=methods.tempering)
                for split, s in zip(splits, seeds, strict=True))]
        for split, r in zip(splits, results, strict=True):
            for name, n in r.pop("fit_store").items():  # the workers' fit-store events, into the profile
                count_fits(name, n)
            chosen[split.name] = r["chosen"]
            exponents[split.name] = [float(x) for x in r["exponents"]]
            log(f"{split.name}: {len(r['objects'])} test trials, active after 1..4 EPs "
                f"{np.round(r['correct']['active'].mean(axis=0), 3).tolist()}")
        table, stop = summarise(results, kind, thresholds=methods.thresholds, n_boot=methods.n_boot, seed=study_seed)
        tables.append(table)
        stops.append(stop.assign(posterior="untempered" if methods.tempering == "none" else "tempered",
                                 tempering=methods.tempering))
        decided.append(decided_table(results, kind, thresholds=methods.decided_thresholds, n_boot=methods.n_boot,
                                     seed=study_seed))
    curves = pd.concat(tables, ignore_index=True)
    out = {"active_touch": summary_table(curves), "active_touch_curves": curves,
           "active_touch_stop": pd.concat(stops, ignore_index=True),
           "active_touch_decided": pd.concat(decided, ignore_index=True)}
    out = {name: table.assign(purpose=config.splits.purpose) for name, table in out.items()}  # random splits' purpose
    for name, table in out.items():
        results_dir.write_csv(f"{name}.csv", table)
    results_dir.write_figure("active_touch.png", _figure(curves))
    results_dir.write_figure("active_touch_stopping.png", stopping_figure(out["active_touch_decided"]))
    for t in out.values():
        t.attrs["chosen"], t.attrs["exponents"] = chosen, exponents
    return out

