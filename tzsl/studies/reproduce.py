"""``tzsl reproduce-tables`` / ``make reproduce-tables``: the built-in studies of both papers, in order.

Not a second code path: each study is the built-in experiment file of the same name
(``tzsl/studies/builtin/``), run by :func:`tzsl.studies.engine.execute_study` exactly as
``tzsl run NAME`` runs it, into one results folder with one ``manifest.json``:

* ``phac2-dap``: ``table1_fusion.csv``, ``table2_priors.csv``, ``table3_challenging.csv``,
  ``multilabel.csv``, ``attribute_accuracy.csv``, ``attribute_sweep.csv``, ``phac2_methods.csv``
  and the figures ``attribute_accuracy.png``, ``object_map.png``, ``attribute_sweep.png``; every split
  scored in ``splits.csv`` (readable by ``--splits``);
* ``fabric``: ``fabric_table1.csv``, ``fabric_runs.csv``, ``fabric_lambda.png`` (+ its own manifest);
* ``hand-simulated``: ``hand_table5.csv`` and its curves, on **simulated** grasps (the
  Shadow-hand data of the paper are not public);
* ``active-touch``: ``active_touch.csv``, ``active_touch_curves.csv``, ``active_touch_stop.csv``
  and ``active_touch.png`` (choosing the next EP on PHAC-2 vs every fixed and a random order).
* ``method_comparison.csv``: the studies' ``*_method_comparison.csv`` stacked (every registered
  method x study: accuracy with its interval, the paper's number, fit time, paired difference to
  the study's paper method), with a row saying why for each method a study does not run.

The other built-in studies (``phac2-gzsl``, ``fabric-deep``) run with ``tzsl run NAME``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tzsl.exceptions import PartialRunError
from tzsl._profile import profiling
from tzsl._warnings import recorded_warnings
from tzsl.studies._outputs import ResultsDir

#: The manifest of ``reproduce-tables``: built-in studies, run in this order.
REPRODUCE_STUDIES: tuple[str, ...] = ("phac2-dap", "fabric", "hand-simulated", "active-touch")


def reproduce_experiments(studies=REPRODUCE_STUDIES, **overrides: Any) -> list:
    """The checked experiments of ``studies`` with the shared overrides (``n_jobs``, ``seed``, ...) applied
    to each study that has the key."""
    from tzsl.studies.config import load_experiment  # noqa: PLC0415
    from tzsl.studies.engine import override_values  # noqa: PLC0415

    experiments = []
    for name in studies:
        study = load_experiment(name).study
        experiments.append(load_experiment(name, override_values(study, overrides, strict=False)))
    return experiments


def reproduce_tables(
    out: str | Path,
    force: bool = False,
    echo: Callable[[str], None] | None = None,
    studies: tuple[str, ...] = REPRODUCE_STUDIES,
    **overrides: Any,
) -> ResultsDir:
    """Run the built-in ``studies`` into ``out``; returns the results folder.

    ``overrides``: ``n_jobs``, ``seed``, ``backend``, ``scheduler``, ``progress``, ``data_dir``
    (each applied to the studies that have the key).
    """
    from tzsl.studies.engine import check_experiment, execute_study, manifest_record  # noqa: PLC0415
    from tzsl.studies.config import get_study  # noqa: PLC0415

    say = echo or (lambda _msg: None)
    experiments = reproduce_experiments(studies, **overrides)
    results = ResultsDir(out, force=force, staging=True)
    for exp in experiments:
        check_experiment(exp)
        outputs = get_study(exp.study).hook("outputs")
        if outputs is not None:
            results.check_free(outputs(exp.config))
    results.check_free(["manifest.json", "method_comparison.csv"])
    records, data_files, timings, tables, done_tables, warned, profiles = {}, [], {}, [], [], {}, []
    failures: list[str] = []
    for name, exp in zip(studies, experiments, strict=True):
        say(f"\n== {name} ({exp.source}) ==")
        start = time.perf_counter()
        with recorded_warnings() as shown, profiling(name) as profile:
            done = execute_study(exp, results, echo)
        warned[name] = shown.lines
        done.record["profile"] = profile.rows()
        profiles += done.record["profile"]
        timings[f"{name}_s"] = time.perf_counter() - start
        records[name] = manifest_record(exp, done)
        data_files += list(done.data_files)
        tables += sorted(done.tables)
        failures += [f"{name}: {line}" for line in done.failures]
        done_tables += [t for key, t in done.tables.items() if key.endswith("method_comparison")]
    if done_tables:
        from tzsl.studies.study_methods import COMPARISON_FILE, FEW_CLASSES, combine_comparisons  # noqa: PLC0415

        dap = {name: FEW_CLASSES for name in ("dap-avg", "dap-max", "multilabel-dap")}
        results.write_csv(COMPARISON_FILE, combine_comparisons(done_tables, {"fabric": dap, "hand": dap}))
        tables.append(COMPARISON_FILE[: -len(".csv")])
    results.write_manifest({"studies": records}, data_files=data_files,
                           extra={"timings_s": timings, "tables": tables, "reproduce_studies": list(studies),
                                  "failures": failures, "warnings": warned, "profile": profiles})
    results.commit()
    if failures:
        raise PartialRunError(results.root, failures)
    return results
