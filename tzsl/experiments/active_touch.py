"""Active touch on PHAC-2: accuracy vs number of EPs and EP-seconds, active policy vs fixed and random orders.

For every split (random: ``n_splits`` draws of 10 test objects; challenging: the 5 map
partitions) a :class:`tzsl.models.PerEPAttributeModel` is fitted on the training objects only
(its confusion model by grouped CV on those objects), and each test trial is explored EP by EP:

* ``active``: greedy expected information gain (bits), ``active_per_second``: gain per second;
* every fixed order of the EPs (``order:<ep>><ep>>...``), among them ``paper`` (the PHAC-2
  recording order squeeze, hold, slow slide, fast slide);
* ``random``: the expected accuracy of a uniformly random order (exact: mean over all orders);
* ``best_fixed_train``: the fixed order with the best mean out-of-fold accuracy over 1..4 EPs on
  the *training* objects (chosen without test objects);
* ``best_fixed_test``: per row, the best fixed order on the pooled test trials. Chosen on test
  objects, so optimistic: an upper bound for any fixed order, not an honest method.

Accuracy is trial accuracy pooled over the splits of a kind, with a 95% percentile interval
from a two-level bootstrap (splits with replacement, then test objects with replacement within
each drawn split, trials of an object kept together). Accuracy vs seconds uses each EP's
duration (:data:`tzsl.models.PHAC2_EP_SECONDS`): at budget ``t`` a trial counts the prediction
after the EPs it has completed by ``t`` (before any EP, the chance ``1 / n_classes`` of a guess).

The stopping rule (top class posterior >= ``threshold``) is evaluated post hoc on the
trajectory of the active policy and of the paper's order: the trajectory of a greedy policy does
not depend on when it stops.
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import permutations
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets import FeatureSet
from tzsl.evaluation import Split, challenging_splits, random_object_splits
from tzsl.exceptions import ConfigError
from tzsl.experiments._outputs import ResultsDir
from tzsl.experiments.phac2_dap import object_map_features
from tzsl.models import PerEPAttributeModel, ep_column_blocks, run_policy

__all__ = ["ACTIVE_TOUCH_OUTPUTS", "bootstrap_accuracy", "evaluate_split", "run_active_touch_study"]

#: Files :func:`run_active_touch_study` writes.
ACTIVE_TOUCH_OUTPUTS: tuple[str, ...] = ("active_touch.csv", "active_touch.png", "manifest.json")
_ACTIVE = ("active", "active_per_second")
_SHORT = {"squeeze": "sq", "hold": "ho", "slow_slide": "ss", "fast_slide": "fs"}


def _order_name(eps: tuple[str, ...], order: tuple[int, ...]) -> str:
    return "order:" + ">".join(_SHORT.get(eps[i], eps[i]) for i in order)


def bootstrap_accuracy(correct: np.ndarray, trials: np.ndarray, unit_split: np.ndarray, *, n_boot: int = 2000,
                       random_state=0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pooled accuracy and a 95% two-level bootstrap interval (splits, then objects within splits).

    Parameters
    ----------
    correct : ndarray of shape (n_units, n_columns)
        Correct test trials of each unit (one test object of one split) for each column.
    trials : ndarray of shape (n_units,)
        Test trials of each unit.
    unit_split : ndarray of shape (n_units,)
        Split index of each unit.
    n_boot : int
    random_state : int or None

    Returns
    -------
    accuracy, low, high : ndarray of shape (n_columns,)
    """
    rng = np.random.default_rng(random_state)
    splits = np.unique(unit_split)
    draw = rng.integers(0, splits.size, size=(n_boot, splits.size))
    W = np.zeros((n_boot, unit_split.size))
    for j, s in enumerate(splits):
        units = np.flatnonzero(unit_split == s)
        times = (draw == j).sum(axis=1)  # how often split s is drawn in each replicate
        W[:, units] = rng.multinomial(times * units.size, np.full(units.size, 1.0 / units.size))
    acc_b = (W @ correct) / (W @ trials)[:, None]
    acc = correct.sum(axis=0) / trials.sum()
    low, high = np.percentile(acc_b, [2.5, 97.5], axis=0)
    return acc, low, high


