"""Standard splits: a fixed, versioned set of unseen-class splits per benchmark dataset ("tzsl splits v1").

As GBU's proposed splits for vision, a paper can say "tzsl splits v1" and mean the same test objects:
every built-in benchmark dataset (:data:`~tzsl.studies.benchmark.catalog.BENCHMARK_DATASETS`) has one
split file in the package, ``tzsl/studies/benchmark/splits/v1/<dataset>.csv`` (the long format of
:func:`tzsl.evaluation.write_splits_csv`, with its ``purpose`` column), and ``index.json`` beside
it records each file's sha256 and the recipe's numbers. A reader checks the hash, so an edited file
is refused with one line.

The recipe of v1 (:func:`standard_splits`), fixed before any result was seen:

* per purpose (``select``: make a choice; ``confirm``: report it; :func:`tzsl.evaluation.split_purpose`
  assigns every test set to one), :data:`N_SPLITS` random object splits drawn with seed
  :data:`SEED`, no two with the same test set; a dataset with fewer distinct valid test sets has
  all of them (the index records how many);
* :func:`n_test_of` unseen classes per split: one in six of the objects (the DAP paper's 10 of 60
  PHAC-2 objects), at least 2 and at most 10, and never more than the distinct attribute rows;
* the DAP paper's rules of every split: mutually different test rows, attributes with fewer than 3
  positive training objects left out of that split, and (so that every attribute a split keeps can be
  learnt) fewer than :data:`~tzsl.models.detectors.MIN_OBJECTS_PER_LABEL` negative ones;
* the objects sorted by name before the draws, so the splits depend on the objects and their rows, not on
  the order a loader lists them in.

The challenging partitions (DAP paper 4.6) are deterministic from the data already
(``tzsl splits --split challenging``) and are not part of this file.
"""

from __future__ import annotations

import dataclasses
import json
import os
from importlib import resources
from pathlib import Path

import pandas as pd

from tzsl._io import atomic_write_bytes, file_sha256
from tzsl.evaluation import PURPOSES, Split, random_object_splits, read_splits_csv, write_splits_csv
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.models.detectors import MIN_OBJECTS_PER_LABEL

__all__ = ["N_SPLITS", "SEED", "SPLITS_VERSION", "n_test_of", "read_standard_splits", "standard_index",
           "standard_split_file", "standard_splits", "write_standard_splits"]

#: The version of the standard splits this package ships (and the folder that holds them).
SPLITS_VERSION = "v1"
#: Splits per purpose (at most: a small dataset has fewer distinct test sets).
N_SPLITS = 20
#: The seed of the draws (each purpose draws from its own stream: :func:`tzsl.evaluation.purpose_seed`).
SEED = 0
#: Share of the objects left unseen per split (the DAP paper: 10 of 60), and the bounds on the count.
TEST_SHARE, MIN_TEST, MAX_TEST = 1 / 6, 2, 10
#: The DAP paper's fewest positive training objects of an attribute a split keeps (section 4.2).
MIN_TRAIN_POSITIVES = 3
#: The index of a version's files: their hashes and recipe numbers.
INDEX_FILE = "index.json"


def n_test_of(object_attributes: pd.DataFrame) -> int:
    """The unseen classes per standard split of a table (n_objects, n_attributes): one in six, within [2, 10].

    Never more than the number of distinct attribute rows (test rows must differ) nor than leaves one
    object to train on.
    """
    n_objects = len(object_attributes)
    n_distinct = len(object_attributes.drop_duplicates())
    n = min(MAX_TEST, max(MIN_TEST, round(n_objects * TEST_SHARE)))
    return max(1, min(n, n_distinct, n_objects - 1))


