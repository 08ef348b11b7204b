"""The hand study's runner: ``study = "hand"`` (the DAP paper's Shadow-hand grasps; SIMULATED from Table 4).

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`).
"""

from __future__ import annotations

from collections.abc import Callable

from tzsl.studies._outputs import ResultsDir
from tzsl.studies.config import Experiment
from tzsl.studies.study_settings import StudyRun, hand_config, record_config

__all__ = ["run_hand"]


def run_hand(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.datasets import load_hand_table4  # noqa: PLC0415
    from tzsl.studies.hand.study import format_hand_summary, run_hand_study  # noqa: PLC0415

    ds = exp.config.dataset
    config = hand_config(exp)
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
    record = {"study_kind": "hand", "hand": record_config(config), "seeds": list(seeds),
              "grasps": None if grasps is None else str(grasps), "table": ds.table}
    return StudyRun(tables, record, [] if grasps is None else [grasps / "grasps.csv"])