def _fixed_order_accuracy(S: np.ndarray, y: np.ndarray, orders: list[tuple[int, ...]], model) -> np.ndarray:
    """Correct indicator (n_trials, n_orders, n_eps) of every fixed order after 1..n_eps EPs."""
    out = np.empty((S.shape[0], len(orders), S.shape[1]), dtype=bool)
    for o, order in enumerate(orders):
        res = run_policy(S, None, model.ep_seconds_, policy=order, random_state=o)
        out[:, o] = res["predictions"][:, 1:] == y[:, None]
    return out


def _train_chosen_order(model: PerEPAttributeModel, A_train: np.ndarray, groups: np.ndarray,
                        orders: list[tuple[int, ...]]) -> int:
    """Index of the order with the best mean out-of-fold accuracy over 1..n_eps EPs on training objects.

    Out-of-fold posteriors missing for an attribute in a fold (too few objects) count as 0.5.
    """
    objects, first = np.unique(groups, return_index=True)
    K = A_train[first]
    y = np.searchsorted(objects, groups)
    P = np.nan_to_num(model.oof_posteriors_, nan=0.5).transpose(1, 0, 2)[:, :, None, :]  # (n, E, 1, m)
    S = model.ep_log_scores(P, K)
    acc = _fixed_order_accuracy(S, y, orders, model).mean(axis=(0, 2))
    return int(np.argmax(acc))


def evaluate_split(features: FeatureSet, split: Split, *, seed: int, update: str = "dap", cv: int = 5,
                   n_samples: int = 128) -> dict:
    """Fit on the split's training objects and explore its test trials with every strategy.

    Returns
    -------
    dict with ``correct`` (strategy -> bool (n_trials, n_eps) after 1..n_eps EPs), ``seconds``
    (strategy -> cumulative seconds (n_trials, n_eps)), ``first`` ((n_trials,): expected
    correctness of the uniform guess before any EP, ``1 / n_classes``), ``top`` (strategy -> top
    posterior (n_trials, n_eps)), ``objects`` (n_trials,), ``eps``, ``ep_seconds``,
    ``best_fixed_train`` (its order name), ``n_classes``.
    """
    attributes = list(split.kept_attributes)
    objects = features.objects
    train, test = np.isin(objects, split.train_objects), np.isin(objects, split.test_objects)
    A = features.attributes.loc[objects, attributes].to_numpy(dtype=int)
    blocks = ep_column_blocks(features.feature_names)
    model = PerEPAttributeModel(ep_columns=blocks, cv=cv, update=update, random_state=seed)
    model.fit(features.X[train], A[train], objects[train])
    K = features.attributes.loc[list(split.test_objects), attributes].to_numpy(dtype=int)
    y = pd.Index(split.test_objects).get_indexer(objects[test])
    S = model.ep_log_scores(model.predict_proba(features.X[test]), K)
    L = model.outcome_log_likelihoods(K, n_samples=n_samples, random_state=seed)
    eps, sec = model.eps_, model.ep_seconds_
    orders = list(permutations(range(len(eps))))
    fixed = _fixed_order_accuracy(S, y, orders, model)
    correct, seconds, top = {}, {}, {}
    for o, order in enumerate(orders):
        name = _order_name(eps, order)
        correct[name] = fixed[:, o]
        seconds[name] = np.broadcast_to(np.cumsum(sec[list(order)]), fixed[:, o].shape)
    correct["random"] = fixed.mean(axis=1)  # expected correctness of a uniformly random order
    paper = _order_name(eps, tuple(range(len(eps))))
    correct["paper"], seconds["paper"] = correct[paper], seconds[paper]
    res_paper = run_policy(S, None, sec, policy=tuple(range(len(eps))), random_state=seed)
    top["paper"] = res_paper["top_probability"][:, 1:]
    best = _order_name(eps, orders[_train_chosen_order(model, A[train], objects[train], orders)])
    correct["best_fixed_train"], seconds["best_fixed_train"] = correct[best], seconds[best]
    for policy in _ACTIVE:
        res = run_policy(S, L, sec, policy=policy, random_state=seed)
        correct[policy] = res["predictions"][:, 1:] == y[:, None]
        seconds[policy] = np.cumsum(sec[res["order"]], axis=1)
        top[policy] = res["top_probability"][:, 1:]
        correct[f"{policy}:first_ep"] = np.eye(len(eps), dtype=bool)[res["order"][:, 0]]  # which EP came first
    first = np.full(y.shape, 1.0 / K.shape[0])  # before any EP: expected accuracy of a uniform guess
    return {"correct": correct, "seconds": seconds, "top": top, "first": first, "objects": objects[test],
            "eps": eps, "ep_seconds": sec, "best_fixed_train": best, "n_classes": K.shape[0]}