def standard_splits(object_attributes: pd.DataFrame) -> list[Split]:
    """The standard splits (:data:`SPLITS_VERSION`) of a table: the selection splits, then the confirmation ones.

    Parameters
    ----------
    object_attributes : DataFrame of shape (n_objects, n_attributes)
        0/1, indexed by object: the table the dataset's study reads
        (:meth:`~tzsl.studies.benchmark.catalog.BenchmarkDataset.object_attributes`).

    Returns
    -------
    list of Split
        Named ``select-01`` ... and ``confirm-01`` ...; ``kind="random"``, ``seed`` :data:`SEED`.

    Raises
    ------
    SplitError
        The table cannot give one valid split of a purpose.
    """
    object_attributes = object_attributes.sort_index()  # the draws read the rows by position: one order for all
    n_test = n_test_of(object_attributes)
    splits = []
    for purpose in PURPOSES:
        drawn = random_object_splits(object_attributes, n_test=n_test, n_splits=N_SPLITS, random_state=SEED,
                                     min_train_positives=MIN_TRAIN_POSITIVES,
                                     min_train_negatives=MIN_OBJECTS_PER_LABEL, purpose=purpose, distinct=True)
        splits += [dataclasses.replace(s, name=f"{purpose}-{k:02d}") for k, s in enumerate(drawn, 1)]
    return splits


def _folder(version: str) -> Path:
    if version != SPLITS_VERSION:
        raise ConfigError(f"unknown standard split version {version!r}; this tzsl ships {SPLITS_VERSION}")
    return Path(str(resources.files("tzsl.studies.benchmark").joinpath("splits", version)))


def standard_index(version: str = SPLITS_VERSION) -> dict[str, dict]:
    """``index.json`` of a version: per dataset its file's sha256, ``n_test`` and splits per purpose."""
    return json.loads((_folder(version) / INDEX_FILE).read_text(encoding="utf-8"))


def standard_split_file(dataset: str, version: str = SPLITS_VERSION) -> Path:
    """The packaged split file of ``dataset``, its sha256 checked against the index.

    Raises
    ------
    ConfigError
        No standard splits for ``dataset`` (the message lists the datasets that have them).
    DataFileError
        The file's sha256 is not the index's (an edited or damaged file).
    """
    index = standard_index(version)
    if dataset not in index:
        raise ConfigError(f"no standard splits {version} for {dataset!r}; they exist for {', '.join(index)}")
    path = _folder(version) / f"{dataset}.csv"
    digest = file_sha256(path)
    if digest != index[dataset]["sha256"]:
        raise DataFileError(path, f"sha256 {digest[:12]}... is not the {version} index's "
                                  f"{index[dataset]['sha256'][:12]}...; reinstall tzsl")
    return path


def read_standard_splits(dataset: str, object_attributes: pd.DataFrame, purpose: str | None = None,
                         version: str = SPLITS_VERSION) -> list[Split]:
    """The standard splits of ``dataset`` read against its table, those of ``purpose`` only when given."""
    splits = read_splits_csv(standard_split_file(dataset, version), object_attributes)
    return [s for s in splits if purpose is None or s.name.startswith(f"{purpose}-")]


def write_standard_splits(tables: dict[str, pd.DataFrame], folder: str | os.PathLike) -> dict[str, dict]:
    """Write the standard split file of every dataset in ``tables`` and their ``index.json`` into ``folder``.

    What the maintainers ran once to make a version (``python -m tzsl.studies.benchmark.splits``); a
    test draws them again and compares, so the recipe cannot drift from the files.

    Returns
    -------
    dict
        The index written.
    """
    folder = Path(folder)
    index = {}
    for name, table in tables.items():
        splits = standard_splits(table)
        path = write_splits_csv(splits, folder / f"{name}.csv")
        counts = {p: sum(s.name.startswith(f"{p}-") for s in splits) for p in PURPOSES}
        index[name] = {"sha256": file_sha256(path), "n_objects": len(table),
                       "n_test": n_test_of(table), **{f"n_{p}": n for p, n in counts.items()}}
    atomic_write_bytes(folder / INDEX_FILE, (json.dumps(index, indent=1, sort_keys=True) + "\n").encode("utf-8"))
    return index


def main() -> None:  # pragma: no cover - the maintainers' tool that wrote splits/v1 (the data must be present)
    from tzsl.studies.benchmark.catalog import BENCHMARK_DATASETS  # noqa: PLC0415

    tables = {d.name: d.object_attributes() for d in BENCHMARK_DATASETS}
    for name, entry in write_standard_splits(tables, _folder(SPLITS_VERSION)).items():
        print(name, entry)


if __name__ == "__main__":  # pragma: no cover
    main()
