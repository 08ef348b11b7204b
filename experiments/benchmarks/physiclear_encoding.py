"""PhysiCLeAR's ranks as attributes: one per level, or ordinal thresholds (issue 42, deliverable 1).

``physiclear`` ranks every object's hardness, roughness and bumpiness 0, 1 or 2
(:func:`tzsl.datasets.read_physiclear_attributes`): ``encoding="levels"`` gives one 0/1 attribute per
property and level (9), ``encoding="thresholds"`` one per property and threshold, 1 when the rank is above
it (6, keeping the order); both add the same material attributes. The rule, written before the
thresholds encoding was run: the encoding with the higher mean accuracy over DAP (the study's own),
ESZSL and SAE on the paper's validation split (``physiclear-validation``: 60 training objects, the
validation objects as unseen classes; purpose: choosing) is the one to use; the paper's test split
(``physiclear-test``) is printed for both, for reporting only, never for choosing.

For each encoding the script writes a plain-file folder beside the converted ``physiclear`` (the same
``trials.csv``, the encoding's ``classes.csv`` and the split file over its objects) and runs the zero-shot
study on it with ``[splits] kinds = ["file"]`` (``tzsl run``), then prints per split, method and
encoding the study's accuracy (over test trials), the mean per-class accuracy with a 95% percentile
bootstrap interval over the test classes, chance, and the encoding the rule chooses. Written:
``DIR/physiclear_encoding.csv``.

Run (the videos fetched first: ``tzsl data fetch physiclear``; the conversion is cached)::

    nice -n 10 python experiments/benchmarks/physiclear_encoding.py --data-dir DATA --out DIR --n-jobs 2
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from tzsl.datasets import get_dataset, physiclear_split_roles, physiclear_split_text, read_physiclear_attributes

#: The encodings of :func:`tzsl.datasets.read_physiclear_attributes`.
ENCODINGS = ("levels", "thresholds")
#: The compared methods (the study's own DAP is always run).
METHODS = ("eszsl", "sae")
#: The split that chooses, and the one that only reports.
SELECT, REPORT = "validation", "test"
#: Bootstrap replicates of the interval over test classes.
N_BOOT = 2000


def encoding_folder(converted: Path, encoding: str, out: Path) -> Path:
    """A plain-file folder of the converted dataset with ``encoding``'s class-attribute table."""
    folder = out / encoding / "dataset"
    folder.mkdir(parents=True, exist_ok=True)
    objects = pd.read_csv(converted / "classes.csv")["class"].tolist()
    classes = read_physiclear_attributes(encoding=encoding).classes.loc[objects]
    classes = classes.loc[:, classes.nunique() > 1]
    classes.to_csv(folder / "classes.csv", index_label="class", lineterminator="\n")
    for name in ("trials.csv", "dataset.toml"):
        shutil.copyfile(converted / name, folder / name)
    (folder / "splits.csv").write_text(physiclear_split_text(physiclear_split_roles(), classes), encoding="utf-8")
    return folder


def run_study(folder: Path, results: Path, n_jobs: int) -> pd.DataFrame:
    """``tzsl run`` of the zero-shot study on ``folder`` with its split file; its method comparison."""
    toml = folder.parent / "study.toml"
    toml.write_text(f'study = "zero-shot"\ndescription = "physiclear, {folder.parent.name}"\n'
                    f'[dataset]\nplain = "{folder}"\n[methods]\ncompare = {list(METHODS)!r}\n'
                    f'[splits]\nkinds = ["file"]\n[compute]\nn_jobs = {n_jobs}\n'
                    f'[output]\nfolder = "{results}"\n'.replace("'", '"'))
    subprocess.run([str(Path(sys.executable).parent / "tzsl"), "run", str(toml), "--no-progress"], check=True)
    return pd.read_csv(results / "methods_per_split.csv")


def class_interval(per_class: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """Mean per-class accuracy (n_test_classes,) and its 95% percentile bootstrap interval over the classes."""
    rng = np.random.default_rng(seed)
    boot = per_class[rng.integers(0, len(per_class), size=(N_BOOT, len(per_class)))].mean(axis=1)
    low, high = np.percentile(boot, [2.5, 97.5])
    return float(per_class.mean()), float(low), float(high)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", type=Path, default=None, help="data home holding physiclear/")
    parser.add_argument("--out", type=Path, required=True, help="folder for the two datasets and studies")
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args(argv)
    converted = get_dataset("physiclear").load(args.data_dir).folder
    rows = []
    for encoding in ENCODINGS:
        folder = encoding_folder(converted, encoding, args.out)
        per_split = run_study(folder, args.out / encoding / "results", args.n_jobs)
        per_class = pd.read_csv(args.out / encoding / "results" / "class_accuracy.csv")
        for split in (SELECT, REPORT):
            row = per_split[per_split["split"] == split].iloc[0]
            # dap-max has no column of its own: its fits are dap-avg's
            for method in [m for m in sorted(set(per_class["method"])) if m in per_split.columns]:
                classes = per_class[(per_class["split"] == split) & (per_class["method"] == method)]
                mean, low, high = class_interval(classes["accuracy"].to_numpy(dtype=float))
                rows.append({"encoding": encoding, "split": split, "method": method,
                             "accuracy": float(row[method]), "class_mean": mean,
                             "class_mean_ci95_low": low, "class_mean_ci95_high": high,
                             "chance": float(row["chance"]), "n_test_classes": len(classes)})
    table = pd.DataFrame(rows)
    table.to_csv(args.out / "physiclear_encoding.csv", index=False)
    print(table.round(3).to_string(index=False))
    chosen = table[table["split"] == SELECT].groupby("encoding")["accuracy"].mean()
    print(f"mean {SELECT} accuracy per encoding: {chosen.to_dict()}; the rule chooses {chosen.idxmax()!r}")


if __name__ == "__main__":
    main()
