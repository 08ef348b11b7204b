"""``tzsl reproduce-tables`` and ``tzsl evidence``: two lists of built-in studies, one engine loop.

Not a second code path: each study is the built-in experiment file of the same name
(``tzsl/studies/builtin/``), run by :func:`tzsl.studies.engine.execute_study` exactly as
``tzsl run NAME`` runs it, into one results folder with one ``manifest.json``
(:func:`run_studies`, which both commands call with their list).

``reproduce-tables`` (:data:`REPRODUCE_STUDIES`, ``make reproduce-tables``): what the two papers
report, with our intervals, chance, baselines and controls beside each number, and nothing else:

* ``phac2-dap``: ``table1_fusion.csv``, ``table2_priors.csv``, ``table3_challenging.csv``,
  ``multilabel.csv``, ``attribute_accuracy.csv``, ``attribute_sweep.csv``, ``dap_fusion_prior.csv``
  and the figures ``attribute_accuracy.png``, ``object_map.png``, ``attribute_sweep.png``; every split
  scored in ``splits.csv`` (readable by ``--splits``);
* ``fabric``: ``fabric_table1.csv``, ``fabric_runs.csv``, ``fabric_lambda.png``,
  ``fabric_method_comparison.csv`` (the lambda grid and ESZSL paired on the same samples);
* ``hand-simulated``: ``hand_table5.csv`` and its curves, on **simulated** grasps (the
  Shadow-hand data of the paper are not public).

``evidence`` (:data:`EVIDENCE_STUDIES`, ``make evidence``): what goes beyond the papers:

* ``phac2-evidence``: every registered method beside DAP on the random and challenging PHAC-2
  splits (``phac2_methods.csv``, ``phac2_method_comparison.csv`` with ECE and Brier score,
  ``phac2_reliability.csv`` / ``.png``) and GZSL (``gzsl.csv``);
* ``fabric-evidence``, ``hand-evidence``: the generic zero-shot study on the preset's dataset
  (``fabric-depth_*``, ``hand-simulated_*``), every registry method beside the paper's protocol,
  the fabric group partitions (``fabric_partitions.csv``);
* ``active-touch``: ``active_touch.csv``, ``active_touch_curves.csv``, ``active_touch_stop.csv``
  and ``active_touch.png`` (choosing the next EP on PHAC-2 vs every fixed and a random order);
* ``phac2-headlines``: 50 random and every challenging PHAC-2 split, seed refits (``headlines_*``);
* ``method_comparison.csv``: the studies' ``*_method_comparison.csv`` stacked (every registered
  method x study: accuracy with its interval, the paper's number, fit time, paired difference to
  the study's paper method), with a row saying why for each method a study does not run.

The other built-in studies (``phac2-gzsl``, ``fabric-deep``) run with ``tzsl run NAME``.

On a machine without the data, :func:`run_studies` first fetches the registered files the studies
read that are missing from their data home (:func:`fetch_study_data`; ``fetch=False``, the
command's ``--no-fetch``, turns it off).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tzsl._profile import profiling
from tzsl._warnings import recorded_warnings
from tzsl.exceptions import PartialRunError

if TYPE_CHECKING:  # the module stays light: the command line reads its lists for --help
    from tzsl.studies.outputs.results_folder import ResultsDir
    from tzsl.studies.outputs.study_run import StudyRun

__all__ = ["EVIDENCE_STUDIES", "REPRODUCE_STUDIES", "STUDY_LISTS", "evidence", "fetch_study_data",
           "reproduce_experiments", "reproduce_tables", "run_studies"]

#: The manifest of ``reproduce-tables``: the papers' built-in studies, run in this order.
REPRODUCE_STUDIES: tuple[str, ...] = ("phac2-dap", "fabric", "hand-simulated")
#: The manifest of ``evidence``: the built-in studies beyond the papers, run in this order.
EVIDENCE_STUDIES: tuple[str, ...] = ("phac2-evidence", "fabric-evidence", "hand-evidence", "active-touch",
                                     "phac2-headlines")
#: Command -> (its default studies, whether it stacks their method comparisons into ``method_comparison.csv``).
STUDY_LISTS: dict[str, tuple[tuple[str, ...], bool]] = {"reproduce-tables": (REPRODUCE_STUDIES, False),
                                                        "evidence": (EVIDENCE_STUDIES, True)}


def reproduce_experiments(studies=REPRODUCE_STUDIES, **overrides: Any) -> list:
    """The checked experiments of ``studies`` with the shared overrides (``n_jobs``, ``seed``, ...) applied
    to each study that has the key."""
    from tzsl.studies.config import load_experiment  # noqa: PLC0415

    return [load_experiment(name, options=overrides, strict=False) for name in studies]


def fetch_study_data(experiments: list, names: tuple[str, ...], echo: Callable[[str], None] | None = None,
                     progress: bool = True) -> None:
    """Fetch the registered data files the studies read that are missing from their data home (first use).

    What a study reads is decided from its config: its ``[dataset] builtin`` (resolved by
    :func:`tzsl.datasets.builtin_data_files`) in its ``[dataset] data_dir`` (else the data home).
    A study on the user's own files reads none. Nothing is fetched, and the network is not used,
    when every file is there; otherwise :func:`tzsl.datasets.fetch_missing` prints one line and
    fetches them as ``tzsl data fetch`` does.

    Parameters
    ----------
    experiments : list of Experiment
        The checked experiments.
    names : tuple of str
        Their names (built-in names or files), in the same order, for the lines printed.
    echo : callable, optional
        Receives the lines.
    progress : bool
        Progress bars while files download.

    Raises
    ------
    DataMissingError, ChecksumError
        A file that cannot be fetched (one line; see :func:`tzsl.datasets.fetch_missing`).
    """
    from tzsl.datasets import builtin_data_files, fetch_missing, get_data_home  # noqa: PLC0415

    wanted: dict[Path, tuple[set[str], list[str]]] = {}
    for name, exp in zip(names, experiments, strict=True):
        dataset = getattr(exp.config, "dataset", None)  # a registered study may read no dataset
        builtin = getattr(dataset, "builtin", None)
        files = builtin_data_files(builtin) if builtin else []
        if files:
            home = get_data_home(exp.resolve(getattr(dataset, "data_dir", None)))
            paths, readers = wanted.setdefault(home, (set(), []))
            paths.update(files)
            readers.append(name)
    for home, (paths, readers) in wanted.items():
        fetch_missing(sorted(paths), home, needed_by=", ".join(readers), progress=progress, echo=echo)


def run_studies(
    command: str,
    out: str | Path,
    force: bool = False,
    echo: Callable[[str], None] | None = None,
    studies: tuple[str, ...] | None = None,
    fetch: bool = True,
    *,
    study_echo: Callable[[str], None] | None = None,
    on_study: Callable[[str, StudyRun], None] | None = None,
    **overrides: Any,
) -> ResultsDir:
    """Run the studies of ``command`` (a key of :data:`STUDY_LISTS`) into ``out``; returns the results folder.

    Parameters
    ----------
    command : {"reproduce-tables", "evidence"}
        Names the list (recorded in the manifest as ``study_list``, which the README's blocks name)
        and says whether the studies' method comparisons are stacked into ``method_comparison.csv``.
    out : str or Path
        Results folder; existing results are refused before any study unless ``force``.
    studies : tuple of str or None
        Built-in names or experiment files (default: the command's list).
    fetch : bool
        Before the first study, fetch the registered data files the studies read that are missing
        (:func:`fetch_study_data`); False: a missing file stops its study with the usual error.
    study_echo : callable or None
        Where each study's own lines go (its notes and tables); default ``echo``.
    on_study : callable or None
        ``on_study(name, run)`` after each study (the command line prints its summary lines).
    overrides
        ``n_jobs``, ``seed``, ``backend``, ``scheduler``, ``progress``, ``data_dir`` (each applied to
        the studies that have the key).
    """
    from tzsl.studies.config import get_study  # noqa: PLC0415
    from tzsl.studies.engine import check_experiment, execute_study, manifest_record  # noqa: PLC0415
    from tzsl.studies.outputs.results_folder import ResultsDir  # noqa: PLC0415

    default, stack = STUDY_LISTS[command]
    studies = default if studies is None else tuple(studies)
    say = echo or (lambda _msg: None)
    experiments = reproduce_experiments(studies, **overrides)
    results = ResultsDir(out, force=force, staging=True)
    for exp in experiments:
        check_experiment(exp)
        outputs = get_study(exp.study).hook("outputs")
        if outputs is not None:
            results.check_free(outputs(exp.config))
    from tzsl.models import DAP_METHOD  # noqa: PLC0415 (the registry, read when a study list runs)
    from tzsl.studies.comparison.method_runs import COMPARISON_FILE, FEW_CLASSES, combine_comparisons  # noqa: PLC0415

    results.check_free(["manifest.json"] + ([COMPARISON_FILE] if stack else []))
    if fetch:
        fetch_study_data(experiments, studies, echo, progress=overrides.get("progress") is not False)
    records, data_files, timings, tables, done_tables, warned, profiles = {}, [], {}, [], [], {}, []
    failures: list[str] = []
    for name, exp in zip(studies, experiments, strict=True):
        say(f"\n== {name} ({exp.source}) ==")
        start = time.perf_counter()
        with recorded_warnings() as shown, profiling(name) as profile:
            done = execute_study(exp, results, echo, study_echo)
        warned[name] = shown.lines
        done.record["profile"] = profile.rows()
        profiles += done.record["profile"]
        timings[f"{name}_s"] = time.perf_counter() - start
        records[name] = manifest_record(exp, done)
        data_files += list(done.data_files)
        tables += sorted(done.tables)
        failures += [f"{name}: {line}" for line in done.failures]
        done_tables += [t for key, t in done.tables.items() if key.endswith("method_comparison")]
        if on_study is not None:
            on_study(name, done)
    if stack and done_tables:
        dap = {name: FEW_CLASSES for name in (DAP_METHOD, "multilabel-dap")}
        results.write_csv(COMPARISON_FILE, combine_comparisons(done_tables, {"fabric": dap, "hand": dap}))
        tables.append(COMPARISON_FILE[: -len(".csv")])
    results.write_manifest({"studies": records}, data_files=data_files,
                           extra={"study_list": command, "timings_s": timings, "tables": tables,
                                  "reproduce_studies": list(studies), "failures": failures, "warnings": warned,
                                  "profile": profiles})
    results.commit()
    if failures:
        raise PartialRunError(results.root, failures)
    return results


def reproduce_tables(out: str | Path, force: bool = False, echo: Callable[[str], None] | None = None,
                     studies: tuple[str, ...] = REPRODUCE_STUDIES, **overrides: Any) -> ResultsDir:
    """``tzsl reproduce-tables``: the papers' studies into ``out`` (:func:`run_studies`)."""
    return run_studies("reproduce-tables", out, force=force, echo=echo, studies=studies, **overrides)


def evidence(out: str | Path, force: bool = False, echo: Callable[[str], None] | None = None,
             studies: tuple[str, ...] = EVIDENCE_STUDIES, **overrides: Any) -> ResultsDir:
    """``tzsl evidence``: the studies beyond the papers into ``out``, with ``method_comparison.csv``
    (:func:`run_studies`)."""
    return run_studies("evidence", out, force=force, echo=echo, studies=studies, **overrides)
