"""``tzsl benchmark``: run the datasets' studies, then write the tables and figures across them and a manifest.

The folder a benchmark writes (``--out``, default ``results/benchmark``):

* ``scores.csv``: one row per (dataset, method, split): per-class mean accuracy (primary), trial
  accuracy, chance (:func:`~tzsl.studies.benchmark.runner.collect_scores`);
* ``datasets.csv``: per dataset and method, the mean per-class accuracy over the splits with its 95%
  interval, chance and the gain over chance; ``gzsl.csv`` the GZSL harmonic mean beside;
* ``ranks.csv``: the methods' mean rank and mean gain over chance across datasets; ``friedman.csv``:
  the Friedman test and the Nemenyi critical difference; ``critical_difference.png`` (Demsar 2006);
* ``meta_analysis.csv`` / ``meta_analysis.png``: every pair of methods' paired difference on shared
  splits, meta-analysed across datasets (random effects);
* ``experiments/``, ``splits/`` and ``datasets/``: each dataset's experiment file, split file and study;
* ``defaults.csv`` (with ``--defaults SELECT_FOLDER``): the defaults chosen with each dataset left out,
  their regret against the dataset's hindsight best, beside ``detector="auto"`` (which such a run adds to the
  methods, :data:`~tzsl.studies.benchmark.runner.DEFAULTS_DETECTORS`) and the shipped default;
* ``manifest.json``: the datasets, their status and failures, the split files' hashes, the methods.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import pandas as pd

from tzsl.exceptions import ConfigError, PartialRunError
from tzsl.studies.benchmark.catalog import BENCHMARK_DATASETS, benchmark_datasets
from tzsl.studies.benchmark.defaults import (
    DEFAULTS_FILE,
    choose_on_every_dataset,
    hindsight_single_method,
    leave_one_dataset_out,
    mean_regrets,
)
from tzsl.studies.benchmark.runner import (
    DatasetRun,
    asked_detectors,
    benchmark_methods,
    collect_gzsl,
    collect_scores,
    detector_entries,
    run_benchmark,
)
from tzsl.studies.benchmark.splits import SPLITS_VERSION, standard_index
from tzsl.studies.benchmark.summary import BENCHMARK_FILES, complete_splits, long_scores, summarise, terminal_lines
from tzsl.studies.outputs.results_folder import ResultsDir

__all__ = ["DEFAULTS_FILE", "list_benchmark", "read_selection", "run_benchmark_command", "write_defaults"]



def list_benchmark() -> list[str]:
    """One line per benchmark dataset: its standard splits (unseen classes, splits per purpose)."""
    index = standard_index()
    lines = [f"standard splits {SPLITS_VERSION} (tzsl/studies/benchmark/splits/{SPLITS_VERSION}):"]
    for d in BENCHMARK_DATASETS:
        entry = index.get(d.name)
        lines.append(f"  {d.name}: " + ("no standard splits" if entry is None else
                                        f"{entry['n_objects']} classes, {entry['n_test']} unseen per split, "
                                        f"{entry['n_select']} selection + {entry['n_confirm']} confirmation "
                                        f"splits, sha256 {entry['sha256'][:12]}"))
    return lines


def _method_entries(methods: Sequence[str], detectors: Sequence[str], defaults: bool) -> list[dict] | None:
    """The ``[methods] compare`` entries of ``--method`` and ``--detector``, with DAP's
    :data:`~tzsl.studies.benchmark.runner.DEFAULTS_DETECTORS` when the run chooses the defaults (None: the
    benchmark's own)."""
    if not methods:
        return benchmark_methods(detectors, defaults=defaults)[1] if detectors or defaults else None
    from tzsl.models import get_method  # noqa: PLC0415

    for name in methods:
        get_method(name)  # an unknown name: one line with the registered ones
    return [{"name": name} for name in methods] + detector_entries(asked_detectors(detectors, defaults=defaults))


def run_benchmark_command(*, datasets: Sequence[str] = (), added: Sequence[str | os.PathLike] = (),
                          catalog: bool = True, methods: Sequence[str] = (),
                          detectors: Sequence[str] = (), purpose: str = "confirm",
                          out: str | os.PathLike, n_jobs: int = 1, data_dir: str | os.PathLike | None = None,
                          force: bool = False, max_splits: int | None = None,
                          defaults_from: str | os.PathLike | None = None,
                          echo: Callable[[str], None] = print) -> list[DatasetRun]:
    """Run the benchmark into ``out`` and write its tables, figures and manifest (``tzsl benchmark``).

    ``methods`` / ``detectors``: run only these registered methods, and DAP with these detector families
    beside (only ``detectors``: the benchmark's methods and these detectors too).
    ``defaults_from``: the folder of a ``--purpose select`` benchmark; the defaults are then chosen on its
    selection scores with each dataset left out and scored on this run's confirmation splits
    (:mod:`tzsl.studies.benchmark.defaults`, ``defaults.csv``), and DAP with ``detector="auto"`` runs beside
    (:data:`~tzsl.studies.benchmark.runner.DEFAULTS_DETECTORS`).

    Raises
    ------
    ConfigError
        ``out`` holds an earlier benchmark and ``force`` is off (checked before any fit); an unknown
        dataset or method; no dataset completed; ``defaults_from`` is not a selection benchmark or
        ``purpose`` is not ``"confirm"`` with it.
    PartialRunError
        After everything is written, when a dataset failed or some (split, method) fits failed.
    """
    if defaults_from is not None and purpose != "confirm":
        raise ConfigError("--defaults scores the defaults on the confirmation splits; drop --purpose select")
    chosen = benchmark_datasets(datasets, added, catalog=catalog)
    entries = _method_entries(methods, detectors, defaults_from is not None)
    results = ResultsDir(Path(out), force=force)
    results.check_free(BENCHMARK_FILES + ((DEFAULTS_FILE,) if defaults_from is not None else ()))
    select = None if defaults_from is None else read_selection(defaults_from)
    echo(f"benchmark: {len(chosen)} dataset(s), standard splits {SPLITS_VERSION} ({purpose}) -> {out}")
    if max_splits is not None:
        echo(f"note: only the first {max_splits} standard splits of each dataset: a quick look, not the benchmark's "
             "numbers")
    runs = run_benchmark(chosen, out, purpose, methods=entries, n_jobs=n_jobs, data_dir=data_dir,
                         max_splits=max_splits, echo=echo)
    scores = collect_scores(runs)
    gzsl = collect_gzsl(runs)
    summary = summarise(scores, gzsl, results)
    for line in terminal_lines(summary):
        echo(line)
    if select is not None:
        for line in write_defaults(select, scores, results):
            echo(line)
    index = standard_index()
    results.write_manifest({"study": "benchmark", "purpose": purpose, "splits_version": SPLITS_VERSION,
                            "max_splits": max_splits,
                            "defaults_from": None if defaults_from is None else str(defaults_from),
                            "methods": entries or "every registered method",
                            "unranked": summary["unranked"],
                            "datasets": [{"name": r.dataset, "status": r.status, "restored": r.restored,
                                          "results": str(r.results), "failures": r.failures,
                                          "standard_splits": index.get(r.dataset)} for r in runs]})
    failures = [_failure_line(r) for r in runs if r.failures]
    n_files = len(results.written)
    echo(f"wrote {n_files} files to {out} (each dataset's study in datasets/); report: tzsl report {out}")
    if failures:
        raise PartialRunError(results.root, failures)
    return runs


#: Characters of a dataset's first failure shown on the terminal (every failure is in its manifest).
FAILURE_CHARS = 160


def _failure_line(run: DatasetRun) -> str:
    """One terminal line per dataset: why it failed, or how many of its fits failed and the first reason."""
    if run.status == "failed":
        return f"{run.dataset}: {run.failures[0]}"
    first = run.failures[0] if len(run.failures[0]) <= FAILURE_CHARS else run.failures[0][:FAILURE_CHARS] + "..."
    return f"{run.dataset}: {len(run.failures)} table row(s) with failed fits (its manifest.json lists them); {first}"


def read_selection(folder: str | os.PathLike) -> pd.DataFrame:
    """The ``scores.csv`` of a ``--purpose select`` benchmark folder (its manifest must say so)."""
    path, manifest = Path(folder) / "scores.csv", Path(folder) / "manifest.json"
    if not path.is_file() or not manifest.is_file():
        raise ConfigError(f"{folder}: no benchmark here; run tzsl benchmark --purpose select --out {folder} first")
    config = json.loads(manifest.read_text(encoding="utf-8")).get("config", {})
    if config.get("purpose") != "select" or config.get("max_splits"):
        raise ConfigError(f"{manifest}: --defaults needs a full benchmark of the selection splits (--purpose select, "
                          f"no --max-splits); this one ran purpose {config.get('purpose')!r}")
    return pd.read_csv(path, dtype={"split": str})


def write_defaults(select: pd.DataFrame, confirm: pd.DataFrame, results: ResultsDir) -> list[str]:
    """Write ``defaults.csv`` (:func:`~tzsl.studies.benchmark.defaults.leave_one_dataset_out`); its terminal lines."""
    from tzsl.models.choices import DEFAULT_METHOD  # noqa: PLC0415

    selection, confirmation = complete_splits(long_scores(select)), complete_splits(long_scores(confirm))
    table = leave_one_dataset_out(selection, confirmation, DEFAULT_METHOD)
    every = choose_on_every_dataset(selection)
    defaults = pd.concat([table, every, hindsight_single_method(confirmation)], ignore_index=True)
    results.write_csv(DEFAULTS_FILE, defaults)
    lines = ["defaults chosen with each dataset left out (mean rank on the others' selection splits), their regret "
             "against each dataset's hindsight best on its confirmation splits:"]
    for choice, m in mean_regrets(defaults).iterrows():
        bound = "-" if m["bound_method"] is None else f"{m['bound_regret']:.3f} ({m['bound_method']})"
        lines.append(f"  {choice}: chose {m['chosen']}; mean regret {m['regret']:.3f} (auto {m['auto_regret']:.3f}, "
                     f"shipped {DEFAULT_METHOD} {m['shipped_regret']:.3f}, chosen on the dataset's own selection "
                     f"splits {m['own_regret']:.3f}) over {m['n_datasets']} datasets; the least any one method "
                     f"reaches, in hindsight: {bound}")
    lines.append("chosen on every dataset's selection splits: " + ", ".join(
        f"{r.choice} {r.chosen}" for r in every.itertuples()) + f" (shipped: {DEFAULT_METHOD})")
    return lines
