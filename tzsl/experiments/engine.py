"""The one engine: run a checked experiment (:mod:`tzsl.experiments.config`) into a results folder.

``tzsl run FILE|NAME``, ``tzsl reproduce-tables``, ``tzsl evaluate``, ``evaluate-fabric``,
``evaluate-hand`` and :func:`tzsl.run` all end in :func:`execute_study`: one function per study
kind turns the resolved settings into the study's own call (:func:`run_dap_study`,
:func:`run_fabric_study`, :func:`run_deep_fabric_study`, :func:`run_hand_study`,
:func:`run_active_touch_study`).
:func:`check_experiment` finds what a run would fail on (missing paths, a missing split
file, an unreachable Dask scheduler, too many CV folds) before any fit.
"""

from __future__ import annotations

import hashlib
import os
import socket
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import pandas as pd

from tzsl.exceptions import ConfigError, PartialRunError
from tzsl.experiments._failures import table_failures
from tzsl.experiments._outputs import ResultsDir
from tzsl.experiments.config import Experiment, load_experiment, to_toml

#: The option names every front-end shares -> the key of the experiment they override.
OVERRIDES: dict[str, str] = {
    "out": "output.folder", "n_jobs": "compute.n_jobs", "seed": "splits.seed", "backend": "compute.backend",
    "scheduler": "compute.scheduler", "progress": "compute.progress", "data_dir": "dataset.data_dir",
}

#: The table :func:`tzsl.run` returns for each study kind.
MAIN_TABLE: dict[str, str] = {"phac2-dap": "table1_fusion", "fabric": "table1", "fabric-deep": "table",
                              "hand": "table5", "active-touch": "active_touch"}


def _has_key(study: str, key: str) -> bool:
    from tzsl.experiments.config import STUDY_MODELS  # noqa: PLC0415

    table, name = key.split(".")
    annotation = STUDY_MODELS[study].model_fields[table].annotation
    return name in getattr(annotation, "model_fields", {})


def override_values(study: str | None, options: Mapping[str, Any], strict: bool = True) -> dict[str, Any]:
    """``{"n_jobs": 2, ...}`` -> ``{"compute.n_jobs": 2, ...}`` (None = not given).

    ``strict``: an option the study has no key for is an error (``tzsl run``); otherwise it is
    skipped (``reproduce-tables`` applies ``--seed`` to the studies that have one).
    """
    values: dict[str, Any] = {}
    for name, value in options.items():
        if value is None:
            continue
        if name not in OVERRIDES:
            raise ConfigError(f"unknown override {name!r} (known: {', '.join(OVERRIDES)})")
        key = OVERRIDES[name]
        if name in ("out", "data_dir"):
            value = os.fspath(Path(value).expanduser().absolute())
        if study is not None and not _has_key(study, key):
            if strict:
                raise ConfigError(f"--{name.replace('_', '-')} does not apply to study {study!r} (no key {key})")
            continue
        values[key] = value
    return values


# --------------------------------------------------------------------------- settings -> study arguments


def _svm_params(svm) -> dict:
    """``[svm]`` -> :class:`~tzsl.models.AttributeSVM` parameters that differ from its defaults."""
    from tzsl.models import AttributeSVM  # noqa: PLC0415

    defaults = AttributeSVM().get_params()
    params: dict[str, Any] = {"cv": None if svm.cv == 0 else svm.cv}
    for key in ("C_range", "gamma_range", "n_C", "n_gamma", "grid", "n_draws", "scoring", "platt_weighting"):
        value = getattr(svm, key)
        params[key] = tuple(float(v) for v in value) if key.endswith("_range") else value
    return {k: v for k, v in params.items() if v != defaults[k]}


def dap_config(exp: Experiment):
    """The :class:`~tzsl.experiments.phac2_dap.DapStudyConfig` of a phac2-dap experiment."""
    from tzsl.experiments.phac2_dap import DapStudyConfig  # noqa: PLC0415

    c = exp.config
    return DapStudyConfig(
        n_splits=c.splits.n_splits, n_test=c.splits.n_test, seed=c.splits.seed,
        random_min_train_positives=c.splits.random_min_train_positives,
        challenging_min_train_positives=c.splits.challenging_min_train_positives,
        undersampling=c.svm.undersampling, svm_params=_svm_params(c.svm), multilabel=c.methods.multilabel,
        sweep_min_attributes=c.methods.sweep_min_attributes, sweep_max_subsets=c.methods.sweep_max_subsets,
        n_jobs=c.compute.n_jobs, backend=c.compute.backend, scheduler=c.compute.scheduler,
        progress=c.compute.progress, cache=c.compute.cache,
    )


def gzsl_config(exp: Experiment):
    """The :class:`~tzsl.experiments.gzsl.GzslConfig` of a phac2-dap experiment's ``[gzsl]``."""
    from tzsl.experiments.gzsl import GzslConfig  # noqa: PLC0415

    g = exp.config.gzsl
    return GzslConfig(holdout_fraction=float(g.holdout_fraction), methods=tuple(g.methods), fusion=g.fusion,
                      prior=g.prior, calibrated_stacking=g.calibrated_stacking, max_draws=g.max_draws)


