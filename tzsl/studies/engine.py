"""The one engine: run a checked experiment (:mod:`tzsl.studies.config`) into a results folder.

``tzsl run FILE|NAME``, ``tzsl reproduce-tables``, ``tzsl evaluate``, ``evaluate-fabric``,
``evaluate-hand`` and :func:`tzsl.run` all end in :func:`execute_study`, which finds the study's
runner in the study registry (:func:`tzsl.studies.config.get_study`); the engine names no study.
:func:`check_experiment` finds what a run would fail on (missing paths, a missing split
file, an unreachable Dask scheduler, too many CV folds) before any fit.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal
from urllib.parse import urlparse

import pandas as pd

from tzsl._profile import profiling
from tzsl._warnings import recorded_warnings
from tzsl.exceptions import ConfigError, PartialRunError, problems_error
from tzsl.studies.config import DATASET_PATHS, Experiment, get_study, load_experiment, to_toml
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.outputs.study_cache import run_cached
from tzsl.studies.outputs.study_run import StudyRun

# --------------------------------------------------------------------------- checks before any fit


def _check_scheduler(address: str, timeout: float, source: str) -> None:
    """Refuse, within ``timeout`` seconds, a Dask scheduler that does not answer (instead of a long hang)."""
    url = urlparse(address if "://" in address else f"tcp://{address}")
    try:
        with socket.create_connection((url.hostname, url.port or 8786), timeout=timeout):
            pass
    except (OSError, ValueError) as exc:
        _unreachable(source, address, timeout, getattr(exc, "strerror", None) or str(exc) or type(exc).__name__)
    try:
        from distributed import Client  # noqa: PLC0415 - the Dask handshake, not only a TCP port
    except ImportError:
        raise ConfigError(
            f"{source}: compute.backend: 'dask' needs dask.distributed: pip install 'tzsl[dask]'"
        ) from None
    try:
        Client(address, timeout=f"{timeout}s", set_as_default=False).close()
    except Exception as exc:  # noqa: BLE001 - whatever answered there is not a working Dask scheduler
        _unreachable(source, address, timeout, f"no Dask handshake: {type(exc).__name__}")


def _unreachable(source: str, address: str, timeout: float, reason: str) -> None:
    raise ConfigError(f"{source}: compute.scheduler: cannot reach the Dask scheduler {address} within {timeout:g} s "
                      f"({reason.splitlines()[0]}); start it or raise compute.connect_timeout")


def _path_problems(exp: Experiment) -> list[str]:
    c = exp.config
    wanted: list[tuple[str, str | None, Literal["file", "folder"]]] = []
    ds = getattr(c, "dataset", None)  # a registered study may read no dataset
    for key, kind in DATASET_PATHS.items():
        wanted.append((f"dataset.{key}", getattr(ds, key, None), kind))
    if "file" in getattr(getattr(c, "splits", None), "kinds", ()):
        # a catalog dataset's own splits.csv is checked once its folder is converted (zero_shot.runner)
        plain = getattr(ds, "plain", None)
        split_file = c.splits.file if c.splits.file is not None else (
            None if plain is None else os.path.join(plain, "splits.csv"))
        wanted.append(("splits.file" if c.splits.file else "splits.kinds", split_file, "file"))
    problems = []
    for key, value, kind in wanted:
        if value is None:
            continue
        path = exp.resolve(value)
        ok = path.is_file() if kind == "file" else path.is_dir()
        if not ok:
            problems.append(f"{exp.source}: {key}: {kind} {path} not found")
    return problems


def check_experiment(exp: Experiment) -> None:
    """Raise a ConfigError listing what a run of ``exp`` would fail on, before any fit.

    Paths (dataset folders and files, the split file of ``kinds = ["file"]``) must exist; a
    Dask scheduler must answer within ``compute.connect_timeout`` seconds.
    """
    problems = _path_problems(exp)
    error = problems_error(problems, exp.source)
    if error is not None:
        raise error
    compute = exp.config.compute
    if getattr(compute, "backend", None) == "dask" and compute.scheduler is not None:
        _check_scheduler(compute.scheduler, compute.connect_timeout, exp.source)
    kind = get_study(exp.study, exp.source)
    missing = [name for name in kind.requires if importlib.util.find_spec(name) is None]
    if missing:
        raise ConfigError(f"{exp.source}: study {exp.study} needs {', '.join(missing)}: "
                          f"pip install 'tzsl[{kind.extra}]'")


# --------------------------------------------------------------------------- running


def execute_study(exp: Experiment, results: ResultsDir, echo: Callable[[str], None] | None = None,
                  study_echo: Callable[[str], None] | None = None) -> StudyRun:
    """Run the study of ``exp`` into ``results`` (no manifest.json; see :func:`run_experiment`).

    ``echo`` receives the run's own lines (the study cache's notes); ``study_echo`` the study's (its
    notes, tables and per-split lines; default ``echo``). What is printed never changes what is written.

    A study run before with the same settings, code and data is restored from the study cache
    (:mod:`tzsl.studies.outputs.study_cache`; on unless ``TZSL_STUDY_CACHE=0`` or ``[compute] cache = false``).
    """
    check_experiment(exp)
    runner = get_study(exp.study).hook("runner")
    return run_cached(exp, results, lambda say: runner(exp, results, say), echo or (lambda _msg: None),
                      study_echo=study_echo)


def results_folder(exp: Experiment, force: bool) -> ResultsDir:
    """The (staged) results folder of ``exp``: the study's own (its ``results`` hook), else a plain one.

    Files are staged in the output folder's :data:`~tzsl.studies.outputs.results_folder.STAGING_FOLDER`
    and moved into place by :meth:`ResultsDir.commit` when the run completes, so a crashed run
    never blocks its rerun.
    """
    opener = get_study(exp.study).hook("results")
    if opener is not None:
        return opener(exp, force)
    results = ResultsDir(Path(exp.config.output.folder), force=force, staging=True)
    results.check_free(["manifest.json"])
    return results


def manifest_record(exp: Experiment, run: StudyRun) -> dict[str, Any]:
    """What a manifest records of one study: the source, the resolved TOML and the study's settings."""
    return {"study": exp.study, "experiment": exp.source, "settings": exp.config.model_dump(),
            "resolved_toml": to_toml(exp.config), **run.record}


