"""Does the stopping rule keep its promise? Accuracy of the trials decided at threshold t, against t.

A robot told "stop when the top class posterior reaches t" expects the trials it decides that way
to be right about a fraction t of the time (at least). For each split kind, posterior (the
tempered one the study uses, and the untempered product for comparison), strategy (``active``
and ``random`` order, the same stopping rule) and threshold t, :func:`decided_table` gives:

* ``decided_share``: the share of test trials whose top posterior reached t within the EPs;
* ``decided_accuracy`` with a 95% interval: accuracy over those trials, pooled over splits
  (the interval resamples (split, test object) clusters, :func:`tzsl.evaluation.bootstrap_accuracy`);
  compare it with ``threshold`` (``decided_gap = decided_accuracy - threshold``); NaN when no
  trial was decided;
* ``accuracy`` at the stop of every trial (undecided trials answer after all EPs) and its paired
  difference to running all EPs (``difference``), the EPs used and saved;
* on ``active`` rows, ``active_minus_random`` (paired difference of accuracy at the stop, same
  trials, with interval) and ``active_minus_random_eps`` (EPs used, active minus random): whether
  choosing the EP beats a random order with the same stopping rule.

``random`` is a uniformly random EP order: every per-trial value is the mean over all orders
(the decided accuracy counts every (trial, order) pair that reached t).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tzsl.evaluation import bootstrap_accuracy, bootstrap_accuracy_columns, paired_difference_interval

__all__ = ["DECIDED_COLUMNS", "decided_table", "stop_outcomes", "stopping_figure"]

#: Columns of :func:`decided_table`, in order.
DECIDED_COLUMNS: tuple[str, ...] = (
    "split_kind", "data", "posterior", "strategy", "threshold", "n_splits", "n_trials", "chance", "decided_share",
    "decided_accuracy", "decided_accuracy_ci95_low", "decided_accuracy_ci95_high", "decided_gap", "accuracy",
    "accuracy_ci95_low", "accuracy_ci95_high", "all_eps_accuracy", "difference", "difference_ci95_low",
    "difference_ci95_high", "mean_eps", "eps_saved", "active_minus_random", "active_minus_random_ci95_low",
    "active_minus_random_ci95_high", "active_minus_random_eps")
_NAN3 = (np.nan, np.nan, np.nan)


def stop_outcomes(top: np.ndarray, correct: np.ndarray, seconds: np.ndarray, threshold: float) -> np.ndarray:
    """Stop after the first EP whose top posterior is >= ``threshold`` (else after the last EP).

    Parameters
    ----------
    top, correct, seconds : ndarray of shape (n_trials, n_eps)
        Top class posterior, correctness and cumulative seconds after 1..n_eps EPs of one trajectory.
    threshold : float

    Returns
    -------
    ndarray of shape (n_trials, 4)
        Decided (1 if the threshold was reached), correct at the stop, EPs used, seconds used.
    """
    hit = top >= threshold
    decided = hit.any(axis=1)
    k = np.where(decided, hit.argmax(axis=1), top.shape[1] - 1)
    rows = np.arange(top.shape[0])
    return np.column_stack([decided, correct[rows, k], k + 1, seconds[rows, k]])


def _trajectories(r: dict, posterior: str, strategy: str) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(top, correct, seconds) of the strategy: one trajectory, or every fixed order for ``random``."""
    src = r if posterior == "tempered" else r["untempered"]
    names = r["orders"] if strategy == "random" else [strategy]
    return [(src["top"][s], src["correct"][s], src["seconds"][s]) for s in names]


