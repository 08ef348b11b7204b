"""The active-touch study's runner: ``study = "active-touch"`` (PHAC-2 EPs; optionally SIMULATED hand grasps).

Registered in :mod:`tzsl.studies.config` (:func:`~tzsl.studies.config.register_study`).
"""

from __future__ import annotations

from collections.abc import Callable

from tzsl.studies.config import Experiment
from tzsl.studies.outputs.results_folder import ResultsDir
from tzsl.studies.outputs.study_run import StudyRun, format_table

__all__ = ["active_touch_outputs", "run_active_touch"]


def active_touch_outputs(config) -> list[str]:
    """Files an active-touch run writes (checked free before any computation)."""
    from tzsl.studies.active_touch.hand import HAND_OUTPUTS  # noqa: PLC0415
    from tzsl.studies.active_touch.study import ACTIVE_TOUCH_OUTPUTS  # noqa: PLC0415

    return ["manifest.json", *ACTIVE_TOUCH_OUTPUTS, *(HAND_OUTPUTS if config.hand.simulated else ())]


def run_active_touch(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.features import load_features  # noqa: PLC0415
    from tzsl.studies.active_touch.hand import run_active_hand  # noqa: PLC0415
    from tzsl.studies.active_touch.study import run_active_touch_study  # noqa: PLC0415

    hand = exp.config.hand
    results.check_free(active_touch_outputs(exp.config))
    config = exp.config
    ds = exp.config.dataset
    features = load_features(ds.builtin, data_dir=exp.resolve(ds.data_dir))
    tables = run_active_touch_study(features, results, config, log=say if exp.config.compute.progress else None)
    stop = tables["active_touch_stop"]
    say("\nActive touch: accuracy after 1..4 EPs (95% intervals in active_touch.csv)\n"
        + format_table(tables["active_touch"][["split_kind", "strategy", "acc_1ep", "acc_2ep", "acc_3ep", "acc_4ep",
                                               "acc_mean_over_seconds"]]))
    say("\nStopping rule vs all four EPs\n" + format_table(stop[["split_kind", "strategy", "threshold", "accuracy",
                                                                 "all_eps_accuracy", "difference", "mean_eps",
                                                                 "mean_seconds"]]))
    dec = tables["active_touch_decided"]
    say("\nDoes the stopping rule keep its promise? Accuracy of the trials decided at t (active_touch_decided.csv)\n"
        + format_table(dec[dec["strategy"] == "active"][["split_kind", "posterior", "threshold", "decided_share",
                                                         "decided_accuracy", "decided_accuracy_ci95_low",
                                                         "decided_accuracy_ci95_high", "eps_saved", "difference",
                                                         "active_minus_random"]]))
    record = {"study_kind": "active-touch", "purpose": exp.config.splits.purpose, "dataset": features.dataset,
              "orders_chosen_on_training_objects": tables["active_touch_curves"].attrs["chosen"],
              "posterior_exponents_fitted_on_training_objects": tables["active_touch_curves"].attrs["exponents"]}
    if hand.simulated:
        from tzsl.datasets import load_hand_table4  # noqa: PLC0415

        hand_tables = run_active_hand(load_hand_table4(), results, config,
                                      log=say if exp.config.compute.progress else None)
        say("\nActive touch on SIMULATED hand grasps: accuracy vs grasps, stopping rule\n"
            + format_table(hand_tables["active_touch_hand_stop"].drop(columns=["data"])))
        tables.update(hand_tables)
        record["hand"] = {"hand_data": "simulated",
                          "grasp_type_share": hand_tables["active_touch_hand"].attrs["type_share"]}
    return StudyRun(tables, record, features.info.get("data_files", []))
