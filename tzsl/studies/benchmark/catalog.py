"""The benchmark's datasets: the built-in datasets every method is scored on, and how a lab's own joins them.

A benchmark dataset is a built-in dataset (``tzsl datasets``) of recorded touch whose classes have an
attribute description: the two papers' (PHAC-2's Penn features, the fabric depth images) and the
public datasets of the catalog (``docs/user_guide/dataset_catalog.md``). The simulated hand
dataset is not one: its touch is simulated. ``tzsl benchmark --add FOLDER`` places a lab's own
plain-file dataset beside them (:func:`plain_dataset`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from tzsl.datasets import get_dataset
from tzsl.exceptions import ConfigError

__all__ = ["BENCHMARK_DATASETS", "BenchmarkDataset", "benchmark_datasets", "plain_dataset"]


@dataclass(frozen=True)
class BenchmarkDataset:
    """One dataset of the benchmark.

    Attributes
    ----------
    name : str
        Its name in the benchmark's tables: the built-in dataset's name, or the folder name of a
        lab's plain-file dataset.
    builtin : str or None
        The built-in dataset (``[dataset] builtin``); None for a plain-file folder.
    plain : Path or None
        A lab's plain-file dataset folder (``[dataset] plain``); None for a built-in one.
    """

    name: str
    builtin: str | None = None
    plain: Path | None = None

    @property
    def standard(self) -> bool:
        """Whether the benchmark ships its standard split file (a built-in dataset) or draws it (a lab's)."""
        return self.builtin is not None

    def dataset_table(self) -> dict[str, str]:
        """The ``[dataset]`` table of an experiment reading it."""
        return {"builtin": self.builtin} if self.builtin is not None else {"plain": str(self.plain)}

    def object_attributes(self, data_dir: str | os.PathLike | None = None) -> pd.DataFrame:
        """The object-attribute table (n_objects, n_attributes) of 0/1 a zero-shot study of it reads.

        The study's own table (:func:`tzsl.features.load_features` with the default ``min_objects``), so
        splits drawn on it read back in the study unchanged.
        """
        from tzsl.features import load_features  # noqa: PLC0415 (reads data)

        return load_features(self.builtin, plain=self.plain, data_dir=data_dir).attributes


#: The built-in datasets of the benchmark, in the order of its tables.
BENCHMARK_DATASETS: tuple[BenchmarkDataset, ...] = tuple(
    BenchmarkDataset(name, builtin=name)
    for name in ("phac2-penn", "fabric-depth", "biotac-slide", "bts3", "icub-grasp", "physiclear"))


def plain_dataset(folder: str | os.PathLike) -> BenchmarkDataset:
    """A lab's plain-file dataset folder as a benchmark dataset (``tzsl benchmark --add FOLDER``).

    Raises
    ------
    ConfigError
        The folder does not exist, or its name is a built-in benchmark dataset's.
    """
    path = Path(folder).expanduser().resolve()
    if not path.is_dir():
        raise ConfigError(f"{folder}: --add needs a plain-file dataset folder (tzsl formats); not a folder")
    if path.name in {d.name for d in BENCHMARK_DATASETS}:
        raise ConfigError(f"{folder}: a lab's dataset cannot take the name of the benchmark's {path.name!r}; "
                          "rename the folder")
    return BenchmarkDataset(path.name, plain=path)


def benchmark_datasets(names: Sequence[str] = (), added: Sequence[str | os.PathLike] = (), *,
                       catalog: bool = True) -> list[BenchmarkDataset]:
    """The datasets of a benchmark run: ``names`` of the catalog (default: all of them, none when ``catalog`` is
    False), then each ``added`` folder.

    Raises
    ------
    ConfigError
        A name that is not a benchmark dataset (the message lists them), or two datasets of one name.
    """
    known = {d.name: d for d in BENCHMARK_DATASETS}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ConfigError(f"unknown benchmark dataset(s) {', '.join(map(repr, unknown))}; choose from "
                          f"{', '.join(known)}")
    for name in names:
        get_dataset(known[name].builtin or name)  # registered (a catalog entry without its loader is a bug)
    if names and not catalog:
        raise ConfigError("--no-catalog runs the --add datasets only; leave out --dataset")
    chosen = [known[n] for n in names] if names else list(BENCHMARK_DATASETS) if catalog else []
    chosen += [plain_dataset(folder) for folder in added]
    if not chosen:
        raise ConfigError("no dataset to run: --no-catalog needs at least one --add FOLDER")
    seen = [d.name for d in chosen]
    repeated = sorted({n for n in seen if seen.count(n) > 1})
    if repeated:
        raise ConfigError(f"benchmark dataset(s) named twice: {', '.join(repeated)}")
    return chosen
