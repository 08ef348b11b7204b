"""The hand study's runner: ``study = "hand"``, a preset of ``zero-shot`` (the DAP paper's Shadow-hand
grasps; SIMULATED from Table 4).

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`). It runs
the generic zero-shot study on the built-in ``hand-simulated`` dataset (``[zero_shot]``,
:mod:`tzsl.studies.zero_shot.preset`), then the paper's protocol (Tables 4-5, multi-grasp).
"""

from __future__ import annotations

from collections.abc import Callable

from tzsl.studies.config import Experiment
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.outputs.study_run import StudyRun
from tzsl.studies.zero_shot.preset import PresetHooks

__all__ = ["hand_notes", "hand_outputs", "hand_results", "run_hand"]


def _paper_outputs(config) -> list[str]:
    from tzsl.studies.hand.study import HAND_OUTPUTS  # noqa: PLC0415

    return list(HAND_OUTPUTS)


#: ``outputs``, ``results`` and ``notes`` of the ``hand`` preset, as registered.
_HOOKS = PresetHooks(_paper_outputs)
hand_outputs, hand_results, hand_notes = _HOOKS.outputs, _HOOKS.results, _HOOKS.notes


def run_hand(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.datasets import load_hand_table4  # noqa: PLC0415
    from tzsl.studies.hand.study import format_hand_summary, run_hand_study  # noqa: PLC0415
    from tzsl.studies.zero_shot.preset import run_generic_part, with_generic_part  # noqa: PLC0415

    generic = run_generic_part(exp, results, say)
    ds = exp.config.dataset
    config = exp.config
    table = load_hand_table4(exp.resolve(ds.table))
    grasps = exp.resolve(ds.grasps)
    seeds = tuple(exp.config.splits.seeds)
    result = run_hand_study(grasps, table, results, seeds=seeds, config=config, force=results.force,
                            log=say if exp.config.compute.progress else None)
    if result.simulated:
        say("\nHand study on SIMULATED grasps (the paper's Shadow-hand data are not public)")
    say(format_hand_summary(result))
    tables = {name: getattr(result, name) for name in ("table5", "multigrasp_T", "multigrasp_k",
                                                       "attribute_accuracy", "attribute_distance", "confusion")}
    tables["hand_method_comparison"] = result.method_comparison
    record = {"study_kind": "hand", "seeds": list(seeds),
              "grasps": None if grasps is None else str(grasps), "table": ds.table, **result.record}
    return with_generic_part(StudyRun(tables, record, result.data_files), generic)
