"""The generated block of the fabric paper's pipeline on PhysiCLeAR (``make physiclear``, never typed).

:func:`physiclear_block` reads a folder holding the two built-in studies' results, ``zero-shot/`` (``tzsl run
physiclear``: texture descriptors of the key frames, the embedding model over the lambda grid, ESZSL, SAE and
the study's DAP) and ``deep/`` (``tzsl run physiclear-deep``: the CNN + LSTM over the same grid), and writes
one row per model: the per-class mean accuracy on the paper's validation objects (where lambda is chosen) and
on its test objects (the unseen classes reported), each with its 95% bootstrap interval over the objects, the
test trial accuracy and chance. The lambda each model family chooses on the validation objects is marked.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from tzsl.evaluation import bootstrap_accuracy
from tzsl.reporting.benchmark_blocks import MissingResults
from tzsl.reporting.markdown_cells import number

__all__ = ["PHYSICLEAR_SPLITS", "physiclear_block", "zero_shot_rows"]

#: The paper's splits (``physiclear-validation``, ``physiclear-test`` in the shipped split file) as the study's tables
#: label them (:func:`tzsl.studies.zero_shot.tables.split_label`: the part after the last "-").
PHYSICLEAR_SPLITS = ("validation", "test")
#: Method labels of the embedding model over the lambda grid (the zero-shot study's ``embedding_lam_<lam>``).
EMBEDDING_PREFIX = "embedding_lam_"


def _read(path: Path, command: str) -> pd.DataFrame:
    if not path.is_file():
        raise MissingResults(f"{path}: missing; run {command} first (make physiclear)")
    return pd.read_csv(path, dtype={"split": str})


def _interval(cell: str, row: pd.Series, prefix: str) -> str:
    return f"{number(row[cell])} [{number(row[prefix + '_low'])}, {number(row[prefix + '_high'])}]"


def zero_shot_rows(folder: str | Path) -> pd.DataFrame:
    """Per method of ``tzsl run physiclear``: per-class mean accuracy on each paper split with its interval.

    Parameters
    ----------
    folder : path-like
        The study's results folder (``class_accuracy.csv``, ``methods_per_split.csv``).

    Returns
    -------
    DataFrame
        One row per method: ``method``, and per protocol ``p`` in (validation, test) ``p`` (per-class mean
        accuracy), ``p_low``, ``p_high`` (95% percentile bootstrap over the split's test objects,
        :func:`tzsl.evaluation.bootstrap_accuracy`), ``p_chance`` (1 / objects); ``test_trial`` (trial
        accuracy on the test objects; NaN for a row the method table does not hold, e.g. MAXDAP).
    """
    folder = Path(folder)
    classes = _read(folder / "class_accuracy.csv", "tzsl run physiclear")
    per_split = _read(folder / "methods_per_split.csv", "tzsl run physiclear").set_index("split")
    rows = []
    for method, part in classes.groupby("method", sort=False):
        row: dict = {"method": method}
        for protocol, split in zip(("validation", "test"), PHYSICLEAR_SPLITS, strict=True):
            objects = part[part["split"] == split]
            if objects.empty:
                raise MissingResults(f"{folder}: no split {split!r} in class_accuracy.csv; not the paper's split file")
            mean, low, high = bootstrap_accuracy(objects["accuracy"].to_numpy(dtype=float),
                                                 classes=objects["class"].to_numpy())
            row.update({protocol: mean, f"{protocol}_low": low, f"{protocol}_high": high,
                        f"{protocol}_chance": 1 / len(objects)})
        row["test_trial"] = float(per_split.loc[PHYSICLEAR_SPLITS[1]].get(method, float("nan")))
        rows.append(row)
    return pd.DataFrame(rows)


def _chosen(labels: pd.Series, validation: pd.Series) -> str:
    """The label with the highest validation score (ties: the first, in the grid's order)."""
    return str(labels.iloc[int(validation.to_numpy().argmax())])


def physiclear_block(results: str | Path) -> str:
    """The pipeline's Markdown from ``results`` (``zero-shot/`` and ``deep/``, module docstring).

    Raises
    ------
    MissingResults
        A study's table is missing (the block is left as it is).
    """
    root = Path(results)
    shallow = zero_shot_rows(root / "zero-shot")
    deep = _read(root / "deep" / "fabric_deep_table.csv", "tzsl run physiclear-deep")
    deep = deep[deep["zero_shot"].astype(str) == "True"]
    lines = ["Generated from `zero-shot/` (`tzsl run physiclear`) and `deep/` (`tzsl run physiclear-deep`) by "
             "`make numbers`: per-class mean accuracy on the paper's validation objects (where lambda is chosen) "
             "and on its 7 test objects (the unseen classes), each [95% bootstrap interval over the objects], "
             "trial accuracy on the test objects and chance. The descriptor models are fitted on the training "
             "and validation objects for the test split, the CNN + LSTM on the training objects only (it chooses "
             "lambda on the validation objects); ✓ marks each family's lambda chosen on validation.", "",
             "| features | method | validation | test | test trials | chance (test) |", "|---|---|---|---|---|---|"]
    embedding = shallow[shallow["method"].str.startswith(EMBEDDING_PREFIX)]
    chosen = _chosen(embedding["method"], embedding["validation"]) if len(embedding) else ""
    for _, r in shallow.iterrows():
        mark = " ✓" if r["method"] == chosen else ""
        lines.append(f"| key-frame descriptors | `{r['method']}`{mark} | {_interval('validation', r, 'validation')} | "
                     f"{_interval('test', r, 'test')} | {number(r['test_trial'])} | {number(r['test_chance'])} |")
    by_protocol = {p: part.set_index("method") for p, part in deep.groupby("protocol")}
    if {"validation", "test"} <= set(by_protocol):
        validation, test = by_protocol["validation"], by_protocol["test"]
        for method in test.index:
            v, t = validation.loc[method], test.loc[method]
            mark = " ✓" if str(v.get("chosen_on_validation")) == "True" else ""
            lines.append(f"| key-frame imprints, CNN + LSTM | `{method}`{mark} | "
                         f"{_interval('per_class_mean_accuracy', v, 'per_class_mean_accuracy_ci95')} | "
                         f"{_interval('per_class_mean_accuracy', t, 'per_class_mean_accuracy_ci95')} | "
                         f"{number(t['accuracy'])} | {number(t['chance'])} |")
    return "\n".join(lines)