def decided_table(results: list[dict], kind: str, *, thresholds, n_boot: int, seed: int,
                  data: str = "real") -> pd.DataFrame:
    """The decided-at-t table of one split kind (module docstring), columns :data:`DECIDED_COLUMNS`.

    Parameters
    ----------
    results : list of dict
        :func:`tzsl.studies.active_touch.study.evaluate_split` of every split of the kind.
    kind : str
    thresholds : sequence of float
    n_boot, seed : int
        Bootstrap replicates and seed.
    data : {"real", "simulated"}

    Returns
    -------
    DataFrame
    """
    objects = np.concatenate([r["objects"] for r in results])
    splits = np.concatenate([np.full(len(r["objects"]), i) for i, r in enumerate(results)])
    cells = np.char.add(np.char.add(splits.astype(str), "|"), objects.astype(str))  # (split, object) clusters
    boot = {"classes": objects, "splits": splits, "n_boot": n_boot, "random_state": seed}
    n_eps = len(results[0]["eps"])
    base = {"split_kind": kind, "data": data, "n_splits": len(results), "n_trials": int(objects.size),
            "chance": float(np.mean([1.0 / r["n_classes"] for r in results]))}
    rows = []
    for posterior in ("tempered", "untempered"):
        full = {s: np.concatenate([np.mean([c[:, -1] for _, c, _ in _trajectories(r, posterior, s)], axis=0)
                                   for r in results]) for s in ("active", "random")}
        for t in thresholds:
            at, pairs = {}, {}
            for s in ("active", "random"):
                per_order = [np.vstack([stop_outcomes(*_trajectories(r, posterior, s)[o], float(t))
                                        for r in results]) for o in range(len(_trajectories(results[0], posterior, s)))]
                at[s] = np.mean(per_order, axis=0)
                pairs[s] = np.vstack(per_order)
            for s in ("active", "random"):
                decided = pairs[s][:, 0] == 1
                dec = (bootstrap_accuracy(pairs[s][decided, 1], classes=np.tile(cells, len(pairs[s]) // cells.size)[
                    decided], n_boot=n_boot, random_state=seed) if decided.any() else _NAN3)
                acc = bootstrap_accuracy_columns(at[s][:, 1:2], **boot)
                diff = paired_difference_interval(at[s][:, 1], full[s], **boot)
                eps_used = float(np.mean([at[s][splits == i, 2].mean() for i in range(len(results))]))
                vs = (paired_difference_interval(at["active"][:, 1], at["random"][:, 1], **boot)
                      if s == "active" else _NAN3)
                rows.append({**base, "posterior": posterior, "strategy": s, "threshold": float(t),
                             "decided_share": float(at[s][:, 0].mean()), "decided_accuracy": dec[0],
                             "decided_accuracy_ci95_low": dec[1], "decided_accuracy_ci95_high": dec[2],
                             "decided_gap": dec[0] - float(t), "accuracy": float(acc[0][0]),
                             "accuracy_ci95_low": float(acc[1][0]), "accuracy_ci95_high": float(acc[2][0]),
                             "all_eps_accuracy": float(np.mean([full[s][splits == i].mean()
                                                                for i in range(len(results))])),
                             "difference": diff[0], "difference_ci95_low": diff[1], "difference_ci95_high": diff[2],
                             "mean_eps": eps_used, "eps_saved": n_eps - eps_used, "active_minus_random": vs[0],
                             "active_minus_random_ci95_low": vs[1], "active_minus_random_ci95_high": vs[2],
                             "active_minus_random_eps": (eps_used - float(np.mean(
                                 [at["random"][splits == i, 2].mean() for i in range(len(results))]))
                                 if s == "active" else np.nan)})
    return pd.DataFrame(rows, columns=list(DECIDED_COLUMNS))


def stopping_figure(table: pd.DataFrame):
    """Decided accuracy against the threshold (top row) and EPs used (bottom row), one column per split kind."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    kinds = list(dict.fromkeys(table["split_kind"]))
    fig, axes = plt.subplots(2, len(kinds), figsize=(5.5 * len(kinds), 8), squeeze=False)
    styles = {("tempered", "active"): ("C0", "-o"), ("tempered", "random"): ("C7", "-s"),
              ("untempered", "active"): ("C3", "--o"), ("untempered", "random"): ("C1", "--s")}
    for col, kind in enumerate(kinds):
        sub = table[table["split_kind"] == kind]
        top, bottom = axes[0, col], axes[1, col]
        for (posterior, strategy), (color, style) in styles.items():
            g = sub[(sub["posterior"] == posterior) & (sub["strategy"] == strategy)].sort_values("threshold")
            label = f"{strategy}, {posterior} posterior"
            err = np.vstack([g["decided_accuracy"] - g["decided_accuracy_ci95_low"],
                             g["decided_accuracy_ci95_high"] - g["decided_accuracy"]])
            top.errorbar(g["threshold"], g["decided_accuracy"], yerr=err, fmt=style, color=color, ms=4, capsize=2,
                         label=label)
            bottom.plot(g["threshold"], g["mean_eps"], style, color=color, ms=4, label=label)
        lim = [float(sub["threshold"].min()) - 0.02, 1.0]
        top.plot(lim, lim, "k:", lw=0.8, label="accuracy = threshold (the promise)")
        top.axhline(sub["chance"].iloc[0], color="k", lw=0.6, ls="--", label="chance")
        top.set_ylim(0, 1.02)
        top.set_ylabel("accuracy of trials decided at t (95% interval)")
        top.set_title(f"PHAC-2 {kind} splits (n={sub['n_splits'].iloc[0]}); missing point: no trial decided")
        bottom.set_ylabel("EPs used (mean)")
        for ax in (top, bottom):
            ax.set_xlabel("threshold t on the top class posterior")
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    fig.suptitle("Stopping rule: does 'decided at t' mean right at least a fraction t of the time?", fontsize=10)
    fig.tight_layout()
    return fig