def _units(results: list[dict], values: Callable[[dict], np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per (split, test object) sums of ``values(result)`` (n_trials, n_cols), trial counts and split index."""
    sums, counts, split_of = [], [], []
    for i, r in enumerate(results):
        v = np.asarray(values(r), dtype=float).reshape(len(r["objects"]), -1)
        codes, uniq = pd.factorize(r["objects"])
        agg = np.zeros((uniq.size, v.shape[1]))
        np.add.at(agg, codes, v)
        sums.append(agg)
        counts.append(np.bincount(codes).astype(float))
        split_of.append(np.full(uniq.size, i))
    return np.vstack(sums), np.concatenate(counts), np.concatenate(split_of)


def _seconds_grid(results: list[dict]) -> np.ndarray:
    return np.arange(0.0, float(results[0]["ep_seconds"].sum()) + 1.0)


def summarise(results: list[dict], kind: str, *, threshold: float, n_boot: int = 2000, seed: int = 0) -> pd.DataFrame:
    """Rows of the study table for one split kind (see :func:`run_active_touch_study`)."""
    strategies = [s for s in results[0]["correct"] if not s.endswith(":first_ep")]
    n_eps = len(results[0]["eps"])
    grid = _seconds_grid(results)
    rows = []
    chance = float(np.mean([1.0 / r["n_classes"] for r in results]))
    base = {"split_kind": kind, "n_splits": len(results), "n_trials": int(sum(len(r["objects"]) for r in results)),
            "chance": chance}

    def add(strategy, x_kind, xs, acc, low, high, **extra):
        for x, a, lo, hi in zip(xs, acc, low, high):
            rows.append({**base, "strategy": strategy, "x_kind": x_kind, "x": float(x), "accuracy": a,
                         "ci_low": lo, "ci_high": hi, **extra})

    for s in strategies:
        C, N, U = _units(results, lambda r: r["correct"][s])
        add(s, "eps", range(1, n_eps + 1), *bootstrap_accuracy(C, N, U, n_boot=n_boot, random_state=seed))
        if s == "random":
            continue
        C, N, U = _units(results, lambda r: _by_budget(r, s, grid))
        add(s, "seconds", grid, *bootstrap_accuracy(C, N, U, n_boot=n_boot, random_state=seed))
    C, N, U = _units(results, lambda r: np.mean([_by_budget(r, s, grid) for s in r["correct"]
                                                 if s.startswith("order:")], axis=0))
    add("random", "seconds", grid, *bootstrap_accuracy(C, N, U, n_boot=n_boot, random_state=seed))
    for s in ("active", "paper"):  # stopping rule, post hoc on the full trajectory
        C, N, U = _units(results, lambda r: _at_stop(r, s, threshold))
        acc, low, high = bootstrap_accuracy(C[:, :1], N, U, n_boot=n_boot, random_state=seed)
        add(f"{s}+stop", "stop", [threshold], acc, low, high, mean_eps=C[:, 1].sum() / N.sum(),
            mean_seconds=C[:, 2].sum() / N.sum())
    table = pd.DataFrame(rows)
    table = pd.concat([table, _best_fixed_test(table)], ignore_index=True)
    for s in _ACTIVE:  # how often each EP is chosen first
        C, N, _ = _units(results, lambda r: r["correct"][f"{s}:first_ep"])
        for e, ep in enumerate(results[0]["eps"]):
            table.loc[(table["strategy"] == s) & (table["x_kind"] == "eps") & (table["x"] == 1.0),
                      f"first_{ep}"] = C[:, e].sum() / N.sum()
    return table


def _by_budget(r: dict, strategy: str, grid: np.ndarray) -> np.ndarray:
    """Correct indicator (n_trials, n_grid): prediction after the EPs completed within each budget."""
    done = (r["seconds"][strategy][:, :, None] <= grid[None, None, :]).sum(axis=1)  # EPs done by t
    cols = np.column_stack([r["first"], r["correct"][strategy]]).astype(float)  # (n, n_eps + 1)
    return np.take_along_axis(cols, done, axis=1)


def _at_stop(r: dict, strategy: str, threshold: float) -> np.ndarray:
    """(n_trials, 3): correct at the stop, EPs used, seconds used; stop after the first EP with top >= threshold."""
    top, corr, sec = r["top"][strategy], r["correct"][strategy], r["seconds"][strategy]
    hit = top >= threshold
    k = np.where(hit.any(axis=1), hit.argmax(axis=1), top.shape[1] - 1)
    rows = np.arange(top.shape[0])
    return np.column_stack([corr[rows, k], k + 1, sec[rows, k]])


def _best_fixed_test(table: pd.DataFrame) -> pd.DataFrame:
    """Per x, the fixed order with the best pooled test accuracy (optimistic: chosen on test objects)."""
    orders = table[table["strategy"].str.startswith("order:") & table["x_kind"].isin(["eps", "seconds"])]
    idx = orders.groupby(["x_kind", "x"])["accuracy"].idxmax()
    best = orders.loc[idx].copy()
    best["chosen_order"] = best["strategy"]
    best["strategy"] = "best_fixed_test"
    return best


def _figure(table: pd.DataFrame):
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    kinds = list(dict.fromkeys(table["split_kind"]))
    fig, axes = plt.subplots(2, len(kinds), figsize=(6 * len(kinds), 8), squeeze=False)
    styles = {"active": "C0", "active_per_second": "C4", "best_fixed_train": "C2", "paper": "C1", "random": "C7",
              "best_fixed_test": "C3"}
    for col, kind in enumerate(kinds):
        for row, x_kind in enumerate(("eps", "seconds")):
            ax = axes[row, col]
            sub = table[(table["split_kind"] == kind) & (table["x_kind"] == x_kind)]
            for s, color in styles.items():
                g = sub[sub["strategy"] == s].sort_values("x")
                if g.empty:
                    continue
                ls = ":" if s == "best_fixed_test" else "-"
                ax.plot(g["x"], g["accuracy"], ls, marker="o" if x_kind == "eps" else None, color=color,
                        label=s + (" (chosen on test)" if s == "best_fixed_test" else ""))
                if s != "best_fixed_test":
                    ax.fill_between(g["x"], g["ci_low"], g["ci_high"], color=color, alpha=0.12)
            ax.axhline(sub["chance"].iloc[0], color="k", lw=0.8, ls="--", label="chance")
            ax.set_xlabel("EPs done" if x_kind == "eps" else "cumulative EP seconds")
            ax.set_ylabel("trial accuracy (95% bootstrap interval)")
            ax.set_title(f"PHAC-2 {kind} splits (n={sub['n_splits'].iloc[0]})")
            if x_kind == "eps":
                ax.set_xticks(sorted(sub["x"].unique()))
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def run_active_touch_study(features: FeatureSet, out_folder, *, n_splits: int = 5, seed: int = 0,
                           threshold: float = 0.9, update: str = "dap", cv: int = 5, n_samples: int = 128,
                           n_boot: int = 2000, kinds: tuple[str, ...] = ("random", "challenging"),
                           force: bool = False, log: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Run the active-touch evaluation on PHAC-2 features and write ``active_touch.csv`` / ``.png``.

    Parameters
    ----------
    features : FeatureSet
        EP-prefixed features (``extract_features("phac2-penn")``).
    out_folder : path-like or ResultsDir
        Existing outputs are refused unless ``force`` (checked before computing).
    n_splits : int
        Random splits (10 test objects each, seed ``seed``); the challenging splits are always 5.
    seed : int
        Seeds the splits, the model fits, the Monte-Carlo outcomes and the bootstrap.
    threshold : float
        Stopping rule: stop once the top class posterior is >= this.
    update : {"dap", "confusion"}
        Per-EP class scores (see :class:`tzsl.models.PerEPAttributeModel`).
    cv : int
        Grouped folds of the confusion estimate (training objects only).
    n_samples : int
        Monte-Carlo outcomes per class for the expected information gain.
    n_boot : int
        Bootstrap replicates.
    kinds : tuple of {"random", "challenging"}
    force : bool
    log : callable, optional
        Receives progress lines.

    Returns
    -------
    DataFrame
        Columns ``split_kind, strategy, x_kind ("eps" | "seconds" | "stop"), x, accuracy, ci_low,
        ci_high, n_splits, n_trials, chance`` and, where relevant, ``mean_eps``, ``mean_seconds``
        (stopping rows), ``chosen_order`` (``best_fixed_test``), ``first_<ep>`` (share of trials
        whose first active EP is ``<ep>``).
    """
    results_dir = out_folder if isinstance(out_folder, ResultsDir) else ResultsDir(out_folder, force=force)
    results_dir.check_free(ACTIVE_TOUCH_OUTPUTS)
    log = log or (lambda _msg: None)
    tables, chosen = [], {}
    for kind in kinds:
        if kind == "random":
            splits = random_object_splits(features.attributes, n_test=10, n_splits=n_splits, random_state=seed)
        elif kind == "challenging":
            splits, _ = challenging_splits(object_map_features(features), features.attributes)
        else:
            raise ConfigError(f"unknown split kind {kind!r}; choose random or challenging")
        results = []
        for i, split in enumerate(splits):
            split_seed = int(np.random.SeedSequence([seed, len(tables), i]).generate_state(1)[0])
            results.append(evaluate_split(features, split, seed=split_seed, update=update, cv=cv, n_samples=n_samples))
            chosen[split.name] = results[-1]["best_fixed_train"]
            log(f"{split.name}: {len(results[-1]['objects'])} test trials, active after 1..4 EPs "
                f"{np.round(results[-1]['correct']['active'].mean(axis=0), 3).tolist()}")
        tables.append(summarise(results, kind, threshold=threshold, n_boot=n_boot, seed=seed))
    table = pd.concat(tables, ignore_index=True)
    results_dir.write_csv("active_touch.csv", table)
    results_dir.write_figure("active_touch.png", _figure(table))
    config = {"n_splits": n_splits, "seed": seed, "threshold": threshold, "update": update, "cv": cv,
              "n_samples": n_samples, "n_boot": n_boot, "kinds": list(kinds), "dataset": features.dataset}
    results_dir.write_manifest(config, [Path(p) for p in features.info.get("data_files", [])],
                               extra={"best_fixed_train_per_split": chosen})
    return table
