"""What a study gets and gives: the resolved settings as the study's own arguments, and its result.

One converter per study kind turns a checked experiment (:mod:`tzsl.studies.config`) into the
call of its study (``fabric_arguments`` ... ``active_config``; the zero-shot study reads its
checked tables directly, :class:`~tzsl.studies.config.DapSettings`); :class:`StudyRun` is what every study
runner returns. Shared by the engine and the runners (so neither imports the other both ways).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from tzsl.studies._failures import table_failures
from tzsl.studies.config import Experiment

__all__ = ["StudyRun", "deep_arguments", "fabric_arguments", "format_table"]


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


def format_table(table: pd.DataFrame) -> str:
    """A table as the runners print it: no index, three decimals, ``-`` for NaN."""
    return table.to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-")