def fabric_arguments(exp: Experiment) -> dict:
    """Keyword arguments of :func:`tzsl.experiments.fabric.run_fabric_study` (all but ``out``)."""
    c = exp.config
    return {
        "data_dir": exp.resolve(c.dataset.data_dir), "seeds": c.splits.n_seeds, "configs": tuple(c.splits.configs),
        "gelsight_root": exp.resolve(c.dataset.gelsight_root), "attributes": c.dataset.attributes,
        "progress": c.compute.progress, "lams": tuple(c.methods.embedding_lambdas),
        "alphas": tuple(float(a) for a in c.methods.alphas), "conditions": tuple(c.features.conditions),
        "gelsight_conditions": None if c.features.gelsight_conditions is None
        else tuple(c.features.gelsight_conditions),
        "seed": c.splits.seed, "max_iter": c.methods.max_iter, "n_jobs": c.compute.n_jobs,
        "methods": tuple(dict(spec) for spec in c.methods.compare),
    }


def deep_arguments(exp: Experiment) -> dict:
    """Keyword arguments of :func:`tzsl.experiments.deep.run_deep_fabric_study` (all but ``out``)."""
    c = exp.config
    return {
        "data_dir": exp.resolve(c.dataset.data_dir), "seeds": c.splits.n_seeds, "configs": tuple(c.splits.configs),
        "gelsight_root": exp.resolve(c.dataset.gelsight_root), "attributes": c.dataset.attributes,
        "progress": c.compute.progress, "lams": tuple(c.methods.embedding_lambdas),
        "gelsight_conditions": None if c.features.gelsight_conditions is None
        else tuple(c.features.gelsight_conditions),
        "seed": c.splits.seed, "model_params": dict(c.methods.model) or None,
        "save_model": exp.resolve(c.output.model),
    }


def hand_config(exp: Experiment):
    """The :class:`~tzsl.experiments.hand.HandStudyConfig` of a hand experiment."""
    from tzsl.experiments.hand import HandStudyConfig  # noqa: PLC0415

    c = exp.config
    values = {**c.simulation.model_dump(), **c.features.model_dump(),
              **{k: v for k, v in c.methods.model_dump().items() if k != "model"},
              "model_params": dict(c.methods.model), "n_jobs": c.compute.n_jobs}
    return HandStudyConfig(**values)


def active_config(exp: Experiment):
    """The :class:`~tzsl.experiments.active_touch.ActiveTouchConfig` of an active-touch experiment."""
    from tzsl.experiments.active_touch import ActiveTouchConfig  # noqa: PLC0415

    c = exp.config
    return ActiveTouchConfig(kinds=tuple(c.splits.kinds), n_splits=c.splits.n_splits, n_test=c.splits.n_test,
                             seed=c.splits.seed, thresholds=tuple(float(t) for t in c.methods.thresholds),
                             update=c.methods.update, cv=c.methods.cv, n_samples=c.methods.n_samples,
                             tempering=c.methods.tempering,
                             decided_thresholds=tuple(float(t) for t in c.methods.decided_thresholds),
                             n_boot=c.methods.n_boot, n_jobs=c.compute.n_jobs)


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
        raise ConfigError(f"{source}: compute.backend: 'dask' needs dask.distributed: pip install 'tzsl[dask]'") from None
    try:
        Client(address, timeout=f"{timeout}s", set_as_default=False).close()
    except Exception as exc:  # noqa: BLE001 - whatever answered there is not a working Dask scheduler
        _unreachable(source, address, timeout, f"no Dask handshake: {type(exc).__name__}")


def _unreachable(source: str, address: str, timeout: float, reason: str) -> None:
    raise ConfigError(f"{source}: compute.scheduler: cannot reach the Dask scheduler {address} within {timeout:g} s "
                      f"({reason.splitlines()[0]}); start it or raise compute.connect_timeout")


def _path_problems(exp: Experiment) -> list[str]:
    c = exp.config
    wanted: list[tuple[str, str | None, str]] = []
    ds = c.dataset
    for key in ("plain", "features", "path", "data_dir", "grasps", "table", "gelsight_root"):
        value = getattr(ds, key, None)
        wanted.append((f"dataset.{key}", value, "file" if key in ("features", "path", "table") else "folder"))
    if exp.study == "phac2-dap" and c.splits.kinds == ["file"]:
        split_file = c.splits.file if c.splits.file is not None else os.path.join(ds.plain, "splits.csv")
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
    if len(problems) == 1:  # one line, as linters print it
        raise ConfigError(problems[0])
    if problems:
        raise ConfigError(f"{exp.source}: {len(problems)} problem(s):\n" + "\n".join(problems))
    compute = exp.config.compute
    if getattr(compute, "backend", None) == "dask" and compute.scheduler is not None:
        _check_scheduler(compute.scheduler, compute.connect_timeout, exp.source)
    if exp.study == "fabric-deep":
        import importlib.util  # noqa: PLC0415

        if importlib.util.find_spec("torch") is None:
            raise ConfigError(f"{exp.source}: study fabric-deep needs torch: pip install 'tzsl[deep]'")


