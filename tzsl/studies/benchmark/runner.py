"""Run the benchmark: every registered method on every benchmark dataset's standard splits, through the one engine.

Each dataset is one zero-shot study (``study = "zero-shot"``): :func:`dataset_experiment` writes its
experiment file into the benchmark's folder (``experiments/<dataset>.toml``, runnable alone with
``tzsl run``) with the dataset's standard split file of the run's purpose
(:mod:`tzsl.studies.benchmark.splits`; a lab's added dataset gets its splits drawn by the same
recipe), and :func:`run_benchmark` runs each through :func:`tzsl.studies.engine.run_experiment`,
so the study cache restores a dataset whose settings, code and data did not change and the fit
store serves the fits another study already made. A dataset that fails is recorded and the others
go on; a method that fails on a split leaves NaN in that split's row (the study's own rule).

What is collected (:func:`collect_scores`), one row per (dataset, method, split):
``per_class_accuracy`` (the primary metric: the mean over the split's unseen classes of the share of
each class's trials recognised), ``trial_accuracy`` and ``chance`` (1 / unseen classes). GZSL's
harmonic mean of seen and unseen per-class accuracy (:func:`collect_gzsl`) comes from the studies'
``gzsl.csv`` for the methods GZSL runs (``[gzsl] methods``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from tzsl._io import atomic_write_bytes, ensure_folder
from tzsl._toml import toml_text
from tzsl.evaluation import write_splits_csv
from tzsl.exceptions import ConfigError, PartialRunError, TzslError, first_line
from tzsl.studies.benchmark.catalog import BenchmarkDataset
from tzsl.studies.benchmark.splits import SEED, SPLITS_VERSION, read_standard_splits, standard_splits

__all__ = ["BENCHMARK_DETECTORS", "DEFAULTS_DETECTORS", "DatasetRun", "asked_detectors", "benchmark_methods",
           "collect_gzsl", "collect_scores", "dataset_experiment", "detector_entries", "run_benchmark"]

#: Sub-folders of a benchmark's folder: the experiment files, the split files they read, the studies' results.
EXPERIMENTS, SPLITS, DATASETS = "experiments", "splits", "datasets"


#: The DAP detector families the benchmark runs beside the study's own (:data:`~tzsl.models.detectors.STUDY_DETECTOR`):
#: the DAP paper's ``rbf-svm`` (also the registered ``ensemble``'s member, so its fits are the ensemble's, read
#: back from the fit store). The tuned linear families (``logistic``, ``linear-svm``, ``robust-logistic``) lost to
#: ``logistic-c1`` on PHAC-2's detector benchmark (:data:`tzsl.models.INHERITED_CHOICES`, ``study-detector``) and
#: cost one to three RBF-SVM banks a split on the larger datasets; ``tzsl benchmark --detector NAME`` adds any of
#: them.
BENCHMARK_DETECTORS: tuple[str, ...] = ("rbf-svm",)
#: The detector families a run that chooses the defaults (``tzsl benchmark --defaults``) adds: ``auto``, the
#: per-dataset choice made on a user's training objects, which a default chosen across datasets is compared with
#: (``defaults.csv``). It is not a candidate for a default, and it costs two to three RBF-SVM banks a split (a bank
#: per candidate family and pseudo-unseen fold), more than every registered method together on the largest
#: datasets, so the benchmark itself (``make benchmark``) does not run it.
DEFAULTS_DETECTORS: tuple[str, ...] = ("auto",)


def benchmark_methods(detectors: Sequence[str] = (), *, defaults: bool = False) -> tuple[str, list[dict]]:
    """The study detector and the ``[methods] compare`` entries of the benchmark: every registered method.

    The study's own DAP uses :data:`~tzsl.models.detectors.STUDY_DETECTOR` (the generic default's
    detector); every registered feature method is compared beside it, and the registry's ``dap`` once
    per detector of :data:`BENCHMARK_DETECTORS`, of :data:`DEFAULTS_DETECTORS` (when ``defaults``) and of
    ``detectors`` (the detector is an axis of the benchmark: the default's detector is chosen among them).

    Parameters
    ----------
    detectors : sequence of str
        More detector families (:data:`~tzsl.models.detectors.DETECTORS`) to run DAP with.
    defaults : bool
        The run chooses the defaults across datasets (``tzsl benchmark --defaults``): add
        :data:`DEFAULTS_DETECTORS`.

    Raises
    ------
    ConfigError
        An unknown detector family.
    """
    from tzsl.models.detectors import STUDY_DETECTOR  # noqa: PLC0415
    from tzsl.studies.config import every_feature_method  # noqa: PLC0415

    return STUDY_DETECTOR, [*every_feature_method(),
                            *detector_entries((*BENCHMARK_DETECTORS, *asked_detectors(detectors, defaults=defaults)))]


def asked_detectors(detectors: Sequence[str], *, defaults: bool) -> tuple[str, ...]:
    """The detector families a run adds to DAP: :data:`DEFAULTS_DETECTORS` when it chooses the defaults
    (``tzsl benchmark --defaults``), then ``detectors`` (``--detector``)."""
    return (*DEFAULTS_DETECTORS, *detectors) if defaults else tuple(detectors)


def detector_entries(detectors: Sequence[str]) -> list[dict]:
    """``[methods] compare`` entries of the registry's ``dap`` with each of ``detectors`` (once each), except the
    study's own detector (its DAP is the study's).

    Raises
    ------
    ConfigError
        An unknown detector family.
    """
    from tzsl.models import DAP_METHOD  # noqa: PLC0415
    from tzsl.models.detectors import DETECTORS, STUDY_DETECTOR  # noqa: PLC0415

    unknown = [d for d in detectors if d not in DETECTORS]
    if unknown:
        raise ConfigError(f"unknown detector {unknown[0]!r}; choose from {', '.join(DETECTORS)}")
    return [{"name": DAP_METHOD, "detector": d} for d in dict.fromkeys(detectors) if d != STUDY_DETECTOR]


def dataset_experiment(dataset: BenchmarkDataset, folder: str | os.PathLike, purpose: str = "confirm", *,
                       methods: Sequence[dict] | None = None, n_jobs: int = 1,
                       data_dir: str | os.PathLike | None = None, max_splits: int | None = None) -> Path:
    """Write the experiment file of ``dataset``'s study and its split file into the benchmark ``folder``.

    Parameters
    ----------
    dataset : BenchmarkDataset
    folder : path-like
        The benchmark's folder.
    purpose : {"select", "confirm"}
        Whose standard splits run: the selection splits (to choose) or the confirmation ones (to report).
    methods : sequence of dict, optional
        ``[methods] compare`` entries (default: :func:`benchmark_methods`).
    n_jobs : int
        ``[compute] n_jobs``.
    data_dir : path-like, optional
        The data home (``[dataset] data_dir``).
    max_splits : int, optional
        Run only the first ``max_splits`` standard splits (a quick look, not the benchmark's numbers).

    Returns
    -------
    Path
        ``<folder>/experiments/<dataset>.toml``.
    """
    folder = Path(folder).resolve()
    table = dataset.object_attributes(data_dir)
    if dataset.standard:
        splits = read_standard_splits(dataset.name, table, purpose)
    else:  # a lab's dataset: the same recipe, drawn on its table (recorded in the benchmark's manifest)
        splits = [s for s in standard_splits(table) if s.name.startswith(f"{purpose}-")]
    split_file = _write_if_changed(splits[:max_splits],
                                   ensure_folder(folder / SPLITS) / f"{dataset.name}.{purpose}.csv")
    detector, default_methods = benchmark_methods()
    compare = list(default_methods if methods is None else methods)
    source = {**dataset.dataset_table(), **({} if data_dir is None else {"data_dir": str(Path(data_dir).resolve())})}
    tables = {
        "dataset": source,
        "splits": {"kinds": ["file"], "file": str(split_file), "purpose": purpose, "seed": SEED},
        "methods": {"compare": compare, "sweep": False},
        "svm": {"detector": detector},
        "compute": {"n_jobs": n_jobs},
        "output": {"folder": str(folder / DATASETS / dataset.name)},
    }
    text = toml_text({"study": "zero-shot",
                      "description": f"tzsl benchmark: {dataset.name}, standard splits {SPLITS_VERSION} ({purpose})",
                      **tables})
    path = ensure_folder(folder / EXPERIMENTS) / f"{dataset.name}.toml"
    atomic_write_bytes(path, text.encode("utf-8"))
    return path


def _write_if_changed(splits: list, path: Path) -> Path:
    """Write the split file, leaving an identical one untouched: the study cache keys a split file by its size and
    modification time, so a rerun of the same splits is restored, not fitted again."""
    fresh = write_splits_csv(splits, path.with_name(f".{path.name}.new"))
    if path.is_file() and path.read_bytes() == fresh.read_bytes():
        fresh.unlink()
    else:
        fresh.replace(path)
    return path


@dataclass
class DatasetRun:
    """One dataset's study in a benchmark run.

    Attributes
    ----------
    dataset : str
    results : Path
        Its results folder.
    status : {"done", "partial", "failed"}
        ``partial``: some (split, method) fits failed (NaN rows, reasons in ``failures``); ``failed``: the
        study did not complete (``failures`` holds the one line why).
    restored : bool
        Whether the study cache restored it.
    failures : list of str
    """

    dataset: str
    results: Path
    status: str = "done"
    restored: bool = False
    failures: list[str] = field(default_factory=list)


def run_benchmark(datasets: Sequence[BenchmarkDataset], folder: str | os.PathLike, purpose: str = "confirm", *,
                  methods: Sequence[dict] | None = None, n_jobs: int = 1, data_dir: str | os.PathLike | None = None,
                  max_splits: int | None = None, echo: Callable[[str], None] | None = None) -> list[DatasetRun]:
    """Run every dataset's study into ``folder`` (their experiment files, split files and results).

    A dataset whose study stops (missing data, a split that cannot be read) is recorded as failed with
    its one line and the others go on.
    """
    from tzsl.studies.engine import run_experiment  # noqa: PLC0415

    say = echo or (lambda _line: None)
    runs = []
    for dataset in datasets:
        out = Path(folder).resolve() / DATASETS / dataset.name
        run = DatasetRun(dataset.name, out)
        try:
            experiment = dataset_experiment(dataset, folder, purpose, methods=methods, n_jobs=n_jobs,
                                            data_dir=data_dir, max_splits=max_splits)
            try:
                _, done = run_experiment(experiment, force=True)
            except PartialRunError as exc:
                run.status, run.failures = "partial", list(exc.failures)
                done = exc.run  # type: ignore[attr-defined]  # set by run_experiment; undeclared
            run.restored = bool(done.record.get("study_cache", {}).get("restored", False))
        except TzslError as exc:
            run.status, run.failures = "failed", [first_line(exc)]
        runs.append(run)
        how = "restored from the study cache" if run.restored else run.status
        say(f"{dataset.name}: {how}" + (f" ({run.failures[0]})" if run.status == "failed" else ""))
    return runs


def _read(path: Path) -> pd.DataFrame:
    """A study's table, split labels as written ("01", not 1)."""
    if not path.is_file():
        raise ConfigError(f"{path}: missing; run the benchmark again")
    return pd.read_csv(path, dtype={"split": str})


def collect_scores(runs: Sequence[DatasetRun]) -> pd.DataFrame:
    """One row per (dataset, method, split) of the completed studies.

    Returns
    -------
    DataFrame
        Columns ``dataset``, ``method``, ``split``, ``per_class_accuracy`` (the mean over the split's
        unseen classes of each class's share of trials recognised), ``trial_accuracy`` and ``chance``
        (1 / the split's unseen classes), in [0, 1]; NaN where a method failed on a split.
    """
    frames = []
    for run in runs:
        if run.status == "failed":
            continue
        classes = _read(run.results / "class_accuracy.csv")
        per_class = (classes.groupby(["method", "split"], sort=False)["accuracy"].mean()
                     .rename("per_class_accuracy").reset_index())
        per_split = _read(run.results / "methods_per_split.csv")
        per_split = per_split[~per_split["split"].astype(str).isin(["mean", "std"])]
        method_columns = [c for c in per_split.columns
                          if c not in {"split", "split_kind", "purpose", "chance", "error"}]
        trial = per_split.melt(id_vars=["split", "chance"], value_vars=method_columns, var_name="method",
                               value_name="trial_accuracy")
        merged = trial.merge(per_class, on=["method", "split"], how="left")
        merged.insert(0, "dataset", run.dataset)
        frames.append(merged[["dataset", "method", "split", "per_class_accuracy", "trial_accuracy", "chance"]])
    if not frames:
        raise ConfigError("no dataset of the benchmark completed; see the lines above")
    return pd.concat(frames, ignore_index=True)


def collect_gzsl(runs: Sequence[DatasetRun]) -> pd.DataFrame:
    """GZSL per (dataset, method, split): ``seen``, ``unseen`` and their ``harmonic`` mean (calibrated stacking)."""
    frames = []
    for run in runs:
        path = run.results / "gzsl.csv"
        if run.status == "failed" or not path.is_file():
            continue
        gzsl = _read(path)
        if "calibrated" in gzsl.columns:
            gzsl = gzsl[gzsl["calibrated"].astype(str) == "True"]
        gzsl = gzsl[~gzsl["split"].astype(str).isin(["mean", "std"])]
        frames.append(gzsl.assign(dataset=run.dataset)[
            ["dataset", "method", "split", "seen", "unseen", "harmonic"]])
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(
        columns=["dataset", "method", "split", "seen", "unseen", "harmonic"])
