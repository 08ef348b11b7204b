"""Figures of the cross-dataset benchmark: Demšar's critical-difference diagram and a forest plot.

Both draw on a matplotlib :class:`~matplotlib.figure.Figure` with the Agg canvas (no pyplot, no
global backend state) and write a PNG atomically (:func:`tzsl._io.atomic_write`), so a reader
never sees half a file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tzsl._io import atomic_write
from tzsl.exceptions import TzslError
from tzsl.studies.benchmark.statistics import rank_groups

__all__ = ["DPI", "critical_difference_diagram", "meta_analysis_figure"]

#: Resolution of the PNG files (dots per inch).
DPI = 150


def _save(figure: Figure, path: str | Path) -> Path:
    """Write ``figure`` as a PNG at ``path`` atomically."""
    FigureCanvasAgg(figure)
    return atomic_write(path, lambda p: figure.savefig(p, format="png", dpi=DPI, bbox_inches="tight"))


def _as_ranks(mean_ranks: pd.Series | pd.DataFrame) -> pd.Series:
    """Mean rank per method from a Series (index: method) or a ``mean_ranks`` table."""
    if isinstance(mean_ranks, pd.DataFrame):
        if not {"method", "mean_rank"} <= set(mean_ranks.columns):
            raise TzslError("a mean-ranks table needs the columns 'method' and 'mean_rank'")
        mean_ranks = mean_ranks.set_index("method")["mean_rank"]
    ranks = mean_ranks.astype(float)
    if len(ranks) < 2 or not np.isfinite(ranks.to_numpy()).all():
        raise TzslError(f"a critical-difference diagram needs finite mean ranks of at least 2 methods, "
                        f"got {ranks.to_dict()}")
    return ranks.sort_values(kind="stable")


def critical_difference_diagram(mean_ranks: pd.Series | pd.DataFrame, cd: float, path: str | Path, *,
                                title: str | None = None) -> Path:
    """Demšar's critical-difference diagram of mean ranks, written as a PNG.

    An axis of ranks 1 (best, left) to k; each method hangs from its mean rank, the better half
    labelled on the left, the others on the right; a thick bar joins each maximal group of
    methods whose mean ranks differ by less than ``cd`` (:func:`~tzsl.studies.benchmark.statistics.rank_groups`);
    the CD is drawn to scale above the axis.

    Parameters
    ----------
    mean_ranks : Series or DataFrame
        Mean rank of each method (index: method), or the table of
        :func:`~tzsl.studies.benchmark.statistics.mean_ranks`.
    cd : float
        Critical difference in ranks (:func:`~tzsl.studies.benchmark.statistics.critical_difference`).
    path : str or Path
        PNG file written.
    title : str, optional

    Returns
    -------
    Path
        ``path``.
    """
    ranks = _as_ranks(mean_ranks)
    if not np.isfinite(cd) or cd < 0:
        raise TzslError(f"the critical difference must be a finite non-negative number of ranks, got {cd!r}")
    k = len(ranks)
    groups = rank_groups(ranks, cd)
    names, r = [str(m) for m in ranks.index], ranks.to_numpy()
    n_left = (k + 1) // 2
    group_gap = 0.25
    label_top = 0.5 + group_gap * len(groups)  # labels start below the group bars
    step = 0.45
    height = label_top + step * max(n_left, k - n_left)
    figure = Figure(figsize=(7, 1.2 + 0.45 * height))
    ax = figure.subplots()
    ax.set_xlim(1 - 0.1 * k, k + 0.1 * k)
    ax.set_ylim(height + 0.2, -1.4)
    ax.axis("off")
    ax.plot([1, k], [0, 0], color="k", lw=1.2)
    ticks = np.arange(1, k + 1)
    ax.vlines(ticks, -0.12, 0, color="k", lw=1)
    for t in range(1, k + 1):
        ax.text(float(t), -0.2, str(t), ha="center", va="bottom", fontsize=9)
    if cd > 0:  # the CD to scale, from rank 1
        ax.plot([1, 1 + cd], [-0.9, -0.9], color="k", lw=1.2)
        ax.vlines([1, 1 + cd], -1.0, -0.8, color="k", lw=1.2)
        ax.text(1 + cd / 2, -1.0, f"CD = {cd:.2f}", ha="center", va="bottom", fontsize=9)
    for i, (name, rank) in enumerate(zip(names, r, strict=True)):
        left = i < n_left
        y = label_top + step * (i if left else k - 1 - i)
        end = 1 - 0.05 * k if left else k + 0.05 * k
        ax.plot([rank, rank, end], [0, y, y], color="k", lw=0.9)
        ax.text(end + (-0.03 if left else 0.03) * k, y, f"{name} ({rank:.2f})", ha="right" if left else "left",
                va="center", fontsize=9)
    for g, group in enumerate(groups):
        lo, hi = ranks[list(group)].min(), ranks[list(group)].max()
        y = 0.35 + group_gap * g
        ax.plot([lo - 0.03, hi + 0.03], [y, y], color="k", lw=4, solid_capstyle="round")
    if title:
        ax.set_title(title, fontsize=10)
    return _save(figure, path)


def meta_analysis_figure(meta: pd.DataFrame, reference_method: str, path: str | Path, *,
                         title: str | None = None) -> Path:
    """Forest plot: each method's pooled paired effect against ``reference_method`` with its 95% interval.

    Parameters
    ----------
    meta : DataFrame
        :func:`~tzsl.studies.benchmark.statistics.meta_analysis` output; the rows with
        ``method_b == reference_method`` are drawn (effect = method minus reference, in score
        units, fractions of accuracy).
    reference_method : str
    path : str or Path
        PNG file written.
    title : str, optional

    Returns
    -------
    Path
        ``path``.
    """
    need = {"method_a", "method_b", "effect", "ci95_low", "ci95_high", "n_datasets"}
    if not need <= set(meta.columns):
        raise TzslError(f"the meta-analysis table lacks column(s) {sorted(need - set(meta.columns))}")
    rows = meta[meta["method_b"] == reference_method].sort_values("effect", kind="stable", na_position="first")
    if rows.empty:
        raise TzslError(f"no comparison with reference method {reference_method!r} in the meta-analysis table; "
                        f"methods: {sorted(map(str, set(meta['method_a']) | set(meta['method_b'])))}")
    y = np.arange(len(rows))
    effect = rows["effect"].to_numpy(dtype=float)
    low, high = rows["ci95_low"].to_numpy(dtype=float), rows["ci95_high"].to_numpy(dtype=float)
    figure = Figure(figsize=(6.5, 1.2 + 0.4 * len(rows)))
    ax = figure.subplots()
    ok = np.isfinite(effect)
    ax.errorbar(effect[ok], y[ok], xerr=np.vstack([effect[ok] - low[ok], high[ok] - effect[ok]]), fmt="s",
                color="k", ecolor="k", capsize=3, markersize=5)
    ax.axvline(0, color="grey", lw=0.9, ls="--")
    labels = [f"{a} ({n} dataset{'s' if n != 1 else ''})" if np.isfinite(e) else f"{a} (no shared splits)"
              for a, n, e in zip(rows["method_a"], rows["n_datasets"], effect, strict=True)]
    ax.set_yticks(y, labels)
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_xlabel(f"pooled difference in per-class mean accuracy vs {reference_method} (random effects, 95% CI)")
    if title:
        ax.set_title(title, fontsize=10)
    figure.tight_layout()
    return _save(figure, path)
