"""What a study gets and gives: the resolved settings as the study's own arguments, and its result.

One converter per study kind turns a checked experiment (:mod:`tzsl.studies.config`) into the
call of its study (``dap_config`` ... ``active_config``); :class:`StudyRun` is what every study
runner returns. Shared by the engine and the runners (so neither imports the other both ways).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import pandas as pd

from tzsl.studies._failures import table_failures
from tzsl.studies.config import Experiment

__all__ = ["StudyRun", "active_config", "dap_config", "deep_arguments", "fabric_arguments", "format_table",
           "gzsl_config", "hand_config", "record_config"]


def _svm_params(svm) -> dict:
    """``[svm]`` -> :class:`~tzsl.models.AttributeSVM` parameters that differ from its defaults."""
    from tzsl.models import AttributeSVM  # noqa: PLC0415

    defaults = AttributeSVM().get_params()
    params: dict[str, Any] = {"cv": None if svm.cv == 0 else svm.cv}
    for key in ("C_range", "gamma_range", "n_C", "n_gamma", "grid", "n_draws", "scoring", "platt_weighting",
                "search"):
        value = getattr(svm, key)
        params[key] = tuple(float(v) for v in value) if key.endswith("_range") else value
    return {k: v for k, v in params.items() if v != defaults[k]}


def dap_config(exp: Experiment):
    """The :class:`~tzsl.studies.zero_shot.study.DapStudyConfig` of a phac2-dap experiment."""
    from tzsl.studies.zero_shot.study import DapStudyConfig  # noqa: PLC0415

    c = exp.config
    return DapStudyConfig(
        n_splits=c.splits.n_splits, n_test=c.splits.n_test, seed=c.splits.seed, purpose=c.splits.purpose,
        random_min_train_positives=c.splits.random_min_train_positives,
        challenging_min_train_positives=c.splits.challenging_min_train_positives,
        min_train_negatives=c.splits.min_train_negatives,
        undersampling=c.svm.undersampling, svm_params=_svm_params(c.svm), multilabel=c.methods.multilabel,
        solver=c.svm.solver, max_exact_trials=c.svm.max_exact_trials,
        sweep_min_attributes=c.methods.sweep_min_attributes, sweep_max_subsets=c.methods.sweep_max_subsets,
        compare_on=tuple(c.methods.compare_on), refit_seeds=c.splits.refit_seeds, refit_splits=c.splits.refit_splits,
        n_jobs=c.compute.n_jobs, backend=c.compute.backend, scheduler=c.compute.scheduler,
        progress=c.compute.progress, cache=c.compute.cache,
    )


def gzsl_config(exp: Experiment):
    """The :class:`~tzsl.studies.zero_shot.gzsl.GzslConfig` of a phac2-dap experiment's ``[gzsl]``."""
    from tzsl.studies.zero_shot.gzsl import GzslConfig  # noqa: PLC0415

    g = exp.config.gzsl
    return GzslConfig(holdout_fraction=float(g.holdout_fraction), methods=tuple(g.methods), fusion=g.fusion,
                      prior=g.prior, calibrated_stacking=g.calibrated_stacking, max_draws=g.max_draws)


def _fabric_data_arguments(exp: Experiment) -> dict:
    """The arguments both fabric studies (embedding and deep) take: data, groups, splits, lambdas."""
    c = exp.config
    return {
        "data_dir": exp.resolve(c.dataset.data_dir), "seeds": c.splits.n_seeds, "configs": tuple(c.splits.configs),
        "gelsight_root": exp.resolve(c.dataset.gelsight_root), "attributes": c.dataset.attributes,
        "progress": c.compute.progress, "lams": tuple(c.methods.embedding_lambdas),
        "gelsight_conditions": None if c.features.gelsight_conditions is None
        else tuple(c.features.gelsight_conditions),
        "seed": c.splits.seed,
    }


def fabric_arguments(exp: Experiment) -> dict:
    """Keyword arguments of :func:`tzsl.studies.fabric.study.run_fabric_study` (all but ``out``)."""
    c = exp.config
    return {
        **_fabric_data_arguments(exp),
        "alphas": tuple(float(a) for a in c.methods.alphas), "conditions": tuple(c.features.conditions),
        "max_iter": c.methods.max_iter, "n_jobs": c.compute.n_jobs,
        "methods": tuple(dict(spec) for spec in c.methods.compare),
        "partitions": c.partitions.model_dump(exclude={"enabled"}) if c.partitions.enabled else None,
    }


def deep_arguments(exp: Experiment) -> dict:
    """Keyword arguments of :func:`tzsl.studies.fabric.deep.run_deep_fabric_study` (all but ``out``)."""
    c = exp.config
    return {
        **_fabric_data_arguments(exp), "model_params": dict(c.methods.model) or None,
        "save_model": exp.resolve(c.output.model),
    }


def hand_config(exp: Experiment):
    """The :class:`~tzsl.studies.hand.study.HandStudyConfig` of a hand experiment."""
    from tzsl.studies.hand.study import HandStudyConfig  # noqa: PLC0415

    c = exp.config
    values = {**c.simulation.model_dump(), **c.features.model_dump(),
              **{k: v for k, v in c.methods.model_dump().items() if k != "model"},
              "model_params": dict(c.methods.model), "n_jobs": c.compute.n_jobs}
    return HandStudyConfig(**values)


def active_config(exp: Experiment):
    """The :class:`~tzsl.studies.active_touch.study.ActiveTouchConfig` of an active-touch experiment."""
    from tzsl.studies.active_touch.study import ActiveTouchConfig  # noqa: PLC0415

    c = exp.config
    return ActiveTouchConfig(kinds=tuple(c.splits.kinds), n_splits=c.splits.n_splits, n_test=c.splits.n_test,
                             seed=c.splits.seed, thresholds=tuple(float(t) for t in c.methods.thresholds),
                             update=c.methods.update, cv=c.methods.cv, n_samples=c.methods.n_samples,
                             tempering=c.methods.tempering,
                             decided_thresholds=tuple(float(t) for t in c.methods.decided_thresholds),
                             n_boot=c.methods.n_boot, n_jobs=c.compute.n_jobs)


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


def record_config(config) -> dict:
    """A dataclass config as a JSON-friendly dict (tuples as lists)."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()}


def format_table(table: pd.DataFrame) -> str:
    """A table as the runners print it: no index, three decimals, ``-`` for NaN."""
    return table.to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-")