def run_experiment(
    experiment: str | os.PathLike | Experiment,
    force: bool = False,
    echo: Callable[[str], None] | None = None,
    *,
    study_echo: Callable[[str], None] | None = None,
    **overrides: Any,
) -> tuple[ResultsDir, StudyRun]:
    """Run an experiment file, a built-in study (by name) or a checked :class:`Experiment`.

    ``echo`` receives the run's lines; ``study_echo`` the study's own (its notes and tables; default
    ``echo``: ``tzsl run`` without ``--verbose`` passes one that keeps the notes only).

    ``overrides``: ``out``, ``n_jobs``, ``seed``, ``backend``, ``scheduler``, ``progress``,
    ``data_dir`` (see :data:`tzsl.studies.config.OPTION_KEYS`; None = as in the file). Writes the study's
    tables and ``manifest.json`` (resolved settings, the file's text and checksum, data checksums,
    failures, warnings, and ``config.profile``: wall and CPU seconds per stage, :mod:`tzsl._profile`).

    Raises
    ------
    PartialRunError
        After everything is written, when some (split, method) fits failed (exit code 1).
    """
    if isinstance(experiment, Experiment):
        if any(v is not None for v in overrides.values()):
            raise ConfigError("overrides need an experiment file or name, not a checked Experiment")
        exp = experiment
    else:
        exp = load_experiment(experiment, options=overrides)
    say = echo or (lambda _msg: None)
    results = results_folder(exp, force)
    say(f"{exp.source}: study {exp.study} -> {results.final_root}")
    with recorded_warnings() as shown, profiling(exp.study) as profile:  # warnings and time per stage
        run = execute_study(exp, results, echo, study_echo)  # checks the experiment (check_experiment) before any fit
    run.record["profile"] = profile.rows()
    failures = run.failures  # one scan of the tables' error columns
    results.write_manifest(manifest_record(exp, run), data_files=run.data_files,
                           extra={"experiment_sha256": hashlib.sha256(exp.text.encode()).hexdigest(),
                                  "experiment_toml": exp.text, "description": exp.config.description,
                                  "tables": sorted(run.tables), "failures": failures, "warnings": shown.lines})
    results.commit()
    if failures:
        error = PartialRunError(results.root, failures)
        error.results, error.run = results, run  # type: ignore[attr-defined]  # carried to run(); undeclared
        raise error
    return results, run


def run(config_or_path: str | os.PathLike | Experiment, *, table: str | None = None, force: bool = False,
        echo: Callable[[str], None] | None = None, **overrides: Any) -> pd.DataFrame:
    """Run a study from Python and return its main table (notebooks).

    Parameters
    ----------
    config_or_path : path, built-in name or Experiment
        An experiment file, a built-in study (``"phac2-dap"``, ``"fabric"``, ``"hand-simulated"``,
        ...) or :func:`tzsl.studies.config.load_experiment`'s result.
    table : str, optional
        Which table to return; default the study's main table (its registered ``main_table``: Table 1 of
        phac2-dap and fabric, the deep study's table, the hand study's Table 5).
    force : bool
        Replace existing results.
    **overrides
        ``out``, ``n_jobs``, ``seed``, ``backend``, ``scheduler``, ``progress``, ``data_dir``.

    Returns
    -------
    DataFrame
        The table, exactly as written to its CSV; ``.attrs["results_dir"]`` is the results folder
        and ``.attrs["tables"]`` the names of every table written.
    """
    try:
        results, done = run_experiment(config_or_path, force=force, echo=echo, **overrides)
    except PartialRunError as exc:  # the tables hold NaN and the reasons: return them, loudly
        import warnings  # noqa: PLC0415

        warnings.warn(str(exc), RuntimeWarning, stacklevel=2)
        results, done = exc.results, exc.run  # type: ignore[attr-defined]  # set by run_experiment; undeclared
    name = table or get_study(done.record["study_kind"]).main_table
    if name not in done.tables:
        raise ConfigError(f"no table {name!r}; this run wrote {sorted(done.tables)}")
    out = done.tables[name].copy()
    out.attrs = {"results_dir": str(results.root), "tables": sorted(done.tables)}
    return out