# --------------------------------------------------------------------------- running


@dataclass
class StudyRun:
    """What :func:`execute_study` returns: the tables written and what the manifest records."""

    tables: dict[str, pd.DataFrame]
    record: dict[str, Any]
    data_files: list = field(default_factory=list)

    @property
    def failures(self) -> list[str]:
        """One line per failed (split, method) fit, read from the tables' ``error`` columns."""
        return table_failures(self.tables)


def execute_study(exp: Experiment, results: ResultsDir, echo: Callable[[str], None] | None = None) -> StudyRun:
    """Run the study of ``exp`` into ``results`` (no manifest.json; see :func:`run_experiment`)."""
    from tzsl.experiments import study_runners  # noqa: PLC0415

    check_experiment(exp)
    say = echo or (lambda _msg: None)
    runner = {"phac2-dap": study_runners.run_phac2, "fabric": study_runners.run_fabric,
              "fabric-deep": study_runners.run_fabric_deep, "hand": study_runners.run_hand,
              "active-touch": study_runners.run_active_touch}[exp.study]
    return runner(exp, results, say)


def results_folder(exp: Experiment, force: bool) -> ResultsDir:
    """The (staged) results folder of ``exp`` (phac2-dap: leaving unselected fusion/prior columns out).

    Files are staged in the output folder's :data:`~tzsl.experiments._outputs.STAGING_FOLDER`
    and moved into place by :meth:`ResultsDir.commit` when the run completes, so a crashed run
    never blocks its rerun.
    """
    from tzsl.experiments import study_runners  # noqa: PLC0415

    folder = Path(exp.config.output.folder)
    if exp.study == "phac2-dap":
        results: ResultsDir = study_runners.SelectedColumns(
            folder, force, study_runners.dropped_columns(exp.config.methods), staging=True)
        results.check_free(study_runners.phac2_outputs(exp.config))
    else:
        results = ResultsDir(folder, force=force, staging=True)
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
    **overrides: Any,
) -> tuple[ResultsDir, StudyRun]:
    """Run an experiment file, a built-in study (by name) or a checked :class:`Experiment`.

    ``overrides``: ``out``, ``n_jobs``, ``seed``, ``backend``, ``scheduler``, ``progress``,
    ``data_dir`` (see :data:`OVERRIDES`; None = as in the file). Writes the study's tables and
    ``manifest.json`` (resolved settings, the file's text and checksum, data checksums, failures).

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
        study = _study_of(experiment)
        exp = load_experiment(experiment, override_values(study, overrides))
    say = echo or (lambda _msg: None)
    results = results_folder(exp, force)
    say(f"{exp.source}: study {exp.study} -> {results.final_root}")
    run = execute_study(exp, results, echo)  # checks the experiment (check_experiment) before any fit
    failures = run.failures  # one scan of the tables' error columns
    results.write_manifest(manifest_record(exp, run), data_files=run.data_files,
                           extra={"experiment_sha256": hashlib.sha256(exp.text.encode()).hexdigest(),
                                  "experiment_toml": exp.text, "description": exp.config.description,
                                  "tables": sorted(run.tables), "failures": failures})
    results.commit()
    if failures:
        error = PartialRunError(results.root, failures)
        error.results, error.run = results, run
        raise error
    return results, run


def _study_of(file_or_name) -> str | None:
    """The ``study`` of a file or built-in name, for mapping overrides (None when unreadable)."""
    try:
        return load_experiment(file_or_name).study
    except ConfigError:
        return None


def run(config_or_path: str | os.PathLike | Experiment, *, table: str | None = None, force: bool = False,
        echo: Callable[[str], None] | None = None, **overrides: Any) -> pd.DataFrame:
    """Run a study from Python and return its main table (notebooks).

    Parameters
    ----------
    config_or_path : path, built-in name or Experiment
        An experiment file, a built-in study (``"phac2-dap"``, ``"fabric"``, ``"hand-simulated"``,
        ...) or :func:`tzsl.experiments.config.load_experiment`'s result.
    table : str, optional
        Which table to return; default the study's main table (:data:`MAIN_TABLE`: Table 1 of
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
        results, done = exc.results, exc.run
    name = table or MAIN_TABLE[done.record["study_kind"]]
    if name not in done.tables:
        raise ConfigError(f"no table {name!r}; this run wrote {sorted(done.tables)}")
    out = done.tables[name].copy()
    out.attrs = {"results_dir": str(results.root), "tables": sorted(done.tables)}
    return out


def record_config(config) -> dict:
    """A dataclass config as a JSON-friendly dict (tuples as lists)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()}
