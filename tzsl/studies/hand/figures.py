"""Figures of the hand study: multi-grasp curves vs T and k, confusion matrices, attributes, S.

Each function takes a table of :class:`tzsl.studies.hand.results.HandStudyResult` (rows per seed
plus ``mean`` / ``std`` rows) and returns a matplotlib Figure.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tzsl.studies.papers import numbers as paper

__all__ = [
    "attribute_accuracy_figure",
    "attribute_distance_figure",
    "confusion_figure",
    "multigrasp_T_figure",
    "multigrasp_k_figure",
]


def _plt():
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    return plt


def _curve(ax, df: pd.DataFrame, x: str, y: str, label: str, color: str) -> None:
    per_seed = df[~df["seed"].isin(["mean", "std"])]
    for _, g in per_seed.groupby("seed"):
        ax.plot(g[x], g[y], color=color, alpha=0.25, lw=0.8)
    mean = df[df["seed"] == "mean"]
    std = df[df["seed"] == "std"][y].fillna(0.0).to_numpy()
    ax.plot(mean[x], mean[y], "o-", color=color, label=label)
    ax.fill_between(mean[x], mean[y] - std, mean[y] + std, color=color, alpha=0.15)


def multigrasp_T_figure(df: pd.DataFrame, data_label: str):
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    _curve(ax, df, "T", "accuracy", "DF-MDAP (ours)", "C0")
    ax.scatter([1], [paper.DAP_HAND_SINGLE_GRASP_BEST], marker="*", s=120, color="k", zorder=3,
               label="paper: LDAP single grasp (T=1)")
    ax.set_xlabel("number of fused grasps T")
    ax.set_ylabel("accuracy on test objects")
    ax.set_ylim(0, 1.02)
    ax.set_title(f"DF-MDAP accuracy vs T\n{data_label}", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return fig


def multigrasp_k_figure(df: pd.DataFrame, data_label: str):
    plt = _plt()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    lo, hi = paper.DAP_HAND_SC_BEST_K_RANGE
    _curve(a1, df, "k", "accuracy", "SC-MDAP (ours)", "C1")
    a1.axvspan(lo - 0.5, hi + 0.5, color="grey", alpha=0.15, label=f"paper: best k in {lo}..{hi}")
    a1.scatter([1], [paper.DAP_HAND_SINGLE_GRASP_BEST], marker="*", s=120, color="k", zorder=3,
               label="paper: LDAP single grasp (k=1)")
    a1.set_ylim(0, 1.02)
    a1.set_xlabel("equal classifications required k")
    a1.set_ylabel("accuracy on test objects")
    a1.legend(loc="lower right", fontsize=8)
    _curve(a2, df, "k", "mean_grasps_used", "mean grasps used", "C2")
    a2.set_xlabel("equal classifications required k")
    a2.set_ylabel("grasps used per decision")
    a2.legend(loc="upper left", fontsize=8)
    fig.suptitle(f"SC-MDAP vs k - {data_label}", fontsize=10)
    fig.tight_layout()
    return fig


def confusion_figure(conf: pd.DataFrame, names: list[str], data_label: str):
    plt = _plt()
    methods = list(pd.unique(conf["method"]))
    fig, axes = plt.subplots(1, len(methods), figsize=(5.2 * len(methods), 5.2))
    axes = np.atleast_1d(axes)
    for ax, method in zip(axes, methods, strict=True):
        c = conf[conf["method"] == method].pivot_table(index="true", columns="predicted", values="count",
                                                       aggfunc="sum")
        rows = [n for n in names if n in c.index]
        c = c.reindex(index=rows, columns=names).fillna(0)
        frac = c.to_numpy() / c.to_numpy().sum(axis=1, keepdims=True)
        ax.imshow(frac, vmin=0, vmax=1, cmap="Blues")
        for (i, j), v in np.ndenumerate(frac):
            if v >= 0.005:
                ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=6,
                        color="white" if v > 0.6 else "black")
        n_all = int(sum(frac[i, names.index(r)] == 1.0 for i, r in enumerate(rows)))
        ax.set_title(f"{method}\nobjects all correct: {n_all}/{len(rows)}", fontsize=9)
        ax.set_xticks(range(len(names)), names, rotation=70, ha="right", fontsize=7)
        ax.set_yticks(range(len(rows)), rows, fontsize=7)
        ax.set_xlabel("predicted")
    axes[0].set_ylabel("true object")
    fig.suptitle(f"Confusion (rows sum to 1, pooled over seeds) - {data_label}; "
                 f"paper Fig. 12: SC-MDAP k=4 all correct on 8/10", fontsize=9)
    fig.tight_layout()
    return fig


def attribute_distance_figure(S: pd.DataFrame, data_label: str):
    plt = _plt()
    mean = S[S["seed"] == "mean"].set_index("object").drop(columns=["seed", "data"], errors="ignore")
    fig, ax = plt.subplots(figsize=(8, 5))
    im = ax.imshow(mean.to_numpy(dtype=float), vmin=0, vmax=1, cmap="viridis")
    for (i, j), v in np.ndenumerate(mean.to_numpy(dtype=float)):
        ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=6, color="white" if v < 0.5 else "black")
    ax.set_xticks(range(mean.shape[1]), mean.columns, rotation=60, ha="right", fontsize=8)
    ax.set_yticks(range(mean.shape[0]), mean.index, fontsize=8)
    fig.colorbar(im, ax=ax, label="S (eq. 13)")
    ax.set_title(f"Attribute distance S = |a - mean p(a=1|x)| (AVGDAP posteriors)\n{data_label}", fontsize=9)
    fig.tight_layout()
    return fig


def attribute_accuracy_figure(df: pd.DataFrame, data_label: str):
    plt = _plt()
    mean = df[(df["seed"] == "mean") & (df["attribute"] != "mean")]
    x = np.arange(len(mean))
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(x - 0.2, mean["accuracy"], width=0.4, label="accuracy (ours)")
    ax.bar(x + 0.2, mean["balanced_accuracy"].fillna(0), width=0.4, label="balanced accuracy (ours)")
    quoted = mean["paper_accuracy"].notna().to_numpy()
    ax.scatter(x[quoted], mean.loc[quoted, "paper_accuracy"], marker="_", s=300, color="k", zorder=3,
               label="paper (quoted in text)")
    ax.axhline(paper.DAP_HAND_MEAN_ATTRIBUTE_ACCURACY, color="k", ls=":", lw=0.8,
               label=f"paper: mean {paper.DAP_HAND_MEAN_ATTRIBUTE_ACCURACY:.2f}")
    ax.set_xticks(x, mean["attribute"], rotation=60, ha="right")
    ax.set_ylim(0, 1.02)
    ax.set_ylabel("test accuracy")
    ax.set_title(f"Attribute classification on test grasps\n{data_label}", fontsize=9)
    ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    return fig
