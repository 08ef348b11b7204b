"""Figures of the zero-shot study (the DAP paper's Figs. 2a, 3 and 4) as matplotlib figures (Agg backend)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd


def attribute_accuracy_figure(summary: pd.DataFrame):
    """Bar chart of mean per-attribute accuracy (ours) with the paper's quoted values as markers.

    ``summary``: :func:`tzsl.studies.zero_shot.study.attribute_accuracy_summary` output.
    """
    rows = summary[summary["attribute"] != "mean"]
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.bar(x - 0.2, rows["accuracy"], width=0.4, label="accuracy (ours)")
    ax.bar(x + 0.2, rows["balanced_accuracy"], width=0.4, label="balanced accuracy (ours)")
    if "paper_accuracy" in rows.columns:  # only beside the paper's dataset and protocol
        quoted = rows["paper_accuracy"].notna()
        ax.scatter(x[quoted.to_numpy()], rows.loc[quoted, "paper_accuracy"], color="k", marker="_", s=300,
                   zorder=3, label="paper (quoted in text)")
    ax.axhline(0.5, color="grey", lw=0.8, ls=":")
    ax.set_xticks(x, rows["attribute"], rotation=60, ha="right")
    ax.set_ylim(0, 1)
    ax.set_ylabel("test accuracy (mean over splits and sensors)")
    ax.set_title("Attribute classification on unseen objects")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return fig


def object_map_figure(map_coords: pd.DataFrame, dataset: str):
    """The 2-D object map of ``dataset`` with the partition lines y = x, y = -x and the halving line (paper Fig. 3)."""
    fig, ax = plt.subplots(figsize=(7, 6))
    for part, group in map_coords.groupby("partition"):
        label = f"{part}: {group['partition_label'].iloc[0]}"
        ax.scatter(group["x"], group["y"], s=25, label=label)
    dropped = map_coords[map_coords["dropped"].astype(bool)]
    if len(dropped):
        ax.scatter(dropped["x"], dropped["y"], s=80, facecolors="none", edgecolors="k", label="dropped (duplicate)")
    for _, row in map_coords.iterrows():
        ax.annotate(str(row["object"]), (row["x"], row["y"]), fontsize=5, alpha=0.7)
    lim = 1.05 * float(np.abs(map_coords[["x", "y"]].to_numpy()).max())
    t = np.array([-lim, lim])
    ax.plot(t, t, color="red", lw=1)
    ax.plot(t, -t, color="red", lw=1)
    halved = map_coords.attrs.get("halved_wedge", "left")
    if halved in ("left", "right"):
        side = np.array([-lim, 0.0]) if halved == "left" else np.array([0.0, lim])
        ax.plot(side, [0, 0], color="blue", lw=1)
    else:
        side = np.array([0.0, lim]) if halved == "top" else np.array([-lim, 0.0])
        ax.plot([0, 0], side, color="blue", lw=1)
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_xlabel("PC 1")
    ax.set_ylabel("PC 2")
    ax.set_title(f"{dataset} objects: 2-D map and challenging partitions")
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def attribute_sweep_figure(sweep: pd.DataFrame):
    """Accuracy vs number of attributes (paper Fig. 4): per split and the mean."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for split, group in sweep.groupby("split", sort=False):
        if split == "mean":
            ax.errorbar(group["n_attributes"], group["accuracy_mean"], yerr=group["accuracy_std"], color="k",
                        lw=2, capsize=3, label="mean over splits")
        else:
            ax.plot(group["n_attributes"], group["accuracy_mean"], lw=1, alpha=0.6, label=f"split {split}")
    chance = sweep.loc[sweep["split"] == "mean", "chance"]
    if len(chance):
        ax.axhline(float(chance.mean()), color="grey", ls=":", label="chance")
    ax.set_xlabel("number of attributes j")
    ax.set_ylabel("ZSL accuracy (AVGDAP, uni-prior)")
    ax.set_title("Accuracy vs number of attributes")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


