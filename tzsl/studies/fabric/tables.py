"""The fabric study's Table 1 analogue, its text form and Fig. 6 (accuracy vs lambda).

Views of ``fabric_runs.csv`` (one row per fit, :func:`tzsl.studies.fabric.study.run_fabric_study`):
:func:`fabric_table` averages the seeds (:func:`tzsl.evaluation.summarise_over_splits`) and
puts the paper's numbers beside ours, :func:`format_fabric_table` prints it,
:func:`fabric_lambda_figure` draws it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from tzsl.datasets import FabricSplit, fabric_zsl_split
from tzsl.evaluation import Outcomes, add_trust_columns, summarise_over_splits, zero_shot_variant
from tzsl.models.embedding import loss_weights
from tzsl.models.protocol import LAST_BIT_NOTE, moves_with_last_bit
from tzsl.studies.fabric.samples import FabricSamples
from tzsl.studies.papers.numbers import FABRIC_TABLE1

__all__ = [
    "ESZSL_METHOD",
    "PAPER_PROTOCOL",
    "ZERO_SHOT_STRATEGY",
    "FabricProtocol",
    "fabric_protocols",
    "PAPER_CONFIG",
    "PAPER_LAMBDAS",
    "fabric_lambda_figure",
    "fabric_note",
    "fabric_outcomes",
    "fabric_table",
    "format_fabric_table",
    "lambda_label",
    "method_names",
    "paper_key",
]

#: The paper's lambda grid (Table 1); "inf" = regression term only (see :mod:`tzsl.studies.fabric.study`).
PAPER_LAMBDAS: tuple = (0, 0.1, 1, 10, "inf")
#: Method name of ESZSL in the runs and the table.
ESZSL_METHOD = "ESZSL"
#: The split config the paper reports (its test groups 0, 5, 7).
PAPER_CONFIG = 1
#: Protocol label of the paper's own split (a reproduction row; not zero-shot on a8).
PAPER_PROTOCOL = "paper"
#: How the headline zero-shot variant is made (:func:`tzsl.evaluation.zero_shot_variant`):
#: test groups whose attribute row a training group has are dropped (training unchanged).
ZERO_SHOT_STRATEGY: Literal["drop", "merge"] = "drop"


@dataclass(frozen=True)
class FabricProtocol:
    """One split the study runs: the paper's, or its zero-shot variant (the headline).

    Attributes
    ----------
    name : str
        ``"paper"`` or ``"zero-shot-drop"``.
    split : FabricSplit
    zero_shot : bool
        Whether no test group has an attribute row that a training group has.
    note : str
        What the row is (for the table's ``note`` column and the report).
    """

    name: str
    split: FabricSplit
    zero_shot: bool
    note: str


def fabric_protocols(configs: Sequence[int], attributes: pd.DataFrame) -> list[FabricProtocol]:
    """Per config: the paper's split, and (when it is not zero-shot) its zero-shot variant.

    In the a8 matrix groups 3, 4 and 5 share one row, so config 1 (test 0, 5, 7) tests group 5
    on a row seen in training: the paper's split stays as a reproduction row labelled not
    zero-shot, and the variant of :data:`ZERO_SHOT_STRATEGY` (``drop``: test groups 0, 7, the
    paper's training groups) is the headline.
    """
    out = []
    A = attributes.to_numpy(dtype=np.float64)
    for config in configs:
        paper = fabric_zsl_split(config, A)
        variant = zero_shot_variant(attributes.reset_index(drop=True), list(paper.train_groups),
                                    list(paper.test_groups), strategy=ZERO_SHOT_STRATEGY)
        if variant.strategy == "none":
            out.append(FabricProtocol(PAPER_PROTOCOL, paper, True, "the paper's split is zero-shot here"))
            continue
        out.append(FabricProtocol(PAPER_PROTOCOL, paper, False,
                                  f"reproduction of the paper's split, NOT zero-shot: {variant.note.split(':')[0]}"))
        split = FabricSplit(config=int(config), train_groups=tuple(int(g) for g in variant.train_classes),
                            test_groups=tuple(int(g) for g in variant.test_classes))
        out.append(FabricProtocol(f"zero-shot-{ZERO_SHOT_STRATEGY}", split, True,
                                  f"zero-shot variant ({ZERO_SHOT_STRATEGY}): {variant.note}"))
    return out


def lambda_label(lam) -> str:
    """Column label of a paper lambda: ``0 -> "0"``, ``0.1 -> "0.1"``, ``"inf" -> "inf"``."""
    w_c, _ = loss_weights(lam)
    if w_c == 0.0:
        return "inf"
    return f"{float(lam):g}"


def method_names(lams: Sequence) -> list[str]:
    """Method columns of the table: ``lam_<label>`` per lambda, then ``ESZSL``."""
    return [f"lam_{lambda_label(lam)}" for lam in lams] + [ESZSL_METHOD]


def paper_key(method: str) -> str:
    """Key of a method column in :data:`~tzsl.studies.papers.numbers.FABRIC_TABLE1`."""
    return ESZSL_METHOD if method == ESZSL_METHOD else method[len("lam_"):]


def fabric_note(samples: FabricSamples, config: int, duplicates: list[tuple[int, ...]], attributes: str) -> str:
    """The ``note`` column of one (condition, config) row: data, paper row and deviations."""
    parts = []
    if samples.condition.startswith("depth"):
        parts.append("public depth images, not the paper's GelSight videos")
    if config != PAPER_CONFIG:
        parts.append(f"the paper reports config {PAPER_CONFIG} only: no paper numbers")
    elif samples.paper_row == "Average":
        parts.append("paper columns = the paper's Average row over its GelSight Flat/Fold/Rand videos "
                     "(CNN+LSTM), for orientation only")
    elif samples.paper_row is not None:
        parts.append(f"paper columns = the paper's {samples.paper_row} row")
    else:
        parts.append("no paper row of this name")
    parts.append("lam_inf = regression term R only (the paper's caption says C only; see EmbeddingZSL)")
    if duplicates:
        dup = "; ".join(",".join(map(str, d)) for d in duplicates)
        parts.append(f"{attributes}: groups {dup} share one attribute vector (merged in training)")
    if moves_with_last_bit():
        parts.append(f"ESZSL and every lam_* column: {LAST_BIT_NOTE}")
    return "; ".join(parts)


def fabric_outcomes(rows: list[dict]) -> tuple[Outcomes, Outcomes]:
    """Per-sample outcomes of every fit, for the table (methods as columns) and the runs (one row per fit).

    Pops the ``"_y"`` entry (``(y_true, y_pred)``) from each run row of
    :func:`tzsl.studies.fabric.study.run_fabric_study`; the seed is the split level of the bootstrap.
    """
    table = Outcomes(split_column="seed", by=("condition", "config", "protocol"))
    runs = Outcomes(split_column="seed", by=("condition", "config", "protocol", "method"))
    for row in rows:
        if "_y" not in row:  # a failed fit: recorded in the runs table (error column), no outcomes
            continue
        y_true, y_pred = row.pop("_y")
        keys = {k: row[k] for k in ("condition", "config", "protocol")}
        seed = "None" if row["seed"] is None else row["seed"]
        for column, metric in ((row["method"], "trial"), (f"{row['method']}_pcma", "class_mean")):
            table.add(seed, column, y_true, y_true == y_pred, metric=metric, **keys)
        for column, metric in (("accuracy", "trial"), ("per_class_mean_accuracy", "class_mean")):
            runs.add(seed, column, y_true, y_true == y_pred, metric=metric, method=row["method"], **keys)
    return table, runs


def fabric_table(runs: pd.DataFrame, lams: Sequence = PAPER_LAMBDAS, outcomes: Outcomes | None = None) -> pd.DataFrame:
    """Aggregate the runs into the Table 1 analogue.

    Parameters
    ----------
    runs : DataFrame
        ``fabric_runs.csv`` (one row per fit) with the per-row columns condition, config,
        unit, test_groups, paper_row, note, n_train, n_test, method, seed, accuracy,
        per_class_mean_accuracy.
    lams : sequence
        The lambdas run (column order).

    Returns
    -------
    DataFrame
        One row per (condition, config), in run order. Columns: condition, config, unit,
        test_groups, n_train, n_test, chance (1 / number of test groups), n_seeds; for each
        method M in ``lam_<lambda>...`` and ``ESZSL``: ``M`` (mean accuracy over seeds),
        ``M_std`` (sample std over seeds, ddof=1; NaN for one seed; 0 for the deterministic
        ESZSL), ``M_pcma`` and ``M_pcma_std`` (per-class mean accuracy); ``paper_M`` (the
        paper's Table 1 number for ``paper_row``, NaN where it has none); paper_row, note.
        Accuracies are fractions in [0, 1]. With a ``protocol`` column in the runs (paper split
        or its zero-shot variant, :func:`fabric_protocols`), one row per (condition, config,
        protocol) with ``protocol``, ``zero_shot`` and ``train_groups``; the headline is the
        per-class mean accuracy (``M_pcma``) of the zero-shot rows.
    outcomes : Outcomes, optional
        Per-test-sample outcomes of every fit (``split_column="seed"``, ``by=(condition,
        config, protocol)``, columns ``M`` and ``M_pcma``): adds interval columns
        ``M_ci95_low``/``M_ci95_high`` (bootstrap over seeds and over test groups within a
        seed; :mod:`tzsl.evaluation._trust`), ``chance`` and ``majority``.
    """
    methods = method_names(lams)
    keys = ["condition", "config"] + (["protocol"] if "protocol" in runs.columns else [])
    rows = []
    for key, sub in runs.groupby(keys, sort=False):
        cond, config = key[0], key[1]
        first = sub.iloc[0]
        n_test_groups = len(str(first["test_groups"]).split())
        row = {
            "condition": cond,
            "config": int(config),
            **({"protocol": first["protocol"], "zero_shot": bool(first["zero_shot"]),
                "train_groups": first["train_groups"]} if "protocol" in keys else {}),
            "unit": first["unit"],
            "test_groups": first["test_groups"],
            "n_train": int(first["n_train"]),
            "n_test": int(first["n_test"]),
            "chance": 1.0 / n_test_groups,
            "n_seeds": int(sub.loc[sub["method"] != ESZSL_METHOD, "seed"].nunique()),
        }
        stats = {}
        for m in methods:
            got = sub.loc[sub["method"] == m, ["accuracy", "per_class_mean_accuracy"]].reset_index(drop=True)
            summary = summarise_over_splits(got) if len(got) else None  # rows mean, std over seeds
            for metric, suffix in (("accuracy", ""), ("per_class_mean_accuracy", "_pcma")):
                stats[f"{m}{suffix}"] = np.nan if summary is None else float(summary.loc["mean", metric])
                if m == ESZSL_METHOD:
                    std = 0.0 if len(got) else np.nan  # deterministic: identical for every seed
                else:
                    std = float(summary.loc["std", metric]) if summary is not None and len(got) > 1 else np.nan
                stats[f"{m}{suffix}_std"] = std
        for m in methods:
            row[m] = stats[m]
        for m in methods:
            row[f"{m}_std"] = stats[f"{m}_std"]
        for m in methods:
            row[f"{m}_pcma"] = stats[f"{m}_pcma"]
        for m in methods:
            row[f"{m}_pcma_std"] = stats[f"{m}_pcma_std"]
        paper_row = first["paper_row"] if isinstance(first["paper_row"], str) and first["paper_row"] else None
        for m in methods:
            value = np.nan
            if (paper_row is not None and int(config) == PAPER_CONFIG
                    and row.get("protocol", PAPER_PROTOCOL) == PAPER_PROTOCOL):
                value = FABRIC_TABLE1[paper_row].get(paper_key(m), np.nan)
            row[f"paper_{m}"] = value
        with_paper = paper_row and int(config) == PAPER_CONFIG and row.get("protocol", PAPER_PROTOCOL) == PAPER_PROTOCOL
        row["paper_row"] = paper_row if with_paper else ""
        row["note"] = first["note"]
        rows.append(row)
    table = pd.DataFrame(rows)
    if outcomes is None:
        return table
    table.insert(0, "seed", "mean")
    return add_trust_columns(table, outcomes, per_split_rows=False).drop(columns="seed")


def format_fabric_table(table: pd.DataFrame) -> str:
    """Plain-text table: per method ``mean±std [paper]`` (accuracy in percent)."""
    methods = [c for c in table.columns if f"paper_{c}" in table.columns]
    n_seeds = int(table["n_seeds"].max()) if len(table) else 0
    proto = "protocol" in table.columns
    head = ["condition", "cfg"] + (["protocol"] if proto else []) + ["test", "n_test", "chance"] + [
        "ESZSL" if m == ESZSL_METHOD else f"lam={m[len('lam_'):]}" for m in methods
    ]
    lines = []
    for _, r in table.iterrows():
        cells = [str(r["condition"]), str(r["config"])] + ([str(r["protocol"])] if proto else []) + [
            str(r["test_groups"]).replace(" ", ","), str(r["n_test"]), f"{100 * r['chance']:.1f}"]
        for m in methods:
            mean, std, paper = r[m], r[f"{m}_std"], r[f"paper_{m}"]
            cell = f"{100 * mean:.1f}" + ("" if pd.isna(std) else f"±{100 * std:.1f}")
            if not pd.isna(paper):
                cell += f" [{100 * paper:.2f}]"  # the paper prints two decimals
            cells.append(cell)
        lines.append(cells)
    widths = [max(len(h), *(len(c[i]) for c in lines)) for i, h in enumerate(head)] if lines else [len(h) for h in head]
    fmt = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True))  # noqa: E731
    out = [
        f"Fabric zero-shot accuracy (%) on unseen groups: ours mean±std over {n_seeds} seed(s), "
        "[paper Table 1] beside (GelSight videos; Average row beside depth rows)",
        fmt(head),
        fmt(["-" * w for w in widths]),
    ]
    out += [fmt(c) for c in lines]
    out.append("lam=inf: regression term R only (documented deviation from the paper's caption). "
               "protocol=paper is NOT zero-shot on a8 (test group 5 shares its row with training groups 3, 4); "
               "the headline is the zero-shot-drop rows' per-class mean accuracy, with intervals, "
               "chance and majority in fabric_table1.csv.")
    return "\n".join(out)


def fabric_lambda_figure(table: pd.DataFrame, lams: Sequence = PAPER_LAMBDAS):
    """Accuracy vs lambda, ours (mean ± std over seeds) and the paper's (its Fig. 6).

    One panel per split config; ESZSL as a separate point right of the lambda axis; the
    paper's Flat / Fold / Rand / Average rows (config 1 panel only) as dashed lines.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib  # noqa: PLC0415  # matplotlib is heavy: imported only to draw the figure

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415  # after matplotlib.use("Agg")

    methods = method_names(lams)
    labels = [lambda_label(lam) for lam in lams]
    x = np.arange(len(lams))
    x_es = len(lams) + 0.5
    configs = list(dict.fromkeys(table["config"].tolist()))
    fig, axes = plt.subplots(1, len(configs), figsize=(6 * len(configs), 4.5), sharey=True, squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, config in zip(axes[0], configs, strict=True):
        sub = table[table["config"] == config]
        for i, (_, r) in enumerate(sub.iterrows()):
            c = colours[i % len(colours)]
            mean = r[methods[:-1]].to_numpy(dtype=float)
            std = np.nan_to_num(r[[f"{m}_std" for m in methods[:-1]]].to_numpy(dtype=float))
            label = r["condition"] + (f", {r['protocol']}" if "protocol" in r.index else "")
            ax.errorbar(x, mean, yerr=std, color=c, marker="o", capsize=3, label=f"{label} (ours)")
            ax.plot([x_es], [r[ESZSL_METHOD]], color=c, marker="s", ls="none")
        if config == PAPER_CONFIG:
            greys = {"Flat": "0.25", "Fold": "0.45", "Rand": "0.6", "Average": "0.0"}
            for row, grey in greys.items():
                vals = [FABRIC_TABLE1[row][paper_key(m)] for m in methods]
                ax.plot(x, vals[:-1], color=grey, ls="--", marker="x", label=f"paper {row}")
                ax.plot([x_es], [vals[-1]], color=grey, marker="x", ls="none")
        for chance in sorted(set(sub["chance"].round(4))):
            ax.axhline(chance, color="red", lw=0.8, ls=":", label=f"chance ({chance:.2f})")
        ax.set_xticks(list(x) + [x_es], labels + ["ESZSL"])
        ax.set_xlabel("lambda (loss C + lambda R; inf = R only)")
        test = " / ".join(dict.fromkeys(str(t).replace(" ", ", ") for t in sub["test_groups"]))
        ax.set_title(f"config {config}: test groups {test}")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3)
    axes[0][0].set_ylabel("zero-shot accuracy on unseen groups")
    fig.tight_layout()
    return fig
