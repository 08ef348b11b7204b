"""The fabric studies' runners: ``study = "fabric"`` (a preset of ``zero-shot``) and ``"fabric-deep"`` (CNN + LSTM).

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`).
``fabric`` runs the generic zero-shot study on the built-in ``fabric-depth`` dataset
(``[zero_shot]``, :mod:`tzsl.studies.zero_shot.preset`), then the fabric paper's protocol.
"""

from __future__ import annotations

from collections.abc import Callable

from tzsl.studies.config import Experiment
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.outputs.study_run import StudyRun
from tzsl.studies.zero_shot.preset import PresetHooks

__all__ = ["fabric_notes", "fabric_outputs", "fabric_results", "run_fabric", "run_fabric_deep"]


def _paper_outputs(config) -> list[str]:
    """Files the fabric paper protocol writes."""
    from tzsl.studies.fabric.methods import COMPARISON_TABLE  # noqa: PLC0415
    from tzsl.studies.fabric.study import FIGURE_FILE, PARTITIONS_FILE, RUNS_FILE, TABLE_FILE  # noqa: PLC0415

    return [TABLE_FILE, RUNS_FILE, FIGURE_FILE, f"{COMPARISON_TABLE}.csv"] + (
        [PARTITIONS_FILE] if config.partitions.enabled else [])


#: ``outputs``, ``results`` and ``notes`` of the ``fabric`` preset, as registered.
_HOOKS = PresetHooks(_paper_outputs)
fabric_outputs, fabric_results, fabric_notes = _HOOKS.outputs, _HOOKS.results, _HOOKS.notes


def run_fabric(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.studies.fabric.study import format_fabric_table, run_fabric_study  # noqa: PLC0415
    from tzsl.studies.zero_shot.preset import run_generic_part, with_generic_part  # noqa: PLC0415

    generic = run_generic_part(exp, results, say)
    c = exp.config
    record: dict = {"study_kind": "fabric"}
    tables = run_fabric_study(results, c, data_dir=exp.resolve(c.dataset.data_dir),
                              gelsight_root=exp.resolve(c.dataset.gelsight_root), record=record)
    say("\nFabric Table 1 analogue - ours beside the paper's\n" + format_fabric_table(tables["table1"]))
    return with_generic_part(StudyRun(dict(tables), record, record.pop("data_files")), generic)


def run_fabric_deep(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.studies.fabric.deep import format_deep_table, run_deep_fabric_study  # noqa: PLC0415

    c = exp.config
    record: dict = {"study_kind": "fabric-deep"}
    if c.dataset.builtin == "physiclear":
        from tzsl.studies.fabric.deep_physiclear import (  # noqa: PLC0415
            format_physiclear_deep_table,
            run_deep_physiclear_study,
        )

        tables = run_deep_physiclear_study(results, c, data_dir=exp.resolve(c.dataset.data_dir),
                                           save_model=exp.resolve(c.output.model), record=record)
        say("\nPhysiCLeAR unseen objects, CNN + LSTM over the lambda grid (fitted on the training objects; "
            "* = chosen on validation)\n" + format_physiclear_deep_table(tables["table"]))
        return StudyRun(dict(tables), record, record.pop("data_files"))
    tables = run_deep_fabric_study(results, c, data_dir=exp.resolve(c.dataset.data_dir),
                                   gelsight_root=exp.resolve(c.dataset.gelsight_root),
                                   save_model=exp.resolve(c.output.model), record=record)
    say("\nFabric, CNN + LSTM over the lambda grid\n" + format_deep_table(tables["table"]))
    return StudyRun(dict(tables), record, record.pop("data_files"))
