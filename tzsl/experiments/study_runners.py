"""One function per study kind: resolved settings -> the study's own call -> tables.

Called only by :func:`tzsl.experiments.engine.execute_study`; each returns a
:class:`~tzsl.experiments.study_settings.StudyRun` (tables written, manifest record, data files).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from tzsl._profile import timed
from tzsl.experiments._outputs import PrefixedResults, ResultsDir, prefixed
from tzsl.experiments.config import Experiment
from tzsl.experiments.study_settings import (
    StudyRun,
    active_config,
    dap_config,
    deep_arguments,
    fabric_arguments,
    gzsl_config,
    hand_config,
    record_config,
)


class SelectedColumns(ResultsDir):
    """A results folder that leaves unselected fusion / prior columns out of Tables 1 and 2."""

    def __init__(self, root, force: bool, drop: Mapping[str, list[str]], staging: bool = False) -> None:
        super().__init__(root, force=force, staging=staging)
        self.drop = dict(drop)

    def write_csv(self, name: str, table: pd.DataFrame, index: bool = False) -> Path:
        return super().write_csv(name, table.drop(columns=self.drop.get(name, []), errors="ignore"), index)


def dropped_columns(methods, prefix: str = "") -> dict[str, list[str]]:
    """Columns of Tables 1 and 2 that ``[methods] fusions`` / ``priors`` leave out, by file name
    (with the run's ``[output] prefix``)."""
    drop: dict[str, list[str]] = {"table1_fusion.csv": [], "table2_priors.csv": []}
    for fusion in sorted({"max", "avg"} - set(methods.fusions)):
        for column in [f"{fusion}dap"] + (["avgdap_per_class_mean"] if fusion == "avg" else []):
            drop["table1_fusion.csv"] += [column, f"{column}_ci95_low", f"{column}_ci95_high"]
        drop["table1_fusion.csv"].append(f"paper_{fusion}dap")
    for prior in sorted({"uni", "test", "train"} - set(methods.priors)):
        drop["table2_priors.csv"] += [prior, f"{prior}_ci95_low", f"{prior}_ci95_high", f"paper_{prior}"]
    return {prefixed(prefix, name): columns for name, columns in drop.items()}


def phac2_outputs(config) -> list[str]:
    """Files a zero-shot (or phac2-dap) run writes (checked free before any computation)."""
    from tzsl.experiments.phac2_spread import FUSION_PRIOR_TABLE, REFIT_TABLE  # noqa: PLC0415
    from tzsl.experiments.study_labels import StudyLabels, paper_protocol  # noqa: PLC0415

    labels = StudyLabels(paper=paper_protocol(config.study, config)[0])
    kinds, methods = config.splits.kinds, config.methods
    names = ["splits.csv", "failed_splits.csv", f"{FUSION_PRIOR_TABLE}.csv"]
    if config.splits.refit_seeds:
        names.append(f"{REFIT_TABLE}.csv")
    if "random" in kinds or "file" in kinds:
        names += ["table1_fusion.csv", "table2_priors.csv", "attribute_accuracy.csv",
                  "attribute_accuracy_per_split.csv", "attribute_accuracy.png"]
        if methods.multilabel:
            names.append("multilabel.csv")
        if methods.sweep:
            names += ["attribute_sweep.csv", "attribute_sweep.png"]
        if methods.method_specs():
            names += [f"{labels.methods_table}.csv", f"{labels.comparison_table}.csv", f"{labels.reliability_table}.csv",
                      f"{labels.reliability_table}.png"]
        if methods.gzsl:
            names.append("gzsl.csv")
    if "challenging" in kinds:
        names += ["table3_challenging.csv", "object_map.csv", "object_map.png"]
        if methods.method_specs() and "challenging" in methods.compare_on:
            names += [f"{labels.methods_table}.csv", f"{labels.comparison_table}.csv",
                      f"{labels.reliability_table}.csv", f"{labels.reliability_table}.png"]
    return ["manifest.json", *dict.fromkeys(prefixed(config.output.prefix, n) for n in names)]


@timed("load")
def phac2_features(exp: Experiment):
    """The FeatureSet of a phac2-dap experiment's ``[dataset]`` and ``[features]``."""
    ds, feat = exp.config.dataset, exp.config.features
    if ds.builtin is not None:
        from tzsl.experiments.extract import extract_features  # noqa: PLC0415

        return extract_features(ds.builtin, data_dir=exp.resolve(ds.data_dir), path=exp.resolve(ds.path),
                                min_objects=ds.min_objects)
    if ds.plain is not None:
        from tzsl.features import load_plain_dataset  # noqa: PLC0415

        folder = exp.resolve(ds.plain)
        compute = exp.config.compute  # signal files: read in n_jobs processes, cached with the fits
        features = load_plain_dataset(folder, statistics=feat.statistics, baseline_rows=feat.baseline_rows,
                                      channels=feat.channels, min_objects=ds.min_objects, n_jobs=compute.n_jobs,
                                      cache=compute.cache)
        features.info.setdefault("data_files", sorted(str(p) for p in Path(folder).rglob("*") if p.is_file()))
        return features
    from tzsl.experiments.sources import load_study_features  # noqa: PLC0415

    features = load_study_features(None, features_file=exp.resolve(ds.features))
    features.info.setdefault("data_files", [str(exp.resolve(ds.features))])
    return features


def _check_folds(exp: Experiment, n_train_objects: int) -> None:
    from tzsl.experiments.phac2_dap import check_cv_folds  # noqa: PLC0415

    check_cv_folds(exp.config.svm.cv, n_train_objects, exp.source)


def _format(table: pd.DataFrame) -> str:
    return table.to_string(index=False, float_format=lambda v: f"{v:.3f}", na_rep="-")


def prepare_phac2(exp: Experiment):
    """Load the dataset and the split file of a phac2-dap experiment and check the CV folds fit.

    Everything a phac2-dap run reads and draws before its first fit (``tzsl run --check`` calls
    it too): the random splits are drawn here, so a split that cannot be drawn is reported with
    the experiment file before any fit. Settings the dataset cannot honour are relaxed first
    (:func:`tzsl.experiments.relaxations.relax_to_dataset`). Returns ``(exp, features, splits or
    None, split_file or None, relaxations)``: the relaxed experiment, the file's splits (``kinds =
    ["file"]``), the random splits, or None (challenging only).
    """
    from tzsl.evaluation import read_splits_csv  # noqa: PLC0415
    from tzsl.exceptions import ConfigError, SplitError  # noqa: PLC0415
    from tzsl.experiments.phac2_dap import make_splits  # noqa: PLC0415

    from tzsl.experiments.relaxations import relax_to_dataset  # noqa: PLC0415

    features = phac2_features(exp)
    exp, relaxed = relax_to_dataset(exp, features)
    c = exp.config
    user_splits, split_file = None, None
    if c.splits.kinds == ["file"]:
        split_file = exp.resolve(c.splits.file) if c.splits.file is not None else (
            exp.resolve(c.dataset.plain) / "splits.csv")
        user_splits = read_splits_csv(split_file, features.attributes,
                                      min_train_positives=c.splits.random_min_train_positives)
        _check_folds(exp, min(len(s.train_objects) for s in user_splits))
    else:
        _check_folds(exp, features.n_objects - (c.splits.n_test if "random" in c.splits.kinds else 0))
        if "random" in c.splits.kinds:
            try:
                user_splits, _ = make_splits(features, "random", dap_config(exp))
            except SplitError as exc:
                raise ConfigError(f"{exp.source}: splits: {exc}") from None
    return exp, features, user_splits, split_file, relaxed


def run_zero_shot(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    """``study = "zero-shot"`` and its paper preset ``"phac2-dap"``: one study, labelled by
    :func:`~tzsl.experiments.study_labels.study_labels` (the paper's numbers only on its data)."""
    from tzsl.experiments.gzsl import GZSL_FILE, RELAXED_COLUMN, gzsl_config_record, run_gzsl  # noqa: PLC0415
    from tzsl.experiments.phac2_dap import make_splits, run_dap_study, solver_lines  # noqa: PLC0415
    from tzsl.experiments.phac2_tables import table_titles  # noqa: PLC0415
    from tzsl.experiments.study_labels import study_labels  # noqa: PLC0415

    study = exp.study
    exp, features, user_splits, split_file, relaxed = prepare_phac2(exp)
    c = exp.config
    config = dap_config(exp)
    labels = study_labels(study, c, features)
    say(f"{features.dataset}: {features.n_trials} trials, {features.n_objects} objects, "
        f"{len(features.sensors)} sensor(s), {features.X.shape[2]} features per sensor, "
        f"{features.attributes.shape[1]} attributes")
    notes = [labels.note] if labels.note else []
    notes += [f"relaxed {r.line()}" for r in relaxed]
    for note in notes:
        say(f"note: {note}")
    kinds = tuple(c.splits.kinds)
    methods = c.methods
    options = {"methods": methods.method_specs()}
    file_splits = user_splits if split_file is not None else None  # random ones are redrawn identically
    solver_record: dict = {}
    out = PrefixedResults(results, c.output.prefix)
    tables = run_dap_study(features, out, config, kinds=kinds, splits=file_splits, sweep=methods.sweep,
                           compare_methods=bool(options["methods"]), method_options=options,
                           record=solver_record, labels=labels)
    for text in solver_lines(solver_record["attribute_solver"]):
        say(text)
    gzsl_record, gzsl_notes = None, []
    if methods.gzsl:
        gzsl = gzsl_config(exp)
        splits = user_splits if user_splits is not None else make_splits(features, "random", config)[0]
        tables["gzsl"] = run_gzsl(features, splits, config, gzsl, echo=say)
        out.write_csv(GZSL_FILE, tables["gzsl"])
        gzsl_record = gzsl_config_record(gzsl)
        if RELAXED_COLUMN in tables["gzsl"].columns:
            gzsl_notes = [t for t in dict.fromkeys(tables["gzsl"][RELAXED_COLUMN].fillna("")) if t and t != "-"]
            for note in gzsl_notes:
                say(f"note: relaxed gzsl {note}")
    drop = getattr(results, "drop", {})
    shown = {name: t.drop(columns=drop.get(out.name(f"{name}.csv"), []), errors="ignore") for name, t in tables.items()}
    for name, title in table_titles(labels).items():
        if name in tables:
            say(f"\n{title}\n{_format(shown[name])}")
    record = {"study_kind": study, "phac2_dap": record_config(config), "kinds": list(kinds),
              "splits_file": None if split_file is None else str(split_file),
              "method_options": options, "labels": {"study": labels.study, "data": labels.data,
                                                    "paper": labels.paper, "note": labels.note},
              "relaxations": [r.record() for r in relaxed] + [{"setting": "gzsl", "why": n} for n in gzsl_notes],
              "gzsl": gzsl_record, "dataset": features.dataset, **solver_record}
    data_files = list(features.info.get("data_files", [])) + ([] if split_file is None else [split_file])
    return StudyRun(shown, record, data_files)


def run_fabric(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.experiments.fabric import format_fabric_table, run_fabric_study  # noqa: PLC0415

    kwargs = fabric_arguments(exp)
    tables = run_fabric_study(results, **kwargs)
    say("\nFabric Table 1 analogue - ours beside the paper's\n" + format_fabric_table(tables["table1"]))
    record = {k: (str(v) if isinstance(v, Path) else list(v) if isinstance(v, tuple) else v)
              for k, v in kwargs.items()}
    return StudyRun(dict(tables), {"study_kind": "fabric", "fabric": record})


def run_fabric_deep(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.experiments.deep import format_deep_table, run_deep_fabric_study  # noqa: PLC0415

    kwargs = deep_arguments(exp)
    tables = run_deep_fabric_study(results, **kwargs)
    say("\nFabric, CNN + LSTM over the lambda grid\n" + format_deep_table(tables["table"]))
    record = {k: (str(v) if isinstance(v, Path) else list(v) if isinstance(v, tuple) else v)
              for k, v in kwargs.items()}
    return StudyRun(dict(tables), {"study_kind": "fabric-deep", "fabric_deep": record})


def run_hand(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.datasets import load_hand_table4  # noqa: PLC0415
    from tzsl.experiments.hand import format_hand_summary, run_hand_study  # noqa: PLC0415

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


def run_active_touch(exp: Experiment, results: ResultsDir, say: Callable[[str], None]) -> StudyRun:
    from tzsl.experiments.active_touch import ACTIVE_TOUCH_OUTPUTS, run_active_touch_study  # noqa: PLC0415
    from tzsl.experiments.extract import extract_features  # noqa: PLC0415

    from tzsl.experiments.active_touch_hand import HAND_OUTPUTS, HandActiveConfig, run_active_hand  # noqa: PLC0415

    hand = exp.config.hand
    results.check_free(ACTIVE_TOUCH_OUTPUTS + (HAND_OUTPUTS if hand.simulated else ()))
    config = active_config(exp)
    ds = exp.config.dataset
    features = extract_features(ds.builtin, data_dir=exp.resolve(ds.data_dir))
    tables = run_active_touch_study(features, results, config, log=say if exp.config.compute.progress else None)
    stop = tables["active_touch_stop"]
    say("\nActive touch: accuracy after 1..4 EPs (95% intervals in active_touch.csv)\n"
        + _format(tables["active_touch"][["split_kind", "strategy", "acc_1ep", "acc_2ep", "acc_3ep", "acc_4ep",
                                          "acc_mean_over_seconds"]]))
    say("\nStopping rule vs all four EPs\n" + _format(stop[["split_kind", "strategy", "threshold", "accuracy",
                                                             "all_eps_accuracy", "difference", "mean_eps",
                                                             "mean_seconds"]]))
    dec = tables["active_touch_decided"]
    say("\nDoes the stopping rule keep its promise? Accuracy of the trials decided at t (active_touch_decided.csv)\n"
        + _format(dec[dec["strategy"] == "active"][["split_kind", "posterior", "threshold", "decided_share",
                                                     "decided_accuracy", "decided_accuracy_ci95_low",
                                                     "decided_accuracy_ci95_high", "eps_saved", "difference",
                                                     "active_minus_random"]]))
    record = {"study_kind": "active-touch", "active_touch": record_config(config), "dataset": features.dataset,
              "orders_chosen_on_training_objects": tables["active_touch_curves"].attrs["chosen"],
              "posterior_exponents_fitted_on_training_objects": tables["active_touch_curves"].attrs["exponents"]}
    if hand.simulated:
        from tzsl.datasets import load_hand_table4  # noqa: PLC0415

        hand_config = HandActiveConfig(seeds=tuple(hand.seeds), n_sequences=hand.n_sequences,
                                       max_grasps=hand.max_grasps, cv=hand.cv, n_samples=config.n_samples,
                                       thresholds=config.thresholds, n_boot=config.n_boot, n_jobs=config.n_jobs)
        hand_tables = run_active_hand(load_hand_table4(), results, hand_config,
                                      log=say if exp.config.compute.progress else None)
        say("\nActive touch on SIMULATED hand grasps: accuracy vs grasps, stopping rule\n"
            + _format(hand_tables["active_touch_hand_stop"].drop(columns=["data"])))
        tables.update(hand_tables)
        record["hand"] = {**record_config(hand_config), "hand_data": "simulated",
                          "grasp_type_share": hand_tables["active_touch_hand"].attrs["type_share"]}
    return StudyRun(tables, record, features.info.get("data_files", []))
