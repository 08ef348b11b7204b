"""The fabric studies' runners: ``study = "fabric"`` (embedding models) and ``"fabric-deep"`` (CNN + LSTM).

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from tzsl.studies._outputs import ResultsDir
from tzsl.studies.config import Experiment
from tzsl.studies.study_settings import StudyRun, deep_arguments, fabric_arguments

__all__ = ["run_fabric", "run_fabric_deep"]


def run_fabric(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.studies.fabric.study import format_fabric_table, run_fabric_study  # noqa: PLC0415

    kwargs = fabric_arguments(exp)
    tables = run_fabric_study(results, **kwargs)
    say("\nFabric Table 1 analogue - ours beside the paper's\n" + format_fabric_table(tables["table1"]))
    record = {k: (str(v) if isinstance(v, Path) else list(v) if isinstance(v, tuple) else v)
              for k, v in kwargs.items()}
    return StudyRun(dict(tables), {"study_kind": "fabric", "fabric": record})


def run_fabric_deep(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.studies.fabric.deep import format_deep_table, run_deep_fabric_study  # noqa: PLC0415

    kwargs = deep_arguments(exp)
    tables = run_deep_fabric_study(results, **kwargs)
    say("\nFabric, CNN + LSTM over the lambda grid\n" + format_deep_table(tables["table"]))
    record = {k: (str(v) if isinstance(v, Path) else list(v) if isinstance(v, tuple) else v)
              for k, v in kwargs.items()}
    return StudyRun(dict(tables), {"study_kind": "fabric-deep", "fabric_deep": record})
